"""A plain MPM Monte Carlo of case 1: every realization by the MPM at the Monte Carlo's mesh, no surrogate.

    python benchmarks/plain_mc.py --run --realizations 10000 --workers 2   # resumable: chunk by chunk
    python benchmarks/plain_mc.py --against <run>   # the report, beside a default run's answer at 1 m

The paper's reference route ("over 400 days using a conventional MPM solver"), as a benchmark the default's
multi-fidelity answer is checked against. Realizations 0 .. N - 1 of the default config's case 1, drawn as rule
mc_chunk draws them, run by the embedded MPM at the Monte Carlo's mesh (1 m) with the pipeline's Monte Carlo
settings (screening, early stop, end frames), one thread per worker process. Each chunk of ``--chunk``
realizations is appended to ``benchmarks/results/plain_mc_runs.csv`` as it finishes (its rows, with its wall
seconds and its first realization, ``chunk``; a line a kill cut short is left out by the reader and cut off by the
next append), so a killed run loses only the chunks in progress and resumes with the realizations missing; each
run's wall time is kept in ``benchmarks/results/plain_mc_walls.json``. The report: the realizations done, their summed job seconds
and the wall time of the runs that made them; mean R and the runouts exceeded with probability 0.5 / 0.1 / 0.01
with 95 % percentile bootstrap intervals (scipy.stats.bootstrap), beside a default run's answer at the same mesh
(``--against``, the run's directory): its 32 pairs' partners at 1 m corrected with its cheap route over all 10,000,
by the estimators of rule multifidelity (the control variate for the mean, the regression control variate for the
exceedance curve, the pairs' stratified design), with their intervals; and its best estimate at the converged
mesh, which a 1 m Monte Carlo cannot check (it is longer by the mesh step). Writes ``plain_mc.json`` and
``plain_mc.md``.
"""

from __future__ import annotations

import argparse
import io
import json
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the evidence package
from mesh_levels import append_lines, complete_lines, run_settings  # noqa: E402

from evidence.formatting import ends  # noqa: E402
from rgns.config import load_config  # noqa: E402
from rgns.fidelity.multifidelity import control_variate, rearranged, regression_control_variate  # noqa: E402
from rgns.fidelity.outputs import paired_rows  # noqa: E402
from rgns.fidelity.pair_design import row_strata  # noqa: E402
from rgns.hazard.exceedance import distance_at, distance_grid  # noqa: E402
from rgns.provenance import commit  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks" / "results"
STORE = RESULTS / "plain_mc_runs.csv"  # every realization run: each chunk's rows appended as it finishes
WALLS = RESULTS / "plain_mc_walls.json"  # each run's wall time up to its last finished chunk
PROBABILITIES = (0.5, 0.1, 0.01)


def load_rows(path: Path = STORE) -> pd.DataFrame:
    """The realizations the store holds, in index order (the last row of one saved twice); a last line a kill
    cut short is left out."""
    lines = complete_lines(path.read_text()) if path.exists() else []
    if not lines:
        return pd.DataFrame({"index": pd.Series(dtype=int)})
    table = pd.read_csv(io.StringIO("\n".join(lines) + "\n"))
    return table.drop_duplicates("index", keep="last").sort_values("index", kind="stable", ignore_index=True)


def append_chunk(table: pd.DataFrame, path: Path = STORE) -> None:
    """A chunk's rows appended to the store in one write (the header first into an empty store)."""
    header, rows = table.to_csv(index=False, lineterminator="\n").split("\n", 1)
    if path.exists() and path.stat().st_size:
        with path.open() as store:
            if store.readline() != header + "\n":
                raise ValueError(f"{path}: its columns are not {header}")
    append_lines(path, rows, header=header + "\n")


def run_chunk(indices: list[int]) -> str:
    """Realizations ``indices`` by the MPM at 1 m, appended to the store with the chunk's wall seconds and its
    first realization."""
    import torch

    from rgns.montecarlo.runs import CaseInputs, run_realizations
    from rgns.scene.realizations import accurate_case_inputs

    torch.set_num_threads(1)
    config = load_config(REPO / "config" / "config.yaml")
    inputs = CaseInputs.from_params(asdict(accurate_case_inputs(config, "case1", config["mesh"]["cell_size_m"])))
    began = time.perf_counter()
    table = run_realizations(inputs, indices, run_settings(config))
    table["chunk_seconds"] = time.perf_counter() - began
    table["chunk"] = indices[0]
    append_chunk(table)
    return f"realizations {indices[0]}-{indices[-1]}"


def run(realizations: int, chunk: int, workers: int) -> None:
    """The missing realizations of every chunk up to ``realizations``, ``workers`` processes side by side; the run's
    wall time so far is saved in ``plain_mc_walls.json`` as each chunk finishes, so a killed run keeps its time too."""
    done = set(load_rows()["index"])
    chunks = [range(first, min(first + chunk, realizations)) for first in range(0, realizations, chunk)]
    missing = [todo for todo in ([i for i in share if i not in done] for share in chunks) if todo]
    runs = json.loads(WALLS.read_text()) if WALLS.exists() else []
    this = {"commit": commit(), "chunks": 0, "workers": workers, "wall_s": 0.0}
    runs.append(this)
    began = time.perf_counter()
    with ProcessPoolExecutor(workers) as pool:
        for finished, label in enumerate(pool.map(run_chunk, missing), start=1):
            this |= {"chunks": finished, "wall_s": time.perf_counter() - began}
            WALLS.with_suffix(".tmp").write_text(json.dumps(runs, indent=1) + "\n")
            WALLS.with_suffix(".tmp").replace(WALLS)
            print(f"{label}: {finished} of {len(missing)} chunks, {this['wall_s']:.0f} s", flush=True)


