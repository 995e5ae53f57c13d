"""The end-state surrogate: lattice, normalisation and U-Net together, saved as one file.

It maps a slope at rest straight to where each material point comes to rest, in one network
evaluation: no time stepping, hence no MPM warm-up and no error growing over a rollout. It knows
only what R, V and I need (initial and final positions), not the path between.
"""

from __future__ import annotations

import pickle
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch

from rgns.atomic import atomic_path
from rgns.surrogates.endstate.lattice import INPUT_CHANNELS, Lattice
from rgns.surrogates.endstate.network import UNet


class EndStateModelError(ValueError):
    """A model file that cannot be used; the message names it."""


@dataclass(frozen=True)
class Normalization:
    """Friction angle centre and scale (deg) and displacement scale (m), from the training data."""

    friction_center_deg: float
    friction_scale_deg: float
    displacement_scale_m: float


class EndStateModel(torch.nn.Module):
    """Initial points and their friction angles in, final points out.

    With ``moved_head`` the network writes a third channel, each point's logit of "moved by at least the
    displacement threshold" (trained as a classifier, rgns.surrogates.endstate.train.ThresholdTerm), and
    :meth:`predict` puts each point's displacement on that side of the threshold: the head decides where the moved
    zone ends (what V and I count), the regression how far the material goes (R).
    """

    def __init__(
        self,
        lattice: Lattice,
        normalization: Normalization,
        widths: tuple[int, ...] = (16, 32, 64, 96),
        moved_head: bool = False,
        threshold_m: float = 1.0,
    ):
        super().__init__()
        self.lattice, self.normalization, self.widths = lattice, normalization, tuple(widths)
        self.moved_head, self.threshold_m = moved_head, threshold_m
        self.network = UNet(INPUT_CHANNELS, 3 if moved_head else 2, self.widths)

    def inputs(self, positions: np.ndarray, friction_deg: np.ndarray) -> np.ndarray:
        n = self.normalization
        return self.lattice.inputs(positions, friction_deg, n.friction_center_deg, n.friction_scale_deg)

    def targets(self, initial: np.ndarray, final: np.ndarray) -> np.ndarray:
        return self.lattice.targets(initial, final, self.normalization.displacement_scale_m)

    def forward(self, images: torch.Tensor) -> torch.Tensor:
        return self.network(images)

    @torch.no_grad()
    def predict(self, initials: list[np.ndarray], frictions: list[np.ndarray], device: str = "cpu") -> list[np.ndarray]:
        """The final positions [N, 2] of each slope (float32)."""
        if not initials:
            return []
        images = torch.from_numpy(np.stack([self.inputs(p, f) for p, f in zip(initials, frictions)])).to(device)
        # channels last: oneDNN's own layout, a fifth faster on the CPU (benchmarks/bench_endstate_layout.py)
        self.network.to(memory_format=torch.channels_last)
        out = self(images.contiguous(memory_format=torch.channels_last)).cpu().numpy()
        finals = []
        for p, image in zip(initials, out):
            values = self.lattice.gather(image, p)
            displacement = values[:, :2] * self.normalization.displacement_scale_m
            if self.moved_head:
                displacement = on_side(displacement, values[:, 2] > 0, self.threshold_m)
            finals.append((np.asarray(p, dtype=float) + displacement).astype(np.float32))
        return finals

    def save(self, path: str | Path, extra: dict | None = None) -> None:
        state = {
            "lattice": asdict(self.lattice),
            "normalization": asdict(self.normalization),
            "widths": self.widths,
            "moved_head": self.moved_head,
            "threshold_m": self.threshold_m,
            "weights": self.state_dict(),
        } | (extra or {})
        with atomic_path(path) as partial:
            torch.save(state, partial)


def on_side(displacement: np.ndarray, moved: np.ndarray, threshold_m: float, margin: float = 1e-3) -> np.ndarray:
    """Each displacement [N, 2] scaled along itself to just past ``threshold_m`` where ``moved`` says moved and it is
    shorter, to just short of it where ``moved`` says not and it is longer; a moved point with no direction moves
    down."""
    length = np.linalg.norm(displacement, axis=1)
    direction = np.where(length[:, None] > 0, displacement / np.maximum(length, 1e-30)[:, None], [0.0, -1.0])
    target = np.where(
        moved, np.maximum(length, threshold_m * (1 + margin)), np.minimum(length, threshold_m * (1 - margin))
    )
    return direction * target[:, None]


def load_model(path: str | Path, device: str = "cpu") -> EndStateModel:
    """A trained end-state model from ``path`` (a model file or a checkpoint), naming the file if unusable."""
    try:
        state = torch.load(path, map_location=device, weights_only=False)
        model = EndStateModel(
            Lattice(**state["lattice"]),
            Normalization(**state["normalization"]),
            tuple(state["widths"]),
            state.get("moved_head", False),  # files saved before the head lack it
            state.get("threshold_m", 1.0),
        )
        model.load_state_dict(state["weights"])
    except (OSError, RuntimeError, KeyError, TypeError, EOFError, ValueError, pickle.UnpicklingError) as error:
        raise EndStateModelError(f"{path}: not a usable end-state model ({type(error).__name__}: {error})") from error
    return model.to(device).eval()
