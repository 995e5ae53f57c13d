"""Shape functions on a regular grid: bilinear (CB-Geo's ED2Q4) and quadratic B-spline.

Each returns, for every particle, the ids of the nodes it talks to, their weights (which sum to
one) and the weight gradients. Node ids are row by row, ``j·(nx+1) + i``, as in the case mesh.
A particle outside the grid gets ``inside = False`` (and clamped, harmless ids).
"""
from __future__ import annotations

from dataclasses import dataclass

import torch


@dataclass
class RegularGrid:
    """A uniform grid of ``cells`` = (nx, ny) square cells of size ``h`` from ``origin``."""

    origin: tuple[float, float]
    h: float
    cells: tuple[int, int]

    @property
    def n_nodes(self) -> int:
        return (self.cells[0] + 1) * (self.cells[1] + 1)


@dataclass
class Weights:
    """Particle-node interpolation: node ids [P, K], weights [P, K], gradients [P, K, 2]."""

    nodes: torch.Tensor
    value: torch.Tensor
    grad: torch.Tensor
    inside: torch.Tensor  # [P] bool: the particle's support lies inside the grid


def _local(positions: torch.Tensor, grid: RegularGrid) -> torch.Tensor:
    origin = torch.tensor(grid.origin, dtype=positions.dtype, device=positions.device)
    return (positions - origin) / grid.h


def linear(positions: torch.Tensor, grid: RegularGrid) -> Weights:
    """Bilinear weights of the 4 nodes of the containing cell."""
    nx, ny = grid.cells
    local = _local(positions, grid)
    cell = torch.floor(local)
    inside = (cell[:, 0] >= 0) & (cell[:, 0] < nx) & (cell[:, 1] >= 0) & (cell[:, 1] < ny)
    cell = torch.stack([cell[:, 0].clamp(0, nx - 1), cell[:, 1].clamp(0, ny - 1)], dim=1)
    xi, eta = (local - cell).unbind(1)
    i, j = cell.long().unbind(1)
    base = j * (nx + 1) + i
    nodes = torch.stack([base, base + 1, base + nx + 2, base + nx + 1], dim=1)
    one = torch.ones_like(xi)
    value = torch.stack([(1 - xi) * (1 - eta), xi * (1 - eta), xi * eta, (1 - xi) * eta], dim=1)
    dx = torch.stack([-(1 - eta), 1 - eta, eta, -eta], dim=1) / grid.h
    dy = torch.stack([-(1 - xi), -xi, xi, (1 - xi) * one], dim=1) / grid.h
    return Weights(nodes, value, torch.stack([dx, dy], dim=2), inside)


def _bspline_1d(offset: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Quadratic B-spline weights and derivatives (per unit h) at the 3 nodes from base."""
    w = torch.stack([0.5 * (1.5 - offset) ** 2, 0.75 - (offset - 1.0) ** 2, 0.5 * (offset - 0.5) ** 2], dim=1)
    dw = torch.stack([offset - 1.5, -2.0 * (offset - 1.0), offset - 0.5], dim=1)
    return w, dw


def bspline(positions: torch.Tensor, grid: RegularGrid) -> Weights:
    """Quadratic B-spline weights of the 3 × 3 nodes around each particle (smooth across cells)."""
    nx, ny = grid.cells
    local = _local(positions, grid)
    base = torch.floor(local - 0.5)
    inside = (base[:, 0] >= 0) & (base[:, 0] + 2 <= nx) & (base[:, 1] >= 0) & (base[:, 1] + 2 <= ny)
    base = torch.stack([base[:, 0].clamp(0, nx - 2), base[:, 1].clamp(0, ny - 2)], dim=1)
    offset = local - base
    wx, dwx = _bspline_1d(offset[:, 0])
    wy, dwy = _bspline_1d(offset[:, 1])
    i, j = base.long().unbind(1)
    a = torch.arange(3, device=positions.device)
    nodes = ((j[:, None, None] + a[None, :, None]) * (nx + 1) + i[:, None, None] + a[None, None, :]).reshape(-1, 9)
    value = (wy[:, :, None] * wx[:, None, :]).reshape(-1, 9)
    gx = (wy[:, :, None] * dwx[:, None, :]).reshape(-1, 9) / grid.h
    gy = (dwy[:, :, None] * wx[:, None, :]).reshape(-1, 9) / grid.h
    return Weights(nodes, value, torch.stack([gx, gy], dim=2), inside)


SHAPE_FUNCTIONS = {"linear": linear, "bspline": bspline}
