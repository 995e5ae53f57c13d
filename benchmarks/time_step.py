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
from influence_mechanism import THRESHOLDS_M, draw  # noqa: E402
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
BY_THRESHOLD = "influence_by_threshold_m"  # a run's I at each of THRESHOLDS_M, stored with it (runs since 2026-12-03)

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
                stored = {
                    i: row
                    for (c, h, p, f, i), row in load_runs().items()
                    if (c, h, p, f) == (case, args.cell, pic, cfl)
                }
                wanted = range(args.first, args.realizations)
                missing = [i for i in wanted if i not in stored]
                if args.refresh_ends:  # stored runs whose positions were not kept, run again to keep them
                    missing += [
                        i
                        for i in wanted
                        if i in stored and not ends_path(args.ends, case, args.cell, pic, cfl, i).exists()
                    ]
                if not missing:
                    continue
                inputs = CaseInputs.from_params(asdict(accurate_case_inputs(config, case, args.cell)))
                settings = run_settings(config)
                target |= {"pic": pic, "cfl": cfl}
                for index in missing:
                    began = time.perf_counter()
                    (row,) = run_realizations(inputs, [index], settings).to_dict("records")
                    row = {k: (v.item() if hasattr(v, "item") else v) for k, v in row.items()}
                    key = (case, args.cell, pic, cfl, index)
                    if index in stored:  # a run again for its positions: it must repeat the stored one
                        changed = [k for k in METRICS if row[k] != stored[index][k]]
                        if changed:
                            sys.exit(f"time_step: {key} ran again gives other {', '.join(changed)} than stored")
                        continue
                    extra = {"case": case, "pic_blend": pic, "cfl": cfl, "cell_size_m": args.cell, "seed": args.seed}
                    extra["seconds"] = time.perf_counter() - began
                    extra[BY_THRESHOLD] = run_thresholds(args.ends, key, row)  # stored: the kept positions may go
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


def order_entry(values: np.ndarray, halves: bool) -> dict:
    """The observed order and Richardson value of the three finest levels of ``values`` [level, realization], with
    intervals, where each level halves the last (``halves``); empty otherwise."""
    if not halves:
        return {}
    point, low, high = paired_bootstrap(tuple(values[-3:]), _order_value, 0)
    order, value = ({"value": float(point[k]), "lower": float(low[k]), "upper": float(high[k])} for k in range(2))
    return {"order": order, "richardson": value}


def mean_row(key: str, entry: dict) -> str:
    """A metric's table row: its mean at each level, then its order and Richardson value (blank where none)."""
    extras = [_text(entry["order"]), _text(entry["richardson"])] if "order" in entry else ["", ""]
    return f"| mean {key} | " + " | ".join([_text(m) for m in entry["means"]] + extras) + " |"


def threshold_rows(thresholds: dict, levels: list[str]) -> list[str]:
    """The table of mean I at each displacement threshold (rows) and level (columns, headed ``levels``)."""
    header = ["| threshold | " + " | ".join(levels) + " |", "|---|" + "---|" * len(levels)]
    return header + [f"| {t} m | " + " | ".join(_text(m) for m in means) + " |" for t, means in thresholds.items()]


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
            entry = {"means": means, "change_from_finest": changes} | order_entry(values, halving(cfls))
            group["metrics"][key] = entry
            lines.append(mean_row(key, entry))
            lines.append(f"| {key} less the finest | " + " | ".join([_text(c) for c in changes] + ["0"]) + " | | |")
        lines.append("| s per realization | " + " | ".join(f"{s:.1f}" for s in seconds) + " | | |")
        keys = [[(case, cell, pic, x, i) for i in common] for x in cfls]
        thresholds = influence_at_thresholds(ends, keys, rows)
        if thresholds is not None:
            group["influence_at_thresholds"] = thresholds
            lines += ["", "Mean I (m) at displacement thresholds, from the kept first and last positions:", ""]
            lines += threshold_rows(thresholds, [f"CFL {x:g}" for x in cfls])
        lines.append("")
        record["groups"].append(group)
    (OUT / "time_step.md").write_text("\n".join(lines))
    (OUT / "time_step.json").write_text(json.dumps(record, indent=1) + "\n")
    print("\n".join(lines))


