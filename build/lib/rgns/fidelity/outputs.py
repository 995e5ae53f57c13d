"""Rule multifidelity: a case's exceedance curves and zoning corrected towards the accurate MPM.

The Monte Carlo table (the cheap route: its simulator after the gate) and the paired table (the
first realizations again, by the MPM at the accurate mesh) are combined for every quantity that
is a mean: the means of R, V and I by :func:`rgns.fidelity.multifidelity.control_variate`; P(R > d) and
P(I > d) at every distance d, and P(x affected) = P(front ≥ x) − P(back scarp > x) at every point
of the zoning profile, by :func:`rgns.fidelity.multifidelity.regression_control_variate` (the cheap route's
predicted exceedance as control variate: an indicator 1[l > d] correlates poorly with 1[h > d]
near d). Exceedance curves are rearranged to be non-increasing; P(x affected) is the difference of
its two rearranged terms, so the corrected zones rise to one maximum and fall (no islands). Costs
come from the Snakemake benchmark files of the chunks.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

import matplotlib
import matplotlib.figure

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from rgns.fidelity.mesh_extrapolation import converged  # noqa: E402
from rgns.fidelity.multifidelity import (
    ControlVariateEstimate,
    MultiFidelityError,
    allocate,
    control_variate,  # noqa: E402
    corrected_affected_probability,
    design_weights,
    rearranged,
    regression_control_variate,
    route,
    weighted_std,
)
from rgns.fidelity.pair_design import row_strata  # noqa: E402
from rgns.fidelity.pair_validation import pair_validation  # noqa: E402
from rgns.hazard.exceedance import distance_at, distance_grid  # noqa: E402
from rgns.hazard.statistics import ZONE_LEVELS, exceedance_distances, zone_levels, zones  # noqa: E402
from rgns.scene.realizations import FINISHED  # noqa: E402

METRICS = {"runout_m": "runout R", "influence_m": "influence I", "volume_m2": "volume V"}
CURVES = ("runout_m", "influence_m")


def paired_rows(low: pd.DataFrame, high: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The cheap table reordered with the paired realizations first, and the paired accurate rows
    in the same order; a realization not finished by either route is left out of both."""
    low = low[low["status"].isin(FINISHED)].set_index("index")
    high = high[high["status"].isin(FINISHED)].set_index("index")
    both = [i for i in high.index if i in low.index]
    if len(both) < 2:
        raise MultiFidelityError(f"{len(both)} realizations finished at both fidelities; at least 2 are needed")
    rest = [i for i in low.index if i not in set(both)]
    return low.loc[both + rest].reset_index(), high.loc[both].reset_index()


def costs(low_benchmarks: list[str], n_low: int, high_benchmarks: list[str], n_high: int) -> dict[str, float]:
    """Seconds per realization of each route, from Snakemake benchmark files (column ``s``)."""

    def seconds(paths: list[str]) -> float:
        return float(sum(pd.read_csv(path, sep="\t")["s"].sum() for path in paths))

    return {"low_s": seconds(low_benchmarks) / n_low, "high_s": seconds(high_benchmarks) / n_high}


def _estimate_record(estimate: ControlVariateEstimate) -> dict[str, Any]:
    return {
        key: np.asarray(getattr(estimate, key)).tolist()
        for key in ("estimate", "lower", "upper", "high_mean", "low_mean", "weight", "correlation", "bias")
    }


