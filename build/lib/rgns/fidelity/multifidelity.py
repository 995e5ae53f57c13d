"""Multi-fidelity Monte Carlo: many cheap realizations, a few of them also run accurately.

The control-variate estimator of Peherstorfer, Willcox & Gunzburger (2016, "Optimal model
management for multifidelity Monte Carlo estimation") for two models: with the high-fidelity
values ``h`` of the first n realizations and the low-fidelity values ``l`` of all N (the first n
paired with ``h``, same realization, same field),

    mu = mean(h) + alpha * (mean(l over N) - mean(l over n)),   alpha = cov(h, l) / var(l)

is unbiased for the high-fidelity mean whatever the low-fidelity model's bias (up to the O(1/n)
bias of the estimated weight), with a variance that falls with the correlation of the two. The
interval is a stratified bootstrap (scipy.stats.bootstrap over the paired and the unpaired
realizations, at Hesterberg's expanded percentile level for a few tens of pairs), so it carries
the uncertainty of the weight. Every quantity is a mean: an exceedance probability is the mean of
an indicator 1[R > r]. For those, :func:`regression_control_variate` uses the cheap route's
predicted probability P(h > r | l) as the control variate instead of its own indicator 1[l > r],
which correlates poorly with 1[h > r] wherever the two routes put a realization on different
sides of r.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy import special, stats

RESAMPLES = 2000


class MultiFidelityError(ValueError):
    """Inputs that cannot make a multi-fidelity estimate."""


@dataclass
class ControlVariateEstimate:
    """Per quantity (arrays of the quantities' shape): the corrected estimate and its interval,
    the plain high-fidelity mean of the pairs, the plain low-fidelity mean of all N, the weight,
    the paired correlation and the estimated bias of the cheap route (low minus high over the pairs)."""

    estimate: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    high_mean: np.ndarray
    low_mean: np.ndarray
    weight: np.ndarray
    correlation: np.ndarray
    bias: np.ndarray
    n_paired: int
    n_low: int
    confidence: float


def expanded_level(confidence: float, n: int) -> float:
    """The percentile bootstrap's level that makes a ``confidence`` interval from n pairs: Hesterberg's
    expanded percentile interval (2015, "What teachers should know about the bootstrap"), z' =
    sqrt(n / (n - 1)) t_{n-1}. The plain percentile interval is too narrow for a few tens of pairs
    (measured: 92 % coverage for a nominal 95 % with 20 pairs)."""
    z = math.sqrt(n / (n - 1)) * stats.t.ppf(0.5 + confidence / 2.0, n - 1)
    return float(2.0 * stats.norm.cdf(z) - 1.0)


def stratified_bootstrap(
    statistic: Callable[[np.ndarray, np.ndarray | None], np.ndarray],
    n: int,
    big_n: int,
    confidence: float,
    resamples: int,
    seed: int,
    batch: int,
    strata: np.ndarray | None = None,
    resample_rest: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """The percentile interval, at the expanded level for n pairs, of ``statistic(pairs, rest)``: row indices
    [..., n] of the paired realizations (0 … n − 1) and [..., N − n] of the unpaired ones (n … N − 1; None when
    every realization is paired, or when ``resample_rest`` is false: the unpaired then stand as they are),
    returning [..., *shape]. The pairs and the unpaired are resampled apart, and within each design stratum
    (``strata``: a label per row, pairs first; None is one stratum), so a resample keeps every stratum's counts
    and a pair's design weight is that of the pair it copies (scipy.stats.bootstrap over the samples),
    ``batch`` resamples at a time → lower and upper [*shape]."""
    labels = np.zeros(big_n, dtype=int) if strata is None else np.asarray(strata)
    rows = np.arange(big_n)
    groups = [rows[:n][labels[:n] == s] for s in np.unique(labels[:n])]
    if resample_rest:
        groups += [rows[n:][labels[n:] == s] for s in np.unique(labels[n:])]
    paired_groups = int(np.unique(labels[:n]).size)
    if min(len(group) for group in groups[:paired_groups]) < 2:
        raise MultiFidelityError("every design stratum needs at least 2 pairs to resample")

    def resampled(*picks: np.ndarray, axis: int = -1) -> np.ndarray:
        chosen = [group[pick.astype(int)] for group, pick in zip(groups, picks)]
        pick = np.concatenate(chosen[:paired_groups], axis=-1)
        rest = np.concatenate(chosen[paired_groups:], axis=-1) if len(chosen) > paired_groups else None
        value = statistic(pick, rest)
        batch_dims = pick.ndim - 1
        return np.moveaxis(value, tuple(range(batch_dims)), tuple(range(value.ndim - batch_dims, value.ndim)))

    groups = [np.repeat(group, 2) if len(group) < 2 else group for group in groups]  # a lone unpaired run: itself
    samples = tuple(np.arange(len(group)) for group in groups)
    boot = stats.bootstrap(
        samples,
        resampled,
        paired=False,
        vectorized=True,
        n_resamples=resamples,
        confidence_level=expanded_level(confidence, n),
        method="percentile",
        batch=batch,
        random_state=np.random.default_rng(seed),
    )
    return boot.confidence_interval


def design_weights(strata: np.ndarray | None, n: int) -> np.ndarray:
    """Each pair's weight [n] (summing to 1) in a design stratified on the cheap route: a pair of stratum s
    stands for N_s / N of the realizations, shared by its n_s pairs (``strata``: a label per row, pairs first;
    None: one stratum, every pair 1 / n)."""
    if strata is None:
        return np.full(n, 1.0 / n)
    labels = np.asarray(strata)
    weights = np.empty(n)
    for s in np.unique(labels[:n]):
        members = labels[:n] == s
        weights[members] = np.count_nonzero(labels == s) / labels.size / np.count_nonzero(members)
    missing = set(np.unique(labels[n:]).tolist()) - set(np.unique(labels[:n]).tolist())
    if missing:
        raise MultiFidelityError(f"design strata {sorted(missing)} hold realizations but no pair")
    return weights


def wmean(values: np.ndarray, weights: np.ndarray, axis: int) -> np.ndarray:
    """The weighted mean along ``axis``; ``weights`` broadcast against ``values`` and sum to 1 along it."""
    return (values * weights).sum(axis=axis)


def _sums(
    high: np.ndarray, low: np.ndarray, axis: int, weights: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Weighted) sums of squared deviations of h and of l, and of their cross products, along ``axis``."""
    if weights is None:
        weights = np.ones_like(high) / high.shape[axis]
    dh = high - np.expand_dims(wmean(high, weights, axis), axis)
    dl = low - np.expand_dims(wmean(low, weights, axis), axis)
    return wmean(dh * dh, weights, axis), wmean(dl * dl, weights, axis), wmean(dh * dl, weights, axis)


def _weight(high: np.ndarray, low: np.ndarray, axis: int, weights: np.ndarray | None = None) -> np.ndarray:
    """cov(h, l) / var(l) along ``axis`` (design-weighted); 1 where the paired low-fidelity values do not vary (a
    tail indicator that no pair reaches): the cheap route's value then stands, shifted by the paired
    difference, instead of the pairs alone throwing the N cheap runs away (any fixed weight is unbiased)."""
    _, var, cov = _sums(high, low, axis, weights)
    return np.divide(cov, var, out=np.ones_like(cov), where=var > 1e-12 * (1.0 + np.abs(cov)))


def point_estimate(
    high_p: np.ndarray, low_p: np.ndarray, low_u: np.ndarray | None, axis: int, weights: np.ndarray | None = None
) -> np.ndarray:
    """The control-variate estimate from paired (h, l) and unpaired l samples along ``axis`` (the weight
    estimated from the pairs; no interval): mean_w(h) + alpha (mean over all N of l − mean_w(l)), the pairs'
    means weighted by their design ``weights`` (broadcast against ``high_p``; None: equal)."""
    n = high_p.shape[axis]
    if weights is None:
        weights = np.ones_like(high_p) / n
    total = low_p.sum(axis=axis) + (low_u.sum(axis=axis) if low_u is not None else 0.0)
    count = n + (low_u.shape[axis] if low_u is not None else 0)
    alpha = _weight(high_p, low_p, axis, weights)
    return wmean(high_p, weights, axis) + alpha * (total / count - wmean(low_p, weights, axis))


def control_variate(
    high: np.ndarray,
    low: np.ndarray,
    confidence: float = 0.95,
    resamples: int = RESAMPLES,
    seed: int = 0,
    strata: np.ndarray | None = None,
) -> ControlVariateEstimate:
    """Estimate the high-fidelity mean of each quantity from ``high`` [n, ...] and ``low`` [N, ...].

    ``low[:n]`` are the same realizations as ``high``; n ≥ 2 pairs are needed for the weight. ``strata`` (a
    label per row of ``low``, pairs first; None: one stratum, the pairs a simple random subsample): the pairs
    were drawn at random within strata of the cheap route's values, and weigh N_s / (N n_s)."""
    high, low = np.asarray(high, dtype=float), np.asarray(low, dtype=float)
    n, big_n = high.shape[0], low.shape[0]
    if high.shape[1:] != low.shape[1:]:
        raise MultiFidelityError(
            f"high- and low-fidelity quantities differ in shape: {high.shape[1:]} vs {low.shape[1:]}"
        )
    if n < 2 or big_n < n:
        raise MultiFidelityError(
            f"need at least 2 paired realizations and no more than the {big_n} low-fidelity ones, got {n}"
        )
    if not (np.isfinite(high).all() and np.isfinite(low).all()):
        raise MultiFidelityError("high- or low-fidelity values hold NaN or infinity (a diverged run?)")
    if not 0.0 < confidence < 1.0:
        raise MultiFidelityError(f"confidence must lie in (0, 1), got {confidence}")
    shape = high.shape[1:]
    h2, l2 = high.reshape(n, -1), low.reshape(big_n, -1)
    w = design_weights(strata, n)

    def statistic(pick: np.ndarray, rest: np.ndarray | None) -> np.ndarray:
        rest_values = None if rest is None else l2[rest]
        return point_estimate(h2[pick], l2[pick], rest_values, axis=-2, weights=w[pick][..., None])  # [..., K]

    estimate = point_estimate(h2, l2[:n], l2[n:] if big_n > n else None, axis=0, weights=w[:, None])
    batch = max(1, 4_000_000 // max(1, big_n * h2.shape[1]))
    lower, upper = stratified_bootstrap(statistic, n, big_n, confidence, resamples, seed, batch, strata)
    lower, upper = np.minimum(lower, estimate), np.maximum(upper, estimate)  # a degenerate bootstrap: the point
    var_h, var_l, cov = _sums(h2, l2[:n], 0, w[:, None])
    denominator = np.sqrt(var_h * var_l)
    correlation = np.divide(cov, denominator, out=np.full(h2.shape[1], np.nan), where=denominator > 0)
    return ControlVariateEstimate(
        estimate=estimate.reshape(shape),
        lower=np.asarray(lower).reshape(shape),
        upper=np.asarray(upper).reshape(shape),
        high_mean=wmean(h2, w[:, None], 0).reshape(shape),
        low_mean=l2.mean(0).reshape(shape),
        weight=_weight(h2, l2[:n], 0, w[:, None]).reshape(shape),
        correlation=correlation.reshape(shape),
        bias=wmean(l2[:n] - h2, w[:, None], 0).reshape(shape),
        n_paired=n,
        n_low=big_n,
        confidence=confidence,
    )


def _exceeds(values: np.ndarray, thresholds: np.ndarray, inclusive: bool) -> np.ndarray:
    """[..., T] 1[value ≥ t] where ``inclusive``, else 1[value > t] (NaN never exceeds)."""
    return ((values[..., None] >= thresholds) if inclusive else (values[..., None] > thresholds)).astype(float)


def predicted_exceedance(
    high_p: np.ndarray,
    low_p: np.ndarray,
    low: np.ndarray,
    thresholds: np.ndarray,
    weights: np.ndarray | None = None,
) -> np.ndarray:
    """The control variate of 1[h > t]: P(h > t | l) under h = a + b l + N(0, s(l)²), a, b fitted by
    (design-weighted) least squares on the pairs finite at both fidelities, evaluated at every low-fidelity value
    (:func:`regression_at` then :func:`exceedance_given`).

    The residual spread follows the cheap value, s(l) = s · shape(l) (:func:`spread_shape`), as the real pairs'
    does (case 1's 128 pairs at 0.5 m: residual sd 0.28 m below the median cheap runout, 0.43 m above): one spread
    for all put each mesh's modelled 1 % tail a tenth of a metre off where the spread differs from its average
    (benchmarks/results/pair_coverage_local.md). s is the residuals' weighted root mean square, made unbiased for
    the fit's 2 parameters (n / (n − 2) with equal weights) by the design's effective count.

    ``high_p``, ``low_p`` [..., n] (pairs; ``weights`` [..., n] their design weights, None: equal), ``low``
    [..., M] (where to evaluate), ``thresholds`` [T] → [..., M, T]. A non-finite low value (nothing moved)
    gives 1[l > t]; a perfect cheap model (s = 0) gives the step 1[l > t] itself."""
    return exceedance_given(*regression_at(high_p, low_p, low, weights), low, thresholds)


def regression_at(
    high_p: np.ndarray, low_p: np.ndarray, low: np.ndarray, weights: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The regression of :func:`predicted_exceedance` fitted on the pairs ``high_p``, ``low_p`` [..., n] and
    evaluated at ``low`` [..., M]: its predicted high value and residual spread there, each [..., M]. Apart from
    the thresholds, so that a search over thresholds fits once."""
    finite = np.isfinite(high_p) & np.isfinite(low_p)
    w = np.where(finite, 1.0 if weights is None else weights, 0.0)
    total = w.sum(-1, keepdims=True)
    w = w / np.maximum(total, 1e-300)
    count = finite.sum(-1, keepdims=True)
    effective = np.where(total > 0, 1.0 / np.maximum((w * w).sum(-1, keepdims=True), 1e-300), 0.0)
    hi, lo = np.where(finite, high_p, 0.0), np.where(finite, low_p, 0.0)
    mean_h = (w * hi).sum(-1, keepdims=True)
    mean_l = (w * lo).sum(-1, keepdims=True)
    dh, dl = np.where(finite, hi - mean_h, 0.0), np.where(finite, lo - mean_l, 0.0)
    var, cov = (w * dl * dl).sum(-1, keepdims=True), (w * dh * dl).sum(-1, keepdims=True)
    slope = np.divide(cov, var, out=np.zeros_like(cov), where=var > 1e-12)
    residual = np.where(finite, dh - slope * dl, 0.0)
    scale = np.sqrt((w * residual**2).sum(-1, keepdims=True) * effective / np.maximum(effective - 2.0, 1.0))
    scale = np.maximum(scale, 1e-9 * (1.0 + np.sqrt(var / np.maximum(count, 1) * count)))
    predicted = mean_h + slope * (low - mean_l)  # [..., M]
    spread = scale * spread_shape(np.abs(residual), dl, w, low - mean_l)  # [..., M]
    return predicted, spread


def exceedance_given(predicted: np.ndarray, spread: np.ndarray, low: np.ndarray, thresholds: np.ndarray) -> np.ndarray:
    """P(h > t | l) at each cheap value ``low`` [..., M] from the regression's ``predicted`` value and ``spread``
    there (:func:`regression_at`) and ``thresholds`` [T] → [..., M, T]; a non-finite ``low`` gives 1[l > t]."""
    smooth = predicted[..., None] - thresholds
    smooth /= spread[..., None]
    special.ndtr(smooth, out=smooth)  # norm.cdf less its wrapper, in place
    finite = np.isfinite(low)
    if finite.all():  # the common case: no step to build
        return smooth
    return np.where(finite[..., None], smooth, low[..., None] > thresholds)


# the spread's shape is held within these multiples of its root mean square over the pairs: a line fitted to a
# few tens of residuals' sizes must not reach zero (a step) or grow without bound beyond the pairs' range
SHAPE_RANGE = (0.25, 4.0)


def spread_shape(size: np.ndarray, dl: np.ndarray, w: np.ndarray, at: np.ndarray) -> np.ndarray:
    """How the residual spread varies with the cheap value: the design-weighted least-squares line of the
    residuals' sizes ``size`` on the centred cheap values ``dl`` (both [..., n], zero where not finite; ``w``
    their normalized weights), evaluated at the centred values ``at`` [..., M] and divided by its root mean
    square over the pairs, so that s · shape keeps the fitted mean square; held within SHAPE_RANGE. The
    line of |residual| on l is Glejser's (1969) model of a standard deviation linear in the regressor."""
    mean_size = (w * size).sum(-1, keepdims=True)
    var = (w * dl * dl).sum(-1, keepdims=True)
    tilt = np.divide((w * size * dl).sum(-1, keepdims=True), var, out=np.zeros_like(var), where=var > 1e-12)
    low, high = SHAPE_RANGE

    def line(x: np.ndarray) -> np.ndarray:
        return np.clip(mean_size + tilt * x, low * mean_size, high * mean_size)

    rms = np.sqrt((w * line(dl) ** 2).sum(-1, keepdims=True))
    return np.divide(line(at), rms, out=np.ones_like(at * rms), where=rms > 0)


def binned(values: np.ndarray, bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Many cheap values [M, K] as at most ``bins`` values per column and their counts [B, K]: the mean of the
    members of each of ``bins`` equal-width bins (empty bins count 0), non-finite values kept as one bin of
    their own. The mean of a smooth function over thousands of runs then costs ``bins`` evaluations; the error
    is that of the function's curvature over a bin, about (span / bins)² of its second derivative."""
    values = np.asarray(values, dtype=float)
    centres = np.zeros((bins + 1, values.shape[1]))
    counts = np.zeros((bins + 1, values.shape[1]))
    for k in range(values.shape[1]):
        column = values[:, k]
        finite = column[np.isfinite(column)]
        if finite.size:
            edges = np.linspace(finite.min(), finite.max(), bins + 1)
            which = np.clip(np.searchsorted(edges, finite, side="right") - 1, 0, bins - 1)
            counts[:bins, k] = np.bincount(which, minlength=bins)
            sums = np.bincount(which, weights=finite, minlength=bins)
            centres[:bins, k] = np.divide(sums, counts[:bins, k], out=edges[:-1].copy(), where=counts[:bins, k] > 0)
        centres[bins, k], counts[bins, k] = np.nan, column.size - finite.size
    return centres, counts


def mean_predicted(
    g_pairs: np.ndarray,
    high_p: np.ndarray,
    low_p: np.ndarray,
    low_u: np.ndarray | None,
    thresholds: np.ndarray,
    weights: np.ndarray,
    low_u_counts: np.ndarray | None = None,
) -> np.ndarray:
    """The mean over all N realizations of the predicted exceedance P(h > t | l) (:func:`predicted_exceedance`
    fitted on the pairs ``high_p``, ``low_p`` [..., n] with ``weights``), given its values at the pairs
    ``g_pairs`` [..., n, T]: the unpaired cheap values ``low_u`` [..., M] (None: none), or binned [M] with
    ``low_u_counts`` [M] → [..., T]."""
    g_rest = None if low_u is None else predicted_exceedance(high_p, low_p, low_u, thresholds, weights)
    return pooled_mean(g_pairs, g_rest, low_u_counts)


def pooled_mean(g_pairs: np.ndarray, g_rest: np.ndarray | None, counts: np.ndarray | None) -> np.ndarray:
    """The mean over all N realizations of a function given at the pairs ``g_pairs`` [..., n, T] and at the
    unpaired runs ``g_rest`` [..., M, T] (None: none), each standing for ``counts`` [M] runs (None: one) → [..., T]."""
    if g_rest is None:
        return g_pairs.mean(-2)
    if counts is None:
        return np.concatenate([g_pairs, g_rest], axis=-2).mean(-2)
    g_sum = g_pairs.sum(-2) + (g_rest * counts[:, None]).sum(-2)
    return g_sum / (g_pairs.shape[-2] + float(counts.sum()))


def regression_point_estimate(
    high_p: np.ndarray,
    low_p: np.ndarray,
    low_u: np.ndarray | None,
    thresholds: np.ndarray,
    signs: np.ndarray | None = None,
    inclusive: np.ndarray | None = None,
    weights: np.ndarray | None = None,
    low_u_counts: np.ndarray | None = None,
) -> np.ndarray:
    """sum_k sign_k P(v_k > t) (≥ where ``inclusive``) from pairs [..., n, K] and unpaired low values
    [..., M, K], each term mean_w(1[h > t] − g) + mean_N(g) with g the regression control variate and the
    pairs' means weighted by their design ``weights`` [..., n] (None: equal) → [..., T]. ``low_u_counts``
    [M, K]: the unpaired values are :func:`binned` ones, each standing for that many runs."""
    columns, n = high_p.shape[-1], high_p.shape[-2]
    signs = np.ones(columns) if signs is None else signs
    inclusive = np.zeros(columns, dtype=bool) if inclusive is None else inclusive
    w = np.full(high_p.shape[:-1], 1.0 / n) if weights is None else weights
    total = np.zeros(())
    for k in range(columns):
        hi, lo = high_p[..., k], low_p[..., k]
        g_pairs = predicted_exceedance(hi, lo, lo, thresholds, w)  # [..., n, T]
        counts = None if low_u_counts is None else low_u_counts[:, k]
        g_mean = mean_predicted(g_pairs, hi, lo, None if low_u is None else low_u[..., k], thresholds, w, counts)
        hit = _exceeds(hi, thresholds, inclusive[k])  # [..., n, T]
        total = total + signs[k] * ((w[..., None] * (hit - g_pairs)).sum(-2) + g_mean)
    return total


def stratified_variance(residual: np.ndarray, model: np.ndarray, strata: np.ndarray, n: int) -> np.ndarray:
    """The variance of a stratified mean of the pairs' ``residual`` [n, T] (1[h > t] − g), each stratum's variance
    at least the model's, the mean over the stratum's N_h runs of ``model`` [N, T] (g (1 − g), the indicator's
    variance given l): sum_h W_h² max(s_h², model_h) / n_h with W_h = N_h / N → [T]. A stratum of four pairs in a
    1 % tail rarely shows the bootstrap an exceedance, and its sample variance is then ~0: stratified pairs'
    bootstrap intervals of P(h > t) at the 0.9 and 0.99 quantiles covered 81 % and 67 %
    (tests/fidelity/test_stratified_pairs.py), with this floor about 95 %."""
    variance = np.zeros(residual.shape[1:])
    for stratum in np.unique(strata[:n]):
        pairs, rows = strata[:n] == stratum, strata == stratum
        spread = residual[pairs].var(axis=0, ddof=1) if pairs.sum() > 1 else np.zeros_like(variance)
        variance += (rows.mean() ** 2) * np.maximum(spread, model[rows].mean(axis=0)) / pairs.sum()
    return variance


# above this many unpaired cheap runs, the regression estimators' bootstraps hold them as they are and binned
# (their own sampling is then a share n / N of the pairs' or less) instead of resampling every one per resample
RESAMPLED_UNPAIRED = 4096
BINS = 1024


def regression_control_variate(
    high: np.ndarray,
    low: np.ndarray,
    thresholds: np.ndarray,
    signs: ArrayLike | None = None,
    inclusive: ArrayLike | None = None,
    confidence: float = 0.95,
    resamples: int = RESAMPLES,
    seed: int = 0,
    strata: np.ndarray | None = None,
) -> ControlVariateEstimate:
    """Exceedance probabilities sum_k sign_k P(v_k > t) of the high-fidelity values, for every threshold t.

    The difference (model-assisted) estimator mean over N of g + mean over the n pairs of
    (1[h > t] − g), where the control variate g of 1[h > t] is the cheap route's *predicted*
    probability P(h > t | l) (a linear regression of h on l over the pairs, Gaussian residuals),
    not its own indicator 1[l > t]: a realization near t that the two routes put on different
    sides no longer breaks the correlation, so the variance falls much further. Any fixed g leaves
    the estimate unbiased, and the weight 1 is the optimal one when g is the conditional
    probability, so none is estimated: a tail that no pair reaches keeps the cheap runs' predicted
    probability. The fit's O(1/n) bias is what remains; the bootstrap refits g in every resample,
    so the interval carries its uncertainty. ``high`` [n] or [n, K], ``low`` [N] or [N, K] (the
    first n paired); K columns are combined with ``signs`` (e.g. P(front ≥ x) − P(rear > x) for
    P(x affected); ``inclusive`` marks the columns compared with ≥). NaN marks a realization with
    nothing to measure (it never exceeds). ``strata``: as :func:`control_variate`'s (the pairs' means
    weighted by design). The correlation reported is that of 1[h > t] with g over the pairs (what sets
    the variance), the bias the cheap route's own (its indicators), the weight 1. Beyond
    RESAMPLED_UNPAIRED unpaired runs the bootstrap holds them as they are, binned.
    """
    high = np.asarray(high, dtype=float).reshape(len(high), -1)
    low = np.asarray(low, dtype=float).reshape(len(low), -1)
    thresholds = np.asarray(thresholds, dtype=float).ravel()
    n, big_n, k = high.shape[0], low.shape[0], high.shape[1]
    if low.shape[1] != k:
        raise MultiFidelityError(f"high- and low-fidelity values differ in columns: {k} vs {low.shape[1]}")
    if n < 2 or big_n < n:
        raise MultiFidelityError(
            f"need at least 2 paired realizations and no more than the {big_n} low-fidelity ones, got {n}"
        )
    if np.isinf(high).any() or np.isinf(low).any():
        raise MultiFidelityError("high- or low-fidelity values hold infinity (a diverged run?)")
    signs = np.ones(k) if signs is None else np.asarray(signs, dtype=float)
    inclusive = np.zeros(k, dtype=bool) if inclusive is None else np.asarray(inclusive, dtype=bool)
    w = design_weights(strata, n)
    resample_rest = big_n - n <= RESAMPLED_UNPAIRED
    fixed_rest, fixed_counts = (None, None) if resample_rest else binned(low[n:], BINS)

    def statistic(pick: np.ndarray, rest: np.ndarray | None) -> np.ndarray:
        low_u = fixed_rest if rest is None else low[rest]
        return regression_point_estimate(
            high[pick], low[pick], low_u, thresholds, signs, inclusive, w[pick], fixed_counts
        )  # [..., T]

    estimate = regression_point_estimate(high, low[:n], low[n:] if big_n > n else None, thresholds, signs, inclusive, w)
    evaluated = (big_n if resample_rest else n + BINS) * thresholds.size * k
    batch = max(1, 2_000_000 // max(1, evaluated))
    lower, upper = stratified_bootstrap(statistic, n, big_n, confidence, resamples, seed, batch, strata, resample_rest)
    lower, upper = np.minimum(lower, estimate), np.maximum(upper, estimate)

    def indicators(values: np.ndarray) -> list[np.ndarray]:
        return [_exceeds(values[:, j], thresholds, inclusive[j]) for j in range(k)]

    def combined(columns: list[np.ndarray]) -> np.ndarray:
        return sum(signs[j] * columns[j] for j in range(k))

    h_ind, l_columns = combined(indicators(high)), indicators(low)
    g_pairs = combined([predicted_exceedance(high[:, j], low[:n, j], low[:n, j], thresholds, w) for j in range(k)])
    if strata is not None and np.unique(strata[:n]).size > 1:
        g_all = [predicted_exceedance(high[:, j], low[:n, j], low[:, j], thresholds, w) for j in range(k)]
        model = np.sum([g * (1.0 - g) for g in g_all], axis=0)  # the indicators' variance given l, columns apart
        half = _z(confidence) * np.sqrt(stratified_variance(h_ind - g_pairs, model, np.asarray(strata), n))
        lower, upper = np.minimum(lower, estimate - half), np.maximum(upper, estimate + half)
    var_h, var_l, cov = _sums(h_ind, g_pairs, 0, w[:, None])
    denominator = np.sqrt(var_h * var_l)
    correlation = np.divide(cov, denominator, out=np.full(thresholds.size, np.nan), where=denominator > 0)
    high_mean = wmean(h_ind, w[:, None], 0)
    return ControlVariateEstimate(
        estimate=estimate,
        lower=np.asarray(lower),
        upper=np.asarray(upper),
        high_mean=high_mean,
        low_mean=combined([column.mean(0) for column in l_columns]),  # summed as the estimate sums its terms
        weight=np.ones(thresholds.size),
        correlation=correlation,
        bias=combined([wmean(column[:n], w[:, None], 0) for column in l_columns]) - high_mean,
        n_paired=n,
        n_low=big_n,
        confidence=confidence,
    )


def rearranged(probability: np.ndarray) -> np.ndarray:
    """An exceedance curve (along the last axis) made a probability and non-increasing by sorting its values
    (the monotone rearrangement of Chernozhukov, Fernandez-Val & Galichon 2010: it never moves the curve
    further from the true one, which is non-increasing); a control-variate estimate need not be either."""
    return np.sort(np.clip(np.asarray(probability, dtype=float), 0.0, 1.0), axis=-1)[..., ::-1]


def corrected_affected_probability(
    high: np.ndarray, low: np.ndarray, x_m: np.ndarray, strata: np.ndarray | None = None
) -> np.ndarray:
    """P(x affected) = P(front ≥ x) − P(back scarp > x) from pairs ``high`` [n, 2] and cheap runs ``low``
    [N, 2] (front, rear; the first n paired; ``strata`` as :func:`control_variate`'s), each term rearranged to
    be non-increasing in x before the difference: estimated as one, the difference wiggles where the terms
    overlap, and a wiggle across a zoning threshold drew an island (a 0.75 m "extremely low" stretch inside
    "low")."""
    n = len(high)
    w = design_weights(strata, n)
    terms = [
        rearranged(
            regression_point_estimate(
                high[:, [k]],
                low[:n, [k]],
                low[n:, [k]] if len(low) > n else None,
                x_m,
                inclusive=np.array([inclusive]),
                weights=w,
            )
        )
        for k, inclusive in ((0, True), (1, False))
    ]
    return np.clip(terms[0] - terms[1], 0.0, 1.0)


def exceedance_indicators(values: np.ndarray, thresholds: np.ndarray) -> np.ndarray:
    """[N, T] indicators 1[value > threshold]: their means are the exceedance probabilities."""
    return (np.asarray(values, dtype=float)[:, None] > np.asarray(thresholds, dtype=float)[None, :]).astype(float)


@dataclass
class Allocation:
    """How many realizations to run at each fidelity (MFMC optimal allocation for two models)."""

    n_high: int
    n_low: int
    ratio: float  # n_low / n_high before rounding
    variance: float  # of the estimate
    cost: float  # n_high * cost_high + n_low * cost_low
    plain_cost: float  # high-fidelity-only cost to the same variance
    speedup: float  # plain_cost / cost


def optimal_ratio(cost_high: float, cost_low: float, correlation: float) -> float:
    """N / n minimising the variance at a fixed cost: sqrt(w rho^2 / (1 - rho^2)), w = cost_high / cost_low
    (at least 1; Peherstorfer et al. 2016, Theorem 3.4)."""
    if cost_high <= 0 or cost_low <= 0:
        raise MultiFidelityError(f"costs must be positive, got high {cost_high} and low {cost_low}")
    rho2 = min(float(correlation) ** 2, 1.0 - 1e-12)
    return max(1.0, math.sqrt(cost_high / cost_low * rho2 / (1.0 - rho2)))


def variance_factor(ratio: float, correlation: float) -> float:
    """Variance of the estimate with n pairs over that of n high-fidelity runs alone: 1 - (1 - 1/r) rho^2."""
    return 1.0 - (1.0 - 1.0 / ratio) * correlation**2


def _z(confidence: float) -> float:
    """The two-sided normal quantile of a ``confidence`` interval."""
    return float(stats.norm.ppf(0.5 + confidence / 2.0))


def predicted_half_width(
    std_high: float, correlation: float, n_high: int, n_low: int, confidence: float = 0.95
) -> float:
    """Interval half-width of the control-variate estimate of a mean from n_high pairs among n_low cheap
    runs (normal approximation, optimal weight): z std sqrt(variance_factor(N / n, rho) / n)."""
    return _z(confidence) * std_high * math.sqrt(variance_factor(n_low / n_high, correlation) / n_high)


def allocate(
    cost_high: float,
    cost_low: float,
    correlation: float,
    std_high: float,
    half_width: float,
    confidence: float = 0.95,
    cap_high: int | None = None,
) -> Allocation:
    """Realizations at each fidelity for a target interval half-width (normal approximation),
    from the measured costs (s per realization), paired correlation and high-fidelity std.
    ``cap_high`` bounds the paired runs (the half-width is then not reached)."""
    if half_width <= 0:
        raise MultiFidelityError(f"the target half-width must be positive, got {half_width}")
    target = (half_width / _z(confidence)) ** 2
    ratio = optimal_ratio(cost_high, cost_low, correlation)
    n_high = max(2, math.ceil(std_high**2 * variance_factor(ratio, correlation) / target))
    if cap_high is not None:
        n_high = min(n_high, cap_high)
    n_low = max(n_high, math.ceil(ratio * n_high))
    variance = std_high**2 / n_high * variance_factor(n_low / n_high, correlation)
    cost = n_high * cost_high + n_low * cost_low
    plain_cost = std_high**2 / variance * cost_high
    return Allocation(n_high, n_low, ratio, variance, cost, plain_cost, plain_cost / cost)


def pairs_for_half_width(
    std_high: float, correlation: float, n_low: int, half_width: float, confidence: float = 0.95
) -> float:
    """Paired runs n for which the control-variate estimate of a mean, from n pairs among ``n_low`` cheap
    runs, reaches ``half_width`` (normal approximation; variance std² ((1 − ρ²) / n + ρ² / N) at the
    optimal weight). Infinite where the N cheap runs cannot: ρ² std² / N alone exceeds the target."""
    if half_width <= 0:
        raise MultiFidelityError(f"the target half-width must be positive, got {half_width}")
    target = (half_width / _z(confidence)) ** 2
    rho2 = min(float(correlation) ** 2, 1.0)
    floor = std_high**2 * rho2 / n_low
    return math.inf if floor >= target else std_high**2 * (1.0 - rho2) / (target - floor)


def speedup(cost_high: float, cost_low: float, correlation: float) -> float:
    """Cost of plain high-fidelity MC over that of optimally allocated MFMC at equal variance."""
    ratio = optimal_ratio(cost_high, cost_low, correlation)
    return 1.0 / ((1.0 + ratio * cost_low / cost_high) * variance_factor(ratio, correlation))


def weighted_std(values: np.ndarray, weights: np.ndarray) -> float:
    """The standard deviation of ``values`` under design ``weights`` (summing to 1)."""
    mean = float(weights @ values)
    return math.sqrt(float(weights @ (values - mean) ** 2))


def correlation_lower_bound(correlation: float, n: int, confidence: float = 0.95) -> float:
    """The one-sided lower confidence bound of |ρ| from a sample correlation on n pairs (Fisher's z:
    atanh(r) ≈ N(atanh(ρ), 1 / (n − 3))), 0 where it falls below 0 or n < 4."""
    if n < 4:
        return 0.0
    z = math.atanh(min(abs(correlation), 1.0 - 1e-12)) - float(stats.norm.ppf(confidence)) / math.sqrt(n - 3)
    return max(math.tanh(z), 0.0)


def route(
    cost_high: float, cost_low: float, correlation: float, n_pairs: int, confidence: float = 0.95
) -> dict[str, Any]:
    """Whether the correction pays for the cheap route: MFMC's predicted speed-up at equal error over plain
    MPM Monte Carlo (:func:`speedup`, optimal allocation), at the lower ``confidence`` bound of the correlation
    on the ``n_pairs`` pairs (:func:`correlation_lower_bound`), not its point value: with a cheap run 1,000×
    cheaper than the MPM any |r| above ~0.03 predicts a gain, and an unrelated cheap route's r on 32 pairs is
    ~N(0, 0.18). Below 1 — a cheap route that may cost more than it saves — the route is "plain MPM". Power
    (tests/fidelity/test_stratified_pairs.py, 4,000 draws of 32 normal pairs, costs 25 s and 0.007 s): an
    uncorrelated cheap route is called plain MPM in 92.8 % of draws (on the point value: 16 %), one correlated
    0.5 (a 1.3x gain) multi-fidelity in 87.8 %, one correlated 0.7 in 99.9 %.
    Unknown costs (NaN) keep the multi-fidelity route."""
    rho = float(np.nan_to_num(correlation))
    if not (math.isfinite(cost_high) and math.isfinite(cost_low)):
        return {
            "correlation_runout": rho,
            "optimal_ratio": None,
            "speedup_at_equal_error": None,
            "route": "multi-fidelity",
            "reason": "the routes' costs were not measured",
        }
    bound = correlation_lower_bound(rho, n_pairs, confidence)
    gain, assured = speedup(cost_high, cost_low, rho), speedup(cost_high, cost_low, bound)
    plain = assured < 1.0
    evidence = (
        f"the cheap route correlates {rho:.2f} with the accurate MPM on {n_pairs} pairs "
        f"(at least {bound:.2f} with {confidence:.0%} confidence)"
    )
    reason = (
        f"{evidence}: at that bound the correction may cost {assured:.2f}x plain MPM for the same interval, so "
        "plain MPM Monte Carlo on the paired realizations is the safe route"
        if plain
        else f"{evidence}: {gain:.1f}x cheaper than plain MPM at equal error (at least {assured:.1f}x)"
    )
    return {
        "correlation_runout": rho,
        "correlation_lower_bound": bound,
        "optimal_ratio": optimal_ratio(cost_high, cost_low, rho),
        "speedup_at_equal_error": gain,
        "speedup_at_the_bound": assured,
        "route": "plain MPM" if plain else "multi-fidelity",
        "reason": reason,
    }
