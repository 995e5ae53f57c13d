"""The real Snakemake workflow on the tiny config: DAG, bad-config stop, targeted reruns."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from rgns.config import load_config, load_yaml
from rgns.fields import read_field
from rgns.geometry import read_scene
from rgns.trajectories import read_packed, read_trajectory
from conftest import REPO, TINY_CONFIG
from workflow_helpers import scheduled, snakemake, write_config

pytestmark = pytest.mark.workflow


def test_dry_run_of_the_default_config_prints_the_dag(tmp_path):
    jobs = scheduled(snakemake(tmp_path, "-n", "hazard_map"))
    config = load_config(REPO / "config" / "config.yaml")
    sizes = [sum(group["count"] for group in groups) for groups in config["sets"].values()]
    chunks = sum(-(-size // config["mpm"]["chunk_size"]) for size in sizes)
    assert jobs == {"geometry": sum(sizes), "random_field": sum(sizes), "mpm_input": sum(sizes), "mpm_run": chunks,
                    "pack": len(sizes), "gns_export": 1, "scene_preview": len(sizes), "train": 1, "hazard_map": 1}


def test_a_bad_config_stops_before_any_job_runs_naming_key_and_value(tmp_path):
    config = load_yaml(TINY_CONFIG)
    config["sets"]["train"][0]["correlation_length_x_m"] = -8.0
    result = snakemake(tmp_path, "--cores", "1", "hazard_map", config=write_config(tmp_path / "bad.yaml", config))
    assert result.returncode != 0
    assert "'sets.train[0].correlation_length_x_m' = -8.0" in result.stderr + result.stdout
    assert not (tmp_path / "results").exists()


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The tiny workflow run to completion once, for the tests that change its config."""
    workdir = tmp_path_factory.mktemp("tiny")
    config = load_yaml(TINY_CONFIG)
    path = write_config(workdir / "config.yaml", config)
    result = snakemake(workdir, "--cores", "2", "hazard_map", config=path)
    assert result.returncode == 0, result.stderr
    return workdir, config


def test_the_tiny_workflow_writes_scenes_fields_previews_and_the_mpm_dataset(built):
    workdir, config = built
    scene = read_scene(workdir / "results" / "geometry" / "case1" / "0000.json")
    field = read_field(str(workdir / "results" / "fields" / "case1" / "0000.npz"))
    assert scene.family == "column" and len(scene.positions) == len(field.friction_deg) == 6 * 5 * 4
    assert field.grid.shape == (40, 10)
    assert (workdir / "results" / "plots" / "train" / "scenes.png").stat().st_size > 10_000
    trajectory = read_trajectory(workdir / "results" / "mpm" / "case1" / "chunk_000" / "0000.h5")
    frames = round(config["mpm"]["duration_s"] / 0.025) + 1
    assert trajectory.engine == "embedded" and trajectory.status == "ok"
    assert trajectory.positions.shape == (frames, len(scene.positions), 2)
    assert np.linalg.norm(trajectory.positions[-1] - trajectory.positions[0], axis=1).max() > 1.0  # the column fell
    assert [t.index for t in read_packed(workdir / "results" / "dataset" / "train.h5")] == [0, 1]
    assert (workdir / "results" / "dataset" / "gns" / "metadata.json").exists()
    assert scheduled(snakemake(workdir, "-n", "hazard_map", config=workdir / "config.yaml")) == {}


def test_changing_a_random_field_key_reruns_fields_but_not_geometry(built, tmp_path):
    workdir, config = built
    changed = copy.deepcopy(config)
    changed["sets"]["train"][0]["correlation_length_y_m"] = 2.0
    jobs = scheduled(snakemake(workdir, "-n", "hazard_map", config=write_config(tmp_path / "c.yaml", changed)))
    assert "geometry" not in jobs
    assert jobs["random_field"] == 2  # the two train realizations, nothing else
    assert jobs["scene_preview"] == 1


def test_realizations_run_in_chunks(tmp_path):
    config = load_yaml(TINY_CONFIG)
    config["mpm"]["chunk_size"] = 1
    jobs = scheduled(snakemake(tmp_path, "-n", "dataset", config=write_config(tmp_path / "c.yaml", config)))
    assert jobs["mpm_run"] == jobs["mpm_input"] == 4
    config["mpm"]["chunk_size"] = 8
    jobs = scheduled(snakemake(tmp_path, "-n", "dataset", config=write_config(tmp_path / "c.yaml", config)))
    assert jobs["mpm_run"] == 3 and jobs["mpm_input"] == 4  # one chunk per set
    assert jobs["pack"] == 3 and jobs["gns_export"] == 1


def test_changing_the_field_method_reruns_every_field_but_no_geometry(built, tmp_path):
    workdir, config = built
    changed = copy.deepcopy(config)
    changed["random_field"] = {"method": "cholesky"}
    jobs = scheduled(snakemake(workdir, "-n", "hazard_map", config=write_config(tmp_path / "c.yaml", changed)))
    assert "geometry" not in jobs and jobs["random_field"] == 4


def test_changing_a_geometry_key_reruns_geometry_and_its_fields(built, tmp_path):
    workdir, config = built
    changed = copy.deepcopy(config)
    changed["geometry"]["families"]["column"]["vertices"][1]["x_m"] = 7.0
    changed["geometry"]["families"]["column"]["vertices"][2]["x_m"] = 7.0
    jobs = scheduled(snakemake(workdir, "-n", "hazard_map", config=write_config(tmp_path / "c.yaml", changed)))
    assert jobs["geometry"] == 1 and jobs["random_field"] == 1  # case1's one column
