"""The embedded MPM's mesh error on the Monte Carlo's own realizations, with intervals.

    python benchmarks/mesh_levels.py --run --cases case1 case3    # resumable: one line per run
    python benchmarks/mesh_levels.py                              # tables and plot from what is saved

Each realization is the default config's Monte Carlo realization (the top-level seed, or ``--seed``), drawn as the
pipeline's paired chunks draw it (``rgns.scene.realizations.accurate_case_inputs``: the same slope and the
friction field on the 1 m grid at every mesh) and run as they run it (``run_realizations`` with the
embedded MPM, screening included), at cells h = 1, 0.5, 0.25 m (``--cells``). Every run is appended as
one line to ``benchmarks/results/mesh_levels_runs.jsonl`` (its row with its case, cell size and index:
:func:`append_run`, :func:`load_runs`) as it finishes, so a killed run loses only the realization in progress
(a line it cut short is left out by the reader and cut off by the next append); realizations run in index
order, every level of one before the next, so the cases and levels stay paired whenever it stops.

The report takes, per case and quantity (the means of R, V and I; the runout and influence exceeded
with probability 0.5 and 0.1, the 1 - P quantiles over realizations; the indicators 1{R > r} at the runout
the 0.5 m level exceeds with those probabilities), over the realizations every level ran: the values per
level, the observed order p = log2(|f_1 - f_0.5| / |f_0.5 - f_0.25|) of the means, the Richardson value
f* = f_0.25 + (f_0.25 - f_0.5) / (2^p - 1) and the error of each level against it; each with a 95 %
percentile bootstrap interval over realizations (scipy.stats.bootstrap, paired). Writes
``mesh_levels.md``, ``mesh_levels.json`` and ``mesh_levels.png`` into benchmarks/results/ (named after the runs'
store, ``--runs``, less its ``_runs.jsonl``).
"""

from __future__ import annotations

import argparse
import fcntl
import json
import os
import subprocess
import time
from dataclasses import asdict, replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import torch  # noqa: E402
from scipy import stats  # noqa: E402

from rgns.config import load_config  # noqa: E402
from rgns.fidelity import mesh_extrapolation  # noqa: E402
from rgns.fidelity.outputs import correct  # noqa: E402
from rgns.hazard.exceedance import sample_distance  # noqa: E402
from rgns.montecarlo.runs import CaseInputs, RunSettings, run_realizations  # noqa: E402
from rgns.provenance import commit  # noqa: E402
from rgns.scene.realizations import accurate_case_inputs  # noqa: E402
from rgns.scene.sets import test_cases  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "benchmarks" / "results"
RUNS = OUT / "mesh_levels_runs.jsonl"  # the runs read and written; --runs rebinds it
CPU_RUNS = OUT / "mesh_levels_runs.jsonl"  # the one-thread CPU runs, one realization at a time
GPU_RUNS = OUT / "mesh_levels_gpu_runs.jsonl"  # case 1's runs in GPU batches of 64 (mesh_levels_gpu.md)
# The one-thread CPU runs made by the compiled kernels (the engine the pipeline runs on the CPU): the cost comparison's
# seconds per realization and level, whatever store the report reads (the other stores' times are the torch engine's)
COST_RUNS = OUT / "mesh_levels_independent_runs.jsonl"
METRICS = ("runout_m", "volume_m2", "influence_m")
PROBABILITIES = (0.5, 0.1)
RESAMPLES = 4000
ASYMPTOTIC = (0.5, 3.0)  # an order inside this is taken as the asymptotic range (as benchmarks/convergence.py)


Key = tuple[str, float, int]  # a run's case, cell size (m) and realization index


def complete_lines(text: str) -> list[str]:
    """The lines of an append-only store's text, without their newlines; a last line without one (a write a
    kill cut short) is left out."""
    return text.split("\n")[:-1]


