"""The corrected hazard carried from the accurate MPM's mesh to the converged one.

The multi-fidelity correction (rgns.fidelity.outputs) is unbiased with respect to the MPM at
``high_cell_size_m``, which is not the converged answer. With the same paired realizations run once
more at the Monte Carlo's own mesh (``coarse_cell_size_m``, r = coarse / high times coarser) and the
measured order p of the engine's mesh convergence (``mesh_order``: per quantity [low, value, high], from
benchmarks/mesh_levels.py; null where no asymptotic range was measured), Richardson extrapolation adds what the accurate mesh still misses,
(f_high − f_coarse) / (r^p − 1), over the pairs:

* means of R, V and I: the nested levels [accurate, coarse, cheap] by :func:`rgns.fidelity.multilevel.extrapolated`,
  whose interval holds the sampling, every weight and the order's interval;
* the runout and influence exceeded with probability P: the corrected distance plus the step of the
  paired quantiles; the interval is one joint bootstrap of both (:func:`distance_intervals`: the pairs and
  the cheap runs resampled once, the corrected curve's distance and the quantile step taken from the same
  resample), at each order of the order's interval, enveloped. Summing the curve's band and the step's own
  interval (``mesh_step_interval``, kept to show the step) end to end over-covered: 200 of 200 replicates
  in benchmarks/chain_coverage.py;
* the zoning: the profile recomputed with the fronts and back scarps moved by their mean steps, at the
  order's value and at its interval's ends.
"""

from __future__ import annotations

from dataclasses import asdict
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
    distance_at,
    rearranged,
    regression_point_estimate,
    stratified_bootstrap,
)
from rgns.fidelity.multilevel import extrapolated, multilevel, richardson_step
from rgns.fidelity.pair_design import row_strata
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


def weighted_quantile(values: np.ndarray, weights: np.ndarray, levels: np.ndarray) -> np.ndarray:
    """Quantiles of ``values`` [..., n] with design ``weights`` [..., n] at ``levels`` [P] → [..., P]: the
    weighted empirical distribution interpolated between the midpoints of each value's weight (Hazen's rule,
    numpy's ``method="hazen"`` when the weights are equal)."""
    order = np.argsort(values, axis=-1)
    v = np.take_along_axis(values, order, axis=-1)
    w = np.take_along_axis(np.broadcast_to(weights, values.shape), order, axis=-1)
    w = w / w.sum(-1, keepdims=True)
    mid = np.cumsum(w, axis=-1) - w / 2.0  # [..., n]
    n = values.shape[-1]
    above = (mid[..., None, :] < np.asarray(levels)[:, None]).sum(-1)  # [..., P]
    j = np.clip(above, 1, n - 1)
    left, right = np.take_along_axis(mid, j - 1, axis=-1), np.take_along_axis(mid, j, axis=-1)
    v_left, v_right = np.take_along_axis(v, j - 1, axis=-1), np.take_along_axis(v, j, axis=-1)
    t = np.clip((np.asarray(levels) - left) / np.maximum(right - left, 1e-300), 0.0, 1.0)
    return v_left + t * (v_right - v_left)


def _quantile_step(
    high: np.ndarray,
    coarse: np.ndarray,
    probabilities: list[float],
    ratio: float,
    orders: np.ndarray,
    weights: np.ndarray | None = None,
) -> np.ndarray:
    """The Richardson step of the paired quantiles exceeded with each probability, values [..., n] (design
    ``weights`` [..., n], None: equal) → [..., orders, P]."""
    levels = 1.0 - np.asarray(probabilities, dtype=float)
    w = np.full(high.shape, 1.0 / high.shape[-1]) if weights is None else weights
    qh, qc = weighted_quantile(high, w, levels), weighted_quantile(coarse, w, levels)  # [..., P]
    return richardson_step(qh[..., None, :], qc[..., None, :], ratio, orders[:, None])


