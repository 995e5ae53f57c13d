"""The README's passages on the fresh-clone runs, the machine's pace, and how often the default's intervals cover."""

from __future__ import annotations

import statistics
from typing import Any

from evidence.formatting import ends, half, interval, minutes, r2
from evidence.sources import RESULTS, result

# issue 42's measurement of the default before its route changed (256 realizations gated to the MPM, 16 pairs)
BEFORE_SECONDS = 23 * 60 + 57
BEFORE_HALF_WIDTH = {"0.1": 2.1, "0.01": 3.3}  # the whole interval's
BEFORE_AT_ORDER = {"0.1": 1.3, "0.01": 2.4}  # its sampling part at the order's value
TARGET_SECONDS = 15 * 60  # the README's: the default hazard_map from a fresh clone on 2 cores


def run_lines(record: dict[str, Any], case: str) -> list[str]:
    """What one fresh run measured, and the best estimate and evidence of one of its cases."""
    head = record["cases"][case]
    distances = head["distances"]["runout_m"]
    at_order = head["distances_at_order"]["runout_m"]
    probabilities = list(distances)
    cheap, simulator = head["cheap_validation"], head["simulator_validation"]
    converged = head["converged_at"]
    load = record["load_before"][0]
    lines = [
        f"Measured by `{record['command']}` at {record['commit']} ({record['date']}): a fresh clone, "
        f"`{record['run']}` after the README's install ({record['install_s']:.0f} s, excluded), "
        f"{record['machine']}, load average {load:.2f} before it: **{minutes(record['seconds'])}**, peak memory "
        f"{record['peak_memory_gb']:.2f} GB (the largest process)"
        + (
            f"; in this run the accurate MPM took {head['cost_s']['high_s']:.1f} s and the learned simulator "
            f"{1000 * head['cost_s']['low_s']:.1f} ms per realization (the machine's pace)."
            if "cost_s" in head
            else "."
        ),
        f"`{case}`: {head['n_realizations']:,} realizations by the learned simulator, {head['n_pairs']} MPM pairs; "
        f"the best estimate carried to the converged mesh (95 % intervals): mean runout "
        f"{ends(head['means']['runout_m'])}; R exceeded with P {' / '.join(probabilities)}: "
        + " / ".join(ends(distances[p]) for p in probabilities)
        + " (the sampling parts at the order's value: "
        + " / ".join(f"[{at_order[p][0]:.2f}, {at_order[p][1]:.2f}]" for p in probabilities)
        + ").",
        f"The pairs' validation: the cheap route ({head['cheap_route']}) against the accurate MPM, runout R² "
        f"{r2(cheap['runout_m'])} (bias {cheap['runout_m']['bias'][0]:+.2f} m)"
        + (
            f"; the Monte Carlo's simulator against the Monte Carlo's mesh, runout R² {r2(simulator['runout_m'])}, "
            f"volume {r2(simulator['volume_m2'])}, influence {r2(simulator['influence_m'])}"
            if simulator
            else ""
        )
        + ".",
        *pair_lines(head),
        "The running mean and variance converge (the paper's rule) at n = "
        + " and ".join(f"{n:,} ({name})" for name, n in converged.items())
        + f". The allocation: {head['allocation']['reason']}.",
        *time_lines(record, case),
    ]
    return lines


def time_lines(record: dict[str, Any], case: str) -> list[str]:
    """Where a run's time went (per rule and route, from Snakemake's log; a run recorded before fresh_run.py took
    it: nothing), and the run against the README's target, 15 min on 2 cores."""
    lines = []
    rules = record.get("rules")
    if rules:
        total = sum(entry["job_seconds"] for entry in rules.values())
        largest = list(rules.items())[:5]
        lines.append(
            f"Its jobs' summed wall time, {minutes(total)} on 2 cores, went to "
            + ", ".join(
                f"{name} {minutes(entry['job_seconds'])} ({entry['jobs']} job{'s' if entry['jobs'] > 1 else ''})"
                for name, entry in largest
            )
            + (", the rest less" if len(rules) > len(largest) else "")
            + " (per rule and route, from Snakemake's log)."
        )
    if "seconds" in record:
        within = record["seconds"] <= TARGET_SECONDS
        lines.append(
            f"The target, {minutes(TARGET_SECONDS)} on 2 cores from a fresh clone: "
            + ("**met**." if within else f"**missed** by {minutes(record['seconds'] - TARGET_SECONDS)}.")
        )
    return lines


