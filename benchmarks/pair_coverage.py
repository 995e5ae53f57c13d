"""Do the pipeline's intervals hold for the default design (10,000 cheap realizations, 32 random pairs)?

    OMP_NUM_THREADS=1 nice -n 19 .venv/bin/python benchmarks/pair_coverage.py --replicates 200 --seed 20261204
    OMP_NUM_THREADS=1 nice -n 19 .venv/bin/python benchmarks/pair_coverage.py --sabotage --replicates 100 --seed 20261204
    .venv/bin/python benchmarks/pair_coverage.py --report       # the tables from what the json holds
    (each with --population finite: the finite population's answers, below; with --strata 0.5 0.9 0.99 the
    pairs drawn in strata of the cheap runout instead of the config's design, written to *_strata.json / .md)

Design under test: the default config's (config/config.yaml) multi-fidelity chain for case 1: N =
montecarlo.realizations cheap runs by montecarlo.fidelity.cheap (tuned: rgns/models/endstate_tuned.pt),
montecarlo.fidelity.paired of them drawn as a simple random subsample (montecarlo.fidelity.strata: [],
rgns.fidelity.pair_design.design_pairs with no edges, as rule paired_plan draws them) and re-run by the MPM at
montecarlo.fidelity.high_cell_size_m and at mesh.cell_size_m, extrapolated at montecarlo.fidelity.mesh_order.

Population (SYNTHETIC, CALIBRATED ON REAL PAIRS; no GPU ran the 10,000 MPM pairs it would take):

* cheap values: the tuned end-state surrogate run on realizations 0 … 9,999 of case 1 as the pipeline's
  mc_chunk runs route control (``CaseInputs.from_config``, ``run_realizations`` with simulator "endstate", one
  thread; benchmarks/cheap_route.py), cached in benchmarks/results/pair_coverage_cheap.npz;
* MPM values: per metric (runout_m, volume_m2, influence_m), h_0.5 = a + b·cheap + e_0.5 and h_1 = c + d·cheap
  + e_1, the lines least-squares fits on the 128 real triples (cheap, MPM 0.5 m, MPM 1 m) of case 1's
  realizations 0-127 (the GPU runs of benchmarks/mesh_levels.py, benchmarks/results/mesh_levels_gpu_runs.jsonl, with the
  tuned model on the same realizations: cheap_route.run_model), and the residuals drawn jointly by bootstrap:
  one real realization per population member gives its (e_0.5, e_1) of every metric, so the residuals'
  correlation across meshes and across metrics holds. front_x_m = toe + runout and rear_x_m = crest −
  influence, at each mesh's own toe and crest (constant over case 1's realizations).

Its answers are known exactly: the mean runout and the runout exceeded with P (0.5, 0.1, 0.01) at 0.5 m, and
at the converged mesh ("the chain's target", as benchmarks/chain_coverage.py defines it): the mean plus the
Richardson step of the 1 → 0.5 m means at the order's point value; the distance at which the population's 0.5 m
exceedance curve falls to P plus the step of the same distances at 0.5 and 1 m, all read by the pipeline's one
estimator (rgns.hazard.exceedance: the curve's crossing of P, linear between grid distances).

A replicate draws N realizations with replacement from the population (a drawn row is a new realization 0 …
N − 1), draws the pairs as rule paired_plan does, and estimates exactly as rule multifidelity does
(workflow/scripts/multifidelity.py → rgns.fidelity.outputs.write_multifidelity → ``best_estimate``: ``correct`` then
``mesh_extrapolation.converged``, the plan passed as the design; the bootstrap seed is the replicate number). It
records per quantity the estimate, the interval at the order's point value (sampling alone: the converged
mean's and the distances' ``interval_at_order`` as rule multifidelity records them) and the report's interval (the envelope over
the order's interval), and the allocation ``correct`` gives (``rgns.fidelity.multifidelity.route``; costs: the
0.5 m MPM's seconds per realization on one CPU thread, benchmarks/results/mesh_levels_runs.jsonl, and the tuned model's
timed here). Coverage: the share of replicates whose interval holds the answer, with its binomial SE; an
interval open above whose lower end is at most the answer holds it (the plain MPM route leaves open the tail
its pairs cannot bound: rgns.fidelity.outputs.open_unreached_tails); any other open
interval (an end beyond the curves' distances) counts as not covering. A miss "below": the interval lies
below the answer; "above": above it.

Three populations (--population). super (the default): a pair's MPM values are its member's fitted lines plus one
real realization's residuals drawn afresh for each pair, and the answers are those of that law (every member with
every real residual): the pipeline estimates the slope's law, not the particular realizations of one run.
finite: each member keeps the residuals drawn for it once (--population-seed), and the answers are that finite
population's; its 1 % tail departs from the law it was drawn from by about one sampling SE of a 10,000-member
quantile, which no 32 pairs can see (measured: the modelled crossings of the whole population's lines miss its
P 0.01 quantiles by −0.12 m at 0.5 m and +0.16 m at 1 m, a step 0.3 m short). local: as super, but each
member draws its residuals from the 32 real realizations nearest to it in cheap runout, so that their spread grows
with the cheap value as the real pairs' does: the modelled mesh step assumes one spread, and this tests it.

--points R: the point estimates alone (no bootstrap: a replicate takes ~0.1 s) over R replicates of the same
draws (replicate r of a seed draws what its coverage replicate r draws), per probability the converged runout's
bias and sd against the answer and its parts' (the corrected accurate distance, the mesh step), to
benchmarks/results/pair_coverage_points.json under the population and seed: the spread a coverage run's
intervals should imply, measured on many more replicates than a coverage run holds.

--sabotage: the same population with the cheap rows permuted across realizations (correlation ~0 with the
MPM). Results are checkpointed after every replicate (a rerun with the same seed resumes) to
benchmarks/results/pair_coverage_superpopulation.json (finite: pair_coverage.json, local:
pair_coverage_local.json), and the md beside it. A second worker takes the replicates from a number on
(``--first K``: a part file beside the population's, ``_fromK`` added); ``--merge`` appends the parts that
continue the run and recomputes the summaries. Replicates are seeded by number, so a split run equals one run.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import cheap_route  # noqa: E402  (benchmarks/ is the script's own folder)
import mesh_levels as ml  # noqa: E402
import numpy as np
import pandas as pd
import torch

from rgns.config import load_config
from rgns.fidelity.mesh_extrapolation import nested_levels, point_distances
from rgns.fidelity.multifidelity import control_variate, rearranged, regression_control_variate, route
from rgns.fidelity.multilevel import richardson_step
from rgns.fidelity.outputs import best_estimate, correct, paired_rows
from rgns.fidelity.pair_design import design_pairs, row_strata
from rgns.hazard.exceedance import distance_at, distance_grid, sample_distance
from rgns.montecarlo.runs import CaseInputs, run_realizations
from rgns.provenance import commit
from rgns.surrogates.endstate.model import load_model

REPO = ml.REPO
OUT = ml.OUT
CASE = "case1"
TUNED = REPO / "rgns" / "models" / "endstate_tuned.pt"
CACHE = OUT / "pair_coverage_cheap.npz"
LOCAL = 32  # --population local: the real realizations nearest in cheap runout a member draws its residuals from
POPULATIONS = {  # --population: its result files
    "finite": (OUT / "pair_coverage.json", OUT / "pair_coverage.md"),
    "super": (OUT / "pair_coverage_superpopulation.json", OUT / "pair_coverage_superpopulation.md"),
    "local": (OUT / "pair_coverage_local.json", OUT / "pair_coverage_local.md"),
}
REAL = 128  # realizations 0-127 ran at 1 and 0.5 m on the GPU
POPULATION_TEXT = {
    "finite": "**Finite population**: each member keeps the residuals drawn for it once (population seed "
    "in the json); the answers are this population's own, whose 1 % tail departs from its line-plus-residual "
    "law by about one sampling SE of a 10,000-member quantile.",
    "super": "**Superpopulation**: a replicate's N cheap members are drawn with replacement, and each pair's MPM "
    "values are its member's fitted lines plus one real realization's residuals drawn afresh, so that every pair "
    "is a new realization of the law the pipeline estimates; the answers are that law's, over every member with "
    f"every one of the {REAL} real residuals (10,000 x {REAL} equally likely values).",
    "local": "**Superpopulation with local residuals**: as the superpopulation, but each member draws its residuals "
    "from the 32 real realizations nearest to it in cheap runout, so that their spread grows with the cheap value "
    "as the real pairs' does (and any bend of the real relation off the line is kept); the pipeline's modelled "
    "mesh step assumes one residual spread, so this population tests that assumption.",
}
METRICS = ml.METRICS
COLUMNS = (*METRICS, "front_x_m", "rear_x_m")
MODES = ("normal", "sabotage")
QUANTITIES = ("mean", "0.5", "0.1", "0.01")  # the mean runout; the runout exceeded with P


def population_cheap(config: dict, size: int) -> tuple[dict[str, np.ndarray], float]:
    """The tuned model's columns on realizations 0 … size − 1 of the case (cached), and its seconds per
    realization (run_realizations on one thread, in chunks of montecarlo.chunk_size)."""
    if CACHE.exists():
        cached = np.load(CACHE)
        if int(cached["size"]) == size and int(cached["seed"]) == int(config["seed"]):
            return {key: cached[key] for key in (*COLUMNS, "index", "ok")}, float(cached["seconds"])
    torch.set_num_threads(1)
    settings = replace(ml.run_settings(config), simulator="endstate")
    inputs = CaseInputs.from_config(config, CASE)
    model = load_model(TUNED)
    chunk = int(config["montecarlo"]["chunk_size"])
    tables = []
    start = time.perf_counter()
    for first in range(0, size, chunk):
        tables.append(run_realizations(inputs, list(range(first, min(first + chunk, size))), settings, model))
        print(f"cheap: {first + len(tables[-1])} of {size} realizations", flush=True)
    seconds = (time.perf_counter() - start) / size
    table = pd.concat(tables, ignore_index=True)
    columns = {key: table[key].to_numpy(float) for key in COLUMNS}
    columns["index"] = table["index"].to_numpy(int)
    columns["ok"] = table["status"].isin(["ok"]).to_numpy()
    np.savez(CACHE, size=size, seed=int(config["seed"]), seconds=seconds, **columns)
    return columns, seconds


def real_triples(config: dict) -> dict[str, Any]:
    """The 128 real (cheap, MPM 0.5 m, MPM 1 m) values per column, the meshes' toe and crest."""
    ml.RUNS = ml.GPU_RUNS
    indices, _, _ = ml.saved(CASE, [1.0, 0.5], REAL)
    assert np.array_equal(indices, np.arange(REAL)), "the GPU runs lack realizations"
    runs = ml.load_runs(ml.GPU_RUNS)
    rows = {h: [runs[CASE, h, int(i)] for i in indices] for h in (0.5, 1.0)}
    cheap, _ = cheap_route.run_model(TUNED, config, CaseInputs.from_config(config, CASE))
    frame = {h: pd.DataFrame(level) for h, level in rows.items()}
    result: dict[str, Any] = {
        key: np.stack([cheap[key], *(frame[h][key].to_numpy(float) for h in (0.5, 1.0))]) for key in METRICS
    }
    for h in (0.5, 1.0):
        for column in ("toe_x_m", "crest_x_m"):
            values = frame[h][column].to_numpy(float)
            assert np.ptp(values) < 1e-9, f"{column} varies over the realizations at {h} m"
            result[f"{column}_{h:g}"] = float(values[0])
    return result


