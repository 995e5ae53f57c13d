"""Training: noisy one-step loss, Adam with exponential decay to a floor, validation,
checkpoints every N steps, resume after a restart, learning curve, optional DDP, pushforward and a moving
average of the weights.

The recipe that makes a GNS learn from MPM runs (docs/gns-training.md): targets from trajectories
smoothed in time, padded early-stop frames never drawn, the training noise folded into the
normalisation, normalised targets clipped, the learning rate annealed over the budget. Every
validation scores the one-step loss against the mean predictor's on the same fixed windows, and
full rollouts of held-out trajectories by their runout R, volume V and influence I: the model
kept (``gns.pt``) is the checkpoint with the best rollout score, not the last iterate. With ``ema_decay`` the
model validated, checkpointed and kept is the exponential moving average of the weights (Polyak averaging): the
iterates swing from one checkpoint to the next, their average less; the optimiser goes on from the raw weights.

A restarted job finds ``checkpoints/latest.pt`` and continues from its step with the same
optimizer state, learning-rate position and random streams (saved with it), and with the checkpoint's
normalisation: data regenerated on a fresh machine, whose statistics differ in the last digits, resumes
(:func:`same_data`); other settings or other data start again, the checkpoint kept beside as ``stale-*.pt``.
With several processes (torchrun, or ``processes > 1`` for gloo on CPU) the loss module is wrapped in
DistributedDataParallel and *called through the wrapper*, so gradients are averaged across processes.
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
from torch.optim.swa_utils import AveragedModel

from rgns.atomic import atomic_path
from rgns.engines.metrics import runout_metrics
from rgns.surrogates.gns.data import WindowSampler
from rgns.surrogates.gns.rollout import RolloutSettings, rollout_soil, warmup_frame_count
from rgns.surrogates.gns.simulator import (
    GraphInput,
    LearnedSimulator,
    ModelSettings,
    Normalization,
    OneStepLoss,
    RolloutLoss,
    random_walk_noise,
)

log = logging.getLogger(__name__)
CHECKPOINT = "latest.pt"
BEST = "best.pt"
DATA_TOLERANCE = 1e-3  # of a spread: how far a checkpoint's normalisation may sit from this data's and resume


@dataclass
class TrainSettings:
    """Optimisation and bookkeeping (config section ``gns``)."""

    steps: int = 2000
    batch_graphs: int = 2
    learning_rate: float = 1e-3
    learning_rate_min: float = 1e-6
    decay_rate: float = 0.01
    decay_steps: int | None = None  # None: the training steps (anneal over the budget)
    noise_std: float = 5e-5
    smoothing_frames: float = 2.0
    target_clip: float = 25.0
    pushforward_steps: int = 0
    rollout_steps: int = 0  # > 0: the loss is RolloutLoss's over this many of the model's own steps
    rollout_from_frame: int = 0  # > 0: RolloutLoss on windows from this frame on, the one-step loss on all (MixedLoss)
    moving_weight: float = 0.0  # extra weight of a particle that moves over its window (OneStepLoss)
    ema_decay: float = 0.0  # > 0: the model used is the moving average of the weights at this decay a step
    checkpoint_every: int = 200
    validate_every: int = 200
    validation_windows: int = 128
    selection_trajectories: int = 6
    selection_warmup_frames: int = 81  # MPM frames before the GNS takes over, as montecarlo.rollout.warmup_s
    log_every: int = 50
    seed: int = 0
    device: str = "cpu"
    threads: int = 1


def settings_from_config(
    section: dict[str, Any], cell_size_m: float, selection_warmup_frames: int | None = None
) -> tuple[ModelSettings, TrainSettings]:
    """Model and training settings from the config's ``gns`` section (and the Monte Carlo's MPM
    warm-up in frames, which the held-out rollouts that select the model start from)."""
    model = ModelSettings(
        latent_size=section["latent_size"],
        mlp_width=section["mlp_width"],
        mlp_hidden_layers=section["mlp_hidden_layers"],
        message_passing_steps=section["message_passing_steps"],
        history=section["history"],
        radius_m=section["connectivity_radius_cells"] * cell_size_m,
        acceleration_features=section["acceleration_features"],
    )
    train = TrainSettings(**{key: section[key] for key in TrainSettings.__dataclass_fields__ if key in section})
    if selection_warmup_frames is not None:
        train.selection_warmup_frames = selection_warmup_frames
    return model, train


def warmup_frames(config: dict[str, Any]) -> int:
    """Frames of MPM before the GNS takes over (config montecarlo.rollout.warmup_s)."""
    return warmup_frame_count(config["montecarlo"]["rollout"]["warmup_s"], config["mpm"]["frame_interval_s"])


def learning_rate(settings: TrainSettings, step: int) -> float:
    """(lr − lr_min)·decay^(step / decay_steps) + lr_min."""
    decay = settings.decay_rate ** (step / (settings.decay_steps or settings.steps))
    return (settings.learning_rate - settings.learning_rate_min) * decay + settings.learning_rate_min


def pushforward(
    simulator: LearnedSimulator, graph: GraphInput, targets: torch.Tensor
) -> tuple[GraphInput, torch.Tensor]:
    """Unroll the model over all but the last target without gradients; train on the last one."""
    positions = graph.positions
    with torch.no_grad():
        for _ in range(targets.shape[1] - 1):
            positions = torch.cat(
                [positions[:, 1:], simulator.next_positions(graph.moved_to(positions))[:, None]], dim=1
            )
    return graph.moved_to(positions), targets[:, -1]


def moving_average(decay: float):
    """AveragedModel's update for an exponential moving average at ``decay`` a step, warming up as
    min(decay, (1 + n) / (10 + n)) after n updates, so that the first steps' weights do not linger in it."""

    @torch.no_grad()
    def update(averaged: list[torch.Tensor], current: list[torch.Tensor], count: torch.Tensor | int) -> None:
        rate = min(decay, (1.0 + float(count)) / (10.0 + float(count)))
        for mine, theirs in zip(averaged, current):
            mine.lerp_(theirs, 1.0 - rate)

    return update


