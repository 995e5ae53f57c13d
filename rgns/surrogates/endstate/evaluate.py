"""The end-state surrogate against MPM end states it never saw: R, V and I of each realization by
both, and per set and metric R², NRMSE and bias with bootstrap intervals over realizations.

The end states are chunk files of rule ``endstate_data`` (any config's sets, e.g. the slope
families and field models of config/ood_validation.yaml); each realization's polygon, which the
influence distance needs (its crest), is drawn again from the same seed and checked to seed the
very points the file holds.
"""

from __future__ import annotations

import math
from functools import partial
from typing import Any

import numpy as np
import pandas as pd

from rgns.engines.metrics import MetricSettings, crest_x, runout_metrics
from rgns.scene.realizations import CaseInputs, draw_scene
from rgns.surrogates.endstate.data import EndState
from rgns.surrogates.endstate.model import EndStateModel
from rgns.surrogates.validation import METRICS, bootstrap_mean_interval, nrmse, paired_interval, r_squared


class EvaluationError(ValueError):
    """End states that do not match the config they are said to come from."""


def _relative(value: float, mean: float) -> float:
    """``value`` as a fraction of ``mean`` (NaN where the mean is 0)."""
    return value / mean if mean else math.nan


def paired_metrics(
    model: EndStateModel, states: list[EndState], inputs: CaseInputs, metrics: MetricSettings, batch_size: int = 16
) -> pd.DataFrame:
    """One row per realization: R, V, I by MPM (``*_mpm``) and by the model (``*_model``)."""
    finals = [
        final
        for first in range(0, len(states), batch_size)
        for final in model.predict(
            [s.initial for s in states[first : first + batch_size]],
            [s.friction_deg for s in states[first : first + batch_size]],
        )
    ]
    return paired_finals(states, finals, inputs, metrics)


def paired_finals(
    states: list[EndState], finals: list[np.ndarray], inputs: CaseInputs, metrics: MetricSettings
) -> pd.DataFrame:
    """One row per realization: R, V, I of the MPM's end state (``*_mpm``) and of another final state of the same
    points (``*_model``: a model's, or another MPM run's)."""
    rows = []
    for state, final in zip(states, finals, strict=True):
        scene = draw_scene(inputs, state.index)
        if scene.positions.shape != state.initial.shape or not np.allclose(scene.positions, state.initial):
            raise EvaluationError(
                f"{inputs.case} realization {state.index}: the end-state file's points are "
                "not the ones this config seeds (another seed or geometry?)"
            )
        crest = crest_x(scene.vertices)
        row: dict[str, Any] = {"set": inputs.case, "index": state.index}
        for source, end in (("mpm", state.final), ("model", final)):
            measured = runout_metrics(state.initial, end, state.volume_m2, crest, metrics).as_row()
            row |= {f"{stem}_{source}": measured[stem] for stem, _ in METRICS.values()}
        rows.append(row)
    return pd.DataFrame(rows)


def agreement_rows(
    pairs: pd.DataFrame, bootstrap: int = 2000, confidence: float = 0.95, seed: int = 0
) -> list[dict[str, Any]]:
    """Per metric of one set: n, R², NRMSE, bias and relative bias, each with its bootstrap interval."""
    rows = []
    for metric, (stem, _) in METRICS.items():
        truth, model = pairs[f"{stem}_mpm"].to_numpy(float), pairs[f"{stem}_model"].to_numpy(float)
        errors = model - truth
        mean = float(truth.mean())
        bias_low, bias_high = bootstrap_mean_interval(errors, bootstrap, confidence, seed)
        r2 = r_squared(truth, model)
        r2_low, r2_high = (
            paired_interval("r2", truth, model, bootstrap, confidence, seed)
            if math.isfinite(r2)
            else (math.nan, math.nan)
        )
        nrmse_low, nrmse_high = paired_interval("nrmse", truth, model, bootstrap, confidence, seed)
        relative = partial(_relative, mean=mean)
        rows.append(
            {
                "set": pairs["set"].iloc[0],
                "metric": metric,
                "n": len(pairs),
                "mpm_mean": mean,
                "model_mean": float(model.mean()),
                "r2": r2,
                "r2_low": r2_low,
                "r2_high": r2_high,
                "nrmse": nrmse(truth, model),
                "nrmse_low": nrmse_low,
                "nrmse_high": nrmse_high,
                "bias": float(errors.mean()),
                "bias_low": bias_low,
                "bias_high": bias_high,
                "relative_bias": relative(float(errors.mean())),
                "relative_bias_low": relative(bias_low),
                "relative_bias_high": relative(bias_high),
                "failed_both": int(((truth > 0) & (model > 0)).sum()),
                "stood_both": int(((truth == 0) & (model == 0)).sum()),
                "failed_mpm_only": int(((truth > 0) & (model == 0)).sum()),
                "failed_model_only": int(((truth == 0) & (model > 0)).sum()),
            }
        )
    return rows


def agreement_of(paired: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """The agreement rows of every set, from its per-realization pairs (:func:`paired_metrics`, :func:`paired_finals`)."""
    return pd.DataFrame([row for table in paired.values() for row in agreement_rows(table)])


def agreement_table(
    model: EndStateModel, sets: dict[str, tuple[list[EndState], CaseInputs]], metrics: MetricSettings
) -> pd.DataFrame:
    """The agreement rows of every set: its end states and the inputs they were drawn from."""
    return agreement_of(
        {name: paired_metrics(model, states, inputs, metrics) for name, (states, inputs) in sets.items()}
    )


def _interval(value: float, low: float, high: float, digits: int = 3, percent: bool = False) -> str:
    if not math.isfinite(value):
        return "–"
    scale, unit = (100.0, " %") if percent else (1.0, "")
    return f"{value * scale:.{digits}f} [{low * scale:.{digits}f}, {high * scale:.{digits}f}]{unit}"


def markdown_table(table: pd.DataFrame) -> str:
    """The agreement table as Markdown, intervals in brackets; failed/stood counts per metric."""
    lines = [
        "| set | metric | n | MPM mean | model mean | R² | NRMSE | bias | relative bias | "
        "failed both / stood both / MPM only / model only |",
        "| --- | --- | ---: | ---: | ---: | --- | --- | --- | --- | --- |",
    ]
    for _, row in table.iterrows():
        lines.append(
            f"| {row['set']} | {row['metric']} | {row['n']} | {row['mpm_mean']:.2f} | {row['model_mean']:.2f} | "
            f"{_interval(row['r2'], row['r2_low'], row['r2_high'])} | "
            f"{_interval(row['nrmse'], row['nrmse_low'], row['nrmse_high'])} | "
            f"{_interval(row['bias'], row['bias_low'], row['bias_high'], 2)} | "
            f"{_interval(row['relative_bias'], row['relative_bias_low'], row['relative_bias_high'], 1, True)} | "
            f"{row['failed_both']} / {row['stood_both']} / {row['failed_mpm_only']} / {row['failed_model_only']} |"
        )
    return "\n".join(lines) + "\n"
