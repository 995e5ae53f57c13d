"""Mesh convergence of the embedded MPM, both shape functions, on the same realizations.

    python benchmarks/convergence.py                  # every part (hours on one core)
    python benchmarks/convergence.py --part slopes --shapes bspline   # one part, one shape
    python benchmarks/convergence.py --report         # tables and plot from the saved parts

Parts (each saved to ``benchmarks/results/convergence/<part>-<shape>.json``, so parts can run in
parallel processes and be re-run alone):

* ``slopes``: the default config's case-1 Monte Carlo realizations (drawn as rgns.montecarlo.runs
  draws them; the random field on a fixed 1 m grid, so every mesh samples the same field), 10 s,
  default engine settings, at cell sizes h = 2, 1, 0.5 m (all realizations) and 0.25 m (the first
  ``--fine-realizations``). R, V, I and the verdict failed (R > 0) / stood.
* ``column``: a granular column 4 m wide, 8 m high (aspect 2), uniform φ 30°, on the floor against
  the left wall, 6 s, at h = 1, 0.5, 0.25, 0.125 m: normalised runout R / width (R as measured
  everywhere, the runout percentile of the advance) and the farthest particle's (front − width) / width.
* ``diagnose``: why 40° slopes stand at 1 m cells: the uniform-φ long slope (φ 30° and 34°, Bishop
  FS < 1) with one setting changed at a time (points per cell, stiffness, Poisson's ratio, the K0
  start, the tension cutoff, the shape function, the cell size), and the depth of the slide.

The report takes, per shape and metric, the observed order of convergence from the three finest
levels (of the realization means over the realizations every level ran), the Richardson estimate
of the converged value f* = f₁ + (f₁ − f₂)/(2^p − 1), and each level's error against f*; where the
differences do not shrink there is no asymptotic range and the error is given against the finest
level only. Writes ``convergence.md`` and ``convergence.png`` into benchmarks/results/.
"""

from __future__ import annotations

import argparse
import copy
import json
import platform
import subprocess
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402

from rgns.config import load_config  # noqa: E402
from rgns.engines.batch import simulate_mpm  # noqa: E402
from rgns.engines.metrics import MetricSettings  # noqa: E402
from rgns.engines.settings import MpmSettings  # noqa: E402
from rgns.montecarlo.runs import measure  # noqa: E402
from rgns.provenance import commit  # noqa: E402
from rgns.scene.geometry import Scene, seed_particles  # noqa: E402
from rgns.scene.realizations import CaseInputs, Realization, draw_realization  # noqa: E402
from rgns.trajectories import frame_count  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "benchmarks" / "results"
PARTS = OUT / "convergence"
METRICS = ("runout_m", "volume_m2", "influence_m")
SLOPE_CELLS = (2.0, 1.0, 0.5, 0.25)
COLUMN_CELLS = (1.0, 0.5, 0.25, 0.125)
LONG_SLOPE = np.array([[0.0, 0.0], [36.0, 0.0], [24.0, 10.0], [0.0, 10.0]])
COLUMN = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 8.0], [0.0, 8.0]])


def mpm_settings(config: dict, shape: str, **changes) -> MpmSettings:
    """The config's mpm section with the shape function and any other key changed."""
    mpm = copy.deepcopy(config["mpm"])
    mpm["embedded"]["shape_function"] = shape
    for key, value in changes.items():
        (mpm["embedded"] if key in mpm["embedded"] else mpm)[key] = value
    return MpmSettings.from_config(mpm)


def slope_inputs(config: dict, cell_size_m: float, particles_per_cell: int | None = None) -> CaseInputs:
    """Case-1 inputs at a cell size, the field on a fixed 1 m grid."""
    config = copy.deepcopy(config)
    config["mesh"]["cell_size_m"] = cell_size_m
    if particles_per_cell:
        config["mesh"]["particles_per_cell"] = particles_per_cell
    config["random_field"]["grid_spacing_m"] = 1.0
    return CaseInputs.from_config(config, "case1")


