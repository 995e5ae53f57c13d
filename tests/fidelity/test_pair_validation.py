"""The learned simulator against the MPM on a Monte Carlo case's own pairs, weighted by the stratified design."""

import numpy as np
import pandas as pd
import pytest

from rgns.fidelity.pair_validation import (
    PairValidationError,
    effective_pairs,
    merged_strata,
    pair_validation,
)
from rgns.surrogates.validation import nrmse, r_squared


def frames(high: np.ndarray, low: np.ndarray) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Pairs with runout h / l, volume 3 h / 3 l and influence 0.5 h / 0.5 l."""
    return tuple(pd.DataFrame({"runout_m": v, "volume_m2": 3.0 * v, "influence_m": 0.5 * v}) for v in (high, low))


def test_equal_weights_and_one_stratum_give_the_plain_statistics():
    rng = np.random.default_rng(0)
    h = rng.normal(10.0, 2.0, 30)
    lo = h + 0.3 + rng.normal(0.0, 0.5, 30)
    high, low = frames(h, lo)
    result = pair_validation(high, low, np.full(30, 1 / 30), np.zeros(30, dtype=int))
    assert list(result) == ["runout_m", "volume_m2", "influence_m"]
    runout = result["runout_m"]
    assert runout["n"] == 30 and set(runout) == {"n", "r2", "nrmse", "bias", "relative_bias"}
    plain_r2 = 1.0 - np.sum((lo - h) ** 2) / np.sum((h - h.mean()) ** 2)
    assert runout["r2"][0] == pytest.approx(plain_r2, rel=1e-12) == r_squared(h, lo)
    assert runout["nrmse"][0] == pytest.approx(np.sqrt(np.mean((lo - h) ** 2)) / np.ptp(h), rel=1e-12)
    assert runout["nrmse"][0] == pytest.approx(nrmse(h, lo), rel=1e-12)
    assert runout["bias"][0] == pytest.approx(np.mean(lo - h), rel=1e-12)
    assert runout["relative_bias"][0] == pytest.approx(np.mean(lo - h) / np.mean(h), rel=1e-12)
    for name in ("r2", "nrmse", "bias", "relative_bias"):
        point, lower, upper = runout[name]
        assert lower < point < upper
    # scale-free statistics do not see the volume's factor 3; the bias does
    assert result["volume_m2"]["r2"] == pytest.approx(runout["r2"])
    assert result["volume_m2"]["bias"][0] == pytest.approx(3.0 * runout["bias"][0])
    # the weights need not sum to 1: they are normalised
    again = pair_validation(high, low, np.full(30, 5.0), np.zeros(30, dtype=int))
    assert again["runout_m"] == runout


def test_pairs_with_nan_leave_that_metric_only_and_the_weights_are_renormalised():
    rng = np.random.default_rng(1)
    h = rng.normal(10.0, 2.0, 24)
    lo = h + rng.normal(0.0, 0.5, 24)
    weights = np.where(np.arange(24) < 8, 0.5 / 8, 0.5 / 16)
    strata = (np.arange(24) >= 8).astype(int)
    high, low = frames(h, lo)
    low.loc[[0, 9], "influence_m"] = np.nan  # nothing moved
    result = pair_validation(high, low, weights, strata)
    assert result["runout_m"]["n"] == 24 and result["influence_m"]["n"] == 22
    keep = np.ones(24, dtype=bool)
    keep[[0, 9]] = False
    w = weights[keep] / weights[keep].sum()
    error = 0.5 * (lo - h)[keep]
    assert result["influence_m"]["bias"][0] == pytest.approx(np.sum(w * error), rel=1e-12)
    mean_h = np.sum(w * 0.5 * h[keep])
    var_h = np.sum(w * (0.5 * h[keep] - mean_h) ** 2)
    assert result["influence_m"]["r2"][0] == pytest.approx(1.0 - np.sum(w * error**2) / var_h, rel=1e-12)
    assert all(np.isfinite(result["influence_m"]["r2"]))


def test_a_stratum_of_one_pair_is_merged_into_its_neighbour_for_the_bootstrap():
    assert list(merged_strata(np.array([0, 1, 1, 2, 2, 2]))) == [1, 1, 1, 2, 2, 2]
    assert list(merged_strata(np.array([0, 0, 1, 2, 2]))) == [0, 0, 0, 2, 2]
    assert list(merged_strata(np.array([3, 5, 7]))) == [5, 5, 5]
    rng = np.random.default_rng(2)
    h = rng.normal(10.0, 2.0, 12)
    high, low = frames(h, h + rng.normal(0.0, 0.5, 12))
    strata = np.array([0] + [1] * 5 + [2] * 6)
    weights = np.where(strata == 0, 0.3, np.where(strata == 1, 0.3 / 5, 0.4 / 6))
    result = pair_validation(high, low, weights, strata)["runout_m"]
    assert all(np.isfinite(result["r2"])) and result["r2"][1] <= result["r2"][0] <= result["r2"][2]


def test_the_effective_pairs_are_n_for_one_even_stratum_and_fewer_for_an_uneven_design():
    members = [np.arange(20)]
    assert effective_pairs(np.full(20, 0.05), members) == pytest.approx(20.0)
    members = [np.arange(3), np.arange(3, 23)]
    weights = np.concatenate([np.full(3, 0.5 / 3), np.full(20, 0.5 / 20)])
    assert effective_pairs(weights, members) < 10


def test_bad_inputs_are_named():
    high, low = frames(np.arange(5.0), np.arange(5.0))
    with pytest.raises(PairValidationError, match="as many rows"):
        pair_validation(high, low, np.full(4, 0.25), np.zeros(5, dtype=int))
    with pytest.raises(PairValidationError, match="positive"):
        pair_validation(high, low, np.array([0.5, 0.5, 0.0, 0.0, 0.0]), np.zeros(5, dtype=int))
    with pytest.raises(PairValidationError, match="columns"):
        pair_validation(high[[]], low[[]], np.full(5, 0.2), np.zeros(5, dtype=int))


def stratified_pairs(seed: int, sizes: tuple[int, ...], population: int = 4000) -> tuple:
    """A Monte Carlo case of ``population`` realizations, MPM h ~ N(10, 1), surrogate l = h + 0.2 + N(0, 0.4²)
    (population R² 1 − (0.2² + 0.4²) / 1 = 0.8), and pairs drawn from strata by quantiles of l, ``sizes[s]``
    pairs from stratum s, each weighted N_s / N / n_s: the population's R² and bias, the pairs' tables,
    weights and strata, and the plain (unweighted) R² of the pairs."""
    rng = np.random.default_rng(seed)
    h = rng.normal(10.0, 1.0, population)
    lo = h + 0.2 + rng.normal(0.0, 0.4, population)
    edges = np.quantile(lo, np.linspace(0.0, 1.0, len(sizes) + 1))
    label = np.clip(np.searchsorted(edges, lo, side="right") - 1, 0, len(sizes) - 1)
    picks, weights, strata = [], [], []
    for stratum, size in enumerate(sizes):
        members = np.flatnonzero(label == stratum)
        picks.append(rng.choice(members, size, replace=False))
        weights += [members.size / population / size] * size
        strata += [stratum] * size
    pick = np.concatenate(picks)
    population_r2 = 1.0 - np.mean((lo - h) ** 2) / np.var(h)
    high, low = pd.DataFrame({"runout_m": h[pick]}), pd.DataFrame({"runout_m": lo[pick]})
    return population_r2, np.mean(lo - h), high, low, np.array(weights), np.array(strata), r_squared(h[pick], lo[pick])


def test_over_replicates_of_a_stratified_design_the_estimate_is_nearly_unbiased_and_the_interval_covers():
    """200 replicates of 40 pairs (4, 6, 10, 20 from the strata of l's quartiles): the weighted R² close to the
    population's (measured over 1000 replicates: 0.790 for 0.800, spread 0.065; the unweighted R² of the pairs,
    which over-represent the upper strata, 0.726), and the 95 % intervals of R² and of the bias cover the population's value in 95 % ± 3 SE
    of the replicates, misses on both sides."""
    replicates, sizes = 200, (4, 6, 10, 20)
    truth, estimate, lower, upper, truth_bias, bias_lower, bias_upper, plain = (np.empty(replicates) for _ in range(8))
    for seed in range(replicates):
        truth[seed], truth_bias[seed], high, low, weights, strata, plain[seed] = stratified_pairs(seed, sizes)
        runout = pair_validation(high, low, weights, strata, seed=seed)["runout_m"]
        estimate[seed], lower[seed], upper[seed] = runout["r2"]
        _, bias_lower[seed], bias_upper[seed] = runout["bias"]
    # the mean's sampling error, and a fifth of the spread for the O(1/n) bias of a ratio of estimated moments
    spread = estimate.std()
    tolerance = 3 * spread / np.sqrt(replicates) + 0.2 * spread
    assert abs(estimate.mean() - truth.mean()) < tolerance < abs(plain.mean() - truth.mean())
    se = np.sqrt(0.95 * 0.05 / replicates)
    for low_end, high_end, value in ((lower, upper, truth), (bias_lower, bias_upper, truth_bias)):
        coverage = np.mean((low_end <= value) & (value <= high_end))
        assert 0.95 - 3 * se <= coverage <= 0.95 + 3 * se and coverage < 1.0, coverage
        assert (value < low_end).any() and (value > high_end).any()