def correct(
    low: pd.DataFrame,
    high: pd.DataFrame,
    settings: dict[str, Any],
    cost: dict[str, float],
    seed: int = 0,
    design: dict[str, Any] | None = None,
    grids: dict[str, list[float]] | None = None,
) -> dict[str, Any]:
    """Every corrected quantity of one case, with the uncorrected ones beside it; ``design``: the pairs'
    stratified design (rgns.fidelity.pair_design; None: a simple random subsample); ``grids``: the distances of
    each exceedance curve (None: :func:`distance_grid` of the runs)."""
    low, high = paired_rows(low, high)
    n, confidence = len(high), settings["confidence"]
    strata = row_strata(design, low["index"].tolist(), n)
    record: dict[str, Any] = {
        "n_low": len(low),
        "n_paired": n,
        "high_cell_size_m": settings["high_cell_size_m"],
        "cheap_route": settings.get("cheap_route", "the Monte Carlo's simulator"),
        "confidence": confidence,
        "cost": cost,
        "means": {},
        "exceedance": {},
    }
    for key in METRICS:
        estimate = control_variate(
            high[[key]].to_numpy(float), low[[key]].to_numpy(float), confidence, seed=seed, strata=strata
        )
        record["means"][key] = {name: value[0] for name, value in _estimate_record(estimate).items()}
    for key in CURVES:
        d_m = np.asarray(grids[key]) if grids else distance_grid(pd.concat([low[key], high[key]]).to_numpy(float))
        estimate = regression_control_variate(
            high[key].to_numpy(float), low[key].to_numpy(float), d_m, confidence=confidence, seed=seed, strata=strata
        )
        corrected, uncorrected = rearranged(estimate.estimate), estimate.low_mean  # low_mean: over all N
        record["exceedance"][key] = {
            "d_m": d_m.tolist(),
            "uncorrected": uncorrected.tolist(),
            "corrected": corrected.tolist(),
            "lower": rearranged(estimate.lower).tolist(),
            "upper": rearranged(estimate.upper).tolist(),
            "paired_high": estimate.high_mean.tolist(),
            "distances": {
                str(p): {"uncorrected": distance_at(d_m, uncorrected, p), "corrected": distance_at(d_m, corrected, p)}
                for p in settings["exceedance_probabilities"]
            },
        }
    x_m = np.arange(0.0, settings["domain"]["length_m"] + 1e-9, settings["resolution_m"])
    ends_high, ends_low = (
        high[["front_x_m", "rear_x_m"]].to_numpy(float),
        low[["front_x_m", "rear_x_m"]].to_numpy(float),
    )
    estimate = regression_control_variate(
        ends_high,
        ends_low,
        x_m,
        signs=[1.0, -1.0],
        inclusive=[True, False],
        confidence=confidence,
        seed=seed,
        strata=strata,
    )
    probability, uncorrected = corrected_affected_probability(ends_high, ends_low, x_m, strata), estimate.low_mean
    thresholds = settings["thresholds"]
    w = design_weights(strata, n)[:, None]
    labels = np.zeros(n, dtype=int) if strata is None else strata[:n]
    record["pair_validation"] = pair_validation(high, low.iloc[:n], w[:, 0], labels, confidence, seed=seed)
    record["zoning"] = {
        "x_m": x_m.tolist(),
        "uncorrected": uncorrected.tolist(),
        "corrected": probability.tolist(),
        # the band: the joint estimate's bootstrap interval, widened where needed to hold the rearranged estimate
        "lower": np.minimum(np.clip(estimate.lower, 0, 1), probability).tolist(),
        "upper": np.maximum(np.clip(estimate.upper, 0, 1), probability).tolist(),
        "zones_uncorrected": [asdict(zone) for zone in zones(x_m, zone_levels(uncorrected, thresholds))],
        "zones_corrected": [asdict(zone) for zone in zones(x_m, zone_levels(probability, thresholds))],
    }
    runout = record["means"]["runout_m"]
    rho = float(np.nan_to_num(runout["correlation"]))
    record["allocation"] = route(cost["high_s"], cost["low_s"], rho, n, confidence)
    if settings.get("target_half_width_m"):
        plan = allocate(
            cost["high_s"],
            cost["low_s"],
            rho,
            weighted_std(high["runout_m"].to_numpy(float), w[:, 0]),
            settings["target_half_width_m"],
            confidence,
        )
        record["allocation"]["target"] = {"half_width_m": settings["target_half_width_m"], **asdict(plan)}
    return record


def plot(record: dict[str, Any], path: str | Path, case: str) -> None:
    """The figure of :func:`best_estimate_figure`, written to ``path``."""
    fig = best_estimate_figure(record, case)
    fig.savefig(path, dpi=130)
    plt.close(fig)


