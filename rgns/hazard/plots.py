"""Hazard figures (matplotlib, Agg backend): one function per figure, each writes one PNG."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Patch, Rectangle  # noqa: E402

from rgns.hazard.statistics import (  # noqa: E402
    ZONE_COLOURS,
    ZONE_LEVELS,
    AffectedProbability,
    ConvergenceTrace,
    ExceedanceCurve,
    ExceedanceDistance,
    check_thresholds,
    zone_range_labels,
    zones,
)


def _log_floor(n: int) -> float:
    """Display floor for probabilities on a log axis: half of the smallest non-zero value 1/n."""
    return 1.0 / (2.0 * n)


def _convergence_marker(axis: plt.Axes, trace: ConvergenceTrace) -> None:
    """Vertical line at the convergence size, or a note that the sample never converged."""
    rule = f"tolerance {trace.tolerance:g}, window {trace.window}"
    if trace.converged_at is not None:
        axis.axvline(
            trace.converged_at,
            color="black",
            linestyle="--",
            linewidth=0.8,
            label=f"converged at n = {trace.converged_at} ({rule})",
        )
    else:
        axis.text(
            0.98,
            0.95,
            f"not converged within {int(trace.n[-1])} ({rule})",
            transform=axis.transAxes,
            ha="right",
            va="top",
            fontsize=8,
            color="firebrick",
        )


def _fit_y_range(axis: plt.Axes, n: np.ndarray, centre: np.ndarray, low: np.ndarray, high: np.ndarray) -> None:
    """y range of the curve and band from n = max(10, N/50) on: the first bands (n = 2: a chi-square
    with one degree of freedom) are so wide that they would flatten the rest of the trace."""
    shown = n >= min(max(10, int(n[-1]) // 50), int(n[-1]))
    values = np.concatenate([centre[shown], low[shown], high[shown]])
    values = values[np.isfinite(values)]
    if values.size == 0:
        return
    bottom, top = float(values.min()), float(values.max())
    pad = 0.05 * (top - bottom) if top > bottom else max(0.05 * abs(top), 1.0)
    axis.set_ylim(bottom - pad, top + pad)


def plot_convergence(
    traces: dict[str, ConvergenceTrace], path: str | Path, units: dict[str, str] | None = None
) -> None:
    """Running mean and std of each metric against sample size, with their confidence bands.

    The y range shows n ≥ max(10, N/50); earlier, wider bands run off the panel.
    """
    units = units or {}
    figure, axes = plt.subplots(len(traces), 2, figsize=(11, 3.2 * len(traces)), squeeze=False, constrained_layout=True)
    for (name, trace), (mean_axis, std_axis) in zip(traces.items(), axes):
        unit = units.get(name, "m")
        for axis, centre, low, high, label in (
            (mean_axis, trace.mean, trace.mean_low, trace.mean_high, "running mean"),
            (std_axis, trace.std, trace.std_low, trace.std_high, "running std"),
        ):
            axis.fill_between(
                trace.n, low, high, color="tab:blue", alpha=0.25, linewidth=0, label=f"{trace.confidence:.0%} band"
            )
            axis.plot(trace.n, centre, color="tab:blue", linewidth=1.0, label=label)
            _fit_y_range(axis, trace.n, centre, low, high)
            _convergence_marker(axis, trace)
            axis.set_xlabel("number of realizations n")
            axis.set_ylabel(f"{label} ({unit})")
            axis.set_title(f"{name}: {label}", fontsize=9)
            axis.legend(fontsize=7, loc="lower right")
    figure.savefig(path, dpi=120)
    plt.close(figure)


def _mark_distances(axis: plt.Axes, distances: Sequence[ExceedanceDistance], n: int) -> None:
    """Dotted line at each probability; resolved distances as points with their CI, others noted."""
    for item in distances:
        axis.axhline(item.probability, color="grey", linestyle=":", linewidth=0.8)
        if not item.resolved:
            axis.text(
                0.98,
                item.probability,
                f"P = {item.probability:g}: < 1/n (n = {n})",
                transform=axis.get_yaxis_transform(),
                ha="right",
                va="bottom",
                fontsize=7,
            )
            continue
        low = item.distance_m - (item.lower_m if item.lower_m is not None else item.distance_m)
        high = (item.upper_m if item.upper_m is not None else item.distance_m) - item.distance_m
        axis.errorbar(
            [item.distance_m],
            [item.probability],
            xerr=[[low], [high]],
            fmt="o",
            color="black",
            markersize=4,
            capsize=3,
            linewidth=0.8,
        )
        axis.annotate(
            f"{item.distance_m:.1f} m",
            (item.distance_m, item.probability),
            textcoords="offset points",
            xytext=(4, 4),
            fontsize=7,
        )


def plot_exceedance(
    curves: dict[str, ExceedanceCurve],
    distances: dict[str, list[ExceedanceDistance]],
    deterministic_m: dict[str, float | None],
    path: str | Path,
) -> None:
    """P(X > x) of each metric on a log axis with Clopper–Pearson band, mean-field value and quantiles."""
    figure, axes = plt.subplots(
        1, len(curves), figsize=(5.5 * len(curves), 4.2), squeeze=False, constrained_layout=True
    )
    for (name, curve), axis in zip(curves.items(), axes[0]):
        floor = _log_floor(curve.n)
        axis.fill_between(
            curve.x,
            np.maximum(curve.lower, floor),
            np.maximum(curve.upper, floor),
            step="post",
            color="tab:blue",
            alpha=0.25,
            linewidth=0,
            label=f"{curve.confidence:.0%} Clopper–Pearson band",
        )
        axis.step(
            curve.x,
            np.maximum(curve.probability, floor),
            where="post",
            color="tab:blue",
            linewidth=1.2,
            label=f"empirical P(X > x), n = {curve.n}",
        )
        marks = distances.get(name, [])
        _mark_distances(axis, marks, curve.n)
        reference = deterministic_m.get(name)
        if reference is not None:
            axis.axvline(reference, color="black", linestyle="--", linewidth=1.0, label="mean-field")
        axis.set_yscale("log")
        axis.set_ylim(0.8 * min([floor, *(item.probability for item in marks)]), 1.5)
        axis.set_xlabel(f"{name} (m)")
        axis.set_ylabel("exceedance probability P(X > x)")
        axis.set_title(name, fontsize=9)
        axis.legend(fontsize=7, loc="lower left")
    figure.savefig(path, dpi=120)
    plt.close(figure)


def _zone_patches(
    axis: plt.Axes, x_m: np.ndarray, levels: np.ndarray, y_from_m: float, height_m: float, alpha: float
) -> None:
    """One coloured rectangle per zone between y_from_m and y_from_m + height_m."""
    for zone in zones(x_m, levels):
        colour = ZONE_COLOURS[ZONE_LEVELS.index(zone.level)]
        axis.add_patch(
            Rectangle(
                (zone.x_from_m, y_from_m),
                zone.x_to_m - zone.x_from_m,
                height_m,
                facecolor=colour,
                edgecolor="none",
                alpha=alpha,
            )
        )


def plot_zoning(
    vertices: np.ndarray,
    affected: AffectedProbability,
    levels: np.ndarray,
    thresholds: Sequence[float],
    domain_length_m: float,
    domain_height_m: float,
    path: str | Path,
) -> None:
    """Slope cross-section over the five hazard zones, and the affected probability below it."""
    limits = check_thresholds(thresholds)
    band_m = 0.08 * domain_height_m
    figure, (section, probability_axis) = plt.subplots(
        2,
        1,
        sharex=True,
        figsize=(10, 10 * (domain_height_m + band_m) / domain_length_m + 3.2),
        height_ratios=[(domain_height_m + band_m) / domain_length_m * 10, 2.4],
        constrained_layout=True,
    )
    _zone_patches(section, affected.x_m, levels, 0.0, domain_height_m, 0.15)
    _zone_patches(section, affected.x_m, levels, -band_m, band_m, 1.0)
    outline = np.vstack([vertices, vertices[:1]])
    section.fill(outline[:, 0], outline[:, 1], color="lightgrey", zorder=2)
    section.plot(outline[:, 0], outline[:, 1], color="black", linewidth=0.8, zorder=3)
    section.axhline(0.0, color="black", linewidth=0.8)
    section.set_xlim(0.0, domain_length_m)
    section.set_aspect("equal", adjustable="datalim")
    section.set_ylabel("y (m)")
    section.set_title(f"hazard zoning along the cross-section (n = {affected.n})", fontsize=9)
    section.legend(
        handles=[
            Patch(facecolor=colour, label=f"{level} ({label})")
            for colour, level, label in zip(ZONE_COLOURS, ZONE_LEVELS, zone_range_labels(limits))
        ],
        fontsize=7,
        loc="upper right",
    )
    floor = _log_floor(affected.n)
    probability_axis.fill_between(
        affected.x_m,
        np.maximum(affected.lower, floor),
        np.maximum(affected.upper, floor),
        color="tab:blue",
        alpha=0.25,
        linewidth=0,
        label=f"{affected.confidence:.0%} Clopper–Pearson band",
    )
    probability_axis.plot(
        affected.x_m,
        np.maximum(affected.probability, floor),
        color="tab:blue",
        linewidth=1.2,
        label="P(point affected)",
    )
    for limit in limits:
        probability_axis.axhline(limit, color="grey", linestyle=":", linewidth=0.8)
    probability_axis.set_yscale("log")
    probability_axis.set_ylim(0.8 * min(floor, limits[-1]), 1.5)
    probability_axis.set_xlabel("x (m)")
    probability_axis.set_ylabel("P(affected)")
    probability_axis.legend(fontsize=7, loc="lower left")
    figure.savefig(path, dpi=120)
    plt.close(figure)
