"""Random fields: SNX correlation theory, the two factorisations, seeds, clipping, mapping."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from rgns.scene.fields import (
    CholeskySampler,
    FieldGrid,
    KroneckerSampler,
    exponential_cholesky_1d,
    friction_field,
    read_field,
    realize_fields,
    snx_correlation_1d,
    write_field,
)

GROUP = {
    "friction_mean_deg": 30.0,
    "friction_std_deg": 5.0,
    "correlation_length_x_m": 10.0,
    "correlation_length_y_m": 4.0,
}
BOUNDS = (0.01, 89.99)  # wide enough that nothing is clipped
N_FIELDS = 2000


@pytest.mark.parametrize("n, spacing, length", [(1, 1.0, 3.0), (7, 2.0, 40.0), (30, 2.0, 15.0), (120, 2.0, 50.0)])
def test_closed_form_1d_cholesky_factor_matches_numpy(n, spacing, length):
    coords = (np.arange(n) + 0.5) * spacing
    reference = np.linalg.cholesky(snx_correlation_1d(coords, length))
    np.testing.assert_allclose(exponential_cholesky_1d(n, spacing, length), reference, atol=1e-12)


def test_kronecker_factor_is_exactly_the_full_cholesky_factor():
    grid = FieldGrid.covering(12.0, 6.0, 1.0)
    kron = KroneckerSampler(grid, 7.0, 3.0)
    full = CholeskySampler(grid, 7.0, 3.0)
    np.testing.assert_allclose(np.kron(kron.lx, kron.ly), full.factor, atol=1e-10)


def test_both_methods_map_the_same_normals_to_the_same_field():
    grid = FieldGrid.covering(20.0, 8.0, 1.0)
    normals = np.random.default_rng(0).standard_normal((5, *grid.shape))
    kron = KroneckerSampler(grid, 9.0, 2.0).correlate(normals)
    full = CholeskySampler(grid, 9.0, 2.0).correlate(normals)
    np.testing.assert_allclose(kron, full, atol=1e-10)


def _standardized(method: str, set_name: str, grid: FieldGrid) -> np.ndarray:
    raw, _, _ = realize_fields(1234, set_name, list(range(N_FIELDS)), GROUP, grid, method, BOUNDS)
    return (raw - GROUP["friction_mean_deg"]) / GROUP["friction_std_deg"]


def _lag_estimates(z: np.ndarray, lag: int, axis: int) -> np.ndarray:
    """Per-field mean of z(p)·z(p + lag) along ``axis``: one estimate of ρ(lag) per field."""
    n = z.shape[axis + 1]
    head = np.take(z, range(0, n - lag), axis=axis + 1)
    tail = np.take(z, range(lag, n), axis=axis + 1)
    return (head * tail).reshape(len(z), -1).mean(axis=1)


@pytest.fixture(scope="module")
def grid() -> FieldGrid:
    return FieldGrid.covering(30.0, 16.0, 1.0)


@pytest.fixture(scope="module")
def kronecker_fields(grid) -> np.ndarray:
    return _standardized("kronecker", "train", grid)


@pytest.fixture(scope="module")
def cholesky_fields(grid) -> np.ndarray:
    return _standardized("cholesky", "valid", grid)


@pytest.mark.parametrize("axis, length_key", [(0, "correlation_length_x_m"), (1, "correlation_length_y_m")])
@pytest.mark.parametrize("lag", [0, 1, 2, 5])
def test_empirical_correlation_of_kronecker_fields_matches_snx_theory(kronecker_fields, lag, axis, length_key):
    estimates = _lag_estimates(kronecker_fields, lag, axis)
    theory = np.exp(-2.0 * lag * 1.0 / GROUP[length_key])
    standard_error = estimates.std(ddof=1) / np.sqrt(len(estimates))
    assert abs(estimates.mean() - theory) < 3.0 * standard_error, (estimates.mean(), theory, standard_error)


@pytest.mark.parametrize("axis", [0, 1])
@pytest.mark.parametrize("lag", [0, 1, 2, 5])
def test_cholesky_and_kronecker_fields_agree_in_correlation(kronecker_fields, cholesky_fields, lag, axis):
    kron = _lag_estimates(kronecker_fields, lag, axis)
    full = _lag_estimates(cholesky_fields, lag, axis)
    standard_error = np.hypot(kron.std(ddof=1), full.std(ddof=1)) / np.sqrt(N_FIELDS)
    assert abs(kron.mean() - full.mean()) < 3.0 * standard_error


def test_cholesky_and_kronecker_fields_agree_in_marginal_distribution(kronecker_fields, cholesky_fields):
    for cell in [(0, 0), (15, 8), (29, 15)]:
        result = stats.ks_2samp(kronecker_fields[:, cell[0], cell[1]], cholesky_fields[:, cell[0], cell[1]])
        assert result.pvalue > 1e-3, (cell, result)
        assert stats.kstest(kronecker_fields[:, cell[0], cell[1]], "norm").pvalue > 1e-3


def test_a_realization_reproduces_whatever_the_batch_it_is_drawn_in(grid):
    alone = realize_fields(5, "case1", [7], GROUP, grid, "kronecker", BOUNDS)[0][0]
    batched = realize_fields(5, "case1", [3, 7, 9], GROUP, grid, "kronecker", BOUNDS)[0][1]
    reversed_batch = realize_fields(5, "case1", [9, 7], GROUP, grid, "kronecker", BOUNDS)[0][1]
    np.testing.assert_array_equal(alone, batched)
    np.testing.assert_array_equal(alone, reversed_batch)
    other_index = realize_fields(5, "case1", [8], GROUP, grid, "kronecker", BOUNDS)[0][0]
    other_set = realize_fields(5, "case2", [7], GROUP, grid, "kronecker", BOUNDS)[0][0]
    other_seed = realize_fields(6, "case1", [7], GROUP, grid, "kronecker", BOUNDS)[0][0]
    for other in (other_index, other_set, other_seed):
        assert not np.allclose(alone, other)


def test_training_means_are_uniform_over_the_configured_range(grid):
    group = dict(GROUP, friction_mean_deg=[20.0, 35.0])
    _, _, means = realize_fields(
        1, "train", list(range(N_FIELDS)), group, FieldGrid.covering(4, 2, 1.0), "kronecker", BOUNDS
    )
    assert means.min() >= 20.0 and means.max() <= 35.0
    assert stats.kstest(means, stats.uniform(loc=20.0, scale=15.0).cdf).pvalue > 1e-3


def test_clipping_keeps_friction_inside_bounds_and_records_the_fraction(grid):
    group = dict(GROUP, friction_std_deg=10.0)
    bounds = (25.0, 35.0)
    raw, clipped, _ = realize_fields(3, "train", [0], group, grid, "kronecker", bounds)
    assert clipped.min() >= 25.0 and clipped.max() <= 35.0
    inside = (raw >= 25.0) & (raw <= 35.0)
    np.testing.assert_array_equal(clipped[inside], raw[inside])
    positions = np.array([[0.5, 0.5]])
    field = friction_field(3, "train", 0, group, grid, "kronecker", bounds, positions)
    assert field.clipped_fraction == pytest.approx(1.0 - inside.mean())
    assert 0.0 < field.clipped_fraction < 1.0


def test_particles_take_the_value_of_the_cell_that_contains_them(grid, tmp_path):
    positions = np.array([[0.2, 0.3], [0.99, 0.01], [12.5, 7.5], [29.9, 15.99], [30.0, 16.0]])
    field = friction_field(9, "case3", 4, GROUP, grid, "kronecker", BOUNDS, positions)
    expected = [
        field.friction_grid_deg[0, 0],
        field.friction_grid_deg[0, 0],
        field.friction_grid_deg[12, 7],
        field.friction_grid_deg[29, 15],
        field.friction_grid_deg[29, 15],
    ]
    np.testing.assert_array_equal(field.friction_deg, expected)
    path = tmp_path / "field.npz"
    write_field(str(path), field)
    again = read_field(str(path))
    np.testing.assert_array_equal(again.friction_deg, field.friction_deg)
    np.testing.assert_array_equal(again.friction_grid_deg, field.friction_grid_deg)
    assert (again.mean_deg, again.method, again.grid.shape) == (field.mean_deg, "kronecker", grid.shape)


def test_a_truncated_field_file_is_reported_by_name(tmp_path):
    grid = FieldGrid.covering(4.0, 2.0, 1.0)
    field = friction_field(1, "train", 0, GROUP, grid, "kronecker", BOUNDS, np.array([[1.0, 1.0]]))
    path = tmp_path / "0000.npz"
    write_field(str(path), field)
    path.write_bytes(path.read_bytes()[:40])
    with pytest.raises(ValueError, match="0000.npz"):
        read_field(str(path))