def cpu_seconds(cell: float) -> float:
    """The MPM's seconds per realization at ``cell`` on one CPU thread (benchmarks/results/mesh_levels_runs.jsonl)."""
    runs = ml.load_runs(ml.CPU_RUNS)
    return float(np.mean([runs[CASE, cell, i]["seconds"] for i in sorted(ml.indices_at(runs, CASE, cell))]))


def pearson(x: np.ndarray, y: np.ndarray) -> float:
    return float(np.corrcoef(x, y)[0, 1])


def calibrate(real: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Per metric the least-squares lines of the 0.5 m and 1 m MPM on the cheap value, their residuals [2, 128]
    and the real correlations."""
    calibration = {}
    for key in METRICS:
        cheap, half, one = real[key]
        fits = [np.polyfit(cheap, level, 1) for level in (half, one)]
        residuals = np.stack([level - np.polyval(fit, cheap) for level, fit in zip((half, one), fits)])
        calibration[key] = {
            "slope_0.5": float(fits[0][0]),
            "intercept_0.5": float(fits[0][1]),
            "slope_1": float(fits[1][0]),
            "intercept_1": float(fits[1][1]),
            "residual_sd_0.5": float(residuals[0].std(ddof=2)),
            "residual_sd_1": float(residuals[1].std(ddof=2)),
            "residuals": residuals,
            "real": correlations(cheap, half, one, residuals),
        }
    return calibration


def correlations(cheap: np.ndarray, half: np.ndarray, one: np.ndarray, residuals: np.ndarray) -> dict[str, float]:
    """The correlations that set the estimators' variance, and the mesh step's spread."""
    return {
        "r_cheap_0.5": pearson(cheap, half),
        "r_cheap_1": pearson(cheap, one),
        "r_0.5_1": pearson(half, one),
        "r_residuals": pearson(residuals[0], residuals[1]),
        "sd_0.5_minus_1": float(np.std(half - one, ddof=1)),
        "mean_0.5": float(half.mean()),
        "mean_1": float(one.mean()),
        "mean_cheap": float(cheap.mean()),
    }


def synthesize(
    cheap: dict[str, np.ndarray], calibration: dict, real: dict[str, Any], seed: int
) -> dict[str, dict[str, np.ndarray]]:
    """The population: per level ("cheap", 0.5, 1.0) its columns; the MPM's from the fitted lines plus one real
    realization's residuals per member, drawn for every metric and both meshes together."""
    finite = cheap["ok"] & np.all([np.isfinite(cheap[key]) for key in COLUMNS], axis=0)
    low = {key: cheap[key][finite] for key in COLUMNS}
    donor = np.random.default_rng(seed).integers(0, REAL, len(low["runout_m"]))
    population: dict[str, dict[str, Any]] = {"cheap": low, "0.5": {}, "1": {}, "lines": {"0.5": {}, "1": {}}}
    for key in METRICS:
        c = calibration[key]
        for level, row in (("0.5", 0), ("1", 1)):
            fitted = c[f"intercept_{level}"] + c[f"slope_{level}"] * low[key]
            population["lines"][level][key] = fitted
            population[level][key] = fitted + c["residuals"][row][donor]
    population["residuals"] = {key: calibration[key]["residuals"] for key in METRICS}
    population["ends"] = {
        level: {name: real[f"{name}_{level}"] for name in ("toe_x_m", "crest_x_m")} for level in ("0.5", "1")
    }
    for level in ("0.5", "1"):
        ends_at(population[level], population["ends"][level])
    return population


def ends_at(values: dict[str, np.ndarray], ends: dict[str, float]) -> None:
    """front_x_m and rear_x_m from the runout and the influence at a mesh's own toe and crest."""
    values["front_x_m"] = ends["toe_x_m"] + values["runout_m"]
    values["rear_x_m"] = ends["crest_x_m"] - values["influence_m"]


def superpopulation(population: dict[str, Any], level: str, key: str) -> np.ndarray:
    """Every member's fitted value with each residual it may draw (``population["donors"]``): the
    superpopulation a member with a fresh residual is drawn from (members x donors values, equally likely)."""
    row = 0 if level == "0.5" else 1
    return (population["lines"][level][key][:, None] + population["residuals"][key][row][population["donors"]]).ravel()


def donor_sets(population: dict[str, Any], real_cheap: np.ndarray, local: int | None) -> np.ndarray:
    """Per member the real realizations whose residuals it may draw [members, k]: every one (k = REAL), or with
    ``local`` the ``local`` nearest to it in cheap runout, so that the residuals' spread follows the cheap value
    as the real pairs' does (sd 0.28 m below and 0.43 m above the median at 0.5 m)."""
    size = len(population["cheap"]["runout_m"])
    if local is None:
        return np.tile(np.arange(REAL), (size, 1))
    distance = np.abs(population["cheap"]["runout_m"][:, None] - real_cheap[None, :])
    return np.argsort(distance, axis=1, kind="stable")[:, :local]


def sabotaged(population: dict[str, dict[str, np.ndarray]], seed: int) -> dict[str, dict[str, np.ndarray]]:
    """The population with the cheap rows permuted across its members: a cheap route unrelated to the MPM."""
    order = np.random.default_rng(seed).permutation(len(population["cheap"]["runout_m"]))
    return population | {"cheap": {key: values[order] for key, values in population["cheap"].items()}}


def answers(half: np.ndarray, one: np.ndarray, settings: dict) -> dict[str, dict[str, float]]:
    """The known answers per quantity of a population whose runouts at 0.5 m and 1 m are ``half`` and ``one``:
    at each mesh and converged (the chain's target), at the order's point value, every distance by
    :func:`rgns.hazard.exceedance.sample_distance`."""
    order = float(settings["mesh_order"]["runout_m"][1])
    ratio = float(settings["coarse_cell_size_m"]) / float(settings["high_cell_size_m"])
    result = {
        "mean": {
            "accurate": float(half.mean()),
            "coarse": float(one.mean()),
            "converged": float(half.mean() + richardson_step(half.mean(), one.mean(), ratio, order)),
        }
    }
    for p in QUANTITIES[1:]:
        accurate, coarse = (sample_distance(values, float(p)) for values in (half, one))
        step = float(richardson_step(accurate, coarse, ratio, order))
        result[p] = {"accurate": accurate, "coarse": coarse, "converged": accurate + step}
    return result


def tables(
    population: dict[str, dict[str, np.ndarray]], settings: dict, rng: np.random.Generator
) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame, dict]:
    """One replicate's cheap table (N members drawn with replacement, realizations 0 … N − 1), the pairs' plan
    (rule paired_plan) and their rows at the accurate and the coarse mesh: the members' own (a finite
    population) or, with ``population["fresh"]``, their fitted values plus a real residual drawn afresh (the
    superpopulation)."""
    size, big_n = len(population["cheap"]["runout_m"]), int(settings["realizations"])
    picks = rng.integers(0, size, big_n)

    def table(level: str, rows: np.ndarray, index: np.ndarray) -> pd.DataFrame:
        return pd.DataFrame({"index": index, "status": "ok"} | {k: population[level][k][rows] for k in COLUMNS})

    low = table("cheap", picks, np.arange(big_n))
    plan = design_pairs(
        low["index"].to_numpy(),
        low["runout_m"].to_numpy(float),
        int(settings["paired"]),
        list(settings["strata"]),
        int(settings["min_per_stratum"]),
        int(rng.integers(0, 2**31)),
    ).to_record()
    chosen = np.asarray(plan["indices"])
    if not population["fresh"]:
        high, coarse = (table(level, picks[chosen], chosen) for level in ("0.5", "1"))
        return low, high, coarse, plan
    allowed = population["donors"][picks[chosen]]  # each pair a new realization: its residuals drawn afresh
    donors = allowed[np.arange(chosen.size), rng.integers(0, allowed.shape[1], chosen.size)]

    def fresh(level: str) -> pd.DataFrame:
        row = 0 if level == "0.5" else 1
        values = {
            k: population["lines"][level][k][picks[chosen]] + population["residuals"][k][row][donors] for k in METRICS
        }
        ends_at(values, population["ends"][level])
        return pd.DataFrame({"index": chosen, "status": "ok"} | {k: values[k] for k in COLUMNS})

    return low, fresh("0.5"), fresh("1"), plan


