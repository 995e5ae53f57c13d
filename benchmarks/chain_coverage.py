"""The fidelity chain on real runs: its intervals' coverage over resampled replicates, and its allocation.

    python benchmarks/chain_coverage.py                 # writes benchmarks/results/chain_coverage.{md,json}

Population: the default config's case-1 realizations that benchmarks/mesh_levels.py ran at 1, 0.5 and
0.25 m, with the cheap route (the tuned end-state surrogate, run as rule mc_chunk runs route control) evaluated
here on the same realizations. In the resampling world the population is the empirical distribution of
those realizations, so every answer is known:

* the converged mean runout: the population's 0.25 m mean plus the Richardson step from 0.5 to 0.25 m at
  the configured order (montecarlo.fidelity.mesh_order; the direct reference of mesh_levels.md);
* the mean volume and influence, which the chain does not extrapolate (no order measured): their 0.5 m means.

A replicate draws N cheap realizations with replacement, pairs the first n (their 0.5 m and 1 m runs), and
estimates as rgns.fidelity.mesh_extrapolation does: rgns.fidelity.multilevel.extrapolated on the nested levels [0.5 m, 1 m,
cheap] for the runout, rgns.fidelity.multilevel.multilevel for the others. Coverage is the share of replicates whose
interval holds the known answer, with its binomial standard error (SE).

Allocation: for candidate (n pairs, N cheap) the estimate's standard deviation over replicates (the same
estimator, no bootstrap) and its cost from measured seconds per realization (mesh_levels' runs; the cheap
route timed here). The work-variance product cost × sd² is what the cost to reach a given sampling error
scales with; the estimator's interval also widens at few pairs (Hesterberg's expanded level for n pairs,
rgns.fidelity.multifidelity.expanded_level), so candidates are ranked by cost × half-width², half-width = z'(n) sd.
Plain Monte Carlo for the same converged mean runs every realization at 0.25 m and 0.5 m (the pair its own
Richardson step needs); for P(R > r50) at 0.25 m alone.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import pandas as pd
import torch
from mesh_levels import CPU_RUNS, METRICS, exceeded_with, load_runs, pipeline_settings, reference, run_settings, saved  # noqa: E402  (benchmarks/ is the script's own folder)
from scipy import stats

from rgns.config import load_config
from rgns.fidelity.mesh_extrapolation import converged
from rgns.fidelity.multifidelity import expanded_level
from rgns.fidelity.multilevel import extrapolated, mfmc_estimate, multilevel, richardson_step
from rgns.fidelity.outputs import correct
from rgns.hazard.exceedance import sample_distance
from rgns.montecarlo.runs import CaseInputs, run_realizations
from rgns.scene.realizations import accurate_case_inputs
from rgns.surrogates.endstate.model import load_model

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "benchmarks" / "results"
CELLS = [1.0, 0.5, 0.25]
PAIRS = [4, 8, 12, 16, 24, 32, 48]
CHEAP = [256, 1024, 4096]


def cheap_table(config: dict, case: str, indices: np.ndarray) -> tuple[pd.DataFrame, float]:
    """The tuned end-state surrogate's rows on the realizations, and its seconds per realization."""
    torch.set_num_threads(1)
    settings = run_settings(config)
    settings = replace(settings, simulator="endstate")
    inputs = CaseInputs.from_params(asdict(accurate_case_inputs(config, case, float(config["mesh"]["cell_size_m"]))))
    model = load_model(REPO / "rgns" / "models" / "endstate_tuned.pt")
    start = time.perf_counter()
    table = run_realizations(inputs, [int(i) for i in indices], settings, model)
    seconds = (time.perf_counter() - start) / len(indices)
    return table, seconds


def mpm_table(case: str, cell: float, indices: np.ndarray) -> pd.DataFrame:
    """mesh_levels' saved MPM rows of the realizations at ``cell``."""
    runs = load_runs(CPU_RUNS)
    return pd.DataFrame([runs[case, cell, int(i)] for i in indices])


def known_answers(values: dict[str, np.ndarray], order: list[float]) -> dict[str, float]:
    """The population's answers: converged runout (mesh_levels' direct reference), 0.5 m V and I."""
    return {
        "runout_m": reference(values["runout_m"], order)["value"],
        "volume_m2": float(values["volume_m2"][1].mean()),
        "influence_m": float(values["influence_m"][1].mean()),
    }


