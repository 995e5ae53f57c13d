"""docs/engine.md's and docs/benchmarks.md's passages on the embedded MPM's mesh convergence and locking."""

from __future__ import annotations

import re
from typing import Any

from evidence.formatting import bracketed, true_minus
from evidence.sources import result


def bench_convergence() -> str:
    """docs/benchmarks.md: the embedded MPM's mesh error on case-1 slopes, per shape function and cell size, against
    the B-spline answer at 0.5 m, and the observed orders."""
    record = result("convergence.json")
    parts = sorted(set(record["parts_committed_in"].values()))
    made = f"`convergence.json`, its parts measured at {', '.join(parts)}, tabled at {record['commit']}"
    command = "`python benchmarks/convergence.py`, then `--report`"
    spread = record["slopes"]["range"]
    units = {"runout_m": "m", "volume_m2": "m²", "influence_m": "m"}
    lines = [
        "| shape, cell size | mean \\|Δ\\| from the B-spline 0.5 m answer: R / V / I (% of its range) | failed "
        "(R > 0) | command | made at |",
        "|---|---|---|---|---|",
    ]
    for shape, levels in record["slopes"]["shapes"].items():
        for cell, level in levels.items():
            if cell == "0.5" and shape == "bspline":
                continue  # the reference itself
            against = level["against_bspline"]["0.5"]
            error = " / ".join(
                f"{against[key]['mean_abs']:.2f} {unit} ({100 * against[key]['share_of_range']:.0f} %)"
                for key, unit in units.items()
            )
            n = against["runout_m"]["n"]
            diverged = f", {level['diverged']} diverged" if level["diverged"] else ""
            lines.append(
                f"| {'B-spline' if shape == 'bspline' else 'bilinear'}, {cell} m | {error} on {n} | "
                f"{level['failed']} of {level['finished']}{diverged} | {command} | {made} |"
            )
    orders = record["orders"]["bspline"]
    fitted = [
        f"{key.split('_')[0]} p = {fit['order']:.2f}" + ("" if fit["asymptotic"] else " (no asymptotic range)")
        for key, fit in orders.items()
    ]
    lines += [
        "",
        f"Range of the B-spline 0.5 m answers: R {spread['runout_m']:.2f} m, V {spread['volume_m2']:.1f} m², "
        f"I {spread['influence_m']:.2f} m. Observed B-spline orders from h = "
        f"{', '.join(f'{h:g}' for h in orders['runout_m']['cells'][-3:])} m on realizations "
        f"{orders['runout_m']['realizations']}: {'; '.join(fitted)}.",
    ]
    return "\n".join(lines)


def convergence_table() -> str:
    """docs/engine.md: every shape and cell size of the mesh-convergence study, its means and differences from the
    B-spline answers at 0.5 m (every realization) and at 0.25 m (the subset run there)."""
    record = result("convergence.json")
    keys = ("runout_m", "volume_m2", "influence_m")
    digits = {"runout_m": 2, "volume_m2": 1, "influence_m": 2}
    shapes = record["slopes"]["shapes"]
    counts = {ref: shapes["bspline"]["1"]["against_bspline"][ref]["runout_m"]["n"] for ref in ("0.5", "0.25")}
    lines = [
        f"| shape | h (m) | failed | mean R / V / I | \\|ΔR\\|, \\|ΔV\\|, \\|ΔI\\| vs B-spline 0.5 m "
        f"({counts['0.5']}) | vs B-spline 0.25 m ({counts['0.25']}) |",
        "|---|---|---:|---|---|---|",
    ]
    for shape, levels in shapes.items():
        for cell, level in levels.items():
            name, h = (
                (f"**{shape}**", f"**{cell} (default)**" if cell == "1" else cell)
                if shape == "bspline"
                else (
                    shape,
                    cell,
                )
            )
            means = " / ".join(f"{level['means'][k]:.{digits[k]}f}" for k in keys)
            columns = []
            for ref in ("0.5", "0.25"):
                against = level["against_bspline"][ref]
                if shape == "bspline" and cell == ref:
                    columns.append("–")
                    continue
                shares = ref == "0.5" or (shape == "bspline" and cell == "1")
                text = ", ".join(
                    f"{against[k]['mean_abs']:.{digits[k]}f}"
                    + (f" ({100 * against[k]['share_of_range']:.0f} %)" if shares else "")
                    for k in keys
                )
                n = against["runout_m"]["n"]
                if n != counts[ref]:
                    text += f" ({n})"
                columns.append(f"**{text}**" if shape == "bspline" and cell == "1" else text)
            diverged = f", {level['diverged']} diverged" if level["diverged"] else ""
            lines.append(
                f"| {name} | {h} | {level['failed']} of {level['finished']}{diverged} | {means} | "
                + " | ".join(columns)
                + " |"
            )
    spread = record["slopes"]["range"]
    lines += [
        "",
        f"The ranges of the B-spline 0.5 m answers over the {counts['0.5']} realizations: R {spread['runout_m']:.2f} m, "
        f"V {spread['volume_m2']:.1f} m², I {spread['influence_m']:.2f} m (`benchmarks/results/convergence.json`).",
    ]
    return "\n".join(lines)


