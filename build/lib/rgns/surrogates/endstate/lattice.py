"""The material points' regular sub-grid as an image, so that a convolutional network can read a
slope and write one displacement per point.

Points are seeded at ((k + ½)/n) of each MPM cell (rgns.scene.geometry.seed_particles), so at the start
of a run every point owns one pixel of a lattice of spacing cell/n anchored at the left wall and
the floor: an image of ``rows`` × ``columns`` pixels. A domain shorter or lower than the model's
fits in its image (the pixels beyond stay empty), so the image of a slope does not depend on the
domain around it. Channels in: occupancy, normalised friction angle (0 off the soil), then the
position features, either

* ``body`` (geometry-general models): height above the floor / 20 m, and depth below the ground
  surface of the point's column / 10 m (0 off the soil) — nothing tied to the domain's extent;
* ``domain`` (the first models, trained on the test cases): x / image length, y / image height.

Channels out: the displacement (x, y) of the point in each pixel, divided by a scale.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

INPUT_CHANNELS = 4
FEATURES = ("body", "domain")
HEIGHT_SCALE_M = 20.0
DEPTH_SCALE_M = 10.0


class LatticeError(ValueError):
    """Points that do not sit one per pixel on the lattice (a scene from another mesh or domain)."""


@dataclass(frozen=True)
class Lattice:
    """A domain's point lattice: spacing and image size."""

    spacing_m: float
    columns: int
    rows: int
    features: str = "domain"  # the position channels: "body" or "domain" (files saved before features lack it)

    @classmethod
    def for_domain(
        cls, length_m: float, height_m: float, cell_size_m: float, particles_per_cell: int, features: str = "body"
    ) -> Lattice:
        if features not in FEATURES:
            raise LatticeError(f"endstate.features = {features!r}: expected one of {FEATURES}")
        spacing = cell_size_m / particles_per_cell
        return cls(spacing, int(round(length_m / spacing)), int(round(height_m / spacing)), features)

    @property
    def length_m(self) -> float:
        return self.columns * self.spacing_m

    @property
    def height_m(self) -> float:
        return self.rows * self.spacing_m

    def pixels(self, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(row, column) of each initial point [N, 2], checked to be one point per pixel inside the image."""
        scaled = np.asarray(positions, dtype=float) / self.spacing_m - 0.5
        index = np.rint(scaled).astype(int)
        if np.abs(scaled - index).max(initial=0.0) > 1e-3:
            raise LatticeError(
                f"points are not on the {self.spacing_m} m lattice (another mesh.cell_size_m or "
                "mesh.particles_per_cell than the model's?)"
            )
        column, row = index[:, 0], index[:, 1]
        if (
            column.min(initial=0) < 0
            or row.min(initial=0) < 0
            or column.max(initial=0) >= self.columns
            or row.max(initial=0) >= self.rows
        ):
            raise LatticeError(
                f"points outside the model's {self.columns * self.spacing_m} x {self.rows * self.spacing_m} m domain"
            )
        if len(np.unique(row * self.columns + column)) != len(row):
            raise LatticeError("two points share a lattice pixel")
        return row, column

    def inputs(
        self, positions: np.ndarray, friction_deg: np.ndarray, friction_center: float, friction_scale: float
    ) -> np.ndarray:
        """The input image [INPUT_CHANNELS, rows, columns] of one slope at rest."""
        row, column = self.pixels(positions)
        image = np.zeros((INPUT_CHANNELS, self.rows, self.columns), np.float32)
        image[0, row, column] = 1.0
        image[1, row, column] = (np.asarray(friction_deg) - friction_center) / friction_scale
        if self.features == "domain":
            image[2] = (np.arange(self.columns) + 0.5)[None, :] / self.columns
            image[3] = (np.arange(self.rows) + 0.5)[:, None] / self.rows
            return image
        image[2] = ((np.arange(self.rows) + 0.5) * self.spacing_m / HEIGHT_SCALE_M)[:, None]
        top = np.full(self.columns, -1)
        np.maximum.at(top, column, row)
        image[3, row, column] = (top[column] - row + 0.5) * self.spacing_m / DEPTH_SCALE_M
        return image

    def targets(self, initial: np.ndarray, final: np.ndarray, scale_m: float) -> np.ndarray:
        """The output image [2, rows, columns]: each point's displacement / ``scale_m`` in its pixel."""
        row, column = self.pixels(initial)
        image = np.zeros((2, self.rows, self.columns), np.float32)
        image[:, row, column] = ((np.asarray(final, dtype=float) - initial) / scale_m).T
        return image

    def gather(self, image: np.ndarray, initial: np.ndarray) -> np.ndarray:
        """Each point's value [N, 2] from an output image [2, rows, columns]."""
        row, column = self.pixels(initial)
        return image[:, row, column].T