def replicate_levels(values: dict, cheap: dict, key: str, picks: np.ndarray, n_pairs: int) -> list[np.ndarray]:
    """Nested levels [0.5 m pairs, 1 m pairs, cheap all] of one replicate's drawn realizations."""
    pairs = picks[:n_pairs]
    return [values[key][1][pairs, None], values[key][0][pairs, None], cheap[key][picks, None]]


def coverage(values: dict, cheap: dict, orders: dict, n_pairs: int, n_cheap: int, replicates: int, seed: int) -> dict:
    """Per quantity: the share of replicates whose interval holds the known answer (sampling only, and with
    the order's interval for the runout), the mean half-width, the estimate's mean error."""
    rng = np.random.default_rng(seed)
    population = values["runout_m"].shape[1]
    truth = known_answers(values, orders["runout_m"])
    hits: dict[str, list] = {key: [] for key in [*METRICS, "runout_m (sampling only)"]}
    widths: dict[str, list] = {key: [] for key in hits}
    errors: dict[str, list] = {key: [] for key in hits}
    for replicate in range(replicates):
        picks = rng.integers(0, population, n_cheap)
        for key in METRICS:
            levels = replicate_levels(values, cheap, key, picks, n_pairs)
            if key == "runout_m":
                low, value, high = orders[key]
                runs = {
                    key: extrapolated(levels, 2.0, value, (low, high), seed=replicate),
                    "runout_m (sampling only)": extrapolated(levels, 2.0, value, (value, value), seed=replicate),
                }
                found = {name: (e.estimate[0], e.lower[0], e.upper[0]) for name, e in runs.items()}
            else:
                e = multilevel(levels, seed=replicate)
                found = {key: (e.estimate[0], e.lower[0], e.upper[0])}
            for name, (estimate, lower, upper) in found.items():
                answer = truth[key]
                hits[name].append(lower <= answer <= upper)
                widths[name].append((upper - lower) / 2.0)
                errors[name].append(estimate - answer)
    result = {}
    for name in hits:
        share = float(np.mean(hits[name]))
        result[name] = {
            "answer": truth[name.split(" ")[0]],
            "coverage": share,
            "se": float(np.sqrt(0.95 * 0.05 / replicates)),
            "half_width": float(np.mean(widths[name])),
            "mean_error": float(np.mean(errors[name])),
            "error_se": float(np.std(errors[name], ddof=1) / np.sqrt(replicates)),
        }
    return result


def drawn(table: pd.DataFrame, picks: np.ndarray) -> pd.DataFrame:
    """The rows ``picks`` of a level's table as realizations 0 … len(picks) - 1 (a drawn row is a new one)."""
    return table.iloc[picks].assign(index=np.arange(len(picks))).reset_index(drop=True)


def distance_answers(
    values: dict[str, np.ndarray], probabilities: list[float], order: list[float]
) -> dict[str, dict[str, float]]:
    """Per probability the population's runout exceeded with it, every distance by the pipeline's one estimator
    (rgns.hazard.exceedance.sample_distance): the direct reference (mesh_levels' Richardson fit over the three
    meshes) and the chain's own target in this world (the 0.5 m distance plus the 1 → 0.5 m step)."""
    coarse, half = values["runout_m"][0], values["runout_m"][1]
    answers = {}
    for p in probabilities:
        quantile = exceeded_with(p)
        curve_distance = sample_distance(half, p)
        step = richardson_step(curve_distance, sample_distance(coarse, p), 2.0, order[1])
        answers[str(p)] = {
            "direct": reference(values["runout_m"], order, quantile)["value"],
            "chain_target": curve_distance + float(step),
        }
    return answers