def append_lines(path: Path, text: str, header: str = "") -> None:
    """Append ``text`` (whole lines, each ending in a newline) to the store at ``path`` in one write, flushed to
    disk, under an exclusive lock (several processes may append to one store); a last line a killed writer cut
    short is cut off first, and ``header`` starts an empty store."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a+b") as store:
        fcntl.flock(store, fcntl.LOCK_EX)  # released when the file closes, or its process dies
        size = store.seek(0, os.SEEK_END)
        if size:
            store.seek(size - 1)
            if store.read(1) != b"\n":
                store.seek(0)
                store.truncate(store.read().rfind(b"\n") + 1)
        if store.seek(0, os.SEEK_END) == 0:
            text = header + text
        store.write(text.encode())
        store.flush()
        os.fsync(store.fileno())


def parse_runs(text: str) -> dict[Key, dict]:
    """The runs a store's text holds, by (case, cell size, index): each the row its run saved, less the case (the
    last of a key saved twice)."""
    runs: dict[Key, dict] = {}
    for line in complete_lines(text):
        row = json.loads(line)
        runs[row.pop("case"), float(row["cell_size_m"]), int(row["index"])] = row
    return runs


def load_runs(path: Path) -> dict[Key, dict]:
    """The runs saved in the store at ``path`` (none if it is absent): :func:`parse_runs`."""
    return parse_runs(path.read_text()) if path.exists() else {}


def append_run(path: Path, case: str, cell: float, index: int, row: dict) -> None:
    """Save one run: its row, with its case, cell size and index, as one line appended to the store at ``path``."""
    append_lines(path, json.dumps({"case": case} | row | {"cell_size_m": cell, "index": index}) + "\n")


def indices_at(runs: dict[Key, dict], case: str, cell: float) -> set[int]:
    """The realizations the runs hold of ``case`` at ``cell``."""
    return {i for c, h, i in runs if c == case and h == cell}


def seeds() -> list[int]:
    """The top-level seeds the runs in RUNS were drawn from (the default config's where a run does not say)."""
    default = load_config(REPO / "config" / "config.yaml")["seed"]
    return sorted({int(row.get("seed", default)) for row in load_runs(RUNS).values()})


def realizations_of(cases: list[str]) -> dict[str, int]:
    """How many realizations the store holds of each case at its finest level."""
    runs = load_runs(RUNS)
    return {case: len(indices_at(runs, case, min(h for c, h, _ in runs if c == case))) for case in cases}


def add_held_out_family(config: dict, name: str) -> None:
    """config/pretrain_general.yaml's family ``name`` (one of its held-out slopes, which no model trained on) as a
    case of that name, under case 1's field statistics."""
    general = load_config(REPO / "config" / "pretrain_general.yaml")
    config["geometry"]["families"][name] = general["geometry"]["families"][name]
    config["sets"][name] = [dict(config["sets"]["case1"][0], family=name)]


def report_name() -> str:
    """The report's name: the runs' store's, less its ``_runs.jsonl`` (mesh_levels, mesh_levels_gpu)."""
    return RUNS.name.removesuffix(".jsonl").removesuffix("_runs")


def other_runs() -> bool:
    """Whether RUNS (``--runs``) ran elsewhere than on one CPU thread (a GPU's batches)."""
    return any(row.get("device", "cpu") != "cpu" for row in load_runs(RUNS).values())


def run_settings(config: dict) -> RunSettings:
    """The Monte Carlo's run settings with the embedded MPM, as rule mc_chunk runs route paired."""
    section = config["montecarlo"]
    params = {
        "montecarlo": {
            key: section[key]
            for key in ("simulator", "batch_size", "duration_s", "device", "keep_frames", "rollout", "screen")
        }
        | {"simulator": "mpm", "keep_frames": "ends"},
        "mpm": config["mpm"],
        "metrics": config["metrics"],
    }
    return RunSettings.from_params(params)


def run(
    config: dict,
    cases: list[str],
    cells: list[float],
    realizations: int,
    first: int = 0,
    batch: int = 1,
    ends: Path | None = None,
) -> None:
    """Every missing (realization, case, cell) run from realization ``first`` on, saved one by one; with
    ``batch`` > 1, the missing ones of each aligned group of ``batch`` indices run together (one MPM batch,
    each at its own time step; on a GPU with ``mpm.embedded.device``), each saved with the batch's seconds / size.
    With ``ends`` a folder, each run's first and last particle positions and friction angles are kept there too
    (``{case}_{cell}_{index}.npz``: what a picture of the moved ground needs)."""
    if ends is not None:
        keep_ends(ends)
    settings = run_settings(config)
    settings = replace(settings, batch_size=batch)
    device = config["mpm"]["embedded"]["device"]
    inputs = {
        (case, h): CaseInputs.from_params(asdict(accurate_case_inputs(config, case, h)))
        for case in cases
        for h in cells
    }
    for start in range(first - first % batch, realizations, batch):
        group = range(max(start, first), min(start + batch, realizations))
        for case in cases:
            for h in cells:
                done = indices_at(load_runs(RUNS), case, h)
                missing = [i for i in group if i not in done]
                if not missing:
                    continue
                began = time.perf_counter()
                rows = run_realizations(inputs[case, h], missing, settings)
                seconds = (time.perf_counter() - began) / len(missing)
                for row in rows.to_dict("records"):
                    record = {k: (v.item() if hasattr(v, "item") else v) for k, v in row.items()}
                    extra = {
                        "seconds": seconds,
                        "cell_size_m": h,
                        "device": device,
                        "batch": len(missing),
                        "seed": config["seed"],
                    }
                    append_run(RUNS, case, h, int(row["index"]), record | extra)
                print(
                    f"{case} h {h:g} realizations {missing[0]}-{missing[-1]}: mean R {rows['runout_m'].mean():.2f} m, "
                    f"{seconds:.1f} s each",
                    flush=True,
                )


def keep_ends(folder: Path) -> None:
    """Make every measured MPM run keep its first and last positions in ``folder`` (rgns.montecarlo.runs.measure
    wrapped: the measure the pipeline uses, unchanged)."""
    from rgns.montecarlo import runs as runs_module

    folder.mkdir(parents=True, exist_ok=True)
    measure = runs_module.measure

    def measure_and_keep(realization, result, *args):
        row = measure(realization, result, *args)
        cell = float(realization.scene.cell_size_m)
        np.savez_compressed(
            folder / f"{realization.scene.set_name}_{cell:g}_{realization.index}.npz",
            initial=result.positions[0].astype(np.float32),
            final=result.positions[-1].astype(np.float32),
            friction_deg=np.asarray(realization.friction_deg, dtype=np.float32),
        )
        return row

    runs_module.measure = measure_and_keep


def saved(
    case: str, cells: list[float], first: int | None = None
) -> tuple[np.ndarray, dict[str, np.ndarray], dict[float, float]]:
    """Indices every level ran (the first ``first`` of them, if given), the metrics [level, realization] per key,
    the mean seconds per level."""
    runs = load_runs(RUNS)
    found = [indices_at(runs, case, h) for h in cells]
    common = np.array(sorted(set.intersection(*found))[:first]) if found else np.array([], dtype=int)
    rows = [[runs[case, h, i] for i in common] for h in cells]
    values = {key: np.array([[row[key] for row in level] for level in rows], dtype=float) for key in METRICS}
    seconds = {h: float(np.mean([row["seconds"] for row in level])) for h, level in zip(cells, rows)}
    return common, values, seconds


def cost_seconds(case: str, cells: list[float]) -> dict[float, float]:
    """Mean one-thread seconds per realization at each of ``cells`` in COST_RUNS (the compiled kernels' runs),
    ValueError naming the store where it lacks a level of ``case``."""
    runs = load_runs(COST_RUNS)
    seconds = {h: [runs[case, h, i]["seconds"] for i in indices_at(runs, case, h)] for h in cells}
    missing = [h for h, level in seconds.items() if not level]
    if missing:
        raise ValueError(f"{COST_RUNS}: no {case} runs at {missing} m for the cost comparison")
    return {h: float(np.mean(level)) for h, level in seconds.items()}


def richardson(means: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Observed order and Richardson value from level means [..., 3] (h, h/2, h/4 along the last axis)."""
    coarse, fine = means[..., 1] - means[..., 0], means[..., 2] - means[..., 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        order = np.log2(np.abs(coarse / fine))
        value = means[..., 2] + fine / (2.0**order - 1.0)
    return order, value


def paired_bootstrap(samples: tuple[np.ndarray, ...], statistic, seed: int) -> tuple[np.ndarray, ...]:
    """A vectorised statistic of paired samples, and its percentile bootstrap interval over the realizations."""
    boot = stats.bootstrap(
        samples,
        statistic,
        paired=True,
        vectorized=True,
        n_resamples=RESAMPLES,
        method="percentile",
        random_state=np.random.default_rng(seed),
    )
    low, high = boot.confidence_interval
    return statistic(*samples), low, high


def fit(values: np.ndarray, reduce=np.mean, seed: int = 0) -> dict:
    """Level values (``reduce`` over realizations: the mean, or a quantile), order, Richardson value and
    level errors of values [3 levels, n], with paired bootstrap intervals over the realizations."""

    def statistic(*columns: np.ndarray, axis: int = -1) -> np.ndarray:
        levels = np.stack(columns, axis=0)  # [3, ..., n]
        means = np.moveaxis(reduce(levels, axis=axis), 0, -1)  # [..., 3]
        order, value = richardson(means)
        errors = means - value[..., None]
        return np.moveaxis(np.concatenate([means, order[..., None], value[..., None], errors], axis=-1), -1, 0)

    point, low, high = paired_bootstrap(tuple(values), statistic, seed)
    names = ["mean_1", "mean_0.5", "mean_0.25", "order", "richardson", "error_1", "error_0.5", "error_0.25"]
    return {
        name: {"value": float(p), "lower": float(lo), "upper": float(hi)}
        for name, p, lo, hi in zip(names, point, low, high)
    }


def devices(case: str, cells: list[float], indices: np.ndarray) -> set[str]:
    """The devices the saved runs ran on ("cpu" where a run does not say)."""
    runs = load_runs(RUNS)
    return {runs[case, h, i].get("device", "cpu") for h in cells for i in indices}


def cpu_agreement(case: str, cells: list[float]) -> tuple[list[str], list[dict]]:
    """Where RUNS are not the one-thread CPU runs: their runout against those on the realizations both ran (the
    report's lines, and per cell size the count, the mean difference and the largest)."""
    if not other_runs():
        return [], []
    rows, records = [], []
    these, cpu = load_runs(RUNS), load_runs(CPU_RUNS)
    for h in cells:
        both = sorted(indices_at(these, case, h) & indices_at(cpu, case, h))
        if not both:
            continue
        pairs = np.array([[runs[case, h, i]["runout_m"] for runs in (these, cpu)] for i in both])
        difference = pairs[:, 0] - pairs[:, 1]
        records.append(
            {
                "cell_size_m": h,
                "n": len(both),
                "mean_difference_m": float(difference.mean()),
                "largest_m": float(np.abs(difference).max()),
            }
        )
        rows.append(
            f"h {h:g} m: {len(both)} realizations, mean difference {difference.mean():+.4f} m, largest "
            f"{np.abs(difference).max():.4f} m"
        )
    if not rows:
        return [], []
    return [
        "",
        f"These runs' runout against the one-thread CPU runs (`{CPU_RUNS.relative_to(REPO)}`, one realization at a "
        "time) on the realizations both ran: " + "; ".join(rows) + ".",
    ], records


def finest_fit(values: np.ndarray, seed: int = 0) -> dict:
    """Four levels [4, n] (h, h/2, h/4, h/8): the finest level's mean against what the three coarser predict for
    it (their Richardson value f* plus the finest's expected error (f_h/4 − f*) / 2^p), and the order and
    Richardson value of the three finest, each with its paired bootstrap interval over the realizations."""

    def statistic(*columns: np.ndarray, axis: int = -1) -> np.ndarray:
        means = np.stack([c.mean(axis=axis) for c in columns], axis=-1)  # [..., 4]
        order, value = richardson(means[..., :3])
        with np.errstate(invalid="ignore", over="ignore"):
            predicted = value + (means[..., 2] - value) / 2.0**order
        order_fine, value_fine = richardson(means[..., 1:])
        stacked = [means[..., 3], predicted, means[..., 3] - predicted, order_fine, value_fine]
        return np.stack(stacked, axis=0)

    point, low, high = paired_bootstrap(tuple(values), statistic, seed)
    names = ["finest", "predicted", "finest_minus_predicted", "order_fine", "richardson_fine"]
    return {
        name: {"value": float(p), "lower": float(lo), "upper": float(hi)}
        for name, p, lo, hi in zip(names, point, low, high)
    }


def finest_check(case: str, cells: list[float], finest: float = 0.125) -> tuple[list[str], dict]:
    """Where realizations also ran at ``finest``: its means against the value the three coarser levels predict
    for the same realizations (:func:`finest_fit`), with intervals once 8 or more ran (points below that)."""
    levels = [*cells, finest]
    indices, values, seconds = saved(case, levels)
    if len(indices) == 0:
        return [], {}
    if len(indices) < 8:
        lines = [
            "",
            f"At h = {finest:g} m ({len(indices)} realizations: {', '.join(map(str, indices))}; "
            f"{seconds[finest]:.0f} s per realization): the means against the Richardson value of 1 / 0.5 / 0.25 m "
            "on the same realizations (points, too few for an interval):",
            "",
            f"| quantity | means at h = {' / '.join(f'{h:g}' for h in levels)} m | Richardson from 1 / 0.5 / 0.25 m | "
            "order from 0.5 / 0.25 / 0.125 m |",
            "|---|---|---|---|",
        ]
        for key in METRICS:
            means = values[key].mean(axis=1)
            _, predicted = richardson(means[:3])
            order_fine, _ = richardson(means[1:])
            steps = np.diff(means[1:])
            fine = (
                f"{order_fine:.2f}" if np.sign(steps[0]) == np.sign(steps[1]) else "none (the differences change sign)"
            )
            lines.append(f"| {key} | {' / '.join(f'{m:.2f}' for m in means)} | {predicted:.2f} | {fine} |")
        return lines, {}
    fits = {key: finest_fit(values[key]) for key in METRICS}

    def cell(entry: dict) -> str:
        return f"{entry['value']:.2f} [{entry['lower']:.2f}, {entry['upper']:.2f}]"

    lines = [
        "",
        f"At h = {finest:g} m ({len(indices)} realizations; {seconds[finest]:.0f} s per realization): its mean "
        "against what 1 / 0.5 / 0.25 m predict for it (their Richardson value plus the finest level's error at "
        "their order), and the order of 0.5 / 0.25 / 0.125 m, with 95 % bootstrap intervals:",
        "",
        f"| quantity | means at h = {' / '.join(f'{h:g}' for h in levels)} m | mean at {finest:g} m | predicted | "
        "observed − predicted | order of the three finest | Richardson from them |",
        "|---|---|---|---|---|---|---|",
    ]
    for key, f in fits.items():
        means = " / ".join(f"{m:.2f}" for m in values[key].mean(axis=1))
        lines.append(
            f"| {key} | {means} | {cell(f['finest'])} | {cell(f['predicted'])} | "
            f"{cell(f['finest_minus_predicted'])} | {cell(f['order_fine'])} | {cell(f['richardson_fine'])} |"
        )
    return lines, {"realizations": indices.tolist(), "seconds": seconds[finest], "fits": fits}


def mesh_order(order: dict) -> list[float] | None:
    """[low, value, high] rounded, where the order's interval shows an asymptotic range; else None."""
    low, value, high = order["lower"], order["value"], order["upper"]
    inside = np.isfinite([low, value, high]).all() and ASYMPTOTIC[0] <= low and high <= ASYMPTOTIC[1]
    return [round(low, 2), round(value, 2), round(high, 2)] if inside else None


MIN_BEYOND = 3


def exceeded_with(probability: float):
    """The reducer of the distance exceeded with ``probability`` over realizations, by the pipeline's one
    estimator (rgns.hazard.exceedance.sample_distance)."""
    return lambda x, axis: np.apply_along_axis(sample_distance, axis, x, probability)


def report(cases: list[str], cells: list[float], run_json: Path | None = None) -> None:
    gpu = other_runs()
    default_cases = test_cases(load_config(REPO / "config" / "config.yaml")["sets"])
    how = (
        f"`python benchmarks/mesh_levels.py --run --cases case1 --device cuda --batch 64 --realizations 256 --runs "
        f"{RUNS.relative_to(REPO)}` on a GPU (an H200; without Snakemake there: `--resolved-config`, the default config "
        f"validated as JSON), then `python benchmarks/mesh_levels.py --cases case1 --runs {RUNS.relative_to(REPO)} "
        "--against <run>/results/report/case1/multifidelity.json`"
        if gpu
        else "`python benchmarks/mesh_levels.py --run --cases case1 case3` (and `--cells 0.125`, `--first`, "
        "`--realizations` to extend), then `python benchmarks/mesh_levels.py --against "
        "<run>/results/report/case1/multifidelity.json`"
        if RUNS.resolve() == CPU_RUNS.resolve()
        else "; ".join(
            f"`python benchmarks/mesh_levels.py --run --no-report --cases {case} --cells 1 0.5 0.25 0.125 "
            f"--seed {', '.join(map(str, seeds()))} --realizations {count} --runs {RUNS.relative_to(REPO)} "
            f"--keep-ends <ends>" + ("`" if case in default_cases else f" --held-out-family {case}`")
            for case, count in realizations_of(cases).items()
        )
        + f" (each in two processes that split the realizations with `--first`), then `python benchmarks/mesh_levels.py "
        f"--cases {' '.join(cases)} --runs {RUNS.relative_to(REPO)}`"
    )
    times = (
        "Times: wall seconds per realization of a GPU batch of 64 (sharing its time step)."
        if gpu
        else "Times: wall seconds per realization on one thread of a 2-core machine with other work running."
    )
    lines = [
        "# The embedded MPM's mesh error on the Monte Carlo's realizations"
        if RUNS.resolve() == CPU_RUNS.resolve() or other_runs()
        else f"# The embedded MPM's mesh error on realizations of their own (seed {', '.join(map(str, seeds()))})",
        "",
        f"{how} (method: its docstring). B-spline shape functions, the default config's engine settings and run "
        f"length; 95 % percentile bootstrap intervals over the realizations. {times}",
        "",
    ]
    record: dict = {"command": how.replace("`", ""), "commit": commit()}  # then one entry per case
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    for case in cases:
        indices, values, seconds = saved(case, cells)
        if len(indices) < 2:
            continue
        r_half = values["runout_m"][1]
        thresholds = {p: float(sample_distance(r_half, p)) for p in PROBABILITIES}
        fits = {key: fit(v) for key, v in values.items()}
        for p in PROBABILITIES:
            for key in ("runout_m", "influence_m"):
                fits[f"{key} exceeded with P {p}"] = fit(values[key], exceeded_with(p))
        for r in thresholds.values():  # the indicators the exceedance curve averages, at the 0.5 m level's distances
            fits[f"P(R > {r:.2f} m)"] = fit((values["runout_m"] > r).astype(float))
        record[case] = {"realizations": indices.tolist(), "seconds": seconds, "thresholds_m": thresholds, "fits": fits}
        lines += [
            f"## {case}: {len(indices)} realizations ({', '.join(map(str, indices))}) at every level",
            "",
            "Seconds per realization: " + ", ".join(f"h {h:g} m {s:.0f} s" for h, s in seconds.items()) + ".",
            "",
            "| quantity | mean at h = 1 / 0.5 / 0.25 m | order p [95 %] | Richardson f* [95 %] | "
            "error of 0.5 m (f_0.5 − f*) [95 %] | error of 0.25 m [95 %] |",
            "|---|---|---|---|---|---|",
        ]

        def cell(entry: dict, digits: int = 2) -> str:
            return f"{entry['value']:.{digits}f} [{entry['lower']:.{digits}f}, {entry['upper']:.{digits}f}]"

        for key, f in fits.items():
            means = " / ".join(f"{f[f'mean_{h:g}']['value']:.2f}" for h in cells)
            lines.append(
                f"| {key} | {means} | {cell(f['order'])} | {cell(f['richardson'])} | "
                f"{cell(f['error_0.5'])} | {cell(f['error_0.25'])} |"
            )
        finest_lines, record[case]["finest"] = finest_check(case, cells)
        lines += finest_lines
        agreement, record[case]["cpu_agreement"] = cpu_agreement(case, cells)
        lines += agreement
        suggested = {key: mesh_order(fits[key]["order"]) for key in METRICS}
        record[case]["mesh_order"] = suggested
        lines += [
            "",
            f"As `montecarlo.fidelity.mesh_order` (an order whose interval lies within {ASYMPTOTIC[0]:g}–"
            f"{ASYMPTOTIC[1]:g}, else null: no asymptotic range): `{json.dumps(suggested)}`.",
        ]
        lines.append("")
        for ax, key in zip(axes, METRICS):
            f = fits[key]
            ax.plot(cells, [f[f"mean_{h:g}"]["value"] for h in cells], "o-", label=f"{case} (n {len(indices)})")
            ax.errorbar(
                [0.0],
                [f["richardson"]["value"]],
                yerr=[  # a percentile interval of a ratio's log need not hold its point value: drawn from it
                    [max(0.0, f["richardson"]["value"] - f["richardson"]["lower"])],
                    [max(0.0, f["richardson"]["upper"] - f["richardson"]["value"])],
                ],
                fmt="s",
                capsize=3,
                color=ax.lines[-1].get_color(),
            )
            ax.set_xlabel("cell size h (m); h = 0: Richardson value [95 %]")
            ax.set_title(f"mean {key}")
    for ax in axes:
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(OUT / f"{report_name()}.png", dpi=130)
    plt.close(fig)
    if run_json is not None:
        against, compared = against_run(cases[0], cells, run_json)
        lines += against
        record[cases[0]]["against"] = {"headline": headline_source(run_json), "comparisons": compared}
    lines += [
        "A negative error is an answer short of the converged one. The order is that of the means; where "
        "its interval reaches below 0.5 or the differences change sign the Richardson value is not to "
        "be trusted, and the interval says so by its width.",
        "",
    ]
    (OUT / f"{report_name()}.md").write_text("\n".join(lines))
    (OUT / f"{report_name()}.json").write_text(json.dumps(record, indent=1))
    print("\n".join(lines))


def reference(values: np.ndarray, order: list[float], reduce=np.mean, seed: int = 0, step: bool = False) -> dict:
    """The direct reference: the finest level plus its Richardson step from the two finest levels, at the
    order's value, with the envelope of the paired bootstrap intervals at the order's value and ends; with
    ``step``, what that adds to the 0.5 m level (converged − 0.5 m, paired: without the sampling both share)."""
    low_order, value, high_order = order
    orders = np.array([value, low_order, high_order])

    def statistic(half: np.ndarray, quarter: np.ndarray, axis: int = -1) -> np.ndarray:
        fine, coarse = reduce(quarter, axis=axis), reduce(half, axis=axis)
        converged = fine[None] + (fine - coarse)[None] / (2.0 ** orders.reshape(-1, *[1] * np.ndim(fine)) - 1.0)
        return converged - coarse[None] if step else converged

    point, low, high = paired_bootstrap((values[1], values[2]), statistic, seed)
    return {"value": float(point[0]), "lower": float(np.min(low)), "upper": float(np.max(high))}


def comparison(name: str, value: float, interval: tuple[float, float], ref: dict) -> dict:
    """The headline and the reference of one quantity, each [value, lower, upper], and whether they agree."""
    return {
        "quantity": name,
        "headline": [value, *interval],
        "reference": [ref["value"], ref["lower"], ref["upper"]],
        "inside": bool(interval[0] <= ref["value"] <= interval[1]),
        "overlap": bool(interval[0] <= ref["upper"] and ref["lower"] <= interval[1]),
    }


def comparison_row(entry: dict) -> str:
    """A table row of a :func:`comparison`."""
    (value, low, high), (ref, ref_low, ref_high) = entry["headline"], entry["reference"]
    return (
        f"| {entry['quantity']} | {value:.2f} [{low:.2f}, {high:.2f}] | {ref:.2f} [{ref_low:.2f}, {ref_high:.2f}] | "
        f"{'yes' if entry['inside'] else 'NO'} | {'yes' if entry['overlap'] else 'NO'} |"
    )


def pipeline_settings(config: dict) -> dict:
    """The settings rule multifidelity passes to the correction and the extrapolation (rules/common.smk)."""
    hazard = config["hazard"]
    return config["montecarlo"]["fidelity"] | {
        "confidence": hazard["confidence"],
        "exceedance_probabilities": hazard["exceedance_probabilities"],
        "thresholds": hazard["zoning_thresholds"],
        "resolution_m": hazard["zoning_resolution_m"],
        "domain": config["domain"],
        "coarse_cell_size_m": config["mesh"]["cell_size_m"],
    }


def run_tables(run_json: Path, case: str) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame] | None:
    """The run's cheap route and its pairs at the accurate and coarse meshes (results/mc/<case>/ beside its report
    folder), or None if they are absent."""
    folder = run_json.parents[2] / "mc" / case
    paths = [folder / name for name in ("control.csv", "paired.csv", "paired_coarse.csv")]
    if not all(path.exists() for path in paths):
        return None
    low, high, coarse = (pd.read_csv(path) for path in paths)
    return low.sort_values("index"), high, coarse


def matched_chain(tables: tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame], cost: dict, n: int) -> dict:
    """The run's own chain on its first n realizations only, the reference's, as rule multifidelity estimates
    with the default config: an estimate of the same population the reference describes."""
    low, high, coarse = (table[table["index"] < n] for table in tables)
    settings = pipeline_settings(load_config(REPO / "config" / "config.yaml"))
    return mesh_extrapolation.converged(low, high, coarse, settings, correct(low, high, settings, cost))


def subset_sampling(cheap_runout: np.ndarray, n: int, distances: dict) -> str:
    """Sentences: the run's own cheap route over the reference's n realizations (its first), over its first 2n
    and 4n, and over all of them, the same distances: how many realizations a reference needs to share the
    run's tail."""
    total = len(cheap_runout)
    prefixes = [k for k in (n, 2 * n, 4 * n) if k < total]

    def over(p: str) -> str:
        values = [f"{float(exceeded_with(float(p))(cheap_runout[:k], axis=-1)):.2f} m" for k in (*prefixes, total)]
        return f"with P {p} " + ", ".join(values)

    return (
        " The run's own cheap route shows that sampling alone: over its first "
        + ", ".join(str(k) for k in prefixes)
        + f" and all {total} realizations it gives a runout exceeded "
        + "; ".join(over(p) for p in distances)
        + "."
    )


def headline_source(run_json: Path) -> str:
    """Which run a headline comes from: its multifidelity.json within the run's checkout, and that checkout's
    commit (a fresh clone's, as benchmarks/fresh_run.py keeps one)."""
    checkout = run_json.resolve().parents[3]
    done = subprocess.run(["git", "-C", str(checkout), "log", "-1", "--format=%h"], capture_output=True, text=True)
    made = f"a clone at {done.stdout.strip()}" if done.returncode == 0 else f"`{checkout}`, no git checkout"
    return f"`{run_json.resolve().relative_to(checkout)}` of a default run in {made}"


def against_run(
    case: str, cells: list[float], run_json: Path, confidence: float = 0.95
) -> tuple[list[str], list[dict]]:
    """The default run's headline (``run_json``: its multifidelity.json) against the direct reference on the
    realizations run at 0.25 m, and the cost of plain Monte Carlo at 0.25 m for the headline's error: the
    report's lines, and the comparisons (:func:`comparison`) for the result file."""
    run = json.loads(run_json.read_text())
    converged = run["converged"]
    order = converged["order"]["runout_m"]
    indices, values, _ = saved(case, cells)
    lines = [
        f"## {case}: the default run's headline against the direct reference",
        "",
        f"Reference: the {len(indices)} realizations run at 0.25 m (above), plus the Richardson step from "
        f"0.5 to 0.25 m at the runout order the run used, {order[1]:g} [{order[0]:g}, {order[2]:g}]; its interval "
        f"is the envelope of the {confidence:.0%} bootstrap intervals at the order's value and ends. Headline: "
        f"{headline_source(run_json)}.",
        "",
        "| quantity | headline (best estimate) [interval] | direct reference [interval] | reference inside "
        "the headline's interval | intervals overlap |",
        "|---|---|---|---|---|",
    ]
    # a distance the reference can estimate: at least MIN_BEYOND of its realizations exceed it (P 0.01 of 32 does not)
    distances = {
        p: entry
        for p, entry in converged["distances"].get("runout_m", {}).items()
        if float(p) * len(indices) >= MIN_BEYOND
    }
    tables = run_tables(run_json, case)
    among = 0 if tables is None else int((tables[1]["index"] < len(indices)).sum())
    # the run's chain on the reference's realizations needs the run's pairs among them: the first pairs of a
    # simple random draw of the first realizations were; pairs drawn in strata over all N mostly are not
    matched = matched_chain(tables, run["cost"], len(indices)) if tables is not None and among >= 8 else None
    reducers = {None: np.mean} | {p: exceeded_with(float(p)) for p in distances}  # None: the mean
    references = {p: reference(values["runout_m"], order, reduce) for p, reduce in reducers.items()}
    compared: list[dict] = []
    for record, suffix in ((converged, ""), (matched, f" — the run's chain on the reference's {len(indices)}")):
        if record is None:
            continue
        for p, ref in references.items():
            headline = record["means"]["runout_m"] if p is None else record["distances"]["runout_m"][p]
            if None in (headline["estimate"], headline["lower"], headline["upper"]):
                continue  # a tail the run's realizations do not bound
            name = ("mean runout R" if p is None else f"R exceeded with P {p}") + suffix
            compared.append(comparison(name, headline["estimate"], (headline["lower"], headline["upper"]), ref))
    runout = converged["means"]["runout_m"]
    compared.append(
        comparison(
            "mesh step of the mean runout (converged − 0.5 m; headline: over the order's interval)",
            runout["mesh_step"],
            tuple(runout["mesh_step_range"]),
            reference(values["runout_m"], order, step=True),
        )
    )
    for p, entry in distances.items():
        if "mesh_step_interval" in entry:
            compared.append(
                comparison(
                    f"mesh step of R exceeded with P {p} (headline: the step's bootstrap over the order's interval)",
                    entry["mesh_step"],
                    tuple(entry["mesh_step_interval"]),
                    reference(values["runout_m"], order, exceeded_with(float(p)), step=True),
                )
            )
    lines += [comparison_row(entry) for entry in compared]
    tails = [
        f"with P {p} {float(exceeded_with(float(p))(values['runout_m'][1], axis=-1)):.2f} m against the run's "
        f"{entry['accurate']:.2f} m"
        for p, entry in distances.items()
        if entry["accurate"] is not None
    ]
    lines += [
        "",
        f"The reference's realizations are {len(indices)} of the run's {run['n_low']} (its first ones), so an absolute "
        f"quantity also differs by their sampling: at 0.5 m their mean runout is {values['runout_m'][1].mean():.2f} m "
        f"against the run's corrected {run['means']['runout_m']['estimate']:.2f} m over {run['n_low']}"
        + "".join(f", the runout exceeded {tail}" for tail in tails)
        + "."
        + ("" if tables is None else subset_sampling(tables[0]["runout_m"].to_numpy(float), len(indices), distances))
        + " The mesh-step rows compare what the chain "
        "adds, the step from the 0.5 m mesh to the converged one, without that sampling"
        + (
            f"; the rows of the run's chain on the reference's {len(indices)} are the run's own estimator (its cheap "
            "route, and its pairs at 0.5 and 1 m among them) on those realizations alone: the population the "
            "reference describes."
            if matched is not None
            else f"; the run's own chain on those {len(indices)} alone is not given: {among} of its pairs are among "
            "them (its pairs are drawn in strata over all its realizations)."
            if tables is not None
            else "."
        ),
    ]
    half_width = (runout["upper"] - runout["lower"]) / 2.0
    ran_on = devices(case, cells, indices)
    if ran_on != {"cpu"}:
        return lines + [
            "",
            f"These runs ran on {', '.join(sorted(ran_on))} in batches: their times are no one-core cost; the cost "
            "comparison is that of the CPU runs (`mesh_levels.md`).",
            "",
        ], compared
    z = stats.norm.ppf(0.5 + confidence / 2.0)
    n_plain = int(np.ceil((z * values["runout_m"][2].std(ddof=1) / half_width) ** 2))
    cost = cost_seconds(case, cells)
    plain_s = n_plain * cost[0.25]
    pace = cost[0.5] / run["cost"]["high_s"]  # the cost runs' machine against the run's, on the same 0.5 m kernels
    cheap_s = run["cost"]["low_s"] * pace
    chain_s = run["n_low"] * cheap_s + converged["n_pairs"] * (cost[0.5] + cost[1.0])
    lines += [
        "",
        f"Cost at the headline's error (mean R, half-width {half_width:.2f} m): plain Monte Carlo at 0.25 m "
        f"needs {n_plain} realizations (the 0.25 m runs' std {values['runout_m'][2].std(ddof=1):.2f} m) × "
        f"{cost[0.25]:.1f} s = {plain_s / 60:.1f} min of one core; the chain {run['n_low']} cheap × "
        f"{cheap_s:.4f} s + {converged['n_pairs']} pairs × ({cost[0.5]:.1f} + {cost[1.0]:.1f}) s "
        f"= {chain_s / 60:.1f} min: **{plain_s / chain_s:.1f}× {'cheaper' if plain_s >= chain_s else 'dearer'}** "
        f"(one-thread MPM seconds per realization from the compiled kernels' runs, `{COST_RUNS.relative_to(REPO)}`; "
        f"the cheap route's from the run, {run['cost']['low_s']:.4f} s on a machine whose 0.5 m MPM took "
        f"{run['cost']['high_s']:.1f} s, scaled by the two 0.5 m times). Plain 0.25 m Monte Carlo would still carry the "
        "0.25 m mesh's own error, which the chain extrapolates away.",
        "",
    ]
    return lines, compared


def main() -> None:
    global RUNS
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--run", action="store_true", help="run what is missing before the report")
    parser.add_argument("--cases", nargs="+", default=["case1", "case3"])
    parser.add_argument("--cells", nargs="+", type=float, default=[1.0, 0.5, 0.25])
    parser.add_argument("--realizations", type=int, default=8, help="run realizations first … this - 1")
    parser.add_argument(
        "--against",
        type=Path,
        help="a default run's results/report/case1/multifidelity.json: "
        "its headline against the direct reference of the first case",
    )
    parser.add_argument("--first", type=int, default=0, help="the first realization to run (split across processes)")
    parser.add_argument("--batch", type=int, default=1, help="realizations per MPM batch (each at its own time step)")
    parser.add_argument("--device", default="cpu", help="the embedded MPM's torch device (cuda: a GPU)")
    parser.add_argument(
        "--runs", type=Path, default=RUNS, help="the store (a JSON-lines file) the runs are appended to and read from"
    )
    parser.add_argument("--no-report", action="store_true", help="run only (a worker among several)")
    parser.add_argument(
        "--seed", type=int, help="draw the realizations from this top-level seed (default: the config's)"
    )
    parser.add_argument(
        "--held-out-family",
        help="add config/pretrain_general.yaml's held-out family of this name as a case (case 1's field) to run",
    )
    parser.add_argument("--keep-ends", type=Path, help="a folder to keep each run's first and last positions in")
    parser.add_argument(
        "--resolved-config",
        type=Path,
        help="the default config already validated, as JSON (a machine without Snakemake)",
    )
    args = parser.parse_args()
    if args.runs.suffix != ".jsonl":  # a folder of one file per run, as before the store: not read
        parser.error(f"--runs {args.runs}: the runs' store is one JSON-lines file, <name>_runs.jsonl")
    RUNS = args.runs.resolve()
    if args.run:
        torch.set_num_threads(1)
        config = (
            json.loads(args.resolved_config.read_text())
            if args.resolved_config
            else load_config(REPO / "config" / "config.yaml")
        )
        config["mpm"]["embedded"]["device"] = args.device
        if args.seed is not None:
            config["seed"] = args.seed
        if args.held_out_family:
            add_held_out_family(config, args.held_out_family)
        run(config, args.cases, args.cells, args.realizations, args.first, args.batch, args.keep_ends)
    if not args.no_report:
        report(args.cases, args.cells, args.against)


if __name__ == "__main__":
    main()
