"""Figures in the repository's documents, rendered from the committed result files that measured them.

A document marks a rendered passage with ``<!-- rendered: NAME -->`` … ``<!-- end rendered -->`` (both indented
alike, inside a list item); NAME is one of :data:`RENDERERS`, which reads its result file(s) under
``benchmarks/results`` and writes the passage. Each result file records the command and the commit that made it,
and the passage says both; a file made before results recorded their commit is read with ``legacy=True`` and its
passage names the commit that committed it (its ``committed_in``) instead, as such. ``python -m
rgns.report.documents`` rewrites every marked passage; ``--check`` lists those that differ from their rendering
(tests/test_documents.py runs it), so a figure edited by hand, or a result re-measured without its documents,
fails the tests.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import statistics
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
RESULTS = REPO / "benchmarks" / "results"
BLOCK = re.compile(
    r"^(?P<indent> *)<!-- rendered: (?P<name>[\w-]+) -->\n(?P<body>.*?)^(?P=indent)<!-- end rendered -->",
    re.DOTALL | re.MULTILINE,
)
# the documents that may hold rendered passages
DOCUMENTS = ("README.md", "docs/*.md", "rgns/models/*.md")
# issue 42's measurement of the default before its route changed (256 realizations gated to the MPM, 16 pairs)
BEFORE_SECONDS = 23 * 60 + 57
BEFORE_HALF_WIDTH = {"0.1": 2.1, "0.01": 3.3}  # the whole interval's
BEFORE_AT_ORDER = {"0.1": 1.3, "0.01": 2.4}  # its sampling part at the order's value


class DocumentError(ValueError):
    """A rendered passage that names no renderer, or a result file that lacks what a passage needs."""


def parts(record: Any) -> Iterator[dict[str, Any]]:
    """Every dict within a result record, itself first (a result made in runs records each run's commit)."""
    if isinstance(record, dict):
        yield record
        for value in record.values():
            yield from parts(value)
    elif isinstance(record, list):
        for value in record:
            yield from parts(value)


def result(name: str, legacy: bool = False) -> dict[str, Any]:
    """A committed result file, checked to record its command and commit. ``legacy``: a file made before results
    recorded their commit must say which commit committed it (``"committed_in"``), named in its place."""
    path = RESULTS / name
    shown = path.relative_to(REPO) if path.is_relative_to(REPO) else path
    if not path.exists():
        raise DocumentError(f"{shown}: no such result file")
    record = json.loads(path.read_text())
    made = list(parts(record))
    if legacy and not any(part.get(key) for part in made for key in ("commit", "commits")):
        if not record.get("committed_in"):
            raise DocumentError(f"{shown}: records no commit, nor the commit that committed it ('committed_in')")
        return record
    for keys in (("commit", "commits"), ("command", "commands")):
        if not any(part.get(key) for part in made for key in keys):
            raise DocumentError(f"{shown}: records no {' or '.join(keys)}")
    return record


def minutes(seconds: float) -> str:
    whole = round(seconds)
    return f"{whole // 60} min {whole % 60:02d} s"


def ends(entry: list[float | None], digits: int = 2) -> str:
    """'v m [lo, hi]' of [value, lower, upper] (an open end: 'open')."""
    value, lower, upper = (("open" if x is None else f"{x:.{digits}f}") for x in entry)
    return f"{value} m [{lower}, {upper}]"


def bracketed(entry: list[float], digits: int = 3, sign: str = "") -> str:
    """'v [lo, hi]' of [value, lower, upper] (``sign`` "+": the value's sign always shown)."""
    value, lower, upper = entry
    return f"{value:{sign}.{digits}f} [{lower:.{digits}f}, {upper:.{digits}f}]"


def r2(entry: dict[str, Any]) -> str:
    return bracketed(entry["r2"])


def half(entry: list[float | None]) -> float:
    lower, upper = entry[-2], entry[-1]
    return float("inf") if lower is None or upper is None else (upper - lower) / 2.0


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
    it: nothing) and the machine's pace against the cost table's one-thread 0.5 m MPM of the same case
    (mesh_levels.json)."""
    head = record["cases"][case]
    lines = []
    table_cases = result("mesh_levels.json")
    if "cost_s" in head and case in table_cases:  # a case the cost table ran (a site's own geometry costs its own)
        table = table_cases[case]["seconds"]["0.5"]
        slower = head["cost_s"]["high_s"] / table
        lines.append(
            f"Its 0.5 m MPM ran {slower:.1f}× slower than the cost table's one thread ({table:.1f} s per "
            f"realization, `benchmarks/results/mesh_levels.json`); the run's time divided by that ratio, "
            f"{minutes(record['seconds'] / slower)}, estimates it at the cost table's pace (an estimate, not a "
            "measurement)."
        )
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


def machine_pace() -> str:
    """README: this machine's pace against the cost table's, the same realization run by each named commit's own
    code (machine_pace.json), and so whether a slow timed run is the machine's or the code's."""
    record = result("machine_pace.json")
    table = record["cost_table"]
    runs = record["runs"]
    same = all(run["runout_m"] == table["runout_m"] for run in runs)
    timed = "; ".join(
        f"{run['seconds']:.1f} s with the code of {run['code']} ({run['date']}, load {run['load_before']:.2f} before)"
        for run in runs
    )
    return (
        f"Case 1's realization 0 at 0.5 m, one thread, took {table['seconds']:.1f} s in the cost table's run "
        f"({table['date']}, committed in {table['commit']}) and takes {timed} (each commit's own code in a "
        f"worktree: `{record['command']}`), "
        + (
            f"the same runout to the last digit ({table['runout_m']!r} m): the machine slowed, not the code."
            if same
            else "with another runout: the code changed what it computes."
        )
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
    """README: case 1's mean influence distance from 0.5 to 0.25 m cells (mesh_levels.json), why the 0.5 m
    influence distances are likely short."""
    levels = result("mesh_levels.json")["case1"]
    fit = levels["fits"]["influence_m"]
    half, quarter = fit["mean_0.5"]["value"], fit["mean_0.25"]["value"]
    return (
        f"Case 1's mean influence distance still grows by {quarter - half:.2f} m from 0.5 to 0.25 m cells "
        f"({half:.2f} → {quarter:.2f} m on {len(levels['realizations'])} realizations: "
        "`benchmarks/results/mesh_levels.md`), so the 0.5 m influence distances are likely short."
    )


def tuned_least() -> str:
    """README: the tuned cheap route's least speed-up over the 0.5 m MPM alone, over every quantity and budget of
    docs/fidelity.md's table (hifi_surrogate.json)."""
    record = result("hifi_surrogate.json", legacy=True)
    least = least_tuned_speedup(record)
    return (
        f"With the tuned surrogate as cheap route it reaches a given error {least:.2f}× faster than the 0.5 m MPM "
        "alone at least, over the means of R, V and I and the exceedance probabilities at every budget measured, on "
        f"the pool the tuning was chosen on (`{record['command']}`, committed in {record['committed_in']}: "
        "`benchmarks/results/hifi_surrogate.md`)."
    )


def card(name: str) -> dict[str, Any]:
    """A shipped model's card (rgns/models/<name>), written by the rule that trained the model beside it."""
    path = REPO / "rgns" / "models" / name
    if not path.exists():
        raise DocumentError(f"{path.relative_to(REPO)}: no such model card")
    return json.loads(path.read_text())


def gns_training() -> str:
    """docs/surrogates.md: how the shipped GNS was trained and how far its one-step loss fell, from its card."""
    record = card("card.json")
    sets = record["config"]["sets"]
    train, valid = (sum(entry["count"] for entry in sets[name]) for name in ("train", "valid"))
    last, kept = record["last_validation"], record["kept_validation"]
    mean = last["valid_mean_predictor_loss"]
    return (
        f"{train} training and {valid} held-out runs of the embedded MPM, then {record['steps']:,} training steps in "
        f"{minutes(record['wall_s'])} on one thread. Its one-step loss on the held-out windows ends "
        f"{mean / last['valid_one_step_loss']:.1f}× below the mean predictor's (the kept step-"
        f"{record['selected_step']:,} checkpoint: {mean / kept['valid_one_step_loss']:.1f}×; "
        "`rgns/models/card.json`)."
    )


# gns_recipe.py's variants as docs/gns-training.md names them, and those rolled out after the paper's 6-frame
# hand-over (the others after 2 s of MPM); the file predates recording either
RECIPE_LABELS = {
    "recipe": "recipe: smoothed targets, padded frames dropped, noise 5·10⁻⁵ folded into the normalisation, "
    "targets clipped at ±25, lr annealed 1e-3 → 1e-5",
    "no_smoothing": "raw targets (σ = 0)",
    "noise_2e-4": "noise 2·10⁻⁴",
    "with_padding": "padded early-stop frames drawn too",
    "acceleration_features": "acceleration features (below)",
    "old": "the recipe before issue 15 (raw, padding, noise 2·10⁻⁴ not folded, no clip, lr 1e-3 decaying 0.1 per "
    "5,000)",
}
SIX_FRAME_HANDOVER = {"recipe", "acceleration_features", "old"}


