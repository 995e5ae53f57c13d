"""When the GNS takes over from MPM: held-out runs rolled out after W frames of their MPM run.

    python benchmarks/gns_handover.py MODEL.pt --valid work/pretrain/results/dataset/valid.h5 --frames 6 41 81

Prints, per hand-over, the runout R and sliding volume V of each of the first ``--runs`` held-out
runs in MPM and in the GNS (the GNS continuing from the MPM's frames W − 6 … W − 1).
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from rgns.engines.metrics import runout_metrics
from rgns.surrogates.gns.data import WindowSampler
from rgns.surrogates.gns.rollout import RolloutSettings, rollout_soil
from rgns.surrogates.gns.train import load_simulator, particle_crest_x


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
    for warmup in args.frames:
        cells = []
        for k in range(min(args.runs, sampler.n_trajectories)):
            truth = sampler.frames_of(k, 0, sampler.frames)
            friction = np.degrees(np.arctan(sampler.tan_friction[k].numpy()))
            result = rollout_soil(
                simulator,
                [truth],
                [friction],
                sampler.frames,
                RolloutSettings(early_stop=True, keep="ends", warmup_frames=warmup),
            )[0]
            crest = particle_crest_x(truth[0])
            mpm = runout_metrics(truth[0], truth[-1], sampler.volume_m2[k], crest)
            gns = runout_metrics(truth[0], result.positions[-1], sampler.volume_m2[k], crest)
            cells.append(
                f"R {mpm.runout_m:.2f} → {gns.runout_m:.2f}, V {mpm.volume_m2:.1f} → {gns.volume_m2:.1f}"
                + ("" if result.status == "ok" else f" ({result.status})")
            )
        print(f"hand-over after {warmup} frames: " + " | ".join(cells), flush=True)


if __name__ == "__main__":
    main()
