"""Config section ``mpm`` typed, as the in-memory MPM runs read it (:mod:`rgns.engines.batch` and its callers).

Rules pass the section as plain data (Snakemake params: a change reruns the job); the rule script or
package function that receives it builds :class:`MpmSettings` once, and passes that down. The
case-directory route (rules ``mpm_input`` and ``mpm_run``) keeps the section itself: a trajectory
records it whole as its provenance, with the engine choice and CB-Geo's options, which no in-memory
run reads.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

from rgns.engines.mpm.solver import EngineSettings


@dataclass(frozen=True)
class MpmSettings:
    """The soil, boundaries and time stepping of every case, and the embedded engine's numerical settings."""

    density_kg_m3: float
    youngs_modulus_pa: float
    poisson_ratio: float
    dilation_deg: float
    cohesion_pa: float
    tension_cutoff_pa: float
    floor_friction: float
    friction_bins: int
    geostatic_stress: bool
    k0: float | None
    gravity_m_s2: float
    dt_s: float
    duration_s: float
    frame_interval_s: float
    damping_factor: float
    scheme: str
    embedded: EngineSettings

    @classmethod
    def from_config(cls, section: dict[str, Any]) -> MpmSettings:
        """The settings of config section ``mpm`` (as validated: every key present)."""
        case = {f.name: section[f.name] for f in fields(cls) if f.name != "embedded"}
        return cls(**case, embedded=EngineSettings.from_config(section["embedded"]))

    @property
    def case(self) -> dict[str, Any]:
        """What :func:`rgns.scene.build.case_from_scene` builds a case from (the scene stage imports no engine)."""
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name != "embedded"}
