"""The case a realization is simulated from (:class:`rgns.scene.case.Case`), built in memory from a drawn
scene and its friction field.

Every engine runs this one case: the embedded engine takes it as it is, and the CB-Geo writer
(:func:`rgns.engines.cbgeo.writer.save_case`) only serialises it to a case directory for the ``mpm``
binary, so building lives here and not with any one engine. Its fields follow CB-Geo's input model:

* the mesh: an ED2Q4 grid over the domain plus ``PAD_CELLS`` cells of padding on every side, for
  CB-Geo, which aborts on a particle outside its mesh. The embedded engine works on the region
  between the walls and above the floor and flags any particle that leaves it, with or without
  padding;
* node sets 0 left wall, 1 right wall, 2 floor; particle sets 1..K, one per friction bin (the
  generator's set is 0, so no id collides), each bin one ``MohrCoulomb2D`` material;
* the exact friction angle per particle, so the embedded engine can use exact values instead of
  the bins;
* ``config``: the ``mpm.json`` (analysis, materials, constraints, and the names of the files a
  case directory holds); ``meta``: which realization this is, its polygon, the domain and the
  frame interval (rgns's own).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rgns.scene.case import Case
from rgns.scene.geometry import Scene
from rgns.scene.geostatic import geostatic_stresses

PAD_CELLS = 1
MESH_FILE = "mesh.txt"
PARTICLES_FILE = "particles.txt"
VOLUMES_FILE = "particles-volumes.txt"
STRESSES_FILE = "particles-stresses.txt"
ENTITY_SETS_FILE = "entity_sets.json"
RESULTS_PATH = "results/"
UUID = "rgns"
LEFT_WALL, RIGHT_WALL, FLOOR = 0, 1, 2
GENERATOR_PSET = 0


@dataclass(frozen=True)
class FrictionBins:
    """Equal-width bins of the friction angles: bin of each particle and each bin's angle."""

    particle_bin: np.ndarray  # [N] int
    bin_friction_deg: np.ndarray  # [K] bin centres
    edges_deg: np.ndarray  # [K + 1]

    @property
    def width_deg(self) -> float:
        return float(self.edges_deg[1] - self.edges_deg[0])


def bin_friction(friction_deg: np.ndarray, count: int) -> FrictionBins:
    """Split [min φ, max φ] into ``count`` equal bins; each particle gets its bin's centre."""
    low, high = float(friction_deg.min()), float(friction_deg.max())
    if high - low < 1e-9:
        high = low + 1e-6
    edges = np.linspace(low, high, count + 1)
    particle_bin = np.clip(np.searchsorted(edges, friction_deg, side="right") - 1, 0, count - 1)
    return FrictionBins(particle_bin, 0.5 * (edges[:-1] + edges[1:]), edges)


@dataclass(frozen=True)
class Grid:
    """The padded background grid: origin, cell size, cells per direction."""

    origin: np.ndarray
    cell_size_m: float
    cells: tuple[int, int]

    @classmethod
    def for_domain(cls, length_m: float, height_m: float, cell_size_m: float) -> Grid:
        nx = int(round(length_m / cell_size_m)) + 2 * PAD_CELLS
        ny = int(round(height_m / cell_size_m)) + 2 * PAD_CELLS
        origin = np.array([-PAD_CELLS * cell_size_m, -PAD_CELLS * cell_size_m])
        return cls(origin, cell_size_m, (nx, ny))

    def nodes(self) -> np.ndarray:
        """Node coordinates [(nx+1)(ny+1), 2], numbered row by row: j·(nx+1) + i."""
        nx, ny = self.cells
        i, j = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), indexing="xy")
        return self.origin + self.cell_size_m * np.column_stack([i.ravel(), j.ravel()])

    def cell_nodes(self) -> np.ndarray:
        """Four node ids per cell [nx·ny, 4], counter-clockwise from the lower left."""
        nx, ny = self.cells
        i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="xy")
        first = (j * (nx + 1) + i).ravel()
        return np.column_stack([first, first + 1, first + nx + 2, first + nx + 1])


def _material(material_id: int, friction_deg: float, settings: dict[str, Any]) -> dict[str, Any]:
    """A MohrCoulomb2D material with every key CB-Geo reads (no softening)."""
    return {
        "id": material_id,
        "type": "MohrCoulomb2D",
        "density": settings["density_kg_m3"],
        "youngs_modulus": settings["youngs_modulus_pa"],
        "poisson_ratio": settings["poisson_ratio"],
        "friction": round(float(friction_deg), 6),
        "dilation": settings["dilation_deg"],
        "cohesion": settings["cohesion_pa"],
        "residual_friction": round(float(friction_deg), 6),
        "residual_dilation": settings["dilation_deg"],
        "residual_cohesion": settings["cohesion_pa"],
        "peak_pdstrain": 0.0,
        "residual_pdstrain": 0.0,
        "tension_cutoff": settings["tension_cutoff_pa"],
        "softening": False,
    }


def time_steps(settings: dict[str, Any]) -> tuple[int, int]:
    """(total steps, steps between stored frames) from duration, dt and the frame interval."""
    output_steps = int(round(settings["frame_interval_s"] / settings["dt_s"]))
    frames = int(round(settings["duration_s"] / settings["frame_interval_s"]))
    return frames * output_steps, output_steps


