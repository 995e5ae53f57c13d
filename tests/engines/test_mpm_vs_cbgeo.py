"""The embedded engine and the real CB-Geo ``mpm`` on one case directory (skipped without mpm)."""

from __future__ import annotations

import os
import shutil
from dataclasses import replace

import pytest
import torch
from reference_cases import failing_slope

from rgns.config import load_config
from rgns.engines.cbgeo.runner import run_cbgeo, trajectory_from_cbgeo
from rgns.engines.metrics import runout_distance, sliding_volume
from rgns.engines.mpm.solver import EngineSettings, run_batch

BINARY = os.environ.get("RGNS_MPM_BINARY") or shutil.which("mpm")
pytestmark = pytest.mark.skipif(BINARY is None, reason="CB-Geo mpm not installed (set RGNS_MPM_BINARY)")


def test_embedded_and_cbgeo_agree_on_runout_and_sliding_volume_of_a_failing_slope(tmp_path):
    torch.set_num_threads(1)
    case = failing_slope(tmp_path / "case")
    options = {"binary": BINARY, "threads": 1, "keep_raw": False, "timeout_s": 3600}
    case, raw, cbgeo_seconds = run_cbgeo(
        case.directory, tmp_path / "scratch", tmp_path / "mpm.log", options, "failing slope"
    )
    reference = trajectory_from_cbgeo(case, raw, "failing slope", {})
    # CB-Geo's own element: the default B-spline is locking-free and slides more than ED2Q4 does
    settings = replace(EngineSettings.from_config(load_config()["mpm"]["embedded"]), shape_function="linear")
    ours = run_batch([case], settings)[0]
    initial = case.positions
    runout = runout_distance(initial, reference.positions[-1]), runout_distance(initial, ours.positions[-1])
    volume = (
        sliding_volume(initial, reference.positions[-1], case.volumes),
        sliding_volume(initial, ours.positions[-1], case.volumes),
    )
    print(
        f"CB-Geo {cbgeo_seconds:.1f} s, embedded {ours.wall_s:.1f} s; runout {runout[0]:.2f} vs {runout[1]:.2f} m; "
        f"sliding volume {volume[0]:.1f} vs {volume[1]:.1f} m2"
    )
    assert runout[0] > 1.0 and volume[0] > 10.0  # the slope did fail
    assert runout[1] == pytest.approx(runout[0], rel=0.10)
    assert volume[1] == pytest.approx(volume[0], rel=0.10)
