"""When the GNS takes over from MPM: held-out runs rolled out after W frames of their MPM run.

    python benchmarks/gns_handover.py rgns/models/gns.pt --valid work/pretrain/results/dataset/valid.h5 --frames 6 41 81

Per hand-over, the runout R and sliding volume V of each of the first ``--runs`` held-out runs in MPM and in
the GNS (the GNS continuing from the MPM's frames W − 6 … W − 1). Writes ``benchmarks/results/gns_handover.json``
(docs/gns-training.md renders it).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import torch

from rgns.engines.metrics import runout_metrics
from rgns.provenance import commit
from rgns.surrogates.gns.data import WindowSampler
from rgns.surrogates.gns.rollout import RolloutSettings, rollout_soil
from rgns.surrogates.gns.train import load_simulator, particle_crest_x

OUT = Path(__file__).parent / "results" / "gns_handover.json"


def handover(simulator, sampler: WindowSampler, warmup: int, runs: int) -> list[dict]:
    """R and V of the first ``runs`` held-out runs in MPM and in the GNS handed over after ``warmup`` frames."""
    rows = []
    for k in range(min(runs, sampler.n_trajectories)):
        truth = sampler.frames_of(k, 0, sampler.frames)
        friction = np.degrees(np.arctan(sampler.tan_friction[k].numpy()))
        settings = RolloutSettings(early_stop=True, keep="ends", warmup_frames=warmup)
        result = rollout_soil(simulator, [truth], [friction], sampler.frames, settings)[0]
        crest = particle_crest_x(truth[0])
        mpm = runout_metrics(truth[0], truth[-1], sampler.volume_m2[k], crest)
        gns = runout_metrics(truth[0], result.positions[-1], sampler.volume_m2[k], crest)
        rows.append(
            {
                "mpm_runout_m": float(mpm.runout_m),
                "gns_runout_m": float(gns.runout_m),
                "mpm_volume_m2": float(mpm.volume_m2),
                "gns_volume_m2": float(gns.volume_m2),
                "status": result.status,
            }
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("model", help="a gns.pt or a training checkpoint")
    parser.add_argument("--valid", required=True, help="packed held-out set")
    parser.add_argument("--frames", type=int, nargs="+", default=[6, 41, 81], help="MPM frames before the hand-over")
    parser.add_argument("--runs", type=int, default=6)
    args = parser.parse_args()
    torch.set_num_threads(1)
    simulator = load_simulator(args.model).eval()
    sampler = WindowSampler(args.valid, simulator.settings.history)
    handovers = []
    for warmup in args.frames:
        rows = handover(simulator, sampler, warmup, args.runs)
        handovers.append({"warmup_frames": warmup, "runs": rows})
        cells = [f"R {row['mpm_runout_m']:.2f} → {row['gns_runout_m']:.2f}" for row in rows]
        print(f"hand-over after {warmup} frames: " + " | ".join(cells), flush=True)
    record = {
        "command": " ".join(["python benchmarks/gns_handover.py", *sys.argv[1:]]),
        "commit": commit(),
        "model": args.model,
        "frame_interval_s": float(sampler.groups[0].attrs["frame_interval_s"]),
        "handovers": handovers,
    }
    OUT.write_text(json.dumps(record, indent=1) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
