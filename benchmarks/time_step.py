"""How the MPM's R, V and I move with its time step: the same realizations at several CFL numbers.

    python benchmarks/time_step.py --run --cases case1 ood_bench --realizations 16 --cfl 0.2 0.1 0.05 0.025 \
        --pic 0 --ends /work/time_step_ends
    python benchmarks/time_step.py --ends /work/time_step_ends          # the report from the stored runs

Each run (case, PIC blend, CFL number, realization) is the Monte Carlo's MPM run of that realization (the pairs'
settings, ``mesh_levels.run_settings``) at ``--cell`` m with ``mpm.embedded.cfl`` and ``pic_blend`` set; the
realizations come from a seed of their own (``--seed``; ``ood_bench`` and the other held-out families of
config/pretrain_general.yaml run under case 1's field statistics). Each is appended to
``benchmarks/results/time_step_runs.jsonl`` as it finishes (a re-run skips what is there; two processes may share
the store), its first and last positions kept under ``--ends``. The report
(``benchmarks/results/time_step.{md,json}``), per case and blend: the mean R, V and I at each CFL number with 95 %
percentile bootstrap intervals over the realizations, each level's paired change from the finest, the observed
order in the time step from the three finest (halving steps) with its Richardson value; and I at thresholds of 0.5,
1, 2 and 4 m at each level (from the kept positions): whether the ground behind the scarp creeps past the 1 m
threshold on a coarse step (I grows at 0.5 and 1 m only) or the failure itself reaches further back (I grows at
every threshold).
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from influence_mechanism import THRESHOLDS_M  # noqa: E402
from mesh_levels import (  # noqa: E402
    add_held_out_family,
    append_lines,
    complete_lines,
    paired_bootstrap,
    richardson,
    run_settings,
)

from rgns.config import load_config  # noqa: E402
from rgns.engines.metrics import influence_distance  # noqa: E402
from rgns.montecarlo import runs as runs_module  # noqa: E402
from rgns.montecarlo.runs import CaseInputs, run_realizations  # noqa: E402
from rgns.provenance import commit  # noqa: E402
from rgns.scene.realizations import accurate_case_inputs  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "benchmarks" / "results"
RUNS = OUT / "time_step_runs.jsonl"
METRICS = ("runout_m", "volume_m2", "influence_m")
HELD_OUT = ("ood_bench", "ood_concave", "hillside")

Key = tuple[str, float, float, float, int]  # case, cell size (m), PIC blend, CFL number, realization index


def load_runs() -> dict[Key, dict]:
    """The stored runs by (case, cell size, PIC blend, CFL number, index)."""
    runs: dict[Key, dict] = {}
    for line in complete_lines(RUNS.read_text()) if RUNS.exists() else []:
        row = json.loads(line)
        key = (row["case"], float(row["cell_size_m"]), float(row["pic_blend"]), float(row["cfl"]), int(row["index"]))
        runs[key] = row
    return runs


def ends_path(folder: Path, case: str, cell: float, pic: float, cfl: float, index: int) -> Path:
    """Where a run's first and last positions are kept (1 m runs without the cell size, as first stored)."""
    size = "" if cell == 1.0 else f"_h{cell:g}"
    return folder / f"{case}{size}_pic{pic:g}_cfl{cfl:g}_{index}.npz"


