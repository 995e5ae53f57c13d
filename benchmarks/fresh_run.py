"""The README's run, timed from a fresh clone: ``hazard_map`` on a config, its headline, its page's first screens.

    .venv/bin/python benchmarks/fresh_run.py                              # the default config
    .venv/bin/python benchmarks/fresh_run.py --configfile config/site.yaml

Clones this repository's HEAD (committed work only) into a temporary directory, installs it there as the
README's first command does (``python3 -m venv .venv && .venv/bin/pip install -q torch==2.13.0 -e .``; timed
apart, excluded from the run's time), then times ``.venv/bin/snakemake --cores 2 hazard_map [--configfile ...]``
under GNU time (wall seconds, and the largest process's peak resident memory). The load average before the
run is recorded: a run beside other work is slower, and says so. From the run's own files it takes the best
estimate per Monte Carlo case (``results/report/<case>/multifidelity.json``: the means and distances carried
to the converged mesh with their intervals and sampling parts, the pairs' validation, the allocation), the
convergence of the running moments (``convergence.json``), where the time went (per rule and route, from
Snakemake's log: jobs, their summed seconds, the span), and renders the page's first two screens of a
1,400 x 900 window with headless Chromium (Debian's ``chromium``). Writes
``benchmarks/results/fresh_run_<name>.json`` (the README and docs/site.md render their figures from it:
evidence) and ``docs/screens/<name>_first_screens.png``, and copies the figures the docs show.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import subprocess
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from rgns.provenance import commit

REPO = Path(__file__).resolve().parent.parent
RESULTS = REPO / "benchmarks" / "results"
SCREENS = REPO / "docs" / "screens"
INSTALL = "python3 -m venv .venv && .venv/bin/pip install -q torch==2.13.0 -e ."
NAMES = {None: "default", "config/site.yaml": "site"}
# the figures a doc shows from the run: (path in the run, path in the repository)
FIGURES = {
    "default": [
        ("results/report/case1/multifidelity.png", "docs/default_best_estimate.png"),
        ("results/report/case1/convergence.png", "docs/default_convergence.png"),
    ],
    "site": [("results/site/hillside/map.png", "docs/site_example_map.png")],
}


def shell(command: str, cwd: Path) -> float:
    """Run ``command`` in ``cwd`` (raising on failure) → wall seconds."""
    start = time.perf_counter()
    subprocess.run(command, shell=True, cwd=cwd, check=True, executable="/bin/bash")
    return time.perf_counter() - start


def timed(command: str, cwd: Path, log: Path) -> dict[str, float]:
    """Wall seconds and peak resident memory (GB, the largest process) of ``command`` under GNU time."""
    stats = cwd / ".time"
    with log.open("w") as out:
        subprocess.run(
            ["/usr/bin/time", "-f", "%e %M", "-o", str(stats), "bash", "-c", command],
            cwd=cwd,
            stdout=out,
            stderr=subprocess.STDOUT,
            check=True,
        )
    wall, peak_kb = stats.read_text().split()[-2:]
    return {"seconds": float(wall), "peak_memory_gb": float(peak_kb) / 1e6}


def interval(entry: dict[str, Any], key: str = "estimate") -> list[float | None]:
    """[value, lower, upper] of one converged entry."""
    return [entry[key], entry["lower"], entry["upper"]]


def pair_positions(record: dict[str, Any], mc: Path) -> dict[str, Any]:
    """Where the paired realizations sit in the cheap route's runout: their quantiles among all its runs (the
    share at or below each), how many lie above its 0.9 and 0.99 quantiles, and the design's strata."""
    import pandas as pd

    plan = json.loads((mc / "paired_plan.json").read_text())
    cheap = pd.read_csv(mc / ("realizations.csv" if record.get("cheap_is_simulator", True) else "control.csv"))
    share = cheap.set_index("index")["runout_m"].rank(pct=True)
    quantiles = sorted(float(q) for q in share.loc[plan["indices"]])
    return {
        "quantiles": quantiles,
        "above_0.9": sum(q > 0.9 for q in quantiles),
        "above_0.99": sum(q > 0.99 for q in quantiles),
        "strata": {key: plan[key] for key in ("bounds_m", "sizes", "pairs")},
    }


def headline(report: Path, mc: Path) -> dict[str, Any]:
    """A case's best estimate, the evidence behind it, where its pairs sit and its convergence, from its files."""
    record = json.loads((report / "multifidelity.json").read_text())
    convergence = json.loads((report / "convergence.json").read_text())
    converged = record["converged"]
    return {
        "n_realizations": record["n_low"],
        "n_pairs": record["n_paired"],
        "cheap_route": record["cheap_route"],
        "means": {key: interval(entry) for key, entry in converged["means"].items()},
        "means_at_order": {key: entry["interval_at_order"] for key, entry in converged["means"].items()},
        "distances": {
            key: {p: interval(entry) for p, entry in entries.items()} for key, entries in converged["distances"].items()
        },
        "distances_at_order": {
            key: {p: entry["interval_at_order"] for p, entry in entries.items()}
            for key, entries in converged["distances"].items()
        },
        "cheap_validation": record["pair_validation"],
        "simulator_validation": record.get("simulator_validation"),
        "allocation": record["allocation"],
        "cost_s": record["cost"],  # seconds per realization measured in this run: the machine's pace
        "converged_at": {name: entry["converged_at"] for name, entry in convergence["metrics"].items()},
        "pairs": pair_positions(record, mc),
    }


