"""Shape functions on a regular grid: bilinear (CB-Geo's ED2Q4) and clamped quadratic B-splines.

A basis maps particles to its degrees of freedom (DOFs, the "nodes" the grid update works on):
for every particle the ids of the DOFs it talks to, their weights (summing to one) and the weight
gradients, laid out [K, P] (slot first) so that gathers, scatters and sums over the K DOFs run
along contiguous memory. Both live on a :class:`Region`, the part of the mesh the soil may occupy
(between the walls and above the floor, else up to the mesh edge); a particle outside it gets
``inside = False`` (and clamped, harmless ids) so the solver can flag it.

* ``linear``: the mesh nodes are the DOFs, ids row by row ``j·(nx+1) + i`` as in the case mesh.
* ``bspline``: quadratic B-splines on an open (clamped) knot vector over the region, knots at the
  mesh lines: (n + 2) DOFs per axis for n cells, at the Greville points 0, h/2, 3h/2, …, nh − h/2,
  nh. Only the first DOF is non-zero on a wall or the floor, so holding it fixed holds the normal
  velocity at zero exactly there (no particle is carried through), and the splines are C¹ across
  cells inside, which removes the volumetric locking of the bilinear cell (findings.md; Steffen,
  Kirby & Berzins 2008; Tielen et al. 2017 for B-spline MPM with open knot vectors).
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


@dataclass(frozen=True)
class Region:
    """Cells ``lower[a]`` up to ``upper[a]`` (exclusive) of a grid along each axis a: where soil may be."""

    lower: tuple[int, int]
    upper: tuple[int, int]

    @classmethod
    def whole(cls, grid: RegularGrid) -> Region:
        return cls((0, 0), grid.cells)

    @property
    def cells(self) -> tuple[int, int]:
        return self.upper[0] - self.lower[0], self.upper[1] - self.lower[1]


@dataclass
class Weights:
    """Particle-DOF interpolation, all [K, P]: DOF ids, weights, ∂/∂x and ∂/∂y of the weights."""

    nodes: torch.Tensor
    value: torch.Tensor
    grad_x: torch.Tensor
    grad_y: torch.Tensor
    inside: torch.Tensor  # [P] bool: the particle lies inside the region


def _grid_units(x: torch.Tensor, y: torch.Tensor, grid: RegularGrid, region: Region) -> tuple:
    """Coordinates in cells from the region's lower corner, and whether each particle is in the region."""
    u = (x - grid.origin[0]) / grid.h - region.lower[0]
    v = (y - grid.origin[1]) / grid.h - region.lower[1]
    nx, ny = region.cells
    inside = (u >= 0) & (u <= nx) & (v >= 0) & (v <= ny)  # False for a non-finite position too
    return u.nan_to_num(0.0, 0.0, 0.0), v.nan_to_num(0.0, 0.0, 0.0), inside


class LinearBasis:
    """Bilinear weights of the 4 nodes of the containing cell; the DOFs are the mesh nodes."""

    name = "linear"

    def __init__(self, grid: RegularGrid, region: Region) -> None:
        self.grid, self.region = grid, region
        self.n_nodes = grid.n_nodes

    def __call__(self, x: torch.Tensor, y: torch.Tensor) -> Weights:
        grid = self.grid
        nx, ny = grid.cells
        u, v, inside = _grid_units(x, y, grid, self.region)
        u, v = u + self.region.lower[0], v + self.region.lower[1]  # cells from the mesh origin
        i, j = torch.floor(u).clamp(0, nx - 1), torch.floor(v).clamp(0, ny - 1)
        xi, eta = (u - i).clamp(0, 1), (v - j).clamp(0, 1)  # a particle off the mesh (flagged) gets its edge's weights
        base = j.long() * (nx + 1) + i.long()
        nodes = torch.stack([base, base + 1, base + nx + 2, base + nx + 1])
        value = torch.stack([(1 - xi) * (1 - eta), xi * (1 - eta), xi * eta, (1 - xi) * eta])
        grad_x = torch.stack([eta - 1, 1 - eta, eta, -eta]) / grid.h
        grad_y = torch.stack([xi - 1, -xi, xi, 1 - xi]) / grid.h
        return Weights(nodes, value, grad_x, grad_y, inside)

    def dof_coordinates(self) -> tuple[torch.Tensor, torch.Tensor]:
        """x and y of every DOF [n_nodes] (float64)."""
        nx, ny = self.grid.cells
        j, i = torch.meshgrid(torch.arange(ny + 1), torch.arange(nx + 1), indexing="ij")
        h, (x0, y0) = self.grid.h, self.grid.origin
        return x0 + h * i.reshape(-1).double(), y0 + h * j.reshape(-1).double()


