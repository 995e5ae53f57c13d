"""GNS rollout throughput and error against MPM: B = 1 vs batched, rest-skipping and early stop.

    python benchmarks/bench_gns.py                                    # trained default model, test sets
    python benchmarks/bench_gns.py --paper-scale-steps 2              # + a paper-sized model step

Rolls out every realization of the packed test sets (``results/dataset/case*.h5``) from its
first frames with the trained model (``results/model/gns.pt``), one at a time (B = 1) and all in
one batch, with and without rest-skipping and early stop, and compares each with the MPM
trajectory: mean position error over the rollout, final-frame error, runout distance error.
``--paper-scale-steps`` also times rollout steps of an untrained paper-sized model (latent 128,
10 message-passing steps, radius 4 m) on a 6,000-particle block at 1 m spacing.
Results: ``benchmarks/results/gns.json`` and ``gns.md``.
"""

from __future__ import annotations

import argparse
import glob
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from rgns.engines.metrics import runout_distance
from rgns.surrogates.gns.data import WindowSampler
from rgns.surrogates.gns.rollout import RolloutSettings, rollout
from rgns.surrogates.gns.simulator import LearnedSimulator, ModelSettings, Normalization
from rgns.surrogates.gns.train import load_simulator


def realizations(paths: list[str], history: int, frames: int | None, limit: int | None) -> list[dict]:
    out = []
    for path in paths:
        sampler = WindowSampler(path, history)
        for k in range(sampler.n_trajectories):
            count = min(frames or sampler.frames, sampler.frames)
            out.append(
                {
                    "truth": sampler.frames_of(k, 0, count),
                    "type": sampler.particle_type[k].numpy(),
                    "friction": sampler.tan_friction[k].numpy(),
                    "name": f"{Path(path).stem}/{k}",
                }
            )
    return out[:limit]


def run(simulator: LearnedSimulator, cases: list[dict], settings: RolloutSettings, batched: bool) -> dict:
    history = simulator.settings.history
    frames = cases[0]["truth"].shape[0]
    start = time.perf_counter()
    if batched:
        results = rollout(
            simulator,
            [c["truth"][: history + 1] for c in cases],
            [c["type"] for c in cases],
            [c["friction"] for c in cases],
            frames,
            settings,
        )
    else:
        results = [
            rollout(simulator, [c["truth"][: history + 1]], [c["type"]], [c["friction"]], frames, settings)[0]
            for c in cases
        ]
    wall = time.perf_counter() - start
    mean_error = [float(np.linalg.norm(r.positions - c["truth"], axis=2).mean()) for r, c in zip(results, cases)]
    final_error = [
        float(np.linalg.norm(r.positions[-1] - c["truth"][-1], axis=1).mean()) for r, c in zip(results, cases)
    ]
    runout_error = [
        abs(runout_distance(c["truth"][0], r.positions[-1]) - runout_distance(c["truth"][0], c["truth"][-1]))
        for r, c in zip(results, cases)
    ]
    return {
        "wall_s": wall,
        "per_realization_s": wall / len(cases),
        "realization_frames_per_s": len(cases) * (frames - history - 1) / wall,
        "mean_position_error_m": float(np.mean(mean_error)),
        "final_position_error_m": float(np.mean(final_error)),
        "runout_abs_error_m": float(np.mean(runout_error)),
        "diverged": sum(r.status != "ok" for r in results),
        "stopped_early": sum(r.stopped_at_frame is not None for r in results),
        "node_updates": int(sum(r.node_updates for r in results)),
    }


