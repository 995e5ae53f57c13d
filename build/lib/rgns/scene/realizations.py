"""Drawing the realizations of a test case for the Monte Carlo runs (no simulator: cheap to import).

Realization ``i`` of case ``c`` is drawn exactly as realization ``i`` of the set ``c`` in the MPM
pipeline (same geometry and field streams), so the first realizations of a Monte Carlo run are
the very realizations the validation compares against MPM.

The deterministic *mean-field* realization has the mean geometry (the midpoint of every vertex
range) and a uniform friction angle equal to the field mean; it is the reference the exceedance
curves mark.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

import numpy as np

from rgns.scene.fields import FIELD_KEYS, FieldGrid, friction_field
from rgns.scene.geometry import DRAW_KEYS, Scene, build_scene, seed_particles
from rgns.scene.slope_generator import generate_vertices, midpoint_family

MEAN_FIELD = -1  # the index recorded for the mean-field realization
FINISHED = ("ok", "screened")  # statuses of rows with metrics (screened: found stable, counted as no failure)


@dataclass
class CaseInputs:
    """What drawing a realization of one case needs (the ``params`` of the Monte Carlo rules)."""

    seed: int
    case: str
    family_name: str
    family: dict[str, Any]
    group: dict[str, Any]
    domain: dict[str, float]
    mesh: dict[str, Any]
    geometry: dict[str, Any]
    random_field: dict[str, Any]

    @classmethod
    def from_config(cls, config: dict[str, Any], case: str) -> CaseInputs:
        """The inputs of test case ``case`` (a set of one group, as rgns.config checks)."""
        group = config["sets"][case][0]
        geometry = config["geometry"]
        return cls(
            seed=config["seed"],
            case=case,
            family_name=group["family"],
            family=geometry["families"][group["family"]],
            group={key: group[key] for key in FIELD_KEYS},
            domain=config["domain"],
            mesh=config["mesh"],
            geometry={key: geometry[key] for key in DRAW_KEYS},
            random_field=config["random_field"],
        )

    @classmethod
    def from_params(cls, params: dict[str, Any]) -> CaseInputs:
        return cls(**{key: params[key] for key in cls.__dataclass_fields__})

    @property
    def field_grid(self) -> FieldGrid:
        spacing = self.random_field["grid_spacing_m"] or self.mesh["cell_size_m"]
        return FieldGrid.covering(self.domain["length_m"], self.domain["height_m"], spacing)


@dataclass
class Realization:
    """One realization ready to simulate."""

    index: int
    scene: Scene
    friction_deg: np.ndarray


def accurate_case_inputs(config: dict[str, Any], case: str, cell_size_m: float) -> CaseInputs:
    """Case ``case`` drawn at ``cell_size_m`` cells: the same geometry, and the friction field on the
    config's own grid, so a realization index is the same slope and soil at both meshes."""
    accurate = copy.deepcopy(config)
    accurate["random_field"]["grid_spacing_m"] = (
        config["random_field"]["grid_spacing_m"] or config["mesh"]["cell_size_m"]
    )
    accurate["mesh"]["cell_size_m"] = cell_size_m
    return CaseInputs.from_config(accurate, case)


def draw_scene(inputs: CaseInputs, index: int) -> Scene:
    """Realization ``index``'s scene alone, from its own seed (no friction field)."""
    return build_scene(
        inputs.case, index, inputs.family_name, inputs.family, inputs.domain, inputs.mesh, inputs.geometry, inputs.seed
    )


def draw_realization(inputs: CaseInputs, index: int) -> Realization:
    """Realization ``index``: its scene and friction field from its own seeds."""
    scene = draw_scene(inputs, index)
    field = friction_field(
        inputs.seed,
        inputs.case,
        index,
        inputs.group,
        inputs.field_grid,
        inputs.random_field["method"],
        tuple(inputs.random_field["friction_bounds_deg"]),
        scene.positions,
    )
    return Realization(index, scene, field.friction_deg)


def _midpoint(value: float | list[float]) -> float:
    return float(np.mean(value)) if isinstance(value, list) else float(value)


def mean_vertices(family: dict[str, Any]) -> np.ndarray:
    """The family's mean polygon [K, 2]: every vertex range (or generator parameter) at its midpoint."""
    if "generator" in family:
        return generate_vertices("mean", midpoint_family(family), np.random.default_rng(0))
    return np.array([[_midpoint(v["x_m"]), _midpoint(v["y_m"])] for v in family["vertices"]])


def mean_field_realization(inputs: CaseInputs) -> Realization:
    """The deterministic reference: mean geometry, uniform friction at the field mean."""
    vertices = mean_vertices(inputs.family)
    positions, volumes = seed_particles(vertices, inputs.mesh["cell_size_m"], inputs.mesh["particles_per_cell"])
    scene = Scene(
        inputs.case,
        MEAN_FIELD,
        inputs.family_name,
        vertices,
        positions,
        volumes,
        float(inputs.domain["length_m"]),
        float(inputs.domain["height_m"]),
        float(inputs.mesh["cell_size_m"]),
        int(inputs.mesh["particles_per_cell"]),
        draws=0,
    )
    mean_deg = _midpoint(inputs.group["friction_mean_deg"])
    return Realization(MEAN_FIELD, scene, np.full(len(positions), mean_deg))