def thresholds_of(initial: np.ndarray, final: np.ndarray, crest_x: float) -> dict[str, float]:
    """A run's I at each of THRESHOLDS_M from its first and last positions."""
    initial, final = initial.astype(float), final.astype(float)  # float32 as kept in a fresh run
    return {f"{t:g}": float(influence_distance(initial, final, crest_x, t)) for t in THRESHOLDS_M}


def kept_positions(ends: Path, key: Key) -> tuple[np.ndarray, np.ndarray]:
    """A run's first and last positions, as :func:`run` kept them."""
    with np.load(ends_path(ends, *key)) as data:
        return data["initial"].astype(float), data["final"].astype(float)


def run_thresholds(ends: Path, key: Key, row: dict) -> dict[str, float] | None:
    """A run's I at each threshold: stored with it, or from its kept positions; None where neither is there."""
    if BY_THRESHOLD in row:
        return row[BY_THRESHOLD]
    if not ends_path(ends, *key).exists():
        return None
    return thresholds_of(*kept_positions(ends, key), row["crest_x_m"])


def influence_at_thresholds(ends: Path, keys: list[list[Key]], rows: list[list[dict]]) -> dict | None:
    """Mean I at each of THRESHOLDS_M per level (``keys`` and ``rows`` [level][realization]), with intervals; None
    where a run has neither its values stored nor its positions kept."""
    found = [[run_thresholds(ends, key, row) for key, row in zip(*level)] for level in zip(keys, rows)]
    if any(entry is None for level in found for entry in level):
        return None
    return {
        f"{t:g}": [interval((np.array([entry[f"{t:g}"] for entry in level]),), _mean) for level in found]
        for t in THRESHOLDS_M
    }


def draw_largest_changes(
    ends: Path, case: str, cells: list[float], keys: list[list[Key]], rows: list[list[dict]], count: int = 3
) -> dict | None:
    """The displacement fields at every cell size of the ``count`` realizations whose I changes most in the last
    refinement, among those whose positions were kept at every cell size (``time_step_mesh_<case>_<finest>m.png``)."""
    kept = [k for k in range(len(keys[0])) if all(ends_path(ends, *level[k]).exists() for level in keys)]
    if not kept:
        return None
    change = {k: abs(rows[-1][k]["influence_m"] - rows[-2][k]["influence_m"]) for k in kept}
    picked = sorted(kept, key=lambda k: -change[k])[:count]
    indices = [keys[0][k][-1] for k in picked]
    crests = {keys[0][k][-1]: rows[0][k]["crest_x_m"] for k in picked}
    pic, cfl = keys[0][0][2], keys[0][0][3]
    name = f"time_step_mesh_{case}_{cells[-1]:g}m.png"
    draw(lambda cell, index: kept_positions(ends, (case, cell, pic, cfl, index)), cells, indices, crests, OUT / name)
    return {"file": name, "realizations": indices}


def mesh_sets(
    runs: dict[Key, dict], cases: list[str], pic: float, cfl: float
) -> list[tuple[str, list[float], list[int]]]:
    """Per case, the cell sizes (descending) and the realizations every one of them ran (two at least); and where
    the finest ran fewer (a study under way), the same without it."""
    sets = []
    for case in cases:
        cells = sorted({h for c, h, p, f, _ in runs if (c, p, f) == (case, pic, cfl)}, reverse=True)
        ran = {x: {i for c, h, p, f, i in runs if (c, h, p, f) == (case, x, pic, cfl)} for x in cells}
        while len(cells) >= 2:
            common = sorted(set.intersection(*(ran[x] for x in cells)))
            if len(common) >= 2:  # an interval needs two
                sets.append((case, cells, common))
            coarser = set.intersection(*(ran[x] for x in cells[:-1]))
            if len(coarser) == len(common):
                break
            cells = cells[:-1]
    return sets


