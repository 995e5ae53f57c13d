"""Monte Carlo hazard statistics against theory: bands, quantiles, convergence, zoning, figures."""

from __future__ import annotations

import re

import matplotlib.figure
import numpy as np
import pytest
from scipy import stats

from rgns.hazard.plots import plot_convergence, plot_exceedance, plot_zoning
from rgns.hazard.statistics import (
    DEFAULT_THRESHOLDS,
    ZONE_LEVELS,
    Zone,
    affected_probability,
    clopper_pearson,
    convergence,
    exceedance_curve,
    exceedance_distances,
    zone_levels,
    zones,
)

CONFIDENCE = 0.95


def test_exceedance_curve_of_an_exponential_sample_covers_the_analytic_curve():
    n, scale_m = 4000, 10.0
    curve = exceedance_curve(np.random.default_rng(11).exponential(scale_m, n), CONFIDENCE)
    analytic = np.exp(-curve.x / scale_m)
    covered = (curve.lower <= analytic) & (analytic <= curve.upper)
    assert covered.mean() >= 0.90
    assert np.abs(curve.probability - analytic).max() < np.sqrt(np.log(2.0 / 0.05) / (2.0 * n))
    assert curve.x[0] == 0.0 and curve.probability[0] == 1.0 and curve.probability[-1] == 0.0


def test_exceedance_curve_counts_strictly_greater_values_at_given_points():
    values = np.array([0.0, 0.0, 1.0, 2.0, 2.0, 3.0])
    curve = exceedance_curve(values, CONFIDENCE, x=np.array([-1.0, 0.0, 1.0, 2.0, 3.0]))
    np.testing.assert_array_equal(curve.probability, np.array([6, 4, 3, 1, 0]) / 6)
    tail = (1.0 - CONFIDENCE) / 2.0
    assert curve.upper[-1] == pytest.approx(1.0 - tail ** (1.0 / 6.0), rel=1e-12)  # analytic bound at k = 0
    assert curve.lower[0] == pytest.approx(tail ** (1.0 / 6.0), rel=1e-12)  # analytic bound at k = n
    assert curve.lower[-1] == 0.0 and curve.upper[0] == 1.0


def test_clopper_pearson_band_covers_a_binomial_probability_at_least_at_its_confidence_by_simulation():
    n, p = 50, 0.1
    counts = np.random.default_rng(5).binomial(n, p, size=2000)
    lower, upper = clopper_pearson(counts, n, CONFIDENCE)
    assert ((lower <= p) & (p <= upper)).mean() >= CONFIDENCE


@pytest.mark.parametrize("p", [0.005, 0.02, 0.1, 0.3, 0.5, 0.9])
def test_clopper_pearson_exact_coverage_is_at_least_the_confidence(p):
    n = 50
    counts = np.arange(n + 1)
    lower, upper = clopper_pearson(counts, n, CONFIDENCE)
    assert stats.binom.pmf(counts, n, p)[(lower <= p) & (p <= upper)].sum() >= CONFIDENCE


def test_exceedance_distances_of_a_normal_sample_bracket_the_analytic_quantiles_with_the_asymptotic_width():
    n, mean_m, std_m = 10_000, 40.0, 8.0
    results = exceedance_distances(np.random.default_rng(3).normal(mean_m, std_m, n), (0.5, 0.1, 0.01), CONFIDENCE)
    z = stats.norm.ppf(0.5 + CONFIDENCE / 2.0)
    for result in results:
        quantile_m = stats.norm.ppf(1.0 - result.probability, mean_m, std_m)
        assert result.resolved
        assert result.lower_m <= quantile_m <= result.upper_m
        assert result.lower_m <= result.distance_m <= result.upper_m
        # Asymptotic standard error of a sample quantile: sqrt(p (1 - p) / n) / density.
        standard_error_m = np.sqrt(result.probability * (1.0 - result.probability) / n) / stats.norm.pdf(
            quantile_m, mean_m, std_m
        )
        assert result.upper_m - result.lower_m == pytest.approx(2.0 * z * standard_error_m, rel=0.25)


@pytest.mark.parametrize("n, resolved", [(64, False), (99, False), (100, True), (1000, True)])
def test_one_percent_distance_is_resolved_only_with_at_least_one_expected_realization_beyond_it(n, resolved):
    (result,) = exceedance_distances(np.random.default_rng(n).exponential(10.0, n), (0.01,))
    assert result.resolved is resolved
    if resolved:
        sample = np.random.default_rng(n).exponential(10.0, n)
        assert result.distance_m == pytest.approx(np.quantile(sample, 0.99, method="interpolated_inverted_cdf"))
    else:
        assert (result.distance_m, result.lower_m, result.upper_m) == (None, None, None)
        assert result.note == f"needs at least 100 realizations (n = {n})"