def uniform(
    vertices: np.ndarray,
    friction_deg: float,
    cell_size_m: float,
    length_m: float,
    height_m: float,
    particles_per_cell: int = 2,
    index: int = 0,
) -> Realization:
    """A realization of one polygon of uniform soil."""
    positions, volumes = seed_particles(vertices, cell_size_m, particles_per_cell)
    scene = Scene(
        "convergence",
        index,
        "polygon",
        vertices,
        positions,
        volumes,
        length_m,
        height_m,
        cell_size_m,
        particles_per_cell,
        0,
    )
    return Realization(index, scene, np.full(len(positions), friction_deg))


def simulate(
    config: dict, batch: list[Realization], mpm: MpmSettings, duration_s: float
) -> tuple[list[dict], float, list]:
    """Table rows of a batch run of the embedded engine, its wall time per realization, and the results."""
    frames = frame_count(duration_s, mpm.frame_interval_s)
    start = time.perf_counter()
    simulated = simulate_mpm(batch, mpm, frames, keep="ends")
    seconds = (time.perf_counter() - start) / len(batch)
    rows = [
        measure(
            r,
            s,
            MetricSettings(**config["metrics"]),
            mpm.density_kg_m3,
            mpm.frame_interval_s,
            mpm.gravity_m_s2,
        )
        for r, s in zip(batch, simulated)
    ]
    return rows, seconds, simulated


def saved(part: str, shape: str) -> dict:
    """What an earlier (perhaps interrupted) run of a part saved."""
    path = PARTS / f"{part}-{shape}.json"
    return json.loads(path.read_text()) if path.exists() else {}


def save(part: str, shape: str, record: dict) -> None:
    machine = f"{platform.processor() or platform.machine()}, torch {torch.__version__}"
    (PARTS / f"{part}-{shape}.json").write_text(json.dumps(record | {"machine": machine}, indent=1))


def slopes(config: dict, shape: str, n: int, n_fine: int) -> dict:
    """Every level, saved as it finishes; levels an earlier run saved are kept."""
    levels = saved("slopes", shape).get("levels", {})
    for h in SLOPE_CELLS:
        count = n if h >= 0.5 else n_fine
        if str(h) in levels and len(levels[str(h)]["rows"]) == count:
            continue
        batch = [draw_realization(slope_inputs(config, h), i) for i in range(count)]
        rows, seconds, _ = simulate(config, batch, mpm_settings(config, shape), 10.0)
        levels[str(h)] = {"rows": rows, "s_per_realization": seconds, "particles": len(batch[0].scene.positions)}
        save("slopes", shape, {"levels": levels})
        print(
            f"slopes {shape} h {h}: {seconds:.1f} s per realization; R {[round(r.get('runout_m', -1), 2) for r in rows]}",
            flush=True,
        )
    return levels


def column(config: dict, shape: str) -> dict:
    levels = {}
    for h in COLUMN_CELLS:
        batch = [uniform(COLUMN, 30.0, h, 30.0, 10.0)]
        mpm = mpm_settings(config, shape, floor_friction=float(np.tan(np.radians(30.0))))
        rows, seconds, simulated = simulate(config, batch, mpm, 6.0)
        front = float(simulated[0].positions[-1][:, 0].max())
        levels[str(h)] = {
            "runout_ratio": rows[0].get("runout_m", float("nan")) / 4.0,
            "front_ratio": (front - 4.0) / 4.0,
            "status": rows[0]["status"],
            "s_per_realization": seconds,
            "lowest_y_m": float(simulated[0].positions[-1][:, 1].min()),
        }
        print(f"column {shape} h {h}: {levels[str(h)]}", flush=True)
    return levels


def slide_depth(realization: Realization, final: np.ndarray, threshold_m: float = 0.5) -> float:
    """Deepest start of a particle that moved more than ``threshold_m``, below the slope's surface (m)."""
    start = realization.scene.positions
    moved = np.linalg.norm(final - start, axis=1) > threshold_m
    if not moved.any():
        return 0.0
    surface = np.interp(start[moved, 0], [0.0, 24.0, 36.0], [10.0, 10.0, 0.0])
    return float((surface - start[moved, 1]).max())