def clamped_quadratic_1d(t: torch.Tensor, n: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Open-knot quadratic B-splines on ``n`` ≥ 2 unit cells at ``t`` ∈ [0, n].

    Returns the weights [3, P] and derivatives [3, P] of DOFs c, c + 1, c + 2, and c [P] (the cell).
    Inside the uniform pieces ½(1 − s)², ½ + s − s², ½s²; the first and last cells carry the
    repeated-knot pieces (1 − s)², 2s − 3s²/2 and their mirror images.
    """
    c = torch.floor(t).clamp(0, n - 1)
    s = (t - c).clamp(0, 1)  # a particle out of the region (flagged by the solver) gets its edge's weights
    r = 1 - s
    first, last = c == 0, c == n - 1
    w0 = torch.where(first, r * r, 0.5 * r * r)
    d0 = torch.where(first, -2 * r, -r)
    w1 = torch.where(first, 2 * s - 1.5 * s * s, torch.where(last, 2 * r - 1.5 * r * r, 0.5 + s - s * s))
    d1 = torch.where(first, 2 - 3 * s, torch.where(last, 3 * r - 2, 1 - 2 * s))
    w2 = torch.where(last, s * s, 0.5 * s * s)
    d2 = torch.where(last, 2 * s, s)
    return torch.stack([w0, w1, w2]), torch.stack([d0, d1, d2]), c.long()


def greville_points(n: int) -> torch.Tensor:
    """Where the n + 2 DOFs of :func:`clamped_quadratic_1d` sit (in cells): 0, ½, 3/2, …, n − ½, n."""
    inner = torch.arange(n, dtype=torch.float64) + 0.5
    return torch.cat([torch.zeros(1, dtype=torch.float64), inner, torch.full((1,), float(n), dtype=torch.float64)])


class ClampedBSplineBasis:
    """Quadratic B-splines, open knot vector at the region's edges: 3 × 3 DOFs per particle."""

    name = "bspline"

    def __init__(self, grid: RegularGrid, region: Region) -> None:
        nx, ny = region.cells
        if min(nx, ny) < 2:
            raise ValueError(f"B-splines need a region of at least 2 x 2 cells, got {nx} x {ny}")
        self.grid, self.region = grid, region
        self.n_nodes = (nx + 2) * (ny + 2)

    def __call__(self, x: torch.Tensor, y: torch.Tensor) -> Weights:
        nx, ny = self.region.cells
        u, v, inside = _grid_units(x, y, self.grid, self.region)
        wx, dwx, i = clamped_quadratic_1d(u, nx)
        wy, dwy, j = clamped_quadratic_1d(v, ny)
        a = torch.arange(3, device=x.device)
        rows = (j[None] + a[:, None]) * (nx + 2)  # [3, P]
        nodes = (rows[:, None, :] + i[None, None] + a[None, :, None]).reshape(9, -1)
        value = (wy[:, None] * wx[None, :]).reshape(9, -1)
        grad_x = (wy[:, None] * dwx[None, :]).reshape(9, -1) / self.grid.h
        grad_y = (dwy[:, None] * wx[None, :]).reshape(9, -1) / self.grid.h
        return Weights(nodes, value, grad_x, grad_y, inside)

    def dof_coordinates(self) -> tuple[torch.Tensor, torch.Tensor]:
        """x and y of every DOF [n_nodes] at its Greville point (float64), ids row by row."""
        nx, ny = self.region.cells
        h, (x0, y0) = self.grid.h, self.grid.origin
        gx = x0 + h * (self.region.lower[0] + greville_points(nx))
        gy = y0 + h * (self.region.lower[1] + greville_points(ny))
        return gx.repeat(ny + 2), gy.repeat_interleave(nx + 2)


Basis = LinearBasis | ClampedBSplineBasis
BASES: dict[str, type] = {"linear": LinearBasis, "bspline": ClampedBSplineBasis}
