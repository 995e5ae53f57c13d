"""Against the real CB-Geo ``mpm`` (skipped when absent): our case runs, our reader reads it.

Point ``RGNS_MPM_BINARY`` at the executable, or put ``mpm`` on PATH.
"""

from __future__ import annotations

import copy
import os
import shutil

import numpy as np
import pytest

from rgns.engines.cbgeo.output import read_frames
from rgns.engines.cbgeo.runner import run_cbgeo, trajectory_from_cbgeo
from rgns.engines.cbgeo.writer import write_case
from rgns.scene.fields import FieldGrid, friction_field
from rgns.scene.geometry import build_scene

BINARY = os.environ.get("RGNS_MPM_BINARY") or shutil.which("mpm")
pytestmark = pytest.mark.skipif(BINARY is None, reason="CB-Geo mpm not installed (set RGNS_MPM_BINARY)")


def test_a_failing_slope_runs_in_cbgeo_and_the_reader_recovers_materials_and_friction(tmp_path, default_config):
    config = copy.deepcopy(default_config)
    config["mpm"]["duration_s"] = 2.0
    group = dict(config["sets"]["train"][0], friction_mean_deg=20.0)  # weak: the slope fails
    scene = build_scene(
        "train",
        0,
        "slope",
        config["geometry"]["families"]["slope"],
        config["domain"],
        config["mesh"],
        config["geometry"],
        config["seed"],
    )
    grid = FieldGrid.covering(config["domain"]["length_m"], config["domain"]["height_m"], config["mesh"]["cell_size_m"])
    field = friction_field(config["seed"], "train", 0, group, grid, "kronecker", (5.0, 60.0), scene.positions)
    case_dir = write_case(tmp_path / "case", scene, field.friction_deg, config["mpm"])
    options = {"binary": BINARY, "threads": 1, "keep_raw": True, "timeout_s": 600}
    case, raw, seconds = run_cbgeo(case_dir, tmp_path / "scratch", tmp_path / "mpm.log", options, "train 0000")
    print(f"CB-Geo: {len(case.positions)} particles, {case.meta['nsteps']} steps in {seconds:.1f} s")

    frames = read_frames(raw, len(case.positions))
    np.testing.assert_array_equal(frames.material_id, case.material_id)
    width = case.meta["friction_bin_width_deg"]
    error = np.abs(np.degrees(frames.friction_rad) - field.friction_deg)
    print(f"friction recovered within {error.max():.3f} deg (bin width {width:.3f} deg)")
    assert error.max() <= 0.5 * width + 1e-4

    trajectory = trajectory_from_cbgeo(case, raw, "train 0000", {})
    assert trajectory.n_frames == round(2.0 / config["mpm"]["frame_interval_s"])
    displacement = np.linalg.norm(trajectory.positions[-1] - trajectory.positions[0], axis=1)
    print(f"max displacement {displacement.max():.2f} m; {np.mean(displacement >= 1.0):.1%} of particles moved >= 1 m")
    assert displacement.max() > 1.0  # the slope failed
    np.testing.assert_allclose(frames.mass_kg.sum(), config["mpm"]["density_kg_m3"] * scene.volumes.sum(), rtol=1e-9)
    assert (trajectory.positions[..., 1] > -0.5).all()  # nothing fell through the floor
