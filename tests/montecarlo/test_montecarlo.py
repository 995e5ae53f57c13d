"""Monte Carlo realizations: drawn like the sets' realizations, batched by index, measured."""

from dataclasses import replace

import numpy as np
import pytest
from conftest import TINY_CONFIG

from rgns.config import load_config
from rgns.montecarlo.runs import MonteCarloError, RunSettings, batches_of, run_realizations
from rgns.scene.fields import FieldGrid, friction_field
from rgns.scene.geometry import build_scene
from rgns.scene.realizations import MEAN_FIELD, CaseInputs, draw_realization, mean_field_realization


@pytest.fixture(scope="module")
def tiny():
    config = load_config(TINY_CONFIG)
    return config, CaseInputs.from_config(config, "case1")


def test_monte_carlo_realization_i_is_realization_i_of_the_set(tiny):
    config, inputs = tiny
    for index in (0, 1, 5):
        realization = draw_realization(inputs, index)
        scene = build_scene(
            "case1",
            index,
            inputs.family_name,
            inputs.family,
            config["domain"],
            config["mesh"],
            config["geometry"],
            config["seed"],
        )
        grid = FieldGrid.covering(
            config["domain"]["length_m"], config["domain"]["height_m"], config["mesh"]["cell_size_m"]
        )
        field = friction_field(
            config["seed"],
            "case1",
            index,
            config["sets"]["case1"][0],
            grid,
            config["random_field"]["method"],
            tuple(config["random_field"]["friction_bounds_deg"]),
            scene.positions,
        )
        np.testing.assert_array_equal(realization.scene.positions, scene.positions)
        np.testing.assert_array_equal(realization.friction_deg, field.friction_deg)
    assert not np.array_equal(draw_realization(inputs, 0).friction_deg, draw_realization(inputs, 1).friction_deg)


def test_the_mean_field_realization_has_uniform_mean_friction_and_the_mean_geometry(tiny):
    config, inputs = tiny
    realization = mean_field_realization(inputs)
    assert realization.index == MEAN_FIELD
    assert np.all(realization.friction_deg == config["sets"]["case1"][0]["friction_mean_deg"])
    assert realization.scene.vertices.tolist() == [[0, 0], [6, 0], [6, 5], [0, 5]]


@pytest.mark.parametrize(
    "indices, size, aligned, batches",
    [
        ([0, 1, 2, 3, 4], 2, True, [[0, 1], [2, 3], [4]]),
        ([3, 4, 5], 2, True, [[3], [4, 5]]),  # a chunk starting mid-batch keeps the global alignment
        ([MEAN_FIELD], 4, True, [[MEAN_FIELD]]),
        ([907, 12, 4410, 3, 88], 2, False, [[907, 12], [4410, 3], [88]]),  # the MPM batches scattered pairs
        ([0, MEAN_FIELD, 1, 2], 2, False, [[0], [MEAN_FIELD], [1, 2]]),  # in order, the mean field alone
    ],
)
def test_learned_simulators_batch_aligned_on_the_index_and_the_mpm_batches_in_order(indices, size, aligned, batches):
    assert batches_of(indices, size, aligned) == batches


def test_the_embedded_mpm_simulator_collapses_the_column_and_measures_it(tiny):
    config, inputs = tiny
    params = {
        "montecarlo": config["montecarlo"] | {"simulator": "mpm", "batch_size": 2, "duration_s": 2.0},
        "mpm": config["mpm"],
        "metrics": config["metrics"],
    }
    table = run_realizations(inputs, [0, 1, MEAN_FIELD], RunSettings.from_params(params))
    assert list(table["index"]) == [0, 1, MEAN_FIELD] and (table["status"] == "ok").all()
    assert (table["runout_m"] > 0.5).all() and (table["volume_m2"] > 1.0).all()  # a 5 m column at 30 degrees falls
    np.testing.assert_allclose(table[["potential_final", "kinetic_final", "dissipated_final"]].sum(axis=1), 1.0)
    assert (table["potential_final"] < 1.0).all()


def test_a_gns_run_without_a_model_is_refused(tiny):
    config, inputs = tiny
    params = {
        "montecarlo": config["montecarlo"] | {"simulator": "gns"},
        "mpm": config["mpm"],
        "metrics": config["metrics"],
    }
    with pytest.raises(MonteCarloError, match="needs a trained model"):
        run_realizations(inputs, [0], RunSettings.from_params(params))


def test_frames_kept_do_not_change_the_table(tiny):
    config, inputs = tiny
    tables = {}
    for keep in ("ends", "all"):
        params = {
            "montecarlo": config["montecarlo"] | {"simulator": "mpm", "duration_s": 1.0, "keep_frames": keep},
            "mpm": config["mpm"],
            "metrics": config["metrics"],
        }
        tables[keep] = run_realizations(inputs, [0], RunSettings.from_params(params))
    assert tables["ends"].equals(tables["all"])


def test_the_screen_counts_a_clearly_stable_realization_as_no_failure_and_simulates_the_others(tiny):
    config, _ = tiny
    gentle = {
        "vertices": [
            {"x_m": 0.0, "y_m": 0.0},
            {"x_m": 20.0, "y_m": 0.0},
            {"x_m": 10.0, "y_m": 5.0},
            {"x_m": 0.0, "y_m": 5.0},
        ]
    }  # a 26.6-degree face
    stable = replace(
        CaseInputs.from_config(config, "case1"),
        family=gentle,
        group=config["sets"]["case1"][0] | {"friction_mean_deg": 50.0, "friction_std_deg": 2.0},
    )
    steep = CaseInputs.from_config(config, "case1")  # the vertical column: FS far below 1
    screen = {"enabled": True, "threshold": 1.2}
    params = {
        "montecarlo": config["montecarlo"] | {"simulator": "mpm", "duration_s": 1.0, "screen": screen},
        "mpm": config["mpm"],
        "metrics": config["metrics"],
    }
    table = run_realizations(stable, [0, 1], RunSettings.from_params(params))
    assert (table["status"] == "screened").all() and (table["factor_of_safety"] > 2.0).all()
    assert (table[["runout_m", "volume_m2", "influence_m", "displaced_fraction"]] == 0).all().all()
    assert table["front_x_m"].isna().all() and (table["potential_final"] == 1.0).all()
    table = run_realizations(steep, [0], RunSettings.from_params(params))
    assert table["status"].tolist() == ["ok"] and table["factor_of_safety"].iloc[0] < 0.5
    assert table["runout_m"].iloc[0] > 0.5
