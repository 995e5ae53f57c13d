"""Training the end-state surrogate: pairs (slope at rest, where each point came to rest) from MPM
runs, masked mean squared error of the scaled displacement, AdamW with a one-cycle learning rate
and the gradient norm clipped (at a peak of 2e-3 without clipping, a 4,000-step run on the
pretraining data collapsed to the mean predictor at step 1,750 and never left it).

Optionally a second term for the displacement threshold that R, V and I count a point as moved by
(metrics.displacement_threshold_m): the binary cross-entropy of "moved" with a soft step of the
predicted displacement's length. Trained on mean squared error alone, the geometry-general model
left the rear of a failure short of the threshold: on 64 realizations of the DEM section (seed
8675309) its influence distance was short in 48 (by 0.5 to 2 m, mean -12 %) and its volume in 58.

Resumable: a checkpoint every ``checkpoint_every`` steps holds the weights, the optimiser, the
schedule and the batch stream, so a killed run resumed continues exactly as an uninterrupted one.
"""

from __future__ import annotations

import csv
import logging
import time
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

from rgns.surrogates.endstate.data import EndState
from rgns.surrogates.endstate.lattice import Lattice
from rgns.surrogates.endstate.model import EndStateModel, Normalization

log = logging.getLogger(__name__)
CHECKPOINT = "endstate-latest.pt"


@dataclass(frozen=True)
class EndStateTrainSettings:
    """Config section ``endstate`` (what training needs of it)."""

    widths: tuple[int, ...] = (16, 32, 64, 96)
    steps: int = 3000
    batch_size: int = 16
    learning_rate: float = 1e-3
    weight_decay: float = 1e-4
    gradient_clip: float = 1.0
    seed: int = 0
    checkpoint_every: int = 250
    threads: int = 1
    device: str = "cpu"
    threshold_weight: float = 0.0  # weight of the moved / not-moved term (0: mean squared error only)
    threshold_m: float = 1.0  # metrics.displacement_threshold_m
    threshold_width_m: float = 0.1  # width of the soft step at the threshold
    moved_head: bool = False  # a third output channel, the moved logit, takes the threshold term (EndStateModel)


@dataclass
class Examples:
    """Input and target images [B, C, H, W] and the occupancy mask [B, 1, H, W]."""

    inputs: torch.Tensor
    targets: torch.Tensor

    @property
    def mask(self) -> torch.Tensor:
        return self.inputs[:, :1]

    def __len__(self) -> int:
        return len(self.inputs)

    def to(self, device: torch.device) -> Examples:
        return Examples(self.inputs.to(device), self.targets.to(device))


def normalization_of(states: list[EndState]) -> Normalization:
    """Friction centre and scale over every point; displacement scale: the RMS final displacement."""
    friction = np.concatenate([s.friction_deg for s in states])
    moved = np.concatenate([np.linalg.norm(s.final - s.initial, axis=1) for s in states])
    return Normalization(
        float(friction.mean()), float(max(friction.std(), 1.0)), float(max(np.sqrt(np.mean(moved**2)), 0.1))
    )


def examples(model: EndStateModel, states: Iterable[EndState]) -> Examples:
    """The images of each realization before and after."""
    inputs, targets = [], []
    for state in states:
        inputs.append(model.inputs(state.initial, state.friction_deg))
        targets.append(model.targets(state.initial, state.final))
    return Examples(torch.from_numpy(np.stack(inputs)), torch.from_numpy(np.stack(targets)))


