"""Multilevel Monte Carlo over a chain of fidelities on nested realizations, and the remaining mesh error.

Levels run from the finest (level 0: e.g. the MPM at 0.25 m) to the cheapest (level K: e.g. the
surrogate); level k runs the first n_k realizations, n_0 ≤ n_1 ≤ … ≤ n_K, so that the first n_{k-1}
of level k are the same realizations (same slope, same field) as level k - 1's. The estimator is
the multifidelity Monte Carlo one of Peherstorfer, Willcox & Gunzburger (2016, eq. 2.4):

    mu = mean_{n_0}(f_0) + sum_k alpha_k (mean_{n_k}(f_k) - mean_{n_{k-1}}(f_k)),
    alpha_k = cov(f_0, f_k) / var(f_k)  (over the n_0 realizations every level ran),

unbiased for the finest level's mean whatever the other levels' biases (up to the O(1/n_0) bias of
the estimated weights). With one cheap level it is :func:`rgns.fidelity.multifidelity.point_estimate`; with
every realization run at every level it is the finest level's plain mean. Its interval is a
bootstrap stratified over the nested blocks (realizations n_{j-1} … n_j - 1 form block j), so it
carries the uncertainty of every weight, at Hesterberg's expanded level for n_0 pairs.

The finest level is not the converged answer: with the two finest levels at cells h_0 = h_1 / r and
the observed order p of the mesh convergence, Richardson extrapolation puts the converged mean at
mu + (mean(f_0) - mean(f_1)) / (r^p - 1) over the realizations both ran. :func:`extrapolated`
estimates that step inside the same bootstrap, at the low and high ends of the order's interval as
well, and reports the envelope, so the interval holds sampling, every weight and the order's
uncertainty.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from rgns.fidelity.multifidelity import RESAMPLES, MultiFidelityError, design_weights, expanded_level


@dataclass
class MultilevelEstimate:
    """Per quantity: the estimate and its interval; per level its plain mean over its own runs, its
    weight and the correction it adds (level 0: none); the counts n_k; the confidence."""

    estimate: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    level_means: list[np.ndarray]
    weights: list[np.ndarray]
    corrections: list[np.ndarray]
    counts: list[int]
    confidence: float


def _checked(levels: list[np.ndarray]) -> list[np.ndarray]:
    """The levels as float arrays [n_k, Q], checked for nesting, shape and finiteness."""
    if len(levels) < 1:
        raise MultiFidelityError("need at least one level")
    arrays = [np.asarray(level, dtype=float) for level in levels]
    arrays = [a.reshape(len(a), -1) for a in arrays]
    counts = [len(a) for a in arrays]
    if counts[0] < 2:
        raise MultiFidelityError(f"the finest level needs at least 2 realizations, got {counts[0]}")
    if any(later < earlier for earlier, later in zip(counts, counts[1:])):
        raise MultiFidelityError(f"levels must run nested, ever more realizations from the finest: counts {counts}")
    if len({a.shape[1] for a in arrays}) != 1:
        raise MultiFidelityError(f"levels differ in their quantities: {[a.shape[1:] for a in arrays]}")
    for k, a in enumerate(arrays):
        if not np.isfinite(a).all():
            raise MultiFidelityError(f"level {k} holds NaN or infinity (a diverged run?)")
    return arrays


def _level_mean(level: np.ndarray, n0: int, weights: np.ndarray, axis: int) -> np.ndarray:
    """A level's mean over its own runs: weighted by design over the n0 pairs, plain over more."""
    if level.shape[axis] == n0:
        return (level * weights).sum(axis=axis)
    return level.mean(axis=axis)


def _weights(levels: list[np.ndarray], n0: int, axis: int, weights: np.ndarray) -> list[np.ndarray]:
    """cov(f_0, f_k) / var(f_k) over the first n0 realizations along ``axis`` (design-weighted); 1 where f_k
    does not vary."""
    first = np.take(levels[0], np.arange(n0), axis=axis)
    d0 = first - np.expand_dims((first * weights).sum(axis=axis), axis)
    result = []
    for level in levels[1:]:
        fk = np.take(level, np.arange(n0), axis=axis)
        dk = fk - np.expand_dims((fk * weights).sum(axis=axis), axis)
        var, cov = (weights * dk * dk).sum(axis=axis), (weights * d0 * dk).sum(axis=axis)
        result.append(np.divide(cov, var, out=np.ones_like(cov), where=var > 1e-12 * (1.0 + np.abs(cov))))
    return result