def run(args: argparse.Namespace) -> None:
    """Every missing run, the finest CFL number last (so that the coarse levels of all realizations come first)."""
    base = load_config(REPO / "config" / "config.yaml")
    base["seed"] = args.seed
    for name in set(args.cases) & set(HELD_OUT):
        add_held_out_family(base, name)
    measure = runs_module.measure
    target: dict = {}

    def measure_and_keep(realization, result, *rest):  # the pipeline's measure, the run's ends kept
        row = measure(realization, result, *rest)
        np.savez_compressed(
            ends_path(
                args.ends, realization.scene.set_name, args.cell, target["pic"], target["cfl"], realization.index
            ),
            initial=result.positions[0].astype(np.float32),
            final=result.positions[-1].astype(np.float32),
        )
        return row

    runs_module.measure = measure_and_keep
    args.ends.mkdir(parents=True, exist_ok=True)
    for cfl in sorted(args.cfl, reverse=True):
        for pic in args.pic:
            for case in args.cases:
                config = copy.deepcopy(base)
                config["mpm"]["embedded"] |= {"cfl": cfl, "pic_blend": pic}
                done = {i for c, h, p, f, i in load_runs() if (c, h, p, f) == (case, args.cell, pic, cfl)}
                missing = [i for i in range(args.first, args.realizations) if i not in done]
                if not missing:
                    continue
                inputs = CaseInputs.from_params(asdict(accurate_case_inputs(config, case, args.cell)))
                settings = run_settings(config)
                target |= {"pic": pic, "cfl": cfl}
                for index in missing:
                    began = time.perf_counter()
                    (row,) = run_realizations(inputs, [index], settings).to_dict("records")
                    row = {k: (v.item() if hasattr(v, "item") else v) for k, v in row.items()}
                    extra = {"case": case, "pic_blend": pic, "cfl": cfl, "cell_size_m": args.cell, "seed": args.seed}
                    extra["seconds"] = time.perf_counter() - began
                    append_lines(RUNS, json.dumps(row | extra) + "\n")
                print(f"{case} pic {pic:g} cfl {cfl:g}: {len(missing)} runs", flush=True)


def interval(samples: tuple[np.ndarray, ...], statistic, seed: int = 0) -> dict:
    point, low, high = paired_bootstrap(samples, statistic, seed)
    return {"value": float(point), "lower": float(low), "upper": float(high)}


def _mean(values: np.ndarray, axis: int = -1) -> np.ndarray:
    return np.mean(values, axis=axis)


def _mean_difference(a: np.ndarray, b: np.ndarray, axis: int = -1) -> np.ndarray:
    return np.mean(a - b, axis=axis)


def _order_value(*levels: np.ndarray, axis: int = -1) -> np.ndarray:
    """Observed order and Richardson value of three levels' means, each step half the last."""
    order, value = richardson(np.stack([level.mean(axis=axis) for level in levels], axis=-1))
    return np.stack([order, value])


def halving(cfls: list[float]) -> bool:
    """Whether the three finest CFL numbers (descending) halve at each step, as the Richardson order assumes."""
    return len(cfls) >= 3 and cfls[-3] == 2 * cfls[-2] == 4 * cfls[-1]


def _text(entry: dict, digits: int = 2) -> str:
    return f"{entry['value']:.{digits}f} [{entry['lower']:.{digits}f}, {entry['upper']:.{digits}f}]"