def distance_coverage(
    tables: dict, values: dict, settings: dict, cost: dict, n_pairs: int, n_cheap: int, replicates: int, seed: int
) -> dict:
    """The runout exceeded with each probability as the pipeline estimates it (rgns.fidelity.outputs.correct,
    then rgns.fidelity.mesh_extrapolation.converged) over resampled replicates: coverage of both answers."""
    probabilities = [p for p in settings["exceedance_probabilities"] if p >= 0.1]
    answers = distance_answers(values, probabilities, settings["mesh_order"]["runout_m"])
    rng = np.random.default_rng(seed)
    found: dict[str, list] = {str(p): [] for p in probabilities}
    levels = (("cheap", n_cheap), (0.5, n_pairs), (1.0, n_pairs))
    for replicate in range(replicates):
        picks = rng.integers(0, len(tables["cheap"]), n_cheap)
        low, high, coarse = (drawn(tables[level], picks[:count]) for level, count in levels)
        record = correct(low, high, settings, cost, seed=replicate)
        distances = converged(low, high, coarse, settings, record, seed=replicate)["distances"]["runout_m"]
        for p in found:
            entry = distances[p]
            found[p].append((entry["estimate"], entry["lower"], entry["upper"], *entry["interval_at_order"]))
        if (replicate + 1) % 20 == 0:
            print(f"distances: {replicate + 1} of {replicates} replicates", flush=True)
    result = {}
    for p, rows in found.items():
        estimates = np.array([[np.nan if v is None else v for v in row] for row in rows], dtype=float)
        row = {"replicates": replicates, "bounded": int(np.isfinite(estimates).all(axis=1).sum())}
        for name, answer in answers[p].items():
            inside = (estimates[:, 1] <= answer) & (answer <= estimates[:, 2])
            at_order = (estimates[:, 3] <= answer) & (answer <= estimates[:, 4])
            row[name] = {
                "answer": answer,
                "coverage": float(inside.mean()),
                "coverage_at_order": float(at_order.mean()),
            }
        row["se"] = float(np.sqrt(0.95 * 0.05 / replicates))
        row["half_width"] = float(np.nanmean(estimates[:, 2] - estimates[:, 1]) / 2.0)
        row["half_width_at_order"] = float(np.nanmean(estimates[:, 4] - estimates[:, 3]) / 2.0)
        row["mean_estimate"] = float(np.nanmean(estimates[:, 0]))
        result[p] = row
    return result


def allocation_levels(values: dict, cheap: dict, order: float) -> dict[str, tuple]:
    """Per quantity the population's [0.5 m, 1 m, cheap] values, the order of its Richardson step (None: not
    extrapolated) and its plain Monte Carlo at 0.25 m per realization: the converged mean runout (0.25 m with
    its own step, paired with 0.5 m) and P(R > r50), r50 the 0.5 m runs' median runout (0.25 m alone)."""
    runout, low = values["runout_m"], cheap["runout_m"]
    r50 = float(np.median(runout[1]))
    above = (runout > r50).astype(float)
    return {
        "mean runout, converged": (
            runout[1],
            runout[0],
            low,
            order,
            runout[2] + richardson_step(runout[2], runout[1], 2.0, order),
            True,
        ),
        f"P(R > {r50:.2f} m), 0.5 m": (above[1], above[0], (low > r50).astype(float), None, above[2], False),
    }


def estimate_sd(levels: tuple, n_pairs: int, n_cheap: int, replicates: int, seed: int) -> float:
    """The standard deviation of the chain's estimate over replicates of (n_pairs, n_cheap)."""
    fine, coarse, low, order = levels[:4]
    picks = np.random.default_rng(seed).integers(0, len(fine), (replicates, n_cheap))
    fine, coarse = fine[picks[:, :n_pairs], None], coarse[picks[:, :n_pairs], None]
    estimate = mfmc_estimate([fine, coarse, low[picks, None]], axis=-2)[0]
    if order is not None:
        estimate = estimate + richardson_step(fine.mean(axis=-2), coarse.mean(axis=-2), 2.0, order)
    return float(estimate.std(ddof=1))


def allocation(values: dict, cheap: dict, seconds: dict, order: float, replicates: int, seed: int) -> dict:
    """Per quantity: each candidate's sd, cost, cost × sd² and cost × half-width²; plain Monte Carlo's cost × variance."""
    result = {}
    for name, levels in allocation_levels(values, cheap, order).items():
        rows = []
        for n_pairs in PAIRS:
            for n_cheap in CHEAP:
                sd = estimate_sd(levels, n_pairs, n_cheap, replicates, seed)
                cost = n_pairs * (seconds[0.5] + seconds[1.0]) + n_cheap * seconds["cheap"]
                half_width = stats.norm.ppf(0.5 + expanded_level(0.95, n_pairs) / 2.0) * sd
                rows.append(
                    {
                        "pairs": n_pairs,
                        "cheap": n_cheap,
                        "sd": sd,
                        "cost_s": cost,
                        "work_variance": cost * sd**2,
                        "half_width": half_width,
                        "work_width": cost * half_width**2,
                    }
                )
        plain, with_half = levels[4], levels[5]
        plain_s = seconds[0.25] + (seconds[0.5] if with_half else 0.0)
        result[name] = {
            "candidates": rows,
            "plain_work_variance": float(plain.var(ddof=1) * plain_s),
            "plain_runs": "0.25 m and 0.5 m paired (its own Richardson step)" if with_half else "0.25 m",
        }
    return result