def pair_lines(head: dict[str, Any]) -> list[str]:
    """Where a run's pairs sit in its cheap route's runout (a run recorded before fresh_run.py took it: none)."""
    pairs = head.get("pairs")
    if pairs is None:
        return []
    strata = pairs["strata"]
    design = (
        "a simple random draw (no strata)"
        if len(strata["sizes"]) == 1
        else f"{len(strata['sizes'])} strata of the cheap runout with {' / '.join(map(str, strata['pairs']))} pairs"
    )
    low, high = pairs["quantiles"][0], pairs["quantiles"][-1]
    return [
        f"The pairs, {design}, sit between the cheap runout's {low:.3f} and {high:.3f} quantiles: "
        f"{pairs['above_0.9']} above its 0.9 quantile, {pairs['above_0.99']} above 0.99."
    ]


def default_run() -> str:
    """README: the default config's fresh-clone run, its headline and how it compares with the old default."""
    record = result("fresh_run_default.json")
    case = next(iter(record["cases"]))
    head = record["cases"][case]
    lines = run_lines(record, case)
    widths = {p: half(head["distances"]["runout_m"][p]) for p in ("0.1", "0.01")}
    sampling = {p: half(head["distances_at_order"]["runout_m"][p]) for p in ("0.1", "0.01")}
    narrower = all(widths[p] < BEFORE_HALF_WIDTH[p] and sampling[p] < BEFORE_AT_ORDER[p] for p in widths)
    lines.append(
        f"The half-widths of R at P 0.1 and 0.01, {widths['0.1']:.2f} and {widths['0.01']:.2f} m (their sampling "
        f"parts {sampling['0.1']:.2f} and {sampling['0.01']:.2f} m), are "
        + ("below" if narrower else "**not all below**")
        + f" the previous default's (256 realizations gated to the MPM, 16 pairs, {minutes(BEFORE_SECONDS)}: "
        f"{BEFORE_HALF_WIDTH['0.1']} and {BEFORE_HALF_WIDTH['0.01']} m, sampling parts "
        f"{BEFORE_AT_ORDER['0.1']} and {BEFORE_AT_ORDER['0.01']} m)."
    )
    return " ".join(lines)


def default_headline() -> str:
    """README: the default run's time and case 1's answer, in a few lines (the whole record: docs/evidence.md)."""
    record = result("fresh_run_default.json")
    case = next(iter(record["cases"]))
    head = record["cases"][case]
    distances = head["distances"]["runout_m"]
    return "\n".join(
        [
            "| runout R | best estimate, m | 95 % interval, m |",
            "|---|---:|---|",
            f"| mean | {head['means']['runout_m'][0]:.2f} | {interval(head['means']['runout_m'])} |",
            *(f"| exceeded with P {p} | {distances[p][0]:.2f} | {interval(distances[p])} |" for p in distances),
            "",
            f"{head['n_realizations']:,} realizations, {head['n_pairs']} MPM pairs, carried to the converged mesh; "
            f"**{minutes(record['seconds'])}** from a fresh clone on {record['machine']} "
            f"(`{record['command']}` at {record['commit'][:7]}).",
        ]
    )


def site_run() -> str:
    """docs/site.md: the example site's fresh-clone run and its headline."""
    record = result("fresh_run_site.json")
    return " ".join(run_lines(record, next(iter(record["cases"]))))


def coverage_row(label: str, record: dict[str, Any]) -> str:
    """One population's coverage of the converged answer: the sampling interval, and the report's."""
    summary = record["normal"]["summary"]
    cells = []
    for key in ("mean", "0.5", "0.1", "0.01"):
        sampling, report = summary[key]["converged"]["at_order"], summary[key]["converged"]["report"]
        cells.append(
            f"{100 * sampling['coverage']:.1f} % ({sampling['below']} / {sampling['above']})"
            + ("" if sampling["within_3se"] else " **outside 3 SE**")
            + f"; {100 * report['coverage']:.1f} %"
        )
    normal, strata = record["normal"], record["meta"]["design"]["strata"]
    design = f"pairs in strata at {' / '.join(f'{q:g}' for q in strata)}" if strata else "simple random pairs"
    return f"| {label} ({len(normal['replicates'])}, seed {normal['seed']}, {design}) | " + " | ".join(cells) + " |"


def spreads(record: dict[str, Any], probability: str) -> tuple[float, float]:
    """Over a coverage run's replicates, the spread its sampling intervals imply (mean half-width / 1.96, over the
    closed ones) and the estimates' sd, at one probability."""
    import numpy as np

    rows = [r[probability] for r in record["normal"]["replicates"]]
    widths = [hi - lo for lo, hi in (r["at_order"] for r in rows) if lo is not None and hi is not None]
    estimates = [r["estimate"] for r in rows if r["estimate"] is not None]
    return float(np.mean(widths)) / 2.0 / 1.959964, float(np.std(estimates, ddof=1))


