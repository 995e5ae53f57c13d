"""Gaussian random fields of friction angle with the SNX correlation.

ρ(Δx, Δy) = exp(−2(|Δx|/ℓx + |Δy|/ℓy)) is separable, so on a regular grid the covariance is
Cx ⊗ Cy and its Cholesky factor is exactly Lx ⊗ Ly. A realization is μ + σ·Lx Z Lyᵀ with Z an
nx × ny standard-normal matrix (:class:`KroneckerSampler`, the default), which equals the paper's
μ + σ·L z with L = chol(C) of the full nx·ny covariance (:class:`CholeskySampler`, the reference)
for the same Z flattened row-major. Arrays are indexed [x, y].
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from typing import Any

import numpy as np

from rgns.scene.seeds import realization_rng

METHODS = ("kronecker", "cholesky")


# the keys of a set's group that a realization's field depends on
FIELD_KEYS = ("friction_mean_deg", "friction_std_deg", "correlation_length_x_m", "correlation_length_y_m")


def snx_correlation_1d(coords: np.ndarray, correlation_length_m: float) -> np.ndarray:
    """The 1-D factor exp(−2|Δ|/ℓ) of the SNX correlation between all pairs of ``coords``."""
    return np.exp(-2.0 * np.abs(coords[:, None] - coords[None, :]) / correlation_length_m)


def exponential_cholesky_1d(n: int, spacing_m: float, correlation_length_m: float) -> np.ndarray:
    """Closed-form Cholesky factor of the 1-D SNX correlation on ``n`` equally spaced points.

    With r = exp(−2Δ/ℓ): L[i, 0] = rⁱ and L[i, j] = r^(i−j)·√(1 − r²) for 0 < j ≤ i (an AR(1)
    process), so no factorisation is needed and the result is exact to rounding.
    """
    r = np.exp(-2.0 * spacing_m / correlation_length_m)
    lag = np.arange(n)[:, None] - np.arange(n)[None, :]
    factor = np.where(lag >= 0, r ** np.maximum(lag, 0), 0.0)
    factor[:, 1:] *= np.sqrt(1.0 - r * r)
    return factor


@dataclass(frozen=True)
class FieldGrid:
    """Cell-centred grid of the field over the domain: x_m [nx], y_m [ny]."""

    x_m: np.ndarray
    y_m: np.ndarray
    spacing_m: float

    @classmethod
    def covering(cls, length_m: float, height_m: float, spacing_m: float) -> FieldGrid:
        nx = int(np.ceil(length_m / spacing_m - 1e-9))
        ny = int(np.ceil(height_m / spacing_m - 1e-9))
        return cls((np.arange(nx) + 0.5) * spacing_m, (np.arange(ny) + 0.5) * spacing_m, spacing_m)

    @property
    def shape(self) -> tuple[int, int]:
        return len(self.x_m), len(self.y_m)

    def cell_of(self, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Indices (ix, iy) of the grid cell containing each position [N, 2]."""
        ix = np.clip(np.floor(positions[:, 0] / self.spacing_m).astype(int), 0, len(self.x_m) - 1)
        iy = np.clip(np.floor(positions[:, 1] / self.spacing_m).astype(int), 0, len(self.y_m) - 1)
        return ix, iy


class KroneckerSampler:
    """Unit-variance SNX fields as Lx Z Lyᵀ with the closed-form 1-D factors."""

    def __init__(self, grid: FieldGrid, correlation_length_x_m: float, correlation_length_y_m: float):
        nx, ny = grid.shape
        self.lx = exponential_cholesky_1d(nx, grid.spacing_m, correlation_length_x_m)
        self.ly = exponential_cholesky_1d(ny, grid.spacing_m, correlation_length_y_m)

    def correlate(self, normals: np.ndarray) -> np.ndarray:
        """Map standard normals [..., nx, ny] to correlated unit-variance fields, same shape."""
        nx, ny = normals.shape[-2:]
        batch = normals.reshape(-1, nx, ny)
        # Two large GEMMs over the whole batch instead of 2·B small ones.
        left = (self.lx @ batch.transpose(1, 0, 2).reshape(nx, -1)).reshape(nx, -1, ny)
        both = left.transpose(1, 0, 2).reshape(-1, ny) @ self.ly.T
        return both.reshape(normals.shape)


class CholeskySampler:
    """Unit-variance SNX fields as L z with L the dense Cholesky factor of the full covariance.

    The paper's method (CMD), kept as the reference: O((nx·ny)³) to factor, O((nx·ny)²) a field.
    """

    def __init__(self, grid: FieldGrid, correlation_length_x_m: float, correlation_length_y_m: float):
        x, y = np.meshgrid(grid.x_m, grid.y_m, indexing="ij")  # row-major flatten = index i·ny + j
        x, y = x.ravel(), y.ravel()
        covariance = np.exp(
            -2.0
            * (
                np.abs(x[:, None] - x[None, :]) / correlation_length_x_m
                + np.abs(y[:, None] - y[None, :]) / correlation_length_y_m
            )
        )
        self.factor = np.linalg.cholesky(covariance)

    def correlate(self, normals: np.ndarray) -> np.ndarray:
        """Map standard normals [..., nx, ny] to correlated unit-variance fields, same shape."""
        nx, ny = normals.shape[-2:]
        flat = normals.reshape(-1, nx * ny)
        return (flat @ self.factor.T).reshape(normals.shape)


