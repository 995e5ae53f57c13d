"""Training: noisy one-step loss, Adam with exponential decay to a floor, validation,
checkpoints every N steps, resume after a restart, learning curve, optional DDP and pushforward.

A restarted job finds ``checkpoints/latest.pt`` and continues from its step with the same
optimizer state, learning-rate position and random streams. With several processes (torchrun,
or ``processes > 1`` for gloo on CPU) the loss module is wrapped in DistributedDataParallel and
*called through the wrapper*, so gradients are averaged across processes.
"""
from __future__ import annotations

import csv
import json
import logging
import os
import pickle
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.distributed as dist
from torch.nn.parallel import DistributedDataParallel

from rgns.gns.data import WindowSampler, normalization_of
from rgns.gns.rollout import rollout
from rgns.gns.simulator import GraphInput, LearnedSimulator, ModelSettings, OneStepLoss, random_walk_noise

log = logging.getLogger(__name__)
CHECKPOINT = "latest.pt"


@dataclass
class TrainSettings:
    """Optimisation and bookkeeping (config section ``gns``)."""

    steps: int = 2000
    batch_graphs: int = 2
    learning_rate: float = 1e-3
    learning_rate_min: float = 1e-6
    decay_rate: float = 0.1
    decay_steps: int = 5000
    noise_std: float = 2e-4
    pushforward_steps: int = 0
    checkpoint_every: int = 200
    validate_every: int = 200
    validation_windows: int = 8
    validation_rollout_frames: int = 40
    log_every: int = 50
    seed: int = 0
    device: str = "cpu"
    threads: int = 1


def settings_from_config(section: dict[str, Any], cell_size_m: float) -> tuple[ModelSettings, TrainSettings]:
    """Model and training settings from the config's ``gns`` section."""
    model = ModelSettings(
        latent_size=section["latent_size"], mlp_width=section["mlp_width"],
        mlp_hidden_layers=section["mlp_hidden_layers"], message_passing_steps=section["message_passing_steps"],
        history=section["history"], radius_m=section["connectivity_radius_cells"] * cell_size_m,
    )
    train = TrainSettings(**{key: section[key] for key in TrainSettings.__dataclass_fields__ if key in section})
    return model, train


def learning_rate(settings: TrainSettings, step: int) -> float:
    """(lr − lr_min)·decay^(step / decay_steps) + lr_min."""
    decay = settings.decay_rate ** (step / settings.decay_steps)
    return (settings.learning_rate - settings.learning_rate_min) * decay + settings.learning_rate_min


def _to(graph: GraphInput, device: torch.device) -> GraphInput:
    return GraphInput(graph.positions.to(device), graph.particle_type.to(device), graph.tan_friction.to(device),
                      graph.batch.to(device), graph.n_graphs)


def pushforward(simulator: LearnedSimulator, graph: GraphInput, targets: torch.Tensor) -> tuple[GraphInput, torch.Tensor]:
    """Unroll the model over all but the last target without gradients; train on the last one."""
    positions = graph.positions
    with torch.no_grad():
        for _ in range(targets.shape[1] - 1):
            current = GraphInput(positions, graph.particle_type, graph.tan_friction, graph.batch, graph.n_graphs)
            positions = torch.cat([positions[:, 1:], simulator.next_positions(current)[:, None]], dim=1)
    return GraphInput(positions, graph.particle_type, graph.tan_friction, graph.batch, graph.n_graphs), targets[:, -1]


def build_simulator(model: ModelSettings, train_path: str, bounds: np.ndarray) -> LearnedSimulator:
    return LearnedSimulator(model, normalization_of(train_path), bounds)


def load_simulator(path: str | Path, device: str = "cpu") -> LearnedSimulator:
    """A trained simulator from ``gns.pt`` (or a checkpoint), naming the file if it is unusable."""
    try:
        state = torch.load(path, map_location=device, weights_only=False)
        config = state["simulator"]
        from rgns.gns.simulator import Normalization

        simulator = LearnedSimulator(ModelSettings(**config["settings"]), Normalization(**config["normalization"]),
                                     np.array(config["bounds"]))
        simulator.load_state_dict(state["model"])
    except (OSError, KeyError, RuntimeError, TypeError, EOFError, pickle.UnpicklingError) as error:
        raise ValueError(f"{path}: not a usable GNS model file ({type(error).__name__}: {error})") from error
    return simulator.to(device)


def validate(simulator: LearnedSimulator, sampler: WindowSampler, settings: TrainSettings, device: torch.device) -> dict:
    """One-step loss on fixed windows and the position error after a short rollout."""
    rng = np.random.default_rng(12345)
    window = sampler.sample(rng, settings.validation_windows)
    objective = OneStepLoss(simulator)
    with torch.no_grad():
        graph = _to(window.graph, device)
        one_step = float(objective(graph, window.targets[:, 0].to(device), torch.zeros_like(graph.positions)))
    history = simulator.settings.history
    frames = min(sampler.frames, history + 1 + settings.validation_rollout_frames)
    errors = []
    for trajectory in range(min(sampler.n_trajectories, 4)):
        truth = sampler.frames_of(trajectory, 0, frames)
        predicted = rollout(simulator, [truth[:history + 1]], [sampler.particle_type[trajectory].numpy()],
                            [sampler.tan_friction[trajectory].numpy()], frames, device=str(device))[0]
        errors.append(float(np.linalg.norm(predicted.positions[-1] - truth[-1], axis=1).mean()))
    return {"valid_one_step_loss": one_step, "valid_rollout_error_m": float(np.mean(errors))}


RESUME_NEUTRAL = ("steps", "checkpoint_every", "validate_every", "validation_windows", "validation_rollout_frames",
                  "log_every", "device", "threads")


