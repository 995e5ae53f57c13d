"""Where do the tail distances' intervals fall short? Their spread over replicates against the bootstrap's.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/interval_spread.py --seed 777 --replicates 30
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/interval_spread.py --seed 787 --replicates 30 --strata 0.5 0.9 0.99
    .venv/bin/python benchmarks/interval_spread.py --passes      # P 0.01 estimates by pairs past the answer
    .venv/bin/python benchmarks/interval_spread.py --report      # the md from every run the json holds

A replicate is benchmarks/pair_coverage.py's (its population, ``--population``, default local: the real pairs'
relation bends and its spread grows; N = 10,000 cheap runs; 32 pairs drawn by rule paired_plan's design, with
``--strata`` the cheap runout's quantiles that bound the strata). For the runout exceeded with P 0.5, 0.1, 0.01
it records the two parts of the converged estimate, the corrected 0.5 m distance (the accurate part) and the
mesh step, and the intervals the pipeline's bootstraps give them: the corrected curve's band where it crosses P
(rgns.fidelity.outputs.correct), and the joint bootstrap of rgns.fidelity.mesh_extrapolation.distance_intervals
at the order's value (the converged distance and the step) and at order 60 (a step of 2^-60 of the difference:
the accurate part alone, from the same resamples). Over the replicates, each part's standard deviation is set
beside the spread its interval implies (mean half-width / z, z = 1.96): an interval that implies less spread
than the estimate has cannot cover 95 %. Beside them, on the same replicates, the alternative
:func:`residual_resampling` (model-based resampling of the pairs), and the union of the two converged intervals,
which distance_intervals reports since f015f0c (the rows recorded before it hold its pairs bootstrap alone as
the joint one; rerun now, that column is the union). ``--passes`` splits the recorded P 0.01
estimates by how many of their pairs passed the population's answer. Seeds 777-799 are development seeds: they
chose nothing and nothing was chosen on them but where to look next; coverage is pair_coverage.py's, on its own
seeds.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numpy as np
import pair_coverage as pc  # noqa: E402  (benchmarks/ is the script's own folder)
import torch
from scipy import stats

from rgns.fidelity import mesh_extrapolation as me
from rgns.fidelity import multifidelity
from rgns.fidelity.pair_design import row_strata
from rgns.hazard.exceedance import distance_at
from rgns.provenance import commit

OUT = pc.OUT / "interval_spread.json"
REPORT = pc.OUT / "interval_spread.md"
PROBABILITIES = (0.5, 0.1, 0.01)
ACCURATE_ONLY = 60.0  # an order whose step is 2^-60 of the meshes' difference: the accurate part alone
Z = 1.96


def replicate(population: dict, settings: dict, cost: dict, seed: int, number: int) -> dict[str, list]:
    """One replicate's parts and intervals (lists over PROBABILITIES)."""
    rng = np.random.default_rng([seed, number, 0])
    low, high, coarse, plan = pc.tables(population, settings, rng)
    curve = pc.runout_correction(low, high, settings, cost, number, plan)["exceedance"]["runout_m"]
    fine, partner, cheap = me.nested_levels(low, high, coarse)
    strata = row_strata(plan, cheap["index"].tolist(), len(fine))
    levels = [t["runout_m"].to_numpy(float) for t in (fine, partner, cheap)]
    d_m = np.asarray(curve["d_m"])
    ratio = float(settings["coarse_cell_size_m"]) / float(settings["high_cell_size_m"])
    order = float(settings["mesh_order"]["runout_m"][1])
    joint = me.distance_intervals(
        *levels,
        d_m,
        list(PROBABILITIES),
        ratio,
        np.array([order, ACCURATE_ONLY]),
        settings["confidence"],
        number,
        strata,
    )
    accurate = [curve["distances"][str(p)]["corrected"] for p in PROBABILITIES]
    deviations = residual_resampling(*levels, d_m, ratio, order, settings["confidence"], number, strata)[
        "deviation_quantiles"
    ]
    estimates = [accurate, joint.step[0].tolist(), (np.asarray(accurate) + joint.step[0]).tolist()]
    alternative = {
        name: [[e - hi, e - lo] for e, lo, hi in zip(values, low_dev, high_dev)]
        for name, (low_dev, high_dev), values in zip(("accurate", "step", "converged"), deviations, estimates)
    }
    return {
        "residual_resampling": alternative,
        "accurate": accurate,
        "band": [[distance_at(d_m, curve[end], p) for end in ("lower", "upper")] for p in PROBABILITIES],
        "step": joint.step[0].tolist(),
        "step_interval": [[lo, hi] for lo, hi in zip(joint.step_lower[0].tolist(), joint.step_upper[0].tolist())],
        "converged_interval": [[lo, hi] for lo, hi in zip(joint.lower[0].tolist(), joint.upper[0].tolist())],
        "accurate_interval": [[lo, hi] for lo, hi in zip(joint.lower[1].tolist(), joint.upper[1].tolist())],
    }