DIAGNOSE = {  # name: (shape, cell size, points per cell per direction, changed mpm keys)
    "linear, 1 m, 2x2 points (old default)": ("linear", 1.0, 2, {}),
    "linear, 1 m, 1x1 point": ("linear", 1.0, 1, {}),
    "linear, 1 m, 4x4 points": ("linear", 1.0, 4, {}),
    "linear, 1 m, nu 0.45": ("linear", 1.0, 2, {"poisson_ratio": 0.45}),
    "linear, 1 m, E 100 MPa": ("linear", 1.0, 2, {"youngs_modulus_pa": 1e8}),
    "linear, 1 m, E 1 MPa": ("linear", 1.0, 2, {"youngs_modulus_pa": 1e6}),
    "linear, 1 m, no K0 start": ("linear", 1.0, 2, {"geostatic_stress": False}),
    "linear, 1 m, tension cutoff 10 kPa": ("linear", 1.0, 2, {"tension_cutoff_pa": 1e4}),
    "linear, 0.5 m": ("linear", 0.5, 2, {}),
    "bspline, 1 m, 2x2 points": ("bspline", 1.0, 2, {}),
    "bspline, 1 m, 4x4 points": ("bspline", 1.0, 4, {}),
    "bspline, 0.5 m": ("bspline", 0.5, 2, {}),
}


def diagnose(config: dict, shape: str) -> dict:
    out = {}
    for name, (route_shape, h, ppc, changes) in DIAGNOSE.items():
        if route_shape != shape:
            continue
        batch = [uniform(LONG_SLOPE, phi, h, 80.0, 20.0, ppc, k) for k, phi in enumerate((30.0, 34.0))]
        rows, seconds, simulated = simulate(config, batch, mpm_settings(config, route_shape, **changes), 10.0)
        depths = [slide_depth(r, s.positions[-1]) for r, s in zip(batch, simulated)]
        out[name] = {"rows": rows, "slide_depth_m": depths, "s_per_realization": seconds}
        print(
            f"diagnose {name}: R {[round(r.get('runout_m', -1), 2) for r in rows]} "
            f"V {[round(r.get('volume_m2', -1), 1) for r in rows]} depth {depths} ({seconds:.1f} s)",
            flush=True,
        )
    return out


# ---------------------------------------------------------------------------------------------- report


def observed(values: list[float]) -> dict:
    """Order, Richardson value and each level's error from values at h, h/2, h/4, … (coarse first).

    Asymptotic (Richardson applies) when successive differences keep their sign and shrink at an
    order of 0.5 to 3; otherwise the finest value stands in for the converged one."""
    f3, f2, f1 = values[-3:]
    d_coarse, d_fine = f2 - f3, f1 - f2
    order = float(np.log(abs(d_coarse / d_fine)) / np.log(2)) if d_fine and d_coarse else float("nan")
    asymptotic = bool(0.5 <= order <= 3 and np.sign(d_coarse) == np.sign(d_fine))
    converged = f1 + d_fine / (2**order - 1) if asymptotic else f1
    return {
        "order": order,
        "asymptotic": asymptotic,
        "converged": float(converged),
        "errors": [float(v - converged) for v in values],
    }


def finished(rows: list[dict]) -> set[int]:
    return {k for k, row in enumerate(rows) if row["status"] == "ok"}


def difference(rows: list[dict], reference: list[dict], key: str) -> tuple[float, int]:
    """Mean absolute difference of a metric over the realizations both finished, and how many."""
    both = sorted(finished(rows) & finished(reference))
    return (float(np.mean([abs(rows[k][key] - reference[k][key]) for k in both])) if both else float("nan")), len(both)


