"""The end-state surrogate shipped with the package: it serves the default config, agrees with fresh
MPM runs of case 1 it never saw, keeps standing slopes standing, and gives the same table on every run."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import torch
from conftest import REPO

from rgns.config import load_config
from rgns.montecarlo.runs import RunSettings, run_realizations
from rgns.scene.realizations import CaseInputs, Realization, draw_realization
from rgns.surrogates.endstate.card import check_serves
from rgns.surrogates.endstate.model import load_model
from rgns.surrogates.shipped import MODELS, ShippedModelError, read_card
from rgns.surrogates.validation import r_squared

DEFAULT = load_config(REPO / "config" / "config.yaml")
METRICS = ("runout_m", "volume_m2", "influence_m")


@pytest.fixture(scope="module")
def shipped():
    torch.set_num_threads(1)
    return load_model(MODELS / "endstate.pt")


def _settings(simulator: str, batch_size: int = 16) -> RunSettings:
    section = copy.deepcopy(DEFAULT["montecarlo"]) | {"simulator": simulator, "batch_size": batch_size}
    return RunSettings.from_params({"montecarlo": section, "mpm": DEFAULT["mpm"], "metrics": DEFAULT["metrics"]})


def test_the_shipped_model_serves_the_default_config_and_refuses_another_scale():
    card = read_card(MODELS, "endstate_card.json")
    check_serves(card, DEFAULT)
    paper = load_config(REPO / "config" / "paper.yaml")
    with pytest.raises(ShippedModelError, match=r"domain.length_m is 240.0, the model was trained at 80.0"):
        check_serves(card, paper)


def test_the_shipped_model_agrees_with_fresh_mpm_runs_of_case_1(shipped):
    """16 case-1 realizations beyond those the Monte Carlo and the validation use (drawn from the
    default seed; the model trained on another seed's): R² at least 0.9 for R, V and I (the issue's
    target; measured 0.988 / 0.995 / 0.950), and the mean runout within 5 % (measured −0.2 %)."""
    inputs = CaseInputs.from_config(DEFAULT, "case1")
    indices = list(range(400, 416))
    mpm = run_realizations(inputs, indices, _settings("mpm"))
    surrogate = run_realizations(inputs, indices, _settings("endstate"), shipped)
    for key in METRICS:
        truth, predicted = mpm[key].to_numpy(float), surrogate[key].to_numpy(float)
        print(key, r_squared(truth, predicted), predicted.mean() / truth.mean() - 1)
        assert r_squared(truth, predicted) >= 0.9, key
    assert abs(surrogate["runout_m"].mean() / mpm["runout_m"].mean() - 1) <= 0.05


def test_slopes_mpm_leaves_standing_stay_put(shipped):
    """The test cases' long slope (39.8° face) at φ 45 ± 2° and at a uniform 50° and 60°: where MPM
    leaves a realization standing (checked here), the model runs nothing out: R = I = 0, and at most
    two cells' worth of surface points moved 1 m (V ≤ 2 m² of the 240 m² slope; measured 0–1 m²,
    MPM 0–1 m²); the uniform slopes (limit equilibrium: stable) move no point 1 m."""
    config = copy.deepcopy(DEFAULT)
    config["sets"]["case4"][0] |= {"friction_mean_deg": 45.0, "friction_std_deg": 2.0}
    inputs = CaseInputs.from_config(config, "case4")
    mpm = run_realizations(inputs, [0, 1, 2, 3], _settings("mpm"))
    standing = mpm.index[mpm["runout_m"] == 0.0]
    assert len(standing) >= 2
    table = run_realizations(inputs, [0, 1, 2, 3], _settings("endstate"), shipped).loc[standing]
    print(mpm[list(METRICS)], table[list(METRICS)])
    assert (table["runout_m"] == 0.0).all() and (table["influence_m"] == 0.0).all()
    assert (table["volume_m2"] <= 2 * config["mesh"]["cell_size_m"] ** 2).all()
    base = draw_realization(inputs, 0)
    for friction in (50.0, 60.0):
        uniform = Realization(0, base.scene, np.full(len(base.friction_deg), friction))
        final = shipped.predict([base.scene.positions], [uniform.friction_deg])[0]
        assert np.linalg.norm(final - base.scene.positions, axis=1).max() < 1.0, friction


def test_two_monte_carlo_runs_with_the_shipped_model_give_identical_tables(shipped):
    inputs = CaseInputs.from_config(DEFAULT, "case1")
    first = run_realizations(inputs, list(range(16)), _settings("endstate"), shipped)
    again = run_realizations(inputs, list(range(16)), _settings("endstate"), load_model(MODELS / "endstate.pt"))
    assert first.equals(again)