def residual_resampling(
    fine: np.ndarray,
    partner: np.ndarray,
    cheap: np.ndarray,
    d_m: np.ndarray,
    ratio: float,
    order: float,
    confidence: float,
    seed: int,
    strata: np.ndarray | None = None,
    resamples: int = 1000,
) -> dict[str, list[list[float]]]:
    """The alternative measured beside the pipeline's pairs bootstrap, as first written: model-based resampling
    (rgns.fidelity.mesh_extrapolation.model_resamples) whose resamples redraw the pairs' own cheap values (within
    their design stratum: ``strata``, a label per row, pairs first; None: one), each estimated as the pipeline
    estimates (mesh_extrapolation.converged_distances: the corrected curve's crossing, the modelled crossings'
    step, the unpaired runs binned) → per part (accurate, step, converged) the quantiles [lower [P], upper [P]],
    at the expanded level for n pairs, of the resamples' deviation from what the fit itself gives (the modelled
    crossing, its step): the basic bootstrap interval of an estimate e is then [e − upper, e − lower]. The
    pipeline's own model-based half draws the cheap values from all N (since 6d65e29); this keeps the variant
    the recorded columns measured."""
    n = len(fine)
    if strata is not None and np.unique(strata[:n]).size == 1:
        strata = None  # a simple random design's labels (rule paired_plan gives one stratum): drawn as one
    cheap_p = cheap[:n]
    rest, counts = multifidelity.binned(cheap[n:, None], multifidelity.BINS)
    design = multifidelity.design_weights(strata, n)
    rng = np.random.default_rng(seed)
    drawn = me.model_resamples(fine, partner, cheap_p, design, None if strata is None else strata[:n], resamples, rng)
    targets, factor = np.asarray(PROBABILITIES), np.array([[ratio**order - 1.0]])

    def parts(found: np.ndarray) -> np.ndarray:
        """[..., 3, 1, P] of converged_distances (estimate, step, the fit's own distance) → [3, ..., P]: the
        accurate part, the step, the converged estimate."""
        distance, step, _ = np.moveaxis(found[..., 0, :], -2, 0)
        return np.stack([distance - step, step, distance])

    batches = [
        me.converged_distances(
            drawn.high[k : k + 16],
            drawn.coarse[k : k + 16],
            drawn.cheap[k : k + 16],
            drawn.weights[k : k + 16],
            rest,
            counts,
            d_m,
            targets,
            factor,
        )
        for k in range(0, resamples, 16)
    ]
    values = np.concatenate([parts(found) for found in batches], axis=1)  # [3, resamples, P]
    _, step, fitted = me.converged_distances(fine, partner, cheap_p, design, rest, counts, d_m, targets, factor)[:, 0]
    centre = np.stack([fitted - step, step, fitted])[:, None, :]  # what the resamples estimate, under the fit
    level = multifidelity.expanded_level(confidence, n)
    low_dev, high_dev = np.nanpercentile(values - centre, [50 * (1 - level), 50 * (1 + level)], axis=1)
    return {"deviation_quantiles": [[lo.tolist(), hi.tolist()] for lo, hi in zip(low_dev, high_dev)]}


def passes(result: dict, population: dict, settings: dict, kind: str) -> dict[str, dict[str, list[float]]]:
    """Per design of ``kind``'s population: for P 0.01, the replicates' corrected 0.5 m distances split by how
    many of their pairs passed the population's 0.5 m answer ([count, replicates, mean estimate, sd])."""
    answer = result["truth"][kind]["0.01"]["accurate"]
    split: dict[str, dict[str, list[float]]] = {}
    for name, design in result["designs"].items():
        if design["population"] != kind:
            continue
        settings["strata"] = [float(q) for q in name.split("[")[1].rstrip("]").split(", ")] if "[" in name else []
        found: dict[int, list[float]] = {}
        for run in design["runs"]:
            seed = int(run["command"].split("--seed ")[1].split()[0])
            for number, row in enumerate(run["rows"]):
                _, high, _, _ = pc.tables(population, settings, np.random.default_rng([seed, number, 0]))
                found.setdefault(int((high["runout_m"] > answer).sum()), []).append(row["accurate"][-1])
        split[name] = {
            str(k): [len(v), float(np.mean(v)), float(np.std(v, ddof=1)) if len(v) > 1 else 0.0]
            for k, v in sorted(found.items())
        }
    return split


def implied(intervals: list[list[float]]) -> float:
    """The spread an interval implies: its mean half-width over z."""
    widths = np.array([(hi - lo) / 2.0 for lo, hi in intervals], dtype=float)
    return float(np.nanmean(widths) / Z)


