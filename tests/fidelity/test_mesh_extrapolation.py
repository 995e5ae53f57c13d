"""The corrected hazard carried to the converged mesh: known answers of a mesh error that is exactly C h^p."""

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from rgns.fidelity.mesh_extrapolation import converged, distance_intervals, model_resamples, modelled_crossing
from rgns.fidelity.multifidelity import MultiFidelityError, mean_predicted, predicted_exceedance
from rgns.fidelity.outputs import correct, write_multifidelity
from rgns.hazard.exceedance import distance_grid

ORDER = 1.3
SETTINGS = {
    "confidence": 0.95,
    "high_cell_size_m": 0.5,
    "coarse_cell_size_m": 1.0,
    "mesh_order": {"runout_m": [1.0, ORDER, 1.6], "volume_m2": [1.0, ORDER, 1.6], "influence_m": [1.0, ORDER, 1.6]},
    "exceedance_probabilities": [0.5, 0.1],
    "domain": {"length_m": 80.0},
    "resolution_m": 0.5,
    "thresholds": [0.9, 0.5, 0.1, 0.01],
}
COST = {"low_s": 0.01, "high_s": 20.0}


def table(runout: np.ndarray) -> pd.DataFrame:
    """A Monte Carlo table: toe at 30 m, the front R beyond it, the back scarp 0.4 R behind the crest at 20 m."""
    return pd.DataFrame(
        {
            "index": np.arange(runout.size),
            "status": "ok",
            "runout_m": runout,
            "volume_m2": 10 * runout,
            "influence_m": 0.4 * runout,
            "front_x_m": 30.0 + runout,
            "rear_x_m": 20.0 - 0.4 * runout,
        }
    )


def at_mesh(converged_runout: np.ndarray, h: float, short_m: float = 2.0) -> np.ndarray:
    """The runout a mesh of cell h gives: the converged one, short by short_m (h / 1 m)^p."""
    return converged_runout - short_m * h**ORDER