def mfmc_estimate(
    levels: list[np.ndarray], axis: int, weights: np.ndarray | None = None
) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray]]:
    """The estimate, the weights and each level's correction, the realizations along ``axis``; the pairs' (the
    finest level's n0) means weighted by their design ``weights`` (broadcast against the levels; None: equal)."""
    counts = [level.shape[axis] for level in levels]
    n0 = counts[0]
    if weights is None:
        weights = np.full([n0 if d == axis % levels[0].ndim else 1 for d in range(levels[0].ndim)], 1.0 / n0)
    alphas = _weights(levels, n0, axis, weights)
    estimate = _level_mean(levels[0], n0, weights, axis)
    corrections = []
    for k, (level, alpha) in enumerate(zip(levels[1:], alphas), start=1):
        previous = _level_mean(np.take(level, np.arange(counts[k - 1]), axis=axis), n0, weights, axis)
        corrections.append(alpha * (_level_mean(level, n0, weights, axis) - previous))
        estimate = estimate + corrections[-1]
    return estimate, alphas, corrections


def _blocks(counts: list[int], strata: np.ndarray | None) -> list[np.ndarray]:
    """Realization indices of each nested block that has any (block j holds n_{j-1} … n_j - 1), each cut by
    design stratum (``strata``: a label per realization of the cheapest level)."""
    edges = [0] + counts
    blocks = [np.arange(lo, hi) for lo, hi in zip(edges, edges[1:]) if hi > lo]
    if strata is None:
        return blocks
    return [block[strata[block] == s] for block in blocks for s in np.unique(strata[block])]