def report(ends: Path) -> None:
    runs = load_runs()
    groups = sorted({(c, h, p) for c, h, p, _, _ in runs})
    lines = [
        "# The MPM's R, V and I against its time step",
        "",
        "`python benchmarks/time_step.py --ends <ends>` from `benchmarks/results/time_step_runs.jsonl`. Each case's",
        "realizations at each CFL number (the time step is CFL · h / (c_p + |v|max)), the pairs' MPM settings;",
        "means with 95 % percentile bootstrap intervals over the realizations (paired), changes from the finest step,",
        "the observed order in the time step from the three finest where each is half the last, and the Richardson value.",
        "",
    ]
    record: dict = {
        "command": " ".join(["python benchmarks/time_step.py", *sys.argv[1:]]),
        "commit": commit(),
        "runs": str(RUNS.relative_to(REPO)),
        "groups": [],
    }
    for case, cell, pic in groups:
        cfls = sorted({f for c, h, p, f, _ in runs if (c, h, p) == (case, cell, pic)}, reverse=True)
        levels = ({i for c, h, p, f, i in runs if (c, h, p, f) == (case, cell, pic, x)} for x in cfls)
        common = sorted(set.intersection(*levels))
        rows = [[runs[case, cell, pic, x, i] for i in common] for x in cfls]
        group: dict = {
            "case": case,
            "cell_size_m": cell,
            "pic_blend": pic,
            "cfl": cfls,
            "realizations": len(common),
            "metrics": {},
        }
        seeds = {row["seed"] for level in rows for row in level}
        group["seeds"] = sorted(seeds)
        seconds = [float(np.mean([row["seconds"] for row in level])) for level in rows]
        lines += [
            f"## {case} at {cell:g} m, PIC blend {pic:g}: {len(common)} realizations "
            f"(seed {', '.join(map(str, sorted(seeds)))})",
            "",
            "| metric | " + " | ".join(f"CFL {x:g}" for x in cfls) + " | order (3 finest) | Richardson value |",
            "|---|" + "---|" * (len(cfls) + 2),
        ]
        for key in METRICS:
            values = np.array([[row[key] for row in level] for level in rows], dtype=float)
            means = [interval((v,), _mean) for v in values]
            changes = [interval((v, values[-1]), _mean_difference) for v in values[:-1]]
            entry = {"means": means, "change_from_finest": changes}
            if halving(cfls):
                point, low, high = paired_bootstrap(tuple(values[-3:]), _order_value, 0)
                entry["order"], entry["richardson"] = (
                    {"value": float(point[k]), "lower": float(low[k]), "upper": float(high[k])} for k in range(2)
                )
            group["metrics"][key] = entry
            cells = [_text(m) for m in means]
            extras = [_text(entry["order"]), _text(entry["richardson"])] if "order" in entry else ["", ""]
            lines.append(f"| mean {key} | " + " | ".join(cells + extras) + " |")
            lines.append(f"| {key} less the finest | " + " | ".join([_text(c) for c in changes] + ["0"]) + " | | |")
        lines.append("| s per realization | " + " | ".join(f"{s:.1f}" for s in seconds) + " | | |")
        thresholds = influence_at_thresholds(ends, case, cell, pic, cfls, common, rows)
        if thresholds is not None:
            group["influence_at_thresholds"] = thresholds
            lines += [
                "",
                "Mean I (m) at displacement thresholds, from the kept first and last positions:",
                "",
                "| threshold | " + " | ".join(f"CFL {x:g}" for x in cfls) + " |",
                "|---|" + "---|" * len(cfls),
            ]
            for threshold, level_means in thresholds.items():
                lines.append(f"| {threshold} m | " + " | ".join(_text(m) for m in level_means) + " |")
        lines.append("")
        record["groups"].append(group)
    (OUT / "time_step.md").write_text("\n".join(lines))
    (OUT / "time_step.json").write_text(json.dumps(record, indent=1) + "\n")
    print("\n".join(lines))


def influence_at_thresholds(
    ends: Path, case: str, cell: float, pic: float, cfls: list[float], common: list[int], rows: list[list[dict]]
) -> dict | None:
    """Mean I at each of THRESHOLDS_M per CFL number, with intervals; None where a run's positions were not kept."""
    paths = [[ends_path(ends, case, cell, pic, x, i) for i in common] for x in cfls]
    if not all(p.exists() for level in paths for p in level):
        return None
    values = np.empty((len(THRESHOLDS_M), len(cfls), len(common)))  # [threshold, CFL, realization]
    for c, (level_paths, level_rows) in enumerate(zip(paths, rows)):
        for k, (path, row) in enumerate(zip(level_paths, level_rows)):
            with np.load(path) as data:
                initial, final = data["initial"].astype(float), data["final"].astype(float)
            for t, threshold in enumerate(THRESHOLDS_M):
                values[t, c, k] = influence_distance(initial, final, row["crest_x_m"], threshold)
    return {
        f"{threshold:g}": [interval((v,), _mean) for v in levels] for threshold, levels in zip(THRESHOLDS_M, values)
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--run", action="store_true", help="run the missing runs before the report")
    parser.add_argument("--cases", nargs="+", default=["case1"])
    parser.add_argument("--realizations", type=int, default=16)
    parser.add_argument("--first", type=int, default=0, help="run realizations --first .. --realizations - 1 only")
    parser.add_argument("--seed", type=int, default=65301)
    parser.add_argument("--cell", type=float, default=1.0)
    parser.add_argument("--cfl", type=float, nargs="+", default=[0.2, 0.1, 0.05, 0.025])
    parser.add_argument("--pic", type=float, nargs="+", default=[0.0])
    parser.add_argument("--ends", type=Path, required=True)
    parser.add_argument("--no-report", action="store_true")
    args = parser.parse_args()
    if args.run:
        run(args)
    if not args.no_report:
        report(args.ends)


if __name__ == "__main__":
    main()
