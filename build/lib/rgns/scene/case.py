"""The realization every engine runs: its mesh, material points, stresses, materials and
constraints, in memory (:class:`Case`).

Built from a drawn scene by :func:`rgns.scene.build.case_from_scene`; CB-Geo's case directory is
one serialization of it (:func:`rgns.engines.cbgeo.writer.save_case` writes it, :func:`rgns.engines.cbgeo.case.read_case`
reads it back to the same numbers). Its fields follow CB-Geo's input model (``mpm.json``'s analysis,
materials and constraints), which both engines read; the embedded engine takes it without importing
a file format.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np


class CaseError(ValueError):
    """A case that cannot be run or read (a missing or malformed file, an unsupported setting); the message
    names the file or the realization."""


@dataclass
class Case:
    """Everything an MPM engine needs from one case, in memory or read from a directory."""

    directory: Path | None  # None: built in memory
    meta: dict[str, Any]  # rgns-case.json: set, index, domain, frame interval ({} for a plain CB-Geo case)
    config: dict[str, Any]  # mpm.json
    nodes: np.ndarray  # [Nn, 2]
    cells: np.ndarray  # [Nc, 4]
    positions: np.ndarray  # [N, 2]
    volumes: np.ndarray  # [N]
    stresses: np.ndarray | None  # [N, 6], CB-Geo order, tension positive
    material_id: np.ndarray  # [N] after material_sets
    friction_deg: np.ndarray  # [N] exact (rgns's own file), else the material's
    node_sets: dict[int, np.ndarray]
    particle_sets: dict[int, np.ndarray]

    @property
    def materials(self) -> dict[int, dict[str, Any]]:
        return {int(m["id"]): m for m in self.config["materials"]}

    @property
    def binned_friction_deg(self) -> np.ndarray:
        """Friction angle per particle as CB-Geo sees it (its material's)."""
        return per_particle(self.config, self.material_id, "friction")

    @property
    def density_kg_m3(self) -> np.ndarray:
        return per_particle(self.config, self.material_id, "density")

    @property
    def set_name(self) -> str:
        """rgns's set name, or the directory's name for a plain CB-Geo case."""
        if "set_name" in self.meta:
            return self.meta["set_name"]
        if self.directory is None:
            raise CaseError("a case built in memory has no set name (meta 'set_name')")
        return Path(self.directory).resolve().name

    @property
    def index(self) -> int:
        return int(self.meta.get("index", 0))

    @property
    def source(self) -> str:
        """Where the case comes from, for messages: its directory, or the realization built in memory."""
        if self.directory is not None:
            return str(self.directory)
        return f"{self.set_name} realization {self.index:04d} (in memory)"

    @property
    def dt_s(self) -> float:
        return float(self.config["analysis"]["dt"])

    @property
    def frame_interval_s(self) -> float:
        """``analysis.dt`` × ``post_processing.output_steps`` of ``mpm.json``."""
        return _steps_to_seconds(self.dt_s, self.config["post_processing"]["output_steps"])

    @property
    def duration_s(self) -> float:
        """``analysis.dt`` × ``analysis.nsteps`` of ``mpm.json``."""
        return _steps_to_seconds(self.dt_s, self.config["analysis"]["nsteps"])

    @property
    def bounds(self) -> np.ndarray:
        """[[x0, x1], [y0, y1]]: rgns's domain, or the mesh's extent for a plain CB-Geo case."""
        if "domain_length_m" in self.meta:
            return np.array([[0.0, self.meta["domain_length_m"]], [0.0, self.meta["domain_height_m"]]])
        return np.column_stack([self.nodes.min(axis=0), self.nodes.max(axis=0)])


def per_particle(config: dict[str, Any], material_id: np.ndarray, key: str) -> np.ndarray:
    """A material property per particle."""
    materials = {int(m["id"]): m for m in config["materials"]}
    return np.array([materials[int(k)][key] for k in material_id], dtype=float)


def _steps_to_seconds(dt_s: float, steps: int) -> float:
    """``steps`` × ``dt_s`` to 12 significant digits, so 300 steps of 1e-4 s are 0.03 s, not 0.030000000000000002."""
    return float(f"{dt_s * int(steps):.12g}")
