"""Run a chunk of case directories through the configured MPM engine into trajectory files.

``mpm.engine: embedded`` advances the whole chunk as one batch; ``cbgeo`` runs the binary on each
case in turn. A realization that diverges (a particle off the grid, a non-finite state, energy
growth; for CB-Geo an abort with "Particle outside the mesh domain") is written with status
"diverged: <reason>", named in the log, and the rest of the chunk goes on; packing leaves it out.
Faults that are not results (a missing binary, an unreadable file) stop the job.
"""

from __future__ import annotations

import logging
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import torch

from rgns.engines.cbgeo.case import read_case, to_trajectory
from rgns.engines.cbgeo.runner import MPMDiverged, MPMRunError, run_cbgeo, trajectory_from_cbgeo
from rgns.engines.mpm.solver import EngineSettings, run_batch
from rgns.scene.case import Case
from rgns.trajectories import write_trajectory

ENGINES = ("embedded", "cbgeo")
log = logging.getLogger(__name__)


def trajectory_name(index: int) -> str:
    """File name of realization ``index``'s trajectory inside its chunk directory."""
    return f"{index:04d}.h5"


def _label(case: Case) -> str:
    return f"{case.set_name} realization {case.index:04d}"


def _diverged(case: Case, reason: str, provenance: dict[str, Any]):
    """A flagged trajectory for a run that gave no usable frames: the initial state, repeated."""
    frames = int(round(case.duration_s / case.frame_interval_s))
    positions = np.repeat(case.positions[None].astype(np.float32), frames, axis=0)
    return to_trajectory(
        case, positions, np.arange(frames) * case.frame_interval_s, "cbgeo", provenance, status=f"diverged: {reason}"
    )


def _run_embedded(cases: list[Case], out_dir: Path, settings: dict[str, Any], compression: str) -> list[str]:
    engine = EngineSettings.from_config(settings["embedded"])
    torch.set_num_threads(settings["embedded"]["threads"])
    provenance = {"engine": "embedded", "mpm": settings}
    statuses = []
    for case, result in zip(cases, run_batch(cases, engine)):
        trajectory = to_trajectory(
            case,
            result.positions,
            result.time_s,
            "embedded",
            provenance,
            status=result.status,
            energies=result.energies,
        )
        write_trajectory(out_dir / trajectory_name(case.index), trajectory, compression)
        stop = f", stopped at t = {result.stopped_at_s:.2f} s" if result.stopped_at_s is not None else ""
        (log.error if result.status != "ok" else log.info)("%s: %s%s", _label(case), result.status, stop)
        statuses.append(result.status)
    log.info("chunk of %d: %d steps in %.1f s", len(cases), result.steps, result.wall_s)
    return statuses


def _run_cbgeo(
    cases: list[Case], out_dir: Path, scratch_root: Path, log_dir: Path, settings: dict[str, Any], compression: str
) -> list[str]:
    provenance = {"engine": "cbgeo", "mpm": settings}
    statuses = []
    for case in cases:
        label, index = _label(case), case.index
        scratch = scratch_root / f"{index:04d}"
        try:
            case, raw_dir, elapsed = run_cbgeo(
                case.directory, scratch, log_dir / f"{index:04d}.log", settings["cbgeo"], label
            )
            trajectory = trajectory_from_cbgeo(case, raw_dir, label, provenance)
            log.info("%s: CB-Geo finished in %.1f s", label, elapsed)
        except MPMDiverged as error:
            log.error("%s (scratch kept in %s)", error, scratch)
            trajectory = _diverged(case, str(error).split(": ", 1)[1], provenance)
        write_trajectory(out_dir / trajectory_name(index), trajectory, compression)
        if trajectory.status == "ok" and not settings["cbgeo"]["keep_raw"]:
            shutil.rmtree(scratch)
        statuses.append(trajectory.status)
    return statuses


def simulate_chunk(
    case_dirs: list[str | Path],
    out_dir: str | Path,
    scratch_root: str | Path,
    log_dir: str | Path,
    settings: dict[str, Any],
    compression: str,
) -> list[str]:
    """Simulate every case of a chunk; writes ``<index>.h5`` into ``out_dir``; returns the statuses."""
    engine = settings["engine"]
    if engine not in ENGINES:
        raise MPMRunError(f"mpm.engine = {engine!r}: expected one of {ENGINES}")
    cases = [read_case(directory) for directory in case_dirs]
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if engine == "embedded":
        return _run_embedded(cases, out_dir, settings, compression)
    return _run_cbgeo(cases, out_dir, Path(scratch_root), Path(log_dir), settings, compression)