def convergence_orders() -> str:
    """docs/engine.md: per shape, the mean R, I and V of the realizations run at every cell size, their observed
    order and Richardson value where the differences keep their sign and shrink (convergence.json)."""
    orders = result("convergence.json")["orders"]
    units = {"runout_m": "m", "influence_m": "m", "volume_m2": "m²"}
    names = {"runout_m": "R", "influence_m": "I", "volume_m2": "V"}

    def series(entry: dict[str, Any], key: str) -> str:
        digits = 1 if key == "volume_m2" else 2
        values = " → ".join(f"{v:.{digits}f}" for v in entry["series"])
        if entry["asymptotic"]:
            how = f"observed order p = {entry['order']:.2f}, Richardson value f* = {entry['converged']:.{digits}f} {units[key]}"
        else:
            how = "no asymptotic range"
        return f"{names[key]} {values} {units[key]} ({how})"

    sentences = []
    for shape, label in (("bspline", "B-spline"), ("linear", "Bilinear")):
        entries = orders[shape]
        cells = " / ".join(f"{h:g}" for h in entries["runout_m"]["cells"])
        sentences.append(
            f"{label}, on the {len(entries['runout_m']['realizations'])} realizations run at every h = {cells} m: "
            + "; ".join(series(entries[key], key) for key in ("runout_m", "influence_m", "volume_m2"))
            + "."
        )
    return " ".join(sentences) + " (`benchmarks/results/convergence.json`.)"


def convergence_column() -> str:
    """docs/engine.md: the column collapse's runout over width per shape and cell size, and the B-spline's order."""
    column = result("convergence.json")["column"]
    sentences = []
    for shape, label in (("bspline", "B-spline"), ("linear", "bilinear")):
        entry = column[shape]
        ran = [f"{v:.2f}" for v in entry["runout_ratio"] if v is not None]
        text = f"{label} {' → '.join(ran)}"
        fit = entry["fit"]
        if fit["asymptotic"]:
            text += f" (p = {fit['order']:.2f}, f* = {fit['converged']:.2f})"
        failed = [(h, status) for h, status in zip(entry["cells"], entry["status"]) if status != "ok"]
        text += "".join(f", then at {h:g} m {status}" for h, status in failed)
        sentences.append(text)
    cells = " / ".join(f"{h:g}" for h in column["bspline"]["cells"])
    return f"On the column, runout over width at h = {cells} m: {'; '.join(sentences)}."