def paper_scale(steps: int) -> dict:
    """Seconds per rollout step of a paper-sized model on 6,000 particles (weights untrained)."""
    model = ModelSettings(
        latent_size=128, mlp_width=128, mlp_hidden_layers=2, message_passing_steps=10, history=5, radius_m=4.0
    )
    normalization = Normalization([0.0, 0.0], [0.01, 0.01], [0.0, 0.0], [0.001, 0.001], 0.6, 0.1)
    simulator = LearnedSimulator(model, normalization, np.array([[0.0, 240.0], [0.0, 60.0]]))
    x, y = np.meshgrid(np.arange(0.5, 100.5, 1.0), np.arange(0.5, 60.5, 1.0))
    block = np.column_stack([x.ravel(), y.ravel()])[:6000]
    history = np.repeat(block[None], model.history + 1, axis=0).astype(np.float32)
    history += np.linspace(0, 0.01, model.history + 1)[:, None, None]
    n = len(block)
    start = time.perf_counter()
    rollout(simulator, [history], [np.full(n, 6)], [np.full(n, 0.6)], model.history + 1 + steps)
    seconds = (time.perf_counter() - start) / steps
    return {
        "particles": n,
        "seconds_per_step": seconds,
        "steps_timed": steps,
        "seconds_per_400_frame_realization": seconds * 400,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="results/model/gns.pt")
    parser.add_argument("--sets", nargs="*", default=sorted(glob.glob("results/dataset/case*.h5")))
    parser.add_argument("--frames", type=int, help="roll out only the first FRAMES frames (default: all)")
    parser.add_argument("--max-realizations", type=int, help="use at most this many realizations")
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--paper-scale-steps", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    torch.set_num_threads(1)
    simulator = load_simulator(args.model, args.device)
    cases = realizations(args.sets, simulator.settings.history, args.frames, args.max_realizations)
    plain = RolloutSettings()
    variants = {
        "plain": plain,
        "rest_skip": replace(plain, skip_rest=True),
        "early_stop": replace(plain, early_stop=True),
        "rest_skip+early_stop": replace(plain, skip_rest=True, early_stop=True),
    }
    rows = {"B1 plain": run(simulator, cases, plain, batched=False)}
    for name, settings in variants.items():
        rows[f"B{len(cases)} {name}"] = run(simulator, cases, settings, batched=True)
    summary = {
        "model": args.model,
        "realizations": len(cases),
        "frames": int(cases[0]["truth"].shape[0]),
        "particles": [int(c["truth"].shape[1]) for c in cases],
        "device": args.device,
        "rows": rows,
    }
    if args.paper_scale_steps:
        summary["paper_scale"] = paper_scale(args.paper_scale_steps)
    lines = [
        "| run | wall (s) | per realization (s) | realization-frames/s | mean pos. err (m) | final pos. err (m) | "
        "runout err (m) | stopped early | diverged |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for name, row in rows.items():
        lines.append(
            f"| {name} | {row['wall_s']:.1f} | {row['per_realization_s']:.2f} | {row['realization_frames_per_s']:.1f} | "
            f"{row['mean_position_error_m']:.3f} | {row['final_position_error_m']:.3f} | "
            f"{row['runout_abs_error_m']:.2f} | {row['stopped_early']} | {row['diverged']} |"
        )
    text = "\n".join(lines)
    if "paper_scale" in summary:
        p = summary["paper_scale"]
        text += (
            f"\n\nPaper-sized model (latent 128, 10 steps, radius 4 m), {p['particles']} particles, {args.device}: "
            f"{p['seconds_per_step']:.2f} s per step ({p['steps_timed']} timed) -> "
            f"{p['seconds_per_400_frame_realization'] / 60:.0f} min per 400-frame realization (paper: 31 s on an A100)"
        )
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "gns.json").write_text(json.dumps(summary, indent=2) + "\n")
    command = "python benchmarks/bench_gns.py " + " ".join(sys.argv[1:])
    (args.out / "gns.md").write_text(
        f"# GNS rollout ({len(cases)} realizations, {summary['frames']} frames)\n\n"
        f"Command: `{command.strip()}`\n\n{text}\n"
    )
    print(text)


if __name__ == "__main__":
    main()
