"""The same realizations through MPM and a learned simulator, paired: what the validation compares.

The learned simulator's columns are named ``gns_*`` whichever it is (the GNS, or the end-state
surrogate :func:`pair_end_states` pairs).

The GNS takes over, as in the Monte Carlo, after the MPM's first ``rollout.warmup_frames`` frames
(at least ``history + 1``: every GNS rollout starts from simulator frames), with the same
per-particle friction, and runs as many frames as the MPM trajectory holds. Both
sides are measured by the same code (:mod:`rgns.engines.metrics`) from positions alone.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
import pandas as pd

from rgns.engines.metrics import MetricSettings, crest_x, normalized_energies, runout_metrics
from rgns.scene.geometry import Scene
from rgns.surrogates.endstate.model import EndStateModel
from rgns.surrogates.gns.rollout import RolloutSettings, rollout_soil
from rgns.surrogates.gns.simulator import LearnedSimulator
from rgns.trajectories import Trajectory

log = logging.getLogger(__name__)
PAIR_COLUMNS = (
    ["index", "gns_status"]
    + [f"{key}_{side}" for key in ("runout_m", "volume_m2", "influence_m") for side in ("mpm", "gns")]
    + ["final_position_mse_m2"]
)


@dataclass
class PairedCase:
    """Per-realization metrics of both simulators, and their energy histories."""

    pairs: pd.DataFrame
    time_s: np.ndarray  # [T]
    index: np.ndarray  # [B]
    mpm_energies: np.ndarray  # [B, T, 3] potential, kinetic, dissipated / E0
    gns_energies: np.ndarray  # [B, T, 3]

    def energies(self) -> dict[str, np.ndarray]:
        return {"time_s": self.time_s, "index": self.index, "mpm": self.mpm_energies, "gns": self.gns_energies}


def _metric_columns(
    trajectory: Trajectory, positions: np.ndarray, crest: float, settings: MetricSettings, suffix: str
) -> dict[str, float]:
    measured = runout_metrics(positions[0], positions[-1], trajectory.volume_m2, crest, settings)
    return {f"{key}_{suffix}": getattr(measured, key) for key in ("runout_m", "volume_m2", "influence_m")}


def pair_case(
    simulator: LearnedSimulator,
    trajectories: list[Trajectory],
    scenes: dict[int, Scene],
    settings: MetricSettings,
    gravity_m_s2: float,
    batch_size: int = 1,
    device: str = "cpu",
    rollout: RolloutSettings | None = None,
) -> PairedCase:
    """Roll the GNS out on every MPM trajectory of a case and pair the metrics."""
    rows, mpm_energies, gns_energies = [], [], []
    started = time.perf_counter()
    for first in range(0, len(trajectories), batch_size):
        batch = trajectories[first : first + batch_size]
        results = rollout_soil(
            simulator, [t.positions for t in batch], [t.friction_deg for t in batch], batch[0].n_frames, rollout, device
        )
        for trajectory, result in zip(batch, results):
            crest = crest_x(scenes[trajectory.index].vertices)
            truth, predicted = trajectory.positions, result.positions
            final_error = np.sum((predicted[-1] - truth[-1]) ** 2, axis=1).mean()
            row = {"index": trajectory.index, "gns_status": result.status}
            row |= _metric_columns(trajectory, truth, crest, settings, "mpm")
            row |= _metric_columns(trajectory, predicted, crest, settings, "gns")
            row["final_position_mse_m2"] = float(final_error)
            rows.append(row)
            mpm_energies.append(
                normalized_energies(truth, trajectory.mass_kg, trajectory.frame_interval_s, gravity_m_s2)
            )
            gns_energies.append(
                normalized_energies(predicted, trajectory.mass_kg, trajectory.frame_interval_s, gravity_m_s2)
            )
        log.info(
            "%s: %d of %d realizations rolled out (%.0f s)",
            batch[0].set_name,
            len(rows),
            len(trajectories),
            time.perf_counter() - started,
        )
    return PairedCase(
        pd.DataFrame(rows)[PAIR_COLUMNS],
        trajectories[0].time_s,
        np.array([t.index for t in trajectories]),
        np.stack(mpm_energies),
        np.stack(gns_energies),
    )


def pair_end_states(
    model: EndStateModel,
    trajectories: list[Trajectory],
    scenes: dict[int, Scene],
    settings: MetricSettings,
    gravity_m_s2: float,
    device: str = "cpu",
) -> PairedCase:
    """The end-state surrogate on every MPM trajectory of a case (from its first frame), paired. Its
    energies are known at the start and the end only (NaN between: it has no path)."""
    finals = model.predict([t.positions[0] for t in trajectories], [t.friction_deg for t in trajectories], device)
    rows, mpm_energies, surrogate_energies = [], [], []
    for trajectory, final in zip(trajectories, finals):
        crest = crest_x(scenes[trajectory.index].vertices)
        truth = trajectory.positions
        predicted = np.stack([truth[0], final, final])
        row = {"index": trajectory.index, "gns_status": "ok"}
        row |= _metric_columns(trajectory, truth, crest, settings, "mpm")
        row |= _metric_columns(trajectory, predicted, crest, settings, "gns")
        row["final_position_mse_m2"] = float(np.sum((final - truth[-1]) ** 2, axis=1).mean())
        rows.append(row)
        mpm_energies.append(normalized_energies(truth, trajectory.mass_kg, trajectory.frame_interval_s, gravity_m_s2))
        ends = normalized_energies(predicted, trajectory.mass_kg, trajectory.frame_interval_s, gravity_m_s2)
        energies = np.full((trajectory.n_frames, 3), np.nan)
        energies[0], energies[-1] = ends[0], ends[-1]
        surrogate_energies.append(energies)
    return PairedCase(
        pd.DataFrame(rows)[PAIR_COLUMNS],
        trajectories[0].time_s,
        np.array([t.index for t in trajectories]),
        np.stack(mpm_energies),
        np.stack(surrogate_energies),
    )
