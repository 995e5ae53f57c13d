"""The CB-Geo case writer, checked file by file against the facts of CB-Geo's formats."""
from __future__ import annotations

import json

import numpy as np
import pytest

from rgns.cbgeo.case import read_case, read_mesh
from rgns.cbgeo.writer import FLOOR, GENERATOR_PSET, LEFT_WALL, PAD_CELLS, RIGHT_WALL, bin_friction, write_case
from rgns.config import ConfigError, validate_config
from rgns.fields import FieldGrid, friction_field
from rgns.geometry import build_scene, signed_area

MOHR_COULOMB_KEYS = {
    "id", "type", "density", "youngs_modulus", "poisson_ratio", "friction", "dilation", "residual_friction",
    "residual_dilation", "cohesion", "residual_cohesion", "tension_cutoff", "peak_pdstrain", "residual_pdstrain",
    "softening",
}


@pytest.fixture(scope="module")
def written(tmp_path_factory, default_config):
    """A case for realization 2 of the default training slopes, written once."""
    config = default_config
    scene = build_scene("train", 2, "slope", config["geometry"]["families"]["slope"], config["domain"],
                        config["mesh"], config["geometry"], config["seed"])
    grid = FieldGrid.covering(config["domain"]["length_m"], config["domain"]["height_m"], config["mesh"]["cell_size_m"])
    field = friction_field(config["seed"], "train", 2, config["sets"]["train"][0], grid, "kronecker",
                           tuple(config["random_field"]["friction_bounds_deg"]), scene.positions)
    directory = write_case(tmp_path_factory.mktemp("case") / "case", scene, field.friction_deg, config["mpm"])
    return directory, scene, field, config


def test_mesh_counts_numbering_and_cells(written):
    directory, scene, _, config = written
    header = (directory / "mesh.txt").read_text().splitlines()[0].split()
    nodes, cells = read_mesh(directory / "mesh.txt")
    cell = config["mesh"]["cell_size_m"]
    nx = round(scene.domain_length_m / cell) + 2 * PAD_CELLS
    ny = round(scene.domain_height_m / cell) + 2 * PAD_CELLS
    assert (int(header[0]), int(header[1])) == ((nx + 1) * (ny + 1), nx * ny) == (len(nodes), len(cells))
    j, i = 3, 5  # row-by-row numbering: node = j·(nx+1) + i
    np.testing.assert_allclose(nodes[j * (nx + 1) + i], [(i - PAD_CELLS) * cell, (j - PAD_CELLS) * cell])
    corners = nodes[cells]  # [Nc, 4, 2]: every cell counter-clockwise with area cell²
    areas = [signed_area(quad) for quad in corners]
    np.testing.assert_allclose(areas, cell * cell)
    assert nodes[:, 0].min() < 0 and nodes[:, 0].max() > scene.domain_length_m and nodes[:, 1].min() < 0


def test_particles_volumes_and_stresses_files(written):
    directory, scene, field, config = written
    lines = (directory / "particles.txt").read_text().splitlines()
    assert int(lines[0]) == len(scene.positions) == len(lines) - 1
    volumes = np.loadtxt(directory / "particles-volumes.txt")
    np.testing.assert_array_equal(volumes[:, 0], np.arange(len(scene.positions)))  # pid volume, no count line
    perimeter = np.sum(np.linalg.norm(np.diff(np.vstack([scene.vertices, scene.vertices[:1]]), axis=0), axis=1))
    spacing = config["mesh"]["cell_size_m"] / config["mesh"]["particles_per_cell"]
    assert abs(volumes[:, 1].sum() - scene.area_m2) <= 0.5 * perimeter * spacing
    case = read_case(directory)
    np.testing.assert_allclose(case.positions, scene.positions)
    np.testing.assert_allclose(case.friction_deg, field.friction_deg, atol=1e-6)
    assert case.stresses.shape == (len(scene.positions), 6)


def test_geostatic_stresses_grow_linearly_with_depth_under_a_flat_top(written):
    directory, scene, field, config = written
    case = read_case(directory)
    rho, g = config["mpm"]["density_kg_m3"], config["mpm"]["gravity_m_s2"]
    behind_crest = case.positions[:, 0] < scene.vertices[3, 0] - 1.0  # under the crest-to-wall top edge
    x, y = case.positions[behind_crest].T
    top = scene.vertices[4, 1] + (scene.vertices[3, 1] - scene.vertices[4, 1]) * x / scene.vertices[3, 0]
    np.testing.assert_allclose(case.stresses[behind_crest, 1], -rho * g * (top - y), rtol=1e-9)
    k0 = 1.0 - np.sin(np.radians(field.friction_deg[behind_crest]))
    np.testing.assert_allclose(case.stresses[behind_crest, 0], k0 * case.stresses[behind_crest, 1], rtol=1e-9)
    np.testing.assert_allclose(case.stresses[:, 3:], 0.0)
    assert (case.stresses[:, 1] <= 0).all()  # compression is negative