def runout_correction(
    low: pd.DataFrame,
    high: pd.DataFrame,
    settings: dict,
    cost: dict[str, float],
    seed: int,
    design: dict,
    grids: dict[str, list[float]] | None = None,
) -> dict[str, Any]:
    """What ``rgns.fidelity.outputs.correct`` records that the runout's converged estimates and the allocation
    read, by the same calls: the corrected mean runout's correlation (its control variate) → the allocation,
    and the runout's exceedance curve (regression control variate, rearranged, its distances). The rest of
    ``correct`` (volume, influence, their curves, the zoning, the pairs' validation: three quarters of its time)
    changes none of them; :func:`check` asserts that the full path gives the same numbers."""
    low, high = paired_rows(low, high)
    n, confidence, key = len(high), settings["confidence"], "runout_m"
    strata = row_strata(design, low["index"].tolist(), n)
    mean = control_variate(
        high[[key]].to_numpy(float), low[[key]].to_numpy(float), confidence, seed=seed, strata=strata
    )
    d_m = np.asarray(grids[key]) if grids else distance_grid(pd.concat([low[key], high[key]]).to_numpy(float))
    curve = regression_control_variate(
        high[key].to_numpy(float), low[key].to_numpy(float), d_m, confidence=confidence, seed=seed, strata=strata
    )
    corrected = rearranged(curve.estimate)
    exceedance = {
        "d_m": d_m.tolist(),
        "corrected": corrected.tolist(),
        "lower": rearranged(curve.lower).tolist(),
        "upper": rearranged(curve.upper).tolist(),
        "distances": {
            str(p): {"corrected": distance_at(d_m, corrected, p)} for p in settings["exceedance_probabilities"]
        },
    }
    rho = float(np.nan_to_num(np.asarray(mean.correlation).tolist()[0]))
    allocation = route(cost["high_s"], cost["low_s"], rho, len(high), confidence)
    means = {key: {name: float(getattr(mean, name)[0]) for name in ("estimate", "lower", "upper", "weight")}}
    record = {"exceedance": {key: exceedance}, "allocation": allocation, "means": means}
    return record | {"n_paired": n, "confidence": confidence}


