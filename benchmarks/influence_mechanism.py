"""What moves the influence distance I under mesh refinement: I at several displacement thresholds, and pictures.

    python benchmarks/mesh_levels.py --run --no-report --cases case1 --cells 1 0.5 0.25 0.125 --seed 65001 \
        --realizations 16 --runs benchmarks/results/mesh_levels_independent_runs.jsonl --keep-ends <ends>
    python benchmarks/influence_mechanism.py --ends <ends>

I is the distance from the crest back to the rear-most point displaced by at least 1 m
(``rgns.engines.metrics.influence_distance``). From each run's first and last positions (kept by
``mesh_levels.py --keep-ends``) this measures I again at thresholds of 0.5, 1, 2 and 4 m, per mesh, with 95 %
percentile bootstrap intervals of the means over the realizations every mesh ran (scipy.stats.bootstrap, paired).
Where I at 1 m grows with refinement and I at 2 and 4 m does not, the ground behind the scarp creeps a little
further past 1 m on a finer mesh: the threshold, not the failure, moves. Where I grows at every threshold, the
failure itself reaches further back (a retrogressive slide the finer mesh resolves). The realizations whose I
changes most between the two finest meshes are drawn: each point at its initial position, coloured by how far it
moved, with the crest and the rear-most point moved 1 m marked. Writes
``benchmarks/results/influence_mechanism.{md,json,png}`` (``influence_mechanism_<case>.*`` for another ``--case``).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from functools import partial
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mesh_levels import OUT, load_runs, paired_bootstrap, richardson  # noqa: E402

from rgns.engines.metrics import influence_distance  # noqa: E402
from rgns.provenance import commit  # noqa: E402

THRESHOLDS_M = (0.5, 1.0, 2.0, 4.0)


def ends(folder: Path, case: str, cell: float, index: int) -> tuple[np.ndarray, np.ndarray]:
    """A run's first and last particle positions, as mesh_levels.py kept them."""
    with np.load(folder / f"{case}_{cell:g}_{index}.npz") as data:
        return data["initial"].astype(float), data["final"].astype(float)


def influence_table(
    folder: Path, runs: dict, case: str, cells: list[float], indices: list[int]
) -> tuple[np.ndarray, np.ndarray]:
    """I [threshold, cell, realization] at each of THRESHOLDS_M, and the crest x per realization."""
    crests = np.array([runs[case, cells[0], i]["crest_x_m"] for i in indices])
    values = np.empty((len(THRESHOLDS_M), len(cells), len(indices)))
    for c, cell in enumerate(cells):
        for k, index in enumerate(indices):
            initial, final = ends(folder, case, cell, index)
            for t, threshold in enumerate(THRESHOLDS_M):
                values[t, c, k] = influence_distance(initial, final, crests[k], threshold)
    return values, crests


def strays(initial: np.ndarray, final: np.ndarray, crest: float, spacing: float) -> dict:
    """The points moved 1 m that lie more than a point spacing behind the scarp of the points moved 2 m: how many,
    how many started in the top two rows of the ground behind the crest, their mean vertical movement; and the
    point that sets I (the rear-most moved 1 m): whether it started in those rows, and how it moved."""
    moved = np.linalg.norm(final - initial, axis=1)
    scarp = crest - influence_distance(initial, final, crest, 2.0)
    behind = (moved >= 1.0) & (initial[:, 0] < scarp - spacing)
    top = initial[:, 1] > initial[initial[:, 0] < crest, 1].max() - 2.0 * spacing
    rise = float((final - initial)[behind, 1].mean()) if behind.any() else 0.0
    candidates = np.flatnonzero(moved >= 1.0)
    setter = int(candidates[np.argmin(initial[candidates, 0])]) if candidates.size else -1
    return {
        "count": int(behind.sum()),
        "top_rows": int((behind & top).sum()),
        "mean_rise_m": rise,
        "setter_top_row": bool(setter >= 0 and top[setter]),
        "setter_move_m": (final[setter] - initial[setter]).tolist() if setter >= 0 else [0.0, 0.0],
    }


def mean_intervals(levels: np.ndarray, seed: int = 0) -> dict:
    """The means over realizations of I at each cell size [cells, n], the last two levels' difference and the
    observed order of the three finest, each with its paired percentile bootstrap interval."""

    def statistic(*columns: np.ndarray, axis: int = -1) -> np.ndarray:
        means = np.stack([c.mean(axis=axis) for c in columns], axis=-1)  # [..., cells]
        order, _ = richardson(means[..., -3:])
        fine = means[..., -1] - means[..., -2]
        return np.concatenate([np.moveaxis(means, -1, 0), fine[None], order[None]], axis=0)

    point, low, high = paired_bootstrap(tuple(levels), statistic, seed)
    return {
        "means": [[float(p), float(lo), float(hi)] for p, lo, hi in zip(point[:-2], low[:-2], high[:-2])],
        "last_step": [float(point[-2]), float(low[-2]), float(high[-2])],
        "order_finest": [float(point[-1]), float(low[-1]), float(high[-1])],
    }