def union(rows: list[dict], j: int, answer: float) -> dict[str, float]:
    """The spread the union of the two converged intervals (the pairs bootstrap's, recorded as the joint one,
    and the model-based one) implies at PROBABILITIES[j], and its coverage of ``answer``: what
    rgns.fidelity.mesh_extrapolation.distance_intervals reports since f015f0c."""
    ends = [
        [
            min(r["converged_interval"][j][0], r["residual_resampling"]["converged"][j][0]),
            max(r["converged_interval"][j][1], r["residual_resampling"]["converged"][j][1]),
        ]
        for r in rows
    ]
    return {"implies": implied(ends), "coverage": float(np.mean([lo <= answer <= hi for lo, hi in ends]))}


def summary(rows: list[dict], truth: dict) -> dict[str, Any]:
    """Per P: each part's sd over the replicates and the spread its intervals imply, biases, the parts'
    correlation, and the converged interval's coverage of the chain's target."""
    result: dict[str, Any] = {}
    for j, p in enumerate(PROBABILITIES):
        accurate = np.array([r["accurate"][j] for r in rows], dtype=float)
        step = np.array([r["step"][j] for r in rows], dtype=float)
        known = truth[str(p)]
        answer_step = known["converged"] - known["accurate"]
        covered = [r["converged_interval"][j][0] <= known["converged"] <= r["converged_interval"][j][1] for r in rows]
        result[str(p)] = {
            "accurate_sd": float(accurate.std(ddof=1)),
            "accurate_band_implies": implied([r["band"][j] for r in rows]),
            "accurate_joint_implies": implied([r["accurate_interval"][j] for r in rows]),
            "accurate_bias": float(accurate.mean() - known["accurate"]),
            "step_sd": float(step.std(ddof=1)),
            "step_implies": implied([r["step_interval"][j] for r in rows]),
            "step_bias": float(step.mean() - answer_step),
            "converged_sd": float((accurate + step).std(ddof=1)),
            "converged_implies": implied([r["converged_interval"][j] for r in rows]),
            "converged_bias": float((accurate + step).mean() - known["converged"]),
            "parts_correlation": float(np.corrcoef(accurate, step)[0, 1]),
            "residual_resampling": {
                name: {
                    "implies": implied([r["residual_resampling"][name][j] for r in rows]),
                    "coverage": float(
                        np.mean(
                            [
                                r["residual_resampling"][name][j][0] <= answer <= r["residual_resampling"][name][j][1]
                                for r in rows
                            ]
                        )
                    ),
                }
                for name, answer in (
                    ("accurate", known["accurate"]),
                    ("step", answer_step),
                    ("converged", known["converged"]),
                )
            }
            if all(r.get("residual_resampling") for r in rows)
            else None,
            "union": union(rows, j, known["converged"]) if all(r.get("residual_resampling") for r in rows) else None,
            "coverage": float(np.mean(covered)),
            "coverage_se": float(np.sqrt(0.95 * 0.05 / len(rows))),
        }
    return result


