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
    """Initial points and their friction angles in, final points out."""

    def __init__(self, lattice: Lattice, normalization: Normalization, widths: tuple[int, ...] = (16, 32, 64, 96)):
        super().__init__()
        self.lattice, self.normalization, self.widths = lattice, normalization, tuple(widths)
        self.network = UNet(INPUT_CHANNELS, 2, self.widths)

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
        out = out * self.normalization.displacement_scale_m
        return [
            (np.asarray(p, dtype=float) + self.lattice.gather(image, p)).astype(np.float32)
            for p, image in zip(initials, out)
        ]

    def save(self, path: str | Path, extra: dict | None = None) -> None:
        state = {
            "lattice": asdict(self.lattice),
            "normalization": asdict(self.normalization),
            "widths": self.widths,
            "weights": self.state_dict(),
        } | (extra or {})
        with atomic_path(path) as partial:
            torch.save(state, partial)


def load_model(path: str | Path, device: str = "cpu") -> EndStateModel:
    """A trained end-state model from ``path`` (a model file or a checkpoint), naming the file if unusable."""
    try:
        state = torch.load(path, map_location=device, weights_only=False)
        model = EndStateModel(
            Lattice(**state["lattice"]), Normalization(**state["normalization"]), tuple(state["widths"])
        )
        model.load_state_dict(state["weights"])
    except (OSError, RuntimeError, KeyError, TypeError, EOFError, ValueError, pickle.UnpicklingError) as error:
        raise EndStateModelError(f"{path}: not a usable end-state model ({type(error).__name__}: {error})") from error
    return model.to(device).eval()
