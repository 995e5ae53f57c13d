"""Write the case of one realization (:class:`rgns.scene.case.Case`, built by
:func:`rgns.scene.build.case_from_scene`) as a CB-Geo case directory.

:func:`save_case` is the case's one serialization, with 17 significant digits so that
:func:`rgns.engines.cbgeo.case.read_case` gives back the same numbers; :func:`write_case` builds a
realization's case and writes it. The directory is the contract between the writer and both engines:
the real ``mpm`` binary and rgns's embedded engine read the same files. Layout (names fixed in the
case's ``mpm.json``, by :mod:`rgns.scene.build`):

* ``mesh.txt``: ED2Q4 grid over the domain plus padding on every side (see :mod:`rgns.scene.build`).
* ``particles.txt``, ``particles-volumes.txt``, ``particles-stresses.txt`` (geostatic, optional).
* ``entity_sets.json``: node sets 0 left wall, 1 right wall, 2 floor; particle sets 1..K, one
  per friction bin (the generator's set is 0, so no id collides).
* ``particles-friction-deg.txt``: the exact friction angle per particle (rgns's own; CB-Geo
  ignores it) so the embedded engine can use exact values instead of the bins.
* ``rgns-case.json``: which realization this is, its polygon, the domain and the frame interval
  (rgns's own).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from rgns.engines.cbgeo.case import FRICTION_FILE, INPUT_JSON, META_FILE
from rgns.scene.build import case_from_scene
from rgns.scene.case import Case
from rgns.scene.geometry import Scene

DIGITS = "%.17g"  # enough for every float64 to read back exactly


def _write_counted(path: Path, header: str, *tables: tuple[np.ndarray, str]) -> None:
    """A header line, then each table's rows, tab-separated."""
    with open(path, "w") as handle:
        handle.write(header + "\n")
        for table, fmt in tables:
            np.savetxt(handle, table, fmt=fmt, delimiter="\t")


def save_case(directory: str | Path, case: Case) -> Path:
    """Write ``case`` as a CB-Geo case directory (file names from its ``mpm.json``); returns the directory."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    mesh = case.config["mesh"]
    n = len(case.positions)
    _write_counted(
        directory / mesh["mesh"], f"{len(case.nodes)}\t{len(case.cells)}", (case.nodes, DIGITS), (case.cells, "%d")
    )
    _write_counted(directory / case.config["particles"][0]["generator"]["location"], f"{n}", (case.positions, DIGITS))
    np.savetxt(
        directory / mesh["particles_volumes"],
        np.column_stack([np.arange(n), case.volumes]),
        fmt=["%d", DIGITS],
        delimiter="\t",
    )
    if case.stresses is not None:
        _write_counted(directory / mesh["particles_stresses"], f"{n}", (case.stresses, DIGITS))
    np.savetxt(directory / FRICTION_FILE, case.friction_deg, fmt=DIGITS)
    entity_sets = {
        "node_sets": [{"id": k, "set": members.tolist()} for k, members in case.node_sets.items()],
        "particle_sets": [{"id": k, "set": members.tolist()} for k, members in case.particle_sets.items()],
    }
    (directory / mesh["entity_sets"]).write_text(json.dumps(entity_sets))
    if case.meta:
        (directory / META_FILE).write_text(json.dumps(case.meta, indent=2))
    (directory / INPUT_JSON).write_text(json.dumps(case.config, indent=2))
    return directory


def write_case(directory: str | Path, scene: Scene, friction_deg: np.ndarray, settings: dict[str, Any]) -> Path:
    """Write the complete case directory of one realization; returns the directory."""
    return save_case(directory, case_from_scene(scene, friction_deg, settings))