def write_report(result: dict) -> None:
    """The md: per design, a table of the parts' spread against what their intervals imply."""
    lines = [
        "# The tail distances' spread against their intervals' (`benchmarks/interval_spread.py`)",
        "",
        (__doc__ or "").split("\n\n", 2)[2].strip().replace("\n", " "),
        "",
    ]
    for name, design in result["designs"].items():
        rows = [row for run in design["runs"] for row in run["rows"]]
        dof = len(rows) - 1
        low, high = (float(np.sqrt(dof / stats.chi2.ppf(q, dof))) for q in (0.975, 0.025))
        lines += [
            f"## {name} pairs: {len(rows)} replicates",
            "",
            "Commands: " + "; ".join(f"`{run['command']}` at {run['commit']}" for run in design["runs"]),
            "",
            f"On {len(rows)} replicates a standard deviation is known to within x{low:.2f} to x{high:.2f} (95 %, "
            "chi-square); each coverage's binomial SE stands beside it.",
            "",
            "| P | accurate part: sd / band implies / joint implies (bias) | mesh step: sd / implies (bias) "
            "| converged: sd / implies (bias) | corr(parts) | coverage (SE) |",
            "|---|---|---|---|---|---|",
        ]
        for p, s in summary(rows, result["truth"][design["population"]]).items():
            lines.append(
                f"| {p} | {s['accurate_sd']:.3f} / {s['accurate_band_implies']:.3f} / {s['accurate_joint_implies']:.3f}"
                f" ({s['accurate_bias']:+.3f}) | {s['step_sd']:.3f} / {s['step_implies']:.3f} ({s['step_bias']:+.3f})"
                f" | {s['converged_sd']:.3f} / {s['converged_implies']:.3f} ({s['converged_bias']:+.3f})"
                f" | {s['parts_correlation']:+.2f} | {s['coverage']:.2f} ({s['coverage_se']:.2f}) |"
            )
        lines.append("")
        alternative = {
            p: s["residual_resampling"] for p, s in summary(rows, result["truth"][design["population"]]).items()
        }
        if all(alternative.values()):
            lines += [
                "Model-based resampling (`residual_resampling`, the alternative) on the same replicates: the spread "
                "its basic intervals imply, and their coverage; last, the union of its converged interval and the "
                "pairs bootstrap's (what `distance_intervals` reports since f015f0c).",
                "",
                "| P | accurate part: implies / coverage | mesh step: implies / coverage | converged: implies / coverage "
                "| union, converged: implies / coverage |",
                "|---|---|---|---|---|",
            ]
            unions = {p: s["union"] for p, s in summary(rows, result["truth"][design["population"]]).items()}
            for p, parts in alternative.items():
                cells = " | ".join(
                    f"{parts[name]['implies']:.3f} / {parts[name]['coverage']:.2f}"
                    for name in ("accurate", "step", "converged")
                )
                lines.append(f"| {p} | {cells} | {unions[p]['implies']:.3f} / {unions[p]['coverage']:.2f} |")
            lines.append("")
    for kind, designs in result.get("passes", {}).items():
        lines += [
            f"How many pairs passed the {kind} population's 0.5 m distance exceeded with P 0.01 "
            f"({result['truth'][kind]['0.01']['accurate']:.2f} m), and the corrected 0.5 m distance then (mean, sd; "
            f"`... interval_spread.py --passes --population {kind}` regenerates each replicate's pairs):",
            "",
            "| design | pairs past it: replicates, estimate mean (sd) |",
            "|---|---|",
            *(
                f"| {name} | "
                + "; ".join(f"{k}: {int(c)}, {m:.2f} m ({sd:.2f})" for k, (c, m, sd) in split.items())
                + " |"
                for name, split in designs.items()
            ),
            "",
        ]
    lines += ["## What it says", "", *result.get("findings", [])]
    REPORT.write_text("\n".join(lines).rstrip() + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--seed", type=int, default=777)
    parser.add_argument("--replicates", type=int, default=30)
    parser.add_argument("--strata", type=float, nargs="*", default=[], help="the cheap runout's quantiles")
    parser.add_argument("--population", choices=("super", "local"), default="local")
    parser.add_argument("--report", action="store_true", help="only write the md from the json")
    parser.add_argument(
        "--passes", action="store_true", help="split the recorded P 0.01 estimates by how many pairs passed the answer"
    )
    args = parser.parse_args()
    result = json.loads(OUT.read_text()) if OUT.exists() else {"designs": {}, "truth": {}}
    if args.report:
        write_report(result)
        print(REPORT.read_text())
        return
    torch.set_num_threads(1)
    if args.passes:
        settings, population, _, _ = pc.prepare(
            argparse.Namespace(population=args.population, population_seed=20261130)
        )
        result.setdefault("passes", {})[args.population] = passes(result, population, settings, args.population)
        OUT.write_text(json.dumps(result, indent=1) + "\n")
        write_report(result)
        print(REPORT.read_text())
        return
    settings, population, truth, meta = pc.prepare(
        argparse.Namespace(population=args.population, population_seed=20261130)
    )
    settings["strata"] = list(args.strata)
    name = f"{args.population}, " + (f"strata at {args.strata}" if args.strata else "simple random")
    command = (
        f"OMP_NUM_THREADS=1 .venv/bin/python benchmarks/interval_spread.py --seed {args.seed} "
        f"--replicates {args.replicates} --population {args.population}"
        + (f" --strata {' '.join(f'{q:g}' for q in args.strata)}" if args.strata else "")
    )
    rows: list[dict] = []
    made_at = commit()
    for number in range(args.replicates):
        tick = time.perf_counter()
        rows.append(replicate(population, settings, meta["cost"], args.seed, number))
        print(f"{name}: replicate {number + 1} of {args.replicates}, {time.perf_counter() - tick:.1f} s", flush=True)
    # written once whole, re-read first (another run may have written since): a run cut short leaves the last one
    result = json.loads(OUT.read_text()) if OUT.exists() else {"designs": {}, "truth": {}}
    result["truth"][args.population] = truth
    design = result["designs"].setdefault(name, {"population": args.population, "runs": []})
    design["runs"] = [run for run in design["runs"] if run["command"] != command]
    design["runs"].append({"command": command, "commit": made_at, "rows": rows})
    OUT.write_text(json.dumps(result, indent=1) + "\n")
    write_report(result)
    print(REPORT.read_text())


if __name__ == "__main__":
    main()
