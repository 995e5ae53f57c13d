"""The multilevel estimator over nested fidelities and its Richardson step: reduces to its limits,
unbiased and covering over many replicates of synthetic chains with a known answer."""

import numpy as np
import pytest

from rgns.fidelity.multifidelity import MultiFidelityError, control_variate
from rgns.fidelity.multilevel import extrapolated, multilevel, richardson_step

TRUE_MEAN = 5.0


def chain(rng: np.random.Generator, counts: tuple[int, ...]) -> list[np.ndarray]:
    """Finest F0 ~ N(5, 1); level 1 = F0 + 0.6 + noise (correlation 0.97); level 2 a cheap route,
    biased (+1.5, scaled 0.8), correlation 0.9 with F0. Level k holds the first counts[k] realizations."""
    size = counts[-1]
    f0 = rng.normal(TRUE_MEAN, 1.0, size)
    f1 = f0 + 0.6 + 0.25 * rng.normal(size=size)
    f2 = 0.8 * (0.9 * (f0 - TRUE_MEAN) + np.sqrt(1 - 0.81) * rng.normal(size=size)) + TRUE_MEAN + 1.5
    return [f[:n, None] for f, n in zip((f0, f1, f2), counts)]


def test_with_one_cheap_level_it_is_the_two_level_control_variate():
    levels = chain(np.random.default_rng(0), (20, 20, 300))
    two = control_variate(levels[0], levels[2], resamples=999, seed=3)
    one = multilevel([levels[0], levels[2]], resamples=999, seed=3)
    assert one.estimate[0] == pytest.approx(two.estimate[0], abs=1e-12)
    assert one.weights[1][0] == pytest.approx(two.weight[0], abs=1e-12)


def test_with_every_realization_run_at_every_level_it_is_the_finest_plain_mean():
    levels = chain(np.random.default_rng(1), (50, 50, 50))
    result = multilevel(levels, resamples=999)
    assert result.estimate[0] == pytest.approx(levels[0].mean(), abs=1e-12)
    assert all(abs(c[0]) < 1e-12 for c in result.corrections)
    half = 1.96 * levels[0].std(ddof=1) / np.sqrt(50)
    assert result.upper[0] - result.lower[0] == pytest.approx(2 * half, rel=0.15)


def test_three_levels_are_unbiased_cover_and_beat_the_finest_alone_over_many_replicates():
    rng = np.random.default_rng(2)
    replicates, counts = 300, (16, 64, 512)
    estimates, covered, plain = [], [], []
    for k in range(replicates):
        levels = chain(rng, counts)
        result = multilevel(levels, resamples=999, seed=k)
        estimates.append(result.estimate[0])
        covered.append(result.lower[0] <= TRUE_MEAN <= result.upper[0])
        plain.append(levels[0].mean())
    estimates = np.array(estimates)
    assert abs(estimates.mean() - TRUE_MEAN) < 3 * estimates.std(ddof=1) / np.sqrt(replicates)
    assert abs(np.mean(covered) - 0.95) < 3 * np.sqrt(0.95 * 0.05 / replicates), np.mean(covered)
    assert estimates.var(ddof=1) < 0.5 * np.var(plain, ddof=1)


def mesh_chain(rng: np.random.Generator, counts: tuple[int, ...], order: float = 1.3) -> list[np.ndarray]:
    """A realization's converged value X ~ N(5, 1) and its mesh error 2 h^order (1 + 0.2 Z): the 0.25 m
    and 0.5 m levels fall short of X, and a cheap route correlates with the 0.5 m level."""
    size = counts[-1]
    converged = rng.normal(TRUE_MEAN, 1.0, size)
    scale = 1.0 + 0.2 * rng.normal(size=size)
    fine, coarse = converged - 2.0 * 0.25**order * scale, converged - 2.0 * 0.5**order * scale
    cheap = coarse + 0.3 + 0.3 * rng.normal(size=size)
    return [f[:n, None] for f, n in zip((fine, coarse, cheap), counts)]


def test_the_richardson_step_recovers_the_converged_answer_that_the_finest_mesh_misses():
    assert richardson_step(9.0, 8.0, 2.0, 1.0) == pytest.approx(1.0)  # h-linear: the finer misses what it gained
    rng = np.random.default_rng(4)
    replicates = 200
    finest_covered, covered, estimates = [], [], []
    for k in range(replicates):
        result = extrapolated(
            mesh_chain(rng, (16, 64, 512)), ratio=2.0, order=1.3, order_interval=(1.1, 1.5), resamples=999, seed=k
        )
        estimates.append(result.estimate[0])
        covered.append(result.lower[0] <= TRUE_MEAN <= result.upper[0])
        finest_covered.append(result.finest.lower[0] <= TRUE_MEAN <= result.finest.upper[0])
        assert result.mesh_error_range[0][0] <= result.mesh_error[0] <= result.mesh_error_range[1][0]
    estimates = np.array(estimates)
    assert abs(estimates.mean() - TRUE_MEAN) < 3 * estimates.std(ddof=1) / np.sqrt(replicates)
    assert np.mean(covered) >= 0.95 - 3 * np.sqrt(0.95 * 0.05 / replicates), np.mean(covered)
    assert np.mean(finest_covered) < 0.5  # the 0.25 m mesh alone is 0.33 short: its interval misses


@pytest.mark.parametrize(
    "levels, message",
    [
        ([np.ones((1, 1))], "at least 2 realizations"),
        ([np.ones((4, 1)), np.ones((3, 1))], "nested"),
        ([np.ones((4, 1)), np.ones((8, 2))], "differ in their quantities"),
        ([np.ones((4, 1)), np.full((8, 1), np.nan)], "level 1 holds NaN"),
    ],
)
def test_bad_input_is_named(levels, message):
    with pytest.raises(MultiFidelityError, match=message):
        multilevel(levels)