def test_entity_sets_walls_floor_and_friction_bins(written):
    directory, scene, field, _ = written
    case = read_case(directory)
    nodes = case.nodes
    np.testing.assert_array_equal(case.node_sets[LEFT_WALL], np.flatnonzero(np.isclose(nodes[:, 0], 0.0)))
    np.testing.assert_array_equal(case.node_sets[RIGHT_WALL], np.flatnonzero(np.isclose(nodes[:, 0], scene.domain_length_m)))
    np.testing.assert_array_equal(case.node_sets[FLOOR], np.flatnonzero(np.isclose(nodes[:, 1], 0.0)))
    assert GENERATOR_PSET not in case.particle_sets  # a colliding id would be silently dropped
    members = np.concatenate(list(case.particle_sets.values()))
    np.testing.assert_array_equal(np.sort(members), np.arange(len(scene.positions)))  # each particle once
    width = json.loads((directory / "rgns-case.json").read_text())["friction_bin_width_deg"]
    assert np.abs(case.binned_friction_deg - field.friction_deg).max() <= 0.5 * width + 1e-6


def test_input_json_has_every_key_cbgeo_needs(written):
    directory, _, _, config = written
    document = json.loads((directory / "mpm.json").read_text())
    for material in document["materials"]:
        assert set(material) == MOHR_COULOMB_KEYS and material["type"] == "MohrCoulomb2D"
        assert material["cohesion"] > 0 and material["tension_cutoff"] > 0 and material["softening"] is False
    material_ids = {m["id"] for m in document["materials"]}
    particle_sets = {s["id"] for s in json.loads((directory / "entity_sets.json").read_text())["particle_sets"]}
    for material_set in document["material_sets"]:
        assert material_set["material_id"] in material_ids and material_set["pset_id"] in particle_sets
    analysis = document["analysis"]
    assert analysis["type"] == "MPMExplicit2D" and analysis["mpm_scheme"] == "usf"
    assert analysis["velocity_update"] is False and "stress_update" not in analysis
    mpm = config["mpm"]
    assert analysis["dt"] == mpm["dt_s"] and analysis["nsteps"] == round(mpm["duration_s"] / mpm["dt_s"])
    assert document["post_processing"]["output_steps"] == round(mpm["frame_interval_s"] / mpm["dt_s"])
    assert document["external_loading_conditions"]["gravity"] == [0.0, -mpm["gravity_m_s2"]]
    generator = document["particles"][0]["generator"]
    assert generator["type"] == "file" and generator["check_duplicates"] is False
    boundary = document["mesh"]["boundary_conditions"]
    assert {(c["nset_id"], c["dir"]) for c in boundary["velocity_constraints"]} == {(0, 0), (1, 0), (2, 1)}
    assert boundary["friction_constraints"] == [
        {"nset_id": FLOOR, "dir": 1, "sign_n": -1, "friction": mpm["floor_friction"]}
    ]


def test_bins_are_equal_width_and_every_angle_is_within_half_a_bin_of_its_material():
    friction = np.random.default_rng(1).normal(30.0, 5.0, 5000)
    bins = bin_friction(friction, 16)
    assert len(bins.bin_friction_deg) == 16
    np.testing.assert_allclose(np.diff(bins.edges_deg), bins.width_deg)
    assert np.abs(bins.bin_friction_deg[bins.particle_bin] - friction).max() <= 0.5 * bins.width_deg + 1e-12
    single = bin_friction(np.full(10, 30.0), 16)
    assert np.allclose(single.bin_friction_deg[single.particle_bin], 30.0)


def test_a_frame_interval_that_is_not_a_whole_number_of_steps_is_rejected(raw_default_config):
    raw_default_config["mpm"] = {"dt_s": 3e-4, "frame_interval_s": 0.025}
    with pytest.raises(ConfigError, match=r"'mpm.frame_interval_s' = 0.025: not a whole number of mpm.dt_s"):
        validate_config(raw_default_config)
