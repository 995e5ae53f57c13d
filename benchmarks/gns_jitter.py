"""How much of the MPM's per-frame acceleration is jitter: its spread in a packed set, raw and smoothed in time.

    python benchmarks/gns_jitter.py --valid work/pretrain/results/dataset/valid.h5 --smoothing 2

The GNS learns the per-frame acceleration (second difference of positions). On every run's real frames (before an
early stop's padding), its standard deviation per axis from the raw frames and from the frames smoothed as the
training targets are (``gns.smoothing_frames``: a Gaussian in time of that many frames), and the share of the
variance the smoothing removes. Writes ``benchmarks/results/gns_jitter.json`` (docs/gns-training.md renders it).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from rgns.provenance import commit
from rgns.surrogates.gns.data import WindowSampler

OUT = Path(__file__).parent / "results" / "gns_jitter.json"


def accelerations(sampler: WindowSampler, smoothed: bool) -> np.ndarray:
    """Every particle's per-frame acceleration [M, 2] over every run's real frames."""
    rows = []
    for k in range(sampler.n_trajectories):
        end = sampler.real[k]
        read = sampler.smoothed_frames_of if smoothed else sampler.frames_of
        frames = read(k, 0, end).astype(np.float64)
        rows.append((frames[2:] - 2 * frames[1:-1] + frames[:-2]).reshape(-1, 2))
    return np.concatenate(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--valid", required=True, help="packed set")
    parser.add_argument("--smoothing", type=float, default=2.0, help="Gaussian standard deviation in frames")
    args = parser.parse_args()
    sampler = WindowSampler(args.valid, history=1, smoothing_frames=args.smoothing)
    raw, smooth = accelerations(sampler, False).std(0), accelerations(sampler, True).std(0)
    record = {
        "command": " ".join(["python benchmarks/gns_jitter.py", *sys.argv[1:]]),
        "commit": commit(),
        "runs": sampler.n_trajectories,
        "smoothing_frames": args.smoothing,
        "raw_std": raw.tolist(),
        "smoothed_std": smooth.tolist(),
        "variance_removed": (1 - (smooth / raw) ** 2).tolist(),
    }
    OUT.write_text(json.dumps(record, indent=1) + "\n")
    print(json.dumps(record, indent=1))


if __name__ == "__main__":
    main()
