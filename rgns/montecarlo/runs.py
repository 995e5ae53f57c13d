"""Monte Carlo realizations of a test case: simulate (GNS, end-state surrogate or embedded MPM) and measure the
realizations :mod:`rgns.scene.realizations` draws. Realizations are simulated in
batches of ``batch_size`` (:func:`batches_of`): a learned simulator's aligned on the index (batch k holds
k·B … k·B + B − 1), so a table does not depend on how the realizations are split into chunks (chunk sizes
are multiples of B); the MPM's in the order listed, since each realization keeps its own time step.

A GNS rollout starts, as in training and validation, from ``history + 1`` frames of MPM: the
embedded engine runs the first 0.125 s (6 frames of 0.025 s, about 1.5 % of a 10 s run), the GNS
the rest. Started from exact rest (a history of identical positions), the default model moved
no particle of the case-1 realizations, failing ones included: zero velocities are a fixed point
it learned from the soil at rest.

What a scene does not need is skipped, each switchable (config ``montecarlo``): a realization
whose limit-equilibrium factor of safety is clearly above 1 (:mod:`rgns.montecarlo.screening`) is not
simulated and enters the table as a no-failure run with status "screened"; GNS rollouts skip
particles at rest and stop once a realization has come to rest (``montecarlo.rollout``); and
only the frames a measurement reads are kept (``keep_frames: ends``).

The end-state surrogate (:mod:`rgns.surrogates.endstate`) needs no MPM at all: one network evaluation maps a
realization at rest to its material points at rest after the run (frames: start, end, end).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from rgns.engines.batch import Simulated, run_mpm, simulate_mpm
from rgns.engines.metrics import MetricSettings, crest_x, normalized_energies, runout_metrics
from rgns.engines.settings import MpmSettings
from rgns.montecarlo.screening import ScreenSettings, minimum_factor_of_safety
from rgns.montecarlo.tables import COLUMNS
from rgns.scene.realizations import (
    FINISHED,
    MEAN_FIELD,
    CaseInputs,
    Realization,
    draw_realization,
    mean_field_realization,
)
from rgns.surrogates.endstate.model import EndStateModel
from rgns.surrogates.gns.rollout import RolloutSettings, rollout_soil, warmup_frame_count
from rgns.surrogates.gns.simulator import LearnedSimulator
from rgns.trajectories import frame_count

SIMULATORS = ("gns", "endstate", "mpm")
SURROGATES = ("gns", "endstate")  # the learned simulators, validated against MPM before use
log = logging.getLogger(__name__)


class MonteCarloError(ValueError):
    """A Monte Carlo case cannot be set up; the message names the config key."""


def simulate_gns(
    simulator: LearnedSimulator,
    batch: list[Realization],
    mpm: MpmSettings,
    frames: int,
    device: str = "cpu",
    rollout: RolloutSettings | None = None,
) -> list[Simulated]:
    """MPM for the warm-up (``rollout.warmup_frames``, at least ``history + 1``), then the GNS to ``frames``."""
    warmup = run_mpm(batch, mpm, (rollout or RolloutSettings()).handover(simulator.settings.history))
    results = rollout_soil(
        simulator, [w.positions for w in warmup], [r.friction_deg for r in batch], frames, rollout, device
    )
    return [
        Simulated(result.positions, w.status if w.status != "ok" else result.status)
        for w, result in zip(warmup, results)
    ]


def simulate_endstate(model: EndStateModel, batch: list[Realization], device: str = "cpu") -> list[Simulated]:
    """The end-state surrogate's final positions of a batch (frames: start, end, end: at rest)."""
    finals = model.predict([r.scene.positions for r in batch], [r.friction_deg for r in batch], device)
    return [
        Simulated(np.stack([r.scene.positions.astype(np.float32), final, final]), "ok")
        for r, final in zip(batch, finals)
    ]


def screened(realization: Realization) -> Simulated:
    """A realization the screen counts as no failure: it stays where it is."""
    positions = realization.scene.positions.astype(np.float32)
    return Simulated(np.stack([positions] * 3), "screened")


def factor_of_safety(realization: Realization, mpm: MpmSettings, settings: ScreenSettings) -> float:
    """Minimum Bishop factor of safety of a realization with the MPM's soil."""
    scene = realization.scene
    return minimum_factor_of_safety(
        scene.vertices,
        scene.positions,
        realization.friction_deg,
        scene.cell_size_m,
        mpm.density_kg_m3 * mpm.gravity_m_s2,
        mpm.cohesion_pa,
        settings,
        domain_length_m=scene.domain_length_m,
    ).factor_of_safety


def measure(
    realization: Realization,
    simulated: Simulated,
    metrics: MetricSettings,
    density_kg_m3: float,
    frame_interval_s: float,
    gravity_m_s2: float,
) -> dict[str, Any]:
    """One table row: R, V, I, the final normalised energies and the status of a realization.

    ``simulated.positions`` may hold every frame or only the first and the last two."""
    scene = realization.scene
    row: dict[str, Any] = {
        "index": realization.index,
        "status": simulated.status,
        "n_particles": len(scene.positions),
        "friction_mean_deg": float(np.mean(realization.friction_deg)),
    }
    if simulated.status not in FINISHED:
        return row
    positions = simulated.positions
    measured = runout_metrics(positions[0], positions[-1], scene.volumes, crest_x(scene.vertices), metrics)
    energies = normalized_energies(positions, density_kg_m3 * scene.volumes, frame_interval_s, gravity_m_s2)
    row |= measured.as_row()
    row |= dict(zip(("potential_final", "kinetic_final", "dissipated_final"), energies[-1].tolist()))
    return row


