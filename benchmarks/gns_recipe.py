"""Why a GNS does or does not learn from MPM runs: each ingredient of the training recipe changed
alone, trained the same number of steps on the same data, scored on the same held-out windows.

    python benchmarks/gns_recipe.py --train work/pretrain/results/dataset/train.h5 \\
        --valid work/pretrain/results/dataset/valid.h5 --steps 800 --variants recipe old no_smoothing

Variants (``recipe`` is rgns's default; every other one changes one thing from it, ``old`` is the
recipe before issue 15):

* ``recipe``: smoothed targets (σ = 2 frames), padded frames dropped, noise 5e-5 folded into the
  normalisation, targets clipped at ±25, learning rate annealed 1e-3 → 1e-5 over the steps.
* ``no_smoothing``, ``no_clip``, ``noise_2e-4``, ``noise_not_folded``, ``constant_lr``,
  ``with_padding``, ``radius_2_cells``: the recipe with that one change.
* ``old``: raw targets, padding drawn, noise 2e-4 not folded, no clip, lr 1e-3 decaying 0.1 per 5,000.

Scores, all on the held-out set: the one-step loss over the mean predictor's (always the mean
acceleration) on 128 fixed windows of smoothed frames and on the same windows of raw frames, and
the mean |error| of the runout R over full rollouts of the first held-out runs.
Results: ``benchmarks/results/gns_recipe.json`` (each variant with the commit that ran it; docs/gns-training.md
renders it) and ``gns_recipe.md``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import torch

from rgns.provenance import commit
from rgns.surrogates.gns.data import WindowSampler
from rgns.surrogates.gns.simulator import LearnedSimulator, ModelSettings, OneStepLoss, random_walk_noise
from rgns.surrogates.gns.train import TrainSettings, fixed_windows, learning_rate, one_step_losses, rollout_score

RESULTS = Path(__file__).parent / "results"
RECIPE = {
    "smoothing": 2.0,
    "noise": 5e-5,
    "fold_noise": True,
    "clip": 25.0,
    "drop_padding": True,
    "decay_rate": 0.01,
    "decay_steps": None,
    "radius_cells": 1.5,
    "acceleration_features": False,
}
VARIANTS = {
    "recipe": {},
    "no_smoothing": {"smoothing": 0.0},
    "no_clip": {"clip": 0.0},
    "noise_2e-4": {"noise": 2e-4},
    "noise_not_folded": {"fold_noise": False},
    "constant_lr": {"decay_rate": 1.0},
    "with_padding": {"drop_padding": False},
    "radius_2_cells": {"radius_cells": 2.0},
    "acceleration_features": {"acceleration_features": True},
    "old": {
        "smoothing": 0.0,
        "noise": 2e-4,
        "fold_noise": False,
        "clip": 0.0,
        "drop_padding": False,
        "decay_rate": 0.1,
        "decay_steps": 5000,
    },
}


def run_variant(name: str, train_path: str, valid_path: str, steps: int, rollouts: int, seed: int) -> dict:
    """Train one variant for ``steps`` and score it."""
    options = RECIPE | VARIANTS[name]
    model = ModelSettings(
        latent_size=32,
        mlp_width=32,
        mlp_hidden_layers=2,
        message_passing_steps=5,
        history=5,
        radius_m=options["radius_cells"],
        acceleration_features=options["acceleration_features"],
    )
    settings = TrainSettings(
        steps=steps, decay_rate=options["decay_rate"], decay_steps=options["decay_steps"], learning_rate_min=1e-6
    )
    train = WindowSampler(train_path, model.history, 1, options["smoothing"])
    if not options["drop_padding"]:  # every frame counts as real, copies included
        train.real = [train.frames] * train.n_trajectories
        train.starts = np.full(train.n_trajectories, train.frames - train.length + 1)
    torch.manual_seed(seed)
    normalization = train.normalization(options["noise"] if options["fold_noise"] else 0.0)
    simulator = LearnedSimulator(model, normalization, train.bounds)
    objective = OneStepLoss(simulator, options["clip"] or None)
    optimizer = torch.optim.Adam(simulator.parameters(), lr=1e-3)
    rng, noise_generator = np.random.default_rng(seed), torch.Generator().manual_seed(seed)
    began = time.perf_counter()
    for step in range(steps):
        for group in optimizer.param_groups:
            group["lr"] = learning_rate(settings, step)
        window = train.sample(rng, 2)
        noise = random_walk_noise(window.graph.positions, options["noise"], noise_generator)
        loss = objective(window.graph, window.targets[:, 0], noise)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    train_s = time.perf_counter() - began
    scores = {"variant": name, "steps": steps, "train_s_per_step": train_s / steps}
    cpu = torch.device("cpu")
    for label, sigma in (("smoothed", 2.0), ("raw", 0.0)):
        valid = WindowSampler(valid_path, model.history, 1, 2.0)  # the same windows (real frames of the smoothed set)
        batches = fixed_windows(valid, 128)
        valid.smoothing_frames = sigma
        loss, mean = one_step_losses(simulator, valid, batches, 25.0, cpu)
        scores[f"{label}_loss_over_mean_predictor"] = loss / mean
    scores |= rollout_score(
        simulator, WindowSampler(valid_path, model.history), rollouts, settings.selection_warmup_frames, cpu
    )
    return scores


def markdown(rows: list[dict]) -> str:
    lines = [
        "| variant | one-step loss / mean predictor (smoothed windows) | (raw windows) | "
        "held-out rollouts: mean abs R error (m) | diverged | s per step |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for row in rows:
        lines.append(
            f"| {row['variant']} | {row['smoothed_loss_over_mean_predictor']:.3f} | "
            f"{row['raw_loss_over_mean_predictor']:.3f} | {row['valid_runout_error_m']:.2f} | "
            f"{row['valid_diverged']} | {row['train_s_per_step']:.2f} |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--train", required=True)
    parser.add_argument("--valid", required=True)
    parser.add_argument("--steps", type=int, default=800)
    parser.add_argument("--rollouts", type=int, default=4)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    parser.add_argument("--out", default=str(RESULTS / "gns_recipe"))
    args = parser.parse_args()
    torch.set_num_threads(1)
    out = Path(args.out)
    path = out.with_suffix(".json")
    record = json.loads(path.read_text()) if path.exists() else {}
    record["command"] = " ".join(["python benchmarks/gns_recipe.py", *sys.argv[1:]])
    rows = [row for row in record.get("variants", []) if row["variant"] not in args.variants]
    for name in args.variants:
        rows.append(
            run_variant(name, args.train, args.valid, args.steps, args.rollouts, args.seed) | {"commit": commit()}
        )
        print(json.dumps(rows[-1]), flush=True)
        rows.sort(key=lambda row: list(VARIANTS).index(row["variant"]))
        record["variants"] = rows
        path.write_text(json.dumps(record, indent=2) + "\n")
        out.with_suffix(".md").write_text(markdown(rows))
    print(markdown(rows))


if __name__ == "__main__":
    main()