def convergence_default_error() -> str:
    """docs/engine.md: the default 1 m B-spline mesh's error against the 0.5 m answers and against the converged
    values (Richardson where the series is asymptotic, else the finest), and what 0.5 m costs."""
    record = result("convergence.json")
    spread = record["slopes"]["range"]
    levels = record["slopes"]["shapes"]["bspline"]
    names = {"runout_m": ("R", "m", 2), "volume_m2": ("V", "m²", 1), "influence_m": ("I", "m", 2)}
    against = levels["1"]["against_bspline"]["0.5"]
    to_half = ", ".join(
        f"{name} {against[key]['mean_abs']:.{digits}f} {unit} ({100 * against[key]['share_of_range']:.0f} %)"
        for key, (name, unit, digits) in names.items()
    )
    orders = record["orders"]["bspline"]
    one = orders["runout_m"]["cells"].index(1.0)
    finest = f"{orders['runout_m']['cells'][-1]:g} m"
    to_converged = ", ".join(
        f"{name} {true_minus(format(orders[key]['errors'][one], '+.1f'))} {unit} "
        f"({100 * abs(orders[key]['errors'][one]) / spread[key]:.0f} %)"
        for key, (name, unit, _) in names.items()
    )
    reference = "; ".join(
        f"{names[key][0]} its {'Richardson value' if orders[key]['asymptotic'] else finest + ' value'}" for key in names
    )
    n_all = against["runout_m"]["n"]
    verdict = (
        f"every realization fails at 1 m and at 0.5 m ({levels['1']['failed']} of {n_all})"
        if levels["1"]["failed"] == levels["0.5"]["failed"] == n_all
        else f"{levels['1']['failed']} of {n_all} fail at 1 m, {levels['0.5']['failed']} at 0.5 m"
    )
    cost = record["diagnose"]
    coarse, fine = cost["bspline, 1 m, 2x2 points"], cost["bspline, 0.5 m"]
    return (
        f"Against the 0.5 m answer on {n_all} realizations, {to_half}; on the "
        f"{len(orders['runout_m']['realizations'])} realizations run at every h, against the converged value "
        f"({reference}), {to_converged}. The failed/stood verdict: {verdict}. 0.5 m costs "
        f"{fine['s_per_realization'] / coarse['s_per_realization']:.1f}× the time per run (the uniform slopes of "
        f"the locking study below, one thread: {coarse['s_per_realization']:.1f} s against "
        f"{fine['s_per_realization']:.1f} s; `benchmarks/results/convergence.json`)."
    )


def route_label(name: str) -> str:
    """A locking-study route's change as the docs write it: 'linear, 1 m, 2x2 points' → '2 × 2 points'."""
    change = name.split(", ", 2)[-1]
    return re.sub(r"(\d)x(\d)", r"\1 × \2", change).replace("nu ", "ν ")


def locking_routes() -> str:
    """docs/engine.md: the bilinear 1 m runouts of the long slope at φ 30° and 34°, one change at a time."""
    routes = result("convergence.json")["diagnose"]
    cells = [
        f"{route_label(name)} {' / '.join('0' if r == 0 else f'{r:.1f}' for r in entry['runout_m'])}"
        for name, entry in routes.items()
        if name.startswith("linear, 1 m")
    ]
    return "; ".join(cells) + " (`benchmarks/results/convergence.json`)."


def locking_bspline() -> str:
    """docs/engine.md: the converged slide's depth and the B-spline runouts of the locking study's slopes."""
    routes = result("convergence.json")["diagnose"]
    fine = routes["bspline, 0.5 m"]

    def pair(values: list[float]) -> str:
        return " / ".join(f"{v:.1f}" for v in values)

    return (
        f"The converged slide starts {pair(fine['slide_depth_m'])} m below the surface (B-spline 0.5 m). With "
        f"B-splines at 1 m the same slopes run out {pair(routes['bspline, 1 m, 2x2 points']['runout_m'])} m with "
        f"2 × 2 points and {pair(routes['bspline, 1 m, 4x4 points']['runout_m'])} m with 4 × 4, against "
        f"{pair(fine['runout_m'])} m at 0.5 m."
    )