@dataclass
class RunSettings:
    """Config section ``montecarlo`` plus what the simulators need from elsewhere."""

    simulator: str
    batch_size: int
    frames: int
    frame_interval_s: float
    metrics: MetricSettings
    mpm: MpmSettings
    device: str = "cpu"
    keep_frames: str = "ends"
    rollout: RolloutSettings | None = None
    screen: ScreenSettings | None = None

    @classmethod
    def from_params(cls, params: dict[str, Any]) -> RunSettings:
        """The settings of a rule's params: the plain sections ``montecarlo``, ``mpm`` and ``metrics``."""
        section, mpm = params["montecarlo"], MpmSettings.from_config(params["mpm"])
        duration_s = section["duration_s"] or mpm.duration_s
        return cls(
            simulator=section["simulator"],
            batch_size=section["batch_size"],
            frames=frame_count(duration_s, mpm.frame_interval_s),
            frame_interval_s=mpm.frame_interval_s,
            metrics=MetricSettings(**params["metrics"]),
            mpm=mpm,
            device=section["device"],
            keep_frames=section["keep_frames"],
            rollout=rollout_settings(section["rollout"], mpm.frame_interval_s, section["keep_frames"]),
            screen=ScreenSettings(**section["screen"]),
        )


def rollout_settings(section: dict[str, Any], frame_interval_s: float, keep: str = "all") -> RolloutSettings:
    """The GNS rollout options of config section ``montecarlo.rollout`` (its MPM warm-up in frames)."""
    return RolloutSettings(
        warmup_frames=warmup_frame_count(section["warmup_s"], frame_interval_s),
        skip_rest=section["skip_rest"],
        rest_velocity=section["rest_velocity_m_per_frame"],
        rest_displacement=section["rest_displacement_m"],
        context_hops=section["context_hops"],
        early_stop=section["early_stop"],
        early_stop_fraction=section["early_stop_fraction"],
        early_stop_frames=section["early_stop_frames"],
        keep=keep,
    )


def run_realizations(
    inputs: CaseInputs,
    indices: list[int],
    settings: RunSettings,
    simulator: LearnedSimulator | EndStateModel | None = None,
) -> pd.DataFrame:
    """Draw, simulate and measure realizations ``indices`` (MEAN_FIELD for the mean-field one)."""
    if settings.simulator not in SIMULATORS:
        raise MonteCarloError(f"montecarlo.simulator = {settings.simulator!r}: expected one of {SIMULATORS}")
    if settings.simulator in SURROGATES and simulator is None:
        raise MonteCarloError(f"montecarlo.simulator = {settings.simulator!r} needs a trained model")
    rows = []
    started = time.perf_counter()
    batches = batches_of(indices, settings.batch_size, aligned=settings.simulator in SURROGATES)
    screen = settings.screen or ScreenSettings()
    for number, batch_indices in enumerate(batches, start=1):
        batch = [
            mean_field_realization(inputs) if i == MEAN_FIELD else draw_realization(inputs, i) for i in batch_indices
        ]
        safety = {r.index: factor_of_safety(r, settings.mpm, screen) if screen.enabled else float("nan") for r in batch}
        skipped = {r.index for r in batch if screen.skips(safety[r.index])}
        to_run = [r for r in batch if r.index not in skipped]
        simulated = {r.index: screened(r) for r in batch if r.index in skipped}
        simulated |= dict(zip([r.index for r in to_run], _simulate(to_run, settings, simulator)))
        for realization in batch:
            result = simulated[realization.index]
            rows.append(
                measure(
                    realization,
                    result,
                    settings.metrics,
                    settings.mpm.density_kg_m3,
                    settings.frame_interval_s,
                    settings.mpm.gravity_m_s2,
                )
                | {"factor_of_safety": safety[realization.index], "simulator": settings.simulator}
            )
            if result.status not in FINISHED:
                log.error("%s realization %d: %s", inputs.case, realization.index, result.status)
        elapsed = time.perf_counter() - started
        log.info(
            "%s: batch %d of %d done (%d realizations, %.1f s, about %.0f s left)",
            inputs.case,
            number,
            len(batches),
            len(rows),
            elapsed,
            elapsed / number * (len(batches) - number),
        )
    return pd.DataFrame(rows, columns=COLUMNS)


def _simulate(
    batch: list[Realization], settings: RunSettings, simulator: LearnedSimulator | EndStateModel | None
) -> list[Simulated]:
    if not batch:
        return []
    if settings.simulator == "endstate":
        return simulate_endstate(simulator, batch, settings.device)
    if settings.simulator == "gns":
        return simulate_gns(simulator, batch, settings.mpm, settings.frames, settings.device, settings.rollout)
    return simulate_mpm(batch, settings.mpm, settings.frames, settings.keep_frames)


def batches_of(indices: list[int], batch_size: int, aligned: bool) -> list[list[int]]:
    """The realizations run together, in order, the mean-field one alone. A learned simulator's answer may
    differ in its last bits with its batchmates, so its batches are ``aligned``: grouped by
    ``index // batch_size``, the same whatever the chunks. The MPM's realizations do not touch each other
    (each its own nodes and time step), so it takes them ``batch_size`` at a time: scattered indices (the
    pairs) run together too."""
    if aligned:
        groups: dict[int, list[int]] = {}
        for i in indices:
            groups.setdefault(i // batch_size if i != MEAN_FIELD else MEAN_FIELD, []).append(i)
        return list(groups.values())
    batches: list[list[int]] = []
    for i in indices:
        if i == MEAN_FIELD or not batches or len(batches[-1]) == batch_size or batches[-1] == [MEAN_FIELD]:
            batches.append([i])
        else:
            batches[-1].append(i)
    return batches
