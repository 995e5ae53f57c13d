"""The validation gate: may a Monte Carlo case be drawn from the learned simulator (the GNS or the
end-state surrogate), judged by its agreement with fresh MPM runs of that case (config
``validation.acceptance``)?

Per case and metric: at least ``min_realizations`` finished pairs; the lower end of R²'s bootstrap
interval (``validation.confidence``) at least ``r2_min`` where MPM has variance (R² is undefined
otherwise), so that a point R² on a few pairs does not pass where the same R² on many would; and
the mean signed error within ``relative_bias_max`` of the MPM mean; where the MPM mean is 0 (every
realization stands) the GNS mean must be within one mesh cell (m, or m² for a volume) of it. The
fraction of diverged rollouts must not exceed ``diverged_fraction_max``. The verdict is a report of the
model (``on_failure: report``, the default): the Monte Carlo runs the learned simulator whatever it says,
because the MPM pairs of the multi-fidelity correction make its estimates unbiased for the MPM anyway (a
poor model widens their intervals; rgns.fidelity). With ``stop`` a failed case stops its Monte Carlo with the
failures named.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

STOP = "stop"
SURROGATE_NAMES = {"gns": "GNS", "endstate": "end-state surrogate"}


class GateError(RuntimeError):
    """The GNS failed the gate of a case whose Monte Carlo is set to stop."""


@dataclass
class Verdict:
    """The gate's decision for one case."""

    case: str
    passed: bool
    failures: list[str] = field(default_factory=list)
    simulator: str = "gns"  # what the Monte Carlo of this case runs: the learned simulator judged, gate or not

    surrogate: str = "gns"  # the learned simulator judged: gns, or endstate (the end-state surrogate)
    evidence: list[str] = field(default_factory=list)  # per metric: R² with its interval, on how many pairs

    def sentence(self) -> str:
        name = SURROGATE_NAMES.get(self.surrogate, self.surrogate)
        if self.passed:
            on = f" ({'; '.join(self.evidence)})" if self.evidence else ""
            return f"{self.case}: the {name} passed the validation gate{on}; the Monte Carlo uses it"
        return (
            f"{self.case}: the {name} failed the validation gate ({'; '.join(self.failures)}): the Monte Carlo "
            "stops with validation.acceptance.on_failure stop, and runs it all the same with report"
        )


def _bias_failure(row: pd.Series, limit: float, cell_size_m: float) -> str | None:
    unit_tolerance = cell_size_m**2 if row["metric"] == "volume" else cell_size_m
    if not math.isfinite(row["bias"]):
        return f"{row['metric']} bias not measurable (no rollout finished)"
    if row["mpm_mean"] == 0.0:
        if abs(row["bias"]) > unit_tolerance:
            return f"{row['metric']} GNS mean {row['gns_mean']:.3g} where every MPM realization is 0"
        return None
    if abs(row["relative_bias"]) > limit:
        return f"{row['metric']} |relative bias| {abs(row['relative_bias']):.3f} > {limit:g}"
    return None


def _r2_bound(row: pd.Series) -> float:
    """The lower end of R²'s interval; the point value where too few pairs give no interval (min_realizations < 3)."""
    return row["r2_low"] if math.isfinite(row["r2_low"]) else row["r2"]


def judge(
    table: pd.DataFrame,
    summaries: list[dict[str, Any]],
    acceptance: dict[str, Any],
    cell_size_m: float,
    surrogate: str = "gns",
) -> dict[str, Verdict]:
    """The verdict of every case of a validation table (rows of case × metric) and its summaries, for
    the learned simulator ``surrogate`` (gns or endstate) the table's ``gns`` columns hold."""
    diverged = {item["case"]: item["diverged"] / max(item["realizations"], 1) for item in summaries}
    verdicts = {}
    for case, rows in table.groupby("case", sort=False):
        failures = []
        if diverged.get(case, 0.0) > acceptance["diverged_fraction_max"]:
            failures.append(f"diverged fraction {diverged[case]:.2f} > {acceptance['diverged_fraction_max']:g}")
        evidence = []
        for _, row in rows.iterrows():
            limits = acceptance["metrics"][row["metric"]]
            if math.isfinite(row["r2"]):
                evidence.append(
                    f"{row['metric']} R² {row['r2']:.3f} [{row['r2_low']:.3f}, {row['r2_high']:.3f}] on {row['n']}"
                )
            if row["n"] < acceptance["min_realizations"]:
                failures.append(
                    f"{row['metric']}: {row['n']} finished pairs, fewer than the "
                    f"{acceptance['min_realizations']} the gate needs (validation.acceptance.min_realizations)"
                )
            elif math.isfinite(row["r2"]) and not _r2_bound(row) >= limits["r2_min"]:
                failures.append(
                    f"{row['metric']} R² {row['r2']:.3f} [{row['r2_low']:.3f}, {row['r2_high']:.3f}]: "
                    f"lower bound < {limits['r2_min']:g}"
                )
            problem = _bias_failure(row, limits["relative_bias_max"], cell_size_m)
            if problem:
                failures.append(problem)
        passed = not failures
        simulator = surrogate
        verdicts[str(case)] = Verdict(str(case), passed, failures, simulator, surrogate, evidence)
    return verdicts


def write_verdicts(verdicts: dict[str, Verdict], path: str | Path) -> None:
    Path(path).write_text(json.dumps({case: asdict(v) for case, v in verdicts.items()}, indent=2) + "\n")


def read_verdict(path: str | Path, case: str) -> Verdict:
    """One case's verdict from the gate file, naming the file if it lacks the case."""
    verdicts = json.loads(Path(path).read_text())
    if case not in verdicts:
        raise GateError(f"{path}: no verdict for {case} (was it validated?)")
    return Verdict(**verdicts[case])


def simulator_for(path: str | Path, case: str) -> str:
    """The simulator a case's Monte Carlo runs under ``on_failure: stop``; raises GateError to stop it."""
    verdict = read_verdict(path, case)
    if verdict.passed:
        return verdict.simulator
    raise GateError(
        f"{verdict.sentence()} (validation.acceptance.on_failure: stop; set it to report to run the surrogate, "
        "corrected by the MPM pairs)"
    )
