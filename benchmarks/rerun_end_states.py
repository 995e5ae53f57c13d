"""Stored MPM end states against the embedded MPM run again here, on this machine's CPU.

    python benchmarks/rerun_end_states.py --data work/pretrain_general/results/endstate/validation \
        --sets case1 hillside --realizations 6

The end states of a pretraining run (rule endstate_validation_data or endstate_data) may come from
another machine or device (config/pretrain_general_gpu.yaml runs the MPM batches on a GPU). This
reruns the first realizations of each set on one CPU thread and prints, per realization, R, V and I
of the stored and the rerun end state and the largest difference of a final position, and per set
their R²: the check that a GPU's MPM is the CPU's to rounding. Each realization now takes its own time
step, so ``--batch-size`` changes the cost only; end states made before 2026-11-28, when a batch's
realizations shared one step (the CFL condition over the batch), differ from a rerun by how far that
shared step moved the MPM's own R, V and I.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

from rgns.config import load_config
from rgns.engines.metrics import MetricSettings, crest_x, runout_metrics
from rgns.scene.realizations import CaseInputs, draw_scene
from rgns.surrogates.endstate.data import read_end_states, simulate_end_states
from rgns.surrogates.validation import r_squared
from rgns.trajectories import frame_count

REPO = Path(__file__).resolve().parent.parent
METRICS = ("runout_m", "volume_m2", "influence_m")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--config", default=str(REPO / "config" / "pretrain_general.yaml"))
    parser.add_argument("--data", required=True, help="folder of <set>/chunk_*.h5 end-state files")
    parser.add_argument("--sets", nargs="+", required=True)
    parser.add_argument("--realizations", type=int, default=6)
    parser.add_argument("--seed", type=int, help="the seed the files were drawn from (default: the validation's)")
    parser.add_argument(
        "--batch-size", type=int, help="realizations per MPM batch (default: all of a set in one, as the data chunks)"
    )
    args = parser.parse_args()
    torch.set_num_threads(1)
    config = load_config(args.config)
    seeded = config | {"seed": args.seed or config["endstate"]["validation"]["data_seed"]}
    metrics = MetricSettings(**config["metrics"])
    frames = frame_count(config["mpm"]["duration_s"], config["mpm"]["frame_interval_s"])
    print("set | index | R stored / rerun | V stored / rerun | I stored / rerun | max |Δ final position| (m)")
    for name in args.sets:
        inputs = CaseInputs.from_config(seeded, name)
        files = sorted((Path(args.data) / name).glob("chunk_*.h5"))
        stored = [s for s in read_end_states(files) if s.index < args.realizations]
        indices = [s.index for s in stored]
        size = args.batch_size or len(indices)
        rerun = [
            state
            for first in range(0, len(indices), size)
            for state in simulate_end_states(inputs, indices[first : first + size], config["mpm"], frames)[0]
        ]
        rows = []
        for old, new in zip(stored, rerun):
            crest = crest_x(draw_scene(inputs, old.index).vertices)
            a = runout_metrics(old.initial, old.final, old.volume_m2, crest, metrics).as_row()
            b = runout_metrics(new.initial, new.final, new.volume_m2, crest, metrics).as_row()
            rows.append([(a[key], b[key]) for key in METRICS])
            pairs = " | ".join(f"{a[key]:.3f} / {b[key]:.3f}" for key in METRICS)
            print(f"{name} | {old.index} | {pairs} | {np.abs(old.final - new.final).max():.4f}")
        values = np.array(rows)  # [realization, metric, (stored, rerun)]
        agreement = ", ".join(
            f"{key} R² {r_squared(values[:, k, 0], values[:, k, 1]):.3f}, "
            f"{int((values[:, k, 0] != values[:, k, 1]).sum())} differ"
            for k, key in enumerate(METRICS)
        )
        print(f"{name}: rerun against stored over {len(rows)} realizations: {agreement}")


if __name__ == "__main__":
    main()
