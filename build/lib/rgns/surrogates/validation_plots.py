"""Validation figures, the learned simulator (GNS or end-state surrogate) against MPM (matplotlib, Agg backend): one function per figure, each writes one PNG.

Only realizations whose GNS rollout is ok enter the figures, as in the statistics of
``rgns.surrogates.validation``.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from rgns.surrogates.validation import METRICS, ok_rows, r_squared  # noqa: E402

ENERGY_LABELS = ("$E_p / E_0$", "$E_k / E_0$", "$E_d / E_0$")
PICK_ORDER = ("best", "median", "worst")


def plot_histograms(pairs_by_case: dict[str, pd.DataFrame], path: str | Path, name: str = "GNS") -> None:
    """Overlaid MPM and learned-simulator (``name``) histograms with common bins: one row per case, one
    column per metric."""
    figure, axes = plt.subplots(
        len(pairs_by_case),
        len(METRICS),
        figsize=(4.0 * len(METRICS), 2.8 * len(pairs_by_case)),
        squeeze=False,
        constrained_layout=True,
    )
    for row, (case, pairs) in zip(axes, pairs_by_case.items()):
        ok = ok_rows(pairs)
        for axis, (stem, label) in zip(row, METRICS.values()):
            mpm, gns = ok[f"{stem}_mpm"].to_numpy(float), ok[f"{stem}_gns"].to_numpy(float)
            bins = np.histogram_bin_edges(np.concatenate([mpm, gns]), bins="auto")
            axis.hist(mpm, bins=bins, alpha=0.5, color="C0", label="MPM")
            axis.hist(gns, bins=bins, histtype="step", linewidth=1.5, color="C1", label=name)
            axis.set_xlabel(label)
        row[0].set_ylabel(f"{case}\ncount")
        row[0].legend(fontsize=8)
    figure.savefig(path, dpi=110)
    plt.close(figure)


def plot_parity(pairs_by_case: dict[str, pd.DataFrame], path: str | Path, name: str = "GNS") -> None:
    """The learned simulator (``name``) against MPM per metric, coloured by case, with the 1:1 line and
    R² per case."""
    figure, axes = plt.subplots(1, len(METRICS), figsize=(4.5 * len(METRICS), 4.3), constrained_layout=True)
    for axis, (stem, label) in zip(axes, METRICS.values()):
        low, high = np.inf, -np.inf
        for number, (case, pairs) in enumerate(pairs_by_case.items()):
            ok = ok_rows(pairs)
            mpm, gns = ok[f"{stem}_mpm"].to_numpy(float), ok[f"{stem}_gns"].to_numpy(float)
            axis.scatter(
                mpm, gns, s=10, color=f"C{number}", alpha=0.7, label=f"{case} (R² = {r_squared(mpm, gns):.3f})"
            )
            if mpm.size:
                low = min(low, mpm.min(), gns.min())
                high = max(high, mpm.max(), gns.max())
        if np.isfinite(low):
            axis.plot([low, high], [low, high], color="black", linewidth=0.8, label="1:1")
        axis.set_xlabel(f"MPM {label}")
        axis.set_ylabel(f"{name} {label}")
        axis.set_aspect("equal", adjustable="datalim")
        axis.legend(fontsize=8)
    figure.savefig(path, dpi=110)
    plt.close(figure)


def plot_energy_evolution(
    energies: dict, picks: dict[str, int], case: str, path: str | Path, name: str = "GNS"
) -> None:
    """Normalised Ep, Ek, Ed (rows) of the best, median and worst realization (columns): MPM vs the
    learned simulator ``name``: a curve, or only its start and end as points where it has no path
    between (the end-state surrogate: its energies are NaN there).

    ``energies`` holds ``time_s`` [T], ``index`` [B], ``mpm`` and ``gns`` [B, T, 3]; ``picks``
    maps "best"/"median"/"worst" to a realization ``index``.
    """
    figure, axes = plt.subplots(
        3, len(PICK_ORDER), figsize=(12, 8), sharex=True, squeeze=False, constrained_layout=True
    )
    time_s = np.asarray(energies["time_s"])
    for column, pick in enumerate(PICK_ORDER):
        matches = np.flatnonzero(np.asarray(energies["index"]) == picks[pick])
        if matches.size == 0:
            raise KeyError(f"{case}: realization {picks[pick]} ({pick}) has no energy history")
        row_number = int(matches[0])
        for component, label in enumerate(ENERGY_LABELS):
            axis = axes[component, column]
            axis.plot(time_s, energies["mpm"][row_number, :, component], "-", color="C0", label="MPM (true)")
            predicted = energies["gns"][row_number, :, component]
            known = np.isfinite(predicted)
            if known.all():
                axis.plot(time_s, predicted, "--", color="C1", label=f"{name} (pred)")
            elif known.any():  # the end-state surrogate: its start and end, no path between
                axis.plot(time_s[known], predicted[known], "o", color="C1", label=f"{name} (end state)")
            axis.set_ylabel(label)
        axes[0, column].set_title(f"{case} {pick}: realization {picks[pick]}")
        axes[-1, column].set_xlabel("time (s)")
    axes[0, 0].legend(fontsize=8)
    figure.savefig(path, dpi=110)
    plt.close(figure)
