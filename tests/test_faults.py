"""Faults on the real tiny workflow: killed jobs, files broken between runs. Nothing already
computed may be lost, and a rerun redoes only what is missing."""
from __future__ import annotations

import copy
import hashlib
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest
import torch

from workflow_helpers import scheduled, snakemake, snakemake_command, write_config

pytestmark = pytest.mark.workflow


@pytest.fixture
def copied(built, tmp_path):
    """A copy of the finished tiny run (times kept, so Snakemake sees it up to date)."""
    workdir, config = built
    shutil.copytree(workdir, tmp_path / "run", symlinks=True)
    return tmp_path / "run", copy.deepcopy(config)


def fingerprints(root: Path, *patterns: str) -> dict[str, tuple[str, int]]:
    """Checksum and modification time of every file matching the patterns under ``root``."""
    return {str(path.relative_to(root)): (hashlib.sha256(path.read_bytes()).hexdigest(), path.stat().st_mtime_ns)
            for pattern in patterns for path in sorted(root.glob(pattern)) if path.is_file()}


def start(workdir: Path, *args: str, config: Path, log: Path) -> subprocess.Popen:
    """snakemake in the background, output to ``log``, in its own process group so it can be
    killed with its jobs."""
    with open(log, "w") as out:
        return subprocess.Popen(snakemake_command(workdir, *args, config=config), stdout=out, stderr=subprocess.STDOUT,
                                start_new_session=True)


def kill_when(process: subprocess.Popen, ready, workdir: Path, config: Path, timeout_s: float = 300) -> None:
    """SIGKILL the whole run (snakemake and its jobs, as a node failure would) once ``ready()``,
    then lift the lock the killed Snakemake left, as its user must (``snakemake --unlock``)."""
    deadline = time.monotonic() + timeout_s
    while not ready():
        assert process.poll() is None, "the run finished before it could be killed"
        assert time.monotonic() < deadline, "the kill point was never reached"
        time.sleep(0.2)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    assert snakemake(workdir, "--unlock", config=config).returncode == 0


UPSTREAM = ("results/geometry/**/*", "results/fields/**/*", "results/mpm/**/*.h5", "results/dataset/**/*")


def test_a_killed_training_job_resumes_from_its_checkpoint_on_rerun(copied):
    workdir, config = copied
    config["gns"] |= {"steps": 700, "checkpoint_every": 100}
    path = write_config(workdir / "longer.yaml", config)
    before = fingerprints(workdir, *UPSTREAM)
    latest = workdir / "results" / "model" / "checkpoints" / "latest.pt"
    shutil.rmtree(workdir / "results" / "model")

    def checkpointed() -> bool:
        try:
            return torch.load(latest, weights_only=False)["step"] >= 200
        except (OSError, EOFError, RuntimeError, KeyError):
            return False

    run = start(workdir, "results/model/gns.pt", "--cores", "2", config=path, log=workdir / "killed.log")
    kill_when(run, checkpointed, workdir, path)
    saved = torch.load(latest, weights_only=False)["step"]
    assert not (workdir / "results" / "model" / "gns.pt").exists()
    assert scheduled(snakemake(workdir, "-n", "--rerun-incomplete", "results/model/gns.pt", config=path)) == {"train": 1}
    result = snakemake(workdir, "--cores", "2", "--rerun-incomplete", "results/model/gns.pt", config=path)
    assert result.returncode == 0, result.stderr
    log = (workdir / "logs" / "train" / "train.log").read_text()
    assert f"resumed from step {saved} of 700" in log, log
    assert torch.load(latest, weights_only=False)["step"] == 700
    assert fingerprints(workdir, *UPSTREAM) == before