def test_running_mean_and_std_equal_numpy_at_every_n():
    values = np.random.default_rng(7).normal(1.0e4, 3.0, 600)  # large offset: tests numerical stability
    trace = convergence(values)
    np.testing.assert_array_equal(trace.n, np.arange(1, values.size + 1))
    np.testing.assert_allclose(trace.mean, [values[:n].mean() for n in trace.n], rtol=1e-10, atol=0.0)
    np.testing.assert_allclose(trace.std[1:], [values[:n].std(ddof=1) for n in trace.n[1:]], rtol=1e-10, atol=0.0)
    assert np.isnan([trace.std[0], trace.mean_low[0], trace.mean_high[0], trace.std_low[0], trace.std_high[0]]).all()


def test_final_bands_of_iid_normal_draws_cover_the_true_mean_and_std():
    trace = convergence(np.random.default_rng(8).normal(5.0, 2.0, 20_000))
    assert trace.mean_low[-1] <= 5.0 <= trace.mean_high[-1]
    assert trace.std_low[-1] <= 2.0 <= trace.std_high[-1]


def test_bands_of_the_mean_and_std_cover_at_their_nominal_rate_over_replicates():
    samples = np.random.default_rng(9).normal(5.0, 2.0, size=(400, 200))
    traces = [convergence(sample, window=1) for sample in samples]
    mean_coverage = np.mean([t.mean_low[-1] <= 5.0 <= t.mean_high[-1] for t in traces])
    std_coverage = np.mean([t.std_low[-1] <= 2.0 <= t.std_high[-1] for t in traces])
    three_standard_errors = 3.0 * np.sqrt(CONFIDENCE * (1.0 - CONFIDENCE) / len(traces))
    assert abs(mean_coverage - CONFIDENCE) < three_standard_errors
    assert abs(std_coverage - CONFIDENCE) < three_standard_errors


def _brute_force_convergence(values: np.ndarray, tolerance: float, window: int, last_n: int) -> int | None:
    """The criterion re-implemented from numpy prefix statistics, for n up to last_n."""
    passed = {}
    for n in range(3, last_n + 1):
        std = values[:n].std(ddof=1)
        change_mean = abs(values[:n].mean() - values[: n - 1].mean()) / std
        change_variance = abs(values[:n].var(ddof=1) - values[: n - 1].var(ddof=1)) / std**2
        passed[n] = change_mean < tolerance and change_variance < tolerance
    return next((n for n in range(3, last_n - window + 2) if all(passed[k] for k in range(n, n + window))), None)


def test_convergence_of_a_long_iid_sample_is_found_where_the_stated_criterion_first_holds():
    values = np.random.default_rng(10).normal(5.0, 2.0, 20_000)
    trace = convergence(values, tolerance=1e-3, window=100)
    assert trace.converged_at is not None
    assert _brute_force_convergence(values, 1e-3, 100, trace.converged_at + 99) == trace.converged_at
    assert "100 consecutive" in trace.criterion and "0.001" in trace.criterion


@pytest.mark.parametrize("n", [100, 1000])
def test_short_samples_do_not_converge(n):
    # The running mean moves by about |z| s / n per draw, so a 1e-3 change needs n well above 1000.
    assert convergence(np.random.default_rng(n).normal(5.0, 2.0, n), tolerance=1e-3, window=100).converged_at is None


def test_a_constant_sample_converges_at_the_first_check():
    trace = convergence(np.full(200, 0.1), tolerance=1e-3, window=100)
    assert trace.converged_at == 3
    np.testing.assert_array_equal(trace.std[1:], 0.0)
    np.testing.assert_array_equal(trace.mean, 0.1)


def test_affected_probability_equals_hand_counts_and_empty_realizations_count_only_in_n():
    rear = np.array([0.0, 5.0, np.nan, 12.0])
    front = np.array([10.0, 15.0, np.nan, 12.0])
    x_m = np.array([-1.0, 0.0, 5.0, 10.0, 11.0, 12.0, 15.0, 16.0])
    affected = affected_probability(x_m, rear, front, CONFIDENCE)
    counts = np.array([0, 1, 2, 2, 1, 2, 1, 0])
    assert affected.n == 4
    np.testing.assert_array_equal(affected.probability, counts / 4)
    lower, upper = clopper_pearson(counts, 4, CONFIDENCE)
    np.testing.assert_array_equal(affected.lower, lower)
    np.testing.assert_array_equal(affected.upper, upper)
    nothing = affected_probability(x_m, np.full(3, np.nan), np.full(3, np.nan))
    assert nothing.n == 3 and not nothing.probability.any()


