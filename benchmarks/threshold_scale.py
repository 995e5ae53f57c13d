"""Whether the displacement threshold that defines V and I should scale with the slope: both ways on the pairs.

    .venv/bin/python benchmarks/threshold_scale.py --plan results/mc/case1/paired_plan.json

The default slope is the paper's case 1 at 1/3 scale (crest 10 m, not 30 m), and ``metrics.displacement_threshold_m``
stays at the paper's 1 m, which at the paper's scale would be 3 m. This runs the paired realizations of a default
run (``--plan``: rule paired_plan's file) through the embedded MPM at 1 m and 0.5 m cells (one thread, end states
only) and measures R, V and I with the paper's 1 m and with the threshold scaled to the slope, 1/3 m. Beside them,
the numerical noise each threshold must clear: V and I, and the displacement percentiles of the material points, on a
slope the MPM leaves standing (the test cases' long slope at friction 45 ± 2°, four realizations), at each mesh,
where both should be 0. Writes
``benchmarks/results/threshold_scale.{json,md}``.
"""

from __future__ import annotations

import argparse
import copy
import json
import time
from pathlib import Path

import numpy as np
import torch

from rgns.config import load_config
from rgns.engines.metrics import MetricSettings, crest_x, runout_metrics
from rgns.provenance import commit
from rgns.scene.realizations import CaseInputs, draw_realization
from rgns.surrogates.endstate.data import EndState, simulate_end_states
from rgns.trajectories import frame_count

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "benchmarks" / "results" / "threshold_scale"
THRESHOLDS = {"paper's 1 m": 1.0, "scaled to the slope, 1/3 m": 1.0 / 3.0}
CELLS = (1.0, 0.5)
BATCH = 8


def end_states(config: dict, case: str, indices: list[int], cell: float) -> tuple[list[EndState], CaseInputs]:
    """The realizations' end states at ``cell`` m cells, in batches."""
    meshed = copy.deepcopy(config)
    meshed["mesh"]["cell_size_m"] = cell
    inputs = CaseInputs.from_config(meshed, case)
    frames = frame_count(config["mpm"]["duration_s"], config["mpm"]["frame_interval_s"])
    states: list[EndState] = []
    for first in range(0, len(indices), BATCH):
        began = time.perf_counter()
        done, statuses = simulate_end_states(inputs, indices[first : first + BATCH], config["mpm"], frames)
        states += done
        print(f"{case} at {cell} m: {len(states)} of {len(indices)} ({time.perf_counter() - began:.0f} s)", flush=True)
    return states, inputs


def measured(states: list[EndState], inputs: CaseInputs, threshold: float) -> dict[str, list[float]]:
    """R, V and I of each end state with ``threshold``, the crest of its own realization's scene."""
    settings = MetricSettings(displacement_threshold_m=threshold)
    rows = [
        runout_metrics(
            s.initial, s.final, s.volume_m2, crest_x(draw_realization(inputs, s.index).scene.vertices), settings
        )
        for s in states
    ]
    return {key: [getattr(row, key) for row in rows] for key in ("runout_m", "volume_m2", "influence_m")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--plan", type=Path, required=True, help="a default run's results/mc/case1/paired_plan.json")
    args = parser.parse_args()
    torch.set_num_threads(1)
    config = load_config(REPO / "config" / "config.yaml")
    indices = [int(i) for i in json.loads(args.plan.read_text())["indices"]]
    standing = copy.deepcopy(config)  # a slope the MPM leaves standing (tests/surrogates/test_shipped_model.py)
    standing["sets"]["case4"][0] |= {"friction_mean_deg": 45.0, "friction_std_deg": 2.0}
    result: dict = {
        "command": f".venv/bin/python benchmarks/threshold_scale.py --plan {args.plan}",
        "commit": commit(),
        "indices": indices,
        "thresholds": THRESHOLDS,
        "cells": {},
    }
    for cell in CELLS:
        states, inputs = end_states(config, "case1", indices, cell)
        still, still_inputs = end_states(standing, "case4", [0, 1, 2, 3], cell)
        moved = np.concatenate([np.linalg.norm(s.final - s.initial, axis=1) for s in still])
        result["cells"][str(cell)] = {
            "metrics": {name: measured(states, inputs, t) for name, t in THRESHOLDS.items()},
            "standing": {name: measured(still, still_inputs, t) for name, t in THRESHOLDS.items()},
            "standing_displacement_m": {
                "p99": float(np.percentile(moved, 99.0)),
                "p99.9": float(np.percentile(moved, 99.9)),
                "max": float(moved.max()),
                "points": int(moved.size),
            },
        }
        (OUT.parent / f"{OUT.name}.json").write_text(json.dumps(result, indent=1) + "\n")
    write_report(result)


def write_report(result: dict) -> None:
    lines = [
        "# The displacement threshold at the slope's scale",
        "",
        f"`{result['command']}` at {result['commit']}; the {len(result['indices'])} paired realizations of case 1 "
        "(method: the script's docstring).",
        "",
        "| mesh | threshold | mean R (m) | mean V (m²) | mean I (m) | r(V) with the 1 m threshold's | r(I) with it | "
        "standing slope: mean V (m²) / mean I (m) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for cell, entry in result["cells"].items():
        reference = entry["metrics"]["paper's 1 m"]
        for name, values in entry["metrics"].items():
            r_v = np.corrcoef(values["volume_m2"], reference["volume_m2"])[0, 1]
            r_i = np.corrcoef(values["influence_m"], reference["influence_m"])[0, 1]
            lines.append(
                f"| {cell} m | {name} | {np.mean(values['runout_m']):.2f} | {np.mean(values['volume_m2']):.2f} | "
                f"{np.mean(values['influence_m']):.2f} | {r_v:.3f} | {r_i:.3f} | "
                f"{np.mean(entry['standing'][name]['volume_m2']):.2f} / {np.mean(entry['standing'][name]['influence_m']):.2f} |"
            )
    lines += [
        "",
        "Displacement of the standing slope's material points (it should be none): 99th / 99.9th percentile / "
        "largest, m: "
        + "; ".join(
            f"{cell} m cells {d['p99']:.3f} / {d['p99.9']:.3f} / {d['max']:.3f} ({d['points']:,} points)"
            for cell, d in ((cell, entry["standing_displacement_m"]) for cell, entry in result["cells"].items())
        )
        + ".",
    ]
    (OUT.parent / f"{OUT.name}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
