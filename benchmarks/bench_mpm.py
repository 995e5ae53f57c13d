"""Embedded MPM vs CB-Geo on the same failing slope: wall time, throughput and error, in one run.

    python benchmarks/bench_mpm.py                                  # embedded only
    python benchmarks/bench_mpm.py --cbgeo /path/to/mpm             # with CB-Geo -p 1
    python benchmarks/bench_mpm.py --cbgeo /path/to/mpm --cbgeo-reference   # + CB-Geo's own fine-dt run

One case directory (the default config's first training slope with a weak field, mean 20°, which
fails) is run by: the embedded engine at fine dt (the reference), the embedded engine with the
default settings for B = 1 and for B realizations in one batch, and CB-Geo at the case's dt.
Errors are against the fine-dt reference(s): runout distance R, sliding volume V, influence
distance I (1 m threshold) and the mean final particle position. Results go to
``benchmarks/results/mpm.json`` and ``mpm.md``.
"""

from __future__ import annotations

import argparse
import json
import platform
import shutil
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from reference_cases import failing_slope  # noqa: E402  (the CB-Geo comparison cases, a test fixture)

from rgns.config import load_config  # noqa: E402
from rgns.engines.cbgeo.case import read_case  # noqa: E402
from rgns.engines.cbgeo.runner import run_cbgeo, trajectory_from_cbgeo  # noqa: E402
from rgns.engines.metrics import crest_x, influence_distance, runout_distance, sliding_volume  # noqa: E402
from rgns.engines.mpm.solver import EngineSettings, run_batch  # noqa: E402
from rgns.scene.case import Case  # noqa: E402


def metrics(case: Case, final: np.ndarray, crest: float) -> dict[str, float]:
    initial = case.positions
    return {
        "R": runout_distance(initial, final),
        "V": sliding_volume(initial, final, case.volumes),
        "I": influence_distance(initial, final, crest),
    }


def errors(case: Case, final: np.ndarray, reference: np.ndarray, crest: float) -> dict[str, float]:
    ours, ref = metrics(case, final, crest), metrics(case, reference, crest)
    out = {f"{k}_rel_error": abs(ours[k] - ref[k]) / max(abs(ref[k]), 1e-9) for k in ours}
    out["mean_position_error_m"] = float(np.linalg.norm(final - reference, axis=1).mean())
    return out | {k: ours[k] for k in ours}


def timed_embedded(case: Case, settings: EngineSettings, batch: int, duration: float) -> tuple[np.ndarray, dict]:
    start = time.perf_counter()
    results = run_batch([case] * batch, settings, duration_s=duration)
    wall = time.perf_counter() - start
    steps = results[0].steps
    return results[0].positions[-1], {
        "batch": batch,
        "wall_s": wall,
        "per_realization_s": wall / batch,
        "steps": steps,
        "stopped_at_s": results[0].stopped_at_s,
        "status": results[0].status,
        "particle_steps_per_s": batch * len(case.positions) * steps / wall,
    }


def timed_cbgeo(case_dir: Path, work: Path, binary: str, dt: float | None, label: str) -> tuple[np.ndarray, dict]:
    directory = case_dir
    if dt is not None:  # a copy of the case at another dt
        directory = work / f"case_dt{dt:g}"
        case = read_case(case_dir)
        document = dict(case.config)
        frame_steps = int(round(case.meta["frame_interval_s"] / dt))
        frames = case.meta["nsteps"] // case.meta["output_steps"]
        document["analysis"] = dict(document["analysis"], dt=dt, nsteps=frames * frame_steps)
        document["post_processing"] = dict(document["post_processing"], output_steps=frame_steps)
        shutil.copytree(case_dir, directory)
        (directory / "mpm.json").write_text(json.dumps(document, indent=2))
        meta = dict(case.meta, dt_s=dt, nsteps=frames * frame_steps, output_steps=frame_steps)
        (directory / "rgns-case.json").write_text(json.dumps(meta, indent=2))
    options = {"binary": binary, "threads": 1, "keep_raw": False, "timeout_s": 7200}
    case, raw, wall = run_cbgeo(directory, work / f"scratch_{label}", work / f"{label}.log", options, label)
    trajectory = trajectory_from_cbgeo(case, raw, label, {})
    nsteps = case.meta["nsteps"]
    return trajectory.positions[-1], {
        "dt_s": case.meta["dt_s"],
        "wall_s": wall,
        "per_realization_s": wall,
        "steps": nsteps,
        "particle_steps_per_s": len(case.positions) * nsteps / wall,
    }