def screenshot(page: Path, out: Path) -> None:
    """The page's first two screens of a 1,400 x 900 window (headless Chromium, 1,400 x 1,800)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run(
        [
            "chromium",
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--window-size=1400,1800",
            f"--screenshot={out}",
            page.as_uri(),
        ],
        check=True,
        capture_output=True,
    )


STAMP = re.compile(r"^\[(\w{3} \w{3} +\d+ \d\d:\d\d:\d\d \d{4})\]$")


def rule_times(log: Path) -> dict[str, dict[str, float]]:
    """Where a run's time went, from Snakemake's log: per rule (and route, where the rule has one) the jobs, their
    summed wall seconds and the span from the first start to the last finish, largest sum first."""
    started: dict[str, tuple[str, float]] = {}
    rules: dict[str, dict[str, float]] = {}
    stamp, name = 0.0, ""
    for line in log.read_text().splitlines():
        if found := STAMP.match(line):
            stamp = datetime.strptime(found[1], "%a %b %d %H:%M:%S %Y").timestamp()
        elif found := re.match(r"^(?:local)?rule (\w+):$", line):
            name = found[1]
        elif found := re.match(r"^ +jobid: (\d+)$", line):
            started[found[1]] = (name, stamp)
        elif (found := re.match(r"^ +wildcards: .*\broute=(\w+)", line)) and started:
            job = next(reversed(started))
            started[job] = (f"{started[job][0]} [{found[1]}]", started[job][1])
        elif (found := re.match(r"^Finished jobid: (\d+)", line)) and found[1] in started:
            key, began = started.pop(found[1])
            entry = rules.setdefault(key, {"jobs": 0, "job_seconds": 0.0, "first": began, "last": stamp})
            entry["jobs"] += 1
            entry["job_seconds"] += stamp - began
            entry["first"], entry["last"] = min(entry["first"], began), max(entry["last"], stamp)
    spans = {
        key: {"jobs": e["jobs"], "job_seconds": e["job_seconds"], "span_s": e["last"] - e["first"]}
        for key, e in rules.items()
    }
    return dict(sorted(spans.items(), key=lambda item: -item[1]["job_seconds"]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--configfile", default=None, help="a config in the repository (default: config/config.yaml)")
    parser.add_argument("--keep", type=Path, default=None, help="clone here and keep it (default: a temporary one)")
    args = parser.parse_args()
    name = NAMES.get(args.configfile, Path(args.configfile or "config").stem)
    made_at = commit()  # HEAD, marked "with local changes" where the clone leaves some out
    work = args.keep or Path(tempfile.mkdtemp(prefix="rgns_fresh_"))
    shell(f"git clone --quiet {REPO} {work}", REPO)
    install_s = shell(INSTALL, work)
    command = "snakemake --cores 2 hazard_map" + (f" --configfile {args.configfile}" if args.configfile else "")
    load = os.getloadavg()
    print(f"{made_at}: installed in {install_s:.0f} s; running {command} (load before {load[0]:.2f})", flush=True)
    run = timed(f".venv/bin/{command}", work, work / "run.log")
    cases = sorted(path.parent.name for path in (work / "results" / "report").glob("*/multifidelity.json"))
    result = {
        "command": ".venv/bin/python benchmarks/fresh_run.py"
        + (f" --configfile {args.configfile}" if args.configfile else ""),
        "commit": made_at,
        "date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": f"{os.cpu_count()} cores, {platform.machine()}, Python {platform.python_version()}",
        "run": command,
        "install_s": install_s,
        "load_before": list(load),
        **run,
        "rules": rule_times(next((work / ".snakemake" / "log").glob("*.snakemake.log"))),
        "cases": {case: headline(work / "results" / "report" / case, work / "results" / "mc" / case) for case in cases},
    }
    path = RESULTS / f"fresh_run_{name}.json"
    path.write_text(json.dumps(result, indent=1) + "\n")
    screenshot(work / "results" / "report" / "report.html", SCREENS / f"{name}_first_screens.png")
    for source, target in FIGURES.get(name, []):
        shutil.copyfile(work / source, REPO / target)
    print(f"{run['seconds']:.0f} s, peak {run['peak_memory_gb']:.2f} GB: {path}", flush=True)
    if args.keep is None:
        shutil.rmtree(work)


if __name__ == "__main__":
    main()