def case_json(settings: dict[str, Any], bins: FrictionBins, used_bins: np.ndarray, title: str) -> dict[str, Any]:
    """The ``mpm.json`` of a case."""
    nsteps, output_steps = time_steps(settings)
    mesh: dict[str, Any] = {
        "mesh": MESH_FILE,
        "entity_sets": ENTITY_SETS_FILE,
        "particles_volumes": VOLUMES_FILE,
        "io_type": "Ascii2D",
        "check_duplicates": False,
        "isoparametric": False,
        "node_type": "N2D",
        "cell_type": "ED2Q4",
        "boundary_conditions": {
            "velocity_constraints": [
                {"nset_id": LEFT_WALL, "dir": 0, "velocity": 0.0},
                {"nset_id": RIGHT_WALL, "dir": 0, "velocity": 0.0},
                {"nset_id": FLOOR, "dir": 1, "velocity": 0.0},
            ],
            "friction_constraints": [
                {"nset_id": FLOOR, "dir": 1, "sign_n": -1, "friction": settings["floor_friction"]},
            ],
        },
    }
    if settings["geostatic_stress"]:
        mesh["particles_stresses"] = STRESSES_FILE
    analysis: dict[str, Any] = {
        "type": "MPMExplicit2D",
        "mpm_scheme": settings["scheme"],
        "velocity_update": False,
        "locate_particles": True,
        "dt": settings["dt_s"],
        "nsteps": nsteps,
        "uuid": UUID,
        "resume": {"resume": False, "uuid": UUID, "step": 0},
    }
    if settings["damping_factor"] > 0:
        analysis["damping"] = {"type": "Cundall", "damping_factor": settings["damping_factor"]}
    return {
        "title": title,
        "mesh": mesh,
        "particles": [
            {
                "generator": {
                    "type": "file",
                    "io_type": "Ascii2D",
                    "location": PARTICLES_FILE,
                    "check_duplicates": False,
                    "particle_type": "P2D",
                    "material_id": int(used_bins[0]),
                    "pset_id": GENERATOR_PSET,
                }
            }
        ],
        "materials": [_material(k, phi, settings) for k, phi in enumerate(bins.bin_friction_deg)],
        "material_sets": [{"material_id": int(k), "pset_id": int(k) + 1} for k in used_bins],
        "external_loading_conditions": {"gravity": [0.0, -settings["gravity_m_s2"]]},
        "analysis": analysis,
        "post_processing": {"path": RESULTS_PATH, "output_steps": output_steps, "vtk": []},
    }


def _node_sets(nodes: np.ndarray, length_m: float, cell_size_m: float) -> dict[int, np.ndarray]:
    """The left and right walls and the floor (the top is free: no node set)."""
    tolerance = 1e-9 * cell_size_m
    return {
        LEFT_WALL: np.flatnonzero(np.abs(nodes[:, 0]) < tolerance),
        RIGHT_WALL: np.flatnonzero(np.abs(nodes[:, 0] - length_m) < tolerance),
        FLOOR: np.flatnonzero(np.abs(nodes[:, 1]) < tolerance),
    }


def _meta(scene: Scene, settings: dict[str, Any], bins: FrictionBins) -> dict[str, Any]:
    """``rgns-case.json``: which realization this is, its polygon and domain, its time steps."""
    nsteps, output_steps = time_steps(settings)
    return {
        "set_name": scene.set_name,
        "index": int(scene.index),
        "family": scene.family,
        "vertices": scene.vertices.tolist(),
        "domain_length_m": scene.domain_length_m,
        "domain_height_m": scene.domain_height_m,
        "cell_size_m": scene.cell_size_m,
        "pad_cells": PAD_CELLS,
        "dt_s": settings["dt_s"],
        "nsteps": nsteps,
        "output_steps": output_steps,
        "frame_interval_s": settings["frame_interval_s"],
        "friction_bin_width_deg": bins.width_deg,
    }


def case_from_scene(scene: Scene, friction_deg: np.ndarray, settings: dict[str, Any]) -> Case:
    """The case of one realization, in memory: what :func:`rgns.engines.cbgeo.writer.save_case` writes and
    :func:`rgns.engines.cbgeo.case.read_case` reads back."""
    grid = Grid.for_domain(scene.domain_length_m, scene.domain_height_m, scene.cell_size_m)
    nodes = grid.nodes()
    positions = np.asarray(scene.positions, dtype=float)
    friction_deg = np.asarray(friction_deg, dtype=float)
    stresses = None
    if settings["geostatic_stress"]:
        stresses = geostatic_stresses(
            scene.vertices, positions, friction_deg, settings["density_kg_m3"], settings["gravity_m_s2"], settings["k0"]
        )
    bins = bin_friction(friction_deg, settings["friction_bins"])
    used = np.unique(bins.particle_bin)
    title = f"rgns {scene.set_name} {scene.index:04d} ({scene.family})"
    return Case(
        directory=None,
        meta=_meta(scene, settings, bins),
        config=case_json(settings, bins, used, title),
        nodes=nodes,
        cells=grid.cell_nodes(),
        positions=positions,
        volumes=np.asarray(scene.volumes, dtype=float),
        stresses=stresses,
        material_id=bins.particle_bin.astype(int),
        friction_deg=friction_deg,
        node_sets=_node_sets(nodes, scene.domain_length_m, grid.cell_size_m),
        particle_sets={int(k) + 1: np.flatnonzero(bins.particle_bin == k) for k in used},
    )
