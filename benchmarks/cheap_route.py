"""Which shipped end-state surrogate correlates best with the accurate (0.5 m) MPM on case 1: the cheap route.

    .venv/bin/python benchmarks/cheap_route.py

Each model (``rgns/models/endstate*.pt``) runs realizations 0-127 of case 1 of the default config (its top-level
seed) as the pipeline's Monte Carlo runs them (``CaseInputs.from_config``, ``run_realizations`` with simulator
"endstate", one thread); the MPM's are the saved GPU runs of ``benchmarks/mesh_levels.py``
(``benchmarks/results/mesh_levels_gpu_runs.jsonl``, the same realizations: checked here by particle count and mean friction
against its 1 m runs). Per model and metric: the Pearson correlation with the 0.5 m MPM, R² of the model as a
predictor of it, the mean bias (model - MPM) and the correlation with the 1 m MPM, each with a 95 % percentile
paired bootstrap interval over the realizations (scipy.stats.bootstrap), on all 128 and on 64-127 alone.
Writes ``benchmarks/results/cheap_route.{md,json}``.
"""

from __future__ import annotations

import json
import time
from dataclasses import replace
from pathlib import Path

import mesh_levels as ml
import numpy as np
import torch

from rgns.config import load_config
from rgns.montecarlo.runs import CaseInputs, run_realizations
from rgns.provenance import commit
from rgns.scene.realizations import draw_realization
from rgns.surrogates.endstate.model import load_model

REPO = ml.REPO
MODELS = {name: REPO / "rgns" / "models" / f"{name}.pt" for name in ("endstate_general", "endstate_tuned")}
REALIZATIONS = 128
UNTOUCHED = 64  # realizations 0-63 were the pool the tuned model was judged on (hifi_surrogate.md)
STATS = ("r_0.5", "R2_0.5", "bias_0.5", "r_1")


def pearson(x: np.ndarray, y: np.ndarray, axis: int = -1) -> np.ndarray:
    dx, dy = x - x.mean(axis, keepdims=True), y - y.mean(axis, keepdims=True)
    return (dx * dy).sum(axis) / np.sqrt((dx**2).sum(axis) * (dy**2).sum(axis))


def statistic(model: np.ndarray, half: np.ndarray, one: np.ndarray, axis: int = -1) -> np.ndarray:
    """[r with 0.5 m, R² against 0.5 m, mean bias (model - 0.5 m), r with 1 m] over the realizations."""
    residual = ((half - model) ** 2).sum(axis)
    spread = ((half - half.mean(axis, keepdims=True)) ** 2).sum(axis)
    return np.stack(
        [pearson(model, half, axis), 1.0 - residual / spread, (model - half).mean(axis), pearson(model, one, axis)]
    )


def difference(first: np.ndarray, second: np.ndarray, half: np.ndarray, axis: int = -1) -> np.ndarray:
    return pearson(first, half, axis) - pearson(second, half, axis)


def run_model(path: Path, config: dict, inputs: CaseInputs) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """The model's metrics over realizations 0..REALIZATIONS-1, and its seconds per realization (the whole
    run_realizations, and the network alone)."""
    settings = replace(ml.run_settings(config), simulator="endstate")
    model = load_model(path)
    start = time.perf_counter()
    table = run_realizations(inputs, list(range(REALIZATIONS)), settings, model)
    pipeline_s = (time.perf_counter() - start) / REALIZATIONS
    batch = [draw_realization(inputs, i) for i in range(REALIZATIONS)]
    start = time.perf_counter()
    for first in range(0, REALIZATIONS, settings.batch_size):
        part = batch[first : first + settings.batch_size]
        model.predict([r.scene.positions for r in part], [r.friction_deg for r in part])
    network_s = (time.perf_counter() - start) / REALIZATIONS
    assert (table["status"] == "ok").all() and (table["index"] == np.arange(REALIZATIONS)).all()
    runs = ml.load_runs(ml.GPU_RUNS)
    same = [runs["case1", 1.0, i] for i in range(REALIZATIONS)]
    assert np.array_equal(table["n_particles"], [row["n_particles"] for row in same]), "not the MPM's realizations"
    assert np.allclose(table["friction_mean_deg"], [row["friction_mean_deg"] for row in same]), "not the same fields"
    return {k: table[k].to_numpy(float) for k in ml.METRICS}, {"pipeline": pipeline_s, "network": network_s}


def interval(entry: list[float], digits: int = 3) -> str:
    return f"{entry[0]:.{digits}f} [{entry[1]:.{digits}f}, {entry[2]:.{digits}f}]"


