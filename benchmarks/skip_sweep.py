"""GNS rest-skipping settings against the suite's no-skipping run: speed-up and change of error.

    python benchmarks/skip_sweep.py          # needs benchmarks/results/suite.json (benchmarks/suite.py)

Re-rolls the suite's realizations with rest-skipping and early stop at each setting below and
compares with the suite's "GNS default, neither" route (same model, same realizations): wall
time per realization, and how much the R, V, I errors against the reference change, in % of
the reference's range. Writes ``benchmarks/results/skip_sweep.{json,md}``.
"""

from __future__ import annotations

import json
from dataclasses import replace

import torch
from suite import METRICS, OUT, REPO, errors, run_gns_route

from rgns.config import load_config
from rgns.montecarlo.runs import rollout_settings

SETTINGS = [  # (context_hops, rest_displacement_m, rest_velocity_m_per_frame)
    (1, 0.1, 5e-4),
    (2, 0.1, 5e-4),
    (1, 0.05, 5e-4),
    (1, 0.05, 2.5e-4),
    (1, 0.05, 1e-4),
]


def main() -> None:
    torch.set_num_threads(1)
    record = json.loads((OUT / "suite.json").read_text())
    reference, neither = record["routes"]["reference"]["rows"], record["routes"]["GNS default, neither"]
    config = load_config(REPO / "config" / "config.yaml")
    base = rollout_settings(config["montecarlo"]["rollout"], config["mpm"]["frame_interval_s"], "ends")
    rows = []
    for hops, displacement, velocity in SETTINGS:
        settings = replace(base, context_hops=hops, rest_displacement=displacement, rest_velocity=velocity)
        measured, seconds = run_gns_route(
            config, REPO / "results" / "model" / "gns.pt", record["n"], record["frames"], settings
        )
        error = errors(measured, reference)
        row = {
            "context_hops": hops,
            "rest_displacement_m": displacement,
            "rest_velocity_m_per_frame": velocity,
            "s_per_realization": seconds,
            "speedup": neither["s_per_realization"] / seconds,
            "error_change_pct_of_range": {k: abs(error[k] - neither["error"][k]) for k in METRICS},
            "per_realization_change": {k: [a[k] - b[k] for a, b in zip(measured, neither["rows"])] for k in METRICS},
        }
        rows.append(row)
        print(json.dumps(row, default=float), flush=True)
    (OUT / "skip_sweep.json").write_text(json.dumps(rows, indent=1, default=float) + "\n")
    lines = [
        f"Against the suite's no-skipping run ({neither['s_per_realization']:.2f} s per realization), "
        f"{record['n']} realizations; one CPU thread.",
        "",
        "| context hops | rest displacement m | rest velocity m/frame | s per realization | speed-up | "
        "error change R / V / I, % of range |",
        "|---:|---:|---:|---:|---:|---|",
    ]
    for row in rows:
        change = " / ".join(f"{row['error_change_pct_of_range'][k]:.2f}" for k in METRICS)
        lines.append(
            f"| {row['context_hops']} | {row['rest_displacement_m']:g} | {row['rest_velocity_m_per_frame']:g} | "
            f"{row['s_per_realization']:.2f} | {row['speedup']:.2f} | {change} |"
        )
    (OUT / "skip_sweep.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