def _bootstrap(
    levels: list[np.ndarray],
    statistic_of,
    confidence: float,
    resamples: int,
    seed: int,
    strata: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Stratified percentile bootstrap of ``statistic_of(resampled levels, pair weights)`` over the nested blocks
    (and the design strata within them)."""
    counts = [len(level) for level in levels]
    blocks = _blocks(counts, strata)
    weights = design_weights(strata, counts[0])
    if any(len(block) < 2 for block in blocks if block[0] < counts[0]):
        raise MultiFidelityError("every design stratum needs at least 2 pairs to resample")
    singles = [len(block) < 2 for block in blocks]
    blocks = [np.repeat(block, 2) if single else block for block, single in zip(blocks, singles)]

    def statistic(*picks: np.ndarray, axis: int = -1) -> np.ndarray:
        order = np.concatenate([blocks[j][pick.astype(int)] for j, pick in enumerate(picks)], axis=-1)  # [B, N_K]
        resampled = [level[order[..., :count]] for level, count in zip(levels, counts)]  # [B, n_k, Q]
        return np.moveaxis(statistic_of(resampled, weights[order[..., : counts[0]]][..., None]), -1, 0)

    samples = tuple(np.arange(len(block)) for block in blocks)
    boot = stats.bootstrap(
        samples,
        statistic,
        paired=False,
        vectorized=True,
        n_resamples=resamples,
        confidence_level=expanded_level(confidence, counts[0]),
        method="percentile",
        batch=max(1, 4_000_000 // max(1, counts[-1] * levels[0].shape[1])),
        random_state=np.random.default_rng(seed),
    )
    return boot.confidence_interval


def _checked_strata(strata: np.ndarray | None, counts: list[int]) -> np.ndarray | None:
    """Design strata (a label per realization of the cheapest level) for levels whose counts are n0 or N only."""
    if strata is None:
        return None
    if any(count not in (counts[0], counts[-1]) for count in counts):
        raise MultiFidelityError(f"a stratified design needs every level at the pairs' count or all: counts {counts}")
    return np.asarray(strata)


def multilevel(
    levels: list[np.ndarray],
    confidence: float = 0.95,
    resamples: int = RESAMPLES,
    seed: int = 0,
    strata: np.ndarray | None = None,
) -> MultilevelEstimate:
    """The finest level's mean of each quantity from nested levels [n_k, ...], finest first; ``strata``: the
    design strata the finest level's realizations were drawn in (a label per realization of the cheapest level,
    as :func:`rgns.fidelity.multifidelity.control_variate`'s; every level at n0 or N realizations)."""
    if not 0.0 < confidence < 1.0:
        raise MultiFidelityError(f"confidence must lie in (0, 1), got {confidence}")
    shape = np.asarray(levels[0]).shape[1:]
    arrays = _checked(levels)
    counts = [len(a) for a in arrays]
    strata = _checked_strata(strata, counts)
    weights = design_weights(strata, counts[0])[:, None]
    estimate, alphas, corrections = mfmc_estimate(arrays, axis=0, weights=weights)
    lower, upper = _bootstrap(
        arrays, lambda r, w: mfmc_estimate(r, axis=-2, weights=w)[0], confidence, resamples, seed, strata
    )
    lower, upper = np.minimum(lower, estimate), np.maximum(upper, estimate)
    return MultilevelEstimate(
        estimate=estimate.reshape(shape),
        lower=np.asarray(lower).reshape(shape),
        upper=np.asarray(upper).reshape(shape),
        level_means=[_level_mean(a, counts[0], weights, 0).reshape(shape) for a in arrays],
        weights=[np.ones(shape)] + [w.reshape(shape) for w in alphas],
        corrections=[np.zeros(shape)] + [c.reshape(shape) for c in corrections],
        counts=counts,
        confidence=confidence,
    )


@dataclass
class Extrapolated:
    """The converged answer per quantity and its interval (sampling, weights and the order's
    interval), the Richardson step added to the finest level's estimate at the order's point value
    and at its interval's ends, and the finest level's own estimate. ``at_order``: the interval at the
    order's point value alone (sampling and weights: what coverage over replicates can check)."""

    estimate: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    at_order: tuple[np.ndarray, np.ndarray]
    mesh_error: np.ndarray
    mesh_error_range: tuple[np.ndarray, np.ndarray]
    order: float
    order_interval: tuple[float, float]
    finest: MultilevelEstimate


def richardson_step(fine: np.ndarray, coarse: np.ndarray, ratio: float, order: float | np.ndarray) -> np.ndarray:
    """What the finer of two meshes still misses: (fine - coarse) / (ratio^order - 1)."""
    return (np.asarray(fine) - np.asarray(coarse)) / (ratio**order - 1.0)


def extrapolated(
    levels: list[np.ndarray],
    ratio: float,
    order: float,
    order_interval: tuple[float, float],
    confidence: float = 0.95,
    resamples: int = RESAMPLES,
    seed: int = 0,
    strata: np.ndarray | None = None,
) -> Extrapolated:
    """The converged mean of each quantity: the multilevel estimate of ``levels`` (finest first; the
    first two are meshes whose cells differ by ``ratio``) plus the Richardson step of their paired
    means at the observed ``order`` (design-weighted with ``strata``, as :func:`multilevel`). The interval is the
    envelope of the bootstrap intervals at the order's point value and its interval's ends."""
    if len(levels) < 2 or ratio <= 1.0:
        raise MultiFidelityError(f"extrapolation needs two meshes, the coarser's cell larger (ratio {ratio})")
    low_order, high_order = order_interval
    if not 0.0 < low_order <= order <= high_order:
        raise MultiFidelityError(f"the order {order} must lie in its interval {order_interval}, above 0")
    finest = multilevel(levels, confidence, resamples, seed, strata)
    arrays = _checked(levels)
    orders = np.array([order, low_order, high_order])
    n0 = len(arrays[0])

    def statistic(resampled: list[np.ndarray], weights: np.ndarray) -> np.ndarray:
        estimate = mfmc_estimate(resampled, axis=-2, weights=weights)[0]
        step = richardson_step(
            (resampled[0] * weights).sum(axis=-2),
            (resampled[1][..., :n0, :] * weights).sum(axis=-2),
            ratio,
            orders[:, None, None],
        )  # [3, B, Q]
        return np.moveaxis(estimate[None] + step, 0, -2).reshape(*estimate.shape[:-1], -1)  # [B, 3 Q]

    lower, upper = _bootstrap(arrays, statistic, confidence, resamples, seed, strata)
    q = arrays[0].shape[1]
    w = design_weights(strata, n0)[:, None]
    steps = richardson_step((arrays[0] * w).sum(axis=0), (arrays[1][:n0] * w).sum(axis=0), ratio, orders[:, None])
    point = finest.estimate.reshape(-1) + steps[0]
    lower, upper = np.asarray(lower).reshape(3, q), np.asarray(upper).reshape(3, q)
    shape = finest.estimate.shape
    return Extrapolated(
        estimate=point.reshape(shape),
        lower=np.minimum(lower.min(axis=0), point).reshape(shape),
        upper=np.maximum(upper.max(axis=0), point).reshape(shape),
        at_order=(np.minimum(lower[0], point).reshape(shape), np.maximum(upper[0], point).reshape(shape)),
        mesh_error=steps[0].reshape(shape),
        mesh_error_range=(steps.min(axis=0).reshape(shape), steps.max(axis=0).reshape(shape)),
        order=order,
        order_interval=(low_order, high_order),
        finest=finest,
    )
