"""docs/benchmarks.md's current rows that are not a study of their own: random fields, scenes, mesh levels, the
MPM's backends, the plain MPM Monte Carlo."""

from __future__ import annotations

from evidence.fidelity import direct_reference
from evidence.formatting import ends, order_text
from evidence.sources import result


def bench_fields() -> str:
    """docs/benchmarks.md: random-field throughput, Kronecker against the paper's dense Cholesky, from one run."""
    record = result("fields.json")
    made = f"`fields.json`, made at {record['commit']}"
    command = f"`{record['command']}`"
    rows, columns = record["grid"]
    paper_minutes = 73  # the paper's ~73 min for 10,000 fields by factor-per-field Cholesky
    lines = [
        "| what | figure | command | made at |",
        "|---|---|---|---|",
        f"| {record['fields']:,} Kronecker fields, paper grid {rows} × {columns} | {record['kronecker_total_s']:.1f} s "
        f"({record['kronecker_per_field_ms']:.2f} ms per field; target ≤ {record['target_total_s']:.0f} s) | "
        f"{command} | {made} |",
        f"| one dense-Cholesky field as the paper ran it (factor + sample) | {record['cholesky_per_field_s']:.2f} s "
        f"per field → ~{record['cholesky_total_estimate_s'] / 60:.0f} min per {record['fields']:,} (paper: "
        f"~{paper_minutes} min) | {command} | {made} |",
        f"| {record['fields']:,} dense-Cholesky fields with one factor reused | "
        f"{record['cholesky_factor_reused_total_s']:.1f} s (Kronecker {record['speedup_vs_factor_reused']:.1f}× "
        f"faster) | {command} | {made} |",
        f"| Kronecker vs factor-per-field Cholesky | ~{round(record['speedup_per_field'], -2):,.0f}× per field | "
        f"{command} | {made} |",
        "",
        f"On {record['machine']}, numpy {record['numpy']}.",
    ]
    return "\n".join(lines)


def scenes_row() -> str:
    """docs/benchmarks.md: cases built in memory against written and read back, per run length (scenes.json)."""
    record = result("scenes.json")
    runs = record["runs"]
    disk_setup = [1000 * run["setup_s"]["disk"] for run in runs]
    memory_setup = max(1000 * run["setup_s"]["memory"] for run in runs)
    ratios = "; ".join(
        f"{run['simulated_s']:g} s simulated {run['seconds']['disk'] / run['seconds']['memory']:.2f}× "
        f"({run['repeats']} repeat{'s' if run['repeats'] > 1 else ''})"
        for run in runs
    )
    identical = "identical" if all(run["identical"] for run in runs) else "NOT identical"
    return (
        f"| Monte Carlo cases in memory vs written and read back ({runs[0]['realizations']} case-1 realizations) | "
        f"{memory_setup:.1f} ms vs {min(disk_setup):.0f}–{max(disk_setup):.0f} ms set-up per realization; the "
        f"disk round trip's time over the in-memory one's, per realization: {ratios} (0.15 s is the GNS warm-up); "
        f"{identical} trajectories | "
        + ", ".join(f"`{run['command']}`" for run in runs)
        + " | `scenes.json` "
        + ", ".join(sorted({run["commit"] for run in runs}))
        + " |"
    )


def mesh_levels_row() -> str:
    """docs/benchmarks.md: the embedded MPM's mesh error on the Monte Carlo's realizations (mesh_levels.json)."""
    record = result("mesh_levels.json")
    case1, case3 = record["case1"], record["case3"]
    fits = case1["fits"]
    means = " / ".join(f"{fits['runout_m'][f'mean_{h}']['value']:.2f}" for h in ("1", "0.5", "0.25"))
    influence = fits["influence_m"]
    step = next(
        entry for entry in case1["against"]["comparisons"] if entry["quantity"].startswith("mesh step of the mean")
    )
    return (
        "| the embedded MPM's mesh error on the Monte Carlo's realizations, h = 1, 0.5, 0.25 m "
        f"(case 1: {len(case1['realizations'])}; case 3: {len(case3['realizations'])}) | case 1 mean runout {means} m, "
        f"order {order_text(case1['mesh_order']['runout_m'])}, by which the 0.5 m mesh's mean runout is short by "
        f"{ends(step['reference'])}, and the default run's mesh step of it, {ends(step['headline'])} "
        f"({case1['against']['headline']}), {'holds' if step['inside'] else 'DOES NOT hold'} that; volume: "
        f"{order_text(case1['mesh_order']['volume_m2'])}, influence: {order_text(case1['mesh_order']['influence_m'])} "
        f"(case 1's mean influence grows {influence['mean_0.5']['value']:.2f} → {influence['mean_0.25']['value']:.2f} m "
        f"from 0.5 to 0.25 m); case 3's runout: {order_text(case3['mesh_order']['runout_m'])}; the cost against plain "
        "0.25 m Monte Carlo and the 0.125 m "
        f"levels: `benchmarks/results/mesh_levels.md` | `{record['command']}` | `mesh_levels.json` {record['commit']} |"
    )