def test_a_killed_monte_carlo_reruns_only_its_missing_chunks_and_leaves_finished_ones_untouched(copied, built):
    workdir, config = copied
    mc = workdir / "results" / "mc" / "case1"
    shutil.rmtree(mc)
    target = "results/mc/case1/realizations.csv"
    log = workdir / "killed.log"
    run = start(workdir, target, "--cores", "1", config=workdir / "config.yaml", log=log)  # one chunk at a time
    # killed once Snakemake has recorded a chunk as finished (a chunk written but not yet recorded
    # counts as incomplete, and --rerun-incomplete redoes it, as it should)
    kill_when(run, lambda: "(Rule: mc_chunk)" in log.read_text(), workdir, workdir / "config.yaml")
    finished = fingerprints(workdir, "results/mc/case1/chunk_*.csv")
    assert 1 <= len(finished) < 3 and not (mc / "realizations.csv").exists()
    jobs = scheduled(snakemake(workdir, "-n", "--rerun-incomplete", target, config=workdir / "config.yaml"))
    assert jobs == {"mc_chunk": 3 - len(finished), "mc_collect": 1}
    result = snakemake(workdir, "--cores", "2", "--rerun-incomplete", target, config=workdir / "config.yaml")
    assert result.returncode == 0, result.stderr
    after = fingerprints(workdir, "results/mc/case1/chunk_*.csv")
    assert {name: after[name] for name in finished} == finished  # same bytes, never rewritten
    assert (mc / "realizations.csv").read_bytes() == (built[0] / target).read_bytes()  # same table as the first run


def test_a_truncated_dataset_stops_training_naming_the_file_and_keeps_the_mpm_results(copied):
    workdir, config = copied
    dataset = workdir / "results" / "dataset" / "train.h5"
    dataset.write_bytes(dataset.read_bytes()[: dataset.stat().st_size // 2])
    before = fingerprints(workdir, "results/geometry/**/*", "results/fields/**/*", "results/mpm/**/*.h5")
    result = snakemake(workdir, "--cores", "2", "results/model/gns.pt", config=workdir / "config.yaml")
    assert result.returncode != 0
    log = (workdir / "logs" / "train" / "train.log").read_text()
    assert f"{Path('results/dataset/train.h5')}: not a readable" in log, log
    assert "Error in rule train" in result.stdout + result.stderr
    assert fingerprints(workdir, "results/geometry/**/*", "results/fields/**/*", "results/mpm/**/*.h5") == before


def test_a_corrupt_model_file_stops_the_monte_carlo_naming_it(copied):
    """A changed model is validated again before the Monte Carlo may use it (the gate): the run
    stops there, naming the file, and no Monte Carlo chunk runs."""
    workdir, config = copied
    (workdir / "results" / "model" / "gns.pt").write_bytes(b"not a model")
    target = "results/mc/case1/realizations.csv"
    table = (workdir / target).read_bytes()
    chunk_logs = {path: path.read_text() for path in (workdir / "logs" / "mc_chunk" / "case1").glob("*.log")}
    result = snakemake(workdir, "--cores", "2", target, config=workdir / "config.yaml")
    assert result.returncode != 0
    log = (workdir / "logs" / "validation_rollout" / "case1.log").read_text()
    assert "gns.pt: not a usable GNS model file" in log, log
    assert "Error in rule validation_rollout" in result.stdout + result.stderr
    assert {path: path.read_text() for path in chunk_logs} == chunk_logs  # no chunk ran on the bad model
    assert (workdir / target).read_bytes() == table  # the last good table stays until a run replaces it
    assert scheduled(snakemake(workdir, "-n", target, config=workdir / "config.yaml")) == {"mc_chunk": 3, "mc_collect": 1}


@pytest.mark.parametrize("damage, message", [
    (lambda text: text[: len(text) - 20], "cut short (no newline after its last row)"),
    (lambda text: text[: text.rindex("\n", 0, len(text) - 1) + 1], "holds realizations [2], not 2..3"),
], ids=["mid-row", "a-whole-row"])
def test_a_truncated_monte_carlo_chunk_is_named_when_collected(copied, damage, message):
    workdir, config = copied
    chunk = workdir / "results" / "mc" / "case1" / "chunk_001.csv"
    chunk.write_text(damage(chunk.read_text()))
    result = snakemake(workdir, "--cores", "1", "results/mc/case1/realizations.csv", config=workdir / "config.yaml")
    assert result.returncode != 0
    log = (workdir / "logs" / "mc_collect" / "case1.log").read_text()
    assert f"chunk_001.csv: {message}" in log, log
    assert (workdir / "results" / "mc" / "case1" / "chunk_000.csv").exists()