def _quantile_steps(
    high: np.ndarray,
    coarse: np.ndarray,
    probabilities: list[float],
    ratio: float,
    orders: np.ndarray,
    confidence: float,
    seed: int,
    strata: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Richardson step of each paired quantile (exceeded with probability P) at each order [orders, P]:
    the point value and the ends of a paired percentile bootstrap (within the design ``strata``: a label per
    pair)."""
    n = len(high)
    weights = design_weights(strata, n)
    labels = None if strata is None else np.asarray(strata)[:n]

    def statistic(pick: np.ndarray, rest: np.ndarray | None) -> np.ndarray:
        return _quantile_step(high[pick], coarse[pick], probabilities, ratio, orders, weights[pick])

    point = statistic(np.arange(n), None)
    low, high_end = stratified_bootstrap(statistic, n, n, confidence, RESAMPLES, seed, 1000, labels)
    return point, np.minimum(np.asarray(low), point), np.maximum(np.asarray(high_end), point)


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
) -> tuple[np.ndarray, np.ndarray]:
    """The interval of each converged distance (exceeded with probability P) at each order [orders, P]: lower and
    upper ends (NaN: open, the resampled curves do not fall to P within ``d_m``), from one bootstrap that
    resamples the pairs (``high``, ``coarse`` and the first n of ``low``, together) and the unpaired cheap runs
    (the rest of ``low``; held as they are, binned, beyond RESAMPLED_UNPAIRED), within the design ``strata``
    (a label per row of ``low``; None: one stratum), and takes, per resample, the corrected curve's distance (as
    rgns.fidelity.outputs.correct finds it: regression control variate, rearranged, first grid distance at most
    P) plus the paired quantiles' Richardson step; at the expanded percentile level for n pairs."""
    n, big_n = len(high), len(low)
    targets = np.asarray(probabilities, dtype=float)
    weights = design_weights(strata, n)
    resample_rest = big_n - n <= RESAMPLED_UNPAIRED
    fixed_rest, fixed_counts = (None, None) if resample_rest else binned(low[n:, None], BINS)

    def value(pick: np.ndarray, low_u: np.ndarray | None, counts: np.ndarray | None) -> np.ndarray:
        curve = regression_point_estimate(
            high[pick][..., None], low[pick][..., None], low_u, d_m, weights=weights[pick], low_u_counts=counts
        )  # [..., T]
        below = rearranged(curve)[..., None, :] <= targets[:, None]  # [..., P, T]
        distance = np.where(below.any(-1), d_m[np.argmax(below, axis=-1)], np.inf)  # [..., P]
        step = _quantile_step(high[pick], coarse[pick], probabilities, ratio, orders, weights[pick])
        return distance[..., None, :] + step  # [..., orders, P]

    def statistic(pick: np.ndarray, rest: np.ndarray | None) -> np.ndarray:
        return value(pick, fixed_rest, fixed_counts) if rest is None else value(pick, low[rest][..., None], None)

    point = value(np.arange(n), low[n:, None] if big_n > n else None, None)
    evaluated = (big_n if resample_rest else n + BINS) * d_m.size
    batch = max(1, 2_000_000 // max(1, evaluated))
    with np.errstate(invalid="ignore"):  # a percentile between an open resample and another: NaN, read as open
        ends = stratified_bootstrap(statistic, n, big_n, confidence, RESAMPLES, seed, batch, strata, resample_rest)
    lower, upper = (np.where(np.isfinite(end), end, np.nan) for end in ends)
    lower = np.where(np.isnan(lower), np.nan, np.fmin(lower, point))  # the interval holds the estimate
    upper = np.where(np.isnan(upper), np.nan, np.fmax(upper, point))
    return lower, upper


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
        else:
            estimate = extrapolated(levels, ratio, order[0], (order[1], order[2]), confidence, seed=seed, strata=strata)
            finest = estimate.finest
            step = float(estimate.mesh_error[0])
            step_range = [float(estimate.mesh_error_range[0][0]), float(estimate.mesh_error_range[1][0])]
            value, lower, upper = estimate.estimate[0], estimate.lower[0], estimate.upper[0]
        record["means"][key] = {
            "cheap_mean": float(finest.level_means[2][0]),
            "coarse_mean": float(finest.level_means[1][0]),
            "accurate": float(finest.estimate[0]),
            "accurate_lower": float(finest.lower[0]),
            "accurate_upper": float(finest.upper[0]),
            "mesh_step": step,
            "mesh_step_range": step_range,
            "estimate": float(value),
            "lower": float(lower),
            "upper": float(upper),
        }
    for key, curve in corrected["exceedance"].items():
        key_order = orders.get(key)
        if key_order is None:
            continue
        probabilities = [float(p) for p in curve["distances"]]
        fine, coarse_values, cheap = (t[key].to_numpy(float) for t in (high, coarse, low))
        point, lower, upper = _quantile_steps(
            fine, coarse_values, probabilities, ratio, key_order, confidence, seed, strata
        )
        joint_lower, joint_upper = distance_intervals(
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
        outer_lower, outer_upper = joint_lower.min(axis=0), joint_upper.max(axis=0)
        record["distances"][key] = {}
        for j, (p, distances) in enumerate(zip(probabilities, curve["distances"].values())):
            accurate = distances["corrected"]
            band = (distance_at(curve["d_m"], curve["lower"], p), distance_at(curve["d_m"], curve["upper"], p))
            entry = {
                "accurate": accurate,
                "accurate_band": list(band),
                "mesh_step": float(point[0, j]),
                "mesh_step_range": [float(point[:, j].min()), float(point[:, j].max())],
                "mesh_step_interval": [float(lower[:, j].min()), float(upper[:, j].max())],
            }
            entry["estimate"] = None if accurate is None else accurate + entry["mesh_step"]
            entry["interval_at_order"] = [_open(joint_lower[0, j]), _open(joint_upper[0, j])]  # sampling alone
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
