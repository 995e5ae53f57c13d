"""How well a trained simulator reproduces a packed set: one-step and full-rollout position errors."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch

from rgns.surrogates.gns.data import WindowSampler
from rgns.surrogates.gns.rollout import RolloutSettings, rollout_soil
from rgns.surrogates.gns.simulator import LearnedSimulator


@torch.no_grad()
def evaluate(
    simulator: LearnedSimulator,
    packed_path: str,
    windows: int = 64,
    seed: int = 0,
    settings: RolloutSettings | None = None,
) -> dict:
    """Mean one-step position error over random windows, and full-rollout errors per trajectory.

    Each rollout hands over from MPM after ``settings.handover(history)`` frames, as the Monte Carlo
    does (at most the frames there are; soil-only sets); the errors are averaged over every frame."""
    history = simulator.settings.history
    settings = settings or RolloutSettings()
    sampler = WindowSampler(packed_path, history)
    rng = np.random.default_rng(seed)
    one_step = []
    for _ in range(windows):
        window = sampler.sample(rng, 1)
        predicted = simulator.next_positions(window.graph)
        one_step.append(float((predicted - window.targets[:, 0]).norm(dim=1).mean()))
    truths = [sampler.frames_of(k, 0, sampler.frames) for k in range(sampler.n_trajectories)]
    friction = [np.degrees(np.arctan(f.numpy())) for f in sampler.tan_friction]
    results = rollout_soil(simulator, truths, friction, sampler.frames, replace(settings, keep="all"))
    per_trajectory = []
    for truth, result in zip(truths, results):
        error = np.linalg.norm(result.positions - truth, axis=2).mean(axis=1)  # [T]
        per_trajectory.append(
            {"mean_error_m": float(error.mean()), "final_error_m": float(error[-1]), "status": result.status}
        )
    return {
        "one_step_error_m": float(np.mean(one_step)),
        "rollout_mean_error_m": float(np.mean([p["mean_error_m"] for p in per_trajectory])),
        "rollout_final_error_m": float(np.mean([p["final_error_m"] for p in per_trajectory])),
        "frames": sampler.frames,
        "trajectories": per_trajectory,
    }