def point_spreads(kind: str) -> str:
    """pair_coverage_points.json's sd of the converged estimate per development seed of one population, at P 0.1
    and 0.01 ('' where it holds none)."""
    points = result("pair_coverage_points.json")
    runs = {key: entry for key, entry in points.items() if key.startswith(f"{kind}, seed ")}
    if not runs:
        return ""
    return "; over the point estimates alone, " + ", ".join(
        f"{entry['replicates']:,} replicates of seed {key.split('seed ')[1]}: "
        + " / ".join(f"{entry['points'][p]['converged']['sd']:.2f}" for p in ("0.1", "0.01"))
        for key, entry in runs.items()
    )


def sabotage_line(record: dict[str, Any]) -> str:
    """A coverage run's sabotage part, if it has one: the cheap rows permuted across realizations, what the
    allocation asked for, how often the sampling intervals covered and how much wider they are than the normal
    run's ('' where there is none)."""
    sabotage = record.get("sabotage", {})
    if not sabotage.get("replicates") or sabotage.get("design") != record["meta"]["design"]:
        return ""  # none, or one of another design than the normal part's (before modes recorded theirs)
    count, routes = len(sabotage["replicates"]), sabotage["allocation"]["routes"]
    cells, ratios = [], []
    for key in ("mean", "0.5", "0.1", "0.01"):
        entry = sabotage["summary"][key]["converged"]["at_order"]
        normal = record["normal"]["summary"][key]["converged"]["at_order"]
        cells.append(f"{100 * entry['coverage']:.1f} % ({entry['below']} / {entry['above']})")
        ratios.append(f"{entry['half_width'] / normal['half_width']:.1f}×")
    return (
        f" Sabotage, the cheap rows permuted across realizations ({count} replicates, seed {sabotage['seed']}, made at "
        f"{', '.join(sabotage['commits'])}): the allocation called for plain MPM in {routes.get('plain MPM', 0)} of "
        f"{count}; the sampling intervals of the mean and of R at P 0.5 / 0.1 / 0.01 covered {' / '.join(cells)}, "
        f"{' / '.join(ratios)} as wide as the normal run's."
    )


def pair_coverage() -> str:
    """README: how often the default design's intervals cover the converged answer, per synthetic population."""
    populations = {
        "every pair a new realization of the real pairs' law": "pair_coverage_superpopulation.json",
        "each member the residuals of its nearest real realizations (the relation bends, its spread grows)": (
            "pair_coverage_local.json"
        ),
    }
    records = {label: result(name) for label, name in populations.items()}
    commits = sorted({commit for record in records.values() for commit in record["normal"].get("commits", [])})
    counts = sorted({len(record["normal"]["replicates"]) for record in records.values()}, reverse=True)
    lines = [
        "| population (replicates, seed, design) | mean runout | R at P 0.5 | R at P 0.1 | R at P 0.01 |",
        "|---|---|---|---|---|",
        *(coverage_row(label, record) for label, record in records.items()),
        "",
        "Each cell: the sampling interval's coverage of the converged answer (misses below / above), then the "
        "report's interval's; 3 SE of 95 % is "
        + ", ".join(f"±{300 * (0.95 * 0.05 / n) ** 0.5:.1f} points on {n} replicates" for n in counts)
        + ". The converged answer of a distance is "
        "read from the law as the pipeline reads its own curves (rgns.hazard.exceedance: where the curve falls to "
        "P, linear between the distances it is known at), plus the Richardson step of the same reading at 0.5 "
        "and 1 m. "
        f"Made at {', '.join(commits)} by "
        + "; ".join(f"`{record['meta']['commands'][0]}`" for record in records.values())
        + ".",
        "",
        "The spread (m) the sampling intervals of R at P 0.1 / 0.01 imply (mean half-width / 1.96) against the "
        "estimates' sd over the same replicates"
        + "".join(
            f"; {kind}: "
            + " / ".join("{:.2f} against {:.2f}".format(*spreads(record, p)) for p in ("0.1", "0.01"))
            + point_spreads(kind)
            for kind, record in zip(("super", "local"), records.values())
        )
        + " (`pair_coverage.py --points 1000`, development seeds, `benchmarks/results/pair_coverage_points.json`)."
        + "".join(sabotage_line(record) for record in records.values()),
    ]
    return "\n".join(lines)