def gns_recipe() -> str:
    """docs/gns-training.md: each ingredient of the GNS's training recipe changed alone (gns_recipe.json)."""
    record = result("gns_recipe.json", legacy=True)
    lines = [
        "| variant (the recipe with one change) | loss / mean predictor, smoothed windows | raw windows | "
        "mean abs R error (m) |",
        "|---|---:|---:|---:|",
    ]
    for row in record["variants"]:
        mark = " ᵃ" if row["variant"] in SIX_FRAME_HANDOVER else ""
        lines.append(
            f"| {RECIPE_LABELS.get(row['variant'], row['variant'])} | {row['smoothed_loss_over_mean_predictor']:.3f} | "
            f"{row['raw_loss_over_mean_predictor']:.3f} | {row['valid_runout_error_m']:.2f}{mark} |"
        )
    steps = {row["steps"] for row in record["variants"]}
    lines += [
        "",
        f"{' / '.join(str(s) for s in sorted(steps))} training steps each; ᵃ rolled out after the paper's 6-frame MPM "
        "hand-over, the other rows after 2 s (81 frames). `" + record["command"] + "`, "
        f"`benchmarks/results/gns_recipe.json` {made_note(record)}.",
    ]
    return "\n".join(lines)


def gns_jitter() -> str:
    """docs/gns-training.md: how much of the per-frame acceleration the smoothing removes (gns_jitter.json)."""
    record = result("gns_jitter.json")
    raw, smooth, removed = record["raw_std"], record["smoothed_std"], record["variance_removed"]
    return (
        f"On the {record['runs']} held-out runs the per-frame acceleration has standard deviation "
        f"{raw[0] * 1e3:.2f}·10⁻³ (x) and {raw[1] * 1e3:.2f}·10⁻³ (y) m/frame²; after a Gaussian filter in time of "
        f"σ = {record['smoothing_frames']:g} frames, {smooth[0] * 1e3:.2f}·10⁻³ and {smooth[1] * 1e3:.2f}·10⁻³: the "
        f"filter removes {removed[0]:.0%} (x) and {removed[1]:.0%} (y) of its variance (`{record['command']}`, "
        f"made at {record['commit']})."
    ).replace("%", " %")


def gns_handover() -> str:
    """docs/gns-training.md: R of held-out runs in MPM and in the GNS per hand-over (gns_handover.json)."""
    record = result("gns_handover.json")
    handovers = record["handovers"]
    runs = len(handovers[0]["runs"])
    stands = [all(entry["runs"][k]["mpm_runout_m"] == 0.0 for entry in handovers) for k in range(runs)]
    lines = [
        "| hand-over after | "
        + " | ".join(f"run {k + 1}" + (" (stands)" if stands[k] else "") for k in range(runs))
        + " |",
        "|---" * (runs + 1) + "|",
    ]
    for entry in handovers:
        seconds = (entry["warmup_frames"] - 1) * record["frame_interval_s"]  # frame 0 is the start
        cells = [
            f"{row['mpm_runout_m']:.2f} → {row['gns_runout_m']:.2f}"
            + ("" if row["status"] == "ok" else f" ({row['status']})")
            for row in entry["runs"]
        ]
        lines.append(f"| {entry['warmup_frames']} frames ({seconds:g} s) | " + " | ".join(cells) + " |")
    lines += ["", f"`{record['command']}`, made at {record['commit']}."]
    return "\n".join(lines)


def power(value: float) -> str:
    """A power of ten as '1e-3'."""
    return f"{value:.0e}".replace("e-0", "e-").replace("e+0", "e")


def gns_shipped() -> str:
    """docs/gns-training.md: how the shipped GNS was trained and which checkpoint was kept, from its card."""
    record = card("card.json")
    last, kept = record["last_validation"], record["kept_validation"]
    mean = last["valid_mean_predictor_loss"]
    schedule = record["config"]["gns"]
    return (
        f"{record['steps']:,} steps ({minutes(record['wall_s'])} on one thread, in two runs: killed at step "
        f"{record['evaluation']['resumed_from']:,} and resumed from its checkpoint), learning rate "
        f"{power(schedule['learning_rate'])} annealed towards {power(schedule['learning_rate'] * schedule['decay_rate'])} "
        "over "
        f"{schedule['decay_steps']:,} steps. "
        f"On the held-out windows the one-step loss ends at {last['valid_one_step_loss']:.3f} against the mean "
        f"predictor's {mean:.2f} ({mean / last['valid_one_step_loss']:.1f}× below); the model kept is step "
        f"{record['selected_step']:,} ({kept['valid_one_step_loss']:.3f}, {mean / kept['valid_one_step_loss']:.1f}× "
        f"below), whose {schedule['selection_trajectories']} held-out rollouts had the best R, V, I score (mean |R error| "
        f"{kept['valid_runout_error_m']:.2f} m; the last step's: {last['valid_runout_error_m']:.2f} m) "
        "(`rgns/models/card.json`)."
    )


def general_training() -> str:
    """docs/surrogates.md: what the geometry-general end-state model learned from and how long it trained, from its
    card."""
    record = card("endstate_general_card.json")
    sets = len(record["cases"])
    evaluation = record["evaluation"]
    return (
        f"It was trained on {sets * record['realizations_per_case']:,} MPM runs (plus "
        f"{sets * record['held_out_per_case']:,} held out; {record['realizations_per_case']} + "
        f"{record['held_out_per_case']} per set of {sets}), {record['steps']:,} steps in {minutes(record['wall_s'])} "
        f"on the GPU; its held-out loss ends at {evaluation['valid_loss']:.4f} against the mean predictor's "
        f"{evaluation['valid_mean_predictor_loss']:.3f} (`rgns/models/endstate_general_card.json`)."
    )


def endstate_training() -> str:
    """docs/surrogates.md: how the test-case end-state model was trained, from its card."""
    record = card("endstate_card.json")
    runs = len(record["cases"]) * (record["realizations_per_case"] + record["held_out_per_case"])
    evaluation = record["evaluation"]
    loss, mean = evaluation["valid_loss"], evaluation["valid_mean_predictor_loss"]
    return (
        f"{runs:,} training and held-out MPM runs ({record['realizations_per_case']} + {record['held_out_per_case']} "
        f"per case of {', '.join(record['cases'])}), then {record['steps']:,} steps in {minutes(record['wall_s'])}: "
        f"the held-out loss ends at {loss:.6f} against the mean predictor's {mean:.3f} ({mean / loss:,.0f}× below; "
        "`rgns/models/endstate_card.json`, learning curve in the card)."
    )


def endstate_untouched() -> str:
    """The test-case end-state model's card: its agreement with MPM runs of the test cases no choice touched."""
    import pandas as pd

    from rgns.surrogates.endstate.evaluate import markdown_table

    record = result("endstate_untouched.json")
    return "\n".join(
        [
            f"{record['model'][0]['n']} realizations per test case drawn from seed {record['data_seed']}, which no "
            f"training or choice of this model touched, run by the embedded MPM at 1 m (made at {record['commit']} by "
            f"`{record['command']}`; `benchmarks/results/endstate_untouched.md`). In distribution: the test cases' "
            "own families and fields, fresh realizations.",
            "",
            markdown_table(pd.DataFrame(record["model"])).strip(),
        ]
    )


