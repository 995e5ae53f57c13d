"""Scenes in memory against the disk round trip, side by side in one run (Monte Carlo, simulator: mpm).

    python benchmarks/bench_scenes.py                       # 8 case-1 realizations, 1 s, 5 repeats
    python benchmarks/bench_scenes.py --frames 401          # the full 10 s

Both routes simulate the same default-config case-1 realizations with the default engine settings,
one CPU thread, alternating route by route: ``memory`` is what rgns.montecarlo.runs does (each case
built by ``rgns.scene.build.case_from_scene``), ``disk`` is what it did before (each case written as a CB-Geo
directory into a scratch folder and read back). Prints the time per realization of each (median
of the repeats), the ratio, the time of the case set-up alone, and whether the trajectories are
identical (they must be: the files hold every digit); records them in ``benchmarks/results/scenes.json``, one
entry per run length (docs/benchmarks.md renders it).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from rgns.config import load_config
from rgns.engines.cbgeo.case import read_case
from rgns.engines.cbgeo.writer import save_case
from rgns.engines.mpm.solver import EngineSettings, run_batch
from rgns.provenance import commit
from rgns.scene.build import case_from_scene
from rgns.scene.realizations import CaseInputs, draw_realization

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "benchmarks" / "results" / "scenes.json"


def build(route: str, batch, mpm: dict, scratch: Path) -> list:
    cases = [case_from_scene(r.scene, r.friction_deg, mpm) for r in batch]
    if route == "disk":
        cases = [read_case(save_case(scratch / f"{r.index:05d}", case)) for r, case in zip(batch, cases)]
    return cases


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--realizations", type=int, default=8)
    parser.add_argument("--frames", type=int, default=41)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    torch.set_num_threads(1)
    config = load_config(REPO / "config" / "config.yaml")
    mpm = config["mpm"]
    batch = [draw_realization(CaseInputs.from_config(config, "case1"), i) for i in range(args.realizations)]
    settings = EngineSettings.from_config(mpm["embedded"])
    duration = (args.frames - 1) * mpm["frame_interval_s"]
    total = {"memory": [], "disk": []}
    setup = {"memory": [], "disk": []}
    positions = {}
    for _ in range(args.repeats):
        for route in ("memory", "disk"):
            with tempfile.TemporaryDirectory(prefix="rgns-bench-scenes-") as scratch:
                start = time.perf_counter()
                cases = build(route, batch, mpm, Path(scratch))
                built = time.perf_counter()
                results = run_batch(cases, settings, duration, mpm["frame_interval_s"], keep="ends")
                end = time.perf_counter()
            setup[route].append((built - start) / len(batch))
            total[route].append((end - start) / len(batch))
            positions[route] = [result.positions for result in results]
    identical = all(np.array_equal(a, b) for a, b in zip(positions["memory"], positions["disk"]))
    print(
        f"{len(batch)} case-1 realizations, {duration:g} s simulated, {settings.shape_function} shape functions, "
        f"median of {args.repeats} repeats, one thread"
    )
    for route in ("memory", "disk"):
        print(
            f"  {route:6s}: {statistics.median(total[route]):.3f} s per realization "
            f"(case set-up {1000 * statistics.median(setup[route]):.1f} ms)"
        )
    print(
        f"  disk / memory: {statistics.median(total['disk']) / statistics.median(total['memory']):.3f}x; "
        f"trajectories identical: {identical}"
    )
    record = json.loads(OUT.read_text()) if OUT.exists() else {"runs": []}
    entry = {
        "command": " ".join(["python benchmarks/bench_scenes.py", *sys.argv[1:]]),
        "commit": commit(),
        "realizations": len(batch),
        "frames": args.frames,
        "simulated_s": duration,
        "repeats": args.repeats,
        "seconds": {route: statistics.median(total[route]) for route in total},
        "setup_s": {route: statistics.median(setup[route]) for route in setup},
        "identical": identical,
    }
    record["runs"] = sorted(
        [run for run in record["runs"] if run["frames"] != args.frames] + [entry], key=lambda run: run["frames"]
    )
    OUT.write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
