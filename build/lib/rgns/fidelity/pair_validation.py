"""The learned simulator against the MPM on a Monte Carlo case's own paired realizations (the paper's Table 3).

The pairs are the realizations of one Monte Carlo case run by both routes: the MPM at the accurate mesh
(``high``) and the surrogate (``low``). They are a stratified sample of the case's N realizations: stratum s
(N_s realizations) contributes N_s / N of the weight, spread over its n_s pairs, so a weighted mean E_w over
the pairs estimates the mean over all N realizations, not over the (unevenly drawn) pairs. Per metric:

    R²            = 1 − E_w[(l − h)²] / Var_w(h)          Var_w(h) = E_w[(h − E_w[h])²]
    NRMSE         = sqrt(E_w[(l − h)²]) / (max h − min h over the pairs)
    bias          = E_w[l − h]
    relative bias = bias / E_w[h]

With equal weights these are :mod:`rgns.surrogates.validation`'s definitions (R² = 1 − SS_res / SS_tot, the
NRMSE normalised by the MPM's range over the pairs, the mean signed error surrogate minus MPM). The interval
is a percentile bootstrap that resamples pairs within each stratum (scipy.stats.bootstrap with one sample per
stratum, each stratum keeping its total weight), like the multi-fidelity correction's
(:func:`rgns.fidelity.multifidelity.stratified_bootstrap`), at Hesterberg's expanded level
(:func:`rgns.fidelity.multifidelity.expanded_level`) for the design's effective number of pairs
(:func:`effective_pairs`: n for one stratum of equal weights, fewer where a stratum of few pairs carries much
of the weight). Coverage of the population's R² and bias at 95 % nominal, 1000 replicates of pairs drawn
from the quartiles of l (h ~ N(10, 1), l = h + 0.2 + N(0, 0.4²), tests/fidelity/test_pair_validation.py):
4, 6, 10, 20 pairs 95.1 % and 94.6 % (at the expanded level for all n pairs: 92.4 %, 92.2 %); 3, 5, 8, 16
pairs 94.3 %, 93.0 % (90.3 %, 90.1 %); 2, 2, 4, 8 pairs 95.4 %, 91.9 % (86.8 %, 83.5 %).
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from rgns.fidelity.multifidelity import RESAMPLES, expanded_level
from rgns.surrogates.validation import METRICS

COLUMNS = tuple(stem for stem, _ in METRICS.values())  # runout_m, volume_m2, influence_m
STATISTICS = ("r2", "nrmse", "bias", "relative_bias")


class PairValidationError(ValueError):
    """Inputs that cannot make a pair validation."""


def weighted_statistics(high: np.ndarray, low: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """R², NRMSE, bias and relative bias of ``low`` against ``high`` along the last axis, ``weights`` summing
    to 1 along it → [..., 4] (NaN where undefined: h constant, or its weighted mean 0 for the relative bias)."""
    mean_h = (weights * high).sum(-1)
    error = low - high
    mse = (weights * error * error).sum(-1)
    var_h = (weights * (high - mean_h[..., None]) ** 2).sum(-1)
    spread = np.ptp(high, axis=-1)
    bias = (weights * error).sum(-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        r2 = np.where(var_h > 0, 1.0 - mse / var_h, np.nan)
        nrmse = np.where(spread > 0, np.sqrt(mse) / spread, np.nan)
        relative = np.where(mean_h != 0, bias / mean_h, np.nan)
    return np.stack([r2, nrmse, bias, relative], axis=-1)


def merged_strata(strata: np.ndarray) -> np.ndarray:
    """The stratum labels with every stratum of one pair merged into its neighbour (the next lower label,
    the next higher for the lowest), until each holds at least two pairs or one stratum is left: a stratum
    of one pair has nothing to resample, and its pair would enter every resample unchanged."""
    labels = np.asarray(strata).copy()
    while True:
        values, counts = np.unique(labels, return_counts=True)
        single = np.nonzero(counts == 1)[0]
        if values.size < 2 or single.size == 0:
            return labels
        k = int(single[0])
        labels[labels == values[k]] = values[k - 1] if k > 0 else values[k + 1]


def effective_pairs(weights: np.ndarray, members: list[np.ndarray]) -> float:
    """The number of pairs n* that sets the interval's level: 1 + the Welch–Satterthwaite degrees of
    freedom of the variance of a weighted mean sum_i w_i x_i estimated stratum by stratum (x of equal
    variance in every stratum): with a_s = sum over stratum s of w_i², df = (sum a_s)² / sum a_s² / (n_s − 1).
    n for one stratum of equal weights (Hesterberg's expanded level as it stands); fewer where a stratum
    of few pairs carries much of the weight, whose variance is then estimated from few pairs."""
    a = np.array([float((weights[index] ** 2).sum()) for index in members])
    sizes = np.array([index.size for index in members], dtype=float)
    return 1.0 + float(a.sum() ** 2 / (a**2 / (sizes - 1.0)).sum())


def _interval(
    high: np.ndarray,
    low: np.ndarray,
    weights: np.ndarray,
    strata: np.ndarray,
    confidence: float,
    resamples: int,
    seed: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The percentile bootstrap interval of :func:`weighted_statistics`: pairs resampled within each stratum
    (merged where one holds a single pair), each stratum keeping its total weight, at the expanded level for
    the design's :func:`effective_pairs` → lower and upper [4]."""
    labels = merged_strata(strata)
    members = [np.flatnonzero(labels == value) for value in np.unique(labels)]
    totals = [float(weights[index].sum()) for index in members]

    def statistic(*picks: np.ndarray, axis: int = -1) -> np.ndarray:
        parts = [pick.astype(int) for pick in picks]  # global pair indices, [..., n_s] each
        shares = [weights[part] / weights[part].sum(-1, keepdims=True) * total for part, total in zip(parts, totals)]
        pick = np.concatenate(parts, axis=-1)
        value = weighted_statistics(high[pick], low[pick], np.concatenate(shares, axis=-1))  # [..., 4]
        return np.moveaxis(value, -1, 0)  # the resamples last

    with warnings.catch_warnings():  # a statistic undefined on some resample: its interval is NaN (documented)
        warnings.simplefilter("ignore", stats.DegenerateDataWarning)
        boot = stats.bootstrap(
            tuple(index.astype(float) for index in members),
            statistic,
            paired=False,
            vectorized=True,
            n_resamples=resamples,
            confidence_level=expanded_level(confidence, round(effective_pairs(weights, members))),
            method="percentile",
            batch=max(1, 4_000_000 // max(1, len(high))),
            random_state=np.random.default_rng(seed),
        )
    return np.asarray(boot.confidence_interval.low), np.asarray(boot.confidence_interval.high)


def pair_validation(
    high: pd.DataFrame,
    low: pd.DataFrame,
    weights: np.ndarray,
    strata: np.ndarray,
    confidence: float = 0.95,
    resamples: int = RESAMPLES,
    seed: int = 0,
) -> dict[str, dict[str, Any]]:
    """R², NRMSE, bias and relative bias of the surrogate (``low``) against the MPM (``high``) on a Monte
    Carlo case's paired realizations, weighted by the design, each with its bootstrap interval.

    ``high`` and ``low``: the pairs, row for row the same realizations, with the columns runout_m,
    volume_m2 and influence_m (those of them present in both are validated); ``weights`` [n]: the pairs'
    design weights (positive; normalised to sum to 1); ``strata`` [n]: integer stratum labels. For each
    metric, the pairs with a non-finite value at either route (NaN: nothing moved) are left out of that
    metric and the weights of the rest renormalised to sum to 1 (each stratum keeping the share of its
    pairs that remain). NRMSE is normalised by the MPM's range over the metric's pairs, max h − min h, as
    in :func:`rgns.surrogates.validation.nrmse`. The interval resamples pairs within each stratum, a
    stratum of one pair merged into its neighbour (:func:`merged_strata`), at
    ``expanded_level(confidence, n*)`` with n* the design's :func:`effective_pairs` (n for one stratum of
    equal weights); it is widened to hold the point estimate where the bootstrap
    distribution does not, and is NaN where the statistic is undefined on the pairs or on some resample,
    or fewer than 3 pairs remain.

    Returns ``{metric: {"n": n, "r2": [point, lower, upper], "nrmse": [...], "bias": [...],
    "relative_bias": [...]}}`` (plain Python numbers; NaN where undefined), metrics in the order runout_m,
    volume_m2, influence_m."""
    weights = np.asarray(weights, dtype=float).ravel()
    strata = np.asarray(strata).ravel()
    n = len(high)
    if len(low) != n or weights.size != n or strata.size != n:
        raise PairValidationError(
            f"need as many rows of low ({len(low)}), weights ({weights.size}) and strata ({strata.size}) as of "
            f"high ({n})"
        )
    if not (np.isfinite(weights).all() and (weights > 0).all()):
        raise PairValidationError("the design weights must be positive and finite")
    if not 0.0 < confidence < 1.0:
        raise PairValidationError(f"confidence must lie in (0, 1), got {confidence}")
    columns = [column for column in COLUMNS if column in high.columns and column in low.columns]
    if not columns:
        raise PairValidationError(f"high and low share none of the columns {', '.join(COLUMNS)}")
    result: dict[str, dict[str, Any]] = {}
    for column in columns:
        h, lo = high[column].to_numpy(float), low[column].to_numpy(float)
        keep = np.isfinite(h) & np.isfinite(lo)
        h, lo, w, s = h[keep], lo[keep], weights[keep], strata[keep]
        count = int(keep.sum())
        entry: dict[str, Any] = {"n": count}
        if count == 0:
            result[column] = entry | {name: [math.nan] * 3 for name in STATISTICS}
            continue
        w = w / w.sum()
        point = weighted_statistics(h, lo, w)
        lower = upper = np.full(len(STATISTICS), np.nan)
        if count >= 3:
            lower, upper = _interval(h, lo, w, s, confidence, resamples, seed)
            defined = np.isfinite(point) & np.isfinite(lower) & np.isfinite(upper)
            lower = np.where(defined, np.minimum(lower, point), np.nan)  # a degenerate bootstrap: the point
            upper = np.where(defined, np.maximum(upper, point), np.nan)
        for k, name in enumerate(STATISTICS):
            entry[name] = [float(point[k]), float(lower[k]), float(upper[k])]
        result[column] = entry
    return result