class MixedLoss(torch.nn.Module):
    """The one-step loss on windows from anywhere in the runs plus the rollout loss on windows late in them (where a
    deposit comes to rest), one module so that DistributedDataParallel averages both gradients."""

    def __init__(self, one_step: OneStepLoss, rollout: RolloutLoss):
        super().__init__()
        self.one_step, self.rollout = one_step, rollout

    def forward(self, graph: GraphInput, target: torch.Tensor, noise: torch.Tensor, late: tuple) -> torch.Tensor:
        return self.one_step(graph, target, noise) + self.rollout(*late)


def load_simulator(path: str | Path, device: str = "cpu") -> LearnedSimulator:
    """A trained simulator from ``gns.pt`` (or a checkpoint), naming the file if it is unusable."""
    try:
        state = torch.load(path, map_location=device, weights_only=False)
        config = state["simulator"]
        from rgns.surrogates.gns.simulator import Normalization

        simulator = LearnedSimulator(
            ModelSettings(**config["settings"]), Normalization(**config["normalization"]), np.array(config["bounds"])
        )
        simulator.load_state_dict(state["model"])
    except (OSError, KeyError, RuntimeError, TypeError, EOFError, pickle.UnpicklingError) as error:
        raise ValueError(f"{path}: not a usable GNS model file ({type(error).__name__}: {error})") from error
    return simulator.to(device)


VALIDATION_SEED = 12345
VALIDATION_BATCH = 8


def fixed_windows(sampler: WindowSampler, count: int) -> list[list[tuple[int, int]]]:
    """The same ``count`` held-out windows at every validation, in batches."""
    picks = sampler.draw(np.random.default_rng(VALIDATION_SEED), count)
    return [picks[i : i + VALIDATION_BATCH] for i in range(0, len(picks), VALIDATION_BATCH)]


@torch.no_grad()
def one_step_losses(
    simulator: LearnedSimulator, sampler: WindowSampler, batches: list, target_clip: float | None, device: torch.device
) -> tuple[float, float]:
    """The model's noise-free one-step loss and the mean predictor's (always the mean acceleration,
    i.e. 0 in normalised units) on the same windows."""
    objective = OneStepLoss(simulator, target_clip)  # unweighted: comparable across moving_weight
    model, mean = [], []
    for picks in batches:
        window = sampler.window(picks)
        graph, target = window.graph.to(device), window.targets[:, 0].to(device)
        model.append(float(objective(graph, target, torch.zeros_like(graph.positions))) * len(picks))
        mean.append(float(objective.mean_predictor(graph, target)) * len(picks))
    count = sum(len(picks) for picks in batches)
    return sum(model) / count, sum(mean) / count


