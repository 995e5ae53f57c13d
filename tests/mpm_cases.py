"""Build CB-Geo case directories for analytic MPM checks from a polygon and a constant friction."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np

from rgns.config import load_config
from rgns.engines.cbgeo.case import read_case
from rgns.engines.cbgeo.writer import write_case
from rgns.scene.case import Case
from rgns.scene.fields import FieldGrid, FrictionField
from rgns.scene.geometry import Scene, seed_particles

DEFAULT_MPM = load_config()["mpm"]
ELASTIC = {"cohesion_pa": 1e9, "tension_cutoff_pa": 1e9}  # strength so high the soil never yields


def polygon_case(
    directory: Path,
    vertices,
    length_m: float,
    height_m: float,
    cell_size_m: float = 0.5,
    particles_per_cell: int = 2,
    friction_deg: float = 30.0,
    index: int = 0,
    **mpm,
) -> Case:
    """Write and read back the case of one polygon of uniform soil; ``mpm`` overrides mpm settings."""
    vertices = np.asarray(vertices, dtype=float)
    settings = copy.deepcopy(DEFAULT_MPM)
    settings.update(mpm)
    positions, volumes = seed_particles(vertices, cell_size_m, particles_per_cell)
    scene = Scene(
        "test", index, "polygon", vertices, positions, volumes, length_m, height_m, cell_size_m, particles_per_cell, 1
    )
    grid = FieldGrid.covering(length_m, height_m, cell_size_m)
    field = FrictionField(
        grid,
        np.full(grid.shape, friction_deg),
        np.full(len(positions), friction_deg),
        friction_deg,
        0.0,
        1.0,
        1.0,
        "constant",
        0.0,
    )
    write_case(directory, scene, field.friction_deg, settings)
    return read_case(directory)


SWEEP_ANGLES_DEG = (30.0, 60.0, 90.0)
SWEEP_FRICTIONS_DEG = (15.0, 30.0, 45.0)


def stiffness_sweep_cases(directory: Path, youngs_modulus_pa: float) -> list[Case]:
    """The stability sweep at one stiffness: a slope 4 m high at each of SWEEP_ANGLES_DEG and each friction of
    SWEEP_FRICTIONS_DEG, 1 m cells, one batch."""
    height, cases = 4.0, []
    for angle in SWEEP_ANGLES_DEG:
        toe = 4.0 + height / np.tan(np.radians(angle))
        for phi in SWEEP_FRICTIONS_DEG:
            vertices = [[0, 0], [toe, 0], [4.0, height], [0, height]]
            cases.append(
                polygon_case(
                    directory / f"{angle}_{phi}",
                    vertices,
                    24.0,
                    6.0,
                    cell_size_m=1.0,
                    friction_deg=phi,
                    index=len(cases),
                    youngs_modulus_pa=youngs_modulus_pa,
                )
            )
    return cases


def cfl_sweep_case(directory: Path, cell_size_m: float) -> tuple[Case, float]:
    """The time-step sweep's slope: 60 degrees, four cells (at least 4 m) high, friction 25 degrees; and its toe."""
    height = max(4.0, 4 * cell_size_m)
    toe = 4.0 + height / np.tan(np.radians(60.0))
    vertices = [[0, 0], [toe, 0], [4.0, height], [0, height]]
    return polygon_case(directory, vertices, 32.0, height + 2.0, cell_size_m=cell_size_m, friction_deg=25.0), toe
