"""The regression control variate for exceedance probabilities: unbiased, covers, beats the indicator one."""

import numpy as np
import pytest
from scipy import stats

from rgns.fidelity.multifidelity import (
    MultiFidelityError,
    control_variate,
    exceedance_indicators,
    regression_control_variate,
    regression_point_estimate,
)

QUANTILES = np.array([0.5, 0.9])
THRESHOLDS = stats.norm.ppf(QUANTILES, loc=5.0)  # H ~ N(5, 1): P(H > t) = 0.5 and 0.1
TRUTH = 1.0 - QUANTILES
RHO = 0.95


def synthetic(rng: np.random.Generator, n: int, big_n: int) -> tuple[np.ndarray, np.ndarray]:
    """High fidelity H ~ N(5, 1); low fidelity short by 1.2 and scaled 0.8, correlation RHO: 1[L > t] and
    1[H > t] disagree for many realizations (the cheap route falls short of the threshold)."""
    h = rng.normal(5.0, 1.0, big_n)
    low = 0.8 * (RHO * (h - 5.0) + np.sqrt(1 - RHO**2) * rng.normal(size=big_n)) + 5.0 - 1.2
    return h[:n], low


def test_unbiased_and_covers_over_many_replicates_and_beats_the_indicator_control_variate():
    rng = np.random.default_rng(11)
    replicates, n, big_n = 400, 20, 200
    regression, indicator, covered = [], [], []
    for k in range(replicates):
        h, low = synthetic(rng, n, big_n)
        result = regression_control_variate(h, low, THRESHOLDS, resamples=999, seed=k)
        regression.append(result.estimate)
        covered.append((result.lower <= TRUTH) & (TRUTH <= result.upper))
        indicator.append(
            control_variate(
                exceedance_indicators(h, THRESHOLDS), exceedance_indicators(low, THRESHOLDS), resamples=9
            ).estimate
        )
    regression, indicator, covered = np.array(regression), np.array(indicator), np.array(covered)
    se = regression.std(axis=0, ddof=1) / np.sqrt(replicates)
    assert np.all(np.abs(regression.mean(axis=0) - TRUTH) < 3 * se), (regression.mean(axis=0), se)
    se_coverage = np.sqrt(0.95 * 0.05 / replicates)
    assert np.all(np.abs(covered.mean(axis=0) - 0.95) < 3 * se_coverage), covered.mean(axis=0)
    mse_regression = ((regression - TRUTH) ** 2).mean(axis=0)
    mse_indicator = ((indicator - TRUTH) ** 2).mean(axis=0)
    mse_pairs_alone = TRUTH * (1 - TRUTH) / n
    assert np.all(mse_regression < 0.6 * mse_indicator), (mse_regression, mse_indicator)
    assert np.all(mse_regression < 0.4 * mse_pairs_alone), (mse_regression, mse_pairs_alone)


def test_with_every_realization_paired_it_is_plain_high_fidelity_mc():
    rng = np.random.default_rng(12)
    h, low = synthetic(rng, 50, 50)
    result = regression_control_variate(h, low, THRESHOLDS, resamples=99)
    assert result.estimate == pytest.approx((h[:, None] > THRESHOLDS).mean(0), abs=1e-12)


def test_with_a_perfect_low_fidelity_model_it_is_the_mean_of_all_n_runs_with_their_interval():
    rng = np.random.default_rng(13)
    values = rng.normal(5.0, 1.0, 400)
    result = regression_control_variate(values[:40], values, THRESHOLDS, resamples=4000, seed=0)
    every = (values[:, None] > THRESHOLDS).astype(float)
    assert result.estimate == pytest.approx(every.mean(0), abs=1e-9)
    plain = stats.bootstrap(
        (every,), np.mean, axis=0, n_resamples=4000, method="percentile", random_state=np.random.default_rng(0)
    )
    width = result.upper - result.lower
    assert width == pytest.approx(np.ptp(plain.confidence_interval, axis=0), rel=0.15)


def test_a_tail_no_pair_reaches_takes_the_cheap_runs_predicted_probability():
    """P(H > 8) = 0.00135, which 40 pairs reach in 5 % of 300 replicates (40,000 cheap runs each): the indicator
    control variate is 0 wherever no pair reaches it; the regression one is unbiased over the replicates (within
    3 SE) and its typical replicate within a factor 1.43 of the truth (median ratio), which a residual-free
    fit (s = 0: a step at the predicted value, median ratio 0.59) or the cheap runs alone (0) break."""
    rng = np.random.default_rng(15)
    tail, replicates = 8.0, 300
    truth = stats.norm.sf(tail, loc=5.0)
    ratios, reached = [], 0
    for _ in range(replicates):
        h, low = synthetic(rng, 40, 40_000)
        ratios.append(
            regression_point_estimate(h[:, None], low[:40, None], low[40:, None], np.array([tail]))[0] / truth
        )
        if not (h > tail).any():
            indicator = control_variate(
                exceedance_indicators(h, [tail]), exceedance_indicators(low, [tail]), resamples=9
            ).estimate[0]
            assert indicator == 0.0
        reached += bool((h > tail).any())
    ratios = np.array(ratios)
    assert reached < 0.1 * replicates
    assert abs(ratios.mean() - 1.0) < 3 * ratios.std(ddof=1) / np.sqrt(replicates), ratios.mean()
    assert 0.7 < np.median(ratios) < 1.0 / 0.7, np.median(ratios)


def test_affected_is_front_minus_rear_and_nothing_moved_counts_as_unaffected():
    rng = np.random.default_rng(15)
    rear = rng.uniform(5.0, 10.0, 30)
    front = rear + rng.uniform(5.0, 20.0, 30)
    values = np.column_stack([front, rear])
    values[[3, 17]] = np.nan  # nothing moved
    x = np.arange(0.0, 40.0, 0.5)
    result = regression_control_variate(
        values, values + 0.1, x, signs=[1.0, -1.0], inclusive=[True, False], resamples=99
    )
    with np.errstate(invalid="ignore"):
        affected = ((rear[:, None] <= x) & (x <= front[:, None])).astype(float)
    affected[[3, 17]] = 0.0
    assert result.estimate == pytest.approx(affected.mean(0), abs=1e-12)


@pytest.mark.parametrize(
    "high, low, message",
    [
        (np.ones(1), np.ones(5), "at least 2 paired"),
        (np.ones((3, 2)), np.ones((5, 1)), "differ in columns"),
        (np.array([1.0, np.inf]), np.ones(5), "infinity"),
    ],
)
def test_bad_input_is_named(high, low, message):
    with pytest.raises(MultiFidelityError, match=message):
        regression_control_variate(high, low, [1.0])