def table(rows: dict[str, dict]) -> str:
    lines = [
        "| run | wall (s) | per realization (s) | steps | particle-steps/s | R err | V err | I err | mean pos. err (m) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for name, row in rows.items():
        lines.append(
            f"| {name} | {row['wall_s']:.1f} | {row['per_realization_s']:.2f} | {row['steps']} | "
            f"{row['particle_steps_per_s']:.3g} | {row.get('R_rel_error', 0):.1%} | "
            f"{row.get('V_rel_error', 0):.1%} | {row.get('I_rel_error', 0):.1%} | "
            f"{row.get('mean_position_error_m', 0):.3f} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch", type=int, default=16)
    parser.add_argument("--duration", type=float, default=None, help="simulated time (s); default: the config's")
    parser.add_argument("--reference-dt", type=float, default=1e-4, help="dt of the fine-dt references (s)")
    parser.add_argument("--cbgeo", help="path of the CB-Geo mpm binary")
    parser.add_argument("--cbgeo-reference", action="store_true", help="also run CB-Geo at --reference-dt")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    torch.set_num_threads(1)

    work = Path(tempfile.mkdtemp(prefix="rgns-bench-mpm-"))
    case = failing_slope(work / "case")
    crest = crest_x(np.array(case.meta["vertices"]))
    duration = args.duration or case.meta["nsteps"] * case.meta["dt_s"]
    default = EngineSettings.from_config(load_config()["mpm"]["embedded"])
    print(f"case: {len(case.positions)} particles, {duration:g} s simulated, {case.meta['cell_size_m']} m cells")

    reference, info = timed_embedded(case, replace(default, dt_max_s=args.reference_dt, early_stop=False), 1, duration)
    rows = {"embedded_reference": info | metrics(case, reference, crest)}
    finals = {}
    for batch in (1, args.batch):
        finals[batch], info = timed_embedded(case, default, batch, duration)
        rows[f"embedded_B{batch}"] = info | errors(case, finals[batch], reference, crest)
    extra = {}
    if args.cbgeo:
        cbgeo_final, info = timed_cbgeo(work / "case", work, args.cbgeo, None, "cbgeo")
        rows["cbgeo"] = info | errors(case, cbgeo_final, reference, crest)
        if args.cbgeo_reference:
            cbgeo_reference, info = timed_cbgeo(work / "case", work, args.cbgeo, args.reference_dt, "cbgeo_reference")
            rows["cbgeo_reference"] = info | errors(case, cbgeo_reference, reference, crest)
            extra["cbgeo_vs_cbgeo_reference"] = errors(case, cbgeo_final, cbgeo_reference, crest)
            extra["embedded_vs_cbgeo_reference"] = errors(case, finals[1], cbgeo_reference, crest)
        extra["speedup_per_realization_batched_vs_cbgeo"] = (
            rows["cbgeo"]["per_realization_s"] / rows[f"embedded_B{args.batch}"]["per_realization_s"]
        )

    text = table(rows)
    for name, value in extra.items():
        text += f"\n\n{name}: " + (
            f"{value:.1f}x (target >= 20x)"
            if isinstance(value, float)
            else ", ".join(f"{k} {v:.3g}" for k, v in value.items())
        )
    summary = {
        "case_particles": len(case.positions),
        "duration_s": duration,
        "machine": platform.machine(),
        "torch": torch.__version__,
        "threads": 1,
        "rows": rows,
        "extra": extra,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "mpm.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
    command = "python benchmarks/bench_mpm.py " + " ".join(sys.argv[1:])
    (args.out / "mpm.md").write_text(
        f"# Embedded MPM vs CB-Geo ({len(case.positions)} particles, {duration:g} s simulated)\n\n"
        f"Command: `{command.strip()}`\n\n{text}\n"
    )
    print(text)


if __name__ == "__main__":
    main()
