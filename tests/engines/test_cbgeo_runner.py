"""Running CB-Geo: failures name the realization, finished realizations are kept.

These use tests/fake_mpm.py, a stand-in with CB-Geo's command line and output layout, so they
run everywhere; tests/engines/test_cbgeo_real.py runs the real binary when it is installed.
"""

from __future__ import annotations

import copy
import shutil

import h5py
import numpy as np
import pytest
from conftest import TINY_CONFIG
from workflow_helpers import fake_mpm_binary, snakemake, write_config

from rgns.config import load_yaml
from rgns.engines.cbgeo.runner import MPMDiverged, MPMRunError, run_cbgeo, trajectory_from_cbgeo
from rgns.engines.cbgeo.writer import write_case
from rgns.engines.chunk import simulate_chunk
from rgns.scene.fields import FieldGrid, friction_field
from rgns.scene.geometry import build_scene
from rgns.trajectories import read_packed, read_trajectory

LABEL = "train realization 0001"


@pytest.fixture()
def case_dir(tmp_path, default_config):
    config = copy.deepcopy(default_config)
    config["mpm"]["duration_s"] = 0.25
    scene = build_scene(
        "train",
        1,
        "slope",
        config["geometry"]["families"]["slope"],
        config["domain"],
        config["mesh"],
        config["geometry"],
        config["seed"],
    )
    grid = FieldGrid.covering(config["domain"]["length_m"], config["domain"]["height_m"], 1.0)
    field = friction_field(
        config["seed"], "train", 1, config["sets"]["train"][0], grid, "kronecker", (5.0, 60.0), scene.positions
    )
    return write_case(tmp_path / "case", scene, field.friction_deg, config["mpm"]), config


def _options(binary, **overrides):
    return {"binary": str(binary), "threads": 1, "keep_raw": False, "timeout_s": 60, **overrides}


def test_a_missing_binary_is_reported_naming_the_realization(case_dir, tmp_path):
    case, _ = case_dir
    with pytest.raises(MPMRunError, match=r"train realization 0001: CB-Geo binary 'no-such-mpm' not found on PATH"):
        run_cbgeo(case, tmp_path / "scratch", tmp_path / "log", _options("no-such-mpm"), LABEL)
    with pytest.raises(MPMRunError, match=r"train realization 0001: .*/nowhere/mpm.*does not exist"):
        run_cbgeo(case, tmp_path / "scratch", tmp_path / "log", _options(tmp_path / "nowhere" / "mpm"), LABEL)


def test_an_aborted_run_is_reported_with_the_reason_and_its_log(case_dir, tmp_path, monkeypatch):
    case, _ = case_dir
    monkeypatch.setenv("FAKE_MPM_ABORT", "1")
    with pytest.raises(
        MPMDiverged, match=r"train realization 0001: CB-Geo mpm exited with status 134: a particle left the mesh"
    ):
        run_cbgeo(case, tmp_path / "scratch", tmp_path / "run.log", _options(fake_mpm_binary(tmp_path)), LABEL)
    assert "Particle outside the mesh" in (tmp_path / "run.log").read_text()


def test_a_finished_run_converts_sorting_particles_by_id(case_dir, tmp_path):
    case, config = case_dir
    loaded, raw, _ = run_cbgeo(case, tmp_path / "scratch", tmp_path / "log", _options(fake_mpm_binary(tmp_path)), LABEL)
    trajectory = trajectory_from_cbgeo(loaded, raw, LABEL, {})
    frames = round(config["mpm"]["duration_s"] / config["mpm"]["frame_interval_s"])
    assert trajectory.positions.shape == (frames, len(loaded.positions), 2)
    np.testing.assert_allclose(trajectory.positions[0], loaded.positions, atol=1e-5)  # the fake writes ids reversed
    np.testing.assert_allclose(
        trajectory.positions[-1, :, 0] - trajectory.positions[0, :, 0], 0.01 * (frames - 1), rtol=1e-4
    )
    np.testing.assert_allclose(np.diff(trajectory.time_s), config["mpm"]["frame_interval_s"])


def test_a_truncated_output_file_is_reported_naming_the_realization_and_file(case_dir, tmp_path):
    case, _ = case_dir
    loaded, raw, _ = run_cbgeo(case, tmp_path / "scratch", tmp_path / "log", _options(fake_mpm_binary(tmp_path)), LABEL)
    victim = sorted(raw.glob("particles*.h5"))[3]
    victim.write_bytes(victim.read_bytes()[:500])
    with pytest.raises(MPMRunError, match=rf"train realization 0001: {victim}: not a readable CB-Geo particle table"):
        trajectory_from_cbgeo(loaded, raw, LABEL, {})


