"""A batch of in-memory realizations run by the embedded MPM: what the Monte Carlo, the surrogates'
training data and their validation all run, so it sits with the engines, not with any one of them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rgns.engines.mpm.solver import RunResult, run_batch
from rgns.engines.settings import MpmSettings
from rgns.scene.build import case_from_scene
from rgns.scene.realizations import Realization


@dataclass
class Simulated:
    """A simulator's answer for one realization."""

    positions: np.ndarray  # [T, N, 2]
    status: str


def run_mpm(batch: list[Realization], mpm: MpmSettings, frames: int, keep: str = "all") -> list[RunResult]:
    """``frames`` frames of the embedded MPM engine, on the realizations' cases built in memory."""
    settings = mpm.case  # built once for the batch
    cases = [case_from_scene(r.scene, r.friction_deg, settings) for r in batch]
    duration_s = (frames - 1) * mpm.frame_interval_s
    return run_batch(cases, mpm.embedded, duration_s, mpm.frame_interval_s, keep=keep)


def simulate_mpm(batch: list[Realization], mpm: MpmSettings, frames: int, keep: str = "all") -> list[Simulated]:
    """Run a batch through the embedded MPM engine, keeping ``keep`` frames ("all" or "ends")."""
    return [Simulated(result.positions, result.status) for result in run_mpm(batch, mpm, frames, keep)]
