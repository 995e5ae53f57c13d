"""The compiled kernels (backend numba) against the torch engine: the same step, the same answers to rounding."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from mpm_cases import ELASTIC, cfl_sweep_case, polygon_case, stiffness_sweep_cases

from rgns.config import ConfigError, load_config, validate_config
from rgns.engines.mpm.solver import EngineSettings, run_batch


@pytest.fixture(autouse=True)
def one_thread():
    torch.set_num_threads(1)


def both(cases, duration_s: float, initial_velocity=None, **settings):
    """The runs of ``cases`` (one batch) by each backend."""
    return [
        run_batch(
            cases,
            EngineSettings(backend=backend, **settings),
            duration_s=duration_s,
            frame_interval_s=0.05,
            initial_velocity=initial_velocity,
        )
        for backend in ("numba", "torch")
    ]


def assert_same_runs(kernels, reference, stress_rtol: float = 1e-12) -> None:
    """Same steps, status and stored frames; stresses to ``stress_rtol`` of the largest; energies to rounding."""
    for a, b in zip(kernels, reference):
        assert (a.steps, a.status, a.stopped_at_s) == (b.steps, b.status, b.stopped_at_s)
        np.testing.assert_allclose(a.positions, b.positions, rtol=0, atol=1e-5)  # float32 frames: a last bit
        scale = np.abs(b.final_stress).max()
        assert np.abs(a.final_stress - b.final_stress).max() <= stress_rtol * scale
        np.testing.assert_allclose(a.energies, b.energies, rtol=1e-10, atol=1e-9 * np.abs(b.energies).max())


def test_a_failing_and_a_standing_slope_batched_agree_on_both_backends(tmp_path):
    """B-splines, Mohr-Coulomb yielding, early stop, each realization at its own step, 2 s (about 800 steps)."""
    cases = [
        polygon_case(
            tmp_path / f"{phi}", [[0, 0], [8, 0], [4, 3], [0, 3]], 16.0, 4.0, cell_size_m=0.5, friction_deg=phi, index=k
        )
        for k, phi in enumerate((15.0, 45.0))
    ]
    kernels, reference = both(cases, 2.0, early_stop_duration_s=0.25)
    assert kernels[0].positions[-1, :, 0].max() > 9.0 and kernels[1].stopped_at_s is not None  # one fails, one stands
    assert_same_runs(kernels, reference)


@pytest.mark.parametrize("pic_blend", [0.0, 0.3])
def test_a_block_sliding_on_the_friction_floor_agrees_on_both_backends_with_bilinear_cells(tmp_path, pic_blend):
    """The bilinear basis, the Coulomb floor (kinetic and static branches), FLIP and a PIC blend."""
    case = polygon_case(
        tmp_path / "block", [[1, 0], [5, 0], [5, 2], [1, 2]], 20.0, 4.0, cell_size_m=0.5, floor_friction=0.5, **ELASTIC
    )
    start = [np.tile([5.0, 0.0], (len(case.positions), 1))]
    kernels, reference = both([case], 1.5, start, shape_function="linear", early_stop=False, pic_blend=pic_blend)
    assert_same_runs(kernels, reference)


def test_a_damped_column_with_a_tension_cutoff_agrees_on_both_backends_within_the_torch_engines_own_spread(tmp_path):
    """Cundall damping, the tension cutoff and dilation in the return map, on a cell size that is no power of two.

    Damping turns on the sign of each nodal velocity, so this run is chaotic at rounding level: the torch engine
    itself moves its particles by about 1e-4 m when its start is nudged by 1e-13 m/s. The kernels (whose sums are
    ordered otherwise) must stay within that spread of the torch engine, in positions and in stresses."""
    case = polygon_case(
        tmp_path / "column",
        [[0, 0], [3, 0], [3, 6], [0, 6]],
        15.0,
        7.5,
        cell_size_m=0.75,
        damping_factor=0.05,
        dilation_deg=10.0,
        tension_cutoff_pa=500.0,
    )
    (kernels,), (reference,) = both([case], 1.5, early_stop=False)
    (nudged,) = run_batch(
        [case],
        EngineSettings(backend="torch", early_stop=False),
        duration_s=1.5,
        frame_interval_s=0.05,
        initial_velocity=[np.tile([1e-13, 0.0], (len(case.positions), 1))],
    )
    assert (kernels.steps, kernels.status) == (reference.steps, reference.status) == (nudged.steps, nudged.status)
    for name in ("positions", "final_stress"):
        spread = np.abs(getattr(nudged, name) - getattr(reference, name)).max()
        assert np.abs(getattr(kernels, name) - getattr(reference, name)).max() <= spread, name


def test_the_stability_sweeps_stiffest_soil_agrees_on_both_backends(tmp_path):
    """The stiffness sweep of tests/engines/test_mpm_physics.py at its stiffest, 1e8 Pa (the shortest steps: about
    2,800 in 2 s), all nine slopes in one batch, each at its own step; seven of them fail, moving 0.6 to 7 m."""
    kernels, reference = both(stiffness_sweep_cases(tmp_path, 1e8), 2.0, early_stop=False)
    assert_same_runs(kernels, reference)


@pytest.mark.parametrize("cell_size_m", [0.5, 2.0])
def test_the_time_step_sweep_at_its_largest_step_agrees_on_both_backends(tmp_path, cell_size_m):
    """The time-step sweep of tests/engines/test_mpm_physics.py at cfl 1.0, its longest step (800 steps in 2 s),
    the slope failing and running out metres past its toe."""
    case, _ = cfl_sweep_case(tmp_path, cell_size_m)
    kernels, reference = both([case], 2.0, early_stop=False, cfl=1.0)
    assert_same_runs(kernels, reference)


def test_auto_picks_the_kernels_on_the_cpu_in_float64_and_torch_otherwise():
    assert EngineSettings().kernels and not EngineSettings(backend="torch").kernels
    assert not EngineSettings(dtype="float32").kernels and not EngineSettings(device="meta").kernels
    with pytest.raises(ValueError, match="mpm.embedded.backend = 'numba'"):
        _ = EngineSettings(backend="numba", dtype="float32").kernels


def test_the_config_refuses_the_kernels_on_a_gpu_naming_the_key():
    config = load_config()
    config["mpm"]["embedded"] |= {"backend": "numba", "device": "cuda"}
    with pytest.raises(ConfigError, match="config key mpm.embedded.backend = 'numba'.*'cuda'"):
        validate_config(config)


def test_the_compile_rule_compiles_exactly_what_a_run_calls(tmp_path):
    """compile_kernels (rule mpm_kernels) leaves a run nothing to compile: a run adds no signature of its own."""
    from rgns.engines.mpm import kernels
    from rgns.engines.mpm.frame_kernels import compile_kernels

    compile_kernels()
    compiled = (set(kernels.advance_frame.signatures), set(kernels.frame_summary.signatures))
    case = polygon_case(tmp_path / "slope", [[0, 0], [8, 0], [4, 3], [0, 3]], 16.0, 4.0, cell_size_m=1.0)
    run_batch([case], EngineSettings(), duration_s=0.1)
    assert (set(kernels.advance_frame.signatures), set(kernels.frame_summary.signatures)) == compiled
