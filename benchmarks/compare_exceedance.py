"""Two Monte Carlo runs of the same realizations side by side, e.g. the default run (end-state
surrogate) and the same run with ``montecarlo.simulator: mpm``:

    cp -a run run_mpm && cd run_mpm && snakemake --cores 2 results/report/case1/exceedance.json \\
        --config 'montecarlo={simulator: mpm}'
    python benchmarks/compare_exceedance.py run run_mpm --names "end-state surrogate" "MPM 1 m"

Per metric and probability: each run's exceedance distance with its confidence interval, and
whether each lies inside the other's interval (an unresolved bound counts as open); then, realization
by realization (the second run as the truth), R² and the relative bias of the mean for R, V and I.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pandas as pd

from rgns.surrogates.validation import r_squared

METRICS = ("runout_m", "volume_m2", "influence_m")


def inside(value: float, lower: float | None, upper: float | None) -> bool:
    return (lower is None or value >= lower) and (upper is None or value <= upper)


def interval(distance: dict) -> str:
    bounds = ["–" if distance[key] is None else f"{distance[key]:.2f}" for key in ("lower_m", "upper_m")]
    return f"{distance['distance_m']:.2f} [{bounds[0]}, {bounds[1]}]"


def exceedance_table(first: dict, second: dict, names: tuple[str, str]) -> str:
    """The two runs' exceedance distances and whether they agree, as Markdown."""
    lines = [
        f"| metric | P | {names[0]} (m) [95 % CI] | {names[1]} (m) [95 % CI] | each inside the other's CI |",
        "|---|---:|---|---|---|",
    ]
    for metric, block in first["metrics"].items():
        others = {d["probability"]: d for d in second["metrics"][metric]["distances"]}
        for d in block["distances"]:
            o = others[d["probability"]]
            agree = inside(d["distance_m"], o["lower_m"], o["upper_m"]) and inside(
                o["distance_m"], d["lower_m"], d["upper_m"]
            )
            lines.append(
                f"| {metric} | {d['probability']} | {interval(d)} | {interval(o)} | {'yes' if agree else 'no'} |"
            )
    return "\n".join(lines)


def agreement_lines(first: pd.DataFrame, second: pd.DataFrame) -> list[str]:
    """R² and the relative bias of the mean of ``first`` against ``second``, realization by realization."""
    joined = first.add_suffix("_first").join(second.add_suffix("_second"), how="inner")
    return [
        f"{key}: n {len(joined)}, R² {r_squared(joined[key + '_second'].to_numpy(), joined[key + '_first'].to_numpy()):.3f}, "
        f"mean {joined[key + '_first'].mean():.3f} vs {joined[key + '_second'].mean():.3f} "
        f"({joined[key + '_first'].mean() / joined[key + '_second'].mean() - 1:+.2%})"
        for key in METRICS
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("first", type=Path, help="a run directory")
    parser.add_argument("second", type=Path, help="a run directory with the same realizations")
    parser.add_argument("--case", default="case1")
    parser.add_argument("--names", nargs=2, default=("first", "second"))
    args = parser.parse_args()

    def read(run: Path) -> dict:
        return json.loads((run / "results" / "report" / args.case / "exceedance.json").read_text())

    def table(run: Path) -> pd.DataFrame:
        realizations = pd.read_csv(run / "results" / "mc" / args.case / "realizations.csv", index_col="index")
        return realizations.query("status == 'ok'")[list(METRICS)]

    print(exceedance_table(read(args.first), read(args.second), tuple(args.names)))
    print("\n".join(agreement_lines(table(args.first), table(args.second))))


if __name__ == "__main__":
    main()