def interval(values: np.ndarray, statistic) -> list[float]:
    """The statistic and its 95 % percentile bootstrap interval."""
    result = stats.bootstrap((values,), statistic, n_resamples=2000, method="percentile", random_state=0)
    return [float(statistic(values)), float(result.confidence_interval.low), float(result.confidence_interval.high)]


def report(against: Path | None) -> dict:
    """The plain Monte Carlo's estimates so far, beside the default run's at the same mesh."""
    table = load_rows()
    chunks = [rows for _, rows in table.groupby("chunk", sort=True)]  # each chunk's rows, by its first realization
    runout = table["runout_m"].to_numpy(dtype=float)
    runs = json.loads(WALLS.read_text()) if WALLS.exists() else []  # each run's wall time up to its last chunk
    record: dict = {
        "command": "python benchmarks/plain_mc.py --run --realizations 10000 --workers 2, "
        "then python benchmarks/plain_mc.py --against <run> (a default run: benchmarks/fresh_run.py --keep <run>)",
        "realizations": len(table),
        "statuses": table["status"].value_counts().to_dict(),
        "job_seconds": float(sum(chunk["chunk_seconds"].iloc[0] for chunk in chunks)),
        "wall_seconds": float(sum(r["wall_s"] for r in runs)),
        "chunks_with_wall": int(sum(r["chunks"] for r in runs)),
        "chunks": len(chunks),
        "runs": runs,
        "mean_runout_m": interval(runout, np.mean),
        "runout_exceeded_m": {
            str(p): interval(runout, lambda v, axis=-1, p=p: np.quantile(v, 1 - p, axis=axis)) for p in PROBABILITIES
        },
    }
    if against is not None:
        record["default"] = default_at_1m(against)
    return record


def default_at_1m(run: Path) -> dict:
    """A default run's case-1 answer at the Monte Carlo's mesh: mean R and the runouts exceeded with each P, with
    their intervals, from its pairs' 1 m partners corrected with its cheap route (rule multifidelity's
    estimators and design), and its best estimate of mean R at the converged mesh."""
    tables = run / "results" / "mc" / "case1"
    low, high = paired_rows(pd.read_csv(tables / "control.csv"), pd.read_csv(tables / "paired_coarse.csv"))
    strata = row_strata(json.loads((tables / "paired_plan.json").read_text()), low["index"].tolist(), len(high))
    high_r, low_r = high["runout_m"].to_numpy(float), low["runout_m"].to_numpy(float)
    mean = control_variate(high_r[:, None], low_r[:, None], 0.95, seed=0, strata=strata)
    d_m = distance_grid(np.concatenate([high_r, low_r]))
    curve = regression_control_variate(high_r, low_r, d_m, confidence=0.95, seed=0, strata=strata)
    bands = [rearranged(curve.estimate), rearranged(curve.lower), rearranged(curve.upper)]
    best = json.loads((run / "results" / "report" / "case1" / "multifidelity.json").read_text())
    converged = best["converged"]["means"]["runout_m"]
    return {
        "run": str(run),
        "run_commit": subprocess.run(
            ["git", "-C", str(run), "rev-parse", "--short=10", "HEAD"], capture_output=True, text=True
        ).stdout.strip(),
        "n_paired": len(high),
        "mean_runout_m": [float(mean.estimate[0]), float(mean.lower[0]), float(mean.upper[0])],
        "runout_exceeded_m": {str(p): [distance_at(d_m, band, p) for band in bands] for p in PROBABILITIES},
        "converged_mean_runout_m": [converged["estimate"], converged["lower"], converged["upper"]],
    }


def markdown(record: dict) -> str:
    """The report's lines."""
    mean = record["mean_runout_m"]
    lines = [
        "# A plain MPM Monte Carlo of case 1 at 1 m",
        "",
        f"{record['realizations']:,} realizations by the MPM at 1 m ({record['statuses']}), "
        f"{record['job_seconds'] / 3600:.2f} h of job time (one thread each, two processes side by side); wall "
        f"{record['wall_seconds'] / 3600:.2f} h for the {record['chunks_with_wall']} of its {record['chunks']} chunks "
        "whose run recorded its time (`python benchmarks/plain_mc.py --run`"
        + ("; partial until 10,000)." if record["realizations"] < 10000 else ")."),
        "",
        f"Mean runout {ends(mean)}; R exceeded with P "
        + " / ".join(f"{p}: {ends(v)}" for p, v in record["runout_exceeded_m"].items())
        + " (95 % percentile bootstrap).",
    ]
    if "default" in record:
        d = record["default"]
        mean, distances = d["mean_runout_m"], d["runout_exceeded_m"]
        lines += [
            "",
            f"The default run's answer at the same mesh (a fresh clone at {d['run_commit']}: its {d['n_paired']} pairs at 1 m corrected with "
            "its cheap route over 10,000, rule multifidelity's estimators): "
            f"mean runout {ends(mean)}; R exceeded with P "
            + " / ".join(f"{p}: {ends(v)}" for p, v in distances.items())
            + ". Its best estimate, at the converged mesh, is longer by the mesh step and not comparable here: "
            f"mean runout {ends(d['converged_mean_runout_m'])}.",
        ]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--run", action="store_true")
    parser.add_argument("--realizations", type=int, default=10000)
    parser.add_argument("--chunk", type=int, default=100)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--against", type=Path, default=None)
    args = parser.parse_args()
    if args.run:
        run(args.realizations, args.chunk, args.workers)
    record = report(args.against)
    (RESULTS / "plain_mc.json").write_text(json.dumps(record, indent=1) + "\n")
    (RESULTS / "plain_mc.md").write_text(markdown(record))
    print(markdown(record))


if __name__ == "__main__":
    main()
