"""The tiny DAG through a real single-node SLURM cluster with profiles/slurm, to completion."""

from __future__ import annotations

import re
import subprocess

import pytest
import yaml
from conftest import REPO, TINY_CONFIG
from slurm_cluster import PARTITION, down, missing, up
from workflow_helpers import snakemake

pytestmark = [pytest.mark.workflow, pytest.mark.slurm]


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    absent = missing()
    if absent:
        pytest.skip(
            f"no single-node SLURM here: missing {', '.join(absent)} "
            "(apt-get install slurmctld slurmd slurm-client munge, as root)"
        )
    base = tmp_path_factory.mktemp("slurm")
    up(base)
    yield base
    down(base)


def site_profile(directory, partition: str) -> dict:
    """profiles/slurm adapted as a site would: its partition, no account (this cluster keeps no
    accounting, so job states come from squeue), memory within this one small node."""
    profile = yaml.safe_load((REPO / "profiles" / "slurm" / "config.yaml").read_text())
    profile["default-resources"]["slurm_partition"] = partition
    del profile["default-resources"]["slurm_account"]
    for resources in profile["set-resources"].values():
        resources["mem_mb"] = min(resources.get("mem_mb", 0), 2000) or 2000
    profile |= {
        "cores": 2,
        "latency-wait": 5,
        "slurm-status-command": "squeue",
        "slurm-init-seconds-before-status-checks": 1,
    }
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "config.yaml").write_text(yaml.safe_dump(profile))
    return profile


def test_the_tiny_workflow_runs_to_the_report_through_slurm_with_the_profile(cluster, tmp_path):
    profile = site_profile(tmp_path / "profile", PARTITION)
    assert profile["executor"] == "slurm" and "prepare=100" in profile["group-components"]
    workdir = tmp_path / "run"
    workdir.mkdir()
    result = snakemake(
        workdir, "hazard_map", "--profile", str(tmp_path / "profile"), config=TINY_CONFIG, timeout=1200, cluster=True
    )
    output = result.stdout + result.stderr
    assert result.returncode == 0, output[-5000:]
    assert (workdir / "results" / "report" / "report.html").exists()
    submitted = {
        int(job): rule
        for job, rule in re.findall(
            r"Job \S+ has been submitted with SLURM jobid (\d+) \(log: \S+/slurm_logs/(\w+?)/", output
        )
    }
    kinds = sorted(set(submitted.values()))
    # every per-realization step of the 5 realizations went in one grouped job; light steps ran locally;
    # the engine's kernels compile in a job of their own, on a compute node (numba's cache is per CPU)
    assert kinds == [
        "group_prepare_geometry_mpm_input_random_field_scene_preview",
        "rule_gns_export",
        "rule_mc_chunk",
        "rule_mpm_kernels",
        "rule_mpm_run",
        "rule_pack",
        "rule_train",
        "rule_validate",
        "rule_validation_rollout",
    ], kinds
    assert list(submitted.values()).count("group_prepare_geometry_mpm_input_random_field_scene_preview") == 1
    for job in submitted:  # finished jobs stay visible for MinJobAge = 600 s
        state = subprocess.run(["scontrol", "show", "job", str(job)], capture_output=True, text=True).stdout
        assert "JobState=COMPLETED" in state, state
    assert "steps (100%) done" in output
    # a chunk made again by a local run (other processes, no cluster) is the same table to the byte
    table = workdir / "results" / "mc" / "case1" / "realizations.csv"
    on_the_cluster = table.read_bytes()
    (workdir / "results" / "mc" / "case1" / "realizations" / "chunk_001.csv").unlink()
    local = snakemake(workdir, "--cores", "2", "hazard_map", config=TINY_CONFIG)
    assert local.returncode == 0, local.stderr[-3000:]
    assert "rule mc_chunk" in local.stdout + local.stderr and table.read_bytes() == on_the_cluster
