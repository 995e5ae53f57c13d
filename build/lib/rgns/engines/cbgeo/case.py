"""A CB-Geo case directory read into the realization every engine runs (:class:`rgns.scene.case.Case`).

A realization's case is built in memory (:func:`rgns.scene.build.case_from_scene`); its case
directory is one serialization of it (:func:`rgns.engines.cbgeo.writer.save_case`), which
:func:`read_case` reads back to the same numbers. :func:`read_case` also reads plain CB-Geo case
directories in the subset the embedded engine supports: an ED2Q4 mesh, one file generator,
particle volumes, optional stresses, entity sets, ``MohrCoulomb2D`` materials and
``material_sets``, node-set velocity and friction constraints. rgns's two own files are optional:
without ``particles-friction-deg.txt`` each particle has its material's friction angle, without
``rgns-case.json`` the case is named after its directory (index 0) and bounded by its mesh.
Duration and frame interval always come from ``mpm.json``. A missing, malformed or unsupported
file is a :class:`CaseError` naming the file (and the key).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from rgns.scene.case import Case, CaseError, per_particle
from rgns.trajectories import SOIL, Trajectory

INPUT_JSON = "mpm.json"
FRICTION_FILE = "particles-friction-deg.txt"
META_FILE = "rgns-case.json"
MATERIAL_TYPE = "MohrCoulomb2D"
MATERIAL_KEYS = ("density", "youngs_modulus", "poisson_ratio", "friction", "dilation", "cohesion", "tension_cutoff")
CONSTRAINT_KEYS = {
    "velocity_constraints": ("nset_id", "dir", "velocity"),
    "friction_constraints": ("nset_id", "dir", "sign_n", "friction"),
}


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


def _count(path: Path, header: str, fields: int) -> list[int]:
    """The first ``fields`` integers of a header line."""
    try:
        return [int(value) for value in header.split()[:fields]]
    except ValueError as error:
        raise CaseError(f"{path}: the first line is not a count ({error})") from error


def _counted(path: Path, columns: int, dtype: type = float) -> np.ndarray:
    """A file with a count line, then ``count`` rows."""
    lines = _data_lines(path)
    if not lines:
        raise CaseError(f"{path}: empty")
    (count,) = _count(path, lines[0], 1)
    rows = _table(path, lines[1:], columns, dtype)
    if len(rows) != count:
        raise CaseError(f"{path}: header says {count} rows, found {len(rows)}")
    return rows


def read_mesh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Nodes [Nn, 2] and ED2Q4 cells [Nc, 4] of a CB-Geo ASCII mesh."""
    lines = _data_lines(path)
    if not lines:
        raise CaseError(f"{path}: empty")
    counts = _count(path, lines[0], 2)
    if len(counts) != 2:
        raise CaseError(f"{path}: the first line must hold the node and cell counts")
    n_nodes, n_cells = counts
    if len(lines) != 1 + n_nodes + n_cells:
        raise CaseError(f"{path}: header says {n_nodes} nodes and {n_cells} cells, found {len(lines) - 1} lines")
    nodes = _table(path, lines[1 : 1 + n_nodes], 2, float)
    cells = _table(path, lines[1 + n_nodes :], 4, int)
    if cells.size and (cells.min() < 0 or cells.max() >= n_nodes):
        raise CaseError(f"{path}: cell node ids outside 0..{n_nodes - 1}")
    return nodes, cells


def _read_json(path: Path) -> dict[str, Any]:
    if not path.is_file():
        raise CaseError(f"{path}: missing")
    try:
        document = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise CaseError(f"{path}: not readable JSON ({error})") from error
    if not isinstance(document, dict):
        raise CaseError(f"{path}: not a JSON object")
    return document


def _get(document: dict[str, Any], path: Path, *keys: str) -> Any:
    """``document[keys[0]][keys[1]]…``, or a CaseError naming the file and the dotted key."""
    value: Any = document
    for depth, key in enumerate(keys):
        if not isinstance(value, dict) or key not in value:
            raise CaseError(f"{path}: missing key '{'.'.join(keys[: depth + 1])}'")
        value = value[key]
    return value


def _input_file(directory: Path, name: Any, key: str, input_path: Path) -> Path:
    """The file an ``mpm.json`` key names; a CaseError naming both when it is absent."""
    path = directory / str(name)
    if not path.is_file():
        raise CaseError(f"{path}: missing (named by {input_path} key '{key}')")
    return path


def _generator(config: dict[str, Any], input_path: Path) -> dict[str, Any]:
    """The one file generator of the particles, checked."""
    particles = _get(config, input_path, "particles")
    if not isinstance(particles, list) or len(particles) != 1 or not isinstance(particles[0], dict):
        raise CaseError(f"{input_path}: key 'particles' must list exactly one generator")
    generator = _get(particles[0], input_path, "generator")
    if not isinstance(generator, dict) or generator.get("type") != "file":
        raise CaseError(f"{input_path}: key 'particles[0].generator.type' must be 'file'")
    for key in ("location", "material_id"):
        if key not in generator:
            raise CaseError(f"{input_path}: missing key 'particles[0].generator.{key}'")
    return generator


