"""The end-state surrogate's forward pass on the CPU in torch's default layout and in channels last, side by side.

    python benchmarks/bench_endstate_layout.py

The shipped general model on a batch of 8 realizations' inputs (the Monte Carlo's batch), one thread, the two
layouts alternating; records the best seconds per realization of each, their ratio and the largest difference of
the outputs (normalised displacements: rounding of the convolution's other summation order). Writes
``benchmarks/results/endstate_layout.json``.
"""

from __future__ import annotations

import copy
import json
import os
import time
from pathlib import Path

import torch

from rgns.provenance import commit
from rgns.surrogates.endstate.model import INPUT_CHANNELS, load_model

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "benchmarks" / "results" / "endstate_layout.json"
BATCH, REPEATS = 8, 7


def main() -> None:
    torch.set_num_threads(1)
    load_before = os.getloadavg()[0]
    default = load_model(REPO / "rgns" / "models" / "endstate_general.pt")
    last = copy.deepcopy(default).to(memory_format=torch.channels_last)
    lattice = default.lattice
    images = torch.randn(
        BATCH, INPUT_CHANNELS, lattice.rows, lattice.columns, generator=torch.Generator().manual_seed(0)
    )
    inputs = {"default": images, "channels_last": images.contiguous(memory_format=torch.channels_last)}
    models = {"default": default, "channels_last": last}
    seconds: dict[str, list[float]] = {name: [] for name in models}
    outputs = {}
    with torch.inference_mode():
        for _ in range(REPEATS):
            for name, model in models.items():
                began = time.perf_counter()
                outputs[name] = model(inputs[name])
                seconds[name].append((time.perf_counter() - began) / BATCH)
    best = {name: min(values) for name, values in seconds.items()}
    record = {
        "command": "python benchmarks/bench_endstate_layout.py",
        "commit": commit(),
        "load_before": load_before,
        "batch": BATCH,
        "seconds_per_realization": best,
        "speedup": best["default"] / best["channels_last"],
        "largest_output_difference": float((outputs["default"] - outputs["channels_last"]).abs().max()),
    }
    OUT.write_text(json.dumps(record, indent=1) + "\n")
    print(json.dumps(record, indent=1))


if __name__ == "__main__":
    main()