def best_estimate_figure(record: dict[str, Any], case: str) -> matplotlib.figure.Figure:
    """Exceedance of R and I and the zoning probability: cheap route, corrected (with interval), paired accurate,
    and at the converged mesh the distances exceeded with each P and the zoning. The curves are drawn linear
    between the distances they are known at, as rgns.hazard.exceedance reads them, so that a distance's
    marker sits on its curve; the pairs' own curve, a sample's, as steps."""
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    simulator_differs = not record.get("cheap_is_simulator", True)
    for ax, key in zip(axes, CURVES):
        curve = record["exceedance"][key]
        d = curve["d_m"]
        ax.plot(d, curve["uncorrected"], color="C0", label=f"cheap route (n = {record['n_low']})")
        ax.plot(d, curve["corrected"], color="C3", label="multi-fidelity corrected")
        ax.fill_between(
            d,
            curve["lower"],
            curve["upper"],
            color="C3",
            alpha=0.2,
            label=f"{record['confidence']:.0%} interval",
        )
        if curve.get("simulator") is not None and simulator_differs:
            ax.plot(
                d,
                curve["simulator"],
                color="0.5",
                linestyle="--",
                label="Monte Carlo's simulator (its map)",
            )
        ax.step(
            d,
            curve["paired_high"],
            where="post",
            color="k",
            linestyle=":",
            label=f"accurate MPM alone (n = {record['n_paired']})",
        )
        drawn = [
            (float(p), e)
            for p, e in record.get("converged", {}).get("distances", {}).get(key, {}).items()
            if None not in (e["estimate"], e["lower"], e["upper"])
        ]
        for k, (p, entry) in enumerate(drawn):
            ax.errorbar(
                [entry["estimate"]],
                [p],
                xerr=[[entry["estimate"] - entry["lower"]], [entry["upper"] - entry["estimate"]]],
                fmt="D",
                color="C2",
                capsize=3,
                label=None if k else "converged mesh: exceeded with P",
            )
        ax.set_xlabel(f"{METRICS[key]} (m)")
        ax.set_ylabel("exceedance probability")
        ax.set_ylim(-0.02, 1.02)
    axes[0].legend(fontsize=7)
    zoning = record["zoning"]
    ax = axes[2]
    ax.plot(zoning["x_m"], zoning["uncorrected"], color="C0", label="cheap route")
    ax.plot(zoning["x_m"], zoning["corrected"], color="C3", label="corrected")
    ax.fill_between(zoning["x_m"], zoning["lower"], zoning["upper"], color="C3", alpha=0.2)
    if "converged" in record:
        ax.plot(zoning["x_m"], record["converged"]["zoning"]["probability"], color="C2", label="converged mesh")
        ax.legend(fontsize=7)
    ax.set_xlabel("x along the section (m)")
    ax.set_ylabel("P(affected)")
    ax.set_ylim(-0.02, 1.02)
    fig.suptitle(
        f"{case}: multi-fidelity correction towards the MPM at {record['high_cell_size_m']:g} m cells"
        + (", and carried to the converged mesh" if "converged" in record else "")
    )
    fig.tight_layout()
    return fig


def simulator_validation(
    simulator: pd.DataFrame, coarse: pd.DataFrame, design: dict[str, Any] | None, confidence: float
) -> dict[str, dict[str, Any]]:
    """The Monte Carlo's simulator against the MPM at its own mesh on the case's pairs (the paper's Table 3,
    on the realizations the map is drawn from), weighted by the pairs' design."""
    simulator_rows, coarse_rows = paired_rows(simulator, coarse)
    n = len(coarse_rows)
    strata = row_strata(design, simulator_rows["index"].tolist(), n)
    weights = design_weights(strata, n)
    labels = np.zeros(n, dtype=int) if strata is None else strata[:n]
    return pair_validation(coarse_rows, simulator_rows.iloc[:n], weights, labels, confidence)


CHEAP_COLUMNS = (*METRICS, "front_x_m", "rear_x_m")


def flattened(low: pd.DataFrame) -> pd.DataFrame:
    """The cheap table with every cheap value replaced by one constant per column (its mean): the correction's
    estimators then reduce to the MPM pairs' own design-weighted means (a constant control variate takes weight 1
    and corrects by 0; the regression's predicted probability is the same for every realization, so the
    difference estimator is the pairs' weighted share above each distance), with every realization kept, so
    the strata's weights N_s / N hold: a plain MPM Monte Carlo over the paired realizations."""
    flat = low.copy()
    for column in CHEAP_COLUMNS:
        flat[column] = float(np.nanmean(low[column].to_numpy(float)))
    return flat


def with_plain_estimate(record: dict[str, Any], plain: dict[str, Any]) -> dict[str, Any]:
    """``record`` (the correction) with its best estimate replaced by ``plain``'s (:func:`correct` of the
    :func:`flattened` table, on the same grids): the means, the exceedance curves and distances, the zoning; the
    cheap route's own curves, the pairs' validation and the allocation stay as the evidence of why."""
    for key, mean in record["means"].items():
        mean.update({name: plain["means"][key][name] for name in ("estimate", "lower", "upper", "weight")})
    for key, curve in record["exceedance"].items():
        curve.update({name: plain["exceedance"][key][name] for name in ("corrected", "lower", "upper")})
        for p, distances in curve["distances"].items():
            distances["corrected"] = plain["exceedance"][key]["distances"][p]["corrected"]
    if "zoning" in plain:
        for name in ("corrected", "lower", "upper", "zones_corrected"):
            record["zoning"][name] = plain["zoning"][name]
    record["route_applied"] = "plain MPM"
    return record


