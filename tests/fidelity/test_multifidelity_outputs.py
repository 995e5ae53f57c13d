"""The multi-fidelity correction of a case's tables: what the rule multifidelity writes."""

import json

import numpy as np
import pandas as pd
import pytest

from rgns.fidelity.multifidelity import MultiFidelityError
from rgns.fidelity.outputs import correct, write_multifidelity
from rgns.hazard.exceedance import distance_at
from rgns.hazard.statistics import ZONE_LEVELS

SETTINGS = {
    "confidence": 0.95,
    "high_cell_size_m": 0.5,
    "exceedance_probabilities": [0.5, 0.1],
    "domain": {"length_m": 60.0},
    "resolution_m": 0.5,
    "thresholds": [0.9, 0.5, 0.1, 0.01],
    "target_half_width_m": 0.5,
}
COST = {"low_s": 2.0, "high_s": 20.0}


def table(runout: np.ndarray, status: str = "ok") -> pd.DataFrame:
    """A Monte Carlo table: toe at 30 m, the front R beyond it, the back scarp 0.4 R behind the crest at 20 m."""
    n = runout.size
    return pd.DataFrame(
        {
            "index": np.arange(n),
            "status": status,
            "runout_m": runout,
            "volume_m2": 10 * runout,
            "influence_m": 0.4 * runout,
            "front_x_m": 30.0 + runout,
            "rear_x_m": 20.0 - 0.4 * runout,
        }
    )


def test_a_shifted_cheap_route_is_corrected_to_the_accurate_mean():
    rng = np.random.default_rng(0)
    accurate = rng.gamma(4.0, 2.0, 200)
    cheap = accurate - 2.0  # 2 m short everywhere, perfectly correlated
    record = correct(table(cheap), table(accurate[:20]), SETTINGS, COST)
    runout = record["means"]["runout_m"]
    assert runout["estimate"] == pytest.approx(accurate.mean(), abs=1e-9)  # the whole pool's, not the 20 pairs'
    assert runout["bias"] == pytest.approx(-2.0)
    assert runout["lower"] <= accurate.mean() <= runout["upper"]
    assert not runout["lower"] <= runout["low_mean"] <= runout["upper"]
    curve = record["exceedance"]["runout_m"]
    d = np.array(curve["d_m"])
    truth = (accurate[:, None] > d[None, :]).mean(0)
    assert np.abs(np.array(curve["corrected"]) - truth).max() < np.abs(np.array(curve["uncorrected"]) - truth).max()
    assert record["allocation"]["speedup_at_equal_error"] > 5.0  # correlation 1, cost ratio 10
    assert record["allocation"]["target"]["n_high"] >= 2


def test_a_perfect_cheap_route_changes_nothing():
    runout = np.random.default_rng(1).gamma(4.0, 2.0, 50)
    record = correct(table(runout), table(runout[:10]), SETTINGS, COST)
    zoning = record["zoning"]
    assert np.allclose(zoning["corrected"], zoning["uncorrected"])
    assert record["zoning"]["zones_corrected"] == record["zoning"]["zones_uncorrected"]
    for curve in record["exceedance"].values():
        assert np.allclose(curve["corrected"], curve["uncorrected"])


def test_unfinished_realizations_leave_their_pairs(tmp_path):
    runout = np.linspace(1.0, 9.0, 12)
    low, high = table(runout), table(runout[:4] + 1.0)
    low.loc[1, "status"] = "diverged: left the domain"
    high.loc[2, "status"] = "diverged: non-finite"
    outputs = {"json": str(tmp_path / "m.json"), "figure": str(tmp_path / "m.png")}
    record = write_multifidelity(low, high, SETTINGS, COST, outputs, "case1")
    assert (record["n_paired"], record["n_low"]) == (2, 11)
    assert json.loads((tmp_path / "m.json").read_text())["n_paired"] == 2
    assert (tmp_path / "m.png").stat().st_size > 10_000


def test_with_a_separate_control_the_monte_carlo_keeps_its_own_means_and_curves(tmp_path):
    """montecarlo.fidelity.cheap tuned: the correction runs on the control's table; the record keeps the
    Monte Carlo's own means, curves and distances beside it, and the estimate does not depend on them."""
    rng = np.random.default_rng(4)
    accurate = rng.gamma(4.0, 2.0, 100)
    control, simulator = accurate - 0.5 + rng.normal(0, 0.2, 100), 0.8 * accurate
    outputs = {"json": str(tmp_path / "m.json"), "figure": str(tmp_path / "m.png")}
    record = write_multifidelity(
        table(control), table(accurate[:16]), SETTINGS, COST, outputs, "case1", simulator=table(simulator)
    )
    alone = correct(table(control), table(accurate[:16]), SETTINGS, COST)
    assert record["means"] == alone["means"] and not record["cheap_is_simulator"]
    assert record["simulator_means"]["runout_m"] == pytest.approx(simulator.mean())
    curve = record["exceedance"]["runout_m"]
    # the Monte Carlo's distances by the one estimator (the empirical curve's crossing: a quantile of numpy's)
    assert curve["simulator"][0] == 1.0 and curve["distances"]["0.5"]["simulator"] == pytest.approx(
        np.quantile(simulator, 0.5, method="interpolated_inverted_cdf"), abs=1e-12
    )
    plain = write_multifidelity(table(control), table(accurate[:16]), SETTINGS, COST, outputs, "case1")
    assert plain["cheap_is_simulator"] and plain["simulator_means"]["runout_m"] == pytest.approx(control.mean())


