"""Run one realization's case directory through the configured MPM engine into a trajectory file."""
from __future__ import annotations

import logging
import shutil
from pathlib import Path
from typing import Any

from rgns.cbgeo.runner import MPMRunError, run_cbgeo, trajectory_from_cbgeo
from rgns.trajectories import write_trajectory

ENGINES = ("embedded", "cbgeo")
log = logging.getLogger(__name__)


def simulate(case_dir: str | Path, trajectory_path: str | Path, scratch_dir: str | Path, log_path: str | Path,
             settings: dict[str, Any], label: str, compression: str) -> None:
    """Run ``settings['engine']`` on a case and write the trajectory; raise MPMRunError naming ``label``.

    A failed run leaves its scratch directory (raw output, copied inputs) for inspection.
    """
    engine = settings["engine"]
    provenance = {"engine": engine, "mpm": settings}
    if engine == "cbgeo":
        case, raw_dir, elapsed = run_cbgeo(case_dir, scratch_dir, log_path, settings["cbgeo"], label)
        log.info("%s: CB-Geo finished in %.1f s, converting %s", label, elapsed, raw_dir)
        write_trajectory(trajectory_path, trajectory_from_cbgeo(case, raw_dir, label, provenance), compression)
        if not settings["cbgeo"]["keep_raw"]:
            shutil.rmtree(scratch_dir)
        return
    if engine == "embedded":
        raise MPMRunError(f"{label}: the embedded MPM engine is not part of this version yet; set mpm.engine: cbgeo")
    raise MPMRunError(f"{label}: mpm.engine = {engine!r}: expected one of {ENGINES}")
