"""Slope geometries: perturbed base polygons, validity checks, particle seeding, scene files.

A family is a polygon whose vertex coordinates are fixed numbers or [min, max] ranges; each
realization draws every ranged coordinate uniformly (the paper's Fig. 4). A drawn polygon must be
simple, counter-clockwise with positive area, inside the domain with a cell of head room, and
leave ``runout_room_m`` free towards every side wall it does not rest against. Invalid draws are
redrawn from the realization's own stream, so the result is still deterministic.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.path import Path as MplPath

from rgns.scene.seeds import realization_rng
from rgns.scene.slope_generator import generate_vertices

WALL_TOLERANCE_M = 1e-9


# the keys of config section ``geometry`` (besides the families) that drawing a scene depends on
DRAW_KEYS = ("runout_room_m", "max_draws")


class GeometryError(ValueError):
    """A polygon or scene is invalid; the message names the family, realization or file."""


def signed_area(vertices: np.ndarray) -> float:
    """Shoelace area: positive for counter-clockwise vertices."""
    x, y = vertices[:, 0], vertices[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    return float((a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]))


def _on_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    return min(a[0], b[0]) <= p[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= p[1] <= max(a[1], b[1])


def segments_intersect(p1: np.ndarray, p2: np.ndarray, q1: np.ndarray, q2: np.ndarray) -> bool:
    """Whether closed segments p1-p2 and q1-q2 share a point (touching counts)."""
    d1, d2 = _cross(q1, q2, p1), _cross(q1, q2, p2)
    d3, d4 = _cross(p1, p2, q1), _cross(p1, p2, q2)
    if ((d1 > 0) != (d2 > 0)) and ((d3 > 0) != (d4 > 0)) and 0 not in (d1, d2, d3, d4):
        return True
    return any(
        d == 0 and _on_segment(p, a, b)
        for d, p, a, b in ((d1, p1, q1, q2), (d2, p2, q1, q2), (d3, q1, p1, p2), (d4, q2, p1, p2))
    )


def is_simple(vertices: np.ndarray) -> bool:
    """True when no two non-adjacent edges meet and no vertex repeats."""
    n = len(vertices)
    if len(np.unique(np.round(vertices, 12), axis=0)) < n:
        return False
    for i in range(n):
        for j in range(i + 1, n):
            if j == i + 1 or (i == 0 and j == n - 1):
                continue
            if segments_intersect(vertices[i], vertices[(i + 1) % n], vertices[j], vertices[(j + 1) % n]):
                return False
    return True


def polygon_problems(
    vertices: np.ndarray, length_m: float, height_m: float, room: float, headroom: float = 0.0
) -> list[str]:
    """What is wrong with a polygon in a [0, length] x [0, height] domain (empty when valid)."""
    problems: list[str] = []
    if not is_simple(vertices):
        problems.append("is not simple (edges cross or vertices repeat)")
    area = signed_area(vertices)
    if area <= 0.0:
        problems.append(f"has signed area {area:.6g} m2 <= 0 (vertices must run counter-clockwise)")
    x_min, y_min = vertices.min(axis=0)
    x_max, y_max = vertices.max(axis=0)
    if x_min < -WALL_TOLERANCE_M or x_max > length_m + WALL_TOLERANCE_M or y_min < -WALL_TOLERANCE_M:
        problems.append(f"leaves the domain [0, {length_m}] x [0, {height_m}]")
    if y_max > height_m - headroom + WALL_TOLERANCE_M:
        problems.append(f"reaches y = {y_max:.6g} m, above the domain height {height_m} m less {headroom} m head room")
    if x_min > WALL_TOLERANCE_M and x_min < room:
        problems.append(f"leaves {x_min:.6g} m to the left wall, less than the runout room {room} m")
    if x_max < length_m - WALL_TOLERANCE_M and length_m - x_max < room:
        problems.append(f"leaves {length_m - x_max:.6g} m to the right wall, less than the runout room {room} m")
    return problems


def sample_vertices(family: dict[str, Any], rng: np.random.Generator, family_name: str = "") -> np.ndarray:
    """Draw every ranged coordinate of a family uniformly in [min, max]; fixed ones stay. A generated
    family (``generator``, rgns.scene.slope_generator) draws its parameters and builds its polygon."""
    if "generator" in family:
        return generate_vertices(family_name, family, rng)
    vertices = np.empty((len(family["vertices"]), 2))
    for k, vertex in enumerate(family["vertices"]):
        for axis, key in enumerate(("x_m", "y_m")):
            value = vertex[key]
            vertices[k, axis] = rng.uniform(value[0], value[1]) if isinstance(value, list) else float(value)
    return vertices


def seed_particles(vertices: np.ndarray, cell_size_m: float, particles_per_cell: int) -> tuple[np.ndarray, np.ndarray]:
    """Material points on the regular sub-grid of the MPM cells that fall inside the polygon.

    Each cell holds ``particles_per_cell``² candidate points at ((k + ½)/n) of the cell; every
    point gets the volume (cell / n)² (m² per metre width), so volumes sum to the polygon area up
    to the seeding error along the boundary. Returns positions [N, 2] and volumes [N].
    """
    spacing = cell_size_m / particles_per_cell
    lower = np.floor(vertices.min(axis=0) / cell_size_m) * cell_size_m
    upper = np.ceil(vertices.max(axis=0) / cell_size_m) * cell_size_m
    xs = np.arange(lower[0] + 0.5 * spacing, upper[0], spacing)
    ys = np.arange(lower[1] + 0.5 * spacing, upper[1], spacing)
    grid_x, grid_y = np.meshgrid(xs, ys, indexing="xy")
    candidates = np.column_stack([grid_x.ravel(), grid_y.ravel()])
    inside = MplPath(vertices).contains_points(candidates)
    positions = candidates[inside]
    volumes = np.full(len(positions), spacing * spacing)
    return positions, volumes


@dataclass
class Scene:
    """One realization's geometry: the drawn polygon and its material points."""

    set_name: str
    index: int
    family: str
    vertices: np.ndarray
    positions: np.ndarray
    volumes: np.ndarray
    domain_length_m: float
    domain_height_m: float
    cell_size_m: float
    particles_per_cell: int
    draws: int

    @property
    def area_m2(self) -> float:
        return signed_area(self.vertices)


