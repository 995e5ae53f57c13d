"""Geometry: perturbation ranges, polygon validity, particle seeding, scene files."""

from __future__ import annotations

import json

import numpy as np
import pytest
from matplotlib.path import Path as MplPath

from rgns.config import as_range
from rgns.scene.geometry import (
    GeometryError,
    build_scene,
    is_simple,
    polygon_problems,
    read_scene,
    seed_particles,
    signed_area,
    write_scene,
)

SQUARE = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])


def _scene(config, set_name, index, family_name):
    return build_scene(
        set_name,
        index,
        family_name,
        config["geometry"]["families"][family_name],
        config["domain"],
        config["mesh"],
        config["geometry"],
        config["seed"],
    )


def test_signed_area_is_positive_counter_clockwise_and_negative_clockwise():
    assert signed_area(SQUARE) == pytest.approx(16.0)
    assert signed_area(SQUARE[::-1]) == pytest.approx(-16.0)


def test_a_bow_tie_is_not_simple_and_a_square_is():
    assert is_simple(SQUARE)
    assert not is_simple(np.array([[0.0, 0.0], [4.0, 4.0], [4.0, 0.0], [0.0, 4.0]]))
    assert not is_simple(np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 0.0], [0.0, 4.0]]))


def test_polygon_problems_name_each_defect():
    assert polygon_problems(SQUARE, 20.0, 10.0, room=5.0, headroom=1.0) == []
    assert any("counter-clockwise" in p for p in polygon_problems(SQUARE[::-1], 20.0, 10.0, 5.0))
    assert any("leaves the domain" in p for p in polygon_problems(SQUARE - [1.0, 0.0], 20.0, 10.0, 5.0))
    assert any("right wall" in p for p in polygon_problems(SQUARE, 6.0, 10.0, room=5.0))
    assert any("left wall" in p for p in polygon_problems(SQUARE + [2.0, 0.0], 20.0, 10.0, room=5.0))
    assert any("head room" in p for p in polygon_problems(SQUARE, 20.0, 4.5, room=5.0, headroom=1.0))


@pytest.mark.parametrize("config_name", ["default_config", "paper_config"])
def test_perturbed_vertices_stay_in_their_ranges_and_polygons_stay_valid(config_name, request):
    config = request.getfixturevalue(config_name)
    geometry, domain = config["geometry"], config["domain"]
    for family_name, family in geometry["families"].items():
        for index in range(100):
            scene = _scene(config, "train", index, family_name)
            for k, vertex in enumerate(family["vertices"]):
                for axis, key in enumerate(("x_m", "y_m")):
                    low, high = as_range(vertex[key])
                    assert low <= scene.vertices[k, axis] <= high, (family_name, index, k, key)
            assert (
                polygon_problems(
                    scene.vertices,
                    domain["length_m"],
                    domain["height_m"],
                    geometry["runout_room_m"],
                    config["mesh"]["cell_size_m"],
                )
                == []
            )


def test_ranged_vertices_actually_vary_and_fixed_ones_do_not(default_config):
    drawn = np.stack([_scene(default_config, "train", i, "slope").vertices for i in range(50)])
    assert drawn[:, 1, 0].std() > 1.0  # toe x in [28, 34]
    assert drawn[:, 0].std() == 0.0  # the corner on the floor and wall


def test_scenes_reproduce_by_seed_and_differ_between_realizations(default_config):
    first = _scene(default_config, "train", 3, "slope")
    again = _scene(default_config, "train", 3, "slope")
    other = _scene(default_config, "train", 4, "slope")
    np.testing.assert_array_equal(first.vertices, again.vertices)
    np.testing.assert_array_equal(first.positions, again.positions)
    assert not np.array_equal(first.vertices, other.vertices)


def test_particles_of_a_cell_aligned_rectangle_fill_it_exactly():
    positions, volumes = seed_particles(SQUARE, 1.0, 2)
    assert len(positions) == 4 * 4 * 4
    assert volumes.sum() == pytest.approx(16.0)
    np.testing.assert_allclose(np.unique(positions[:, 0]), np.arange(0.25, 4.0, 0.5))


@pytest.mark.parametrize("per_cell", [1, 2, 3, 4])
def test_particle_volumes_sum_to_the_polygon_area_within_the_seeding_error(default_config, per_cell):
    scene = _scene(default_config, "case1", 0, "slope")
    positions, volumes = seed_particles(scene.vertices, 1.0, per_cell)
    spacing = 1.0 / per_cell
    perimeter = np.sum(np.linalg.norm(np.diff(np.vstack([scene.vertices, scene.vertices[:1]]), axis=0), axis=1))
    assert abs(volumes.sum() - scene.area_m2) <= 0.5 * perimeter * spacing
    assert MplPath(scene.vertices).contains_points(positions).all()


def test_seeding_error_shrinks_with_finer_particles(default_config):
    vertices = _scene(default_config, "train", 1, "embankment").vertices
    area = signed_area(vertices)
    errors = [abs(seed_particles(vertices, 1.0, n)[1].sum() - area) for n in (1, 2, 4, 8)]
    assert errors[-1] < errors[0]
    assert errors[-1] < 0.01 * area


def test_a_family_without_room_for_the_runout_fails_naming_the_family(default_config):
    geometry = dict(default_config["geometry"], runout_room_m=60.0, max_draws=5)
    with pytest.raises(GeometryError, match=r"'slope'.*5 draws.*runout room"):
        build_scene(
            "train",
            0,
            "slope",
            geometry["families"]["slope"],
            default_config["domain"],
            default_config["mesh"],
            geometry,
            1,
        )


def test_scene_files_round_trip_and_a_broken_one_is_named(default_config, tmp_path):
    scene = _scene(default_config, "valid", 1, "embankment")
    path = tmp_path / "0001.json"
    write_scene(path, scene)
    again = read_scene(path)
    np.testing.assert_array_equal(again.positions, scene.positions)
    np.testing.assert_array_equal(again.vertices, scene.vertices)
    assert (again.family, again.index, again.set_name) == ("embankment", 1, "valid")
    record = json.loads(path.read_text())
    record["positions"] = record["positions"][:-1]
    path.write_text(json.dumps(record))
    with pytest.raises(GeometryError, match="0001.json.*n_particles"):
        read_scene(path)
    path.write_text(path.read_text()[:100])
    with pytest.raises(GeometryError, match="0001.json.*not a readable scene"):
        read_scene(path)