def slope_section(parts: dict, axes) -> tuple[list[str], dict, dict]:
    """Both shapes' levels against the B-spline references (the table's numbers, per shape and h), orders and
    Richardson values, the plot."""
    shapes = [s for s in ("linear", "bspline") if f"slopes-{s}" in parts]
    reference_levels = parts["slopes-bspline"]["levels"]
    references = [h for h in ("0.5", "0.25") if h in reference_levels]
    spread = {
        key: float(np.ptp([row[key] for row in reference_levels["0.5"]["rows"] if row["status"] == "ok"]))
        for key in METRICS
    }
    lines = [
        "## Slopes: the default config's case-1 realizations (10 s)",
        "",
        "Means over every realization a level finished; differences: mean |Δ| per realization against the "
        "B-spline answer at 0.5 m (all realizations) and at 0.25 m (the subset), with % of the range of "
        f"the 0.5 m B-spline answers over the realizations (R {spread['runout_m']:.2f} m, V "
        f"{spread['volume_m2']:.1f} m², I {spread['influence_m']:.2f} m).",
        "",
        "| shape | h (m) | s per realization | failed (R > 0) | R (m) | V (m²) | I (m) | "
        + " | ".join(f"\\|ΔR\\|, \\|ΔV\\|, \\|ΔI\\| vs B-spline {h} m" for h in references)
        + " |",
        "|---|---|---:|---:|---:|---:|---:|" + "---|" * len(references),
    ]
    fits: dict = {}
    table: dict = {"range": spread, "shapes": {}}
    for shape in shapes:
        levels = parts[f"slopes-{shape}"]["levels"]
        cells = [h for h in SLOPE_CELLS if str(h) in levels]
        table["shapes"][shape] = {}
        for h in cells:
            rows = levels[str(h)]["rows"]
            ok = sorted(finished(rows))
            failed = sum(row.get("runout_m", 0.0) > 0 for row in rows if row["status"] == "ok")
            diverged = len(rows) - len(ok)
            means = [float(np.mean([rows[k][key] for k in ok])) for key in METRICS]
            cols = []
            against: dict = {}
            for ref in references:
                parts_ = []
                against[ref] = {}
                for key in METRICS:
                    value, n = difference(rows, reference_levels[ref]["rows"], key)
                    against[ref][key] = {"mean_abs": value, "share_of_range": value / spread[key], "n": n}
                    parts_.append(f"{value:.2f} ({100 * value / spread[key]:.0f} %)")
                cols.append(", ".join(parts_) + f" [n {n}]")
            table["shapes"][shape][f"{h:g}"] = {
                "s_per_realization": levels[str(h)]["s_per_realization"],
                "finished": len(ok),
                "failed": failed,
                "diverged": diverged,
                "means": dict(zip(METRICS, means)),
                "against_bspline": against,
            }
            status = f"{failed} of {len(ok)}" + (f" (+{diverged} diverged)" if diverged else "")
            lines.append(
                f"| {shape} | {h:g} | {levels[str(h)]['s_per_realization']:.1f} | {status} | {means[0]:.2f} | "
                f"{means[1]:.1f} | {means[2]:.2f} | " + " | ".join(cols) + " |"
            )
        common = sorted(set.intersection(*(finished(levels[str(h)]["rows"]) for h in cells)))
        series = {
            key: [float(np.mean([levels[str(h)]["rows"][k][key] for k in common])) for h in cells] for key in METRICS
        }
        fits[shape] = {
            key: observed(series[key]) | {"series": series[key], "cells": cells, "realizations": common}
            for key in METRICS
        }
        for ax, key in zip(axes[:3], METRICS):
            ax.plot(cells, series[key], "o-", label=f"{shape} (realizations {common})")
            ax.set_xscale("log", base=2)
            ax.set_xlabel("cell size h (m)")
            ax.set_title(f"case 1: mean {key}")
    lines += [
        "",
        "Observed order p from the three finest levels, on the means over the realizations every "
        "level finished, and the Richardson value f* (p in 0.5–3 and differences of one sign; otherwise "
        "no asymptotic range, and f* is the finest value):",
        "",
    ]
    for shape, fit in fits.items():
        text = "; ".join(
            f"{key.split('_')[0]}: "
            + " → ".join(f"{v:.2f}" for v in fit[key]["series"])
            + f", p = {fit[key]['order']:.2f}"
            + (f", f* = {fit[key]['converged']:.2f}" if fit[key]["asymptotic"] else " (no asymptotic range)")
            for key in METRICS
        )
        lines.append(
            f"* {shape} (h = {', '.join(f'{h:g}' for h in fit['runout_m']['cells'])} m, realizations "
            f"{fit['runout_m']['realizations']}): {text}"
        )
    return lines + [""], fits, table