@pytest.mark.parametrize("rear, front", [([1.0], [0.0]), ([np.nan], [1.0])])
def test_affected_probability_rejects_reversed_or_half_missing_intervals(rear, front):
    with pytest.raises(ValueError):
        affected_probability(np.array([0.5]), np.array(rear), np.array(front))


@pytest.mark.parametrize(
    "probability, level",
    [
        (1.0, "extremely high"),
        (9 / 10, "extremely high"),
        (0.8999, "high"),
        (0.5, "high"),
        (0.4999, "moderate"),
        (0.1, "moderate"),
        (0.0999, "low"),
        (1 / 100, "low"),
        (0.0099, "extremely low"),
        (0.0, "extremely low"),
    ],
)
def test_a_threshold_probability_belongs_to_the_higher_zone(probability, level):
    assert ZONE_LEVELS[int(zone_levels(np.array([probability]), DEFAULT_THRESHOLDS)[0])] == level


def test_zones_merge_runs_in_x_order_with_edges_midway_between_levels():
    x_m = np.array([4.0, 0.0, 1.0, 2.0, 3.0, 5.0])
    levels = np.array([4, 0, 0, 1, 1, 4])
    assert zones(x_m, levels) == [
        Zone("extremely high", 0.0, 1.5),
        Zone("high", 1.5, 3.5),
        Zone("extremely low", 3.5, 5.0),
    ]


@pytest.mark.parametrize(
    "thresholds",
    [(0.5, 0.9, 0.1, 0.01), (1.0, 0.5, 0.1, 0.01), (0.9, 0.5, 0.5, 0.01), (0.9, 0.5, 0.1), (0.9, 0.5, 0.1, 0.0)],
)
def test_bad_thresholds_raise_an_error_naming_them(thresholds):
    with pytest.raises(ValueError, match=re.escape(str(list(thresholds)))):
        zone_levels(np.array([0.5]), thresholds)


def test_each_hazard_figure_writes_a_png(tmp_path):
    rng = np.random.default_rng(12)
    runout_m, influence_m = rng.exponential(8.0, 300), rng.exponential(3.0, 300)
    traces = {"influence distance I": convergence(influence_m), "runout distance R": convergence(runout_m)}
    curves = {
        name: exceedance_curve(values)
        for name, values in (("influence distance I", influence_m), ("runout distance R", runout_m))
    }
    distances = {
        name: exceedance_distances(values)
        for name, values in (("influence distance I", influence_m), ("runout distance R", runout_m))
    }
    vertices = np.array([[0.0, 0.0], [40.0, 0.0], [25.0, 10.0], [0.0, 10.0]])
    x_m = np.linspace(0.0, 80.0, 161)
    affected = affected_probability(x_m, 25.0 - influence_m, 40.0 + runout_m)
    paths = [tmp_path / name for name in ("convergence.png", "exceedance.png", "zoning.png")]
    plot_convergence(traces, paths[0], units={"influence distance I": "m"})
    plot_exceedance(curves, distances, {"influence distance I": None, "runout distance R": 6.0}, paths[1])
    plot_zoning(vertices, affected, zone_levels(affected.probability), DEFAULT_THRESHOLDS, 80.0, 20.0, paths[2])
    for path in paths:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def drawn_figures(monkeypatch) -> list:
    """The figures saved while the test runs (each kept open for reading back)."""
    drawn = []
    save = matplotlib.figure.Figure.savefig
    monkeypatch.setattr(
        matplotlib.figure.Figure,
        "savefig",
        lambda figure, *args, **kwargs: (drawn.append(figure), save(figure, *args, **kwargs))[1],
    )
    return drawn