def run_replicate(
    population: dict, settings: dict, cost: dict[str, float], rng: np.random.Generator, seed: int, full: bool = False
) -> dict:
    """One replicate through rule multifidelity's estimators: per quantity the estimate, the interval at the
    order's value and the report's, the accurate-mesh estimate and its interval; the allocation. ``full``: the
    whole ``correct``; else :func:`runout_correction`."""
    low, high, coarse, plan = tables(population, settings, rng)
    record = best_estimate(low, high, coarse, settings, cost, plan, seed, correct if full else runout_correction)
    chain = record["converged"]
    plain = record.get("route_applied") == "plain MPM"
    mean = chain["means"]["runout_m"]
    found: dict[str, Any] = {
        "mean": {
            "estimate": mean["estimate"],
            "at_order": mean["interval_at_order"],
            "report": [mean["lower"], mean["upper"]],
            "accurate": mean["accurate"],
            "accurate_interval": [mean["accurate_lower"], mean["accurate_upper"]],
        }
    }
    for p in QUANTITIES[1:]:
        entry = chain["distances"]["runout_m"][p]
        found[p] = {
            "estimate": entry["estimate"],
            "at_order": entry["interval_at_order"],
            "report": [entry["lower"], entry["upper"]],
            "accurate": entry["accurate"],
            "accurate_interval": entry["accurate_band"],
        }
    allocation = record["allocation"]
    keys = ("route", "reason", "correlation_runout", "speedup_at_equal_error")
    found["allocation"] = {key: allocation[key] for key in keys} | {"applied": "plain MPM" if plain else None}
    return found


def point_replicate(population: dict, settings: dict, rng: np.random.Generator) -> np.ndarray:
    """One replicate's converged runout exceeded with each P and its mesh step, as rule multifidelity estimates
    them (rgns.fidelity.mesh_extrapolation.point_distances on the grid runout_correction reads the curve on),
    without the intervals → [2, P]."""
    low, high, coarse, plan = tables(population, settings, rng)
    d_m = distance_grid(pd.concat([low["runout_m"], high["runout_m"]]).to_numpy(float))
    high, coarse, low = nested_levels(low, high, coarse)
    ratio = float(settings["coarse_cell_size_m"]) / float(settings["high_cell_size_m"])
    order = np.asarray([float(settings["mesh_order"]["runout_m"][1])])
    strata = row_strata(plan, low["index"].tolist(), len(high))
    values = (t["runout_m"].to_numpy(float) for t in (high, coarse, low))
    probabilities = [float(p) for p in QUANTITIES[1:]]
    return point_distances(*values, d_m, probabilities, ratio, order, strata)[:2, 0, :]


def points(population: dict, settings: dict, truth: dict, seed: int, replicates: int, sabotage: bool) -> dict:
    """:func:`point_replicate` over ``replicates`` replicates (replicate r drawn as coverage replicate r is):
    per probability the converged estimate's and its parts' bias against the answer, sd, and the parts'
    correlation."""
    found = np.array(
        [
            point_replicate(population, settings, np.random.default_rng([seed, r, int(sabotage)]))
            for r in range(replicates)
        ]
    )  # [R, 2, P]
    record = {}
    for j, p in enumerate(QUANTITIES[1:]):
        estimate, step = found[:, 0, j], found[:, 1, j]
        accurate = estimate - step
        answer = truth[p]
        parts = {
            "converged": (estimate, answer["converged"]),
            "accurate": (accurate, answer["accurate"]),
            "step": (step, answer["converged"] - answer["accurate"]),
        }
        record[p] = {
            name: {"bias": float(np.mean(v) - a), "sd": float(np.std(v, ddof=1))} for name, (v, a) in parts.items()
        } | {"correlation": pearson(accurate, step)}
    return record


def check(population: dict, settings: dict, cost: dict[str, float], rng_seed: list[int], seed: int) -> dict:
    """One replicate by the fast path and by the full one (``correct`` whole): the fast
    one's record, after asserting that both give the same numbers."""
    fast = run_replicate(population, settings, cost, np.random.default_rng(rng_seed), seed)
    full = run_replicate(population, settings, cost, np.random.default_rng(rng_seed), seed, full=True)
    assert fast == full, f"the fast path differs from the full one:\n{fast}\n{full}"
    return fast


def checkpoint(result: dict, path: Path) -> None:
    """The results so far, written atomically to ``path``."""
    temporary = path.with_suffix(".json.tmp")
    temporary.write_text(json.dumps(result, indent=1) + "\n")
    os.replace(temporary, path)