def rollout_score(
    simulator: LearnedSimulator, sampler: WindowSampler, trajectories: int, warmup_frames: int, device: torch.device
) -> dict:
    """Full rollouts of the first held-out trajectories (after ``warmup_frames`` of their MPM run,
    as the Monte Carlo starts them) against their MPM runs: the mean absolute error of R, V and I,
    each over the mean MPM value plus one (m or m²), averaged into one score (plus the diverged count)."""
    picks = list(range(min(trajectories, sampler.n_trajectories)))
    truths = [sampler.frames_of(k, 0, sampler.frames) for k in picks]
    friction = [np.degrees(np.arctan(sampler.tan_friction[k].numpy())) for k in picks]
    results = rollout_soil(
        simulator,
        truths,
        friction,
        sampler.frames,
        RolloutSettings(early_stop=True, keep="ends", warmup_frames=warmup_frames),
        str(device),
    )
    errors = {"runout_m": [], "volume_m2": [], "influence_m": []}
    reference = {key: [] for key in errors}
    diverged = 0
    for k, truth, result in zip(picks, truths, results):
        diverged += result.status != "ok"
        crest = particle_crest_x(truth[0])
        mpm = runout_metrics(truth[0], truth[-1], sampler.volume_m2[k], crest).as_row()
        gns = runout_metrics(truth[0], result.positions[-1], sampler.volume_m2[k], crest).as_row()
        for key in errors:
            errors[key].append(abs(gns[key] - mpm[key]))
            reference[key].append(abs(mpm[key]))
    relative = [np.mean(errors[key]) / (np.mean(reference[key]) + 1.0) for key in errors]
    return {
        "valid_rollout_score": float(np.mean(relative) + diverged),
        "valid_runout_error_m": float(np.mean(errors["runout_m"])),
        "valid_diverged": diverged,
    }


def particle_crest_x(initial: np.ndarray) -> float:
    """The crest of a slope from its particles: the rightmost one within half a metre of the top."""
    top = initial[:, 1] >= initial[:, 1].max() - 0.5
    return float(initial[top, 0].max())


def validate(
    simulator: LearnedSimulator, sampler: WindowSampler, batches: list, settings: TrainSettings, device: torch.device
) -> dict:
    """One-step loss beside the mean predictor's, and the held-out rollout score."""
    loss, mean_loss = one_step_losses(simulator, sampler, batches, settings.target_clip, device)
    row = {"valid_one_step_loss": loss, "valid_mean_predictor_loss": mean_loss}
    if settings.selection_trajectories:
        row |= rollout_score(
            simulator, sampler, settings.selection_trajectories, settings.selection_warmup_frames, device
        )
    return row


RESUME_NEUTRAL = (
    "steps",
    "checkpoint_every",
    "validate_every",
    "validation_windows",
    "selection_trajectories",
    "selection_warmup_frames",
    "log_every",
    "device",
    "threads",
)


def fingerprint(simulator: LearnedSimulator, settings: TrainSettings) -> str:
    """What a checkpoint must share exactly with this run to be resumed: architecture, bounds and the
    optimisation settings, but not the step count or bookkeeping, nor the normalisation, which
    :func:`same_data` compares up to rounding."""
    training = {key: value for key, value in asdict(settings).items() if key not in RESUME_NEUTRAL}
    built = {key: value for key, value in simulator.config().items() if key != "normalization"}
    return json.dumps({"simulator": built, "training": training}, sort_keys=True)


def _saved_fingerprint(state: dict[str, Any]) -> str | None:
    """A checkpoint's fingerprint as :func:`fingerprint` writes it now (one written with its normalisation in
    it, before that was compared apart, read without it; one written before a setting existed, with the value
    that reproduces how it trained: TrainSettings' and ModelSettings' defaults)."""
    if "fingerprint" not in state:
        return None
    saved = json.loads(state["fingerprint"])
    saved["simulator"].pop("normalization", None)
    saved["simulator"]["settings"] = asdict(ModelSettings()) | saved["simulator"]["settings"]
    neutral = {key: value for key, value in asdict(TrainSettings()).items() if key not in RESUME_NEUTRAL}
    saved["training"] = neutral | saved["training"]
    return json.dumps(saved, sort_keys=True)


def same_data(saved: Normalization, recomputed: Normalization, tolerance: float = DATA_TOLERANCE) -> bool:
    """Whether a checkpoint's normalisation is this data's up to rounding: every mean and spread within
    ``tolerance`` of the recomputed spread. Data regenerated on a fresh machine or another device differs from
    the checkpoint's in the last digits and resumes; other data (another set, other frames) does not."""
    for mean, spread in (
        ("velocity_mean", "velocity_std"),
        ("acceleration_mean", "acceleration_std"),
        ("tan_friction_mean", "tan_friction_std"),
    ):
        scale = tolerance * np.asarray(getattr(recomputed, spread), dtype=float)
        for key in (mean, spread):
            difference = np.asarray(getattr(saved, key), dtype=float) - np.asarray(getattr(recomputed, key))
            if np.any(np.abs(difference) > scale):
                return False
    return True


