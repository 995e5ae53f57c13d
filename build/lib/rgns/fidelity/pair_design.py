"""Which Monte Carlo realizations the MPM re-runs: pairs stratified on the cheap route's runout.

With every realization's cheap answer in hand, the realizations are cut into strata at quantiles of
the cheap runout (``edges``, e.g. the median, the 90th and the 99th percentile) and each stratum gets
pairs drawn at random within it: Neyman's allocation on the cheap runout's spread in the stratum (n_s ∝
N_s σ_s), at least ``min_per_stratum``. The tail strata, few realizations with a wide spread, so get far
more pairs than their share, and the distances exceeded with a low probability rest on pairs that reach
them. Drawn at random within a stratum, a pair of stratum s stands for N_s / N of the realizations shared
by its n_s pairs (:func:`rgns.fidelity.multifidelity.design_weights`), which keeps every estimator of the
correction unbiased for the accurate MPM (stratified sampling: Cochran 1977, ch. 5), whatever the cheap
route's errors. With ``edges`` empty it is a simple random subsample.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from rgns.fidelity.multifidelity import MultiFidelityError


@dataclass
class PairDesign:
    """The pairs' realization indices (by stratum, then index), every realization's stratum (by index, over
    ``realizations``), the strata's runout bounds of the cheap route, their sizes and pairs."""

    indices: list[int]
    realizations: list[int]
    strata: list[int]
    bounds_m: list[list[float]]
    sizes: list[int]
    pairs: list[int]

    def to_record(self) -> dict[str, Any]:
        return asdict(self)


def allocate_pairs(sizes: np.ndarray, spreads: np.ndarray, total: int, floor: int) -> np.ndarray:
    """Neyman allocation of ``total`` pairs over strata of ``sizes`` and cheap-runout ``spreads``: n_s ∝ N_s σ_s,
    at least ``floor`` (or N_s) each, at most N_s, summing to ``total`` (largest remainders)."""
    sizes = np.asarray(sizes, dtype=int)
    least = np.minimum(sizes, floor)
    if least.sum() > total:
        raise MultiFidelityError(
            f"montecarlo.fidelity.paired = {total}: {len(sizes)} strata need at least {int(least.sum())} pairs "
            f"({floor} each)"
        )
    if total > sizes.sum():
        raise MultiFidelityError(f"montecarlo.fidelity.paired = {total}: more than the {int(sizes.sum())} realizations")
    pairs = least.copy()
    share = sizes * np.maximum(np.asarray(spreads, dtype=float), 1e-12)
    while pairs.sum() < total:
        room = pairs < sizes
        wanted = np.where(room, share, 0.0)
        ideal = wanted / wanted.sum() * total
        gap = np.where(room, ideal - pairs, -np.inf)
        pairs[int(np.argmax(gap))] += 1
    return pairs


def design_pairs(
    index: np.ndarray, runout_m: np.ndarray, total: int, edges: list[float], floor: int, seed: int
) -> PairDesign:
    """Strata at the ``edges`` quantiles of the cheap runout (a realization whose runout is not finite — nothing
    moved — counts as the lowest), pairs allocated by :func:`allocate_pairs` and drawn at random within each."""
    index = np.asarray(index, dtype=int)
    runout = np.nan_to_num(np.asarray(runout_m, dtype=float), nan=-np.inf)
    if sorted(edges) != list(edges) or any(not 0.0 < q < 1.0 for q in edges):
        raise MultiFidelityError(f"montecarlo.fidelity.strata = {edges}: increasing quantiles inside (0, 1)")
    finite = runout[np.isfinite(runout)]
    cuts = np.quantile(finite, edges) if finite.size else np.zeros(len(edges))
    strata = np.searchsorted(cuts, runout, side="right")  # stratum s: cuts[s-1] < R ≤ cuts[s]
    labels = np.unique(strata)
    sizes = np.array([np.count_nonzero(strata == s) for s in labels])
    spreads = np.array([np.std(np.where(np.isfinite(runout[strata == s]), runout[strata == s], 0.0)) for s in labels])
    pairs = allocate_pairs(sizes, spreads, total, min(floor, max(2, total // len(labels))))
    rng = np.random.default_rng(seed)
    chosen: list[int] = []
    bounds = []
    for s, count in zip(labels, pairs):
        members = index[strata == s]
        chosen += sorted(rng.choice(members, size=int(count), replace=False).tolist())
        values = runout[strata == s]
        values = values[np.isfinite(values)]
        bounds.append([float(values.min()), float(values.max())] if values.size else [float("nan")] * 2)
    relabel = {int(s): k for k, s in enumerate(labels)}
    return PairDesign(
        indices=[int(i) for i in chosen],
        realizations=index.tolist(),
        strata=[relabel[int(s)] for s in strata],
        bounds_m=bounds,
        sizes=sizes.tolist(),
        pairs=pairs.tolist(),
    )


def row_strata(design: dict[str, Any] | None, indices: list[int], n: int) -> np.ndarray | None:
    """The design stratum of each of ``indices`` (the correction's rows, its n pairs first), a stratum left with
    fewer than 2 finished pairs merged into a neighbour (:func:`merge_thin_strata`); None without a design (a
    simple random subsample)."""
    if design is None:
        return None
    of = dict(zip(design["realizations"], design["strata"]))
    return merge_thin_strata(np.array([of[i] for i in indices]), n)


def merge_thin_strata(labels: np.ndarray, n: int) -> np.ndarray:
    """Stratum labels (a label per row, pairs first) with every stratum that holds fewer than 2 of the n pairs
    (a pair lost to a failed run) merged into a neighbour, so that each can be resampled and weighed."""
    labels = np.asarray(labels).copy()
    while True:
        present = np.unique(labels)
        counts = {int(s): int(np.count_nonzero(labels[:n] == s)) for s in present}
        thin = [s for s in present if counts[int(s)] < 2]
        if not thin or len(present) == 1:
            return labels
        s = int(thin[0])
        others = [int(t) for t in present if t != s]
        target = max((t for t in others if t < s), default=min(others))
        labels[labels == s] = target