def chain(
    seed: int, n_low: int = 400, n_pairs: int = 24
) -> tuple[np.ndarray, pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    truth = np.random.default_rng(seed).gamma(6.0, 1.5, n_low)
    cheap = at_mesh(truth, 1.0) + np.random.default_rng(seed + 1).normal(0.0, 0.3, n_low)  # a noisy 1 m surrogate
    return truth, table(cheap), table(at_mesh(truth[:n_pairs], 0.5)), table(at_mesh(truth[:n_pairs], 1.0))


def extrapolate(low: pd.DataFrame, high: pd.DataFrame, coarse: pd.DataFrame, settings: dict = SETTINGS) -> dict:
    return converged(low, high, coarse, settings, correct(low, high, settings, COST))


def test_an_error_of_exactly_c_h_to_the_p_is_removed_from_means_distances_and_zones():
    truth, low, high, coarse = chain(0)
    record = extrapolate(low, high, coarse)
    runout = record["means"]["runout_m"]
    step = 2.0 * 0.5**ORDER  # what the 0.5 m mesh misses
    assert runout["mesh_step"] == pytest.approx(step, rel=1e-9)
    assert runout["estimate"] - runout["accurate"] == pytest.approx(step, rel=1e-9)
    assert runout["lower"] <= truth.mean() <= runout["upper"]
    assert not runout["accurate_lower"] <= truth.mean() <= runout["accurate_upper"]  # 0.5 m alone misses it
    assert runout["mesh_step_range"][0] < step < runout["mesh_step_range"][1]  # the order's interval
    assert record["means"]["volume_m2"]["mesh_step"] == pytest.approx(10 * step, rel=1e-9)
    for p, entry in record["distances"]["runout_m"].items():
        assert entry["mesh_step"] == pytest.approx(step, abs=1e-6)  # every quantile moves by the same step
        assert entry["lower"] <= np.quantile(truth, 1 - float(p)) <= entry["upper"]
    zoning = record["zoning"]
    assert zoning["front_step_m"] == pytest.approx(step) and zoning["rear_step_m"] == pytest.approx(-0.4 * step)
    assert record["distances"]["influence_m"]["0.5"]["mesh_step"] == pytest.approx(0.4 * step)
    x, accurate = np.array(zoning["x_m"]), np.array(correct(low, high, SETTINGS, COST)["zoning"]["corrected"])
    reach = {
        name: x[np.nonzero(np.array(p) >= 0.1)[0][-1]]
        for name, p in (("converged", zoning["probability"]), ("accurate", accurate))
    }
    assert reach["converged"] - reach["accurate"] == pytest.approx(step, abs=0.5)  # the profile's resolution


def test_the_converged_mean_interval_covers_the_truth_within_3_se_of_95_percent_over_replicates():
    """200 replicates: the converged mean's interval at the order's point value (sampling and weights alone)
    covers the converged mean within 3 standard errors of 95 %, on either side (an interval that always covers
    is too wide); the report's interval, widened over the order's interval, covers at least as often."""
    sampling, report = [], []
    for seed in range(200):
        truth, low, high, coarse = chain(1000 + seed, n_low=200, n_pairs=16)
        runout = converged(low, high, coarse, SETTINGS, {"exceedance": {}})["means"]["runout_m"]
        lower, upper = runout["interval_at_order"]
        assert runout["lower"] <= lower <= runout["estimate"] <= upper <= runout["upper"]
        sampling.append(lower <= 6.0 * 1.5 <= upper)  # the gamma's mean
        report.append(runout["lower"] <= 6.0 * 1.5 <= runout["upper"])
    se = np.sqrt(0.95 * 0.05 / len(sampling))
    assert abs(np.mean(sampling) - 0.95) <= 3 * se, np.mean(sampling)
    assert np.mean(report) >= np.mean(sampling)


def test_the_converged_distance_intervals_cover_the_truth_within_3_se_of_95_percent_over_replicates():
    """The joint bootstrap's 95 % intervals of the runout exceeded with P 0.5 and 0.1 (the corrected curve's
    distance and the quantile step from the same resample, at the order's interval) hold the converged
    population's quantiles in 200 replicates within 3 standard errors of 95 %, on either side: neither too
    narrow nor, as the curve's band and the step's interval summed end to end were, covering every time."""
    probabilities = [0.5, 0.1]
    answers = stats.gamma(6.0, scale=1.5).ppf(1.0 - np.array(probabilities))  # chain()'s converged runout
    orders = np.array([ORDER, *SETTINGS["mesh_order"]["runout_m"][::2]])  # [value, low, high]
    covered = []
    for seed in range(200):
        _, low, high, coarse = chain(3000 + seed, n_low=64, n_pairs=16)
        values = [t["runout_m"].to_numpy(float) for t in (high, coarse, low)]
        d_m = distance_grid(np.concatenate([values[0], values[2]]))[::2]  # every 0.5 m keeps the test quick
        joint = distance_intervals(*values, d_m, probabilities, 2.0, orders, 0.95, seed)
        lower, upper = (
            joint.lower.min(axis=0),
            joint.upper.max(axis=0),
        )  # the envelope over the order's interval, as reported
        covered.append((lower <= answers) & (answers <= upper))
    se = np.sqrt(0.95 * 0.05 / len(covered))
    assert np.all(np.abs(np.mean(covered, axis=0) - 0.95) <= 3 * se), np.mean(covered, axis=0)


def test_model_resamples_reach_the_tail_as_often_as_new_pairs_would():
    """40 samples of 32 pairs among 2,000 cheap runs, h = 1 + l + N(0, 0.5²): the model-based resamples' pairs
    pass the law's 1 % quantile t at the population's rate (means within 3 SE), in the samples that no pair
    passed too (measured: 0.99 % against 0.94 % in the 31 such samples), where resampling the pairs themselves
    never passes it, and drawing the pairs' own cheap values (as first written) passed it at 0.47 %: the tail
    the sample lacked stayed missing, and the tail distances' intervals covered 85 % on fresh seeds. The
    resamples keep the fit's line, both meshes' residuals drawn jointly, and each stratum's cheap values."""
    threshold = 11.0 + stats.norm.ppf(0.99) * np.hypot(2.0, 0.5)
    law, resampled, unreached = [], [], []
    for seed in range(40):
        rng = np.random.default_rng(seed)
        cheap = rng.normal(10.0, 2.0, 2000)
        high = 1.0 + cheap[:32] + rng.normal(0.0, 0.5, 32)
        strata = (cheap > np.median(cheap)).astype(int)
        drawn = model_resamples(high, high - 1.0, cheap, np.full(32, 1 / 32), strata, 2000, rng)
        law.append(stats.norm.sf(threshold, 1.0 + cheap, 0.5).mean())
        resampled.append((drawn.high > threshold).mean())
        if (high <= threshold).all():
            unreached.append((resampled[-1], law[-1]))
        np.testing.assert_allclose(drawn.coarse, drawn.high - 1.0, atol=1e-9)
        assert (np.isin(drawn.cheap, cheap[strata == 1]) == (strata[None, :32] == 1)).all()
        assert np.polyfit(drawn.cheap.ravel(), drawn.high.ravel(), 1) == pytest.approx(
            np.polyfit(cheap[:32], high, 1), abs=0.05
        )
    difference = np.array(resampled) - np.array(law)
    assert abs(difference.mean()) < 3 * difference.std(ddof=1) / np.sqrt(difference.size), (
        np.mean(resampled),
        np.mean(law),
    )
    rate, expected = np.mean(unreached, axis=0)
    assert len(unreached) >= 10 and 0.7 < rate / expected < 1.4, (len(unreached), rate, expected)


def test_a_modelled_tail_follows_a_residual_spread_that_grows_with_the_cheap_value():
    """32 pairs and 10,000 cheap runs, h = 1 + l + s(l) ε with s growing with l as case 1's real pairs' does:
    each mesh's modelled curve falls to P at the population's 1 − P quantile within 3 SE over 100 replicates,
    the 1 % tail included (with one spread for all it fell 0.34 ± 0.04 m short there)."""
    rng = np.random.default_rng(20261126)

    def spread(cheap: np.ndarray) -> np.ndarray:
        return np.clip(0.1 + 0.12 * (cheap - 6.0), 0.05, None)

    targets = np.array([0.5, 0.1, 0.01])
    cheap = rng.normal(10.0, 2.0, 2_000_000)
    truth = np.quantile(1.0 + cheap + spread(cheap) * rng.standard_normal(cheap.size), 1.0 - targets)
    errors = []
    for _ in range(100):
        low = rng.normal(10.0, 2.0, 10_000)
        high = 1.0 + low[:32] + spread(low[:32]) * rng.standard_normal(32)
        found = modelled_crossing(high, low[:32], low[32:, None], targets, (0.0, 40.0), np.full(32, 1 / 32))
        errors.append(found - truth)
    mean, se = np.mean(errors, axis=0), np.std(errors, axis=0, ddof=1) / np.sqrt(len(errors))
    assert np.all(np.abs(mean) < 3 * se), (mean, se)


def test_the_modelled_crossing_is_where_the_modelled_curve_falls_to_p_within_a_micrometre():
    """Bisection then false position: over 50 resamples of pairs whose relation bends and whose spread grows, and
    the 1 %, 0.1 % and 99.99 % levels, the modelled curve is above P a micrometre before each crossing found and
    at most P a micrometre after it; one the curve never reaches is inf, one it starts below is the bracket's
    lower end. (A crossing left at the 12 bisections' 1 cm would fail the first.)"""
    rng = np.random.default_rng(7)
    low = rng.gamma(6.0, 1.4, 5000)
    cheap = np.broadcast_to(low[:32], (50, 32))
    high = 0.3 + 1.05 * cheap + 0.03 * (cheap - 8.0) ** 2 + rng.normal(0.0, 1.0, (50, 32)) * (0.2 + 0.05 * cheap)
    weights = np.full((50, 32), 1 / 32)
    targets = np.array([0.5, 0.1, 0.01, 0.001, 0.9999])
    found = modelled_crossing(high, cheap, low[32:, None], targets, (0.0, 60.0), weights)

    def curve(at: np.ndarray) -> np.ndarray:
        g_pairs = predicted_exceedance(high, cheap, cheap, at[:, None, :], weights)
        return mean_predicted(g_pairs, high, cheap, low[32:], at[:, None, :], weights)

    assert np.isfinite(found).all()
    assert (curve(found - 1e-6) > targets).all() and (curve(found + 1e-6) <= targets).all()
    never = modelled_crossing(high[:2], cheap[:2], low[32:, None], np.array([1e-12]), (0.0, 5.0), weights[:2])
    starts_below = modelled_crossing(high[:2], cheap[:2], low[32:, None], np.array([0.5]), (40.0, 60.0), weights[:2])
    assert np.isinf(never).all() and (starts_below == 40.0).all()


def test_without_the_order_or_the_coarse_pairs_nothing_is_extrapolated(tmp_path):
    _, low, high, coarse = chain(2, n_low=60, n_pairs=8)
    outputs = {"json": str(tmp_path / "m.json"), "figure": str(tmp_path / "m.png")}
    assert "converged" in write_multifidelity(low, high, SETTINGS, COST, outputs, "case1", coarse=coarse)
    assert "converged" not in write_multifidelity(low, high, SETTINGS, COST, outputs, "case1")
    assert "converged" not in write_multifidelity(
        low, high, SETTINGS | {"mesh_order": None}, COST, outputs, "case1", coarse=coarse
    )


@pytest.mark.parametrize(
    "change, message",
    [
        ({"coarse_cell_size_m": 0.5}, "must be coarser than montecarlo.fidelity.high_cell_size_m"),
        ({"mesh_order": {"runout_m": [1.5, 1.3, 1.6]}}, "montecarlo.fidelity.mesh_order.runout_m [1.5, 1.3, 1.6]"),
    ],
)
def test_bad_settings_are_named(change, message):
    _, low, high, coarse = chain(3)
    with pytest.raises(MultiFidelityError, match=message.replace("[", r"\[").replace("]", r"\]")):
        extrapolate(low, high, coarse, SETTINGS | change)


def test_pairs_unfinished_at_the_coarse_mesh_leave_the_chain():
    _, low, high, coarse = chain(4)
    coarse.loc[[0, 5], "status"] = "diverged: non-finite"
    assert extrapolate(low, high, coarse)["n_pairs"] == 22


def test_a_quantity_without_an_order_keeps_the_accurate_meshs_value_and_its_ends_stay():
    _, low, high, coarse = chain(5, n_low=60, n_pairs=8)
    settings = SETTINGS | {"mesh_order": {"runout_m": [1.0, ORDER, 1.6], "volume_m2": None, "influence_m": None}}
    record = converged(low, high, coarse, settings, correct(low, high, settings, COST))
    volume = record["means"]["volume_m2"]
    assert volume["mesh_step"] is None and volume["estimate"] == volume["accurate"]
    assert set(record["distances"]) == {"runout_m"} and record["zoning"]["rear_step_m"] == 0.0
    assert record["means"]["runout_m"]["mesh_step"] == pytest.approx(2.0 * 0.5**ORDER)


def test_the_plain_mpm_route_extrapolates_the_pairs_alone(tmp_path):
    """An unrelated cheap route: the converged mean is the pairs' own 0.5 m mean plus their mesh step, exact for
    an error C h^p, and a tail the pairs cannot bound stays open above."""
    truth, low, high, coarse = chain(5, n_low=400, n_pairs=40)
    columns = ["runout_m", "volume_m2", "influence_m", "front_x_m", "rear_x_m"]
    low[columns] = low[columns].to_numpy()[np.random.default_rng(5).permutation(len(low))]
    settings = SETTINGS | {"exceedance_probabilities": [0.5, 0.01]}
    outputs = {"json": str(tmp_path / "m.json"), "figure": str(tmp_path / "m.png")}
    record = write_multifidelity(low, high, settings, {"low_s": 0.01, "high_s": 20.0}, outputs, "c", coarse=coarse)
    assert record["route_applied"] == "plain MPM"
    mean = record["converged"]["means"]["runout_m"]
    assert mean["accurate"] == pytest.approx(high["runout_m"].mean(), abs=1e-9)
    assert mean["estimate"] == pytest.approx(truth[:40].mean(), abs=1e-9)
    tail = record["converged"]["distances"]["runout_m"]["0.01"]
    assert tail["upper"] is None and tail["lower"] is not None


def test_the_best_estimate_figure_draws_the_records_own_curves_and_converged_distances():
    """What the page's answer figure shows, read back from its axes: on each curve panel the corrected curve and
    its band are the record's, each converged distance a marker at (estimate, P) with the record's interval, and
    a corrected distance at the accurate mesh lies on the drawn corrected line (the line is read as the
    estimator reads it); the zoning panel's converged line is the record's converged zoning."""
    from rgns.fidelity.outputs import best_estimate_figure

    _, low, high, coarse = chain(6, n_low=200, n_pairs=16)
    record = write_multifidelity(
        low, high, SETTINGS, COST, {"json": "/dev/null", "figure": "/dev/null"}, "c", coarse=coarse
    )
    figure = best_estimate_figure(record, "c")
    runout_axis, _, zoning_axis = figure.axes
    curve = record["exceedance"]["runout_m"]
    (corrected,) = [line for line in runout_axis.get_lines() if line.get_label() == "multi-fidelity corrected"]
    np.testing.assert_array_equal(corrected.get_xdata(), curve["d_m"])
    np.testing.assert_array_equal(corrected.get_ydata(), curve["corrected"])
    assert corrected.get_drawstyle() == "default"  # linear between grid distances, not steps
    for p, entry in curve["distances"].items():  # the drawn line crosses P at the record's corrected distance
        assert np.interp(entry["corrected"], corrected.get_xdata(), corrected.get_ydata()) == pytest.approx(float(p))
    markers = [c for c in runout_axis.containers if c.lines[0].get_marker() == "D"]
    drawn = sorted((float(c.lines[0].get_xdata()[0]), float(c.lines[0].get_ydata()[0])) for c in markers)
    expected = sorted((e["estimate"], float(p)) for p, e in record["converged"]["distances"]["runout_m"].items())
    np.testing.assert_allclose(drawn, expected)
    (band,) = runout_axis.collections[:1]
    vertices = band.get_paths()[0].vertices
    assert vertices[:, 1].min() == pytest.approx(min(curve["lower"])) and vertices[:, 1].max() == pytest.approx(
        max(curve["upper"])
    )
    (line,) = [line for line in zoning_axis.get_lines() if line.get_label() == "converged mesh"]
    np.testing.assert_array_equal(line.get_ydata(), record["converged"]["zoning"]["probability"])
