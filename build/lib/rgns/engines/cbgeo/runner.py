"""Run the CB-Geo ``mpm`` binary on a case directory and turn its output into a trajectory.

The case is copied into a scratch directory so the input stays untouched; the raw per-step files
(each ≥ 4 MB) are converted right after the run and deleted unless asked to keep them.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import time
from pathlib import Path
from typing import Any

from rgns.engines.cbgeo.case import INPUT_JSON, read_case, to_trajectory
from rgns.engines.cbgeo.output import OutputError, read_frames
from rgns.scene.build import RESULTS_PATH, UUID
from rgns.scene.case import Case
from rgns.trajectories import Trajectory


class MPMRunError(RuntimeError):
    """An MPM run could not start, failed, or produced unusable output; names the realization."""


class MPMDiverged(MPMRunError):
    """The run blew up numerically (a particle left the mesh, non-finite state): a result, not a fault."""


def find_binary(name_or_path: str, label: str) -> str:
    """The path of the CB-Geo executable, or an error saying where it was looked for."""
    if os.sep in name_or_path:
        if os.access(name_or_path, os.X_OK) and Path(name_or_path).is_file():
            return name_or_path
        raise MPMRunError(
            f"{label}: CB-Geo binary {name_or_path!r} (mpm.cbgeo.binary) does not exist or is not executable"
        )
    found = shutil.which(name_or_path)
    if found is None:
        raise MPMRunError(
            f"{label}: CB-Geo binary {name_or_path!r} not found on PATH; install CB-Geo MPM "
            "(https://www.cb-geo.com/mpm) and put `mpm` on PATH or set mpm.cbgeo.binary, or use mpm.engine: embedded"
        )
    return found


def _failure_reason(log_path: Path) -> str:
    text = log_path.read_text(errors="replace") if log_path.exists() else ""
    if "Particle outside the mesh" in text:
        return "a particle left the mesh (CB-Geo's sign of a numerical blow-up or a too-small domain)"
    tail = [line for line in text.splitlines() if line.strip()][-3:]
    return "last output: " + " | ".join(tail) if tail else "no output"


def run_cbgeo(
    case_dir: str | Path, scratch_dir: str | Path, log_path: str | Path, options: dict[str, Any], label: str
) -> tuple[Case, Path, float]:
    """Run ``mpm`` on a copy of ``case_dir``; returns the case, the raw results dir and wall time."""
    binary = find_binary(options["binary"], label)
    case = read_case(case_dir)
    scratch_dir, log_path = Path(scratch_dir), Path(log_path)
    if scratch_dir.exists():
        shutil.rmtree(scratch_dir)
    shutil.copytree(case_dir, scratch_dir)
    env = dict(os.environ)
    if options["threads"] > 1:
        env["OMP_WAIT_POLICY"] = "passive"
    command = [binary, "-f", f"{scratch_dir.resolve()}/", "-i", INPUT_JSON, "-p", str(options["threads"])]
    log_path.parent.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    with open(log_path, "w") as log:
        log.write("$ " + " ".join(command) + "\n")
        log.flush()
        try:
            status = subprocess.run(
                command, stdout=log, stderr=subprocess.STDOUT, env=env, timeout=options["timeout_s"]
            ).returncode
        except subprocess.TimeoutExpired as error:
            raise MPMRunError(
                f"{label}: CB-Geo ran past mpm.cbgeo.timeout_s = {options['timeout_s']} s; log: {log_path}"
            ) from error
    elapsed = time.perf_counter() - start
    if status != 0:
        reason = _failure_reason(log_path)
        error = MPMDiverged if reason.startswith("a particle left the mesh") else MPMRunError
        raise error(f"{label}: CB-Geo mpm exited with status {status}: {reason}; log: {log_path}")
    return case, scratch_dir / RESULTS_PATH / UUID, elapsed


def trajectory_from_cbgeo(case: Case, results_dir: Path, label: str, provenance: dict[str, Any]) -> Trajectory:
    """Convert a finished run's step files into a trajectory (exact φ from the case)."""
    try:
        frames = read_frames(results_dir, len(case.positions))
    except OutputError as error:
        kind = MPMDiverged if "non-finite" in str(error) else MPMRunError
        raise kind(f"{label}: {error}") from error
    return to_trajectory(case, frames.positions, (frames.steps + 1) * case.dt_s, "cbgeo", provenance)