def fingerprint(simulator: LearnedSimulator, settings: TrainSettings) -> str:
    """What a checkpoint must share with this run to be resumed: architecture, normalisation
    (i.e. the data) and the optimisation settings, but not the step count or bookkeeping."""
    training = {key: value for key, value in asdict(settings).items() if key not in RESUME_NEUTRAL}
    return json.dumps({"simulator": simulator.config(), "training": training}, sort_keys=True)


def _save(path: Path, state: dict[str, Any]) -> None:
    partial = path.with_suffix(".partial")
    torch.save(state, partial)
    partial.replace(path)


def train(model: ModelSettings, settings: TrainSettings, train_path: str, valid_path: str, out_dir: str | Path,
          final_model: str | Path | None = None) -> dict:
    """Train (or resume) and write ``gns.pt``, ``history.csv`` and checkpoints into ``out_dir``."""
    distributed = dist.is_available() and dist.is_initialized()
    rank = dist.get_rank() if distributed else 0
    device = torch.device(settings.device)
    torch.set_num_threads(settings.threads)
    out_dir = Path(out_dir)
    checkpoints = out_dir / "checkpoints"
    checkpoints.mkdir(parents=True, exist_ok=True)
    train_windows = WindowSampler(train_path, model.history, max(1, settings.pushforward_steps + 1))
    valid_windows = WindowSampler(valid_path, model.history)
    torch.manual_seed(settings.seed)
    simulator = build_simulator(model, train_path, train_windows.bounds).to(device)
    objective = OneStepLoss(simulator)
    step_module = DistributedDataParallel(objective) if distributed else objective
    optimizer = torch.optim.Adam(simulator.parameters(), lr=settings.learning_rate)
    start, history, elapsed = 0, [], 0.0
    latest = checkpoints / CHECKPOINT
    state = torch.load(latest, map_location=device, weights_only=False) if latest.exists() else None
    if state is not None and state.get("fingerprint") != fingerprint(simulator, settings):
        stale = latest.with_name(f"stale-{int(time.time())}.pt")
        latest.replace(stale)
        log.warning("%s was made with other settings or data: kept as %s, training from scratch", latest, stale)
        state = None
    if state is not None:
        simulator.load_state_dict(state["model"])
        optimizer.load_state_dict(state["optimizer"])
        start, history, elapsed = state["step"], state["history"], state["elapsed_s"]
        log.info("resumed from step %d of %d (%s)", start, settings.steps, latest)
        if start >= settings.steps:
            log.info("the checkpoint is at step %d, beyond the %d asked for: nothing to train", start, settings.steps)
    else:
        log.info("training from scratch: %d steps, %d parameters", settings.steps,
                 sum(p.numel() for p in simulator.parameters()))
    # streams keyed by (seed, process, first step): a resumed run draws fresh, reproducible windows
    rng = np.random.default_rng([settings.seed, rank, start])
    noise_generator = torch.Generator().manual_seed(hash((settings.seed, rank, start)) % 2 ** 62)
    began = time.perf_counter() - elapsed
    running = []
    for step in range(start, settings.steps):
        for group in optimizer.param_groups:
            group["lr"] = learning_rate(settings, step)
        window = train_windows.sample(rng, settings.batch_graphs)
        graph, targets = _to(window.graph, device), window.targets.to(device)
        if settings.pushforward_steps:
            graph, target = pushforward(simulator, graph, targets)
        else:
            target = targets[:, 0]
        noise = random_walk_noise(graph.positions, settings.noise_std, noise_generator) if settings.noise_std else \
            torch.zeros_like(graph.positions)
        loss = step_module(graph, target, noise)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        running.append(loss.item())
        done = step + 1
        if done % settings.log_every == 0 or done == settings.steps:
            row: dict[str, Any] = {"step": done, "train_loss": float(np.mean(running)), "lr": learning_rate(settings, step),
                                   "elapsed_s": time.perf_counter() - began}
            running = []
            if rank == 0 and (done % settings.validate_every == 0 or done == settings.steps):
                row |= validate(simulator, valid_windows, settings, device)
            history.append(row)
            if rank == 0:
                log.info("step %d/%d  loss %.4g  lr %.2e  %s  %.0f s", done, settings.steps, row["train_loss"], row["lr"],
                         " ".join(f"{k} {v:.4g}" for k, v in row.items() if k.startswith("valid")), row["elapsed_s"])
        if rank == 0 and (done % settings.checkpoint_every == 0 or done == settings.steps):
            _save(latest, {"model": simulator.state_dict(), "optimizer": optimizer.state_dict(), "step": done,
                           "history": history, "elapsed_s": time.perf_counter() - began,
                           "simulator": simulator.config(), "fingerprint": fingerprint(simulator, settings)})
    summary = {"steps": settings.steps, "wall_s": time.perf_counter() - began, "resumed_from": start}
    if rank == 0:
        _save(Path(final_model or out_dir / "gns.pt"),
              {"model": simulator.state_dict(), "simulator": simulator.config(), "train_settings": asdict(settings)})
        write_history(history, out_dir / "history.csv")
    return summary


def write_history(history: list[dict], path: Path) -> None:
    """The learning history as CSV (one row per logged step)."""
    keys = sorted({key for row in history for key in row}, key=lambda k: (k != "step", k))
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=keys)
        writer.writeheader()
        writer.writerows(history)


def init_distributed_from_environment() -> bool:
    """Join the process group torchrun describes (RANK / WORLD_SIZE), if any."""
    if "RANK" not in os.environ or dist.is_initialized():
        return False
    backend = "nccl" if torch.cuda.is_available() else "gloo"
    dist.init_process_group(backend)
    if backend == "nccl":
        torch.cuda.set_device(int(os.environ.get("LOCAL_RANK", 0)))
    return True