def _volumes(path: Path, n_particles: int) -> np.ndarray:
    """``pid volume`` lines (no count line): one positive volume per particle."""
    rows = _table(path, _data_lines(path), 2, float)
    ids = rows[:, 0].astype(int)
    if len(ids) and (ids.min() < 0 or ids.max() >= n_particles):
        raise CaseError(f"{path}: particle ids outside 0..{n_particles - 1}")
    if not np.array_equal(np.bincount(ids, minlength=n_particles), np.ones(n_particles, dtype=int)):
        raise CaseError(f"{path}: needs exactly one volume per particle ({n_particles} particles, {len(ids)} lines)")
    volumes = np.zeros(n_particles)
    volumes[ids] = rows[:, 1]
    if not (volumes > 0).all():
        raise CaseError(f"{path}: volumes must be positive")
    return volumes


def _stresses(path: Path, n_particles: int) -> np.ndarray:
    """A count line, then ``σxx σyy σzz τxy τyz τxz`` per particle."""
    stresses = _counted(path, 6)
    if len(stresses) != n_particles:
        raise CaseError(f"{path}: {len(stresses)} rows for {n_particles} particles")
    return stresses


def _entity_sets(
    path: Path | None, n_nodes: int, n_particles: int
) -> tuple[dict[int, np.ndarray], dict[int, np.ndarray]]:
    """Node and particle sets of ``entity_sets.json`` (none when ``mpm.json`` names no file)."""
    if path is None:
        return {}, {}
    document = _read_json(path)
    found = []
    for kind, size in (("node_sets", n_nodes), ("particle_sets", n_particles)):
        sets = {}
        for entry in document.get(kind, []):
            try:
                members = np.asarray(entry["set"], dtype=int)
                sets[int(entry["id"])] = members
            except (KeyError, TypeError, ValueError) as error:
                raise CaseError(
                    f"{path}: every entry of '{kind}' needs an integer 'id' and a list 'set' ({error!r})"
                ) from error
            if members.ndim != 1 or (len(members) and (members.min() < 0 or members.max() >= size)):
                raise CaseError(f"{path}: {kind} id {int(entry['id'])} holds ids outside 0..{size - 1}")
        found.append(sets)
    return found[0], found[1]


def _material_ids(
    config: dict[str, Any],
    generator: dict[str, Any],
    particle_sets: dict[int, np.ndarray],
    n_particles: int,
    input_path: Path,
    sets_path: Path | None,
) -> np.ndarray:
    """Each particle's material: the generator's, then ``material_sets`` in order; every id checked."""
    referenced = {"particles[0].generator.material_id": generator["material_id"]}
    material_id = np.full(n_particles, int(generator["material_id"]))
    for i, material_set in enumerate(config.get("material_sets", [])):
        if not isinstance(material_set, dict) or "pset_id" not in material_set or "material_id" not in material_set:
            raise CaseError(f"{input_path}: key 'material_sets[{i}]' needs 'material_id' and 'pset_id'")
        pset = int(material_set["pset_id"])
        if pset not in particle_sets:
            raise CaseError(
                f"{input_path}: key 'material_sets[{i}].pset_id' = {pset}: no particle set with that id "
                f"in {sets_path or 'the entity sets (mpm.json names no mesh.entity_sets file)'}"
            )
        material_id[particle_sets[pset]] = int(material_set["material_id"])
        referenced[f"material_sets[{i}].material_id"] = material_set["material_id"]
    _check_materials(config, referenced, input_path)
    return material_id


def _check_materials(config: dict[str, Any], referenced: dict[str, Any], input_path: Path) -> None:
    """Every material referenced exists, is ``MohrCoulomb2D`` and has every key the engine reads."""
    materials = _get(config, input_path, "materials")
    if not isinstance(materials, list) or not all(isinstance(m, dict) and "id" in m for m in materials):
        raise CaseError(f"{input_path}: key 'materials' must be a list of objects with an 'id'")
    by_id = {int(m["id"]): m for m in materials}
    for key, used in referenced.items():
        if int(used) not in by_id:
            raise CaseError(
                f"{input_path}: key '{key}' = {used}: no material with that id in 'materials' (ids {sorted(by_id)})"
            )
        material = by_id[int(used)]
        if material.get("type") != MATERIAL_TYPE:
            raise CaseError(
                f"{input_path}: material {used} has type {material.get('type')!r}; "
                f"the embedded engine supports {MATERIAL_TYPE} only"
            )
        missing = [name for name in MATERIAL_KEYS if name not in material]
        if missing:
            raise CaseError(f"{input_path}: material {used} lacks key(s) {missing}")


