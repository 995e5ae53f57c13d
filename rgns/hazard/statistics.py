"""Monte Carlo statistics of per-realization runout metrics: convergence, exceedance, zoning.

Inputs are the metrics of the realizations that finished (diverged ones are dropped by the
caller), so arrays are NaN-free but may hold zeros (nothing failed). Every probability comes with
a distribution-free confidence band: Clopper–Pearson for probabilities, order statistics for
quantiles, so small samples show their uncertainty instead of hiding it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import stats

from rgns.hazard.exceedance import sample_distance

ZONE_LEVELS = ("extremely high", "high", "moderate", "low", "extremely low")
ZONE_COLOURS = ("red", "darkorange", "yellow", "lightgreen", "green")  # each level's, in figures, maps and the page
DEFAULT_THRESHOLDS = (0.9, 0.5, 0.1, 0.01)


def _sample(values: np.ndarray) -> np.ndarray:
    """The values as a non-empty 1-D float array without NaN (diverged runs are dropped before)."""
    array = np.asarray(values, dtype=float).ravel()
    if array.size == 0:
        raise ValueError("no realizations: the sample is empty")
    if not np.isfinite(array).all():
        raise ValueError(
            f"the sample holds {int((~np.isfinite(array)).sum())} non-finite values; drop diverged runs first"
        )
    return array


def _check_confidence(confidence: float) -> float:
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}")
    return float(confidence)


@dataclass
class ConvergenceTrace:
    """Running mean and standard deviation of a sample against its size, with 95 % bands."""

    n: np.ndarray
    mean: np.ndarray
    mean_low: np.ndarray
    mean_high: np.ndarray
    std: np.ndarray
    std_low: np.ndarray
    std_high: np.ndarray
    converged_at: int | None
    tolerance: float
    window: int
    criterion: str
    confidence: float = 0.95

    def to_frame(self) -> pd.DataFrame:
        """One row per sample size, for CSV."""
        return pd.DataFrame(
            {
                "n": self.n,
                "mean": self.mean,
                "mean_low": self.mean_low,
                "mean_high": self.mean_high,
                "std": self.std,
                "std_low": self.std_low,
                "std_high": self.std_high,
            }
        )


def running_moments(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Running mean and sample variance (ddof=1, NaN at n=1) of every prefix, vectorised.

    The mean is a cumulative sum of the values shifted by the first one (a constant prefix gives
    an exactly constant mean and zero variance). The sum of squares is Welford's
    M2_n = M2_(n-1) + (x_n - m_(n-1))(x_n - m_n) accumulated with cumsum: every increment is
    non-negative, so there is no cancellation for long samples or large offsets.
    """
    x = _sample(values)
    n = np.arange(1, x.size + 1, dtype=float)
    mean = x[0] + np.cumsum(x - x[0]) / n
    increments = np.zeros_like(x)
    increments[1:] = (x[1:] - mean[:-1]) * (x[1:] - mean[1:])
    with np.errstate(invalid="ignore", divide="ignore"):
        variance = np.cumsum(increments) / (n - 1.0)
    variance[0] = np.nan
    return mean, variance


def convergence_criterion(tolerance: float, window: int) -> str:
    """The sentence stating the convergence rule that :func:`convergence` applies."""
    return (
        f"converged at the first n from which, for {window} consecutive sample sizes, both the change "
        f"of the running mean |m_n - m_(n-1)| / s_n and the relative change of the running variance "
        f"|s²_n - s²_(n-1)| / s²_n stayed below {tolerance:g} (checks start at n = 3; "
        f"a zero standard deviation, i.e. a constant sample, counts as passing)"
    )


def convergence_checks(mean: np.ndarray, variance: np.ndarray, tolerance: float) -> np.ndarray:
    """Boolean [N]: whether the normalised changes at each n pass (False for n < 3)."""
    passed = np.zeros(mean.size, dtype=bool)
    if mean.size < 3:
        return passed
    std = np.sqrt(variance[2:])
    constant = std == 0.0
    with np.errstate(invalid="ignore", divide="ignore"):
        change_mean = np.abs(np.diff(mean)[1:]) / std
        change_variance = np.abs(np.diff(variance)[1:]) / variance[2:]
    change_mean[constant] = 0.0
    change_variance[constant] = 0.0
    passed[2:] = (change_mean < tolerance) & (change_variance < tolerance)
    return passed


