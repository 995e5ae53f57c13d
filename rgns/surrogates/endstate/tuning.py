"""Tuning the end-state surrogate to the accurate MPM: the control variate of the multi-fidelity
correction.

The shipped surrogate learned the MPM at the default 1 m cells and correlates with the 0.5 m MPM no
better than that MPM does (runout 0.974), which caps the correction's speed-up on exceedance
probabilities below 5× (docs/fidelity.md, "Multi-fidelity correction"). Trained further on realizations run
by the accurate MPM, it correlates 0.991 (``benchmarks/hifi_surrogate.py``).

The accurate runs are made at the finer mesh; each end state is coarse-grained back onto the
surrogate's lattice (a coarse point moves by the mean displacement of the fine points in its lattice
pixel), so the model keeps its lattice and its inputs. The friction field lives on the default run's
grid, so the fine points of a pixel share its friction angle.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
import torch

from rgns.engines.batch import simulate_mpm
from rgns.engines.metrics import MetricSettings, crest_x, runout_metrics
from rgns.engines.settings import MpmSettings
from rgns.scene.realizations import CaseInputs, draw_realization
from rgns.surrogates.endstate.data import EndState
from rgns.surrogates.endstate.model import EndStateModel
from rgns.surrogates.endstate.train import Examples, held_out_loss, training_step
from rgns.surrogates.validation import agreement

log = logging.getLogger(__name__)
METRICS = ("runout_m", "volume_m2", "influence_m")


@dataclass(frozen=True)
class TuneSettings:
    """Config section ``endstate.tuned`` (what the fine-tune needs of it) and the training's fixed choices."""

    steps: int = 1000
    learning_rate: float = 3e-4
    batch_size: int = 16
    weight_decay: float = 1e-4
    gradient_clip: float = 1.0
    report_every: int = 100


def coarse_grained(
    coarse_initial: np.ndarray, fine_initial: np.ndarray, fine_final: np.ndarray, coarse_spacing_m: float
) -> np.ndarray:
    """Final positions of the coarse points: each moved by the mean displacement of the fine points
    in its lattice pixel (a coarse point with none stays where it is)."""

    def pixel(p: np.ndarray) -> np.ndarray:
        cells = np.floor(p / coarse_spacing_m).astype(np.int64)
        return cells[:, 0] * 100_000 + cells[:, 1]

    coarse, fine = pixel(coarse_initial), pixel(fine_initial)
    order = np.argsort(coarse)
    slot = order[np.clip(np.searchsorted(coarse[order], fine), 0, len(coarse) - 1)]
    inside = coarse[slot] == fine
    total, count = np.zeros_like(coarse_initial), np.zeros(len(coarse_initial))
    np.add.at(total, slot[inside], (fine_final - fine_initial)[inside])
    np.add.at(count, slot[inside], 1.0)
    return coarse_initial + total / np.maximum(count, 1.0)[:, None]


def simulate_tuning_states(
    coarse: CaseInputs, fine: CaseInputs, indices: list[int], mpm: dict[str, Any], frames: int
) -> tuple[list[EndState], list[str]]:
    """Realizations ``indices`` run by the MPM at ``fine``'s mesh in one batch (config section ``mpm``, as
    the rule passes it), their end states coarse-grained onto ``coarse``'s points; the finished ones, and
    every run's status."""
    fine_batch = [draw_realization(fine, i) for i in indices]
    coarse_batch = [draw_realization(coarse, i) for i in indices]
    runs = simulate_mpm(fine_batch, MpmSettings.from_config(mpm), frames, keep="ends")
    spacing = coarse.mesh["cell_size_m"] / coarse.mesh["particles_per_cell"]
    states = [
        EndState(
            coarse.case,
            c.index,
            c.scene.positions,
            coarse_grained(c.scene.positions, f.scene.positions, run.positions[-1], spacing),
            c.friction_deg,
            c.scene.volumes,
        )
        for f, c, run in zip(fine_batch, coarse_batch, runs)
        if run.status == "ok"
    ]
    return states, [run.status for run in runs]


def fine_tune(model: EndStateModel, train: Examples, held: Examples, settings: TuneSettings) -> list[dict[str, float]]:
    """Continue training ``model`` on ``train`` (AdamW, cosine learning rate, the gradient norm
    clipped); every ``report_every`` steps a history row with the held-out and mean-predictor losses."""
    torch.manual_seed(0)
    optimizer = torch.optim.AdamW(model.parameters(), settings.learning_rate, weight_decay=settings.weight_decay)
    schedule = torch.optim.lr_scheduler.CosineAnnealingLR(optimizer, settings.steps)
    batches = torch.Generator().manual_seed(1)
    history, running, began = [], [], time.perf_counter()
    model.train()
    for step in range(1, settings.steps + 1):
        running.append(
            training_step(model, optimizer, schedule, train, settings.batch_size, batches, settings.gradient_clip)
        )
        if step % settings.report_every == 0 or step == settings.steps:
            model.eval()
            valid, mean = held_out_loss(model, held)
            model.train()
            history.append(
                {
                    "step": step,
                    "train_loss": float(np.mean(running)),
                    "valid_loss": valid,
                    "valid_mean_predictor_loss": mean,
                    "lr": schedule.get_last_lr()[0],
                    "elapsed_s": time.perf_counter() - began,
                }
            )
            running = []
            log.info("step %d/%d  loss %.4g  held-out %.4g", step, settings.steps, history[-1]["train_loss"], valid)
    return history


def held_out_agreement(
    models: dict[str, EndStateModel], states: list[EndState], inputs: CaseInputs, metrics: MetricSettings
) -> pd.DataFrame:
    """R², NRMSE and bias of R, V and I of each model against the coarse-grained accurate runs ``states``."""
    crest = {s.index: crest_x(draw_realization(inputs, s.index).scene.vertices) for s in states}

    def measured(finals: list[np.ndarray]) -> dict[str, np.ndarray]:
        rows = [
            runout_metrics(s.initial, final, s.volume_m2, crest[s.index], metrics).as_row()
            for s, final in zip(states, finals)
        ]
        return {key: np.array([row[key] for row in rows]) for key in METRICS}

    accurate = measured([s.final for s in states])
    rows = []
    for name, model in models.items():
        predicted = measured(model.predict([s.initial for s in states], [s.friction_deg for s in states]))
        for key in METRICS:
            rows.append({"model": name, **vars(agreement(accurate[key], predicted[key], key.rsplit("_", 1)[0]))})
    return pd.DataFrame(rows).rename(columns={"mpm_mean": "accurate_mean", "gns_mean": "model_mean"})


def tuning_agreement(
    base: EndStateModel, tuned: EndStateModel, held_out: list[EndState], config: dict[str, Any], cases: list[str]
) -> pd.DataFrame:
    """:func:`held_out_agreement` of the model before and after tuning, per case (drawn from
    endstate.tuned.data_seed, as the tuning runs were)."""
    seeded = config | {"seed": config["endstate"]["tuned"]["data_seed"]}
    metrics = MetricSettings(**config["metrics"])
    tables = [
        held_out_agreement(
            {"before": base, "after": tuned},
            [s for s in held_out if s.case == case],
            CaseInputs.from_config(seeded, case),
            metrics,
        ).assign(case=case)
        for case in cases
    ]
    table = pd.concat(tables, ignore_index=True)
    return table[["case"] + [column for column in table if column != "case"]]