def column_section(parts: dict, ax) -> list[str]:
    shapes = [s for s in ("linear", "bspline") if f"column-{s}" in parts]
    lines = [
        "## Column collapse (4 m × 8 m, aspect 2, φ 30°, 6 s)",
        "",
        "Runout R as every metric here measures it (the config's runout percentile of the particles' "
        "advance past the toe) and the front (the farthest particle), over the width; the lowest particle "
        "at the end (the floor is y = 0).",
        "",
        "| h (m) | " + " | ".join(f"{s}: R / width, front / width, s, lowest y (m)" for s in shapes) + " |",
        "|---|" + "---|" * len(shapes),
    ]
    for h in COLUMN_CELLS:
        cells = []
        for s in shapes:
            level = parts[f"column-{s}"]["levels"][str(h)]
            status = "" if level["status"] == "ok" else f" ({level['status']})"
            cells.append(
                f"{level['runout_ratio']:.3f}, {level['front_ratio']:.3f}, {level['s_per_realization']:.1f}, "
                f"{level['lowest_y_m']:.4f}{status}"
            )
        lines.append(f"| {h:g} | " + " | ".join(cells) + " |")
    lines.append("")
    for s in shapes:
        levels = parts[f"column-{s}"]["levels"]
        cells = [h for h in COLUMN_CELLS if levels[str(h)]["status"] == "ok"]
        values = [levels[str(h)]["runout_ratio"] for h in cells]
        fit = observed(values)
        lines.append(
            f"* {s} (h = {', '.join(f'{h:g}' for h in cells)} m): observed order {fit['order']:.2f}"
            + (f", f* = {fit['converged']:.3f}" if fit["asymptotic"] else " (no asymptotic range)")
        )
        ax.plot(cells, values, "o-", label=s)
    ax.set_xscale("log", base=2)
    ax.set_xlabel("cell size h (m)")
    ax.set_title("column, aspect 2: runout / width")
    return lines + [""]


def diagnose_section(parts: dict) -> list[str]:
    lines = [
        "## Why 40° slopes stand at 1 m cells (uniform φ, the long slope, 10 s; Bishop FS < 1 for both)",
        "",
        "| route | φ 30°: R / V / I | φ 34°: R / V / I | slide depth φ 30 / 34 (m) | s per run |",
        "|---|---|---|---|---:|",
    ]
    for shape in ("linear", "bspline"):
        for name, record in parts.get(f"diagnose-{shape}", {}).get("routes", {}).items():
            cells = [
                f"{r.get('runout_m', float('nan')):.1f} / {r.get('volume_m2', float('nan')):.1f} / "
                f"{r.get('influence_m', float('nan')):.2f}"
                for r in record["rows"]
            ]
            depth = " / ".join(f"{d:.1f}" for d in record["slide_depth_m"])
            lines.append(f"| {name} | {cells[0]} | {cells[1]} | {depth} | {record['s_per_realization']:.1f} |")
    return lines + [
        "",
        "Slide depth: the deepest starting point, below the slope surface, of a particle that moved more than 0.5 m.",
        "",
    ]