def test_non_finite_output_is_reported_as_divergence(case_dir, tmp_path):
    case, _ = case_dir
    loaded, raw, _ = run_cbgeo(case, tmp_path / "scratch", tmp_path / "log", _options(fake_mpm_binary(tmp_path)), LABEL)
    victim = sorted(raw.glob("particles*.h5"))[-1]
    with h5py.File(victim, "r+") as handle:
        table = handle["table"][()]
        table["coord_y"][7] = np.nan
        handle["table"][...] = table
    with pytest.raises(MPMDiverged, match=r"train realization 0001: .*non-finite particle coordinates.*diverged"):
        trajectory_from_cbgeo(loaded, raw, LABEL, {})


@pytest.mark.parametrize("threads, policy", [(1, ""), (2, "passive")])
def test_threads_are_passed_and_omp_waits_passively_with_more_than_one(
    case_dir, tmp_path, threads, policy, monkeypatch
):
    case, _ = case_dir
    monkeypatch.delenv("OMP_WAIT_POLICY", raising=False)
    run_cbgeo(case, tmp_path / "scratch", tmp_path / "log", _options(fake_mpm_binary(tmp_path), threads=threads), LABEL)
    log = (tmp_path / "log").read_text()
    assert f"-p {threads}" in log and f"{threads} thread(s), OMP_WAIT_POLICY={policy}\n" in log


def test_a_chunk_writes_trajectories_and_removes_raw_output_unless_kept(case_dir, tmp_path):
    case, config = case_dir
    settings = copy.deepcopy(config["mpm"])
    settings.update(engine="cbgeo", cbgeo=_options(fake_mpm_binary(tmp_path)))
    simulate_chunk([case], tmp_path / "chunk", tmp_path / "scratch", tmp_path / "logs", settings, "gzip")
    assert read_trajectory(tmp_path / "chunk" / "0001.h5").engine == "cbgeo"
    assert not list((tmp_path / "scratch").rglob("particles*.h5"))
    settings["cbgeo"]["keep_raw"] = True
    simulate_chunk([case], tmp_path / "chunk", tmp_path / "scratch", tmp_path / "logs", settings, "gzip")
    assert list((tmp_path / "scratch").rglob("particles*.h5"))


@pytest.mark.workflow
def test_a_diverging_realization_is_flagged_and_left_out_while_the_others_finish(tmp_path, monkeypatch):
    config = load_yaml(TINY_CONFIG)
    config["mpm"] = {"engine": "cbgeo", "duration_s": 0.25, "cbgeo": {"binary": str(fake_mpm_binary(tmp_path))}}
    path = write_config(tmp_path / "config.yaml", config)
    monkeypatch.setenv("FAKE_MPM_ABORT", "1")
    result = snakemake(tmp_path, "--cores", "2", "dataset", config=path)
    assert result.returncode == 0, result.stderr
    chunk = tmp_path / "results/mpm/train/chunk_000"
    assert read_trajectory(chunk / "0000.h5").status == "ok"
    assert read_trajectory(chunk / "0001.h5").status.startswith("diverged: CB-Geo mpm exited with status 134")
    run_log = (tmp_path / "logs/mpm_run/train/chunk_000.log").read_text()
    assert "train realization 0001: CB-Geo mpm exited with status 134: a particle left the mesh" in run_log
    assert (tmp_path / "results/mpm/train/scratch_000/0001/mpm.json").exists()  # kept for inspection
    assert [t.index for t in read_packed(tmp_path / "results/dataset/train.h5")] == [0]
    assert "left out: results/mpm/train/chunk_000/0001.h5: diverged" in (tmp_path / "logs/pack/train.log").read_text()


@pytest.mark.workflow
def test_a_missing_binary_stops_the_job_and_keeps_what_was_computed(tmp_path):
    config = load_yaml(TINY_CONFIG)
    config["mpm"] = {"engine": "cbgeo", "duration_s": 0.25, "cbgeo": {"binary": str(tmp_path / "nowhere" / "mpm")}}
    path = write_config(tmp_path / "config.yaml", config)
    result = snakemake(tmp_path, "--cores", "2", "--keep-going", "dataset", config=path)
    assert result.returncode != 0
    run_log = (tmp_path / "logs/mpm_run/train/chunk_000.log").read_text()
    assert "MPMRunError: train realization 0000: CB-Geo binary" in run_log and "does not exist" in run_log
    assert len(list((tmp_path / "results/mpm/train").glob("*/case/mpm.json"))) == 2  # the inputs stay
    assert (tmp_path / "results/fields/train/0001.npz").exists()
    shutil.rmtree(tmp_path / "results")
