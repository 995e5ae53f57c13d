"""Where the embedded MPM's time at 0.5 m goes: per-realization cost alone and batched, in float64 and float32.

    python benchmarks/engine_levers.py --frames 201

Runs the first ``--batch`` case-1 Monte Carlo realizations at the accurate mesh (0.5 m cells), one CPU thread, for
``--frames`` frames: realization 0 alone, the batch together in float64 (the default), and the batch in float32.
A batch's cost per realization near the lone run's says the step is not bound by per-operation overhead (batching
would amortise that); float32's says how much memory traffic costs. Records the seconds per realization and the
largest runout difference from float64 in ``benchmarks/results/engine_levers.json``.
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


def timed(config: dict, indices: list[int], frames: int, dtype: str) -> tuple[float, list[float]]:
    """Seconds per realization and the runouts of ``indices`` run together at 0.5 m in ``dtype``."""
    config = copy.deepcopy(config)
    config["mpm"]["embedded"]["dtype"] = dtype
    settings = replace(run_settings(config), batch_size=len(indices), frames=frames)
    inputs = CaseInputs.from_params(asdict(accurate_case_inputs(config, "case1", 0.5)))
    began = time.perf_counter()
    rows = run_realizations(inputs, indices, settings)
    return (time.perf_counter() - began) / len(indices), [float(r) for r in rows["runout_m"]]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=201)
    parser.add_argument("--batch", type=int, default=4)
    args = parser.parse_args()
    torch.set_num_threads(1)
    config = load_config(REPO / "config" / "config.yaml")
    batch = list(range(args.batch))
    alone, _ = timed(config, [0], args.frames, "float64")
    together, runouts = timed(config, batch, args.frames, "float64")
    single, runouts32 = timed(config, batch, args.frames, "float32")
    record = {
        "command": " ".join(["python benchmarks/engine_levers.py", *sys.argv[1:]]),
        "commit": commit(),
        "frames": args.frames,
        "batch": args.batch,
        "seconds_per_realization": {"alone": alone, "batch": together, "batch_float32": single},
        "float32_largest_runout_difference_m": max(abs(a - b) for a, b in zip(runouts, runouts32)),
    }
    OUT.write_text(json.dumps(record, indent=1) + "\n")
    print(json.dumps(record, indent=1))


if __name__ == "__main__":
    main()