def untouched_subset(record: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """cheap_route.json's subset of realizations no choice touched: its range ("64-127") and its rows per model."""
    name = next(name for name in record["subsets"] if name.startswith("untouched"))
    return name.split("(")[1].rstrip(")"), record["subsets"][name]


def cheap_route_choice() -> str:
    """README: which surrogate is the correction's cheap route, by its correlation with the 0.5 m MPM on
    realizations no choice touched."""
    record = result("cheap_route.json")
    realizations, models = untouched_subset(record)
    best, second = record["best"]["model"], record["best"]["second"]
    r_best, r_general = models[best]["runout_m"]["r_0.5"], models["endstate_general"]["runout_m"]["r_0.5"]
    return (
        f"The correction's cheap route, {best}, against the 0.5 m MPM: runout r {bracketed(r_best)} against the "
        f"general model's {bracketed(r_general)} on realizations {realizations} of seed {record['seed']}, which no "
        f"choice touched; the best by a paired bootstrap of the difference from the next, {second} "
        f"({bracketed(record['best']['r_difference'], sign='+')}): `{record['command']}` at {record['commit']}, "
        "`benchmarks/results/cheap_route.md`."
    )


def tuned_untouched() -> str:
    """The tuned model's card: its agreement with the 0.5 m MPM itself on realizations no choice touched."""
    record = result("cheap_route.json")
    realizations, models = untouched_subset(record)
    rows = models["endstate_tuned"]
    first, last = realizations.split("-")
    lines = [
        f"Case 1, realizations {first}–{last} of seed {record['seed']} (the default Monte Carlo's), which no training "
        "or choice of this model touched (0–63 were the pool it was judged on), against the MPM at 0.5 m cells "
        "measured on the MPM's own points, as every report's pairs are (made on a GPU: "
        "`benchmarks/results/mesh_levels_gpu`), with 95 % bootstrap intervals over the "
        f"{int(last) - int(first) + 1} realizations; `{record['command']}` at {record['commit']}. In distribution: "
        "the family and field the model was tuned on, fresh realizations. The correction removes any bias; the "
        "correlation sets its gain.",
        "",
        "| metric | r with the 0.5 m MPM | R² | bias (model − MPM) |",
        "| --- | --- | --- | --- |",
    ]
    for metric in ("runout_m", "volume_m2", "influence_m"):
        row = rows[metric]
        cells = [bracketed(row[key], digits) for key, digits in (("r_0.5", 3), ("R2_0.5", 3), ("bias_0.5", 2))]
        lines.append(f"| {metric.split('_')[0]} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


# the README's names of the out-of-distribution sets, in its order
OOD_SETS = {
    "ood_bench": "benched slope",
    "ood_concave": "concave slope",
    "hillside": "DEM section (`config/site.yaml`)",
    "ood_field": "a field model outside the training draws",
}


def standing(runout: dict[str, Any]) -> int:
    """How many of an ood_surrogate.json set's realizations the MPM left standing (its runout row)."""
    return runout["stood_both"] + runout["failed_model_only"]


def stood(runout: dict[str, Any]) -> str:
    """' (54 of 64 stand)' for a set the MPM mostly left standing, else ''."""
    return f" ({standing(runout)} of {runout['n']} stand)" if standing(runout) > runout["n"] / 2 else ""


def r2_interval(row: dict[str, Any]) -> str:
    """An ood_surrogate.json row's R² with its bootstrap interval."""
    return bracketed([row["r2"], row["r2_low"], row["r2_high"]])


def made_note(record: dict[str, Any]) -> str:
    """The commit a result file records, or the one that committed it where it records none."""
    return record.get("commit") or f"committed in {record['committed_in']}, which the file does not record"


def true_minus(text: str) -> str:
    """``text`` with its hyphen-minus signs written as a true minus sign, as the docs write them."""
    return text.replace("-", "−")


def ood_table() -> str:
    """README: the geometry-general surrogate's R² on sets it never trained on, and on the test cases."""
    record = result("ood_surrogate.json", legacy=True)
    rows = {(row["set"], row["metric"]): row for row in record["model"]}
    metrics = ("runout", "volume", "influence")
    cases = [name for name in ("case1", "case2", "case3", "case4") if (name, "runout") in rows]
    return "\n".join(
        [
            "| set (its realizations never trained on) | runout R | volume V | influence I |",
            "|---|---|---|---|",
            *(
                f"| {label}{stood(rows[name, 'runout'])} | "
                + " | ".join(r2_interval(rows[name, m]) for m in metrics)
                + " |"
                for name, label in OOD_SETS.items()
                if (name, "runout") in rows
            ),
            "| test cases "
            + " / ".join(c.removeprefix("case") for c in cases)
            + " (their families, `long_slope` and `column`, are in the training, `config/pretrain_general.yaml`; "
            "the rows above are not) | "
            + " | ".join(" / ".join(f"{rows[c, m]['r2']:.3f}" for c in cases) for m in metrics)
            + " |",
            "",
            f"Seed {record['data_seed']}; `{record['command']}` ({made_note(record)}).",
            "",
            ood_bias_and_cost(record, rows),
        ]
    )


# docs/surrogates.md's notes on the out-of-distribution sets' names
OOD_NOTES = {"hillside": " (DEM section)", "ood_field": " (field outside training)"}


def signed_percent(fraction: float) -> str:
    """'+0.9 %' / '−3.1 %'."""
    return true_minus(f"{100 * fraction:+.1f} %")


def ood_bias_table() -> str:
    """docs/surrogates.md: the geometry-general surrogate's R² and relative bias of R, V and I per set it never
    trained on and per test case (ood_surrogate.json)."""
    record = result("ood_surrogate.json", legacy=True)
    rows = {(row["set"], row["metric"]): row for row in record["model"]}
    sets = list(dict.fromkeys(row["set"] for row in record["model"]))
    lines = ["| set | runout R | volume V | influence I |", "|---|---|---|---|"]
    for name in sets:
        runout = rows[name, "runout"]
        cells = []
        for metric in ("runout", "volume", "influence"):
            row = rows[name, metric]
            cell = f"{r2_interval(row)}, {signed_percent(row['relative_bias'])}"
            if metric == "runout" and stood(runout):
                cell += true_minus(f" ({row['bias']:+.2f} m)")
            cells.append(cell)
        lines.append(f"| {name}{OOD_NOTES.get(name, '')}{stood(runout)} | " + " | ".join(cells) + " |")
    lines += ["", f"Seed {record['data_seed']}; `{record['command']}` ({made_note(record)})."]
    return "\n".join(lines)


def endstate_speed() -> str:
    """docs/surrogates.md: the test-case end-state model's cost per realization beside the MPM's and the GNS's, all
    timed in one benchmark run on the same realizations (multifidelity.json)."""
    record = result("multifidelity.json", legacy=True)
    cost = {name: route["s_per_realization"] for name, route in record["analysis"]["cheap"].items()}
    accurate = record["routes"]["MPM 0.5 m"]["s_per_realization"]
    model = cost["end-state surrogate (shipped)"]
    return (
        f"{1000 * model:.1f} ms per realization against {cost['MPM 1 m']:.2f} s for the 1 m MPM, {accurate:.1f} s for "
        f"the 0.5 m MPM and {cost['GNS (shipped)']:.1f} s for the GNS ({record['n']} case-1 realizations, "
        f"{record['machine']}; `{record['command']}`, committed in {record['committed_in']})."
    )


def ood_targets() -> str:
    """docs/surrogates.md: the geometry-general surrogate against its targets (R² ≥ 0.9 for R, V and I and |relative
    bias of R| ≤ 5 % on every unseen set; R² ≥ 0.95 for R and V on the test cases), beside the model it replaced
    (ood_surrogate.json's "compare" rows, the same realizations)."""
    record = result("ood_surrogate.json", legacy=True)
    new, old = ({(row["set"], row["metric"]): row for row in record[key]} for key in ("model", "compare"))
    sets = list(dict.fromkeys(row["set"] for row in record["model"]))
    cases = [name for name in sets if name.startswith("case")]
    unseen = [name for name in sets if name not in cases]

    def span(rows: dict[tuple[str, str], dict[str, Any]], metrics: tuple[str, ...]) -> str:
        values = [rows[name, metric]["r2"] for name in cases for metric in metrics]
        return f"{min(values):.3f}–{max(values):.3f}"

    missed = []
    for name in unseen:
        for metric in ("runout", "volume", "influence"):
            row = new[name, metric]
            if row["r2"] < 0.9:
                missed.append(
                    f"{name}'s {metric} (R² {row['r2']:.3f}; the replaced model {old[name, metric]['r2']:.3f})"
                )
        if abs(new[name, "runout"]["relative_bias"]) > 0.05 and not stood(new[name, "runout"]):
            missed.append(f"{name}'s runout bias ({signed_percent(new[name, 'runout']['relative_bias'])})")
    met = [name for name in unseen if not any(text.startswith(f"{name}'s") for text in missed)]
    cases_met = all(new[name, metric]["r2"] >= 0.95 for name in cases for metric in ("runout", "volume"))
    return (
        f"Against the targets (R² ≥ 0.9 for R, V and I and |relative bias of R| ≤ 5 % on every unseen set; R² ≥ 0.95 "
        f"for R and V on the test cases): the test cases {'meet' if cases_met else 'miss'} theirs (R and V R² "
        f"{span(new, ('runout', 'volume'))}, where the replaced model had {span(old, ('runout', 'volume'))}); "
        + (f"{', '.join(met)} {'meets' if len(met) == 1 else 'meet'} every one. " if met else "")
        + ("Not met: " + "; ".join(missed) + "." if missed else "Every target is met.")
        + f" (`benchmarks/results/ood_surrogate.json`, {made_note(record)}.)"
    )


def ood_bias_and_cost(record: dict[str, Any], rows: dict[tuple[str, str], dict[str, Any]]) -> str:
    """The runout's bias on each unseen set (relative, or in metres on a set the MPM mostly left standing), and the
    model's cost per realization against the 1 m MPM's."""

    def bias(name: str) -> str:
        row = rows[name, "runout"]
        if stood(row):
            return true_minus(f"{row['bias']:+.2f} m of a {row['mpm_mean']:.2f} m mean")
        return signed_percent(row["relative_bias"])

    cost = record["cost"]
    return (
        "Runout's bias on the sets above, model − MPM: "
        + "; ".join(f"{label} {bias(name)}" for name, label in OOD_SETS.items() if (name, "runout") in rows)
        + f". Per realization the model costs {1000 * cost['model_s']:.1f} ms against the 1 m MPM's "
        f"{cost['mpm_s']:.2f} s ({cost['ratio']:.0f}×, one thread each, {cost['realizations']} realizations of "
        f"{cost['case'].replace('case', 'case ')})."
    )


def bench_fields() -> str:
    """docs/benchmarks.md: random-field throughput, Kronecker against the paper's dense Cholesky, from one run."""
    record = result("fields.json")
    made = f"`fields.json`, made at {record['commit']}"
    command = f"`{record['command']}`"
    rows, columns = record["grid"]
    paper_minutes = 73  # the paper's ~73 min for 10,000 fields by factor-per-field Cholesky
    lines = [
        "| what | figure | command | made at |",
        "|---|---|---|---|",
        f"| {record['fields']:,} Kronecker fields, paper grid {rows} × {columns} | {record['kronecker_total_s']:.1f} s "
        f"({record['kronecker_per_field_ms']:.2f} ms per field; target ≤ {record['target_total_s']:.0f} s) | "
        f"{command} | {made} |",
        f"| one dense-Cholesky field as the paper ran it (factor + sample) | {record['cholesky_per_field_s']:.2f} s "
        f"per field → ~{record['cholesky_total_estimate_s'] / 60:.0f} min per {record['fields']:,} (paper: "
        f"~{paper_minutes} min) | {command} | {made} |",
        f"| {record['fields']:,} dense-Cholesky fields with one factor reused | "
        f"{record['cholesky_factor_reused_total_s']:.1f} s (Kronecker {record['speedup_vs_factor_reused']:.1f}× "
        f"faster) | {command} | {made} |",
        f"| Kronecker vs factor-per-field Cholesky | ~{round(record['speedup_per_field'], -2):,.0f}× per field | "
        f"{command} | {made} |",
        "",
        f"On {record['machine']}, numpy {record['numpy']}.",
    ]
    return "\n".join(lines)


def order_text(entry: list[float] | None) -> str:
    """A mesh_order entry [lower, value, upper] as 'v [lo, hi]', or that it has no asymptotic range."""
    return "no asymptotic range" if entry is None else f"{entry[1]:.2f} [{entry[0]:.2f}, {entry[2]:.2f}]"


def scenes_row() -> str:
    """docs/benchmarks.md: cases built in memory against written and read back, per run length (scenes.json)."""
    record = result("scenes.json")
    runs = record["runs"]
    disk_setup = [1000 * run["setup_s"]["disk"] for run in runs]
    memory_setup = max(1000 * run["setup_s"]["memory"] for run in runs)
    ratios = "; ".join(
        f"{run['simulated_s']:g} s simulated {run['seconds']['disk'] / run['seconds']['memory']:.2f}× "
        f"({run['repeats']} repeat{'s' if run['repeats'] > 1 else ''})"
        for run in runs
    )
    identical = "identical" if all(run["identical"] for run in runs) else "NOT identical"
    return (
        f"| Monte Carlo cases in memory vs written and read back ({runs[0]['realizations']} case-1 realizations) | "
        f"{memory_setup:.1f} ms vs {min(disk_setup):.0f}–{max(disk_setup):.0f} ms set-up per realization; the "
        f"disk round trip's time over the in-memory one's, per realization: {ratios} (0.15 s is the GNS warm-up); "
        f"{identical} trajectories | "
        + ", ".join(f"`{run['command']}`" for run in runs)
        + " | `scenes.json` "
        + ", ".join(sorted({run["commit"] for run in runs}))
        + " |"
    )


def mesh_levels_row() -> str:
    """docs/benchmarks.md: the embedded MPM's mesh error on the Monte Carlo's realizations (mesh_levels.json)."""
    record = result("mesh_levels.json")
    case1, case3 = record["case1"], record["case3"]
    fits = case1["fits"]
    means = " / ".join(f"{fits['runout_m'][f'mean_{h}']['value']:.2f}" for h in ("1", "0.5", "0.25"))
    influence = fits["influence_m"]
    step = next(
        entry for entry in case1["against"]["comparisons"] if entry["quantity"].startswith("mesh step of the mean")
    )
    return (
        "| the embedded MPM's mesh error on the Monte Carlo's realizations, h = 1, 0.5, 0.25 m "
        f"(case 1: {len(case1['realizations'])}; case 3: {len(case3['realizations'])}) | case 1 mean runout {means} m, "
        f"order {order_text(case1['mesh_order']['runout_m'])}, by which the 0.5 m mesh's mean runout is short by "
        f"{ends(step['reference'])}, and the default run's mesh step of it, {ends(step['headline'])} "
        f"({case1['against']['headline']}), {'holds' if step['inside'] else 'DOES NOT hold'} that; volume: "
        f"{order_text(case1['mesh_order']['volume_m2'])}, influence: {order_text(case1['mesh_order']['influence_m'])} "
        f"(case 1's mean influence grows {influence['mean_0.5']['value']:.2f} → {influence['mean_0.25']['value']:.2f} m "
        f"from 0.5 to 0.25 m); case 3's runout: {order_text(case3['mesh_order']['runout_m'])}; the cost against plain "
        "0.25 m Monte Carlo and the 0.125 m "
        f"levels: `benchmarks/results/mesh_levels.md` | `{record['command']}` | `mesh_levels.json` {record['commit']} |"
    )


def mesh_levels_gpu_row() -> str:
    """docs/benchmarks.md: the direct 0.25 m reference of the default run's realizations, run on a GPU
    (mesh_levels_gpu.json)."""
    record = result("mesh_levels_gpu.json")
    gpu = record["case1"]
    agreement = gpu["cpu_agreement"]
    worst = max(agreement, key=lambda row: row["largest_m"])
    direct = [entry for entry in gpu["against"]["comparisons"] if not entry["quantity"].startswith("mesh")]
    held = "; ".join(
        f"{entry['quantity']} {ends(entry['headline'])} {'holds' if entry['inside'] else 'DOES NOT hold'} "
        f"{entry['reference'][0]:.2f} m"
        for entry in direct
    )
    return (
        f"| the direct 0.25 m reference on the default run's first {len(gpu['realizations'])} case-1 realizations at "
        f"h = {', '.join(f'{float(h):g}' for h in gpu['seconds'])} m, run on a GPU | "
        f"{sum(gpu['seconds'].values()):.1f} s per realization for the {len(gpu['seconds'])} meshes; runout within "
        f"{100 * worst['largest_m']:.1f} cm of the one-thread CPU runs on {agreement[0]['n']} (at "
        f"{worst['cell_size_m']:g} m); order of the mean runout {order_text(gpu['mesh_order']['runout_m'])}, of the "
        f"volume {order_text(gpu['mesh_order']['volume_m2'])}, of the influence "
        f"{order_text(gpu['mesh_order']['influence_m'])}; the default run's headline ({gpu['against']['headline']}): "
        f"{held} | `{record['command']}` | `mesh_levels_gpu.json` {record['commit']} |"
    )


def bench_current() -> str:
    """docs/benchmarks.md: the current rows that are not a table of their own, each from its result file."""
    return "\n".join(
        [
            "| what | figure | command | made at |",
            "|---|---|---|---|",
            scenes_row(),
            mesh_levels_row(),
            mesh_levels_gpu_row(),
        ]
    )


def bench_convergence() -> str:
    """docs/benchmarks.md: the embedded MPM's mesh error on case-1 slopes, per shape function and cell size, against
    the B-spline answer at 0.5 m, and the observed orders."""
    record = result("convergence.json")
    parts = sorted(set(record["parts_committed_in"].values()))
    made = f"`convergence.json`, its parts measured at {', '.join(parts)}, tabled at {record['commit']}"
    command = "`python benchmarks/convergence.py`, then `--report`"
    spread = record["slopes"]["range"]
    units = {"runout_m": "m", "volume_m2": "m²", "influence_m": "m"}
    lines = [
        "| shape, cell size | mean \\|Δ\\| from the B-spline 0.5 m answer: R / V / I (% of its range) | failed "
        "(R > 0) | command | made at |",
        "|---|---|---|---|---|",
    ]
    for shape, levels in record["slopes"]["shapes"].items():
        for cell, level in levels.items():
            if cell == "0.5" and shape == "bspline":
                continue  # the reference itself
            against = level["against_bspline"]["0.5"]
            error = " / ".join(
                f"{against[key]['mean_abs']:.2f} {unit} ({100 * against[key]['share_of_range']:.0f} %)"
                for key, unit in units.items()
            )
            n = against["runout_m"]["n"]
            diverged = f", {level['diverged']} diverged" if level["diverged"] else ""
            lines.append(
                f"| {'B-spline' if shape == 'bspline' else 'bilinear'}, {cell} m | {error} on {n} | "
                f"{level['failed']} of {level['finished']}{diverged} | {command} | {made} |"
            )
    orders = record["orders"]["bspline"]
    fitted = [
        f"{key.split('_')[0]} p = {fit['order']:.2f}" + ("" if fit["asymptotic"] else " (no asymptotic range)")
        for key, fit in orders.items()
    ]
    lines += [
        "",
        f"Range of the B-spline 0.5 m answers: R {spread['runout_m']:.2f} m, V {spread['volume_m2']:.1f} m², "
        f"I {spread['influence_m']:.2f} m. Observed B-spline orders from h = "
        f"{', '.join(f'{h:g}' for h in orders['runout_m']['cells'][-3:])} m on realizations "
        f"{orders['runout_m']['realizations']}: {'; '.join(fitted)}.",
    ]
    return "\n".join(lines)


def convergence_table() -> str:
    """docs/engine.md: every shape and cell size of the mesh-convergence study, its means and differences from the
    B-spline answers at 0.5 m (every realization) and at 0.25 m (the subset run there)."""
    record = result("convergence.json")
    keys = ("runout_m", "volume_m2", "influence_m")
    digits = {"runout_m": 2, "volume_m2": 1, "influence_m": 2}
    shapes = record["slopes"]["shapes"]
    counts = {ref: shapes["bspline"]["1"]["against_bspline"][ref]["runout_m"]["n"] for ref in ("0.5", "0.25")}
    lines = [
        f"| shape | h (m) | failed | mean R / V / I | \\|ΔR\\|, \\|ΔV\\|, \\|ΔI\\| vs B-spline 0.5 m "
        f"({counts['0.5']}) | vs B-spline 0.25 m ({counts['0.25']}) |",
        "|---|---|---:|---|---|---|",
    ]
    for shape, levels in shapes.items():
        for cell, level in levels.items():
            name, h = (
                (f"**{shape}**", f"**{cell} (default)**" if cell == "1" else cell)
                if shape == "bspline"
                else (
                    shape,
                    cell,
                )
            )
            means = " / ".join(f"{level['means'][k]:.{digits[k]}f}" for k in keys)
            columns = []
            for ref in ("0.5", "0.25"):
                against = level["against_bspline"][ref]
                if shape == "bspline" and cell == ref:
                    columns.append("–")
                    continue
                shares = ref == "0.5" or (shape == "bspline" and cell == "1")
                text = ", ".join(
                    f"{against[k]['mean_abs']:.{digits[k]}f}"
                    + (f" ({100 * against[k]['share_of_range']:.0f} %)" if shares else "")
                    for k in keys
                )
                n = against["runout_m"]["n"]
                if n != counts[ref]:
                    text += f" ({n})"
                columns.append(f"**{text}**" if shape == "bspline" and cell == "1" else text)
            diverged = f", {level['diverged']} diverged" if level["diverged"] else ""
            lines.append(
                f"| {name} | {h} | {level['failed']} of {level['finished']}{diverged} | {means} | "
                + " | ".join(columns)
                + " |"
            )
    spread = record["slopes"]["range"]
    lines += [
        "",
        f"The ranges of the B-spline 0.5 m answers over the {counts['0.5']} realizations: R {spread['runout_m']:.2f} m, "
        f"V {spread['volume_m2']:.1f} m², I {spread['influence_m']:.2f} m (`benchmarks/results/convergence.json`).",
    ]
    return "\n".join(lines)


def convergence_orders() -> str:
    """docs/engine.md: per shape, the mean R, I and V of the realizations run at every cell size, their observed
    order and Richardson value where the differences keep their sign and shrink (convergence.json)."""
    orders = result("convergence.json")["orders"]
    units = {"runout_m": "m", "influence_m": "m", "volume_m2": "m²"}
    names = {"runout_m": "R", "influence_m": "I", "volume_m2": "V"}

    def series(entry: dict[str, Any], key: str) -> str:
        digits = 1 if key == "volume_m2" else 2
        values = " → ".join(f"{v:.{digits}f}" for v in entry["series"])
        if entry["asymptotic"]:
            how = f"observed order p = {entry['order']:.2f}, Richardson value f* = {entry['converged']:.{digits}f} {units[key]}"
        else:
            how = "no asymptotic range"
        return f"{names[key]} {values} {units[key]} ({how})"

    sentences = []
    for shape, label in (("bspline", "B-spline"), ("linear", "Bilinear")):
        entries = orders[shape]
        cells = " / ".join(f"{h:g}" for h in entries["runout_m"]["cells"])
        sentences.append(
            f"{label}, on the {len(entries['runout_m']['realizations'])} realizations run at every h = {cells} m: "
            + "; ".join(series(entries[key], key) for key in ("runout_m", "influence_m", "volume_m2"))
            + "."
        )
    return " ".join(sentences) + " (`benchmarks/results/convergence.json`.)"


def convergence_column() -> str:
    """docs/engine.md: the column collapse's runout over width per shape and cell size, and the B-spline's order."""
    column = result("convergence.json")["column"]
    sentences = []
    for shape, label in (("bspline", "B-spline"), ("linear", "bilinear")):
        entry = column[shape]
        ran = [f"{v:.2f}" for v in entry["runout_ratio"] if v is not None]
        text = f"{label} {' → '.join(ran)}"
        fit = entry["fit"]
        if fit["asymptotic"]:
            text += f" (p = {fit['order']:.2f}, f* = {fit['converged']:.2f})"
        failed = [(h, status) for h, status in zip(entry["cells"], entry["status"]) if status != "ok"]
        text += "".join(f", then at {h:g} m {status}" for h, status in failed)
        sentences.append(text)
    cells = " / ".join(f"{h:g}" for h in column["bspline"]["cells"])
    return f"On the column, runout over width at h = {cells} m: {'; '.join(sentences)}."


def convergence_default_error() -> str:
    """docs/engine.md: the default 1 m B-spline mesh's error against the 0.5 m answers and against the converged
    values (Richardson where the series is asymptotic, else the finest), and what 0.5 m costs."""
    record = result("convergence.json")
    spread = record["slopes"]["range"]
    levels = record["slopes"]["shapes"]["bspline"]
    names = {"runout_m": ("R", "m", 2), "volume_m2": ("V", "m²", 1), "influence_m": ("I", "m", 2)}
    against = levels["1"]["against_bspline"]["0.5"]
    to_half = ", ".join(
        f"{name} {against[key]['mean_abs']:.{digits}f} {unit} ({100 * against[key]['share_of_range']:.0f} %)"
        for key, (name, unit, digits) in names.items()
    )
    orders = record["orders"]["bspline"]
    one = orders["runout_m"]["cells"].index(1.0)
    finest = f"{orders['runout_m']['cells'][-1]:g} m"
    to_converged = ", ".join(
        f"{name} {true_minus(format(orders[key]['errors'][one], '+.1f'))} {unit} "
        f"({100 * abs(orders[key]['errors'][one]) / spread[key]:.0f} %)"
        for key, (name, unit, _) in names.items()
    )
    reference = "; ".join(
        f"{names[key][0]} its {'Richardson value' if orders[key]['asymptotic'] else finest + ' value'}" for key in names
    )
    n_all = against["runout_m"]["n"]
    verdict = (
        f"every realization fails at 1 m and at 0.5 m ({levels['1']['failed']} of {n_all})"
        if levels["1"]["failed"] == levels["0.5"]["failed"] == n_all
        else f"{levels['1']['failed']} of {n_all} fail at 1 m, {levels['0.5']['failed']} at 0.5 m"
    )
    cost = record["diagnose"]
    coarse, fine = cost["bspline, 1 m, 2x2 points"], cost["bspline, 0.5 m"]
    return (
        f"Against the 0.5 m answer on {n_all} realizations, {to_half}; on the "
        f"{len(orders['runout_m']['realizations'])} realizations run at every h, against the converged value "
        f"({reference}), {to_converged}. The failed/stood verdict: {verdict}. 0.5 m costs "
        f"{fine['s_per_realization'] / coarse['s_per_realization']:.1f}× the time per run (the uniform slopes of "
        f"the locking study below, one thread: {coarse['s_per_realization']:.1f} s against "
        f"{fine['s_per_realization']:.1f} s; `benchmarks/results/convergence.json`)."
    )


def route_label(name: str) -> str:
    """A locking-study route's change as the docs write it: 'linear, 1 m, 2x2 points' → '2 × 2 points'."""
    change = name.split(", ", 2)[-1]
    return re.sub(r"(\d)x(\d)", r"\1 × \2", change).replace("nu ", "ν ")


def locking_routes() -> str:
    """docs/engine.md: the bilinear 1 m runouts of the long slope at φ 30° and 34°, one change at a time."""
    routes = result("convergence.json")["diagnose"]
    cells = [
        f"{route_label(name)} {' / '.join('0' if r == 0 else f'{r:.1f}' for r in entry['runout_m'])}"
        for name, entry in routes.items()
        if name.startswith("linear, 1 m")
    ]
    return "; ".join(cells) + " (`benchmarks/results/convergence.json`)."


def locking_bspline() -> str:
    """docs/engine.md: the converged slide's depth and the B-spline runouts of the locking study's slopes."""
    routes = result("convergence.json")["diagnose"]
    fine = routes["bspline, 0.5 m"]

    def pair(values: list[float]) -> str:
        return " / ".join(f"{v:.1f}" for v in values)

    return (
        f"The converged slide starts {pair(fine['slide_depth_m'])} m below the surface (B-spline 0.5 m). With "
        f"B-splines at 1 m the same slopes run out {pair(routes['bspline, 1 m, 2x2 points']['runout_m'])} m with "
        f"2 × 2 points and {pair(routes['bspline, 1 m, 4x4 points']['runout_m'])} m with 4 × 4, against "
        f"{pair(fine['runout_m'])} m at 0.5 m."
    )


def speedups(cheap: dict[str, Any], quantities: list[str], wanted: list[str], runs: list[int]) -> str:
    """'a / b×' of the measured speed-ups of ``wanted`` quantities at ``runs`` accurate runs' time."""
    at = {budget["high_runs"]: budget["speedup"] for budget in cheap["budgets"]}
    return " / ".join(f"{at[n][quantities.index(q)]:.2f}" for q in wanted for n in runs) + "×"


def speedup_cell(cheap: dict[str, Any], quantities: list[str], column: str) -> str:
    """'a / b / c× (ρ r)': one quantity's speed-ups at every budget a cheap route was measured at, and its
    correlation with the accurate route."""
    runs = [budget["high_runs"] for budget in cheap["budgets"]]
    return f"{speedups(cheap, quantities, [column], runs)} (ρ {cheap['correlation'][quantities.index(column)]:.3f})"


def bench_multifidelity() -> str:
    """docs/benchmarks.md: multi-fidelity against plain 0.5 m Monte Carlo at equal wall time, per cheap route
    (multifidelity.json), and with the surrogate tuned on 0.5 m runs (hifi_surrogate.json)."""
    plain = result("multifidelity.json", legacy=True)
    tuned = result("hifi_surrogate.json", legacy=True)
    q, cheap = plain["analysis"]["quantities"], plain["analysis"]["cheap"]
    one, shipped = cheap["MPM 1 m"], cheap["end-state surrogate (shipped)"]
    tq, tuned_cheap = tuned["analysis"]["quantities"], tuned["analysis"]["cheap"]["end-state surrogate, tuned on 0.5 m"]
    used = [i for i, name in enumerate(tq) if not name.startswith("P(") or name.endswith("regression")]
    tuned_least = min(budget["speedup"][i] for budget in tuned_cheap["budgets"] for i in used)
    figure = (
        f"with the 1 m MPM as cheap route ({one['s_per_realization']:.2f} vs "
        f"{plain['routes']['MPM 0.5 m']['s_per_realization']:.2f} s per realization), at 16 / 32 accurate runs' "
        f"time: mean R {speedups(one, q, ['mean R'], [16, 32])}, mean V {speedups(one, q, ['mean V'], [16, 32])}, "
        f"mean I {speedups(one, q, ['mean I'], [16, 32])}; P(R > r50), P(R > r10) "
        f"{speedups(one, q, ['P(R > r50), regression'], [16, 32])} and "
        f"{speedups(one, q, ['P(R > r10), regression'], [16, 32])} by the regression control variate "
        f"({speedups(one, q, ['P(R > r50)'], [16, 32])} and {speedups(one, q, ['P(R > r10)'], [16, 32])} by the "
        f"indicator one); with the shipped end-state surrogate ({shipped['s_per_realization']:.3f} s) mean R / V / I "
        f"{speedups(shipped, q, ['mean R', 'mean V', 'mean I'], [16])} at 16 runs' time, P(R > r50), P(R > r10) "
        f"{speedups(shipped, q, ['P(R > r50), regression', 'P(R > r10), regression'], [16])}; tuned on "
        f"{tuned['args']['train']} coarse-grained 0.5 m runs (`benchmarks/hifi_surrogate.py`): mean R / V / I "
        f"{speedups(tuned_cheap, tq, ['mean R', 'mean V', 'mean I'], [16])}, P(R > r50), P(R > r10) "
        f"{speedups(tuned_cheap, tq, ['P(R > r50), regression', 'P(R > r10), regression'], [16])} at 16 runs' time "
        f"(the least at 8, 16 and 32 over the means and the regression estimates of P, the estimators the pipeline "
        f"uses: {tuned_least:.2f}×, on the pool the tuning was chosen on)"
    )
    return "\n".join(
        [
            "| what | figure | command | made at |",
            "|---|---|---|---|",
            f"| multi-fidelity vs plain 0.5 m MC at equal wall time, {plain['n']} case-1 realizations | {figure} | "
            f"`{plain['command'].split(' (')[0]}`, then `--analyse`; `{tuned['command'].split(' (')[0]}` | "
            f"`multifidelity.json` committed in "
            f"{plain['committed_in']}, `hifi_surrogate.json` committed in {tuned['committed_in']} |",
        ]
    )


def lowest_work(candidates: list[dict[str, Any]], cheap: int) -> str:
    """Where an allocation's cost × half-width² is lowest among ``candidates`` with ``cheap`` cheap runs, and the
    range of pairs within 10 % of it."""
    rows = sorted((c for c in candidates if c["cheap"] == cheap), key=lambda c: c["pairs"])
    best = min(rows, key=lambda c: c["work_width"])
    near = [c["pairs"] for c in rows if c["work_width"] <= 1.1 * best["work_width"]]
    return f"{best['pairs']} pairs (within 10 % of it from {near[0]} to {near[-1]})"


def pct(value: float) -> str:
    """A fraction as a percentage to one decimal."""
    return f"{100 * value:.1f} %"


def chain_gains(record: dict[str, Any]) -> dict[str, float]:
    """chain_coverage.json: per quantity, plain Monte Carlo's cost × variance over its default allocation's."""
    gains = {}
    for name, entry in record["allocation"].items():
        default = next(
            c for c in entry["candidates"] if c["pairs"] == record["pairs"] and c["cheap"] == record["cheap"]
        )
        gains[name] = entry["plain_work_variance"] / default["work_variance"]
    return gains


def bench_chain_coverage() -> str:
    """docs/benchmarks.md: the fidelity chain's coverage and allocation on the real runs (chain_coverage.json)."""
    record = result("chain_coverage.json", legacy=True)
    coverage, distances, allocation = record["coverage"], record["distances"], record["allocation"]
    gains = chain_gains(record)
    mean_name, p_name = list(allocation)
    figure = (
        f"converged mean runout covered in {pct(coverage['runout_m (sampling only)']['coverage'])} (sampling "
        f"interval; {pct(coverage['runout_m']['coverage'])} with the order's range), V "
        f"{pct(coverage['volume_m2']['coverage'])}, I {pct(coverage['influence_m']['coverage'])}; through the "
        f"pipeline's estimators over {distances['0.5']['replicates']} replicates the runout exceeded with P 0.5 and "
        f"0.1 covered in {pct(distances['0.5']['direct']['coverage_at_order'])} and "
        f"{pct(distances['0.1']['direct']['coverage_at_order'])} (sampling interval of the joint bootstrap; "
        f"{pct(distances['0.5']['direct']['coverage'])} and {pct(distances['0.1']['direct']['coverage'])} with the "
        f"order's range); at equal sampling error {gains[mean_name]:.0f}× cheaper than plain 0.25 m Monte Carlo "
        f"for the converged mean runout, {gains[p_name]:.0f}× for {p_name.split(',')[0]}; at {record['cheap']} "
        f"cheap realizations the interval's cost × half-width² is lowest at "
        f"{lowest_work(allocation[mean_name]['candidates'], record['cheap'])} for the mean, at "
        f"{lowest_work(allocation[p_name]['candidates'], record['cheap'])} for {p_name.split(',')[0]} (then "
        f"default {record['pairs']})"
    )
    return "\n".join(
        [
            "| what | figure | command | made at |",
            "|---|---|---|---|",
            f"| the fidelity chain on real runs: coverage over {record['replicates']} resampled replicates of the "
            f"{record['population']} case-1 realizations at 1 / 0.5 / 0.25 m, and its allocation from measured costs "
            f"and correlations | {figure} | `{record['command']}` | `chain_coverage.json` committed in "
            f"{record['committed_in']} |",
        ]
    )


def mesh_step() -> str:
    """README: the step to the converged mesh, its order measured on case 1, against the direct reference of the
    GPU's 0.25 m runs, and the chain's coverage on the real runs (mesh_levels.json, mesh_levels_gpu.json,
    chain_coverage.json)."""
    cpu, gpu = result("mesh_levels.json"), result("mesh_levels_gpu.json")
    chain = result("chain_coverage.json", legacy=True)
    for name, record in (("mesh_levels.json", cpu), ("mesh_levels_gpu.json", gpu)):
        if "against" not in record["case1"]:
            raise DocumentError(f"benchmarks/results/{name}: no comparison with a default run (run it with --against)")
    order = cpu["case1"]["fits"]["runout_m"]["order"]
    compared = {entry["quantity"]: entry for entry in cpu["case1"]["against"]["comparisons"]}
    step = compared["mesh step of the mean runout (converged − 0.5 m; headline: over the order's interval)"]
    direct = [entry for entry in gpu["case1"]["against"]["comparisons"] if not entry["quantity"].startswith("mesh")]

    coverage, distances = chain["coverage"], chain["distances"]
    mean_name = list(chain["allocation"])[0]
    return (
        f"The step to the converged mesh uses the order measured on case 1's realizations at 1, 0.5 and 0.25 m: "
        f"{order['value']:.2f} [{order['lower']:.2f}, {order['upper']:.2f}] for runout on "
        f"{len(cpu['case1']['realizations'])} realizations, by which the 0.5 m mesh's mean runout is short by "
        f"{ends(step['reference'])}; the default run's step, {ends(step['headline'])} "
        f"({cpu['case1']['against']['headline']}), {'holds' if step['inside'] else 'DOES NOT hold'} it "
        f"(`benchmarks/results/mesh_levels.md`: `{cpu['command']}` at {cpu['commit']}). Its interval holds that "
        f"order's uncertainty, which is most of its width. Against a direct reference, the run's first "
        f"{len(gpu['case1']['realizations'])} realizations at 0.25 m plus their own Richardson step, run on a GPU "
        f"(`benchmarks/results/mesh_levels_gpu.md`, at {gpu['commit']}), the headline "
        + "; ".join(
            f"{entry['quantity']} {ends(entry['headline'])} {'holds' if entry['inside'] else 'DOES NOT hold'} "
            f"its {entry['reference'][0]:.2f} m"
            for entry in direct
        )
        + f". Over {chain['replicates']} replicates resampled from the {chain['population']} realizations at three "
        f"meshes the mean runout's sampling interval covered the known converged answer in "
        f"{pct(coverage['runout_m (sampling only)']['coverage'])} and the mean V and I in "
        f"{pct(coverage['volume_m2']['coverage'])} and {pct(coverage['influence_m']['coverage'])}; R exceeded with "
        f"P 0.5 and 0.1, through the pipeline's estimators over {distances['0.5']['replicates']}, in "
        f"{pct(distances['0.5']['direct']['coverage_at_order'])} and "
        f"{pct(distances['0.1']['direct']['coverage_at_order'])} (sampling part); at equal sampling error the chain "
        f"is {chain_gains(chain)[mean_name]:.0f}× cheaper than plain 0.25 m Monte Carlo for the converged mean "
        f"runout (`{chain['command']}`, committed in {chain['committed_in']}, {chain['pairs']} pairs and "
        f"{chain['cheap']} cheap runs: the estimators as they were then)."
    )


# docs/fidelity.md's names of multifidelity.json's cheap routes, in its order
ROUTE_LABELS = {
    "MPM 1 m": "MPM 1 m",
    "MPM 1 m, cfl 0.8": "MPM 1 m, CFL 0.8 (rejected)",
    "MPM 2 m": "MPM 2 m",
    "GNS (shipped)": "GNS (shipped)",
    "end-state surrogate (shipped)": "end-state surrogate (shipped at 6d09908, 8,000 steps)",
}


def gpu_levels() -> str:
    """docs/fidelity.md: the mesh levels run on a GPU: their time per realization against the one-thread CPU runs',
    their runout against those runs, and the orders their realizations give against the configured ones."""
    gpu, cpu = result("mesh_levels_gpu.json")["case1"], result("mesh_levels.json")["case1"]
    cells = list(gpu["seconds"])
    agreement = gpu["cpu_agreement"]
    worst = max(agreement, key=lambda row: row["largest_m"])
    mean = max(abs(row["mean_difference_m"]) for row in agreement)

    def order(entry: list[float] | None) -> str:
        return "no asymptotic range" if entry is None else f"{entry[1]:.2f} [{entry[0]:.2f}, {entry[2]:.2f}]"

    names = {"runout_m": "runout", "volume_m2": "volume", "influence_m": "influence"}
    orders = "; ".join(
        f"the {name}'s {order(gpu['mesh_order'][key])} (on the CPU's {len(cpu['realizations'])}: "
        f"{order(cpu['mesh_order'][key])})"
        for key, name in names.items()
    )
    return (
        f"{sum(gpu['seconds'].values()):.1f} s per realization for all {len(cells)} meshes (h = "
        f"{' / '.join(f'{float(h):g}' for h in cells)} m) in batches of 64, against "
        f"{' + '.join(format(cpu['seconds'][h], '.0f') for h in cells)} s on one CPU thread of the 2-core machine; the runout "
        f"agrees with the one-thread CPU runs on the {agreement[0]['n']} realizations both ran to "
        f"{100 * worst['largest_m']:.1f} cm at most (at {worst['cell_size_m']:g} m), {100 * mean:.2f} cm on average "
        f"(`benchmarks/results/mesh_levels_gpu.md`). That folder holds the first {len(gpu['realizations'])} "
        f"realizations at every mesh; the orders they give, as `mesh_order` would take them: {orders}."
    )


def multifidelity_routes() -> str:
    """docs/fidelity.md: every cheap route against plain 0.5 m Monte Carlo at equal wall time, speed-ups at 8 / 16 /
    32 accurate runs' time with each quantity's correlation, the exceedance probabilities by the indicator and the
    regression control variate (multifidelity.json)."""
    record = result("multifidelity.json", legacy=True)
    quantities, cheap = record["analysis"]["quantities"], record["analysis"]["cheap"]

    def cell(route: dict[str, Any], column: str) -> str:
        return speedup_cell(route, quantities, column)

    lines = [
        "| cheap route | s per realization | mean R | mean V | mean I | P(R > r50): indicator → regression | "
        "P(R > r10): indicator → regression |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, label in ROUTE_LABELS.items():
        route = cheap[name]
        probabilities = [f"{cell(route, p)} → {cell(route, f'{p}, regression')}" for p in ("P(R > r50)", "P(R > r10)")]
        lines.append(
            f"| {label} | {route['s_per_realization']:.3g} | "
            + " | ".join([cell(route, q) for q in ("mean R", "mean V", "mean I")] + probabilities)
            + " |"
        )
    budgets = " / ".join(str(b["high_runs"]) for b in cheap["MPM 1 m"]["budgets"])
    lines += [
        "",
        f"The accurate route, the MPM at 0.5 m: {record['routes']['MPM 0.5 m']['s_per_realization']:.2f} s per "
        f"realization. Speed-ups at {budgets} accurate runs' time, on the {record['n']}-realization pool; "
        f"`{record['command']}`, `benchmarks/results/multifidelity.json` committed in {record['committed_in']} "
        f"({record['machine']}).",
    ]
    return "\n".join(lines)


def indicator_ceiling(rho: float) -> float:
    """The correlation of 1[h > median] with its exact conditional probability given l, for (l, h) bivariate
    normal with correlation ``rho``: the best any regression on a cheap runout can do for an exceedance
    probability at the median (Var Φ(aZ) = arcsin(a² / (1 + a²)) / 2π, a = ρ / √(1 − ρ²))."""
    a2 = rho**2 / (1 - rho**2)
    return math.sqrt(2 * math.asin(a2 / (1 + a2)) / math.pi)


def needed_cost_ratio(rho: float, speedup: float) -> float:
    """How many times cheaper than the accurate route a cheap route correlating ``rho`` must be for the MFMC
    optimum, 1 / (√(1 − ρ²) + ρ √(c_L / c_H))², to reach ``speedup``."""
    root = (1 / math.sqrt(speedup) - math.sqrt(1 - rho**2)) / rho
    return 1 / root**2 if root > 0 else math.inf


def measured_speedups(route: dict[str, Any], quantities: list[str], names: list[str]) -> list[float]:
    """Every measured speed-up of a cheap route for ``names``, at every budget."""
    return [budget["speedup"][quantities.index(name)] for budget in route["budgets"] for name in names]


def route_span(route: dict[str, Any], quantities: list[str], names: list[str]) -> str:
    """'a–b×': the lowest and highest measured speed-up of ``names`` over every budget."""
    values = measured_speedups(route, quantities, names)
    return f"{min(values):.1f}–{max(values):.1f}×"


# the quantities of docs/fidelity.md's table of the tuned cheap route (hifi_surrogate.json)
TUNED_COLUMNS = ["mean R", "mean V", "mean I", "P(R > r50), regression", "P(R > r10), regression"]


def least_tuned_speedup(record: dict[str, Any]) -> float:
    """hifi_surrogate.json: the tuned route's least speed-up over the table's quantities and budgets."""
    analysis = record["analysis"]
    return min(
        measured_speedups(
            analysis["cheap"]["end-state surrogate, tuned on 0.5 m"], analysis["quantities"], TUNED_COLUMNS
        )
    )


def multifidelity_levers() -> str:
    """docs/fidelity.md: what each lever of the correction did, from multifidelity.json (speed-ups, correlations,
    costs, the routes' means)."""
    record = result("multifidelity.json", legacy=True)
    quantities, cheap, routes = record["analysis"]["quantities"], record["analysis"]["cheap"], record["routes"]

    def rho(route: str, quantity: str) -> float:
        return cheap[route]["correlation"][quantities.index(quantity)]

    def mean(route: str, key: str) -> float:
        rows = [row[key] for row in routes[route]["rows"] if row["status"] == "ok"]
        return sum(rows) / len(rows)

    one, cfl, two = "MPM 1 m", "MPM 1 m, cfl 0.8", "MPM 2 m"
    accurate = routes["MPM 0.5 m"]["s_per_realization"]
    w = accurate / cheap[one]["s_per_realization"]
    regression = rho(one, "P(R > r50), regression")
    indicators = ["P(R > r50)", "P(R > r10)"]
    fitted = [f"{p}, regression" for p in indicators]
    ceiling = indicator_ceiling(rho(one, "mean R"))
    return "\n".join(
        [
            f"* **The regression control variate** lifted the exceedance probabilities from "
            f"{route_span(cheap[one], quantities, indicators)} to {route_span(cheap[one], quantities, fitted)} (its "
            f"correlation with 1[h > r] is {regression:.2f} and {rho(one, fitted[1]):.2f} instead of the indicators' "
            f"{rho(one, indicators[0]):.2f} and {rho(one, indicators[1]):.2f}). Its ceiling: with the runouts "
            f"correlating {rho(one, 'mean R'):.3f}, 1[h > r] stays uncertain given l near r; even the exact "
            f"conditional probability would correlate only {ceiling:.2f} with it "
            f"(bivariate normal at the median: at most {1 / (1 - ceiling**2):.1f}× "
            f"with infinitely many free cheap runs), the fitted one {regression:.2f}, so at most 1/(1 − ρ²) = "
            f"{1 / (1 - regression**2):.1f}× with free cheap runs and "
            f"{cheap[one]['predicted_speedup'][quantities.index(fitted[0])]:.1f}× at this cost ratio "
            f"(w = {w:.1f}, MFMC optimum).",
            f"* **The cost ratio** w = {w:.1f} is what limits the means: at ρ {rho(one, 'mean R'):.3f} the MFMC "
            f"optimum is {cheap[one]['predicted_speedup'][0]:.1f}×.",
            f"* **A larger time step** (CFL 0.8 instead of 0.2) made the 1 m route "
            f"{cheap[one]['s_per_realization'] / cheap[cfl]['s_per_realization']:.1f}× cheaper at the same runout "
            f"correlation ({rho(cfl, 'mean R'):.3f}), {max(b['speedup'][0] for b in cheap[cfl]['budgets']):.1f}× for "
            f"mean R, **but the deposit creeps**: V and I correlate {rho(cfl, 'mean V'):.2f} and "
            f"{rho(cfl, 'mean I'):.2f} with the 0.5 m runs (mean V {mean(cfl, 'volume_m2') / mean('MPM 0.5 m', 'volume_m2'):.1f}×, "
            f"mean I {mean(cfl, 'influence_m') / mean('MPM 0.5 m', 'influence_m'):.1f}× the 0.5 m runs'), and the "
            "zoning's back scarp with them. Rejected: the cheap route keeps CFL 0.2.",
            f"* **A coarser mesh** (2 m) is {cheap[one]['s_per_realization'] / cheap[two]['s_per_realization']:.1f}× "
            f"cheaper than 1 m but correlates {rho(two, 'mean R'):.3f} in R: no better.",
            f"* **The GNS** ({cheap['GNS (shipped)']['s_per_realization']:.1f} s per realization against the 0.5 m "
            f"MPM's {accurate:.1f} s on a CPU, R correlation {rho('GNS (shipped)', 'mean R'):.3f}) only costs.",
            "",
            f"Reaching 5× for the means at ρ {rho(one, 'mean R'):.3f} needs a cheap route "
            f"{needed_cost_ratio(rho(one, 'mean R'), 5.0):.0f}× cheaper than the accurate one (the MFMC optimum); no "
            f"MPM setting or the GNS was; the end-state surrogate is "
            f"{accurate / cheap['end-state surrogate (shipped)']['s_per_realization']:,.0f}× cheaper at ρ "
            f"{min(rho('end-state surrogate (shipped)', q) for q in ('mean R', 'mean V', 'mean I')):.3f}–"
            f"{max(rho('end-state surrogate (shipped)', q) for q in ('mean R', 'mean V', 'mean I')):.3f} "
            f"(`benchmarks/results/multifidelity.json`).",
        ]
    )


def hifi_tuning() -> str:
    """docs/fidelity.md: the tuned surrogate's fine-tune (time, held-out loss), its runout bias against the 0.5 m
    MPM on the pool beside the shipped model's, and when its tuning runs pay for themselves (hifi_surrogate.json)."""
    record = result("hifi_surrogate.json", legacy=True)
    quantities, cheap = record["analysis"]["quantities"], record["analysis"]["cheap"]
    tuned, shipped = cheap["end-state surrogate, tuned on 0.5 m"], cheap["end-state surrogate, shipped (1 m)"]
    smallest = least_tuned_speedup(record)
    runs = int(record["args"]["realizations"])
    bias = quantities.index("mean R")
    return (
        f"Fine-tuned {record['args']['steps']} steps on {record['train']} of the {runs} coarse-grained 0.5 m runs in "
        f"{minutes(record['fine_tune_s'])} (2 threads); held-out loss on the other {record['held_out']}: "
        f"{record['before']['valid_loss']:.4f} → {record['history'][-1]['valid_loss']:.5f}. On the "
        f"{record['n']}-realization pool its runout is {true_minus(format(tuned['bias'][bias], '.2f'))} m off the "
        f"0.5 m MPM's on average (the shipped model: {true_minus(format(shipped['bias'][bias], '.2f'))} m). The "
        f"{runs} tuning runs are paid once per case: at the smallest speed-up in the table above ({smallest:.2f}×) the tuned "
        f"route saves time from about {runs / (1 - 1 / smallest):.0f} accurate runs' worth of plain MC on "
        f"(`benchmarks/results/hifi_surrogate.json`, committed in {record['committed_in']})."
    )


def tuned_speedups() -> str:
    """docs/fidelity.md: the end-state surrogate, shipped and tuned on 0.5 m runs, as the cheap route against the
    0.5 m MPM: speed-ups at 8 / 16 / 32 accurate runs' time and correlations (hifi_surrogate.json)."""
    record = result("hifi_surrogate.json", legacy=True)
    quantities = record["analysis"]["quantities"]
    columns = TUNED_COLUMNS
    labels = {
        "end-state surrogate, shipped (1 m)": "end-state surrogate, shipped (learned from the 1 m MPM)",
        "end-state surrogate, tuned on 0.5 m": f"**the same, tuned on {record['args']['train']} coarse-grained "
        "0.5 m runs**",
    }
    lines = ["| cheap route | " + " | ".join(columns) + " |", "|---" * (len(columns) + 1) + "|"]
    for name, label in labels.items():
        cheap = record["analysis"]["cheap"][name]
        cells = [speedup_cell(cheap, quantities, column) for column in columns]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    budgets = " / ".join(str(b["high_runs"]) for b in record["analysis"]["cheap"][next(iter(labels))]["budgets"])
    lines += [
        "",
        f"At {budgets} accurate runs' time, on the {record['n']}-realization pool; `{record['command'].split(' (')[0]}`, "
        f"`benchmarks/results/hifi_surrogate.json` committed in {record['committed_in']}.",
    ]
    return "\n".join(lines)


RENDERERS: dict[str, Callable[[], str]] = {
    "ood-table": ood_table,
    "ood-bias-table": ood_bias_table,
    "ood-targets": ood_targets,
    "endstate-speed": endstate_speed,
    "endstate-untouched": endstate_untouched,
    "endstate-training": endstate_training,
    "general-training": general_training,
    "gns-training": gns_training,
    "gns-recipe": gns_recipe,
    "gns-jitter": gns_jitter,
    "gns-handover": gns_handover,
    "gns-shipped": gns_shipped,
    "default-run": default_run,
    "site-run": site_run,
    "machine-pace": machine_pace,
    "pair-coverage": pair_coverage,
    "strata-spread": strata_spread,
    "influence-growth": influence_growth,
    "tuned-least": tuned_least,
    "cheap-route": cheap_route_choice,
    "tuned-untouched": tuned_untouched,
    "bench-fields": bench_fields,
    "bench-current": bench_current,
    "bench-convergence": bench_convergence,
    "bench-multifidelity": bench_multifidelity,
    "bench-chain-coverage": bench_chain_coverage,
    "tuned-speedups": tuned_speedups,
    "hifi-tuning": hifi_tuning,
    "multifidelity-routes": multifidelity_routes,
    "multifidelity-levers": multifidelity_levers,
    "mesh-step": mesh_step,
    "gpu-levels": gpu_levels,
    "convergence-table": convergence_table,
    "convergence-orders": convergence_orders,
    "convergence-column": convergence_column,
    "convergence-default-error": convergence_default_error,
    "locking-routes": locking_routes,
    "locking-bspline": locking_bspline,
}


def documents() -> list[Path]:
    return sorted({path for pattern in DOCUMENTS for path in REPO.glob(pattern)})


def rendered(text: str, where: str, only: set[str] | None = None) -> str:
    """``text`` with every marked passage (``only`` these names; None: all) replaced by its rendering."""

    def replace(match: re.Match[str]) -> str:
        name = match["name"]
        if name not in RENDERERS:
            raise DocumentError(f"{where}: rendered passage {name!r} has no renderer (known: {sorted(RENDERERS)})")
        if only is not None and name not in only:
            return match[0]
        indent = match["indent"]
        body = "\n".join(f"{indent}{line}" if line else "" for line in RENDERERS[name]().rstrip().split("\n"))
        return f"{indent}<!-- rendered: {name} -->\n{body}\n{indent}<!-- end rendered -->"

    return BLOCK.sub(replace, text)


def stale(paths: list[Path] | None = None) -> list[Path]:
    """The documents (``paths``; None: every one that may hold rendered passages) whose marked passages differ
    from their rendering."""
    return [path for path in paths or documents() if (text := path.read_text()) != rendered(text, str(path))]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--check", action="store_true", help="list the documents that differ; write nothing")
    parser.add_argument("--only", nargs="+", choices=sorted(RENDERERS), help="rewrite only these passages")
    args = parser.parse_args(argv)
    if args.check:
        differing = stale()
        for path in differing:
            print(
                f"{path}: a rendered passage differs from its result files (rewrite: python -m rgns.report.documents)"
            )
        return 1 if differing else 0
    for path in documents():
        text = path.read_text()
        new = rendered(text, str(path), None if args.only is None else set(args.only))
        if new != text:
            path.write_text(new)
            print(f"rewrote {path.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