def strata_spread() -> str:
    """README: how much the stratified design cut the converged tail distances' spread against simple random pairs,
    over interval_spread.json's development replicates (the sd of accurate part + mesh step per replicate)."""
    designs = result("interval_spread.json")["designs"]

    def spread(design: dict[str, Any]) -> tuple[int, list[float]]:
        rows = [row for run in design["runs"] for row in run["rows"]]
        converged = [[a + s for a, s in zip(row["accurate"], row["step"])] for row in rows]
        columns = list(zip(*converged))
        return len(rows), [statistics.stdev(column) for column in columns]

    (simple_n, simple), (strata_n, strata) = (
        spread(design) for name, design in sorted(designs.items(), key=lambda item: "strata" in item[0])
    )
    return (
        f"The design cut the converged 1 % distance's spread from {simple[2]:.2f} to {strata[2]:.2f} m and left the "
        f"10 % distance's at {simple[1]:.2f} / {strata[1]:.2f} m (sd over {simple_n} / {strata_n} development "
        "replicates of the population whose relation bends: `benchmarks/results/interval_spread.md`)."
    )


def influence_growth() -> str:
    """docs/evidence.md: what the converged MPM says about the influence distance, from the independent mesh
    study's kept ends (influence_mechanism.json): its means per mesh, the realizations whose I a few lifted
    surface points set, and I at a 2 m threshold, which has no such jump."""
    record = result("influence_mechanism.json")
    cells, thresholds = record["cells"], record["thresholds_m"]
    at_1, at_2 = (record["fits"][f"{t:g}"] for t in (1.0, 2.0))
    lifted: dict[float, set[int]] = {0.25: set(), 0.125: set()}  # realizations whose I a point moved up sets
    for key, stray in record["strays"].items():
        cell, realization = key.split("_")
        if float(cell) in lifted and stray["setter_move_m"][1] > 0.0:
            lifted[float(cell)].add(int(realization))
    either = lifted[0.25] | lifted[0.125]
    dropped = len(lifted[0.25] - lifted[0.125])
    n = len(record["realizations"])

    def means(fit: dict) -> str:
        return " / ".join(f"{mean[0]:.2f}" for mean in fit["means"])

    order = at_2["order_finest"]
    return (
        f"On {n} case-1 realizations of a seed of their own ({', '.join(map(str, record['seed']))}) the mean "
        f"influence distance is {means(at_1)} m at {' / '.join(f'{c:g}' for c in cells)} m cells. In {len(either)} of "
        "them, at 0.25 or 0.125 m, it is set far behind the crest by a few free-surface points lifted just past the "
        f"{thresholds[1]:g} m threshold (moved up, not slumped)"
        + (f"; {dropped} lifted at 0.25 m are not at 0.125 m" if dropped else "")
        + "; the failure itself does not reach back there: the rear-most point moved 2 m gives "
        f"{means(at_2)} m, observed order of the three finest {order[0]:.2f} [{order[1]:.2f}, {order[2]:.2f}] "
        "(`benchmarks/results/influence_mechanism.md`). So I, as defined, has no converged value under refinement: "
        "the page reports it at the 0.5 m mesh and does not extrapolate it; read it as that mesh's."
        + other_cases_influence()
    )


OTHER_INFLUENCE = {  # influence_mechanism.py --case runs beside case 1's: the case and how the page names it
    "case3": "case 3's column",
    "ood_bench": "a benched slope no model trained on (ood_bench)",
}


def threshold_fit(record: dict, threshold: str) -> str:
    """An influence_mechanism record's mean I per mesh at ``threshold`` (m) and its last step with its interval."""
    fit = record["fits"][threshold]
    step = fit["last_step"]
    means = " / ".join(f"{mean[0]:.2f}" for mean in fit["means"])
    return f"{means} m, last step {step[0]:+.2f} m [{step[1]:+.2f}, {step[2]:+.2f}]"


def other_cases_influence() -> str:
    """The influence distance's means per mesh and last step on the other cases of the independent mesh study."""
    parts = []
    for case, named in OTHER_INFLUENCE.items():
        path = f"influence_mechanism_{case}.json"
        if not (RESULTS / path).exists():
            continue
        record = result(path)
        parts.append(
            f"on {named}, {len(record['realizations'])} realizations: {threshold_fit(record, '1')}; the rear-most "
            f"point moved 2 m {threshold_fit(record, '2')} (`benchmarks/results/{path[:-5]}.md`)"
        )
    return (" The same at the same meshes " + "; ".join(parts) + ".") if parts else ""