def _save(path: Path, state: dict[str, Any]) -> None:
    with atomic_path(path) as partial:
        torch.save(state, partial)


def train(
    model: ModelSettings,
    settings: TrainSettings,
    train_path: str,
    valid_path: str,
    out_dir: str | Path,
    final_model: str | Path | None = None,
    init_model: str | Path | None = None,
) -> dict:
    """Train (or resume) and write ``gns.pt``, ``history.csv`` and checkpoints into ``out_dir``.
    With ``init_model`` (fine-tuning) the weights and normalisation start from that model."""
    distributed = dist.is_available() and dist.is_initialized()
    rank = dist.get_rank() if distributed else 0
    device = torch.device(settings.device)
    torch.set_num_threads(settings.threads)
    out_dir = Path(out_dir)
    checkpoints = out_dir / "checkpoints"
    checkpoints.mkdir(parents=True, exist_ok=True)
    mixed = bool(settings.rollout_steps and settings.rollout_from_frame)
    train_windows = WindowSampler(
        train_path,
        model.history,
        max(1, settings.pushforward_steps + 1, 0 if mixed else settings.rollout_steps),
        settings.smoothing_frames,
    )
    late_windows = train_windows.windows_from(settings.rollout_from_frame, settings.rollout_steps) if mixed else None
    valid_windows = WindowSampler(valid_path, model.history, 1, settings.smoothing_frames)
    batches = fixed_windows(valid_windows, settings.validation_windows)
    torch.manual_seed(settings.seed)
    if init_model:
        simulator = load_simulator(init_model, str(device))
        if simulator.settings != model:
            differing = [key for key, value in asdict(model).items() if getattr(simulator.settings, key) != value]
            raise ValueError(
                f"{init_model}: its architecture differs from config gns in {', '.join(differing)} "
                f"({', '.join(f'{k} {getattr(simulator.settings, k)}' for k in differing)}): "
                "fine-tuning needs the same"
            )
    else:
        simulator = LearnedSimulator(model, train_windows.normalization(settings.noise_std), train_windows.bounds)
    latest, best_path = checkpoints / CHECKPOINT, checkpoints / BEST
    state = torch.load(latest, map_location=device, weights_only=False) if latest.exists() else None
    if state is not None:
        saved = Normalization(**state["simulator"]["normalization"]) if "simulator" in state else None
        if _saved_fingerprint(state) != fingerprint(simulator, settings) or saved is None:
            reason = "other settings"
        elif not same_data(saved, simulator.normalization):
            reason = "other data"
        else:  # the checkpoint's normalisation, not this data's recomputed one: a resumed model is the one saved
            reason = None
            simulator = LearnedSimulator(simulator.settings, saved, simulator.bounds.cpu().numpy())
        if reason:
            stale = latest.with_name(f"stale-{int(time.time())}.pt")
            latest.replace(stale)
            log.warning("%s was made with %s: kept as %s, training from scratch", latest, reason, stale)
            state = None
    simulator = simulator.to(device)
    one_step = OneStepLoss(simulator, settings.target_clip, settings.moving_weight)
    rollout = RolloutLoss(simulator, settings.target_clip, settings.moving_weight)
    objective: torch.nn.Module = (
        MixedLoss(one_step, rollout) if mixed else rollout if settings.rollout_steps else one_step
    )
    step_module = DistributedDataParallel(objective) if distributed else objective
    optimizer = torch.optim.Adam(simulator.parameters(), lr=settings.learning_rate)
    averaged = AveragedModel(simulator, multi_avg_fn=moving_average(settings.ema_decay)) if settings.ema_decay else None
    used = averaged.module if averaged is not None else simulator  # what is validated, saved and kept
    start, history, elapsed, best = 0, [], 0.0, None
    rng = np.random.default_rng([settings.seed, rank])
    noise_generator = torch.Generator().manual_seed(settings.seed * 1000 + rank)
    if state is not None:
        simulator.load_state_dict(state.get("training_weights", state["model"]))
        if averaged is not None:
            averaged.module.load_state_dict(state["model"])
            averaged.n_averaged.fill_(state["step"])
        optimizer.load_state_dict(state["optimizer"])
        start, history, elapsed, best = state["step"], state["history"], state["elapsed_s"], state.get("best")
        streams = state["streams"][rank] if rank < len(state["streams"]) else state["streams"][0]
        rng.bit_generator.state = streams["windows"]
        noise_generator.set_state(streams["noise"])
        log.info("resumed from step %d of %d (%s)", start, settings.steps, latest)
        if start >= settings.steps:
            log.info("the checkpoint is at step %d, beyond the %d asked for: nothing to train", start, settings.steps)
    else:
        log.info(
            "training %s: %d steps, %d parameters",
            f"from {init_model}" if init_model else "from scratch",
            settings.steps,
            sum(p.numel() for p in simulator.parameters()),
        )
    began = time.perf_counter() - elapsed
    running = []

    def input_noise(positions: torch.Tensor) -> torch.Tensor:
        if not settings.noise_std:
            return torch.zeros_like(positions)
        return random_walk_noise(positions, settings.noise_std, noise_generator)

    for step in range(start, settings.steps):
        for group in optimizer.param_groups:
            group["lr"] = learning_rate(settings, step)
        window = train_windows.sample(rng, settings.batch_graphs)
        graph, targets = window.graph.to(device), window.targets.to(device)
        if settings.rollout_steps and not mixed:
            target = targets
        elif settings.pushforward_steps:
            graph, target = pushforward(simulator, graph, targets)
        else:
            target = targets[:, 0]
        noise = input_noise(graph.positions)
        if late_windows is not None:
            late = late_windows.sample(rng, settings.batch_graphs)
            late_graph = late.graph.to(device)
            loss = step_module(
                graph, target, noise, (late_graph, late.targets.to(device), input_noise(late_graph.positions))
            )
        else:
            loss = step_module(graph, target, noise)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        if averaged is not None:
            averaged.update_parameters(simulator)
        running.append(loss.item())
        done = step + 1
        if done % settings.log_every == 0 or done == settings.steps:
            row: dict[str, Any] = {
                "step": done,
                "train_loss": float(np.mean(running)),
                "lr": learning_rate(settings, step),
                "elapsed_s": time.perf_counter() - began,
            }
            running = []
            if rank == 0 and (done % settings.validate_every == 0 or done == settings.steps):
                row |= validate(used, valid_windows, batches, settings, device)
                score = row.get("valid_rollout_score", row["valid_one_step_loss"])
                if best is None or score < best["score"]:
                    best = {"step": done, "score": score}
                    _save(best_path, _model_state(used, settings, done, history + [row]))
            history.append(row)
            if rank == 0:
                log.info(
                    "step %d/%d  loss %.4g  lr %.2e  %s  %.0f s",
                    done,
                    settings.steps,
                    row["train_loss"],
                    row["lr"],
                    " ".join(f"{k} {v:.4g}" for k, v in row.items() if k.startswith("valid")),
                    row["elapsed_s"],
                )
        if done % settings.checkpoint_every == 0 or done == settings.steps:
            streams = _gather_streams(rng, noise_generator, distributed)
            if rank == 0:
                _save(
                    latest,
                    {
                        "model": used.state_dict(),
                        "training_weights": simulator.state_dict(),
                        "optimizer": optimizer.state_dict(),
                        "step": done,
                        "history": history,
                        "elapsed_s": time.perf_counter() - began,
                        "best": best,
                        "streams": streams,
                        "simulator": simulator.config(),
                        "fingerprint": fingerprint(simulator, settings),
                    },
                )
    summary = {
        "steps": settings.steps,
        "wall_s": time.perf_counter() - began,
        "resumed_from": start,
        "selected_step": best["step"] if best else settings.steps,
    }
    if rank == 0:
        final = Path(final_model or out_dir / "gns.pt")
        if best is not None and best_path.exists():
            kept = torch.load(best_path, map_location="cpu", weights_only=False)
            kept["history"] = history
            _save(final, kept)
        else:
            _save(final, _model_state(used, settings, settings.steps, history))
        write_history(history, out_dir / "history.csv")
    return summary


def _model_state(simulator: LearnedSimulator, settings: TrainSettings, step: int, history: list[dict]) -> dict:
    """What a model file holds: weights, how to rebuild the simulator, how it was trained."""
    return {
        "model": simulator.state_dict(),
        "simulator": simulator.config(),
        "train_settings": asdict(settings),
        "step": step,
        "history": history,
    }


def _gather_streams(rng: np.random.Generator, noise: torch.Generator, distributed: bool) -> list[dict]:
    """The window and noise streams of every process, so a resume continues them exactly."""
    mine = {"windows": rng.bit_generator.state, "noise": noise.get_state()}
    if not distributed:
        return [mine]
    everyone: list[Any] = [None] * dist.get_world_size()
    dist.all_gather_object(everyone, mine)
    return everyone


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
