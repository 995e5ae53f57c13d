"""The one exceedance-distance estimator: a curve's crossing of P, linear between the distances it is known at."""

import numpy as np
import pytest
from scipy import stats

from rgns.hazard.exceedance import DISTANCE_STEP_M, crossings, distance_at, distance_grid, sample_distance


def test_a_smooth_curve_on_the_report_grid_is_read_to_well_under_one_grid_step():
    """The normal law's exceedance on the 0.25 m grid: the crossing of P 0.5, 0.1, 0.01 within 1 cm of the
    analytic quantile (reading the first grid distance at most P is off by up to 25 cm, 12 on average)."""
    d_m = np.arange(0.0, 30.0, DISTANCE_STEP_M)
    for mean in np.linspace(10.0, 10.25, 7):  # the quantiles at every position within a grid step
        curve = stats.norm.sf(d_m, mean, 2.0)
        found = crossings(curve, d_m, np.array([0.5, 0.1, 0.01]))
        np.testing.assert_allclose(found, stats.norm.isf([0.5, 0.1, 0.01], mean, 2.0), atol=0.01)


def test_a_sample_is_read_as_numpy_reads_its_interpolated_inverted_cdf():
    values = np.random.default_rng(5).gamma(3.0, 2.0, 257)
    for p in (0.5, 0.37, 0.1, 0.01):
        assert sample_distance(values, p) == pytest.approx(
            np.quantile(values, 1 - p, method="interpolated_inverted_cdf")
        )


def test_a_large_sample_and_its_curve_on_the_report_grid_give_the_same_distance():
    """A plain Monte Carlo (its sample) and a curve (its share above each grid distance) are read alike: on
    200,000 draws within 1 cm of each other, both within 4 SE of the law's quantile."""
    n = 200_000
    values = np.random.default_rng(6).normal(10.0, 2.0, n)
    d_m = distance_grid(values)
    curve = 1.0 - np.searchsorted(np.sort(values), d_m, side="right") / n
    for p in (0.5, 0.1, 0.01):
        exact = stats.norm.isf(p, 10.0, 2.0)
        se = np.sqrt(p * (1 - p) / n) / stats.norm.pdf(exact, 10.0, 2.0)
        from_sample, from_curve = sample_distance(values, p), distance_at(d_m, curve, p)
        assert from_curve == pytest.approx(from_sample, abs=0.01)
        assert abs(from_sample - exact) < 4 * se


def test_a_curve_that_starts_below_or_never_falls_to_p():
    d_m = np.array([0.0, 1.0, 2.0])
    assert distance_at(d_m, [0.05, 0.0, 0.0], 0.1) == 0.0
    assert distance_at(d_m, [1.0, 0.5, 0.2], 0.1) is None
    assert crossings(np.array([[1.0, 0.5, 0.2], [1.0, 0.4, 0.0]]), d_m, np.array([0.1]))[:, 0].tolist() == [
        np.inf,
        1.75,
    ]