def write(result: dict, path_md: Path) -> None:
    c, a, s = result["coverage"], result["allocation"], result["seconds"]
    lines = [
        "# The fidelity chain on real runs: coverage and allocation",
        "",
        "`python benchmarks/chain_coverage.py` (method: its docstring). Population: the "
        f"{result['population']} case-1 realizations of `benchmarks/results/mesh_levels_runs.jsonl` at 1, 0.5 and 0.25 m, "
        "with the tuned end-state surrogate on the same realizations. Order of the runout's mesh convergence: "
        f"{result['order'][1]} [{result['order'][0]}, {result['order'][2]}] (montecarlo.fidelity.mesh_order).",
        "",
        f"## Coverage: {result['replicates']} replicates of the default allocation ({result['pairs']} pairs, "
        f"{result['cheap']} cheap)",
        "",
        "| quantity | known answer | coverage of the 95 % interval | within 3 SE of 95 % | mean half-width | "
        "mean error of the estimate |",
        "|---|---|---|---|---|---|",
    ]
    for name, row in c.items():
        inside = abs(row["coverage"] - 0.95) <= 3 * row["se"]
        lines.append(
            f"| {name} | {row['answer']:.2f} | {row['coverage']:.3f} (SE {row['se']:.3f}) | "
            f"{'yes' if inside else 'no'} | {row['half_width']:.2f} | "
            f"{row['mean_error']:+.3f} ± {2 * row['error_se']:.3f} |"
        )
    lines += [
        "",
        "Sampling only: the runout's interval at the order's point value (the resampling world's answer uses that "
        "value, so the order's interval, which the report adds, only widens it here).",
        "",
        f"## The runout exceeded with P: {result['distances'][next(iter(result['distances']))]['replicates']} "
        "replicates through the pipeline's own estimators",
        "",
        "Each replicate's distance as the report gives it (`rgns.fidelity.outputs.correct`, then "
        "`rgns.fidelity.mesh_extrapolation.converged`: the corrected exceedance curve's distance plus the paired "
        "quantiles' step; the interval one joint bootstrap of both, `distance_intervals`). Answers: the direct "
        "reference (0.25 m quantile plus its own Richardson step) and the chain's own target in this world (the "
        "0.5 m curve's distance on the pipeline's 0.25 m grid plus the 1 → 0.5 m quantile step); they differ by the "
        f"Richardson step's model error on a quantile of {result['population']} values. Two intervals: at the "
        "order's point value (sampling alone: the answers use that value) and the report's, the envelope over "
        "the order's interval.",
        "",
        "| P | mean estimate | intervals closed | answer | value | covered at the order's value (mean half-width) "
        "| within 3 SE of 95 % | covered by the report's interval (mean half-width) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for p, row in result["distances"].items():
        for name, label in (("direct", "direct reference"), ("chain_target", "chain's target")):
            answer = row[name]
            within = abs(answer["coverage_at_order"] - 0.95) <= 3 * row["se"]
            lines.append(
                f"| {p} | {row['mean_estimate']:.2f} | {row['bounded']} of {row['replicates']} | {label} | "
                f"{answer['answer']:.2f} | {answer['coverage_at_order']:.3f} ({row['half_width_at_order']:.2f}) | "
                f"{'yes' if within else 'no'} (SE {row['se']:.3f}) | {answer['coverage']:.3f} ({row['half_width']:.2f}) |"
            )
    lines += [
        "",
        "An interval left open (an end beyond the curves' distances) counts as not covering."
        + (" These rows are those of the previous run (`--reuse-distances`: same seed)." if result["reused"] else ""),
    ]
    lines += [
        "",
        "## Allocation from measured costs and correlations",
        "",
        f"Seconds per realization: cheap {s['cheap']:.3f} (timed here, one thread, without a chunk's start-up), "
        f"MPM at 1 / 0.5 / 0.25 m {s[1.0]:.0f} / {s[0.5]:.0f} / {s[0.25]:.0f} (mesh_levels' runs). Correlation of "
        f"the cheap route's runout with the 0.5 m runs': {result['correlation']:.3f}. Standard deviations over "
        f"{result['sd_replicates']} replicates.",
    ]
    for name, table in a.items():
        rows = table["candidates"]
        best = min(rows, key=lambda r: r["work_width"])
        default = next(r for r in rows if r["pairs"] == result["pairs"] and r["cheap"] == result["cheap"])
        lines += [
            "",
            f"### {name}",
            "",
            "| pairs | cheap | sd of the estimate | cost (s) | cost × sd² | 95 % half-width | cost × half-width² |",
            "|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for row in rows:
            mark = " (default)" if row is default else (" (lowest)" if row is best else "")
            lines.append(
                f"| {row['pairs']}{mark} | {row['cheap']} | {row['sd']:.4g} | {row['cost_s']:.0f} | "
                f"{row['work_variance']:.4g} | {row['half_width']:.4g} | {row['work_width']:.4g} |"
            )
        plain = table["plain_work_variance"]
        lines += [
            "",
            f"Plain Monte Carlo ({table['plain_runs']} per realization): cost × variance {plain:.4g}. At equal "
            f"sampling error the default allocation is **{plain / default['work_variance']:.0f}×** cheaper; the "
            f"lowest cost × half-width² here ({best['pairs']} pairs, {best['cheap']} cheap) "
            f"{plain / best['work_variance']:.0f}×.",
        ]
    lines.append("")
    path_md.write_text("\n".join(lines))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--case", default="case1")
    parser.add_argument("--replicates", type=int, default=400)
    parser.add_argument("--distance-replicates", type=int, default=200, help="~20 s each on one core")
    parser.add_argument("--sd-replicates", type=int, default=4000)
    parser.add_argument("--seed", type=int, default=20261125)
    parser.add_argument(
        "--population", type=int, help="the first this many realizations mesh_levels ran at every mesh (default: all)"
    )
    parser.add_argument(
        "--reuse-distances",
        action="store_true",
        help="keep the distances' rows of the previous results (same seed): re-measure the rest in a minute",
    )
    args = parser.parse_args()
    config = load_config(REPO / "config" / "config.yaml")
    settings = pipeline_settings(config)
    order = settings["mesh_order"]["runout_m"]
    indices, values, seconds = saved(args.case, CELLS, args.population)
    tables = {h: mpm_table(args.case, h, indices) for h in CELLS}
    tables["cheap"], seconds["cheap"] = cheap_table(config, args.case, indices)
    cheap = {key: tables["cheap"][key].to_numpy(float) for key in METRICS}
    n_pairs, n_cheap = int(settings["paired"]), int(config["montecarlo"]["realizations"])
    cost = {"high_s": seconds[0.5], "low_s": seconds["cheap"]}
    result = {
        "population": len(indices),
        "order": order,
        "pairs": n_pairs,
        "cheap": n_cheap,
        "replicates": args.replicates,
        "sd_replicates": args.sd_replicates,
        "seed": args.seed,
        "seconds": {str(k): v for k, v in seconds.items()},
        "correlation": float(np.corrcoef(values["runout_m"][1], cheap["runout_m"])[0, 1]),
        "coverage": coverage(values, cheap, {"runout_m": order}, n_pairs, n_cheap, args.replicates, args.seed),
        "allocation": allocation(values, cheap, seconds, order[1], args.sd_replicates, args.seed),
        "reused": args.reuse_distances,
    }
    if args.reuse_distances:
        previous = json.loads((OUT / "chain_coverage.json").read_text())
        if previous["seed"] != args.seed:
            raise SystemExit(f"--reuse-distances: the previous results used seed {previous['seed']}, not {args.seed}")
        result["distances"] = previous["distances"]
    else:
        result["distances"] = distance_coverage(
            tables, values, settings, cost, n_pairs, n_cheap, args.distance_replicates, args.seed
        )
    (OUT / "chain_coverage.json").write_text(json.dumps(result, indent=1))
    write(result | {"seconds": seconds}, OUT / "chain_coverage.md")
    print((OUT / "chain_coverage.md").read_text())


if __name__ == "__main__":
    main()