def test_too_few_finished_pairs_is_a_clear_error():
    runout = np.linspace(1.0, 9.0, 12)
    with pytest.raises(MultiFidelityError, match="1 realizations finished at both fidelities"):
        correct(table(runout), table(runout[:1]), SETTINGS, COST)


def test_corrected_exceedance_curves_are_probabilities_that_never_rise():
    """A noisy cheap route (correlation well below 1): the control-variate curve, left alone, would rise
    in places; the written one and its band are non-increasing and within [0, 1]."""
    rng = np.random.default_rng(3)
    accurate = rng.gamma(4.0, 2.0, 120)
    cheap = 0.7 * accurate + rng.normal(0.0, 2.0, 120)
    record = correct(table(cheap), table(accurate[:12]), SETTINGS, COST)
    for key in ("runout_m", "influence_m"):
        curve = record["exceedance"][key]
        for name in ("corrected", "lower", "upper"):
            values = np.array(curve[name])
            assert np.all(np.diff(values) <= 0.0) and values.min() >= 0.0 and values.max() <= 1.0


def test_a_tail_the_cheap_route_misses_leaves_the_distance_interval_closed():
    """Two of the 12 pairs run to 22 and 20 m where the cheap route says about 5 m: the band's upper curve
    stays above 0.1 past the largest run (a curve cut there left the upper end of the runout exceeded with
    P 0.1 open); the curves run on, so that end is a distance, beyond the far runs."""
    rng = np.random.default_rng(3)
    accurate = rng.gamma(4.0, 2.0, 120)
    cheap = accurate + rng.normal(0.0, 0.3, 120)
    accurate[:2] = [22.0, 20.0]
    curve = correct(table(cheap), table(accurate[:12]), SETTINGS, COST)["exceedance"]["runout_m"]
    upper = distance_at(curve["d_m"], curve["upper"], 0.1)
    assert upper is not None and upper > 22.0


def test_corrected_zones_rise_to_one_maximum_and_fall():
    """A noisy cheap route whose fronts and scarps scatter: the corrected P(x affected) is built from the
    rearranged P(front ≥ x) and P(scarp > x), so it never dips and rises again, and the zones
    (ordered by level) form no island; within [0, 1] and inside its band."""
    for seed in range(5):
        rng = np.random.default_rng(seed)
        accurate = rng.gamma(4.0, 2.0, 160)
        cheap = 0.7 * accurate + rng.normal(0.0, 2.0, 160)
        zoning = correct(table(cheap), table(accurate[:12]), SETTINGS, COST)["zoning"]
        p = np.array(zoning["corrected"])
        peak = int(np.argmax(p))
        assert np.all(np.diff(p[: peak + 1]) >= 0.0) and np.all(np.diff(p[peak:]) <= 0.0), seed
        assert p.min() >= 0.0 and p.max() <= 1.0
        assert np.all(np.array(zoning["lower"]) <= p) and np.all(p <= np.array(zoning["upper"]))
        ranks = np.array([ZONE_LEVELS.index(zone["level"]) for zone in zoning["zones_corrected"]])
        top = int(np.argmin(ranks))  # 0 = extremely high
        assert np.all(np.diff(ranks[: top + 1]) < 0) and np.all(np.diff(ranks[top:]) > 0), (seed, ranks)


def test_an_uncorrelated_cheap_route_is_replaced_by_the_pairs_alone(tmp_path):
    """The allocation's plain MPM route is applied: with a cheap route unrelated to the MPM, the best estimate is
    the pairs' own mean and share above each distance (a plain MPM Monte Carlo), the tail 40 pairs cannot bound
    is left open above, and the cheap route's own curve stays beside it."""
    rng = np.random.default_rng(7)
    accurate = rng.gamma(4.0, 2.0, 40)
    cheap = rng.permutation(rng.gamma(4.0, 2.0, 400))  # unrelated to the accurate runs
    settings = SETTINGS | {"exceedance_probabilities": [0.5, 0.01]}
    outputs = {"json": str(tmp_path / "m.json"), "figure": str(tmp_path / "m.png")}
    record = write_multifidelity(table(cheap), table(accurate), settings, {"low_s": 0.01, "high_s": 20.0}, outputs, "c")
    assert record["allocation"]["route"] == "plain MPM" and record["route_applied"] == "plain MPM"
    runout = record["means"]["runout_m"]
    assert runout["estimate"] == pytest.approx(accurate.mean(), abs=1e-9)
    assert runout["low_mean"] == pytest.approx(cheap.mean())  # the cheap route's value stays as evidence
    curve = record["exceedance"]["runout_m"]
    d = np.array(curve["d_m"])
    plain = (accurate[:, None] > d[None, :]).mean(0)
    assert np.allclose(curve["corrected"], plain)
    assert np.allclose(curve["uncorrected"], (cheap[:, None] > d[None, :]).mean(0))
    assert curve["distances"]["0.01"].get("open_above") and not curve["distances"]["0.5"].get("open_above")
    assert json.loads((tmp_path / "m.json").read_text())["route_applied"] == "plain MPM"
