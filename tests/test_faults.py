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
from workflow_helpers import scheduled, snakemake, snakemake_command, snakemake_environment, write_config

pytestmark = pytest.mark.workflow


@pytest.fixture
def copied(built, tmp_path):
    """A copy of the finished tiny run (times kept, so Snakemake sees it up to date)."""
    workdir, config = built
    shutil.copytree(workdir, tmp_path / "run", symlinks=True)
    return tmp_path / "run", copy.deepcopy(config)


def fingerprints(root: Path, *patterns: str) -> dict[str, tuple[str, int]]:
    """Checksum and modification time of every file matching the patterns under ``root``."""
    return {
        str(path.relative_to(root)): (hashlib.sha256(path.read_bytes()).hexdigest(), path.stat().st_mtime_ns)
        for pattern in patterns
        for path in sorted(root.glob(pattern))
        if path.is_file()
    }


def start(workdir: Path, *args: str, config: Path, log: Path) -> subprocess.Popen:
    """snakemake in the background, output to ``log``, in its own process group so it can be
    killed with its jobs."""
    with open(log, "w") as out:
        return subprocess.Popen(
            snakemake_command(workdir, *args, config=config),
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
            env=snakemake_environment(),
        )


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
    config["gns"] |= {"steps": 400, "checkpoint_every": 100}
    path = write_config(workdir / "longer.yaml", config)
    before = fingerprints(workdir, *UPSTREAM)
    latest = workdir / "results" / "model" / "checkpoints" / "latest.pt"
    shutil.rmtree(workdir / "results" / "model")

    def checkpointed() -> bool:
        try:
            return torch.load(latest, weights_only=False)["step"] >= 100
        except (OSError, EOFError, RuntimeError, KeyError):
            return False

    run = start(workdir, "results/model/gns.pt", "--cores", "2", config=path, log=workdir / "killed.log")
    kill_when(run, checkpointed, workdir, path)
    saved = torch.load(latest, weights_only=False)["step"]
    assert not (workdir / "results" / "model" / "gns.pt").exists()
    assert scheduled(snakemake(workdir, "-n", "--rerun-incomplete", "results/model/gns.pt", config=path)) == {
        "train": 1
    }
    result = snakemake(workdir, "--cores", "2", "--rerun-incomplete", "results/model/gns.pt", config=path)
    assert result.returncode == 0, result.stderr
    log = (workdir / "logs" / "train" / "train.log").read_text()
    assert f"resumed from step {saved} of 400" in log, log
    assert torch.load(latest, weights_only=False)["step"] == 400
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
    finished = fingerprints(workdir, "results/mc/case1/realizations/chunk_*.csv")
    assert 1 <= len(finished) < 3 and not (mc / "realizations.csv").exists()
    jobs = scheduled(snakemake(workdir, "-n", "--rerun-incomplete", target, config=workdir / "config.yaml"))
    assert jobs == {"mc_chunk": 3 - len(finished), "mc_collect": 1}
    result = snakemake(workdir, "--cores", "2", "--rerun-incomplete", target, config=workdir / "config.yaml")
    assert result.returncode == 0, result.stderr
    after = fingerprints(workdir, "results/mc/case1/realizations/chunk_*.csv")
    assert {name: after[name] for name in finished} == finished  # same bytes, never rewritten
    assert (mc / "realizations.csv").read_bytes() == (built[0] / target).read_bytes()  # same table as the first run


def truncate(path: Path) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def garble(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[len(data) // 3 : len(data) // 3 + 64] = b"\x00garbled by a bad copy\x00".ljust(64, b"#")
    path.write_bytes(bytes(data))


def cut_a_row(path: Path) -> None:
    text = path.read_text()
    path.write_text(text[: text.rindex("\n", 0, len(text) - 1) + 1])


FINAL_TABLES = (
    "results/mc/case1/realizations.csv",
    "results/mc/case1/paired.csv",
    "results/validation/case1/pairs.csv",
    "results/report/validation/table.csv",
    "results/report/validation/gate.json",
    "results/report/case1/exceedance.json",
    "results/report/case1/zoning.json",
)

# (file, fault, what the console names): each found before the run, removed, made again (one of each
# reader: the other tables, fields and scenes go through the same sweep, tests/test_integrity.py)
FAULTS = [
    ("results/mc/case1/realizations.csv", truncate, "results/mc/case1/realizations.csv is damaged (TableError"),
    ("results/mc/case1/realizations.csv", Path.unlink, None),
    (
        "results/mc/case1/realizations/chunk_001.csv",
        cut_a_row,
        "results/mc/case1/realizations/chunk_001.csv is damaged (TableError: holds realizations [2], not [2, 3] (cut short",
    ),
    ("results/mpm/case1/chunk_000/0001.h5", truncate, "results/mpm/case1/chunk_000 (its member 0001.h5) is damaged"),
    ("results/mpm/case1/chunk_000/0001.h5", Path.unlink, "results/mpm/case1/chunk_000 lacks 0001.h5: removed"),
    ("results/dataset/train.h5", garble, "results/dataset/train.h5 is damaged"),
    ("results/model/gns.pt", garble, "results/model/gns.pt is damaged"),
]


@pytest.mark.parametrize(
    "name, fault, announced", FAULTS, ids=[f"{Path(name).name}-{fault.__name__}" for name, fault, _ in FAULTS]
)
def test_a_damaged_or_missing_intermediate_is_rebuilt_by_the_next_hazard_map(copied, built, name, fault, announced):
    """Truncated, garbled or deleted (a member of a folder output too): the next hazard_map names it on
    the console, makes it again and everything made from it; the final tables are byte-identical to the
    clean run's and the report is newer than every one of them (nothing stale)."""
    workdir, _ = copied
    fault(workdir / name)
    result = snakemake(workdir, "--cores", "2", "hazard_map", config=workdir / "config.yaml")
    assert result.returncode == 0, result.stderr[-3000:]
    if announced:
        assert f"rgns: {announced}" in result.stderr, result.stderr[-3000:]
    for table in FINAL_TABLES:
        assert (workdir / table).read_bytes() == (built[0] / table).read_bytes(), table
    report = (workdir / "results" / "report" / "report.html").stat().st_mtime_ns
    assert all((workdir / table).stat().st_mtime_ns <= report for table in FINAL_TABLES)
    assert scheduled(snakemake(workdir, "-n", "hazard_map", config=workdir / "config.yaml")) == {}
