"""The embedded MPM engine against analytic solutions, known scaling laws and conservation."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from mpm_cases import ELASTIC, cfl_sweep_case, polygon_case, stiffness_sweep_cases

from rgns.engines.mpm.mohr_coulomb import MohrCoulomb, return_map, yield_function
from rgns.engines.mpm.shape import BASES, Region, RegularGrid
from rgns.engines.mpm.solver import EngineSettings, basis_of, particles_of, run_batch
from rgns.engines.mpm.step import p2g

G = 9.81


@pytest.fixture(autouse=True)
def one_thread():
    torch.set_num_threads(1)


@pytest.fixture(scope="module", params=["numba", "torch"])
def backend(request) -> str:
    """Every run below on each backend: the compiled kernels (the CPU default) and the torch engine."""
    return request.param


@pytest.mark.parametrize("shape", ["linear", "bspline"])
def test_shape_functions_are_a_partition_of_unity_and_reproduce_linear_fields(shape):
    basis = BASES[shape](RegularGrid((-1.0, -1.0), 0.5, (20, 12)), Region((2, 2), (18, 10)))
    points = torch.rand(2000, 2, dtype=torch.float64) * torch.tensor([8.0, 4.0])  # the whole region, to its edges
    weights = basis(points[:, 0], points[:, 1])
    dof_x, dof_y = basis.dof_coordinates()
    node_x, node_y = dof_x[weights.nodes], dof_y[weights.nodes]
    assert weights.inside.all() and (weights.value >= 0).all()
    torch.testing.assert_close(weights.value.sum(0), torch.ones(2000, dtype=torch.float64))
    torch.testing.assert_close((weights.value * node_x).sum(0), points[:, 0])
    torch.testing.assert_close((weights.grad_x * node_x).sum(0), torch.ones(2000, dtype=torch.float64))
    torch.testing.assert_close((weights.grad_y * node_y).sum(0), torch.ones(2000, dtype=torch.float64))
    torch.testing.assert_close((weights.grad_y * node_x).sum(0), torch.zeros(2000, dtype=torch.float64))


@pytest.mark.parametrize("dilation_deg", [0.0, 10.0, 30.0])
def test_return_mapping_lands_every_stress_on_or_inside_the_yield_surface(dilation_deg):
    generator = torch.Generator().manual_seed(0)
    trial = torch.randn(50_000, 4, generator=generator, dtype=torch.float64) * 1e5 - 5e4
    material = MohrCoulomb.from_parameters(1e7, 0.3, 30.0, dilation_deg, 1000.0, 1e9, trial[:, 0])
    stress, yielded = return_map(*trial.unbind(1), material)
    assert yield_function(*stress, material).max() < 1e-6 * 1e5
    elastic = yield_function(*trial.unbind(1), material) <= 0
    torch.testing.assert_close(torch.stack(stress, 1)[elastic], trial[elastic])
    assert yielded[~elastic].all()


def test_the_tension_cutoff_caps_principal_stresses():
    trial = torch.tensor([[5e3, 2e3, 1e3, 0.0], [-1e4, 3e3, -2e3, 1e3]], dtype=torch.float64)
    material = MohrCoulomb.from_parameters(1e7, 0.3, 30.0, 0.0, 1e6, 100.0, trial[:, 0])
    stress, _ = return_map(*trial.unbind(1), material)
    sxx, syy, szz, txy = stress
    largest = torch.maximum(0.5 * (sxx + syy) + torch.sqrt((0.5 * (sxx - syy)) ** 2 + txy**2), szz)
    assert (largest <= 100.0 + 1e-9).all()


@pytest.mark.parametrize("shape", ["linear", "bspline"])
def test_mapping_to_the_grid_conserves_mass_and_momentum_exactly(tmp_path, default_config, shape):
    case = polygon_case(tmp_path / "case", [[1, 0], [6, 0], [4, 3], [1, 3]], 12.0, 5.0)
    particles = particles_of([case, case], EngineSettings(shape_function=shape), torch.device("cpu"))
    particles.vx = torch.linspace(-2.0, 3.0, len(particles.mass), dtype=torch.float64)
    basis, boundary = basis_of(case, shape, torch.device("cpu"))
    nodal = p2g(particles, basis(particles.x, particles.y), basis.n_nodes, boundary.repeat(2), 2)
    assert nodal.mass.sum().item() == pytest.approx(particles.mass.sum().item(), rel=1e-13)
    assert (nodal.mass * nodal.vx).sum().item() == pytest.approx(
        (particles.mass * particles.vx).sum().item(), rel=1e-12
    )


def test_elastic_column_settles_to_the_weight_of_the_soil_above(tmp_path, backend):
    height = 10.0
    case = polygon_case(
        tmp_path / "column",
        [[0, 0], [2, 0], [2, height], [0, height]],
        2.0,
        12.0,
        geostatic_stress=False,
        damping_factor=0.05,
        **ELASTIC,
    )
    result = run_batch([case], EngineSettings(early_stop=False, backend=backend), duration_s=2.0)[0]
    mid_depth = np.abs(case.positions[:, 1] - height / 2) < 0.3
    expected = -case.density_kg_m3[mid_depth] * G * (height - case.positions[mid_depth, 1])
    ratio = result.final_stress[mid_depth, 1].mean() / expected.mean()
    assert ratio == pytest.approx(1.0, abs=0.03)


@pytest.mark.parametrize("shape", ["linear", "bspline"])
def test_a_block_sliding_on_the_floor_stops_at_the_coulomb_distance(tmp_path, shape, backend):
    mu, speed = 0.5, 5.0
    case = polygon_case(
        tmp_path / "block",
        [[1, 0], [5, 0], [5, 2], [1, 2]],
        20.0,
        4.0,
        cell_size_m=0.25,
        floor_friction=mu,
        k0=0.3 / 0.7,
        **ELASTIC,
    )
    start = np.tile([speed, 0.0], (len(case.positions), 1))
    # Pure PIC damps the block's elastic vibration, which under FLIP makes the floor's normal force
    # flicker and over-brakes (measured: 0.63 of the Coulomb distance at E = 100 MPa).
    result = run_batch(
        [case],
        EngineSettings(early_stop=False, shape_function=shape, pic_blend=1.0, backend=backend),
        duration_s=2.0,
        initial_velocity=[start],
    )[0]
    distance = (result.positions[-1, :, 0] - result.positions[0, :, 0]).mean()
    assert distance == pytest.approx(speed**2 / (2 * mu * G), rel=0.05)
    assert np.abs(result.positions[-1, :, 0] - result.positions[-5, :, 0]).max() < 1e-3  # it has stopped


@pytest.fixture(scope="module")
def column_collapse(tmp_path_factory, backend):
    """Granular columns of width 2 m and several aspect ratios, one batch (references.md)."""
    width = 2.0
    specs = [(a, 35.0) for a in (0.5, 0.75, 1.0, 1.25, 1.5, 3.0, 4.0, 6.0)] + [(1.5, 45.0), (3.0, 45.0)]
    directory = tmp_path_factory.mktemp("collapse")
    cases = [
        polygon_case(
            directory / f"{i}",
            [[0, 0], [width, 0], [width, a * width], [0, a * width]],
            36.0,
            13.0,
            cell_size_m=0.25,
            friction_deg=phi,
            index=i,
            youngs_modulus_pa=5e6,
            floor_friction=float(np.tan(np.radians(phi))),
        )
        for i, (a, phi) in enumerate(specs)
    ]
    torch.set_num_threads(1)
    results = run_batch(cases, EngineSettings(shape_function="bspline", backend=backend), duration_s=6.0)
    runout = {spec: (result.positions[-1, :, 0].max() - width) / width for spec, result in zip(specs, results)}
    return runout, results


def _log_slope(runout: dict, aspect_ratios: tuple) -> float:
    a = np.array(aspect_ratios)
    return float(np.polyfit(np.log(a), np.log([runout[(x, 35.0)] for x in aspect_ratios]), 1)[0])


def test_column_collapse_runout_scales_linearly_at_low_aspect_ratio(column_collapse):
    runout, results = column_collapse
    assert all(result.status == "ok" for result in results)
    small = _log_slope(runout, (0.5, 0.75, 1.0, 1.25, 1.5))
    print(f"normalized runout {dict((k, round(v, 2)) for k, v in runout.items())}; log-log slope a <= 1.5: {small:.3f}")
    assert small == pytest.approx(1.0, abs=0.2)
    assert np.all(np.diff([runout[(a, 35.0)] for a in (0.5, 0.75, 1.0, 1.25, 1.5, 3.0, 4.0, 6.0)]) > 0)


def test_column_collapse_runout_grows_more_slowly_at_high_aspect_ratio(column_collapse):
    runout, _ = column_collapse
    small = _log_slope(runout, (0.5, 0.75, 1.0, 1.25, 1.5))
    large = _log_slope(runout, (3.0, 4.0, 6.0))
    print(f"log-log slope a >= 3: {large:.3f} (a <= 1.5: {small:.3f}; experiments: about 2/3 and 1)")
    assert large < small - 0.15


def test_column_collapse_runout_is_shorter_with_higher_friction(column_collapse):
    runout, _ = column_collapse
    for a in (1.5, 3.0):
        assert runout[(a, 45.0)] < 0.9 * runout[(a, 35.0)]


# The two stability sweeps run on the default engine, the kernels; the torch engine runs the same algorithm and is
# held to the kernels' steps, statuses, positions and energies on the sweeps' hardest settings (the stiffest soil,
# cfl 1.0) in tests/engines/test_mpm_backends.py, where a 2 s window costs it a tenth of these 20 s sweeps.


@pytest.mark.parametrize("youngs_modulus_pa", [1e6, 1e7, 1e8])
def test_no_nan_and_no_energy_gain_across_stiffness_friction_and_slope_angle(tmp_path, youngs_modulus_pa):
    """Twice the default 10 s, early stop off: every run finishes, mass fixed, energy never gains > 1 %."""
    cases = stiffness_sweep_cases(tmp_path, youngs_modulus_pa)
    results = run_batch(cases, EngineSettings(early_stop=False, backend="numba"), duration_s=20.0)
    for case, result in zip(cases, results):
        assert result.status == "ok", (case.directory, result.status)
        assert np.isfinite(result.positions).all()
        total = result.energies.sum(axis=1)
        assert total.max() <= 1.01 * total[0], (case.directory, total.max() / total[0])
        assert case.volumes.sum() * case.density_kg_m3[0] == pytest.approx(
            sum(case.volumes * case.density_kg_m3), rel=1e-12
        )


@pytest.mark.parametrize("cell_size_m", [0.5, 1.0, 2.0])
def test_no_nan_and_no_energy_gain_across_cell_size_and_time_step_up_to_the_cfl_limit(tmp_path, cell_size_m):
    """A 60-degree slope four cells high at cfl 0.1 ... 1.0 (dt up to the CFL limit): each run finishes
    without a non-finite state or an energy gain above 1 %, or is flagged diverged with its reason."""
    cfls = (0.1, 0.2, 0.5, 1.0)
    outcomes = {}
    for cfl in cfls:
        case, toe = cfl_sweep_case(tmp_path / f"{cfl}", cell_size_m)
        settings = EngineSettings(early_stop=False, cfl=cfl, backend="numba")
        result = run_batch([case], settings, duration_s=5.0)[0]
        outcomes[cfl] = result.status
        if result.status == "ok":
            assert np.isfinite(result.positions).all()
            total = result.energies.sum(axis=1)
            assert total.max() <= 1.01 * total[0], (cfl, total.max() / total[0])
            assert result.positions[-1, :, 0].max() > toe + 1.0  # it failed and ran out
        else:
            assert result.status.startswith("diverged: ") and " by t = " in result.status, result.status
    print(f"cell {cell_size_m} m: {outcomes}")
    assert outcomes[0.1] == outcomes[0.2] == "ok"


def test_keeping_only_the_ends_returns_exactly_those_frames_of_a_full_run(tmp_path, backend):
    cases = [
        polygon_case(
            tmp_path / f"{phi}", [[0, 0], [8, 0], [4, 3], [0, 3]], 16.0, 4.0, cell_size_m=1.0, friction_deg=phi, index=k
        )
        for k, phi in enumerate((20.0, 45.0))
    ]
    settings = EngineSettings(early_stop=True, early_stop_duration_s=0.25, backend=backend)
    full = run_batch(cases, settings, duration_s=3.0, frame_interval_s=0.05)
    ends = run_batch(cases, settings, duration_s=3.0, frame_interval_s=0.05, keep="ends")
    assert full[1].stopped_at_s is not None  # the 37-degree face stands at 45 degrees of friction and stops early
    for a, b in zip(full, ends):
        assert (a.status, a.stopped_at_s) == (b.status, b.stopped_at_s)
        np.testing.assert_array_equal(b.positions, a.positions[[0, -2, -1]])
        np.testing.assert_array_equal(b.time_s, a.time_s[[0, -2, -1]])
        np.testing.assert_array_equal(b.energies, a.energies)


@pytest.fixture(scope="module")
def unpadded_runs(tmp_path_factory, backend):
    """A column collapse and a failing slope on meshes that end at the walls and the floor (as CB-Geo
    users write them), and the same slope on the padded mesh rgns writes: B-splines, default settings."""
    import rgns.scene.build as build

    directory = tmp_path_factory.mktemp("unpadded")
    torch.set_num_threads(1)
    padding = build.PAD_CELLS
    try:
        build.PAD_CELLS = 0
        column = polygon_case(directory / "column", [[0, 0], [4, 0], [4, 8], [0, 8]], 24.0, 10.0, cell_size_m=0.5)
        slope = polygon_case(
            directory / "slope", [[0, 0], [36, 0], [24, 10], [0, 10]], 60.0, 14.0, cell_size_m=1.0, index=1
        )
    finally:
        build.PAD_CELLS = padding
    padded = polygon_case(
        directory / "padded", [[0, 0], [36, 0], [24, 10], [0, 10]], 60.0, 14.0, cell_size_m=1.0, index=2
    )
    assert column.nodes.min() == 0.0 and padded.nodes.min() < 0.0
    settings = EngineSettings(shape_function="bspline", backend=backend)
    return (column, slope, padded), [run_batch([case], settings, duration_s=5.0)[0] for case in (column, slope, padded)]


def test_bsplines_run_on_a_mesh_without_padding_and_no_particle_crosses_the_floor_or_a_wall(unpadded_runs):
    (column, slope, _), results = unpadded_runs
    for case, result in zip((column, slope), results):
        final = result.positions[-1]
        length = case.nodes[:, 0].max()
        print(
            f"{case.directory.name}: {result.status}, front {final[:, 0].max():.2f} m, lowest y {final[:, 1].min():.4f} m"
        )
        assert result.status == "ok"
        assert (result.positions[..., 1] >= 0).all() and (result.positions[..., 0] >= 0).all()
        assert (result.positions[..., 0] <= length).all()
    assert (results[0].positions[-1, :, 0].max() - 4.0) / 4.0 > 1.0  # the aspect-2 column spreads over its width
    assert results[1].positions[-1, :, 0].max() > 36.0 + 3.0  # the 40-degree face at phi 30 fails and runs out


def test_bsplines_give_the_same_run_with_and_without_padding_beyond_the_walls(unpadded_runs):
    _, (_, slope, padded) = unpadded_runs
    np.testing.assert_allclose(padded.positions, slope.positions, atol=1e-9)


def test_a_particle_pushed_out_of_the_region_is_flagged_diverged(tmp_path, backend):
    case = polygon_case(tmp_path / "case", [[1, 0], [5, 0], [5, 2], [1, 2]], 10.0, 3.0, cell_size_m=0.5)
    start = np.zeros((len(case.positions), 2))
    start[:, 1] = 200.0  # upwards, through the mesh edge (the top has no wall)
    result = run_batch(
        [case], EngineSettings(early_stop=False, backend=backend), duration_s=0.5, initial_velocity=[start]
    )[0]
    assert result.status.startswith("diverged: ") and "past a wall, the floor or the mesh edge" in result.status


def test_a_slope_limit_equilibrium_says_must_fail_fails_at_one_metre_cells_with_bsplines_not_with_bilinear(
    tmp_path, backend
):
    """Volumetric locking: the 39.8-degree long slope at phi 34 (infinite-slope FS = tan 34 / tan 39.8 = 0.81)
    stands on the bilinear 1 m mesh with 2 x 2 points per cell, and runs out with the default B-splines."""
    case = polygon_case(
        tmp_path / "slope", [[0, 0], [36, 0], [24, 10], [0, 10]], 60.0, 14.0, cell_size_m=1.0, friction_deg=34.0
    )
    fronts = {}
    for shape in ("linear", "bspline"):
        result = run_batch([case], EngineSettings(shape_function=shape, backend=backend), duration_s=6.0)[0]
        assert result.status == "ok"
        fronts[shape] = result.positions[-1, :, 0].max() - case.positions[:, 0].max()
    print(f"front advance at phi 34, 1 m cells: {fronts}")
    assert fronts["linear"] < 0.25 and fronts["bspline"] > 2.0


def test_a_realization_runs_the_same_alone_and_in_a_batch_each_at_its_own_time_step(tmp_path, backend):
    """The step follows each realization's own fastest particle: a slope that fails and one that stands take
    different steps, and each runs the same steps alone and batched (no batchmate sets them), to the same stored
    frames; its stresses agree to rounding (vectorised math rounds a particle by its place in the array)."""
    cases = [
        polygon_case(
            tmp_path / f"{phi}", [[0, 0], [8, 0], [4, 3], [0, 3]], 16.0, 4.0, cell_size_m=1.0, friction_deg=phi, index=k
        )
        for k, phi in enumerate((15.0, 45.0))
    ]
    settings = EngineSettings(early_stop=False, backend=backend)
    together = run_batch(cases, settings, duration_s=2.0, frame_interval_s=0.05)
    alone = [run_batch([case], settings, duration_s=2.0, frame_interval_s=0.05)[0] for case in cases]
    assert together[0].steps > together[1].steps  # the failing slope's speed shortens its own step only
    for batched, single in zip(together, alone):
        assert batched.steps == single.steps
        np.testing.assert_array_equal(batched.positions, single.positions)
        np.testing.assert_allclose(batched.final_stress, single.final_stress, rtol=1e-12, atol=1e-9)
