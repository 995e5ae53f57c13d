"""The corrected hazard carried from the accurate MPM's mesh to the converged one.

The multi-fidelity correction (rgns.fidelity.outputs) is unbiased with respect to the MPM at
``high_cell_size_m``, which is not the converged answer. With the same paired realizations run once
more at the Monte Carlo's own mesh (``coarse_cell_size_m``, r = coarse / high times coarser) and the
measured order p of the engine's mesh convergence (``mesh_order``: per quantity [low, value, high], from
benchmarks/mesh_levels.py; null where no asymptotic range was measured), Richardson extrapolation adds what the accurate mesh still misses,
(f_high − f_coarse) / (r^p − 1), over the pairs:

* means of R, V and I: the nested levels [accurate, coarse, cheap] by :func:`rgns.fidelity.multilevel.extrapolated`,
  whose interval holds the sampling, every weight and the order's interval;
* the runout and influence exceeded with probability P: the corrected distance plus the Richardson step
  of the distances at which the accurate and the coarse mesh's curves, as each mesh's regression on the
  cheap route models them over all N realizations, fall to P (so the step of a 1 % tail rests on the N
  cheap runs, not on the pairs' maximum); the interval is the union of two bootstraps of both together
  (:func:`distance_intervals`: the pairs resampled, and the pairs redrawn from each mesh's fit, the distance
  and the step taken from the same resample), at each order of the order's interval, enveloped;
* the zoning: the profile recomputed with the fronts and back scarps moved by their mean steps, at the
  order's value and at its interval's ends.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from functools import partial
from typing import Any

import numpy as np
import pandas as pd

from rgns.fidelity.multifidelity import (
    BINS,
    RESAMPLED_UNPAIRED,
    RESAMPLES,
    MultiFidelityError,
    binned,
    corrected_affected_probability,
    design_weights,
    exceedance_given,
    expanded_level,
    pooled_mean,
    rearranged,
    regression_at,
    regression_point_estimate,
    spread_shape,
    stratified_bootstrap,
)
from rgns.fidelity.multilevel import extrapolated, multilevel, richardson_step
from rgns.fidelity.pair_design import row_strata
from rgns.hazard.exceedance import crossings, distance_at
from rgns.hazard.statistics import zone_levels, zones
from rgns.scene.realizations import FINISHED

MEANS = ("runout_m", "volume_m2", "influence_m")
ENDS = ("front_x_m", "rear_x_m")


def nested_levels(
    low: pd.DataFrame, high: pd.DataFrame, coarse: pd.DataFrame
) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """The accurate and coarse rows of the realizations both finished (in the accurate table's order),
    and the cheap rows with those first: nested levels for the multilevel estimator."""
    low, coarse = (t[t["status"].isin(FINISHED)].set_index("index") for t in (low, coarse))
    high = high[high["status"].isin(FINISHED) & high["index"].isin(coarse.index) & high["index"].isin(low.index)]
    if len(high) < 2:
        raise MultiFidelityError(
            f"{len(high)} paired realizations finished at both meshes and by the cheap route; at least 2 are needed"
        )
    first = high["index"].tolist()
    rest = [i for i in low.index if i not in set(first)]
    return high.reset_index(drop=True), coarse.loc[first].reset_index(), low.loc[first + rest].reset_index()


# how a modelled curve's fall to P is found: 12 bisections halve a 40 m bracket to 1 cm, where the curve is a
# straight line to ~1e-5 m, then false-position steps and a last interpolation (16 evaluations of the curve where
# 30 bisections took 32, to the same 1e-6 m: tests/fidelity/test_mesh_extrapolation.py)
BISECTIONS = 12
FALSE_POSITIONS = 2


def modelled_crossing(
    high_p: np.ndarray,
    low_p: np.ndarray,
    low_u: np.ndarray | None,
    targets: np.ndarray,
    bracket: tuple[float, float],
    weights: np.ndarray,
    low_u_counts: np.ndarray | None = None,
) -> np.ndarray:
    """The distance at which the exceedance curve of the MPM at one mesh, as its regression on the cheap route
    models it over every realization — the mean over all N of P(h > t | l) under h = a + b l + N(0, s(l)²), fitted
    on the pairs ``high_p``, ``low_p`` [..., n] with design ``weights`` (rgns.fidelity.multifidelity.
    predicted_exceedance) — falls to each probability ``targets`` [P] → [..., P], by BISECTIONS bisections and
    FALSE_POSITIONS false-position steps within ``bracket`` (its lower end where the curve starts at most P; inf
    where it is still above P at the upper end). ``low_u``: the unpaired cheap values [..., M, 1], or binned
    [M, 1] with ``low_u_counts``. Without the pairs' indicator correction the curve is smooth, so a difference
    of two meshes' crossings is free of the 1 / n jumps that made the step of a 1 % tail swing by metres; and it
    moves continuously with the fit: two meshes whose runs differ by δ cross δ apart."""
    shape = (*high_p.shape[:-1], targets.size)
    rest = None if low_u is None else low_u[..., 0]
    counts = None if low_u_counts is None else low_u_counts[:, 0]

    at_pairs = regression_at(high_p, low_p, low_p, weights)  # fitted once for all the search's thresholds
    at_rest = None if rest is None else regression_at(high_p, low_p, rest, weights)

    def curve(at: np.ndarray) -> np.ndarray:
        thresholds = at[..., None, :]  # [..., 1, P]
        g_pairs = exceedance_given(*at_pairs, low_p, thresholds)  # [..., n, P]
        g_rest = None if at_rest is None or rest is None else exceedance_given(*at_rest, rest, thresholds)
        return pooled_mean(g_pairs, g_rest, counts)

    lower, upper = np.full(shape, float(bracket[0])), np.full(shape, float(bracket[1]))
    at_lower, at_upper = curve(lower) - targets, curve(upper) - targets  # the curve less P: > 0 below the fall
    starts_low, never_falls = at_lower <= 0.0, at_upper > 0.0

    def interpolated() -> np.ndarray:
        drop = at_lower - at_upper
        share = np.divide(at_lower, drop, out=np.full_like(drop, 0.5), where=drop > 0.0)
        return lower + np.clip(share, 0.0, 1.0) * (upper - lower)

    for step in range(BISECTIONS + FALSE_POSITIONS):
        middle = 0.5 * (lower + upper) if step < BISECTIONS else interpolated()
        at_middle = curve(middle) - targets
        above = at_middle > 0.0  # the fall lies above middle: it becomes the bracket's lower end
        lower, at_lower = np.where(above, middle, lower), np.where(above, at_middle, at_lower)
        upper, at_upper = np.where(above, upper, middle), np.where(above, at_upper, at_middle)
    found = np.where(starts_low, bracket[0], interpolated())
    return np.where(never_falls, np.inf, found)


def converged_distances(
    fine: np.ndarray,
    partner: np.ndarray,
    cheap: np.ndarray,
    weights: np.ndarray,
    low_u: np.ndarray | None,
    counts: np.ndarray | None,
    d_m: np.ndarray,
    targets: np.ndarray,
    factor: np.ndarray,
) -> np.ndarray:
    """What :func:`distance_intervals` estimates from one set of pairs (``fine``, ``partner``: the accurate and the
    coarse mesh's values, ``cheap`` their cheap values, ``weights`` their design weights, all [..., n]; the unpaired
    cheap runs ``low_u`` as :func:`modelled_crossing` takes them), per Richardson ``factor`` r^p − 1 [orders, 1]
    and probability ``targets`` → [..., 3, orders, P]: the estimate (the corrected curve's distance on ``d_m`` plus
    the step), the step, and the fit's own distance (the accurate mesh's modelled crossing plus the step)."""
    bracket = (float(d_m[0]), float(d_m[-1]))
    ends = [modelled_crossing(mesh, cheap, low_u, targets, bracket, weights, counts) for mesh in (fine, partner)]
    step = (ends[0] - ends[1])[..., None, :] / factor
    curve = regression_point_estimate(
        fine[..., None], cheap[..., None], low_u, d_m, weights=weights, low_u_counts=counts
    )
    distance = crossings(rearranged(curve), d_m, targets)[..., None, :] + step  # [..., orders, P]
    return np.stack([distance, step, ends[0][..., None, :] + step], axis=-3)


def point_distances(
    high: np.ndarray,
    coarse: np.ndarray,
    low: np.ndarray,
    d_m: np.ndarray,
    probabilities: list[float],
    ratio: float,
    orders: np.ndarray,
    strata: np.ndarray | None = None,
) -> np.ndarray:
    """What :func:`distance_intervals` estimates from the sample itself (its arguments, less the bootstraps'):
    :func:`converged_distances` of the pairs with the unpaired cheap runs as they are, or binned beyond
    RESAMPLED_UNPAIRED → [3, orders, P] (the estimate, the step, the fit's own distance)."""
    n = len(high)
    targets = np.asarray(probabilities, dtype=float)
    factor = ratio ** np.asarray(orders, dtype=float)[:, None] - 1.0  # [orders, 1]
    with np.errstate(invalid="ignore"):  # inf − inf where neither curve falls to P: NaN, read as open
        return converged_distances(
            high, coarse, low[:n], design_weights(strata, n), *held_unpaired(low, n), d_m, targets, factor
        )


def held_unpaired(low: np.ndarray, n: int) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The unpaired cheap runs (``low`` past its first ``n``, the pairs') as an estimate from the sample holds them:
    as they are [M, 1] up to RESAMPLED_UNPAIRED, beyond it :func:`binned`, with their counts; (None, None) if none."""
    if len(low) == n:
        return None, None
    if len(low) - n <= RESAMPLED_UNPAIRED:
        return low[n:, None], None
    return binned(low[n:, None], BINS)


@dataclass
class DistanceIntervals:
    """Per order [value, low, high] and probability: the converged distance's interval ends (NaN: open) and the
    mesh step's point value and interval ends, from one bootstrap."""

    lower: np.ndarray
    upper: np.ndarray
    step: np.ndarray
    step_lower: np.ndarray
    step_upper: np.ndarray


@dataclass
class ModelResamples:
    """Resamples of the pairs drawn from their regressions on the cheap route (:func:`model_resamples`): the
    cheap values, the accurate and coarse values and the design weights [B, n]."""

    cheap: np.ndarray
    high: np.ndarray
    coarse: np.ndarray
    weights: np.ndarray


def model_resamples(
    high: np.ndarray,
    coarse: np.ndarray,
    cheap: np.ndarray,
    weights: np.ndarray,
    strata: np.ndarray | None,
    resamples: int,
    rng: np.random.Generator,
) -> ModelResamples:
    """Model-based resampling of the n pairs (Davison & Hinkley 1997, "Bootstrap methods and their application",
    section 6.2.3), as the design would draw new pairs: each resample draws its n cheap values anew from all N
    cheap runs (``cheap`` [N], the pairs first), each within its pair's design stratum (``strata``: a label per
    row; None: one), and gives each an accurate and a coarse value from that mesh's design-weighted regression
    line on the cheap route, fitted once on the pairs, plus one pair's standardized residuals of both meshes
    (drawn jointly, with the design weights as probabilities) at the spread the residual-spread model puts at
    that cheap value (rgns.fidelity.multifidelity.spread_shape), scaled up for the fit's two parameters by the
    design's effective count. A resample's pairs so fall in the cheap route's tail, and pass a tail threshold
    that no pair of the sample reached, as often as new pairs would under the fit. Drawing the cheap values from
    the pairs' own instead (as first written) left a sample with no pair in the tail without one in any
    resample: its intervals of the converged 10 % and 1 % distances covered 85 and 85 % on fresh seeds
    (benchmarks/results/pair_coverage_local.md)."""
    n = len(high)
    w = weights / weights.sum()
    effective = 1.0 / float((w * w).sum())
    centre = float(w @ cheap[:n])
    centred = cheap[:n] - centre
    labels = np.zeros(len(cheap), dtype=int) if strata is None else np.asarray(strata)
    picks = np.empty((resamples, n), dtype=int)
    for label in np.unique(labels[:n]):
        slots, pool = np.flatnonzero(labels[:n] == label), np.flatnonzero(labels == label)
        picks[:, slots] = pool[rng.integers(0, pool.size, (resamples, slots.size))]
    drawn = cheap[picks] - centre  # [B, n]
    donors = rng.choice(n, size=(resamples, n), p=w)
    values = []
    for mesh in (high, coarse):
        mean = w @ mesh
        slope = float(w @ ((mesh - mean) * centred) / max(float(w @ centred**2), 1e-300))
        residual = mesh - mean - slope * centred
        standardized = residual / spread_shape(np.abs(residual), centred, w, centred)
        standardized *= np.sqrt(effective / max(effective - 2.0, 1.0))
        values.append(mean + slope * drawn + spread_shape(np.abs(residual), centred, w, drawn) * standardized[donors])
    return ModelResamples(cheap[picks], values[0], values[1], np.broadcast_to(weights, (resamples, n)).copy())


def distance_intervals(
    high: np.ndarray,
    coarse: np.ndarray,
    low: np.ndarray,
    d_m: np.ndarray,
    probabilities: list[float],
    ratio: float,
    orders: np.ndarray,
    confidence: float,
    seed: int,
    strata: np.ndarray | None = None,
) -> DistanceIntervals:
    """The converged distance exceeded with each probability P at each order [orders, P]: the corrected accurate
    curve's distance (as rgns.fidelity.outputs.correct finds it: regression control variate of ``high`` on the
    cheap ``low``, rearranged, where it falls to P: rgns.hazard.exceedance.crossings) plus the Richardson step of
    the distances at which the accurate and the coarse mesh's modelled curves fall to P (:func:`modelled_crossing`:
    each mesh's regression on the cheap route over all N realizations). The corrected distance is
    design-unbiased; the step is model-based, as Richardson's is, and borrows the N cheap runs' tail: the pairs'
    1 − P quantiles it replaces are, past the last pair's plotting position, the pairs' maximum (that step came
    out 0.43 m short at P 0.01 in benchmarks/pair_coverage.py).

    The interval is the union of two bootstraps' intervals, each at the expanded percentile level for n pairs:
    the pairs bootstrap (the pairs — ``high``, ``coarse`` and the first n of ``low`` together — and the
    unpaired cheap runs resampled within the design ``strata``: a label per row of ``low``, None one stratum;
    both regressions refitted in every resample) and a basic interval from model-based resamples of the pairs
    (:func:`model_resamples`: new pairs drawn by the design from the N cheap runs, their values at both meshes
    from each mesh's fit; each resample is estimated as the sample is, and its deviation from what the fit itself
    gives — the accurate mesh's modelled crossing plus the step — stands for the estimate's error). A tail
    distance's estimate is pushed far out when a pair happens to pass P's threshold and not otherwise:
    resampling the pairs cannot show that to a sample with no such pair (its intervals of the converged 10 % and
    1 % distances covered 85 and 83 % where the real pairs' relation bends and its spread grows), and nor could
    model-based resamples that redrew the pairs' own cheap values (with them the union covered 85 and 85 % on
    46 fresh replicates, in pair_coverage_local.md's history); drawn from all N cheap runs, the union's intervals
    implied 0.50 and 0.87 m of spread where the estimates had 0.51 and 0.93 m (24 development replicates of that
    population, simple random pairs; measured on fresh seeds: benchmarks/results/pair_coverage_local.md).
    The unpaired cheap runs are resampled up to RESAMPLED_UNPAIRED, beyond it held as they are, binned."""
    n, big_n = len(high), len(low)
    targets = np.asarray(probabilities, dtype=float)
    weights = design_weights(strata, n)
    resample_rest = big_n - n <= RESAMPLED_UNPAIRED
    held = held_unpaired(low, n)  # as the sample's own estimate holds them; the pairs bootstrap resamples them
    fixed_rest, fixed_counts = (None, None) if resample_rest else held
    factor = ratio ** np.asarray(orders, dtype=float)[:, None] - 1.0  # [orders, 1]
    value = partial(converged_distances, d_m=d_m, targets=targets, factor=factor)
    rng = np.random.default_rng([seed, 1])  # the model-based resamples' own stream, apart from the pairs'
    rest = low[n:, None] if big_n > n else None

    def statistic(pick: np.ndarray, rest_pick: np.ndarray | None) -> np.ndarray:
        low_u, counts = (fixed_rest, fixed_counts) if rest_pick is None else (low[rest_pick][..., None], None)
        return value(high[pick], coarse[pick], low[pick], weights[pick], low_u, counts)[..., :2, :, :]

    with np.errstate(invalid="ignore"):  # inf − inf where neither curve falls to P: NaN, read as open
        point = value(high, coarse, low[:n], weights, *held)  # point_distances, its pieces at hand
        evaluated = max(d_m.size, targets.size) * (big_n if resample_rest else n + BINS)  # the largest array
        batch = max(1, 2_000_000 // max(1, evaluated))
        paired = stratified_bootstrap(statistic, n, big_n, confidence, RESAMPLES, seed, batch, strata, resample_rest)
        fitted = np.stack([point[2], point[1]])  # what the model-based resamples estimate: the fit's distance, step
        drawn = model_resamples(high, coarse, low, weights, strata, RESAMPLES, rng)
        deviations = []
        for start in range(0, RESAMPLES, batch):
            part = slice(start, start + batch)
            low_u = fixed_rest
            if resample_rest and rest is not None:
                low_u = rest[rng.integers(0, big_n - n, (len(drawn.cheap[part]), big_n - n))]
            found = value(
                drawn.high[part], drawn.coarse[part], drawn.cheap[part], drawn.weights[part], low_u, fixed_counts
            )
            deviations.append(found[:, :2] - fitted)  # the estimate's and the step's error where the fit is the law
        errors = np.concatenate(deviations)  # [B, 2, orders, P]
        level = expanded_level(confidence, n)
        # the estimate's error exceeds the fit's at a share of resamples (NaN: a curve that never fell to P)
        low_error, high_error = np.nanpercentile(errors, [50.0 * (1 - level), 50.0 * (1 + level)], axis=0)
        open_ends = [np.where(np.isfinite(end), end, np.nan) for end in paired]  # NaN (open) stays open below
        lower = np.minimum(open_ends[0], point[:2] - high_error)  # [2, orders, P]: the distance, the step
        upper = np.maximum(open_ends[1], point[:2] - low_error)
    lower, upper, point = (np.where(np.isfinite(a), a, np.nan) for a in (lower, upper, point))
    lower = np.where(np.isnan(lower), np.nan, np.fmin(lower, point[:2]))  # the interval holds the estimate
    upper = np.where(np.isnan(upper), np.nan, np.fmax(upper, point[:2]))
    return DistanceIntervals(lower[0], upper[0], point[1], lower[1], upper[1])


def _open(end: float) -> float | None:
    """An interval end as recorded: None where the runs leave it open (NaN)."""
    return None if np.isnan(end) else float(end)


def _orders(settings: dict[str, Any]) -> dict[str, np.ndarray | None]:
    """Each quantity's order [value, low, high] from ``mesh_order`` (None: not established, not extrapolated)."""
    orders: dict[str, np.ndarray | None] = {}
    for key in MEANS:
        given = (settings["mesh_order"] or {}).get(key)
        if given is None:
            orders[key] = None
            continue
        low_order, order, high_order = (float(v) for v in given)
        if not 0.0 < low_order <= order <= high_order:
            raise MultiFidelityError(
                f"montecarlo.fidelity.mesh_order.{key} {list(given)}: expected 0 < low ≤ value ≤ high"
            )
        orders[key] = np.array([order, low_order, high_order])
    return orders


def converged(
    low: pd.DataFrame,
    high: pd.DataFrame,
    coarse: pd.DataFrame,
    settings: dict[str, Any],
    corrected: dict[str, Any],
    seed: int = 0,
    design: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The means, exceedance distances and zoning at the converged mesh, each with its chain: the corrected
    (accurate-mesh) value, the mesh step at the order's value and interval, the converged value and interval.
    A quantity without an order (``mesh_order.<key>`` null: no asymptotic range was measured) keeps the
    accurate mesh's value, marked so. ``design``: the pairs' stratified design (rgns.fidelity.pair_design;
    None: a simple random subsample)."""
    ratio = float(settings["coarse_cell_size_m"]) / float(settings["high_cell_size_m"])
    if ratio <= 1.0:
        raise MultiFidelityError(
            f"mesh.cell_size_m ({settings['coarse_cell_size_m']}) must be coarser than "
            f"montecarlo.fidelity.high_cell_size_m ({settings['high_cell_size_m']}) to extrapolate"
        )
    orders = _orders(settings)
    high, coarse, low = nested_levels(low, high, coarse)
    strata = row_strata(design, low["index"].tolist(), len(high))
    confidence = settings["confidence"]
    record: dict[str, Any] = {
        "order": {key: None if o is None else [o[1], o[0], o[2]] for key, o in orders.items()},
        "ratio": ratio,
        "n_pairs": len(high),
        "coarse_cell_size_m": settings["coarse_cell_size_m"],
        "means": {},
        "distances": {},
    }
    for key, order in orders.items():
        levels = [t[[key]].to_numpy(float) for t in (high, coarse, low)]
        if order is None:
            finest = multilevel(levels, confidence, seed=seed, strata=strata)
            step, step_range, value, lower, upper = None, None, finest.estimate[0], finest.lower[0], finest.upper[0]
            at_order = (lower, upper)
        else:
            estimate = extrapolated(levels, ratio, order[0], (order[1], order[2]), confidence, seed=seed, strata=strata)
            finest = estimate.finest
            step = float(estimate.mesh_error[0])
            step_range = [float(estimate.mesh_error_range[0][0]), float(estimate.mesh_error_range[1][0])]
            value, lower, upper = estimate.estimate[0], estimate.lower[0], estimate.upper[0]
            at_order = (estimate.at_order[0][0], estimate.at_order[1][0])
        record["means"][key] = {
            "cheap_mean": float(finest.level_means[2][0]),
            "coarse_mean": float(finest.level_means[1][0]),
            "accurate": float(finest.estimate[0]),
            "accurate_lower": float(finest.lower[0]),
            "accurate_upper": float(finest.upper[0]),
            "mesh_step": step,
            "mesh_step_range": step_range,
            "estimate": float(value),
            "interval_at_order": [float(at_order[0]), float(at_order[1])],  # sampling alone
            "lower": float(lower),
            "upper": float(upper),
        }
    for key, curve in corrected["exceedance"].items():
        key_order = orders.get(key)
        if key_order is None:
            continue
        probabilities = [float(p) for p in curve["distances"]]
        fine, coarse_values, cheap = (t[key].to_numpy(float) for t in (high, coarse, low))
        joint = distance_intervals(
            fine,
            coarse_values,
            cheap,
            np.asarray(curve["d_m"]),
            probabilities,
            ratio,
            key_order,
            confidence,
            seed,
            strata,
        )
        # the envelope over the order's interval; NaN (open) at any order leaves it open
        outer_lower, outer_upper = joint.lower.min(axis=0), joint.upper.max(axis=0)
        record["distances"][key] = {}
        for j, (p, distances) in enumerate(zip(probabilities, curve["distances"].values())):
            accurate = distances["corrected"]
            band = (distance_at(curve["d_m"], curve["lower"], p), distance_at(curve["d_m"], curve["upper"], p))
            entry = {
                "accurate": accurate,
                "accurate_band": list(band),
                "mesh_step": _open(joint.step[0, j]),
                "mesh_step_range": [_open(joint.step[:, j].min()), _open(joint.step[:, j].max())],
                "mesh_step_interval": [_open(joint.step_lower[:, j].min()), _open(joint.step_upper[:, j].max())],
            }
            step = entry["mesh_step"]
            entry["estimate"] = None if accurate is None or step is None else accurate + step
            entry["interval_at_order"] = [_open(joint.lower[0, j]), _open(joint.upper[0, j])]  # sampling alone
            entry["lower"], entry["upper"] = _open(outer_lower[j]), _open(outer_upper[j])
            record["distances"][key][str(p)] = entry
    record["zoning"] = _zoning(low, high, coarse, settings, ratio, orders, strata)
    return record


def _zoning(
    low: pd.DataFrame,
    high: pd.DataFrame,
    coarse: pd.DataFrame,
    settings: dict[str, Any],
    ratio: float,
    orders: dict[str, np.ndarray | None],
    strata: np.ndarray | None = None,
) -> dict[str, Any]:
    """P(x affected) with every front moved by the mean Richardson step of the fronts (at the runout's
    order) and every back scarp by the back scarps' (at the influence distance's order; means weighted by the
    design ``strata``); an end whose quantity has no order stays where the accurate mesh put it."""
    x_m = np.arange(0.0, settings["domain"]["length_m"] + 1e-9, settings["resolution_m"])
    ends_high, ends_coarse, ends_low = (t[list(ENDS)].to_numpy(float) for t in (high, coarse, low))
    steps = np.zeros((3, 2))
    weights = design_weights(strata, len(high))
    for column, key in enumerate(("runout_m", "influence_m")):
        key_order = orders[key]
        if key_order is not None:
            steps[:, column] = richardson_step(
                weights @ ends_high[:, column], weights @ ends_coarse[:, column], ratio, key_order
            )
    profiles = [corrected_affected_probability(ends_high + step, ends_low + step, x_m, strata) for step in steps]
    thresholds = settings["thresholds"]
    return {
        "x_m": x_m.tolist(),
        "probability": profiles[0].tolist(),
        "front_step_m": float(steps[0, 0]),
        "rear_step_m": float(steps[0, 1]),
        "front_step_range_m": [float(steps[:, 0].min()), float(steps[:, 0].max())],
        "rear_step_range_m": [float(steps[:, 1].min()), float(steps[:, 1].max())],
        "zones": [asdict(zone) for zone in zones(x_m, zone_levels(profiles[0], thresholds))],
        "zones_at_order_ends": [
            [asdict(zone) for zone in zones(x_m, zone_levels(p, thresholds))] for p in profiles[1:]
        ],
    }