def time_step() -> str:
    """docs/evidence.md: the MPM's mean R, V and I at each CFL number, pure FLIP, per case and mesh, with the change of
    the default step (the coarsest) from the finest, from paired runs of a seed of their own (time_step.json)."""
    record = result("time_step.json")
    lines = [
        "| case, cells | realizations | CFL | mean R (m) | mean V (m²) | mean I (m) | I less the finest step's (m) "
        "| V less the finest step's (m²) |",
        "|---|---:|---|---|---|---|---|---|",
    ]
    for group in record["groups"]:
        if group["pic_blend"] != 0:
            continue
        metrics = group["metrics"]
        means = {key: " / ".join(f"{m['value']:.2f}" for m in metrics[key]["means"]) for key in metrics}
        changes = {
            key: true_minus(bracketed([coarsest[part] for part in ("value", "lower", "upper")], 2, "+"))
            for key in ("influence_m", "volume_m2")
            for coarsest in [metrics[key]["change_from_finest"][0]]
        }
        lines.append(
            f"| {group['case']}, {group['cell_size_m']:g} m | {group['realizations']} | "
            f"{' / '.join(f'{x:g}' for x in group['cfl'])} | {means['runout_m']} | {means['volume_m2']} | "
            f"{means['influence_m']} | {changes['influence_m']} (CFL {group['cfl'][0]:g}) | "
            f"{changes['volume_m2']} (CFL {group['cfl'][0]:g}) |"
        )
    seeds = sorted({seed for group in record["groups"] for seed in group["seeds"]})
    lines += [
        "",
        f"Realizations of seed {', '.join(map(str, seeds))}; intervals 95 % paired bootstrap; "
        f"`{record['command']}` from `{record['runs']}`, tabled at {record['commit']}.",
    ]
    return "\n".join(lines)


def _interval(entry: dict[str, float]) -> str:
    """'v [lo, hi]' of an entry with value, lower and upper, minus signs true."""
    return true_minus(bracketed([entry[part] for part in ("value", "lower", "upper")], 2))


def time_step_mesh() -> str:
    """docs/evidence.md: the MPM's mean R, V and I against the cell size at a converged time step, with the last
    refinement's change, the observed order and the Richardson value, and I at displacement thresholds
    (time_step_mesh.json)."""
    record = result("time_step_mesh.json")
    names = {"runout_m": "R (m)", "volume_m2": "V (m²)", "influence_m": "I (m)"}
    lines = []
    for case in record["cases"]:
        cells = case["cell_size_m"]
        lines += [
            f"{case['case']}, {case['realizations']} realizations at every cell size, CFL {record['cfl']:g}:",
            "",
            "| quantity | " + " | ".join(f"{x:g} m" for x in cells) + " | last refinement's change | observed order "
            "(3 finest) | Richardson value |",
            "|---|" + "---|" * (len(cells) + 3),
        ]
        for key, name in names.items():
            metric = case["metrics"][key]
            means = [f"{m['value']:.2f}" for m in metric["means"]]
            last = metric["change_from_finer"][-1]
            change = true_minus(
                bracketed([-last[part] for part in ("value", "upper", "lower")], 2, "+")
            )  # finer less coarser
            order = [_interval(metric["order"]), _interval(metric["richardson"])] if "order" in metric else ["—", "—"]
            lines.append(f"| mean {name} | " + " | ".join([*means, change, *order]) + " |")
        for threshold, means in case.get("influence_at_thresholds", {}).items():
            values = " | ".join(f"{m['value']:.2f}" for m in means)
            lines.append(f"| mean I at a {threshold} m threshold (m) | {values} | | | |")
        lines.append("")
    lines.append(
        f"Intervals 95 % paired bootstrap; `{record['command']}` from `{record['runs']}`, tabled at {record['commit']}."
    )
    return "\n".join(lines)