def make_sampler(method: str, grid: FieldGrid, correlation_length_x_m: float, correlation_length_y_m: float):
    """The sampler for ``method`` in :data:`METHODS`."""
    samplers = {"kronecker": KroneckerSampler, "cholesky": CholeskySampler}
    if method not in samplers:
        raise ValueError(f"random_field.method = {method!r}: expected one of {METHODS}")
    return samplers[method](grid, correlation_length_x_m, correlation_length_y_m)


def draw_mean_and_normals(
    seed: int, set_name: str, index: int, friction_mean_deg: float | list[float], shape: tuple[int, int]
) -> tuple[float, np.ndarray]:
    """The field mean (drawn uniformly when a range is given) and the normals of one realization."""
    rng = realization_rng(seed, set_name, index, "field")
    mean = friction_mean_deg
    mean_deg = float(rng.uniform(mean[0], mean[1])) if isinstance(mean, list) else float(mean)
    return mean_deg, rng.standard_normal(shape)


@dataclass
class FrictionField:
    """One realization's friction-angle field on the grid and on the material points."""

    grid: FieldGrid
    friction_grid_deg: np.ndarray  # [nx, ny], clipped to the bounds
    friction_deg: np.ndarray  # [N] per material point
    mean_deg: float
    std_deg: float
    correlation_length_x_m: float
    correlation_length_y_m: float
    method: str
    clipped_fraction: float


def realize_fields(
    seed: int,
    set_name: str,
    indices: list[int],
    group: dict[str, Any],
    grid: FieldGrid,
    method: str,
    bounds_deg: tuple[float, float],
    sampler: KroneckerSampler | CholeskySampler | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unclipped and clipped friction grids [B, nx, ny] and means [B] of realizations ``indices``.

    Every realization draws from its own stream, so the result for index i does not depend on
    which other indices are in the batch. Pass ``sampler`` to reuse a factorisation across calls.
    """
    draws = [draw_mean_and_normals(seed, set_name, i, group["friction_mean_deg"], grid.shape) for i in indices]
    means = np.array([mean for mean, _ in draws])
    normals = np.stack([z for _, z in draws])
    if sampler is None:
        sampler = make_sampler(method, grid, group["correlation_length_x_m"], group["correlation_length_y_m"])
    raw = means[:, None, None] + group["friction_std_deg"] * sampler.correlate(normals)
    return raw, np.clip(raw, bounds_deg[0], bounds_deg[1]), means


def friction_field(
    seed: int,
    set_name: str,
    index: int,
    group: dict[str, Any],
    grid: FieldGrid,
    method: str,
    bounds_deg: tuple[float, float],
    positions: np.ndarray,
) -> FrictionField:
    """Realization ``index``'s field, clipped to the physical bounds and mapped onto particles."""
    raw, clipped, means = realize_fields(seed, set_name, [index], group, grid, method, bounds_deg)
    ix, iy = grid.cell_of(positions)
    return FrictionField(
        grid=grid,
        friction_grid_deg=clipped[0],
        friction_deg=clipped[0][ix, iy],
        mean_deg=float(means[0]),
        std_deg=float(group["friction_std_deg"]),
        correlation_length_x_m=float(group["correlation_length_x_m"]),
        correlation_length_y_m=float(group["correlation_length_y_m"]),
        method=method,
        clipped_fraction=float(np.mean(raw[0] != clipped[0])),
    )


def write_field(path: str, field: FrictionField) -> None:
    """Write a field as ``.npz``: the grid, the clipped grid field, the per-particle values."""
    np.savez_compressed(
        path,
        x_m=field.grid.x_m,
        y_m=field.grid.y_m,
        spacing_m=field.grid.spacing_m,
        friction_grid_deg=field.friction_grid_deg,
        friction_deg=field.friction_deg,
        mean_deg=field.mean_deg,
        std_deg=field.std_deg,
        correlation_length_x_m=field.correlation_length_x_m,
        correlation_length_y_m=field.correlation_length_y_m,
        method=field.method,
        clipped_fraction=field.clipped_fraction,
    )


def read_field(path: str) -> FrictionField:
    """Read a field written by :func:`write_field`, naming the file on any defect."""
    try:
        with np.load(path) as data:
            grid = FieldGrid(data["x_m"], data["y_m"], float(data["spacing_m"]))
            field = FrictionField(
                grid=grid,
                friction_grid_deg=data["friction_grid_deg"],
                friction_deg=data["friction_deg"],
                mean_deg=float(data["mean_deg"]),
                std_deg=float(data["std_deg"]),
                correlation_length_x_m=float(data["correlation_length_x_m"]),
                correlation_length_y_m=float(data["correlation_length_y_m"]),
                method=str(data["method"]),
                clipped_fraction=float(data["clipped_fraction"]),
            )
    except (OSError, ValueError, KeyError, zipfile.BadZipFile) as error:
        raise ValueError(f"{path}: not a readable field file ({error})") from error
    if field.friction_grid_deg.shape != grid.shape:
        raise ValueError(f"{path}: friction grid {field.friction_grid_deg.shape} does not match the grid {grid.shape}")
    return field