def merged(path: Path, name: str, result: dict) -> dict:
    """``result`` with the file's other mode and findings kept as the file now holds them, and both modes'
    commands: a normal and a sabotage run of one population may write the same file at once, each only its own
    mode, while its findings are edited."""
    current = json.loads(path.read_text()) if path.exists() else {}
    if current.get("meta", {}).get("population_seed") != result["meta"].get("population_seed"):
        return result
    commands = {*current["meta"].get("commands", []), *result["meta"]["commands"]}
    other = {key: value for key, value in current.items() if (key in MODES and key != name) or key == "findings"}
    meta = result["meta"] | {"commands": sorted(commands, key=lambda c: "--sabotage" in c)}
    return result | other | {"meta": meta}


def merge_parts(path: Path, name: str) -> None:
    """Append to ``path``'s mode ``name`` each part file (``--first``) that continues it, in order, and remove
    the part; a part may overlap the replicates (those it repeats are the same draws, and are skipped); one that
    starts past their end is left where it is, and said."""
    result = json.loads(path.read_text())
    mode = result[name]

    def first_of(part_path: Path) -> int:  # the part's first replicate: its name's "_from<K>"
        return int(part_path.stem.rsplit("_from", 1)[1])

    for part_path in sorted(path.parent.glob(f"{path.stem}_from*.json"), key=first_of):
        part = json.loads(part_path.read_text()).get(name, {})
        first = first_of(part_path)
        if part.get("seed") != mode["seed"] or first > len(mode["replicates"]):
            print(
                f"{part_path.name}: seed {part.get('seed')} from {first}; the run holds {len(mode['replicates'])} "
                f"of seed {mode['seed']}: left as it is"
            )
            continue
        skip = len(mode["replicates"]) - first
        if part["replicates"][:skip] != mode["replicates"][first:]:
            print(f"{part_path.name}: its replicates {first}-{first + skip - 1} differ from the run's: left as it is")
            continue
        mode["replicates"] += part["replicates"][skip:]
        mode["seconds"] += part["seconds"][skip:]
        mode["commits"] = sorted({*mode["commits"], *part["commits"]})
        mode["seconds_per_replicate"] = float(np.median(mode["seconds"]))
        checkpoint(result, path)
        part_path.unlink()
        part_path.with_suffix(".md").unlink(missing_ok=True)
        print(
            f"{part_path.name}: {len(part['replicates'][skip:])} replicates appended ({len(mode['replicates'])} in all)"
        )


def verdict(interval: list[float | None], answer: float) -> str:
    """ "in", "below" (the interval lies below the answer), "above", "open in" (open above, its lower end at
    most the answer: a one-sided interval that holds it), or "open" (else an end left open)."""
    lower, upper = interval
    if lower is not None and upper is None:
        return "above" if lower > answer else "open in"
    if lower is None or upper is None:
        return "open"
    return "below" if upper < answer else "above" if lower > answer else "in"


def summary(records: list[dict], truth: dict[str, dict[str, float]]) -> dict[str, dict]:
    """Per quantity, target and interval: coverage with its binomial SE, misses below and above, open
    intervals, the mean half-width; the estimate's mean error."""
    count = len(records)
    se = float(np.sqrt(0.95 * 0.05 / max(count, 1)))
    result: dict[str, dict] = {}
    for quantity in QUANTITIES:
        rows = [r[quantity] for r in records]
        known = truth[quantity]
        targets = {"converged": known["converged"]}
        estimates = np.array([np.nan if r["estimate"] is None else r["estimate"] for r in rows], dtype=float)
        entry: dict[str, Any] = {"replicates": count, "se": se, "mean_estimate": float(np.nanmean(estimates))}
        for target, answer in targets.items():
            errors = estimates - answer
            finite = int(np.isfinite(errors).sum())
            entry[target] = {
                "answer": answer,
                "mean_error": float(np.nanmean(errors)),
                "error_se": float(np.nanstd(errors, ddof=1) / np.sqrt(finite)) if finite > 1 else float("nan"),
            }
            for interval in ("at_order", "report"):
                outcomes = [verdict(r[interval], answer) for r in rows]
                entry[target][interval] = tally(outcomes, [r[interval] for r in rows], se)
        accurate = known["accurate"]
        entry["decomposition"] = decomposition(rows, accurate, known["converged"] - accurate)
        outcomes = [verdict(r["accurate_interval"], accurate) for r in rows]
        entry["accurate"] = {"answer": accurate} | tally(outcomes, [r["accurate_interval"] for r in rows], se)
        result[quantity] = entry
    return result


def decomposition(rows: list[dict], accurate: float, step: float) -> dict[str, Any]:
    """The estimate's error split: its accurate-mesh part (the corrected 0.5 m value against the population's)
    and its mesh step (estimate − accurate part, against the population's step), each mean ± SE."""
    values = np.array([[np.nan if v is None else v for v in (r["accurate"], r["estimate"])] for r in rows], dtype=float)
    parts = {"accurate_error": values[:, 0] - accurate, "step_error": values[:, 1] - values[:, 0] - step}
    result: dict[str, Any] = {"step_answer": step}
    for name, errors in parts.items():
        finite = errors[np.isfinite(errors)]
        se = float(finite.std(ddof=1) / np.sqrt(finite.size)) if finite.size > 1 else float("nan")
        result[name] = [float(finite.mean()) if finite.size else float("nan"), se]
    return result


def tally(outcomes: list[str], intervals: list[list[float | None]], se: float) -> dict[str, Any]:
    """Coverage of one interval over the replicates."""
    coverage = (outcomes.count("in") + outcomes.count("open in")) / max(len(outcomes), 1)
    widths = [(u - lo) / 2.0 for lo, u in intervals if lo is not None and u is not None]
    return {
        "coverage": coverage,
        "within_3se": bool(abs(coverage - 0.95) <= 3 * se),
        "below": outcomes.count("below"),
        "above": outcomes.count("above"),
        "open": outcomes.count("open") + outcomes.count("open in"),
        "open_in": outcomes.count("open in"),
        "half_width": float(np.mean(widths)) if widths else float("nan"),
    }


def allocation_summary(records: list[dict], meta: dict[str, Any]) -> dict[str, Any]:
    """How often the allocation says each route, the correlation's spread, a reason of each route: the route
    as rgns.fidelity.multifidelity.route decides it now, from each replicate's paired correlation (so a
    change of the rule re-reads the replicates without re-running them)."""
    design = meta["design"]
    decided = [
        route(meta["cost"]["high_s"], meta["cost"]["low_s"], r["allocation"]["correlation_runout"],
              design["paired"], design["confidence"])
        for r in records
    ]  # fmt: skip
    routes = [a["route"] for a in decided]
    rho = np.array([a["correlation_runout"] for a in decided], dtype=float)
    return {
        "routes": {name: routes.count(name) for name in sorted(set(routes))},
        "correlation_mean": float(rho.mean()),
        "correlation_range": [float(rho.min()), float(rho.max())],
        "reasons": {a["route"]: a["reason"] for a in decided},
    }


