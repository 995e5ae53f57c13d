"""From a case's Monte Carlo table to the files of its hazard report: exceedance, convergence,
zoning (CSV for the curves, JSON for the numbers a reader quotes, PNG for the figures).

Realizations the screen found stable (status "screened") count as no failure; those whose status
is neither (a diverged rollout) are left out and counted.
"""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rgns.hazard.plots import plot_convergence, plot_exceedance, plot_zoning
from rgns.hazard.statistics import (
    ZONE_LEVELS,
    affected_probability,
    convergence,
    exceedance_curve,
    exceedance_distances,
    zone_levels,
    zone_range_labels,
    zones,
)
from rgns.scene.realizations import FINISHED
from rgns.tables import write_csv

# report label -> column of the Monte Carlo table (the paper reports I, then R)
HAZARD_METRICS = {"influence distance I": "influence_m", "runout distance R": "runout_m"}


def finished(table: pd.DataFrame) -> pd.DataFrame:
    """The realizations whose simulation finished or that the screen found stable, in index order."""
    return table[table["status"].isin(FINISHED)].sort_values("index")


def _json(path: str | Path, record: dict[str, Any]) -> None:
    Path(path).write_text(json.dumps(record, indent=2, default=float) + "\n")


def write_exceedance(
    table: pd.DataFrame, mean_field: pd.DataFrame, settings: dict[str, Any], outputs: dict[str, str]
) -> dict[str, Any]:
    """Exceedance curves and distances, convergence traces: CSV, JSON and PNG of each."""
    ok = finished(table)
    confidence = settings["confidence"]
    deterministic_row = mean_field.iloc[0]
    curves, distances, traces, deterministic = {}, {}, {}, {}
    for label, column in HAZARD_METRICS.items():
        values = ok[column].to_numpy()
        curves[label] = exceedance_curve(values, confidence)
        distances[label] = exceedance_distances(values, settings["exceedance_probabilities"], confidence)
        traces[label] = convergence(
            values, settings["convergence_tolerance"], settings["convergence_window"], confidence
        )
        deterministic[label] = float(deterministic_row[column]) if deterministic_row["status"] in FINISHED else None
    write_csv(pd.concat([c.to_frame().assign(metric=label) for label, c in curves.items()]), outputs["curve_csv"])
    write_csv(pd.concat([t.to_frame().assign(metric=label) for label, t in traces.items()]), outputs["convergence_csv"])
    exceedance = {
        "n": len(ok),
        "not_ok": len(table) - len(ok),
        "screened": int((table["status"] == "screened").sum()),
        "confidence": confidence,
        "metrics": {
            label: {
                "deterministic_m": deterministic[label],
                "mean_m": float(ok[column].mean()),
                "std_m": float(ok[column].std()),
                "distances": [asdict(d) for d in distances[label]],
            }
            for label, column in HAZARD_METRICS.items()
        },
    }
    _json(outputs["curve_json"], exceedance)
    any_trace = next(iter(traces.values()))
    _json(
        outputs["convergence_json"],
        {
            "criterion": any_trace.criterion,
            "metrics": {
                label: {
                    "n": int(t.n[-1]),
                    "converged_at": t.converged_at,
                    "final_mean_m": float(t.mean[-1]),
                    "final_std_m": float(t.std[-1]),
                }
                for label, t in traces.items()
            },
        },
    )
    plot_exceedance(curves, distances, deterministic, outputs["curve"])
    plot_convergence(traces, outputs["convergence"])
    return exceedance


def write_zoning(table: pd.DataFrame, settings: dict[str, Any], outputs: dict[str, str]) -> dict[str, Any]:
    """The probability that each point along x is affected, its five-level zoning: CSV, JSON, PNG."""
    ok = finished(table)
    domain = settings["domain"]
    x_m = np.arange(0.0, domain["length_m"] + 1e-9, settings["resolution_m"])
    affected = affected_probability(x_m, ok["rear_x_m"].to_numpy(), ok["front_x_m"].to_numpy(), settings["confidence"])
    thresholds = settings["thresholds"]
    levels = zone_levels(affected.probability, thresholds)
    write_csv(affected.to_frame(levels), outputs["csv"])
    record = {
        "n": len(ok),
        "not_ok": len(table) - len(ok),
        "thresholds": thresholds,
        "levels": dict(zip(ZONE_LEVELS, zone_range_labels(thresholds))),
        "zones": [asdict(zone) for zone in zones(x_m, levels)],
    }
    _json(outputs["json"], record)
    plot_zoning(
        np.asarray(settings["vertices"]),
        affected,
        levels,
        thresholds,
        domain["length_m"],
        domain["height_m"],
        outputs["map"],
    )
    return record
