"""The default Monte Carlo by the shipped GNS beside the embedded MPM, on the same realizations.

    python benchmarks/mc_routes.py                    # default config, its case and realizations
    python benchmarks/mc_routes.py --realizations 16  # fewer

Both routes draw exactly the realizations ``hazard_map`` draws (``rgns.montecarlo.runs.run_realizations``
with the config's settings), the GNS one with the shipped model whatever the validation gate says.
Per route: the exceedance distances of R and I at p = 0.5 and 0.1 with their 95 % order-statistic
intervals (``rgns.hazard.exceedance_distances``), the means, and the wall time per realization;
and whether each pair of intervals overlaps. Writes ``benchmarks/results/mc_routes.json`` and
``mc_routes.md``.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import torch

from rgns.config import load_config
from rgns.hazard.statistics import exceedance_distances
from rgns.montecarlo.runs import CaseInputs, RunSettings, run_realizations
from rgns.surrogates.gns.train import load_simulator
from rgns.surrogates.shipped import MODELS

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "benchmarks" / "results"
PROBABILITIES = (0.5, 0.1)
METRICS = {"runout_m": "R", "influence_m": "I"}


def run_route(config: dict, case: str, n: int, simulator: str, model: Path) -> tuple[list[dict], float]:
    """The Monte Carlo table rows of realizations 0..n-1 by one simulator, and seconds per realization."""
    section = config["montecarlo"]
    params = {
        "montecarlo": {
            key: section[key]
            for key in ("simulator", "batch_size", "duration_s", "device", "keep_frames", "rollout", "screen")
        },
        "mpm": config["mpm"],
        "metrics": config["metrics"],
    }
    settings = replace(RunSettings.from_params(params), simulator=simulator)
    network = load_simulator(model).eval() if simulator == "gns" else None
    start = time.perf_counter()
    table = run_realizations(CaseInputs.from_config(config, case), list(range(n)), settings, network)
    return table.to_dict("records"), (time.perf_counter() - start) / n


def summary(rows: list[dict]) -> dict:
    """Exceedance distances with intervals and the mean of each metric over the finished rows."""
    out = {}
    for key in METRICS:
        values = np.array([row[key] for row in rows if np.isfinite(row[key])])
        out[key] = {
            "mean": float(values.mean()),
            "n": int(values.size),
            "exceedance": [asdict(d) for d in exceedance_distances(values, PROBABILITIES)],
        }
    return out


def overlap(a: dict, b: dict) -> bool | None:
    """Whether two exceedance distances' intervals overlap (None when a bound is missing)."""
    bounds = (a["lower_m"], a["upper_m"], b["lower_m"], b["upper_m"])
    return None if None in bounds else bool(a["lower_m"] <= b["upper_m"] and b["lower_m"] <= a["upper_m"])


def _bound(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def markdown(record: dict) -> str:
    lines = [
        f"{record['case']}, {record['n']} realizations (the same ones by each route); machine: {record['machine']}",
        "",
        "| quantity | GNS (shipped) | MPM | intervals overlap |",
        "|---|---|---|---|",
    ]
    gns, mpm = record["routes"]["gns"]["summary"], record["routes"]["mpm"]["summary"]
    for key, name in METRICS.items():
        for a, b in zip(gns[key]["exceedance"], mpm[key]["exceedance"]):
            cell = [
                f"{d['distance_m']:.2f} [{_bound(d['lower_m'])}, {_bound(d['upper_m'])}]"
                if d["resolved"]
                else d["note"]
                for d in (a, b)
            ]
            lines.append(
                f"| {name} exceeded with p = {a['probability']:g} (m) | {cell[0]} | {cell[1]} | {overlap(a, b)} |"
            )
        lines.append(f"| mean {name} (m) | {gns[key]['mean']:.2f} | {mpm[key]['mean']:.2f} | |")
    lines.append(
        f"| s per realization | {record['routes']['gns']['s_per_realization']:.2f} | "
        f"{record['routes']['mpm']['s_per_realization']:.2f} | |"
    )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--config", type=Path, default=REPO / "config" / "config.yaml")
    parser.add_argument("--realizations", type=int, help="default: montecarlo.realizations")
    parser.add_argument("--model", type=Path, default=MODELS / "gns.pt")
    args = parser.parse_args()
    torch.set_num_threads(1)
    config = load_config(args.config)
    case = config["montecarlo"]["cases"][0]
    n = args.realizations or config["montecarlo"]["realizations"]
    routes = {}
    for simulator in ("gns", "mpm"):
        rows, seconds = run_route(config, case, n, simulator, args.model)
        routes[simulator] = {"s_per_realization": seconds, "rows": rows, "summary": summary(rows)}
        print(f"{simulator}: {seconds:.2f} s per realization", flush=True)
    record = {
        "case": case,
        "n": n,
        "routes": routes,
        "machine": f"{platform.processor() or platform.machine()}, torch {torch.__version__}, 1 thread, CPU",
    }
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "mc_routes.json").write_text(json.dumps(record, indent=1, default=float) + "\n")
    (OUT / "mc_routes.md").write_text(markdown(record))
    print(markdown(record))


if __name__ == "__main__":
    main()
