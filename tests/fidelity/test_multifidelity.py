"""The multi-fidelity control-variate estimator: unbiased, covers, reduces to its limits."""

import numpy as np
import pytest
from scipy import stats

from rgns.fidelity.multifidelity import (
    MultiFidelityError,
    allocate,
    control_variate,
    exceedance_indicators,
    optimal_ratio,
    speedup,
    variance_factor,
)

TRUE_MEAN = 5.0
THRESHOLD = 6.2816  # P(H > 6.2816) = 0.1 for H ~ N(5, 1)
RHO = 0.9


def synthetic(rng: np.random.Generator, n: int, big_n: int) -> tuple[np.ndarray, np.ndarray]:
    """High fidelity H ~ N(5, 1); low fidelity biased (+1.5, scaled 0.8) with correlation RHO."""
    h = rng.normal(TRUE_MEAN, 1.0, big_n)
    low = 0.8 * (RHO * (h - TRUE_MEAN) + np.sqrt(1 - RHO**2) * rng.normal(size=big_n)) + TRUE_MEAN + 1.5
    return h[:n], low


def quantities(values: np.ndarray) -> np.ndarray:
    """[N, 2]: the value (for its mean) and the exceedance indicator at THRESHOLD."""
    return np.column_stack([values, exceedance_indicators(values, [THRESHOLD])[:, 0]])


def test_unbiased_and_covers_on_biased_correlated_pairs_over_many_replicates():
    rng = np.random.default_rng(1)
    replicates, n, big_n = 400, 40, 400
    truth = np.array([TRUE_MEAN, 0.1])
    estimates, covered = [], []
    for k in range(replicates):
        h, low = synthetic(rng, n, big_n)
        result = control_variate(quantities(h), quantities(low), resamples=999, seed=k)
        estimates.append(result.estimate)
        covered.append((result.lower <= truth) & (truth <= result.upper))
    estimates, covered = np.array(estimates), np.array(covered)
    se_mean = estimates.std(axis=0, ddof=1) / np.sqrt(replicates)
    assert np.all(np.abs(estimates.mean(axis=0) - truth) < 3 * se_mean), (estimates.mean(axis=0), se_mean)
    se_coverage = np.sqrt(0.95 * 0.05 / replicates)
    assert np.all(np.abs(covered.mean(axis=0) - 0.95) < 3 * se_coverage), covered.mean(axis=0)
    # the plain low-fidelity mean is off by its bias, far beyond the noise
    assert abs(np.mean([synthetic(rng, n, big_n)[1].mean() for _ in range(50)]) - TRUE_MEAN) > 1.0


def test_variance_matches_the_mfmc_formula():
    rng = np.random.default_rng(2)
    n, big_n = 30, 300
    means = [
        control_variate(h[:, None], low[:, None], resamples=9).estimate[0]
        for h, low in (synthetic(rng, n, big_n) for _ in range(1500))
    ]
    expected = 1.0 / n * variance_factor(big_n / n, RHO)
    assert np.var(means, ddof=1) == pytest.approx(expected, rel=0.12)
    assert expected < 0.3 / n  # 1 - 0.9 * 0.81 = 0.27: 3.7x below the n high-fidelity runs alone


def test_with_every_realization_paired_it_is_plain_high_fidelity_mc():
    rng = np.random.default_rng(3)
    h, low = synthetic(rng, 60, 60)
    result = control_variate(h[:, None], low[:, None], resamples=4000, seed=0)
    assert result.estimate[0] == pytest.approx(h.mean(), abs=1e-12)
    plain = stats.bootstrap((h,), np.mean, n_resamples=4000, method="percentile", random_state=np.random.default_rng(0))
    width, plain_width = result.upper[0] - result.lower[0], np.ptp(plain.confidence_interval)
    assert width == pytest.approx(plain_width, rel=0.1)


def test_with_a_perfect_low_fidelity_model_the_interval_is_that_of_n_high_fidelity_runs():
    rng = np.random.default_rng(4)
    values = rng.normal(TRUE_MEAN, 1.0, 400)
    result = control_variate(values[:40, None], values[:, None], resamples=4000, seed=0)
    assert result.estimate[0] == pytest.approx(values.mean(), abs=1e-12)
    assert result.weight[0] == pytest.approx(1.0)
    plain = stats.bootstrap(
        (values,), np.mean, n_resamples=4000, method="percentile", random_state=np.random.default_rng(0)
    )
    assert result.upper[0] - result.lower[0] == pytest.approx(np.ptp(plain.confidence_interval), rel=0.1)
    # ... and much narrower than the 40 paired runs alone
    alone = control_variate(values[:40, None], values[:40, None], resamples=4000, seed=0)
    assert (alone.upper - alone.lower)[0] > 2.5 * (result.upper - result.lower)[0]


def test_reports_the_bias_and_correlation_of_the_cheap_route():
    rng = np.random.default_rng(5)
    h, low = synthetic(rng, 200, 400)
    result = control_variate(h[:, None], low[:, None], resamples=99)
    assert result.bias[0] == pytest.approx(1.5, abs=0.2)
    assert result.correlation[0] == pytest.approx(RHO, abs=0.05)
    assert result.weight[0] == pytest.approx(RHO / 0.8, rel=0.1)  # cov(h, l) / var(l) = 0.8 rho / 0.64


def test_a_quantity_that_never_varies_gets_a_point_interval():
    h, low = np.zeros((10, 1)), np.zeros((50, 1))
    result = control_variate(h, low, resamples=99)
    assert result.estimate[0] == 0.0 and result.lower[0] == 0.0 and result.upper[0] == 0.0


def test_a_tail_no_pair_reaches_keeps_the_cheap_runs():
    """P(R > r) where none of the pairs exceeds r but some cheap runs do: weight 1, the cheap estimate."""
    h, low = np.zeros((10, 1)), np.zeros((100, 1))
    low[[20, 50, 70]] = 1.0
    result = control_variate(h, low, resamples=99)
    assert result.weight[0] == 1.0
    assert result.estimate[0] == pytest.approx(0.03)


def test_allocation_follows_the_mfmc_optimum():
    assert optimal_ratio(7.3, 1.0, 0.0) == 1.0
    assert optimal_ratio(100.0, 1.0, 0.99) == pytest.approx(np.sqrt(100 * 0.99**2 / (1 - 0.99**2)))
    assert speedup(7.3, 1.0, 0.0) < 1.0  # an uncorrelated cheap model only costs
    assert speedup(100.0, 1.0, 0.999) > 10.0
    plan = allocate(7.3, 1.0, 0.9, std_high=2.0, half_width=0.2)
    z = stats.norm.ppf(0.975)
    assert z * np.sqrt(plan.variance) <= 0.2 + 1e-9
    assert plan.n_low >= plan.n_high
    assert plan.speedup == pytest.approx(speedup(7.3, 1.0, 0.9), rel=0.05)
    capped = allocate(7.3, 1.0, 0.9, std_high=2.0, half_width=0.2, cap_high=10)
    assert capped.n_high == 10 and z * np.sqrt(capped.variance) > 0.2


@pytest.mark.parametrize(
    "high, low, message",
    [
        (np.ones((1, 1)), np.ones((5, 1)), "at least 2 paired"),
        (np.ones((6, 1)), np.ones((5, 1)), "at least 2 paired"),
        (np.ones((3, 2)), np.ones((5, 1)), "differ in shape"),
        (np.array([[1.0], [np.nan]]), np.ones((5, 1)), "NaN"),
    ],
)
def test_bad_input_is_named(high, low, message):
    with pytest.raises(MultiFidelityError, match=message):
        control_variate(high, low)
