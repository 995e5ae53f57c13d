"""The CB-Geo case writer, checked file by file against the facts of CB-Geo's formats."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import torch
from conftest import TINY_CONFIG

from rgns.config import ConfigError, load_config, validate_config
from rgns.engines.cbgeo.case import read_case, read_mesh
from rgns.engines.cbgeo.writer import save_case, write_case
from rgns.engines.mpm.solver import EngineSettings, run_batch
from rgns.scene.build import FLOOR, GENERATOR_PSET, LEFT_WALL, PAD_CELLS, RIGHT_WALL, bin_friction, case_from_scene
from rgns.scene.fields import FieldGrid, friction_field
from rgns.scene.geometry import build_scene, signed_area
from rgns.scene.realizations import CaseInputs, draw_realization

MOHR_COULOMB_KEYS = {
    "id",
    "type",
    "density",
    "youngs_modulus",
    "poisson_ratio",
    "friction",
    "dilation",
    "residual_friction",
    "residual_dilation",
    "cohesion",
    "residual_cohesion",
    "tension_cutoff",
    "peak_pdstrain",
    "residual_pdstrain",
    "softening",
}


@pytest.fixture(scope="module")
def written(tmp_path_factory, default_config):
    """A case for realization 2 of the default training slopes, written once."""
    config = default_config
    scene = build_scene(
        "train",
        2,
        "slope",
        config["geometry"]["families"]["slope"],
        config["domain"],
        config["mesh"],
        config["geometry"],
        config["seed"],
    )
    grid = FieldGrid.covering(config["domain"]["length_m"], config["domain"]["height_m"], config["mesh"]["cell_size_m"])
    field = friction_field(
        config["seed"],
        "train",
        2,
        config["sets"]["train"][0],
        grid,
        "kronecker",
        tuple(config["random_field"]["friction_bounds_deg"]),
        scene.positions,
    )
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
    np.testing.assert_array_equal(
        case.node_sets[RIGHT_WALL], np.flatnonzero(np.isclose(nodes[:, 0], scene.domain_length_m))
    )
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


def _assert_same_case(first, second):
    for field in dataclasses.fields(first):
        a, b = getattr(first, field.name), getattr(second, field.name)
        if field.name == "directory":
            continue
        if isinstance(a, np.ndarray):
            assert a.dtype.kind == b.dtype.kind and np.array_equal(a, b), field.name
        elif field.name in ("node_sets", "particle_sets"):
            assert list(a) == list(b) and all(np.array_equal(a[k], b[k]) for k in a), field.name
        else:
            assert a == b, field.name


@pytest.mark.parametrize("geostatic", [True, False])
def test_a_case_built_in_memory_is_exactly_the_case_read_back_from_its_directory(written, tmp_path, geostatic):
    _, scene, field, config = written
    settings = config["mpm"] | {"geostatic_stress": geostatic}
    in_memory = case_from_scene(scene, field.friction_deg, settings)
    assert in_memory.directory is None and in_memory.source == "train realization 0002 (in memory)"
    read = read_case(save_case(tmp_path / "case", in_memory))
    assert read.directory == tmp_path / "case"
    _assert_same_case(in_memory, read)
    assert (read.stresses is None) == (not geostatic)


def test_duration_and_frame_interval_come_from_mpm_json_and_are_the_configs(written):
    directory, _, _, config = written
    case = read_case(directory)
    assert (case.duration_s, case.frame_interval_s) == (config["mpm"]["duration_s"], config["mpm"]["frame_interval_s"])
    assert case.dt_s == config["mpm"]["dt_s"]


def test_a_realization_run_from_memory_and_from_its_written_directory_gives_identical_trajectories(tmp_path):
    torch.set_num_threads(1)
    config = load_config(TINY_CONFIG)
    realization = draw_realization(CaseInputs.from_config(config, "case1"), 1)
    in_memory = case_from_scene(realization.scene, realization.friction_deg, config["mpm"])
    from_disk = read_case(write_case(tmp_path / "case", realization.scene, realization.friction_deg, config["mpm"]))
    settings = EngineSettings(shape_function="linear")
    first, second = (
        run_batch([case], settings, 0.5, config["mpm"]["frame_interval_s"])[0] for case in (in_memory, from_disk)
    )
    assert first.status == second.status == "ok" and first.positions.shape == (21, len(in_memory.positions), 2)
    assert np.abs(first.positions[-1] - first.positions[0]).max() > 0.05  # it did move
    assert np.array_equal(first.positions, second.positions)
    assert np.array_equal(first.energies, second.energies)
