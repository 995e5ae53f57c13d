"""Run the real workflow with snakemake in a scratch directory and read what it scheduled."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from collections import Counter
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parent.parent
# The SLURM executor plugin (installed with the test extra) runs `scontrol show config` when snakemake starts. With
# SLURM's client installed and no controller up (CI, and here outside tests/test_slurm.py) that call waits ~9 s for
# the controller on every start, dry runs included. Runs that use no cluster find an scontrol that says at once that
# there is none; the SLURM test runs with the real one.
NO_CLUSTER = REPO / "tests" / "no_cluster"


def snakemake_environment(cluster: bool = False) -> dict[str, str]:
    """The environment of a snakemake run: this one, with :data:`NO_CLUSTER` first on the PATH unless ``cluster``."""
    environment = dict(os.environ)
    if not cluster:
        environment["PATH"] = f"{NO_CLUSTER}{os.pathsep}{environment.get('PATH', '')}"
    return environment


def snakemake_command(workdir: Path, *args: str, config: Path | None = None) -> list[str]:
    """The ``snakemake`` command line on the repository's Snakefile in ``workdir``."""
    command = [
        sys.executable,
        "-m",
        "snakemake",
        "--snakefile",
        str(REPO / "Snakefile"),
        "--directory",
        str(workdir),
        *args,
    ]
    return command + ["--configfile", str(config)] if config is not None else command


def snakemake(
    workdir: Path, *args: str, config: Path | None = None, timeout: int = 900, cluster: bool = False
) -> subprocess.CompletedProcess:
    """``snakemake`` on the repository's Snakefile in ``workdir`` (targets go in ``args``); ``cluster``: with the
    machine's own SLURM client (:func:`snakemake_environment`)."""
    command = snakemake_command(workdir, *args, config=config)
    # its own process group, so a timeout kills the jobs it started too, not only snakemake
    process = subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        env=snakemake_environment(cluster),
    )
    try:
        stdout, stderr = process.communicate(timeout=timeout)
    except subprocess.TimeoutExpired as error:
        os.killpg(process.pid, signal.SIGKILL)
        stdout, stderr = process.communicate()
        raise AssertionError(
            f"snakemake {' '.join(args)} timed out after {timeout} s:\n{stdout[-3000:]}\n{stderr[-3000:]}"
        ) from error
    return subprocess.CompletedProcess(command, process.returncode, stdout, stderr)


def scheduled(result: subprocess.CompletedProcess) -> dict[str, int]:
    """Rule -> job count from a dry run's 'Job stats' table (empty when nothing is to be done)."""
    output = result.stdout + result.stderr
    assert result.returncode == 0, output
    table = output.split("Job stats:", 1)
    if len(table) == 1:
        assert "Nothing to be done" in output, output
        return {}
    counts = {}
    for line in table[1].splitlines()[3:]:
        match = re.match(r"^(\w+)\s+(\d+)$", line.strip())
        if not match:
            break
        counts[match.group(1)] = int(match.group(2))
    counts.pop("total", None)
    return counts


def scheduled_routes(result: subprocess.CompletedProcess) -> dict[str, int]:
    """Route -> mc_chunk job count from a dry run (rgns/montecarlo/routes.py: which model runs which
    realizations), read off the jobs' outputs results/mc/<case>/<route>/chunk_<k>.csv."""
    output = result.stdout + result.stderr
    assert result.returncode == 0, output
    return dict(Counter(re.findall(r"output: results/mc/[^/\s]+/(\w+)/chunk_\d+\.csv", output)))


def write_config(path: Path, config: dict) -> Path:
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    return path


def fake_mpm_binary(directory: Path) -> Path:
    """An executable ``mpm`` that runs tests/fake_mpm.py with this interpreter."""
    binary = directory / "mpm"
    binary.write_text(f'#!/bin/sh\nexec {sys.executable} {REPO / "tests" / "fake_mpm.py"} "$@"\n')
    binary.chmod(0o755)
    return binary
