"""Where each Monte Carlo realization of a case runs: one route per model and mesh.

Every rule that simulates realizations is one family keyed by route (rules/montecarlo.smk): a route's
chunks are ``results/mc/{case}/{route}/chunk_{k}.csv``, its table ``results/mc/{case}/{route}.csv``, and
which model, mesh and realizations it runs reads off :func:`monte_carlo_routes`. The MPM runs only the
pairs' routes; the Monte Carlo itself is run by ``montecarlo.simulator``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rgns.scene.realizations import MEAN_FIELD, CaseInputs, accurate_case_inputs

#: which realizations a route runs
ALL, PAIRED, MEAN = "all", "paired", "mean_field"


@dataclass(frozen=True)
class Route:
    """One way of running a case's realizations: by which simulator, at which mesh, which of them."""

    name: str  # the folder of its chunks and the stem of its table under results/mc/{case}/
    simulator: str  # "gns", "endstate" or "mpm"
    cell_size_m: float  # the mesh the realizations are drawn at
    realizations: str  # ALL, PAIRED (those rule paired_plan chose) or MEAN
    chunk_size: int  # realizations per chunk job
    model: str | None  # the trained model file the simulator loads (none for the MPM)
    drawn_as_accurate: bool  # the field on the Monte Carlo's grid, as the accurate mesh draws it
    gated: bool  # the validation gate may stop it (validation.acceptance.on_failure: stop)

    def case_inputs(self, config: dict[str, Any], case: str) -> CaseInputs:
        """What drawing one of its realizations of ``case`` depends on."""
        if self.drawn_as_accurate:
            return accurate_case_inputs(config, case, self.cell_size_m)
        return CaseInputs.from_config(config, case)

    def listed(self, config: dict[str, Any]) -> list[int] | None:
        """Its realization indices in chunk order; None where rule paired_plan lists them."""
        if self.realizations == MEAN:
            return [MEAN_FIELD]
        if self.realizations == ALL:
            return list(range(config["montecarlo"]["realizations"]))
        return None

    def count(self, config: dict[str, Any]) -> int:
        """How many realizations it runs."""
        listed = self.listed(config)
        return len(listed) if listed is not None else config["montecarlo"]["fidelity"]["paired"]

    def chunk_ids(self, config: dict[str, Any]) -> list[str]:
        """Its chunk ids ('000', '001', ...)."""
        return chunk_labels(self.count(config), self.chunk_size)


def monte_carlo_routes(config: dict[str, Any]) -> dict[str, Route]:
    """The routes a config runs, by name: the Monte Carlo and its mean field by ``montecarlo.simulator``;
    with ``montecarlo.fidelity.paired`` the pairs by the MPM at the accurate mesh, with ``mesh_order`` once
    more at the Monte Carlo's mesh, and with ``cheap: tuned`` every realization by the tuned end-state
    surrogate (the correction's control variate)."""
    section, fidelity = config["montecarlo"], config["montecarlo"]["fidelity"]
    simulator, cell_size_m = section["simulator"], config["mesh"]["cell_size_m"]
    model = None if simulator == "mpm" else f"results/model/{simulator}.pt"
    gated = model is not None and config["validation"]["acceptance"]["on_failure"] == "stop"
    routes = [
        # every Monte Carlo realization, by the Monte Carlo's simulator
        Route(
            "realizations",
            simulator,
            cell_size_m,
            ALL,
            section["chunk_size"],
            model,
            False,
            gated,
        ),
        # the deterministic mean-field realization, the reference of the report
        Route(
            "mean_field",
            simulator,
            cell_size_m,
            MEAN,
            1,
            model,
            False,
            gated,
        ),
    ]
    if fidelity["paired"]:
        routes.append(
            # the pairs at the accurate mesh: what the correction makes the estimate exact for
            Route(
                "paired",
                "mpm",
                fidelity["high_cell_size_m"],
                PAIRED,
                fidelity["chunk_size"],
                None,
                True,
                False,
            )
        )
        if fidelity["mesh_order"]:
            routes.append(
                # the pairs at the Monte Carlo's mesh: the coarser end of the step to the converged mesh
                Route(
                    "paired_coarse",
                    "mpm",
                    cell_size_m,
                    PAIRED,
                    fidelity["chunk_size"],
                    None,
                    True,
                    False,
                )
            )
        if fidelity["cheap"] == "tuned":
            routes.append(
                # every realization by the tuned end-state surrogate: the correction's control variate
                Route(
                    "control",
                    "endstate",
                    cell_size_m,
                    ALL,
                    section["chunk_size"],
                    "results/model/endstate_tuned.pt",
                    False,
                    False,
                )
            )
    return {route.name: route for route in routes}


def chunk_labels(count: int, chunk_size: int) -> list[str]:
    """The ids ('000', '001', ...) of the chunks of ``chunk_size`` that ``count`` items make (the last one short)."""
    return [f"{k:03d}" for k in range(-(-count // chunk_size))]


def chunk_share(listed: list[int], chunk: int, chunk_size: int) -> list[int]:
    """The realizations chunk ``chunk`` of a route runs: its ``chunk_size`` share of the listed ones."""
    return listed[chunk * chunk_size : (chunk + 1) * chunk_size]


def route_realizations(listed: list[int] | None, plans: list[str]) -> list[int]:
    """A route's realizations in chunk order: its own list, or (None) the one rule paired_plan chose, read
    from its plan file (the only one in ``plans``)."""
    if listed is not None:
        return listed
    return list(json.loads(Path(plans[0]).read_text())["indices"])