def draw(
    positions: Callable[[float, int], tuple[np.ndarray, np.ndarray]],
    cells: list[float],
    picked: list[int],
    crests: dict[int, float],
    path: Path,
) -> None:
    """One row per picked realization, one panel per mesh: initial points coloured by displacement (m);
    ``positions(cell, index)``: a run's first and last positions."""
    fig, axes = plt.subplots(len(picked), len(cells), figsize=(3.6 * len(cells), 2.4 * len(picked)), squeeze=False)
    for row, index in enumerate(picked):
        for col, cell in enumerate(cells):
            ax = axes[row, col]
            initial, final = positions(cell, index)
            moved = np.linalg.norm(final - initial, axis=1)
            shown = ax.scatter(
                initial[:, 0], initial[:, 1], c=np.clip(moved, 0.0, 4.0), s=0.6, cmap="viridis", vmin=0.0, vmax=4.0
            )
            crest = crests[index]
            ax.axvline(crest, color="k", ls="--", lw=0.8)
            reach = influence_distance(initial, final, crest, 1.0)
            ax.axvline(crest - reach, color="r", lw=0.8)
            ax.set_xlim(0.0, 40.0)
            ax.set_ylim(0.0, 11.0)
            ax.set_aspect("equal")
            ax.set_title(f"realization {index}, h {cell:g} m: I {reach:.2f} m", fontsize=8)
            ax.tick_params(labelsize=6)
    fig.colorbar(shown, ax=axes, shrink=0.6, label="displacement (m, clipped at 4)")
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--ends", type=Path, required=True, help="the folder mesh_levels.py --keep-ends wrote")
    parser.add_argument("--runs", type=Path, default=OUT / "mesh_levels_independent_runs.jsonl")
    parser.add_argument("--case", default="case1")
    parser.add_argument("--cells", nargs="+", type=float, default=[1.0, 0.5, 0.25, 0.125])
    parser.add_argument("--pictures", type=int, default=3, help="realizations drawn: the largest last-step I change")
    args = parser.parse_args()
    runs = load_runs(args.runs)
    found = [
        {i for c, h, i in runs if c == args.case and h == cell and (args.ends / f"{c}_{h:g}_{i}.npz").exists()}
        for cell in args.cells
    ]
    indices = sorted(set.intersection(*found))
    if len(indices) < 2:
        parser.error(f"{len(indices)} realizations ran at every one of {args.cells} with their ends kept")
    values, crests = influence_table(args.ends, runs, args.case, args.cells, indices)
    stray = {
        (cell, index): strays(*ends(args.ends, args.case, cell, index), crest, cell / 2.0)
        for cell in args.cells
        for index, crest in zip(indices, crests)
    }
    seed = {runs[args.case, args.cells[0], i].get("seed") for i in indices}
    fits = {f"{t:g}": mean_intervals(values[k]) for k, t in enumerate(THRESHOLDS_M)}
    jump = values[THRESHOLDS_M.index(1.0), -1] - values[THRESHOLDS_M.index(1.0), -2]
    picked = [indices[k] for k in np.argsort(-np.abs(jump))[: args.pictures]]
    other_case = args.case != "case1"
    name = "influence_mechanism" + (f"_{args.case}" if other_case else "")
    draw(partial(ends, args.ends, args.case), args.cells, picked, dict(zip(indices, crests)), OUT / f"{name}.png")
    command = f"python benchmarks/influence_mechanism.py --ends <ends> --runs {args.runs.name}"
    command += f" --case {args.case}" if other_case else ""
    sizes = " / ".join(f"{h:g}" for h in args.cells)

    def cell(entry: list[float]) -> str:
        return f"{entry[0]:.2f} [{entry[1]:.2f}, {entry[2]:.2f}]"

    lines = [
        f"# The influence distance under refinement, by displacement threshold ({args.case})",
        "",
        f"`{command}` at {commit()}; {len(indices)} realizations of seed {', '.join(map(str, sorted(seed)))} at "
        f"h = {sizes} m (method: its docstring). Means over the realizations with 95 % bootstrap intervals.",
        "",
        f"| threshold | mean I at h = {sizes} m | last step (h {args.cells[-2]:g} → {args.cells[-1]:g}) | "
        "order of the three finest |",
        "|---|---|---|---|",
    ]
    for t, fit in fits.items():
        means = " / ".join(cell(m) for m in fit["means"])
        lines.append(f"| {t} m | {means} | {cell(fit['last_step'])} | {cell(fit['order_finest'])} |")
    lines += [
        "",
        f"Per realization and mesh (h = {sizes} m): I at 1 m (I at 2 m); and the points moved 1 m more than a point "
        "spacing behind the 2 m scarp: how many, how many of them from the top two rows of the ground behind the "
        "crest, their mean vertical movement (m; + up); and how the point that sets I moved (dx, dy; T: from the top "
        "two rows).",
        "",
        "| realization | "
        + " | ".join(f"h {h:g}: I (I₂) · behind, top rows, rise · setter" for h in args.cells)
        + " |",
        "|---|" + "---|" * len(args.cells),
    ]
    ones, twos = values[THRESHOLDS_M.index(1.0)], values[THRESHOLDS_M.index(2.0)]
    for k, index in enumerate(indices):
        cells = []
        for c, cell in enumerate(args.cells):
            st = stray[cell, index]
            dx, dy = st["setter_move_m"]
            cells.append(
                f"{ones[c, k]:.2f} ({twos[c, k]:.2f}) · {st['count']}, {st['top_rows']}, {st['mean_rise_m']:+.2f} · "
                f"({dx:+.2f}, {dy:+.2f}){' T' if st['setter_top_row'] else ''}"
            )
        lines.append(f"| {index} | " + " | ".join(cells) + " |")
    lines += ["", f"Drawn (`{name}.png`): realizations {', '.join(map(str, picked))}.", ""]
    (OUT / f"{name}.md").write_text("\n".join(lines))
    record = {
        "command": command,
        "commit": commit(),
        "case": args.case,
        "cells": args.cells,
        "realizations": indices,
        "seed": sorted(seed),
        "thresholds_m": list(THRESHOLDS_M),
        "influence_m": values.tolist(),
        "strays": {f"{cell:g}_{index}": entry for (cell, index), entry in stray.items()},
        "fits": fits,
        "pictured": picked,
    }
    (OUT / f"{name}.json").write_text(json.dumps(record, indent=1) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