def first_sustained(passed: np.ndarray, window: int) -> int | None:
    """Smallest index i with passed[i : i + window] all True (inside the array), else None."""
    if passed.size < window:
        return None
    totals = np.concatenate([[0], np.cumsum(passed, dtype=np.int64)])
    full = np.flatnonzero(totals[window:] - totals[:-window] == window)
    return int(full[0]) if full.size else None


def convergence(
    values: np.ndarray, tolerance: float = 1e-3, window: int = 100, confidence: float = 0.95
) -> ConvergenceTrace:
    """Running statistics of a Monte Carlo sample and the size from which they stopped moving.

    The paper's 1e-3 rule on absolute changes depends on units, so the changes are normalised by
    the running std (mean) and variance (variance), and must hold ``window`` times in a row so a
    single lucky draw does not declare convergence. The band of the mean is m ∓ z·s/√n (normal
    approximation); the band of the std is the chi-square interval (exact for normal data).
    """
    if tolerance <= 0.0:
        raise ValueError(f"tolerance must be positive, got {tolerance}")
    if window < 1:
        raise ValueError(f"window must be at least 1, got {window}")
    confidence = _check_confidence(confidence)
    mean, variance = running_moments(values)
    n = np.arange(1, mean.size + 1)
    alpha = 1.0 - confidence
    std = np.sqrt(variance)
    half_width = stats.norm.ppf(1.0 - alpha / 2.0) * std / np.sqrt(n)
    dof = np.maximum(n - 1, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        std_low = np.sqrt(dof * variance / stats.chi2.ppf(1.0 - alpha / 2.0, dof))
        std_high = np.sqrt(dof * variance / stats.chi2.ppf(alpha / 2.0, dof))
    start = first_sustained(convergence_checks(mean, variance, tolerance), window)
    return ConvergenceTrace(
        n=n,
        mean=mean,
        mean_low=mean - half_width,
        mean_high=mean + half_width,
        std=std,
        std_low=std_low,
        std_high=std_high,
        converged_at=None if start is None else int(n[start]),
        tolerance=float(tolerance),
        window=int(window),
        criterion=convergence_criterion(tolerance, window),
        confidence=confidence,
    )


def clopper_pearson(count: np.ndarray, n: int, confidence: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Exact (conservative) binomial bounds (lower, upper) of a probability seen count times in n."""
    confidence = _check_confidence(confidence)
    k = np.asarray(count, dtype=float)
    if n < 1 or np.any((k < 0) | (k > n)):
        raise ValueError(f"counts must lie in [0, n] with n >= 1 (n = {n})")
    alpha = 1.0 - confidence
    with np.errstate(invalid="ignore", divide="ignore"):
        lower = np.where(k > 0, stats.beta.ppf(alpha / 2.0, k, n - k + 1.0), 0.0)
        upper = np.where(k < n, stats.beta.ppf(1.0 - alpha / 2.0, k + 1.0, n - k), 1.0)
    return lower, upper


@dataclass
class ExceedanceCurve:
    """Empirical P(X > x) with pointwise Clopper–Pearson bounds."""

    x: np.ndarray
    probability: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    n: int
    confidence: float

    def to_frame(self) -> pd.DataFrame:
        """One row per evaluation point, for CSV."""
        return pd.DataFrame({"x": self.x, "probability": self.probability, "lower": self.lower, "upper": self.upper})


def exceedance_curve(values: np.ndarray, confidence: float = 0.95, x: np.ndarray | None = None) -> ExceedanceCurve:
    """P(X > x) = count(X > x) / n at the sorted unique sample values and 0, or at ``x`` if given."""
    sample = np.sort(_sample(values))
    where = np.unique(np.concatenate([[0.0], sample])) if x is None else np.asarray(x, dtype=float).ravel()
    count = sample.size - np.searchsorted(sample, where, side="right")
    lower, upper = clopper_pearson(count, sample.size, confidence)
    return ExceedanceCurve(
        x=where,
        probability=count / sample.size,
        lower=lower,
        upper=upper,
        n=int(sample.size),
        confidence=float(confidence),
    )


@dataclass
class ExceedanceDistance:
    """The distance exceeded with a given probability, or why it cannot be given."""

    probability: float
    distance_m: float | None
    lower_m: float | None
    upper_m: float | None
    resolved: bool
    note: str


def realizations_needed(probability: float) -> int:
    """Smallest n with n·p ≥ 1: at least one realization expected beyond the quantile."""
    return math.ceil(1.0 / probability - 1e-9)


def quantile_interval(
    sample_sorted: np.ndarray, quantile: float, confidence: float
) -> tuple[float | None, float | None]:
    """Distribution-free CI (lower, upper) of a quantile from order statistics.

    The number of values at or below the q-quantile is Binomial(n, q); with l = binom.ppf(α/2) and
    u = binom.ppf(1 − α/2) + 1, P(X_(l) ≤ ξ_q < X_(u)) ≥ 1 − α (1-based order statistics,
    continuous distribution). A bound is None when its order statistic falls outside 1..n.
    """
    n = sample_sorted.size
    alpha = 1.0 - confidence
    low_rank = int(stats.binom.ppf(alpha / 2.0, n, quantile))
    high_rank = int(stats.binom.ppf(1.0 - alpha / 2.0, n, quantile)) + 1
    lower = float(sample_sorted[low_rank - 1]) if 1 <= low_rank <= n else None
    upper = float(sample_sorted[high_rank - 1]) if 1 <= high_rank <= n else None
    return lower, upper


def exceedance_distances(
    values: np.ndarray, probabilities: Sequence[float] = (0.5, 0.1, 0.01), confidence: float = 0.95
) -> list[ExceedanceDistance]:
    """Distances exceeded with each probability p: where the sample's exceedance curve falls to p
    (:func:`rgns.hazard.exceedance.sample_distance`, the estimator every route reads), with the order
    statistics' distribution-free interval of the (1 − p) quantile.

    A probability with n·p < 1 is left unresolved: fewer than one realization is expected beyond
    it, so it can only be reported as "< 1/n", never as a number.
    """
    confidence = _check_confidence(confidence)
    sample = np.sort(_sample(values))
    n = sample.size
    results = []
    for p in probabilities:
        if not 0.0 < p < 1.0:
            raise ValueError(f"exceedance probabilities must lie in (0, 1), got {p}")
        needed = realizations_needed(p)
        if n < needed:
            results.append(
                ExceedanceDistance(float(p), None, None, None, False, f"needs at least {needed} realizations (n = {n})")
            )
            continue
        lower, upper = quantile_interval(sample, 1.0 - p, confidence)
        missing = [name for name, bound in (("lower", lower), ("upper", upper)) if bound is None]
        note = f"empirical exceedance curve's crossing of {p:g} (linear between the sample's values) of n = {n}"
        if missing:
            note += f"; {' and '.join(missing)} {confidence:.0%} bound needs more realizations"
        results.append(ExceedanceDistance(float(p), sample_distance(sample, p), lower, upper, True, note))
    return results


@dataclass
class AffectedProbability:
    """Probability that each point of the cross-section lies in a realization's affected interval."""

    x_m: np.ndarray
    probability: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    n: int
    confidence: float = 0.95

    def to_frame(self, levels: np.ndarray | None = None) -> pd.DataFrame:
        """One row per point, for CSV; with ``levels`` (from :func:`zone_levels`) a ``level`` column."""
        frame = pd.DataFrame(
            {"x_m": self.x_m, "probability": self.probability, "lower": self.lower, "upper": self.upper}
        )
        if levels is not None:
            frame["level"] = [ZONE_LEVELS[int(level)] for level in levels]
        return frame


def affected_probability(
    x_m: np.ndarray, rear_x_m: np.ndarray, front_x_m: np.ndarray, confidence: float = 0.95
) -> AffectedProbability:
    """Fraction of realizations with rear_x ≤ x ≤ front_x at each x, with Clopper–Pearson bounds.

    A realization with nothing displaced has rear = front = NaN: it counts in n but affects no x.
    """
    rear = np.asarray(rear_x_m, dtype=float).ravel()
    front = np.asarray(front_x_m, dtype=float).ravel()
    if rear.shape != front.shape or rear.size == 0:
        raise ValueError(f"rear and front need the same non-zero length, got {rear.size} and {front.size}")
    empty = np.isnan(rear)
    if not np.array_equal(empty, np.isnan(front)):
        raise ValueError("a realization has exactly one of rear and front NaN; give both or neither")
    if np.any(rear[~empty] > front[~empty]):
        raise ValueError(f"{int((rear[~empty] > front[~empty]).sum())} realizations have rear_x > front_x")
    points = np.asarray(x_m, dtype=float).ravel()
    rear_sorted, front_sorted = np.sort(rear[~empty]), np.sort(front[~empty])
    # rear <= front, so every interval already ended before x also started before x.
    count = np.searchsorted(rear_sorted, points, side="right") - np.searchsorted(front_sorted, points, side="left")
    lower, upper = clopper_pearson(count, rear.size, confidence)
    return AffectedProbability(
        x_m=points,
        probability=count / rear.size,
        lower=lower,
        upper=upper,
        n=int(rear.size),
        confidence=float(confidence),
    )


def check_thresholds(thresholds: Sequence[float]) -> np.ndarray:
    """The four zoning thresholds as an array; ValueError unless strictly decreasing in (0, 1)."""
    array = np.asarray(thresholds, dtype=float).ravel()
    if array.size != len(ZONE_LEVELS) - 1 or np.any((array <= 0.0) | (array >= 1.0)) or np.any(np.diff(array) >= 0.0):
        raise ValueError(
            f"zoning thresholds {list(thresholds)} must be {len(ZONE_LEVELS) - 1} probabilities "
            f"strictly decreasing in (0, 1), e.g. {list(DEFAULT_THRESHOLDS)}"
        )
    return array


def zone_levels(probability: np.ndarray, thresholds: Sequence[float] = DEFAULT_THRESHOLDS) -> np.ndarray:
    """Zone index per point, 0 = extremely high ... 4 = extremely low; a threshold belongs to the higher zone."""
    limits = check_thresholds(thresholds)
    p = np.asarray(probability, dtype=float)
    if np.isnan(p).any():
        raise ValueError("probabilities contain NaN")
    return (p[..., None] < limits).sum(axis=-1)


def zone_range_labels(thresholds: Sequence[float] = DEFAULT_THRESHOLDS) -> list[str]:
    """The probability range of each zone, e.g. "0.5 ≤ P < 0.9", in ZONE_LEVELS order."""
    limits = check_thresholds(thresholds)
    middle = [f"{low:g} ≤ P < {high:g}" for high, low in zip(limits[:-1], limits[1:])]
    return [f"P ≥ {limits[0]:g}", *middle, f"P < {limits[-1]:g}"]


@dataclass
class Zone:
    """A stretch of the cross-section with one hazard level."""

    level: str
    x_from_m: float
    x_to_m: float


def zones(x_m: np.ndarray, levels: np.ndarray) -> list[Zone]:
    """Contiguous runs of one level, in x order.

    Edges between runs lie midway between the neighbouring points of different level; the outer
    edges are the first and last x, so the zones tile [min x, max x] without gaps.
    """
    x = np.asarray(x_m, dtype=float).ravel()
    level = np.asarray(levels).ravel()
    if x.size != level.size or x.size == 0:
        raise ValueError(f"x and levels need the same non-zero length, got {x.size} and {level.size}")
    order = np.argsort(x, kind="stable")
    x, level = x[order], level[order]
    changes = np.flatnonzero(level[1:] != level[:-1]) + 1
    starts = np.concatenate([[0], changes])
    edges = np.concatenate([[x[0]], 0.5 * (x[changes - 1] + x[changes]), [x[-1]]])
    return [
        Zone(ZONE_LEVELS[int(level[start])], float(edges[k]), float(edges[k + 1])) for k, start in enumerate(starts)
    ]