@dataclass(frozen=True)
class ThresholdTerm:
    """The moved / not-moved term in scaled units: its weight, the threshold and the soft step's width."""

    weight: float
    threshold: float
    width: float

    @classmethod
    def of(cls, settings: EndStateTrainSettings, displacement_scale_m: float) -> ThresholdTerm | None:
        if settings.threshold_weight <= 0:
            return None
        return cls(
            settings.threshold_weight,
            settings.threshold_m / displacement_scale_m,
            settings.threshold_width_m / displacement_scale_m,
        )

    def __call__(self, predicted: torch.Tensor, targets: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        """On the moved head's logit where the model has one (a third channel), else on a soft step of the
        predicted displacement's length."""
        moved = (targets.norm(dim=1, keepdim=True) >= self.threshold).float()
        if predicted.shape[1] > 2:
            logits = predicted[:, 2:3]
        else:
            length = torch.sqrt((predicted**2).sum(dim=1, keepdim=True) + 1e-12)
            logits = (length - self.threshold) / self.width
        entropy = F.binary_cross_entropy_with_logits(logits, moved, reduction="none")
        return self.weight * (entropy * mask).sum() / mask.sum()


def masked_loss(model: EndStateModel, batch: Examples, threshold: ThresholdTerm | None = None) -> torch.Tensor:
    """Mean squared error of the scaled displacement over the points (both components), plus the
    threshold term if given."""
    mask = batch.mask
    predicted = model(batch.inputs)
    loss = ((predicted[:, :2] - batch.targets) ** 2 * mask).sum() / (2 * mask.sum())
    return loss if threshold is None else loss + threshold(predicted, batch.targets, mask)


@torch.no_grad()
def held_out_loss(model: EndStateModel, batch: Examples) -> tuple[float, float]:
    """The model's masked loss and the mean predictor's (every point gets the mean displacement)."""
    mask = batch.mask
    mean = (batch.targets * mask).sum(dim=(0, 2, 3), keepdim=True) / mask.sum()
    baseline = ((mean - batch.targets) ** 2 * mask).sum() / (2 * mask.sum())
    return float(masked_loss(model, batch)), float(baseline)


def training_step(
    model: EndStateModel,
    optimizer: torch.optim.Optimizer,
    schedule: torch.optim.lr_scheduler.LRScheduler,
    data: Examples,
    batch_size: int,
    batches: torch.Generator,
    gradient_clip: float,
    threshold: ThresholdTerm | None = None,
) -> float:
    """One optimiser step on a batch drawn with replacement from ``data``; its loss."""
    pick = torch.randint(0, len(data), (batch_size,), generator=batches).to(data.inputs.device)
    loss = masked_loss(model, Examples(data.inputs[pick], data.targets[pick]), threshold)
    optimizer.zero_grad()
    loss.backward()
    torch.nn.utils.clip_grad_norm_(model.parameters(), gradient_clip)
    optimizer.step()
    schedule.step()
    return loss.item()


def started_weights(start: EndStateModel, model: EndStateModel) -> dict[str, torch.Tensor]:
    """``start``'s weights for ``model``: a moved head ``start`` lacks starts at zero (every logit 0), the
    displacement channels as ``start``'s."""
    weights = start.state_dict()
    for name, value in model.state_dict().items():
        if value.shape != weights[name].shape:  # the head's output channels
            grown = torch.zeros_like(value)
            grown[: weights[name].shape[0]] = weights[name]
            weights[name] = grown
    return weights


def train(
    states: list[EndState],
    held_out: list[EndState],
    lattice: Lattice,
    settings: EndStateTrainSettings,
    out_dir: str | Path,
    start: EndStateModel | None = None,
) -> tuple[EndStateModel, list[dict]]:
    """Train (or resume from ``out_dir``'s checkpoint) and return the model and its history; from ``start``'s weights
    and normalisation (fine-tuning a trained model, on its lattice) if given, else from scratch."""
    torch.set_num_threads(settings.threads)
    torch.manual_seed(settings.seed)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    device = torch.device(settings.device)
    if settings.moved_head and settings.threshold_weight <= 0:
        raise ValueError("endstate.moved_head needs endstate.threshold_weight > 0: the head learns from that term")
    lattice, normalization, widths = (
        (lattice, normalization_of(states), settings.widths)
        if start is None
        else (start.lattice, start.normalization, start.widths)
    )
    model = EndStateModel(lattice, normalization, widths, settings.moved_head, settings.threshold_m)
    if start is not None:
        model.load_state_dict(started_weights(start, model))
    data, valid = examples(model, states).to(device), examples(model, held_out).to(device)
    model.to(device)
    threshold = ThresholdTerm.of(settings, model.normalization.displacement_scale_m)
    optimizer = torch.optim.AdamW(model.parameters(), settings.learning_rate, weight_decay=settings.weight_decay)
    schedule = torch.optim.lr_scheduler.OneCycleLR(optimizer, settings.learning_rate, total_steps=settings.steps)
    batches = torch.Generator().manual_seed(settings.seed)
    start, history, elapsed = 0, [], 0.0
    latest = out_dir / CHECKPOINT
    if latest.exists():
        state = torch.load(latest, map_location=device, weights_only=False)
        if state["settings"] == asdict(settings) and state["normalization"] == asdict(model.normalization):
            model.load_state_dict(state["weights"])
            optimizer.load_state_dict(state["optimizer"])
            schedule.load_state_dict(state["schedule"])
            batches.set_state(state["batches"])
            start, history, elapsed = state["step"], state["history"], state["elapsed_s"]
            log.info("resumed from step %d of %d (%s)", start, settings.steps, latest)
        else:
            log.warning("%s was made with other settings or data: training from scratch", latest)
    began = time.perf_counter() - elapsed
    running: list[float] = []
    model.train()
    for step in range(start, settings.steps):
        running.append(
            training_step(
                model, optimizer, schedule, data, settings.batch_size, batches, settings.gradient_clip, threshold
            )
        )
        done = step + 1
        if done % settings.checkpoint_every == 0 or done == settings.steps:
            model.eval()
            valid_loss, mean_loss = held_out_loss(model, valid)
            model.train()
            row = {
                "step": done,
                "train_loss": float(np.mean(running)),
                "valid_loss": valid_loss,
                "valid_mean_predictor_loss": mean_loss,
                "lr": schedule.get_last_lr()[0],
                "elapsed_s": time.perf_counter() - began,
            }
            running = []
            history.append(row)
            log.info(
                "step %d/%d  loss %.4g  held-out %.4g (mean predictor %.4g)  %.0f s",
                done,
                settings.steps,
                row["train_loss"],
                valid_loss,
                mean_loss,
                row["elapsed_s"],
            )
            model.save(
                latest,
                {
                    "optimizer": optimizer.state_dict(),
                    "schedule": schedule.state_dict(),
                    "batches": batches.get_state(),
                    "step": done,
                    "history": history,
                    "elapsed_s": row["elapsed_s"],
                    "settings": asdict(settings),
                },
            )
    return model.to("cpu").eval(), history


def write_history(history: list[dict], path: str | Path) -> None:
    """The learning history as CSV."""
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(history[0]))
        writer.writeheader()
        writer.writerows(history)