def fmt(value: float | None, digits: int = 2) -> str:
    return "open" if value is None or not np.isfinite(value) else f"{value:.{digits}f}"


def cell(c: dict, se: str) -> str:
    """One interval's cells: coverage, within 3 SE, misses, mean half-width."""
    within = "yes" if c["within_3se"] else "NO"
    return f"{c['coverage']:.3f}{se} | {within} | {c['below']} / {c['above']} / {c['open']} | {fmt(c['half_width'], 3)}"


def coverage_table(mode: dict) -> list[str]:
    """The coverage table of one mode: per quantity and target, the interval at the order's value (sampling)
    and the report's (the envelope over the order's interval)."""
    lines = [
        "| quantity | target | known answer | mean estimate (error ± 2 SE) | sampling interval: coverage (SE) | "
        "within 3 SE of 95 % | misses below / above / open | mean half-width | report's interval: coverage | "
        "within 3 SE | misses below / above / open | mean half-width |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    names = {"mean": "mean runout", **{p: f"R exceeded with P {p}" for p in QUANTITIES[1:]}}
    targets = {"converged": "chain's target"}
    for quantity, entry in mode["summary"].items():
        for target, label in targets.items():
            if target not in entry:
                continue
            row = entry[target]
            se = f" ({entry['se']:.3f})"
            cells = [cell(row["at_order"], se), cell(row["report"], "")]
            lines.append(
                f"| {names[quantity]} | {label} | {row['answer']:.3f} | {entry['mean_estimate']:.3f} "
                f"({row['mean_error']:+.3f} ± {2 * row['error_se']:.3f}) | {cells[0]} | {cells[1]} |"
            )
    return lines


def accurate_table(mode: dict) -> list[str]:
    lines = [
        "| quantity | answer at 0.5 m | interval | coverage (SE) | within 3 SE | misses below / above / open | "
        "mean half-width |",
        "|---|---|---|---|---|---|---|",
    ]
    for quantity, entry in mode["summary"].items():
        row = entry["accurate"]
        name = "mean runout" if quantity == "mean" else f"R exceeded with P {quantity}"
        interval = "multilevel (converged's accurate_lower/upper)" if quantity == "mean" else "corrected curve's band"
        lines.append(
            f"| {name} | {row['answer']:.3f} | {interval} | {row['coverage']:.3f} ({entry['se']:.3f}) | "
            f"{'yes' if row['within_3se'] else 'NO'} | {row['below']} / {row['above']} / {row['open']} | "
            f"{fmt(row['half_width'], 3)} |"
        )
    return lines


def write_report(result: dict, path: Path) -> None:
    """The md from the json, to ``path``."""
    meta = result["meta"]
    lines = [
        f"# Coverage of the {'stratified' if meta['design']['strata'] else 'default'} design: 10,000 cheap "
        f"realizations, 32 {'stratified' if meta['design']['strata'] else 'random'} MPM pairs (case 1)",
        "",
        "**The population is SYNTHETIC, CALIBRATED ON REAL PAIRS** (no GPU ran 10,000 MPM pairs): the cheap values "
        f"are the tuned end-state surrogate's on case 1's realizations 0-{meta['population'] - 1} (run here as the "
        "pipeline runs it), the MPM values at 0.5 and 1 m a least-squares line of each on the cheap value plus "
        f"residuals bootstrapped jointly (per member one real realization's residuals of every metric at both meshes) "
        f"from the {REAL} real triples of `benchmarks/results/mesh_levels_gpu_runs.jsonl` (realizations 0-{REAL - 1}). Method: the "
        "docstring of `benchmarks/pair_coverage.py`.",
        "",
        POPULATION_TEXT[meta.get("population_kind", "finite")],
        "",
        "Commands (one thread, `nice -n 19`, on a 2-core machine shared with a timed run):",
        "",
        "```",
        *meta["commands"],
        "```",
        "",
        f"Design (config/config.yaml): N = {meta['design']['realizations']} cheap ({meta['design']['cheap']}), "
        f"{meta['design']['paired']} pairs, strata {meta['design']['strata']} "
        f"({'in strata of the cheap runout at these quantiles' if meta['design']['strata'] else 'a simple random subsample'}), accurate "
        f"MPM at {meta['design']['high_cell_size_m']} m, coarse partner at {meta['design']['coarse_cell_size_m']} m, "
        f"order of the runout {meta['design']['order'][1]} [{meta['design']['order'][0]}, {meta['design']['order'][2]}]"
        f", confidence {meta['design']['confidence']}. Costs given to the allocation: {meta['cost']['high_s']:.1f} s "
        f"per 0.5 m MPM realization (one CPU thread, `benchmarks/results/mesh_levels_runs.jsonl`), {meta['cost']['low_s']:.4f} s "
        "per cheap one (timed here).",
        "",
        "## Calibration on the real pairs",
        "",
        "| metric | 0.5 m = a + b·cheap | residual sd | 1 m = c + d·cheap | residual sd | r(cheap, 0.5 m) real / "
        "synthetic | r(cheap, 1 m) real / synthetic | r(0.5 m, 1 m) real / synthetic | r of the residuals real / "
        "synthetic | sd(0.5 m − 1 m) real / synthetic |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for key, c in meta["calibration"].items():
        real, synthetic = c["real"], c["synthetic"]
        pair = " | ".join(
            f"{real[name]:.3f} / {synthetic[name]:.3f}"
            for name in ("r_cheap_0.5", "r_cheap_1", "r_0.5_1", "r_residuals", "sd_0.5_minus_1")
        )
        lines.append(
            f"| {key} | {c['intercept_0.5']:.3f} + {c['slope_0.5']:.3f}·cheap | {c['residual_sd_0.5']:.3f} | "
            f"{c['intercept_1']:.3f} + {c['slope_1']:.3f}·cheap | {c['residual_sd_1']:.3f} | {pair} |"
        )
    pop = meta["population_stats"]
    lines += [
        "",
        f"Population: {meta['population']} members ({meta['dropped']} cheap runs left out: not finished or not "
        f"finite). Cheap runout over the population: mean {pop['cheap_mean']:.3f} m, 1st / 99th percentile "
        f"{pop['cheap_p01']:.2f} / {pop['cheap_p99']:.2f} m; over the real {REAL}: {pop['real_cheap_p01']:.2f} / "
        f"{pop['real_cheap_p99']:.2f} m (their range {pop['real_cheap_min']:.2f}-{pop['real_cheap_max']:.2f} m): "
        "the population's tail beyond it rests on the fitted line's extrapolation and the real residuals.",
        "",
        "Known answers (runout, m):",
        "",
        "| quantity | 0.5 m | 1 m | converged: chain's target |",
        "|---|---|---|---|",
    ]
    for quantity, t in meta["answers"].items():
        name = "mean" if quantity == "mean" else f"exceeded with P {quantity}"
        lines.append(f"| {name} | {t['accurate']:.3f} | {t['coarse']:.3f} | {t['converged']:.3f} |")
    for mode_name in MODES:
        mode = result.get(mode_name)
        if not mode or not mode.get("replicates"):
            continue
        title = "Normal" if mode_name == "normal" else "Sabotage: the cheap rows permuted across realizations"
        lines += [
            "",
            f"## {title}: {len(mode['replicates'])} replicates (seed {mode['seed']}, commit "
            f"{', '.join(mode.get('commits', ['not recorded']))})",
            "",
            f"Wall seconds per replicate on one thread: median {np.median(mode['seconds']):.1f}, mean "
            f"{np.mean(mode['seconds']):.1f} "
            "(the mean holds the spells when the process was paused while a timed run used both cores). "
            "Coverage of the converged answer:",
            "",
            *coverage_table(mode),
            "",
            "At the accurate mesh (0.5 m) alone, the corrected estimate against the population's 0.5 m answer:",
            "",
            *accurate_table(mode),
        ]
        lines += [
            "",
            "The converged estimate's error, split into its accurate-mesh part and its mesh step (mean ± 2 SE, m):",
            "",
            "| quantity | accurate part − 0.5 m answer | mesh step − the population's step | the population's step |",
            "|---|---|---|---|",
        ]
        for quantity, entry in mode["summary"].items():
            d = entry["decomposition"]
            name = "mean runout" if quantity == "mean" else f"R exceeded with P {quantity}"
            accurate, step = d["accurate_error"], d["step_error"]
            lines.append(
                f"| {name} | {accurate[0]:+.3f} ± {2 * accurate[1]:.3f} | {step[0]:+.3f} ± {2 * step[1]:.3f} | "
                f"{d['step_answer']:.3f} |"
            )
        allocation = mode["allocation"]
        lines += [
            "",
            'Allocation (`multifidelity.json`\'s "allocation", `rgns.fidelity.multifidelity.route`): '
            + ", ".join(f'"{name}" in {count}' for name, count in allocation["routes"].items())
            + f" of {len(mode['replicates'])} replicates; paired correlation of the runout "
            f"{allocation['correlation_mean']:.3f} on average ({allocation['correlation_range'][0]:.3f} to "
            f"{allocation['correlation_range'][1]:.3f}).",
        ]
        for name, reason in allocation["reasons"].items():
            lines.append(f'* {name}, e.g.: "{reason}"')
    if all(result.get(name, {}).get("replicates") for name in MODES):
        lines += [
            "",
            "## Sabotage against normal: mean half-widths (m)",
            "",
            "| quantity | interval | normal | sabotage | ratio |",
            "|---|---|---|---|---|",
        ]
        for quantity in QUANTITIES:
            for interval, label in (("at_order", "sampling"), ("report", "report's")):
                widths = [result[name]["summary"][quantity]["converged"][interval]["half_width"] for name in MODES]
                name = "mean runout" if quantity == "mean" else f"R exceeded with P {quantity}"
                lines.append(f"| {name} | {label} | {widths[0]:.3f} | {widths[1]:.3f} | {widths[1] / widths[0]:.2f} |")
    if result.get("findings"):
        lines += ["", "## What it says", "", *result["findings"]]
    lines.append("")
    path.write_text("\n".join(lines))


def prepare(args: argparse.Namespace) -> tuple[dict, dict, dict, dict]:
    """Settings, the population (sabotaged with --sabotage), its answers, and the results' meta."""
    config = load_config(REPO / "config" / "config.yaml")
    settings = ml.pipeline_settings(config) | {"realizations": int(config["montecarlo"]["realizations"])}
    cheap, cheap_s = population_cheap(config, int(config["montecarlo"]["realizations"]))
    real = real_triples(config)
    for key in METRICS:  # the population's first realizations are the real ones: the same cheap values
        assert np.allclose(cheap[key][:REAL], real[key][0], equal_nan=True), f"cheap {key} differs from cheap_route's"
    calibration = calibrate(real)
    population = synthesize(cheap, calibration, real, args.population_seed)
    population["fresh"] = args.population != "finite"
    population["donors"] = donor_sets(population, real["runout_m"][0], LOCAL if args.population == "local" else None)
    for key in METRICS:
        residuals = np.stack(
            [
                population[level][key]
                - np.polyval(np.polyfit(population["cheap"][key], population[level][key], 1), population["cheap"][key])
                for level in ("0.5", "1")
            ]
        )
        calibration[key]["synthetic"] = correlations(
            population["cheap"][key], population["0.5"][key], population["1"][key], residuals
        )
    cost = {"high_s": cpu_seconds(0.5), "low_s": cheap_s}
    if population["fresh"]:
        truth = answers(*(superpopulation(population, level, "runout_m") for level in ("0.5", "1")), settings)
    else:
        truth = answers(population["0.5"]["runout_m"], population["1"]["runout_m"], settings)
    size = len(population["cheap"]["runout_m"])
    runout = population["cheap"]["runout_m"]
    meta = {
        "design": {
            "realizations": settings["realizations"],
            "cheap": settings["cheap"],
            "paired": settings["paired"],
            "strata": settings["strata"],
            "high_cell_size_m": settings["high_cell_size_m"],
            "coarse_cell_size_m": settings["coarse_cell_size_m"],
            "order": settings["mesh_order"]["runout_m"],
            "confidence": settings["confidence"],
        },
        "population": size,
        "dropped": int(len(cheap["runout_m"]) - size),
        "population_seed": args.population_seed,
        "population_kind": args.population,
        "cost": cost,
        "calibration": {key: {k: v for k, v in c.items() if k != "residuals"} for key, c in calibration.items()},
        "population_stats": {
            "cheap_mean": float(runout.mean()),
            "cheap_p01": float(np.quantile(runout, 0.01)),
            "cheap_p99": float(np.quantile(runout, 0.99)),
            "real_cheap_p01": float(np.quantile(real["runout_m"][0], 0.01)),
            "real_cheap_p99": float(np.quantile(real["runout_m"][0], 0.99)),
            "real_cheap_min": float(real["runout_m"][0].min()),
            "real_cheap_max": float(real["runout_m"][0].max()),
        },
        "answers": truth,
    }
    return settings, population, truth, meta


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--replicates", type=int, default=200)
    parser.add_argument("--seed", type=int, default=20261201, help="of the replicates' draws and the sabotage")
    parser.add_argument("--population-seed", type=int, default=20261130, help="of the synthetic residuals' draw")
    parser.add_argument("--sabotage", action="store_true", help="the cheap rows permuted across realizations")
    parser.add_argument("--minutes", type=float, default=None, help="stop starting replicates after this long")
    parser.add_argument("--report", action="store_true", help="only write the md from the json")
    parser.add_argument("--points", type=int, default=None, help="only the point estimates, over this many replicates")
    parser.add_argument(
        "--population",
        choices=sorted(POPULATIONS),
        default="super",
        help="super: each pair a new realization of the fitted line plus a real residual (the answers the "
        "superpopulation's); local: the same with residuals from the real realizations nearest in cheap runout; "
        "finite: the members' own residuals, drawn once (the answers the finite population's)",
    )
    parser.add_argument(
        "--first",
        type=int,
        default=None,
        help="a second worker: replicates from this number on, to a part file beside the population's (the "
        "replicates are seeded by number, so a part equals what one run would have drawn); --merge appends it",
    )
    parser.add_argument("--merge", action="store_true", help="append the part files that continue the run, in order")
    parser.add_argument(
        "--strata",
        type=float,
        nargs="*",
        default=None,
        help="the cheap runout's quantiles that bound the pairs' strata (montecarlo.fidelity.strata; default: "
        "the config's); a design other than the config's writes beside the population's files, '_strata' added",
    )
    args = parser.parse_args()
    result_path, report_path = POPULATIONS[args.population]
    if args.strata is not None:
        suffix = "_strata" if args.strata else "_simple"
        result_path, report_path = (p.with_name(p.stem + suffix + p.suffix) for p in (result_path, report_path))
    if args.first is not None:
        result_path, report_path = (
            p.with_name(f"{p.stem}_from{args.first}{p.suffix}") for p in (result_path, report_path)
        )
    if args.merge:
        merge_parts(result_path, "sabotage" if args.sabotage else "normal")
    if args.report or args.merge:  # the summaries recomputed from the replicates, then the md
        result = json.loads(result_path.read_text())
        for name in MODES:
            if result.get(name, {}).get("replicates"):
                mode = result[name]
                mode["summary"] = summary(mode["replicates"], result["meta"]["answers"])
                mode["allocation"] = allocation_summary(mode["replicates"], result["meta"])
        checkpoint(result, result_path)
        write_report(result, report_path)
        print(report_path.read_text())
        return
    torch.set_num_threads(1)
    began = time.perf_counter()
    settings, population, truth, meta = prepare(args)
    if args.strata is not None:
        settings["strata"] = meta["design"]["strata"] = list(args.strata)
    name = "sabotage" if args.sabotage else "normal"
    if args.sabotage:
        population = sabotaged(population, args.seed)  # the answers stand: the MPM values are the same
    if args.points is not None:
        record = points(population, settings, truth, args.seed, args.points, args.sabotage)
        path = OUT / "pair_coverage_points.json"
        saved = json.loads(path.read_text()) if path.exists() else {}
        key = f"{args.population}{'' if args.strata is None else ' strata ' + str(args.strata)}, seed {args.seed}"
        saved[key + (", sabotage" if args.sabotage else "")] = {
            "command": f"OMP_NUM_THREADS=1 .venv/bin/python benchmarks/pair_coverage.py --points {args.points} "
            f"--seed {args.seed} --population {args.population}"
            + (" --sabotage" if args.sabotage else "")
            + ("" if args.strata is None else " --strata " + " ".join(f"{q:g}" for q in args.strata)),
            "commit": commit(),
            "replicates": args.points,
            "design": meta["design"],
            "seconds": time.perf_counter() - began,
            "points": record,
        }
        checkpoint(saved, path)
        print(json.dumps(saved[key + (", sabotage" if args.sabotage else "")], indent=1))
        return
    result = json.loads(result_path.read_text()) if result_path.exists() else {}
    if result.get("meta", {}).get("population_seed") not in (None, args.population_seed):
        result = {}  # another population: start over
    command = (
        f"OMP_NUM_THREADS=1 nice -n 19 .venv/bin/python benchmarks/pair_coverage.py --replicates {args.replicates} "
        f"--seed {args.seed} --population {args.population}"
        + (" --sabotage" if args.sabotage else "")
        + ("" if args.strata is None else " --strata " + " ".join(f"{q:g}" for q in args.strata))
    )
    commands = [c for c in result.get("meta", {}).get("commands", []) if ("--sabotage" in c) != args.sabotage]
    result["meta"] = meta | {"commands": sorted([*commands, command], key=lambda c: "--sabotage" in c)}
    mode = result.get(name, {})
    if mode.get("seed") != args.seed:
        mode = {"seed": args.seed, "replicates": [], "seconds": []}
    mode.setdefault("commits", [])
    running = commit()  # the code this process loaded, which every replicate it runs uses
    mode["design"] = meta["design"]  # a sabotage part is set beside the normal part only under the same design
    result[name] = mode
    print(
        f"{name}: {len(mode['replicates'])} replicates done before; setup {time.perf_counter() - began:.0f} s",
        flush=True,
    )
    start = time.perf_counter()
    for number in range((args.first or 0) + len(mode["replicates"]), args.replicates):
        if args.minutes is not None and time.perf_counter() - start > 60.0 * args.minutes:
            print(f"{name}: stopped after {args.minutes} minutes", flush=True)
            break
        tick = time.perf_counter()
        mode["commits"] = sorted({*mode["commits"], running})  # the code each part ran
        rng_seed = [args.seed, number, int(args.sabotage)]
        if number == 0:  # the fast path against rule multifidelity's own, once per run
            mode["replicates"].append(check(population, settings, meta["cost"], rng_seed, number))
            mode["checked"] = "replicate 0: the fast path's numbers equal those of the full correct()"
            print(f"{name}: {mode['checked']} ({time.perf_counter() - tick:.0f} s for both)", flush=True)
            tick = time.perf_counter()
            run_replicate(population, settings, meta["cost"], np.random.default_rng(rng_seed), number)
        else:
            rng = np.random.default_rng(rng_seed)
            mode["replicates"].append(run_replicate(population, settings, meta["cost"], rng, number))
        mode["seconds"].append(time.perf_counter() - tick)
        mode["seconds_per_replicate"] = float(np.median(mode["seconds"]))
        mode["summary"] = summary(mode["replicates"], truth)
        mode["allocation"] = allocation_summary(mode["replicates"], result["meta"])
        result = merged(result_path, name, result)
        checkpoint(result, result_path)
        print(f"{name}: replicate {number + 1} of {args.replicates}, {mode['seconds'][-1]:.1f} s", flush=True)
    result = merged(result_path, name, result)
    checkpoint(result, result_path)  # a rerun that finds every replicate done records its command too
    write_report(result, report_path)
    print(report_path.read_text())


if __name__ == "__main__":
    main()