def mesh_report(ends: Path, cfl: float, pic: float) -> None:
    """R, V and I against the cell size at one CFL number (a converged time step): per case, the realizations every
    cell size ran; means with intervals, each level's paired change from the next finer, the observed order and
    Richardson value from the three finest where each cell is half the last. ``time_step_mesh.{md,json}``."""
    runs = load_runs()
    cases = sorted({c for c, h, p, f, _ in runs if (p, f) == (pic, cfl)})
    lines = [
        f"# The MPM's R, V and I against the cell size at CFL {cfl:g}",
        "",
        f"`python benchmarks/time_step.py --ends <ends> --mesh-cfl {cfl:g}` from "
        f"`benchmarks/results/time_step_runs.jsonl`, PIC blend {pic:g}: the realizations every cell size ran at a time "
        "step converged at 1 and 0.5 m (`time_step.md`); means with 95 % percentile bootstrap intervals over the "
        "realizations (paired), each level's change from the next finer, the observed order in the cell size from the "
        "three finest where each is half the last, and the Richardson value.",
        "",
    ]
    record: dict = {
        "command": " ".join(["python benchmarks/time_step.py", *sys.argv[1:]]),
        "commit": commit(),
        "runs": str(RUNS.relative_to(REPO)),
        "cfl": cfl,
        "pic_blend": pic,
        "cases": [],
    }
    for case, cells, common in mesh_sets(runs, cases, pic, cfl):
        keys = [[(case, x, pic, cfl, i) for i in common] for x in cells]
        rows = [[runs[key] for key in level] for level in keys]
        entry: dict = {"case": case, "cell_size_m": cells, "realizations": len(common), "metrics": {}}
        seeds = ", ".join(map(str, sorted({r["seed"] for r in rows[0]})))
        lines += [
            f"## {case}, {' / '.join(f'{x:g}' for x in cells)} m: {len(common)} realizations (seed {seeds})",
            "",
            "| metric | " + " | ".join(f"{x:g} m" for x in cells) + " | order (3 finest) | Richardson value |",
            "|---|" + "---|" * (len(cells) + 2),
        ]
        for key in METRICS:
            values = np.array([[row[key] for row in level] for level in rows], dtype=float)
            metric: dict = {
                "means": [interval((v,), _mean) for v in values],
                "change_from_finer": [interval((a, b), _mean_difference) for a, b in zip(values[:-1], values[1:])],
            } | order_entry(values, halving(cells))
            entry["metrics"][key] = metric
            lines.append(mean_row(key, metric))
            changes = [_text(c) for c in metric["change_from_finer"]]
            lines.append(f"| {key} less the next finer | " + " | ".join([*changes, ""]) + " | | |")
        seconds = [float(np.mean([row["seconds"] for row in level])) for level in rows]
        entry["seconds"] = seconds
        lines.append("| s per realization | " + " | ".join(f"{x:.1f}" for x in seconds) + " | | |")
        thresholds = influence_at_thresholds(ends, keys, rows)
        if thresholds is not None:
            entry["influence_at_thresholds"] = thresholds
            lines += ["", "Mean I (m) at displacement thresholds:", ""]
            lines += threshold_rows(thresholds, [f"{x:g} m" for x in cells])
        picture = draw_largest_changes(ends, case, cells, keys, rows)
        if picture is not None:
            entry["picture"] = picture
            lines += [
                "",
                f"`{picture['file']}`: realizations {', '.join(map(str, picture['realizations']))} (of those whose "
                "positions were kept at every cell size, the largest changes of I in the last refinement), each point "
                "at its initial position coloured by how far it moved; dashed: the crest, red: the rear-most point "
                "moved 1 m.",
            ]
        lines.append("")
        record["cases"].append(entry)
    (OUT / "time_step_mesh.md").write_text("\n".join(lines))
    (OUT / "time_step_mesh.json").write_text(json.dumps(record, indent=1) + "\n")
    print("\n".join(lines))


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
    parser.add_argument(
        "--refresh-ends", action="store_true", help="run stored runs again to keep their positions (checked equal)"
    )
    parser.add_argument("--mesh-cfl", type=float, help="report R, V, I against the cell size at this CFL number")
    args = parser.parse_args()
    if args.run:
        run(args)
    if args.no_report:
        return
    if args.mesh_cfl is not None:
        mesh_report(args.ends, args.mesh_cfl, args.pic[0])
    else:
        report(args.ends)


if __name__ == "__main__":
    main()