def draw_polygon(
    family_name: str,
    family: dict[str, Any],
    rng: np.random.Generator,
    domain: dict[str, float],
    cell_size_m: float,
    runout_room_m: float,
    max_draws: int,
) -> tuple[np.ndarray, int]:
    """Draw a valid polygon of a family; returns it and the number of draws it took."""
    problems: list[str] = []
    for draw in range(1, max_draws + 1):
        vertices = sample_vertices(family, rng, family_name)
        problems = polygon_problems(
            vertices, domain["length_m"], domain["height_m"], runout_room_m, headroom=cell_size_m
        )
        if not problems:
            return vertices, draw
    raise GeometryError(
        f"geometry family {family_name!r}: no valid polygon in {max_draws} draws "
        f"(geometry.max_draws); the last one {vertices.round(3).tolist()} {'; '.join(problems)}"
    )


def build_scene(
    set_name: str,
    index: int,
    family_name: str,
    family: dict[str, Any],
    domain: dict[str, float],
    mesh: dict[str, Any],
    geometry: dict[str, Any],
    seed: int,
) -> Scene:
    """Draw realization ``index`` of a set: its polygon (from its own stream) and particles."""
    rng = realization_rng(seed, set_name, index, "geometry")
    vertices, draws = draw_polygon(
        family_name, family, rng, domain, mesh["cell_size_m"], geometry["runout_room_m"], geometry["max_draws"]
    )
    positions, volumes = seed_particles(vertices, mesh["cell_size_m"], mesh["particles_per_cell"])
    if len(positions) == 0:
        raise GeometryError(
            f"{set_name} realization {index}: family {family_name!r} holds no material point at "
            f"cell size {mesh['cell_size_m']} m"
        )
    return Scene(
        set_name=set_name,
        index=index,
        family=family_name,
        vertices=vertices,
        positions=positions,
        volumes=volumes,
        domain_length_m=float(domain["length_m"]),
        domain_height_m=float(domain["height_m"]),
        cell_size_m=float(mesh["cell_size_m"]),
        particles_per_cell=int(mesh["particles_per_cell"]),
        draws=draws,
    )


def write_scene(path: str | Path, scene: Scene) -> None:
    """Write a scene as JSON (arrays as nested lists; human-readable, diffable)."""
    record = asdict(scene)
    for key in ("vertices", "positions", "volumes"):
        record[key] = np.asarray(record[key]).tolist()
    record["area_m2"] = scene.area_m2
    record["n_particles"] = int(len(scene.positions))
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w") as handle:
        json.dump(record, handle)


def read_scene(path: str | Path) -> Scene:
    """Read a scene written by :func:`write_scene`, naming the file on any defect."""
    try:
        with open(path) as handle:
            record = json.load(handle)
        record.pop("area_m2", None)
        n_particles = record.pop("n_particles")
        for key in ("vertices", "positions", "volumes"):
            record[key] = np.asarray(record[key], dtype=float)
        scene = Scene(**record)
    except (OSError, ValueError, TypeError, KeyError) as error:
        raise GeometryError(f"{path}: not a readable scene file ({error})") from error
    if scene.positions.shape != (n_particles, 2) or scene.volumes.shape != (n_particles,):
        raise GeometryError(
            f"{path}: positions {scene.positions.shape} and volumes {scene.volumes.shape} do not "
            f"match n_particles = {n_particles}"
        )
    return scene