def main() -> None:
    torch.set_num_threads(1)
    began = time.perf_counter()
    ml.RUNS = ml.GPU_RUNS
    config = load_config(REPO / "config" / "config.yaml")
    inputs = CaseInputs.from_config(config, "case1")
    indices, mpm, mpm_s = ml.saved("case1", [1.0, 0.5], REALIZATIONS)
    assert np.array_equal(indices, np.arange(REALIZATIONS)), "the MPM runs lack realizations"
    routes = {name: run_model(path, config, inputs) for name, path in MODELS.items()}
    routes["MPM 1 m (reference)"] = ({k: mpm[k][0] for k in ml.METRICS}, {"pipeline": mpm_s[1.0], "network": None})
    subsets = {"all 128 (0-127)": slice(0, REALIZATIONS), f"untouched ({UNTOUCHED}-127)": slice(UNTOUCHED, None)}
    result: dict = {
        "seed": config["seed"],
        "commit": commit(),
        "command": "python benchmarks/cheap_route.py",
        "subsets": {},
    }
    for subset, rows in subsets.items():
        result["subsets"][subset] = {
            name: {
                "seconds": seconds,
                **{
                    key: dict(
                        zip(
                            STATS,
                            np.array(
                                ml.paired_bootstrap(
                                    (values[key][rows], mpm[key][1][rows], mpm[key][0][rows]), statistic, 0
                                )
                            ).T.tolist(),
                        )
                    )
                    for key in ml.METRICS
                },
            }
            for name, (values, seconds) in routes.items()
        }
    untouched = slice(UNTOUCHED, None)
    ranked = sorted(MODELS, key=lambda n: -result["subsets"][f"untouched ({UNTOUCHED}-127)"][n]["runout_m"]["r_0.5"][0])
    best, second = ranked[:2]
    gap = ml.paired_bootstrap(
        (
            routes[best][0]["runout_m"][untouched],
            routes[second][0]["runout_m"][untouched],
            mpm["runout_m"][1][untouched],
        ),
        difference,
        1,
    )
    result["best"] = {"model": best, "second": second, "r_difference": [float(v) for v in gap]}
    result["seconds_total"] = time.perf_counter() - began
    text = markdown(result)
    (ml.OUT / "cheap_route.json").write_text(json.dumps(result, indent=1) + "\n")
    (ml.OUT / "cheap_route.md").write_text(text)
    print(text)


def markdown(result: dict) -> str:
    lines = [
        "# The cheap route: which end-state surrogate correlates best with the 0.5 m MPM (case 1)",
        "",
        f"`.venv/bin/python benchmarks/cheap_route.py` at commit {result['commit']} (method: its docstring); "
        f"{result['seconds_total']:.0f} s in all. Realizations 0-127 of case 1, default config (seed "
        f"{result['seed']}); MPM: the GPU runs of `benchmarks/results/mesh_levels_gpu_runs.jsonl` at 0.5 and 1 m. Realizations "
        f"0-{UNTOUCHED - 1} were the pool on which the tuned model was judged (`hifi_surrogate.md`); "
        f"{UNTOUCHED}-127 are untouched by any choice. R²: 1 - Σ(MPM - model)² / Σ(MPM - mean)², the model as a "
        "predictor of the 0.5 m MPM (its bias counts against it). Seconds per realization on one thread of a 2-core "
        "machine shared with other work: the whole `run_realizations` (draw, measure) / the network alone; the 1 m "
        "MPM's are wall seconds per realization of a GPU batch of 64, not comparable.",
    ]
    for subset, routes in result["subsets"].items():
        lines += [
            "",
            f"## {subset}",
            "",
            "| model | metric | r with 0.5 m MPM [95 %] | R² vs 0.5 m [95 %] | bias (model − MPM) [95 %] | "
            "r with 1 m MPM [95 %] | s per realization |",
            "|---|---|---|---|---|---|---|",
        ]
        for name, record in routes.items():
            seconds = record["seconds"]
            network = "—" if seconds["network"] is None else f"{seconds['network']:.4f}"
            for key in ml.METRICS:
                entry = record[key]
                lines.append(
                    f"| {name} | {key} | {interval(entry['r_0.5'])} | {interval(entry['R2_0.5'])} | "
                    f"{interval(entry['bias_0.5'], 2)} | {interval(entry['r_1'])} | "
                    f"{seconds['pipeline']:.3f} / {network} |"
                )
    best = result["best"]
    routes = result["subsets"][f"untouched ({UNTOUCHED}-127)"]
    first, second = (routes[best[k]]["runout_m"]["r_0.5"] for k in ("model", "second"))
    outside = first[1] > second[2]
    d = best["r_difference"]
    significant = d[1] > 0
    lines += [
        "",
        f"Best for the runout on the untouched realizations ({UNTOUCHED}-127): **{best['model']}**, r = "
        f"{interval(first)} against {best['second']}'s {interval(second)}; the intervals "
        f"{'do not overlap' if outside else 'overlap'} (paired bootstrap of the difference "
        f"{interval(d)}: {'outside' if significant else 'within'} the sampling error).",
        "",
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    main()
