"""Read CB-Geo's per-step ``particles<step>.h5`` tables into frames.

Each file holds one compound dataset ``table`` (one row per particle); file N is the state after
step N, i.e. at t = (N + 1)·dt. Rows are sorted by ``id`` so particle order is the input order.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

STEP_FILE = re.compile(r"^particles(\d+)\.h5$")


class OutputError(ValueError):
    """CB-Geo output is missing, truncated or inconsistent; the message names the file."""


@dataclass
class CBGeoFrames:
    """Positions per stored step and the per-particle state CB-Geo reports."""

    steps: np.ndarray  # [T]
    positions: np.ndarray  # [T, N, 2]
    material_id: np.ndarray  # [N], from the last file
    friction_rad: np.ndarray  # [N], svars_0 of the last file (Mohr-Coulomb φ)
    mass_kg: np.ndarray  # [N]
    volume_m2: np.ndarray  # [N], first file


def step_files(results_dir: str | Path) -> list[tuple[int, Path]]:
    """(step, path) of every particles<step>.h5 in a results directory, by step."""
    found = []
    for path in Path(results_dir).glob("particles*.h5"):
        match = STEP_FILE.match(path.name)
        if match:
            found.append((int(match.group(1)), path))
    return sorted(found)


def read_table(path: Path) -> np.ndarray:
    """One step file's table, sorted by particle id."""
    try:
        with h5py.File(path, "r") as handle:
            table = handle["table"][()]
    except (OSError, KeyError) as error:
        raise OutputError(f"{path}: not a readable CB-Geo particle table ({error})") from error
    return np.sort(table, order="id")


def read_frames(results_dir: str | Path, expected_particles: int) -> CBGeoFrames:
    """All frames of a run; every file must hold the same ``expected_particles`` finite rows."""
    files = step_files(results_dir)
    if not files:
        raise OutputError(f"{results_dir}: no particles<step>.h5 files")
    positions, first, table = [], None, None
    for step, path in files:
        table = read_table(path)
        if len(table) != expected_particles:
            raise OutputError(f"{path}: {len(table)} particles, expected {expected_particles}")
        xy = np.column_stack([table["coord_x"], table["coord_y"]])
        if not np.isfinite(xy).all():
            raise OutputError(f"{path}: non-finite particle coordinates at step {step} (the run diverged)")
        positions.append(xy)
        first = table if first is None else first
    return CBGeoFrames(
        steps=np.array([step for step, _ in files]),
        positions=np.stack(positions),
        material_id=table["material_id"].astype(int),
        friction_rad=table["svars_0"].astype(float),
        mass_kg=first["mass"].astype(float),
        volume_m2=first["volume"].astype(float),
    )
