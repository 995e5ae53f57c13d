"""The procedural slope generator: every family it draws is a valid body the engine runs, each kind
has the shape it promises, and a draw is a function of its seed alone."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from conftest import REPO

from rgns.config import load_config, load_yaml, validate_config
from rgns.scene.geometry import build_scene, polygon_problems
from rgns.scene.realizations import CaseInputs, mean_vertices
from rgns.scene.slope_generator import GeneratorError, generate_vertices
from rgns.surrogates.endstate.data import simulate_end_states

PRETRAIN = load_config(REPO / "config" / "pretrain_general.yaml")
FAMILIES = {name: family for name, family in PRETRAIN["geometry"]["families"].items() if "generator" in family}
DOMAIN, MESH = PRETRAIN["domain"], PRETRAIN["mesh"]
GEOMETRY = {"runout_room_m": PRETRAIN["geometry"]["runout_room_m"], "max_draws": PRETRAIN["geometry"]["max_draws"]}


@pytest.mark.parametrize("name", sorted(FAMILIES))
def test_every_draw_is_a_valid_body_inside_the_domain(name):
    """100 draws per family: a simple counter-clockwise polygon with head and runout room, every
    material point inside the domain and above the floor, resting on the floor."""
    for index in range(100):
        scene = build_scene(name, index, name, FAMILIES[name], DOMAIN, MESH, GEOMETRY, seed=11)
        assert (
            polygon_problems(
                scene.vertices, DOMAIN["length_m"], DOMAIN["height_m"], GEOMETRY["runout_room_m"], MESH["cell_size_m"]
            )
            == []
        )
        assert scene.vertices[:, 1].min() == 0.0
        points = scene.positions
        assert len(points) > 0
        assert points[:, 0].min() > 0 and points[:, 0].max() < DOMAIN["length_m"]
        assert points[:, 1].min() > 0 and points[:, 1].max() < DOMAIN["height_m"]


def test_the_kinds_have_their_shapes():
    """A wall slope rests on the left wall, a free one and an embankment stand off it by the runout
    room; benches are level steps of the face; a concave face steepens upwards, a convex one flattens."""
    rng = np.random.default_rng(0)
    wall = generate_vertices("w", FAMILIES["gen_slope_wall"], rng)
    assert wall[:, 0].min() == 0.0
    for name in ("gen_slope_free", "gen_embankment"):
        assert generate_vertices(name, FAMILIES[name], rng)[:, 0].min() >= GEOMETRY["runout_room_m"]
    base = {
        "height_m": 10.0,
        "face_angle_deg": 45.0,
        "bench_width_m": 3.0,
        "crest_length_m": 10.0,
        "crest_tilt_deg": 0.0,
        "free_rear": 0.0,
        "back_angle_deg": 30.0,
        "rear_x_m": 15.0,
    }

    def face_angles(curvature: float, benches: int) -> list[float]:
        family = {"generator": "slope", "params": base | {"curvature": curvature, "benches": benches}}
        vertices = generate_vertices("f", family, rng)
        edges = np.diff(vertices[1:], axis=0)  # from the toe up the face and along the crest to the wall
        return [float(np.degrees(np.arctan2(dy, -dx))) for dx, dy in edges]

    benched = face_angles(0.0, 2)
    assert sum(abs(a) < 1e-9 for a in benched) == 2 + 1  # two benches and the level crest
    concave, convex = face_angles(1.0, 0)[:-1], face_angles(-1.0, 0)[:-1]
    assert np.all(np.diff(concave) > 0) and np.all(np.diff(convex) < 0)


def test_a_draw_depends_on_its_seed_only_and_the_mean_slope_is_valid():
    family = FAMILIES["gen_terrain"]
    one = build_scene("s", 3, "gen_terrain", family, DOMAIN, MESH, GEOMETRY, seed=5)
    again = build_scene("s", 3, "gen_terrain", family, DOMAIN, MESH, GEOMETRY, seed=5)
    other = build_scene("s", 3, "gen_terrain", family, DOMAIN, MESH, GEOMETRY, seed=6)
    np.testing.assert_array_equal(one.vertices, again.vertices)
    assert one.vertices.shape != other.vertices.shape or not np.allclose(one.vertices, other.vertices)
    for name, family in FAMILIES.items():
        assert polygon_problems(mean_vertices(family), DOMAIN["length_m"], DOMAIN["height_m"], 0.0) == [], name


def test_the_engine_runs_every_kind():
    """One realization of each generated family through the embedded MPM for 2 s: it finishes, and no
    point leaves the domain or sinks below the floor."""
    config = copy.deepcopy(PRETRAIN)
    mpm = config["mpm"] | {"duration_s": 2.0}
    for name in sorted(FAMILIES):
        case = f"{name}_f1"
        states, statuses = simulate_end_states(CaseInputs.from_config(config, case), [0], mpm, 21)
        assert statuses == ["ok"], (case, statuses)
        final = states[0].final
        assert final[:, 1].min() >= 0.0 and final[:, 0].min() >= 0.0 and final[:, 0].max() <= DOMAIN["length_m"]


def test_a_generated_family_names_a_missing_or_unknown_parameter():
    config = load_yaml(REPO / "config" / "pretrain_general.yaml")
    params = config["geometry"]["families"]["gen_embankment"]["params"]
    del params["height_m"]
    params["heigth_m"] = 5.0
    with pytest.raises(ValueError) as error:
        validate_config(config)
    assert "'geometry.families.gen_embankment.params': lacks 'height_m'" in str(error.value)
    assert "'geometry.families.gen_embankment.params.heigth_m': generator 'embankment' has no such parameter" in str(
        error.value
    )
    with pytest.raises(GeneratorError, match="params lacks .*height_m"):
        generate_vertices("gen_embankment", {"generator": "embankment", "params": {}}, np.random.default_rng(0))