def mesh_levels_gpu_row() -> str:
    """docs/benchmarks.md: the direct 0.25 m reference of the default run's realizations, run on a GPU
    (mesh_levels_gpu.json)."""
    record = result("mesh_levels_gpu.json")
    gpu = record["case1"]
    agreement = gpu["cpu_agreement"]
    worst = max(agreement, key=lambda row: row["largest_m"])
    return (
        f"| the direct 0.25 m reference on the default run's first {len(gpu['realizations'])} case-1 realizations at "
        f"h = {', '.join(f'{float(h):g}' for h in gpu['seconds'])} m, run on a GPU | "
        f"{sum(gpu['seconds'].values()):.1f} s per realization for the {len(gpu['seconds'])} meshes; runout within "
        f"{100 * worst['largest_m']:.1f} cm of the one-thread CPU runs on {agreement[0]['n']} (at "
        f"{worst['cell_size_m']:g} m); order of the mean runout {order_text(gpu['mesh_order']['runout_m'])}, of the "
        f"volume {order_text(gpu['mesh_order']['volume_m2'])}, of the influence "
        f"{order_text(gpu['mesh_order']['influence_m'])}; the default run's headline ({gpu['against']['headline']}): "
        f"{direct_reference(gpu)} | `{record['command']}` | `mesh_levels_gpu.json` {record['commit']} |"
    )


def bench_current() -> str:
    """docs/benchmarks.md: the current rows that are not a table of their own, each from its result file."""
    return "\n".join(
        [
            "| what | figure | command | made at |",
            "|---|---|---|---|",
            scenes_row(),
            mesh_levels_row(),
            mesh_levels_gpu_row(),
            engine_backends_row(),
            plain_mc_row(),
        ]
    )


def engine_backends_row() -> str:
    """docs/benchmarks.md: the compiled kernels against the torch engine, side by side (engine_backends.json)."""
    record = result("engine_backends.json")
    meshes = []
    for cell, shown in (("0.5", "0.5 m"), ("1", "1 m")):
        mesh = record["cells"][cell]
        numba, torch = mesh["backends"]["numba"], mesh["backends"]["torch"]
        agreement = mesh["agreement"]
        same = (
            "R, V, I and step counts identical"
            if agreement["same_R_V_I"] and agreement["same_steps"]
            else ("R, V, I or step counts DIFFER")
        )
        each = mesh["speedup_each"]
        meshes.append(
            f"{shown}: {numba['seconds_best']:.2f} s against {torch['seconds_best']:.2f} s a realization, "
            f"{mesh['speedup']:.1f}× (each repeat's {min(each):.1f}–{max(each):.1f}×; "
            f"{numba['particle_steps_per_s'] / 1e6:.2f} M particle-steps a second), {same}, "
            f"final stresses within {agreement['final_stress_max_relative_difference']:.1e} relative"
        )
    return (
        "| the MPM's compiled kernels (numba) against its torch engine, case 1's realization 0 whole, one thread, "
        f"best of {record['repeats']} | " + "; ".join(meshes) + f"; compile {record['compile']['cold_s']:.1f} s "
        f"cold, {record['compile']['cached_s']:.2f} s from the cache | `{record['command']}` | "
        f"`engine_backends.json` {record['commit']} |"
    )


def plain_mc_row() -> str:
    """docs/benchmarks.md: the plain MPM Monte Carlo of case 1 at 1 m against a default run's answer at 1 m
    (plain_mc.json)."""
    record = result("plain_mc.json")
    default = record["default"]

    def checked(plain: float, interval: list[float | None]) -> str:
        lower, upper = (-float("inf") if interval[1] is None else interval[1]), interval[2]
        verdict = "holds" if lower <= plain <= (float("inf") if upper is None else upper) else "MISSES"
        return f"{ends(interval)} {verdict} its {plain:.2f} m"

    exceeded = "; ".join(f"R exceeded with P {p} {ends(value)}" for p, value in record["runout_exceeded_m"].items())
    against = "; ".join(
        [f"mean runout {checked(record['mean_runout_m'][0], default['mean_runout_m'])}"]
        + [
            f"R exceeded with P {p} {checked(record['runout_exceeded_m'][p][0], value)}"
            for p, value in default["runout_exceeded_m"].items()
        ]
    )
    commits = ", ".join(sorted({run["commit"] for run in record["runs"]}))
    return (
        f"| a plain MPM Monte Carlo of case 1 at 1 m, {record['realizations']:,} realizations (the paper's reference "
        f"route) | mean runout {ends(record['mean_runout_m'])}; {exceeded} "
        f"(95 % bootstrap); {record['job_seconds'] / 3600:.2f} h of job time on one thread each, "
        f"{record['wall_seconds'] / 3600:.2f} h wall for the {record['chunks_with_wall']} of {record['chunks']} "
        f"chunks whose run recorded its time; a default run's answer at 1 m (at {default['run_commit']}: its "
        f"{default['n_paired']} pairs' 1 m "
        f"partners corrected with its cheap route over 10,000): {against} | `{record['command']}` | "
        f"`plain_mc.json` {commits} |"
    )
