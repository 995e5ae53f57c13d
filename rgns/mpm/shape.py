"""Shape functions on a regular grid: bilinear (CB-Geo's ED2Q4) and quadratic B-spline.

Each returns, for every particle, the ids of the nodes it talks to, their weights (summing to
one) and the weight gradients, laid out [K, P] (node slot first) so that gathers, scatters and
sums over the K nodes run along contiguous memory. Node ids are row by row, ``j·(nx+1) + i``, as
in the case mesh. A particle outside the grid gets ``inside = False`` (and clamped, harmless ids).
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
    """Particle-node interpolation, all [K, P]: node ids, weights, ∂/∂x and ∂/∂y of the weights."""

    nodes: torch.Tensor
    value: torch.Tensor
    grad_x: torch.Tensor
    grad_y: torch.Tensor
    inside: torch.Tensor  # [P] bool: the particle's support lies inside the grid


def linear(x: torch.Tensor, y: torch.Tensor, grid: RegularGrid) -> Weights:
    """Bilinear weights of the 4 nodes of the containing cell."""
    nx, ny = grid.cells
    u, v = (x - grid.origin[0]) / grid.h, (y - grid.origin[1]) / grid.h
    i, j = torch.floor(u), torch.floor(v)
    inside = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
    i, j = i.clamp(0, nx - 1), j.clamp(0, ny - 1)
    xi, eta = u - i, v - j
    base = j.long() * (nx + 1) + i.long()
    nodes = torch.stack([base, base + 1, base + nx + 2, base + nx + 1])
    value = torch.stack([(1 - xi) * (1 - eta), xi * (1 - eta), xi * eta, (1 - xi) * eta])
    grad_x = torch.stack([eta - 1, 1 - eta, eta, -eta]) / grid.h
    grad_y = torch.stack([xi - 1, -xi, xi, 1 - xi]) / grid.h
    return Weights(nodes, value, grad_x, grad_y, inside)


def _bspline_1d(offset: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Quadratic B-spline weights [3, P] and derivatives (per unit h) at the 3 nodes from base."""
    w = torch.stack([0.5 * (1.5 - offset) ** 2, 0.75 - (offset - 1.0) ** 2, 0.5 * (offset - 0.5) ** 2])
    dw = torch.stack([offset - 1.5, -2.0 * (offset - 1.0), offset - 0.5])
    return w, dw


def bspline(x: torch.Tensor, y: torch.Tensor, grid: RegularGrid) -> Weights:
    """Quadratic B-spline weights of the 3 × 3 nodes around each particle (smooth across cells)."""
    nx, ny = grid.cells
    u, v = (x - grid.origin[0]) / grid.h, (y - grid.origin[1]) / grid.h
    i, j = torch.floor(u - 0.5), torch.floor(v - 0.5)
    inside = (i >= 0) & (i + 2 <= nx) & (j >= 0) & (j + 2 <= ny)
    i, j = i.clamp(0, nx - 2), j.clamp(0, ny - 2)
    wx, dwx = _bspline_1d(u - i)
    wy, dwy = _bspline_1d(v - j)
    a = torch.arange(3, device=x.device)
    rows = (j.long()[None] + a[:, None]) * (nx + 1)  # [3, P]
    nodes = (rows[:, None, :] + i.long()[None, None] + a[None, :, None]).reshape(9, -1)
    value = (wy[:, None] * wx[None, :]).reshape(9, -1)
    grad_x = (wy[:, None] * dwx[None, :]).reshape(9, -1) / grid.h
    grad_y = (dwy[:, None] * wx[None, :]).reshape(9, -1) / grid.h
    return Weights(nodes, value, grad_x, grad_y, inside)


SHAPE_FUNCTIONS = {"linear": linear, "bspline": bspline}
