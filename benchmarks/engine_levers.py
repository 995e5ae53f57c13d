"""Where the embedded MPM's time goes: per-realization cost alone and batched, in float64 and float32, per mesh.

    python benchmarks/engine_levers.py --frames 201 --cells 0.5 1.0

Runs the first ``--batch`` case-1 Monte Carlo realizations at each ``--cells`` size (0.5 m: the accurate mesh of
the pairs; 1 m: the Monte Carlo's, the pairs' coarse partner), one CPU thread, for ``--frames`` frames: each
realization alone, the batch together in float64 (the default), and the batch in float32. A batch's cost per
realization below the lone runs' is what batching the pairs buys (per-operation overhead amortised); near it,
the step is bound by the work per particle; float32's says how much memory traffic costs. Each realization
takes its own time step, so its runout alone and batched agree (the largest difference is recorded beside
float32's). Records them in ``benchmarks/results/engine_levers.json``.
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import time
from dataclasses import asdict, replace
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).parent))
from mesh_levels import run_settings  # noqa: E402

from rgns.config import load_config  # noqa: E402
from rgns.montecarlo.runs import CaseInputs, run_realizations  # noqa: E402
from rgns.provenance import commit  # noqa: E402
from rgns.scene.realizations import accurate_case_inputs  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "benchmarks" / "results" / "engine_levers.json"


def timed(config: dict, cell: float, indices: list[int], frames: int, dtype: str) -> tuple[float, list[float]]:
    """Seconds per realization and the runouts of ``indices`` run together at ``cell`` m in ``dtype``."""
    config = copy.deepcopy(config)
    config["mpm"]["embedded"]["dtype"] = dtype
    settings = replace(run_settings(config), batch_size=len(indices), frames=frames)
    inputs = CaseInputs.from_params(asdict(accurate_case_inputs(config, "case1", cell)))
    began = time.perf_counter()
    rows = run_realizations(inputs, indices, settings)
    return (time.perf_counter() - began) / len(indices), [float(r) for r in rows["runout_m"]]


def levers(config: dict, cell: float, batch: list[int], frames: int) -> dict:
    """One mesh's costs per realization alone, batched and in float32, and how far the runouts move."""
    lone = [timed(config, cell, [i], frames, "float64") for i in batch]
    together, runouts = timed(config, cell, batch, frames, "float64")
    single, runouts32 = timed(config, cell, batch, frames, "float32")
    alone_runouts = [runout for _, (runout,) in lone]
    return {
        "seconds_per_realization": {
            "alone": sum(seconds for seconds, _ in lone) / len(lone),
            "batch": together,
            "batch_float32": single,
        },
        "batch_largest_runout_difference_m": max(abs(a - b) for a, b in zip(alone_runouts, runouts)),
        "float32_largest_runout_difference_m": max(abs(a - b) for a, b in zip(runouts, runouts32)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=201)
    parser.add_argument("--batch", type=int, default=4)
    parser.add_argument("--cells", type=float, nargs="+", default=[0.5, 1.0])
    args = parser.parse_args()
    torch.set_num_threads(1)
    config = load_config(REPO / "config" / "config.yaml")
    batch = list(range(args.batch))
    record = {
        "command": " ".join(["python benchmarks/engine_levers.py", *sys.argv[1:]]),
        "commit": commit(),
        "frames": args.frames,
        "batch": args.batch,
        "cells": {str(cell): levers(config, cell, batch, args.frames) for cell in args.cells},
    }
    OUT.write_text(json.dumps(record, indent=1) + "\n")
    print(json.dumps(record, indent=1))


if __name__ == "__main__":
    main()