def column_record(parts: dict) -> dict:
    """Per shape: the column's runout over width at every h, each level's status, and the observed order and
    Richardson value over the levels that finished (docs/engine.md renders it)."""
    out = {}
    for s in ("linear", "bspline"):
        if f"column-{s}" not in parts:
            continue
        levels = parts[f"column-{s}"]["levels"]
        ok = [h for h in COLUMN_CELLS if levels[str(h)]["status"] == "ok"]
        out[s] = {
            "cells": list(COLUMN_CELLS),
            "runout_ratio": [levels[str(h)]["runout_ratio"] if h in ok else None for h in COLUMN_CELLS],
            "status": [levels[str(h)]["status"] for h in COLUMN_CELLS],
            "fit": observed([levels[str(h)]["runout_ratio"] for h in ok]),
        }
    return out


def diagnose_record(parts: dict) -> dict:
    """Per route of the locking diagnosis: the two slopes' (φ 30°, 34°) runouts, slide depths and seconds per run."""
    return {
        name: {
            "runout_m": [row.get("runout_m") for row in record["rows"]],
            "slide_depth_m": record["slide_depth_m"],
            "s_per_realization": record["s_per_realization"],
        }
        for shape in ("linear", "bspline")
        for name, record in parts.get(f"diagnose-{shape}", {}).get("routes", {}).items()
    }


def committed_in(path: Path) -> str:
    """The commit that last committed ``path``: when a saved part was measured (parts record no commit)."""
    done = subprocess.run(
        ["git", "-C", str(REPO), "log", "-1", "--format=%h", "--", str(path)], capture_output=True, text=True
    )
    return done.stdout.strip() or "not committed"


def report() -> None:
    parts = {path.stem: json.loads(path.read_text()) for path in sorted(PARTS.glob("*.json"))}
    fig, axes = plt.subplots(1, 4, figsize=(18, 4.2))
    lines = [
        "# Mesh convergence of the embedded MPM",
        "",
        "`python benchmarks/convergence.py` (parts and method: its docstring); times are wall seconds per "
        "realization on one CPU thread of a shared 2-core machine, with other processes running (compare "
        "them within a row of levels only).",
        "",
    ]
    fits: dict = {}
    table: dict = {}
    if "slopes-bspline" in parts:
        section, fits, table = slope_section(parts, axes)
        lines += section
    lines += column_section(parts, axes[3])
    lines += diagnose_section(parts)
    for ax in axes:
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(OUT / "convergence.png", dpi=130)
    plt.close(fig)
    machine = next(iter(parts.values()))["machine"] if parts else ""
    lines += [f"Machine: {machine}."]
    (OUT / "convergence.md").write_text("\n".join(lines) + "\n")
    record = {
        "command": "python benchmarks/convergence.py --report",
        "commit": commit(),
        "parts_committed_in": {name: committed_in(PARTS / f"{name}.json") for name in parts},
        "slopes": table,
        "orders": fits,
        "column": column_record(parts),
        "diagnose": diagnose_record(parts),
    }
    (OUT / "convergence.json").write_text(json.dumps(record, indent=1))
    print("\n".join(lines))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--part", choices=["slopes", "column", "diagnose", "all"], default="all")
    parser.add_argument("--shapes", nargs="+", default=["linear", "bspline"], choices=["linear", "bspline"])
    parser.add_argument("--realizations", type=int, default=8)
    parser.add_argument("--fine-realizations", type=int, default=4, help="how many also run at 0.25 m")
    parser.add_argument("--report", action="store_true", help="only write the tables and plot from saved parts")
    args = parser.parse_args()
    if not args.report:
        torch.set_num_threads(1)
        config = load_config(REPO / "config" / "config.yaml")
        PARTS.mkdir(parents=True, exist_ok=True)
        for part in ["slopes", "column", "diagnose"] if args.part == "all" else [args.part]:
            for shape in args.shapes:
                if part == "slopes":
                    record = {"levels": slopes(config, shape, args.realizations, args.fine_realizations)}
                elif part == "column":
                    record = {"levels": column(config, shape)}
                else:
                    record = {"routes": diagnose(config, shape)}
                save(part, shape, record)
    report()


if __name__ == "__main__":
    main()
