"""How well a trained simulator reproduces a packed set: one-step and full-rollout position errors."""
from __future__ import annotations

import numpy as np
import torch

from rgns.gns.data import WindowSampler
from rgns.gns.rollout import RolloutSettings, rollout
from rgns.gns.simulator import LearnedSimulator


@torch.no_grad()
def evaluate(simulator: LearnedSimulator, packed_path: str, windows: int = 64, seed: int = 0,
             settings: RolloutSettings | None = None) -> dict:
    """Mean one-step position error over random windows, and full-rollout errors per trajectory.

    Each rollout starts from its first ``settings.handover(history)`` MPM frames (the Monte Carlo's
    warm-up, at most the frames there are); the errors are averaged over every frame."""
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
    start = min(settings.handover(history), sampler.frames - 1)
    results = rollout(simulator, [t[:start] for t in truths], [t.numpy() for t in sampler.particle_type],
                      [f.numpy() for f in sampler.tan_friction], sampler.frames, settings)
    per_trajectory = []
    for truth, result in zip(truths, results):
        error = np.linalg.norm(result.positions - truth, axis=2).mean(axis=1)  # [T]
        per_trajectory.append({"mean_error_m": float(error.mean()), "final_error_m": float(error[-1]),
                               "status": result.status})
    return {
        "one_step_error_m": float(np.mean(one_step)),
        "rollout_mean_error_m": float(np.mean([p["mean_error_m"] for p in per_trajectory])),
        "rollout_final_error_m": float(np.mean([p["final_error_m"] for p in per_trajectory])),
        "frames": sampler.frames,
        "trajectories": per_trajectory,
    }
