"""The embedded MPM's two backends side by side: the compiled kernels (numba) against the torch engine, one thread.

    python benchmarks/engine_backends.py                      # both meshes, case 1 realization 0
    python benchmarks/engine_backends.py --cells 1.0 --repeats 3

Runs case 1's Monte Carlo realization 0 (the realization ``machine_pace.py`` times) whole, as the pairs run it
(``mesh_levels.run_settings``: the default config's frames, early stop, end frames kept), at each ``--cells`` size,
by each backend in turn in one process, one thread, alternating ``--repeats`` times (so both see the same
machine); the kernels are compiled before the clock starts. Records per backend and mesh: seconds per
realization (best and all), steps, milliseconds per step, particle-steps per second; the ratio torch / kernels of
the best times and of each repeat's pair (how far it moves with the machine); the agreement (R, V, I and step
counts of both, the largest position difference of the final frame, the largest stress difference relative to the
largest stress); and the kernels' compile time in a fresh process with an empty cache and their load time from the
cache in another. Writes
``benchmarks/results/engine_backends.json`` and ``.md``.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).parent))
from mesh_levels import run_settings  # noqa: E402

from rgns.config import load_config  # noqa: E402
from rgns.engines.batch import Simulated, run_mpm  # noqa: E402
from rgns.montecarlo.runs import CaseInputs, measure  # noqa: E402
from rgns.provenance import commit  # noqa: E402
from rgns.scene.realizations import accurate_case_inputs, draw_realization  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "benchmarks" / "results" / "engine_backends"
BACKENDS = ("numba", "torch")


def one_run(config: dict, cell: float, backend: str) -> dict:
    """Realization 0 of case 1 at ``cell`` m by ``backend``: seconds, steps, R, V, I, final frame and stress."""
    config = copy.deepcopy(config)
    config["mpm"]["embedded"]["backend"] = backend
    settings = run_settings(config)
    inputs = CaseInputs.from_params(asdict(accurate_case_inputs(config, "case1", cell)))
    realization = draw_realization(inputs, 0)
    began = time.perf_counter()
    (result,) = run_mpm([realization], settings.mpm, settings.frames, keep="ends")
    seconds = time.perf_counter() - began
    row = measure(
        realization,
        Simulated(result.positions, result.status),
        settings.metrics,
        settings.mpm.density_kg_m3,
        settings.frame_interval_s,
        settings.mpm.gravity_m_s2,
    )
    return {
        "seconds": seconds,
        "steps": result.steps,
        "particles": len(realization.scene.positions),
        "status": result.status,
        "runout_m": row["runout_m"],
        "volume_m2": row["volume_m2"],
        "influence_m": row["influence_m"],
        "final": result.positions[-1],
        "stress": result.final_stress,
    }


def first_call_seconds(cache: Path) -> float:
    """Seconds of a fresh process's first (two-frame) run, with ``cache`` as numba's cache: compiling the kernels
    when it is empty, loading them when it holds them."""
    env = os.environ | {"NUMBA_CACHE_DIR": str(cache)}
    probe = subprocess.run(
        [sys.executable, "-c", WARM],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        cwd=REPO,
    )
    return float(probe.stdout.strip().splitlines()[-1])


WARM = """
import time
from dataclasses import asdict
began = time.perf_counter()
from rgns.config import load_config
from rgns.engines.batch import run_mpm
from rgns.engines.settings import MpmSettings
from rgns.montecarlo.runs import CaseInputs
from rgns.scene.realizations import accurate_case_inputs, draw_realization
config = load_config("config/config.yaml")
inputs = CaseInputs.from_params(asdict(accurate_case_inputs(config, "case1", 1.0)))
realization = draw_realization(inputs, 0)
mpm = MpmSettings.from_config(config["mpm"])
ready = time.perf_counter()
run_mpm([realization], mpm, 2, keep="ends")
print(time.perf_counter() - ready)
"""


def mesh(config: dict, cell: float, repeats: int) -> dict:
    """Both backends at ``cell`` m, alternating ``repeats`` times; their times, ratio and agreement."""
    runs: dict[str, list[dict]] = {backend: [] for backend in BACKENDS}
    for _ in range(repeats):
        for backend in BACKENDS:
            runs[backend].append(one_run(config, cell, backend))
            print(f"{cell} m {backend}: {runs[backend][-1]['seconds']:.2f} s", flush=True)
    best = {backend: min(r["seconds"] for r in rows) for backend, rows in runs.items()}
    kernels, reference = runs["numba"][0], runs["torch"][0]
    out: dict = {"backends": {}}
    for backend, rows in runs.items():
        steps, particles = rows[0]["steps"], rows[0]["particles"]
        out["backends"][backend] = {
            "seconds_best": best[backend],
            "seconds_all": [r["seconds"] for r in rows],
            "steps": steps,
            "particles": particles,
            "ms_per_step": 1e3 * best[backend] / steps,
            "particle_steps_per_s": particles * steps / best[backend],
            "runout_m": rows[0]["runout_m"],
            "volume_m2": rows[0]["volume_m2"],
            "influence_m": rows[0]["influence_m"],
            "status": rows[0]["status"],
        }
    scale = float(np.abs(reference["stress"]).max())
    out["speedup"] = best["torch"] / best["numba"]
    # each repeat's own ratio: how far the ratio of bests moves with the machine between runs minutes apart
    out["speedup_each"] = [t["seconds"] / k["seconds"] for k, t in zip(runs["numba"], runs["torch"])]
    out["agreement"] = {
        "same_R_V_I": all(kernels[key] == reference[key] for key in ("runout_m", "volume_m2", "influence_m")),
        "same_steps": kernels["steps"] == reference["steps"],
        "final_position_max_difference_m": float(np.abs(kernels["final"] - reference["final"]).max()),
        "final_stress_max_relative_difference": float(np.abs(kernels["stress"] - reference["stress"]).max() / scale),
    }
    return out


def markdown(record: dict) -> str:
    """The tables of a record."""
    lines = [
        "# The MPM's backends side by side",
        "",
        f"`{record['command']}` at {record['commit']} ({record['when']}, load average {record['load_before']:.2f} "
        "before): case 1's Monte Carlo realization 0 run whole as the pairs run it, one thread, the backends "
        f"alternating in one process, best of {record['repeats']}.",
        "",
        "| mesh | backend | s per realization | steps | ms per step | particle-steps per s | speed-up (each repeat's) |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for cell, row in record["cells"].items():
        for backend, b in row["backends"].items():
            each = ", ".join(f"{r:.1f}" for r in row["speedup_each"])
            ratio = f"{row['speedup']:.1f}x ({each})" if backend == "numba" else ""
            lines.append(
                f"| {cell} m | {backend} | {b['seconds_best']:.2f} | {b['steps']:,} | {b['ms_per_step']:.3f} | "
                f"{b['particle_steps_per_s'] / 1e6:.2f} M | {ratio} |"
            )
    lines += [
        "",
        "| mesh | R (m) numba / torch | V (m²) numba / torch | I (m) numba / torch | same steps | final positions "
        "max diff (m) | final stress max rel. diff |",
        "|---|---|---|---|---|---:|---:|",
    ]
    for cell, row in record["cells"].items():
        k, t, a = row["backends"]["numba"], row["backends"]["torch"], row["agreement"]
        lines.append(
            f"| {cell} m | {k['runout_m']!r} / {t['runout_m']!r} | {k['volume_m2']!r} / {t['volume_m2']!r} | "
            f"{k['influence_m']!r} / {t['influence_m']!r} | {a['same_steps']} | "
            f"{a['final_position_max_difference_m']:.1e} | {a['final_stress_max_relative_difference']:.1e} |"
        )
    compile_ = record["compile"]
    lines += [
        "",
        f"Kernels' first call in a fresh process: {compile_['cold_s']:.1f} s with an empty cache (compiling), "
        f"{compile_['cached_s']:.2f} s from the cache.",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cells", type=float, nargs="+", default=[0.5, 1.0])
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    torch.set_num_threads(1)
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as cache:
        cold, cached = first_call_seconds(Path(cache)), first_call_seconds(Path(cache))
    config = load_config(REPO / "config" / "config.yaml")
    one_run(config, 1.0, "numba")  # compiled (or loaded) before any clock
    record = {
        "command": " ".join(["python benchmarks/engine_backends.py", *sys.argv[1:]]),
        "commit": commit(),
        "when": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "load_before": load_before,
        "repeats": args.repeats,
        "compile": {"cold_s": cold, "cached_s": cached},
        "cells": {f"{cell:g}": mesh(config, cell, args.repeats) for cell in args.cells},
    }
    OUT.with_suffix(".json").write_text(json.dumps(record, indent=1) + "\n")
    OUT.with_suffix(".md").write_text(markdown(record))
    print(markdown(record))


if __name__ == "__main__":
    main()