def open_unreached_tails(record: dict[str, Any]) -> None:
    """Leave open the upper end of a plain MPM estimate's distance exceeded with P where its n pairs cannot bound
    it: without a cheap route to borrow the tail from, a distance-free upper bound of the 1 − P quantile needs
    the chance that none of n runs exceeds it, (1 − P)^n, below (1 − confidence) / 2 (at 95 %: n ≥ 36 for P 0.1,
    367 for P 0.01); a bootstrap of n values cannot reach past their largest."""
    n, confidence = record["n_paired"], record["confidence"]
    chain = record.get("converged", {}).get("distances", {})
    for key, curve in record["exceedance"].items():
        for p, distances in curve["distances"].items():
            if (1.0 - float(p)) ** n <= (1.0 - confidence) / 2.0:
                continue
            distances["open_above"] = True
            if p in chain.get(key, {}):
                chain[key][p]["upper"] = None
                chain[key][p]["interval_at_order"][1] = None
                chain[key][p]["accurate_band"][1] = None


def best_estimate(
    low: pd.DataFrame,
    high: pd.DataFrame,
    coarse: pd.DataFrame | None,
    settings: dict[str, Any],
    cost: dict[str, float],
    design: dict[str, Any] | None = None,
    seed: int = 0,
    correction: Callable[..., dict[str, Any]] = correct,
) -> dict[str, Any]:
    """The case's correction (``correction``: :func:`correct`, or a stand-in with its signature that records
    part of it) and, with the ``coarse`` pairs and ``mesh_order``, its chain to the converged mesh. Where the
    allocation finds that the cheap route does not pay, the route it names is applied: the estimate from the
    paired MPM runs alone (:func:`flattened`, :func:`with_plain_estimate`) with the tails they cannot bound
    left open (:func:`open_unreached_tails`)."""
    record = correction(low, high, settings, cost, seed=seed, design=design)
    plain = record["allocation"]["route"] == "plain MPM"
    if plain:
        low = flattened(low)
        grids = {key: curve["d_m"] for key, curve in record["exceedance"].items()}
        record = with_plain_estimate(
            record, correction(low, high, settings, cost, seed=seed, design=design, grids=grids)
        )
    if coarse is not None and settings.get("mesh_order"):
        record["converged"] = converged(low, high, coarse, settings, record, seed=seed, design=design)
    if plain:
        open_unreached_tails(record)
    return record


def write_multifidelity(
    low: pd.DataFrame,
    high: pd.DataFrame,
    settings: dict[str, Any],
    cost: dict[str, float],
    outputs: dict[str, str],
    case: str,
    plan: dict[str, Any] | None = None,
    simulator: pd.DataFrame | None = None,
    coarse: pd.DataFrame | None = None,
) -> dict[str, Any]:
    """Correct, then write the JSON (with the pairs' stratified design ``plan`` (rule paired_plan), the Monte
    Carlo's own means and curves: its ``simulator`` table where that is not the cheap route, and with the
    pairs at the Monte Carlo's mesh, ``coarse``, the estimates at the converged mesh and the simulator's
    validation against them) and the figure."""
    record = best_estimate(low, high, coarse, settings, cost, plan)
    record["levels"] = list(ZONE_LEVELS)
    own = simulator if simulator is not None else low
    record["cheap_is_simulator"] = simulator is None
    finished = own[own["status"].isin(FINISHED)]
    record["simulator_means"] = {key: float(finished[key].mean()) for key in METRICS}
    for key, curve in record["exceedance"].items():  # the Monte Carlo's own curve, what its map is drawn from
        values = finished[key].to_numpy(float)
        curve["simulator"] = [float(np.mean(values > d)) for d in curve["d_m"]]
        # its distances by the exceedance table's own estimator (rgns.hazard.statistics), so the two tables agree
        own_distances = exceedance_distances(values, [float(p) for p in curve["distances"]], confidence=0.95)
        for distances, own_distance in zip(curve["distances"].values(), own_distances):
            distances["simulator"] = own_distance.distance_m
    if coarse is not None:
        record["simulator_validation"] = simulator_validation(own, coarse, plan, settings["confidence"])
    if plan is not None:
        record["plan"] = {key: plan[key] for key in ("bounds_m", "sizes", "pairs")} | {"n_paired": len(plan["indices"])}
    Path(outputs["json"]).write_text(json.dumps(record, indent=1, default=float) + "\n")
    plot(record, outputs["figure"], case)
    return record
