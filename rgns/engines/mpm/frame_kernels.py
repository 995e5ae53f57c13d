"""The solver's bridge to the compiled kernels: a frame of a batch's particles advanced in place, no copies.

The particle tensors of :class:`~rgns.engines.mpm.step.Particles` are CPU float64 and contiguous; their numpy
views are handed to :mod:`rgns.engines.mpm.kernels`, which writes the new state into them. The views are
made once per particle set (a torch tensor's ``.numpy()`` costs tens of microseconds, a frame's worth of
kernel at 1 m). numba is imported on first use, so a run on the torch backend never loads it.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import torch

from rgns.engines.mpm.shape import Basis, ClampedBSplineBasis, Region, RegularGrid
from rgns.engines.mpm.step import Boundary, Particles

STATE = ("x", "y", "vx", "vy", "mass", "volume", "sxx", "syy", "szz", "txy")
CONSTANTS = ("shear_modulus", "lame_lambda", "k", "m", "sigma_c", "tension_cutoff")
SUMMARY = STATE + CONSTANTS[:2]  # what frame_summary reads, in its order


class FrameKernels:
    """One batch's grid, basis and constraints, ready for :meth:`advance` and :meth:`summary`."""

    def __init__(
        self, basis: Basis, boundary: Boundary, gravity: tuple[float, float], damping: float, pic_blend: float
    ) -> None:
        from rgns.engines.mpm import kernels

        self._kernels: Any = kernels  # numba dispatchers: their arguments are typed at the call
        grid, region = basis.grid, basis.region
        self.grid = np.array([*grid.origin, grid.h, *region.lower, *region.cells, *grid.cells], dtype=np.float64)
        self.spline = isinstance(basis, ClampedBSplineBasis)
        self.constraints = tuple(
            getattr(boundary, name).cpu().numpy() for name in ("fixed_x", "fixed_y", "floor", "friction")
        )
        self.gravity, self.damping, self.pic_blend = gravity, float(damping), float(pic_blend)
        self._tensors: tuple[torch.Tensor, ...] = ()
        self._views: tuple[np.ndarray, ...] = ()
        self._starts = np.zeros(1, dtype=np.int64)

    def views(self, particles: Particles) -> tuple[np.ndarray, ...]:
        """The numpy views of the state (STATE) and constants (CONSTANTS), made again only for new tensors."""
        tensors = tuple(getattr(particles, name) for name in STATE) + tuple(
            getattr(particles.material, name) for name in CONSTANTS
        )
        if len(tensors) != len(self._tensors) or any(a is not b for a, b in zip(tensors, self._tensors)):
            self._tensors, self._views = tensors, tuple(tensor.numpy() for tensor in tensors)
            counts = torch.bincount(particles.batch).numpy()
            self._starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        return self._views

    def advance(self, particles: Particles, substeps: list[int], dt: list[float]) -> np.ndarray:
        """Realization b takes substeps[b] steps of dt[b]; returns its particle steps out of the region [B]."""
        return self._advance(self.views(particles), self._starts, substeps, dt)

    def summary(self, particles: Particles, gravity: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per realization: kinetic, potential and elastic energy [B, 3], non-finite particles [B], top speed [B]."""
        return self._summary(self.views(particles), self._starts, gravity)

    def _advance(
        self, views: tuple[np.ndarray, ...], starts: np.ndarray, substeps: list[int], dt: list[float]
    ) -> np.ndarray:
        outside = np.zeros(len(substeps), dtype=np.int64)
        self._kernels.advance_frame(
            *views,
            starts,
            np.asarray(substeps, dtype=np.int64),
            np.asarray(dt, dtype=np.float64),
            self.grid,
            self.spline,
            *self.constraints,
            *self.gravity,
            self.damping,
            self.pic_blend,
            outside,
        )
        return outside

    def _summary(
        self, views: tuple[np.ndarray, ...], starts: np.ndarray, gravity: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        batches = len(starts) - 1
        energy, non_finite, speed = np.zeros((batches, 3)), np.zeros(batches, dtype=np.int64), np.zeros(batches)
        self._kernels.frame_summary(*views[: len(SUMMARY)], starts, gravity, energy, non_finite, speed)
        return energy, non_finite, speed


def compile_kernels() -> float:
    """Compile (or load from the cache) both kernels, through the calls a run makes, on an empty batch; returns the
    seconds. A workflow runs this once before its MPM jobs, so that two jobs side by side do not both compile."""
    began = time.perf_counter()
    grid = RegularGrid((0.0, 0.0), 1.0, (2, 2))
    basis = ClampedBSplineBasis(grid, Region.whole(grid))
    free = torch.zeros(basis.n_nodes, dtype=torch.bool)
    frames = FrameKernels(
        basis, Boundary(free, free, free, torch.zeros(basis.n_nodes, dtype=torch.float64)), (0.0, -9.81), 0.0, 0.0
    )
    views = tuple(np.zeros(0) for _ in STATE + CONSTANTS)
    starts = np.zeros(1, dtype=np.int64)
    frames._advance(views, starts, [], [])
    frames._summary(views, starts, 9.81)
    return time.perf_counter() - began