def test_the_exceedance_figure_draws_each_metrics_own_curve_and_the_mean_field_where_given(tmp_path, monkeypatch):
    """What the figure shows, read back from its axes: each metric on the axes titled with its name, its
    empirical P(X > x) as the step line (floored at 1 / 2n on the log axis), the mean-field value as a
    vertical line only where one is given."""
    drawn = drawn_figures(monkeypatch)
    rng = np.random.default_rng(13)
    values = {"influence distance I": rng.exponential(3.0, 200), "runout distance R": rng.exponential(8.0, 200)}
    curves = {name: exceedance_curve(v) for name, v in values.items()}
    distances = {name: exceedance_distances(v) for name, v in values.items()}
    plot_exceedance(curves, distances, {"influence distance I": None, "runout distance R": 6.0}, tmp_path / "e.png")
    (figure,) = drawn
    for axis, (name, curve) in zip(figure.axes, curves.items(), strict=True):
        assert axis.get_title() == name
        step = next(line for line in axis.get_lines() if line.get_label().startswith("empirical"))
        np.testing.assert_array_equal(step.get_xdata(), curve.x)
        np.testing.assert_array_equal(step.get_ydata(), np.maximum(curve.probability, 1.0 / (2 * curve.n)))
        mean_field = [line for line in axis.get_lines() if line.get_label() == "mean-field"]
        assert [line.get_xdata()[0] for line in mean_field] == ([6.0] if name == "runout distance R" else [])


def test_the_zoning_figure_draws_each_zone_where_the_zones_put_it_in_its_colour(tmp_path, monkeypatch):
    """Read back: the band under the section has one rectangle per zone, spanning that zone's x range in the
    colour of its level, and the probability line is P(affected) floored at 1 / 2n on the log axis."""
    from rgns.hazard.statistics import ZONE_COLOURS

    drawn = drawn_figures(monkeypatch)
    rng = np.random.default_rng(14)
    influence_m, runout_m = rng.exponential(3.0, 400), rng.exponential(8.0, 400)
    x_m = np.linspace(0.0, 80.0, 321)
    affected = affected_probability(x_m, 25.0 - influence_m, 40.0 + runout_m)
    levels = zone_levels(affected.probability, DEFAULT_THRESHOLDS)
    vertices = np.array([[0.0, 0.0], [40.0, 0.0], [25.0, 10.0], [0.0, 10.0]])
    plot_zoning(vertices, affected, levels, DEFAULT_THRESHOLDS, 80.0, 20.0, tmp_path / "z.png")
    (figure,) = drawn
    section, probability_axis = figure.axes[:2]
    band = [patch for patch in section.patches if patch.get_alpha() == 1.0]  # the solid band under the section
    expected = zones(x_m, levels)
    assert len(band) == len(expected) > 2
    for patch, zone in zip(sorted(band, key=lambda p: p.get_x()), expected, strict=True):
        assert (patch.get_x(), patch.get_x() + patch.get_width()) == pytest.approx((zone.x_from_m, zone.x_to_m))
        assert matplotlib.colors.same_color(patch.get_facecolor()[:3], ZONE_COLOURS[ZONE_LEVELS.index(zone.level)])
    (line,) = [line for line in probability_axis.get_lines() if line.get_label() == "P(point affected)"]
    np.testing.assert_array_equal(line.get_ydata(), np.maximum(affected.probability, 1.0 / (2 * affected.n)))


def test_the_convergence_figure_marks_where_each_running_statistic_converged(tmp_path, monkeypatch):
    """Read back: each metric's running mean and std are the trace's, the dashed marker at the n where the
    paper's rule says it converged, and a trace that never converges says so instead of a marker."""
    drawn = drawn_figures(monkeypatch)
    rng = np.random.default_rng(15)
    settled, short = convergence(rng.normal(10.0, 1.0, 6000)), convergence(rng.lognormal(0.0, 2.0, 30))
    assert settled.converged_at is not None and short.converged_at is None
    plot_convergence({"runout distance R": settled, "influence distance I": short}, tmp_path / "c.png")
    (figure,) = drawn
    mean_axis, std_axis, short_mean_axis, _ = figure.axes
    (mean,) = [line for line in mean_axis.get_lines() if line.get_label() == "running mean"]
    np.testing.assert_array_equal(mean.get_ydata(), settled.mean)
    (std,) = [line for line in std_axis.get_lines() if line.get_label() == "running std"]
    np.testing.assert_array_equal(std.get_ydata(), settled.std)
    (marker,) = [line for line in mean_axis.get_lines() if line.get_label().startswith("converged at n =")]
    assert marker.get_xdata()[0] == settled.converged_at
    assert not [line for line in short_mean_axis.get_lines() if line.get_label().startswith("converged at")]
    assert any(text.get_text().startswith("not converged within 30") for text in short_mean_axis.texts)
