"""Read a CB-Geo case directory back into arrays: what both engines and the tests see.

Only the subset rgns writes is understood (ED2Q4 mesh, one file generator, binned Mohr-Coulomb
materials, node-set constraints); anything else is reported as unsupported, naming the file.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rgns.cbgeo import writer as names
from rgns.trajectories import SOIL, Trajectory


class CaseError(ValueError):
    """A case directory is missing a file, or a file is malformed; the message names it."""


@dataclass
class Case:
    """Everything an MPM engine needs from one case directory."""

    directory: Path
    meta: dict[str, Any]  # rgns-case.json: set, index, domain, frame interval
    config: dict[str, Any]  # mpm.json
    nodes: np.ndarray  # [Nn, 2]
    cells: np.ndarray  # [Nc, 4]
    positions: np.ndarray  # [N, 2]
    volumes: np.ndarray  # [N]
    stresses: np.ndarray | None  # [N, 6], CB-Geo order, tension positive
    material_id: np.ndarray  # [N] after material_sets
    friction_deg: np.ndarray  # [N] exact (rgns's own file)
    node_sets: dict[int, np.ndarray]
    particle_sets: dict[int, np.ndarray]

    @property
    def materials(self) -> dict[int, dict[str, Any]]:
        return {int(m["id"]): m for m in self.config["materials"]}

    @property
    def binned_friction_deg(self) -> np.ndarray:
        """Friction angle per particle as CB-Geo sees it (its material's)."""
        materials = self.materials
        return np.array([materials[int(k)]["friction"] for k in self.material_id])

    @property
    def density_kg_m3(self) -> np.ndarray:
        materials = self.materials
        return np.array([materials[int(k)]["density"] for k in self.material_id])


def _data_lines(path: Path) -> list[str]:
    """Lines of an ASCII input, skipping those CB-Geo skips (containing '#' or '!') and blanks."""
    try:
        text = path.read_text()
    except OSError as error:
        raise CaseError(f"{path}: cannot be read ({error})") from error
    return [line for line in text.splitlines() if line.strip() and "#" not in line and "!" not in line]


def _table(path: Path, lines: list[str], columns: int, dtype: type) -> np.ndarray:
    try:
        table = np.array([line.split() for line in lines], dtype=dtype)
    except ValueError as error:
        raise CaseError(f"{path}: not a table of numbers ({error})") from error
    if table.size == 0:
        return np.zeros((0, columns), dtype=dtype)
    if table.ndim != 2 or table.shape[1] != columns:
        raise CaseError(f"{path}: expected {columns} columns per line, got shape {table.shape}")
    return table


def _counted(path: Path, columns: int, dtype: type = float) -> np.ndarray:
    """A file with a count line, then ``count`` rows."""
    lines = _data_lines(path)
    if not lines:
        raise CaseError(f"{path}: empty")
    count = int(lines[0].split()[0])
    rows = _table(path, lines[1:], columns, dtype)
    if len(rows) != count:
        raise CaseError(f"{path}: header says {count} rows, found {len(rows)}")
    return rows


def read_mesh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Nodes [Nn, 2] and ED2Q4 cells [Nc, 4] of a CB-Geo ASCII mesh."""
    lines = _data_lines(path)
    if not lines:
        raise CaseError(f"{path}: empty")
    n_nodes, n_cells = (int(v) for v in lines[0].split()[:2])
    if len(lines) != 1 + n_nodes + n_cells:
        raise CaseError(f"{path}: header says {n_nodes} nodes and {n_cells} cells, found {len(lines) - 1} lines")
    nodes = _table(path, lines[1:1 + n_nodes], 2, float)
    cells = _table(path, lines[1 + n_nodes:], 4, int)
    if cells.size and (cells.min() < 0 or cells.max() >= n_nodes):
        raise CaseError(f"{path}: cell node ids outside 0..{n_nodes - 1}")
    return nodes, cells


def read_case(directory: str | Path) -> Case:
    """Parse a case directory written by :func:`rgns.cbgeo.writer.write_case`."""
    directory = Path(directory)
    input_path = directory / names.INPUT_JSON
    try:
        config = json.loads(input_path.read_text())
        meta = json.loads((directory / names.META_FILE).read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise CaseError(f"{directory}: not a readable case directory ({error})") from error
    mesh = config["mesh"]
    if mesh.get("cell_type") != "ED2Q4" or len(config["particles"]) != 1:
        raise CaseError(f"{input_path}: only ED2Q4 meshes with one particle generator are supported")
    generator = config["particles"][0]["generator"]
    nodes, cells = read_mesh(directory / mesh["mesh"])
    positions = _counted(directory / generator["location"], 2)
    volume_rows = _table(directory / mesh["particles_volumes"], _data_lines(directory / mesh["particles_volumes"]), 2, float)
    volumes = np.zeros(len(positions))
    ids = volume_rows[:, 0].astype(int)
    if len(ids) and (ids.min() < 0 or ids.max() >= len(positions)):
        raise CaseError(f"{directory / mesh['particles_volumes']}: particle ids outside 0..{len(positions) - 1}")
    volumes[ids] = volume_rows[:, 1]
    stresses = _counted(directory / mesh["particles_stresses"], 6) if "particles_stresses" in mesh else None
    if stresses is not None and len(stresses) != len(positions):
        raise CaseError(f"{directory / mesh['particles_stresses']}: {len(stresses)} rows for {len(positions)} particles")

    sets = json.loads((directory / mesh["entity_sets"]).read_text())
    node_sets = {int(s["id"]): np.asarray(s["set"], dtype=int) for s in sets.get("node_sets", [])}
    particle_sets = {int(s["id"]): np.asarray(s["set"], dtype=int) for s in sets.get("particle_sets", [])}
    material_id = np.full(len(positions), int(generator["material_id"]))
    for material_set in config.get("material_sets", []):
        material_id[particle_sets[int(material_set["pset_id"])]] = int(material_set["material_id"])
    friction_deg = np.loadtxt(directory / names.FRICTION_FILE, ndmin=1)
    if len(friction_deg) != len(positions):
        raise CaseError(f"{directory / names.FRICTION_FILE}: {len(friction_deg)} values for {len(positions)} particles")
    return Case(directory, meta, config, nodes, cells, positions, volumes, stresses, material_id, friction_deg,
                node_sets, particle_sets)


def to_trajectory(case: Case, positions: np.ndarray, time_s: np.ndarray, engine: str, provenance: dict[str, Any],
                  status: str = "ok", energies: np.ndarray | None = None) -> Trajectory:
    """A trajectory of a case's particles (exact friction, volumes, masses from the case)."""
    meta = case.meta
    return Trajectory(
        positions=positions,
        time_s=time_s,
        particle_type=np.full(len(case.positions), SOIL),
        friction_deg=case.friction_deg,
        volume_m2=case.volumes,
        mass_kg=case.volumes * case.density_kg_m3,
        frame_interval_s=meta["frame_interval_s"],
        bounds=np.array([[0.0, meta["domain_length_m"]], [0.0, meta["domain_height_m"]]]),
        engine=engine,
        set_name=meta["set_name"],
        index=meta["index"],
        provenance=provenance,
        status=status,
        energies=energies,
    )