def _check_analysis(config: dict[str, Any], input_path: Path) -> None:
    """``analysis.dt``, ``analysis.nsteps``, ``post_processing.output_steps`` and gravity are there."""
    for keys, kind in (
        (("analysis", "dt"), float),
        (("analysis", "nsteps"), int),
        (("post_processing", "output_steps"), int),
    ):
        value = _get(config, input_path, *keys)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or value <= 0 or kind(value) != value:
            raise CaseError(f"{input_path}: key '{'.'.join(keys)}' = {value!r}: expected a positive {kind.__name__}")
    gravity = _get(config, input_path, "external_loading_conditions", "gravity")
    if not isinstance(gravity, list) or len(gravity) != 2:
        raise CaseError(f"{input_path}: key 'external_loading_conditions.gravity' = {gravity!r}: expected [gx, gy]")


def _check_constraints(
    config: dict[str, Any], node_sets: dict[int, np.ndarray], input_path: Path, sets_path: Path | None
) -> None:
    """Velocity and friction constraints are node-set ones, with every key, on sets that exist."""
    conditions = _get(config, input_path, "mesh", "boundary_conditions")
    if not isinstance(conditions, dict):
        raise CaseError(f"{input_path}: key 'mesh.boundary_conditions' must be an object")
    for kind, keys in CONSTRAINT_KEYS.items():
        for i, constraint in enumerate(conditions.get(kind, [])):
            where = f"mesh.boundary_conditions.{kind}[{i}]"
            missing = [key for key in keys if not isinstance(constraint, dict) or key not in constraint]
            if missing:
                raise CaseError(
                    f"{input_path}: key '{where}' lacks {missing} (only node-set constraints are supported)"
                )
            if int(constraint["nset_id"]) not in node_sets:
                raise CaseError(
                    f"{input_path}: key '{where}.nset_id' = {constraint['nset_id']}: no node set with "
                    f"that id in {sets_path or 'the entity sets (mpm.json names no mesh.entity_sets file)'}"
                )


def _friction(directory: Path, n_particles: int) -> np.ndarray | None:
    """rgns's exact friction angle per particle, or None when the directory has no such file."""
    path = directory / FRICTION_FILE
    if not path.exists():
        return None
    friction_deg = _table(path, _data_lines(path), 1, float)[:, 0]
    if len(friction_deg) != n_particles:
        raise CaseError(f"{path}: {len(friction_deg)} values for {n_particles} particles")
    return friction_deg


def read_case(directory: str | Path) -> Case:
    """Read a case directory: one :func:`rgns.engines.cbgeo.writer.save_case` wrote, or a plain CB-Geo one."""
    directory = Path(directory)
    input_path = directory / INPUT_JSON
    config = _read_json(input_path)
    meta = _read_json(directory / META_FILE) if (directory / META_FILE).exists() else {}
    mesh = _get(config, input_path, "mesh")
    if _get(config, input_path, "mesh", "cell_type") != "ED2Q4":
        raise CaseError(f"{input_path}: key 'mesh.cell_type' = {mesh['cell_type']!r}: only ED2Q4 meshes are supported")
    _check_analysis(config, input_path)
    generator = _generator(config, input_path)

    nodes, cells = read_mesh(_input_file(directory, _get(config, input_path, "mesh", "mesh"), "mesh.mesh", input_path))
    positions = _counted(
        _input_file(directory, generator["location"], "particles[0].generator.location", input_path), 2
    )
    volumes_path = _input_file(
        directory, _get(config, input_path, "mesh", "particles_volumes"), "mesh.particles_volumes", input_path
    )
    volumes = _volumes(volumes_path, len(positions))
    stresses = None
    if "particles_stresses" in mesh:
        stresses = _stresses(
            _input_file(directory, mesh["particles_stresses"], "mesh.particles_stresses", input_path), len(positions)
        )
    sets_path = (
        _input_file(directory, mesh["entity_sets"], "mesh.entity_sets", input_path) if "entity_sets" in mesh else None
    )
    node_sets, particle_sets = _entity_sets(sets_path, len(nodes), len(positions))
    _check_constraints(config, node_sets, input_path, sets_path)
    material_id = _material_ids(config, generator, particle_sets, len(positions), input_path, sets_path)
    friction_deg = _friction(directory, len(positions))
    if friction_deg is None:
        friction_deg = per_particle(config, material_id, "friction")
    return Case(
        directory,
        meta,
        config,
        nodes,
        cells,
        positions,
        volumes,
        stresses,
        material_id,
        friction_deg,
        node_sets,
        particle_sets,
    )


def to_trajectory(
    case: Case,
    positions: np.ndarray,
    time_s: np.ndarray,
    engine: str,
    provenance: dict[str, Any],
    status: str = "ok",
    energies: np.ndarray | None = None,
) -> Trajectory:
    """A trajectory of a case's particles (exact friction, volumes, masses from the case)."""
    return Trajectory(
        positions=positions,
        time_s=time_s,
        particle_type=np.full(len(case.positions), SOIL),
        friction_deg=case.friction_deg,
        volume_m2=case.volumes,
        mass_kg=case.volumes * case.density_kg_m3,
        frame_interval_s=case.frame_interval_s,
        bounds=case.bounds,
        engine=engine,
        set_name=case.set_name,
        index=case.index,
        provenance=provenance,
        status=status,
        energies=energies,
    )
