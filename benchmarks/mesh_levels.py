"""The embedded MPM's mesh error on the Monte Carlo's own realizations, with intervals.

    python benchmarks/mesh_levels.py --run --cases case1 case3    # resumable: one file per run
    python benchmarks/mesh_levels.py                              # tables and plot from what is saved

Each realization is the default config's Monte Carlo realization (the top-level seed), drawn as the
pipeline's paired chunks draw it (``rgns.realizations.accurate_case_inputs``: the same slope and the
friction field on the 1 m grid at every mesh) and run as they run it (``run_realizations`` with the
embedded MPM, screening included), at cells h = 1, 0.5, 0.25 m (``--cells``). Every run is saved alone
to ``benchmarks/results/mesh_levels/<case>/h<h>/<index>.json`` as it finishes, so a killed run loses
only the realization in progress; realizations run in index order, every level of one before the
next, so the cases and levels stay paired whenever it stops.

The report takes, per case and quantity (the means of R, V and I; the runout and influence exceeded
with probability 0.5 and 0.1, the 1 - P quantiles over realizations; the indicators 1{R > r} at the runout
the 0.5 m level exceeds with those probabilities), over the realizations every level ran: the values per
level, the observed order p = log2(|f_1 - f_0.5| / |f_0.5 - f_0.25|) of the means, the Richardson value
f* = f_0.25 + (f_0.25 - f_0.5) / (2^p - 1) and the error of each level against it; each with a 95 %
percentile bootstrap interval over realizations (scipy.stats.bootstrap, paired). Writes
``mesh_levels.md``, ``mesh_levels.json`` and ``mesh_levels.png`` into benchmarks/results/.
"""
from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
from scipy import stats  # noqa: E402

from rgns.config import load_config  # noqa: E402
from rgns.montecarlo import CaseInputs, RunSettings, run_realizations  # noqa: E402
from rgns.realizations import accurate_case_inputs  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "benchmarks" / "results"
RUNS = OUT / "mesh_levels"
METRICS = ("runout_m", "volume_m2", "influence_m")
PROBABILITIES = (0.5, 0.1)
RESAMPLES = 4000
ASYMPTOTIC = (0.5, 3.0)  # an order inside this is taken as the asymptotic range (as benchmarks/convergence.py)


def run_file(case: str, cell: float, index: int) -> Path:
    return RUNS / case / f"h{cell:g}" / f"{index:04d}.json"


def run_settings(config: dict) -> RunSettings:
    """The Monte Carlo's run settings with the embedded MPM, as rule mc_paired_chunk runs it."""
    section = config["montecarlo"]
    params = {"montecarlo": {key: section[key] for key in ("simulator", "batch_size", "duration_s", "device",
                                                           "keep_frames", "rollout", "screen")}
              | {"simulator": "mpm", "keep_frames": "ends"},
              "mpm": config["mpm"], "metrics": config["metrics"]}
    return RunSettings.from_params(params)


def run(config: dict, cases: list[str], cells: list[float], realizations: int, first: int = 0) -> None:
    """Every missing (realization, case, cell) run from realization ``first`` on, saved one by one."""
    settings = run_settings(config)
    inputs = {(case, h): CaseInputs.from_params(asdict(accurate_case_inputs(config, case, h)))
              for case in cases for h in cells}
    for index in range(first, realizations):
        for case in cases:
            for h in cells:
                path = run_file(case, h, index)
                if path.exists():
                    continue
                start = time.perf_counter()
                row = run_realizations(inputs[case, h], [index], settings).iloc[0].to_dict()
                seconds = time.perf_counter() - start
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(json.dumps({k: (v.item() if hasattr(v, "item") else v) for k, v in row.items()}
                                           | {"seconds": seconds, "cell_size_m": h}, indent=1))
                print(f"{case} h {h:g} realization {index}: R {row['runout_m']:.2f} m, {seconds:.0f} s", flush=True)


def saved(case: str, cells: list[float]) -> tuple[np.ndarray, dict[str, np.ndarray], dict[float, float]]:
    """Indices every level ran, the metrics [level, realization] per key, the mean seconds per level."""
    found = [{int(p.stem) for p in (RUNS / case / f"h{h:g}").glob("*.json")} for h in cells]
    common = np.array(sorted(set.intersection(*found))) if found else np.array([], dtype=int)
    rows = [[json.loads(run_file(case, h, i).read_text()) for i in common] for h in cells]
    values = {key: np.array([[row[key] for row in level] for level in rows], dtype=float) for key in METRICS}
    seconds = {h: float(np.mean([row["seconds"] for row in level])) for h, level in zip(cells, rows)}
    return common, values, seconds


def richardson(means: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Observed order and Richardson value from level means [..., 3] (h, h/2, h/4 along the last axis)."""
    coarse, fine = means[..., 1] - means[..., 0], means[..., 2] - means[..., 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        order = np.log2(np.abs(coarse / fine))
        value = means[..., 2] + fine / (2.0 ** order - 1.0)
    return order, value


def fit(values: np.ndarray, reduce=np.mean, seed: int = 0) -> dict:
    """Level values (``reduce`` over realizations: the mean, or a quantile), order, Richardson value and
    level errors of values [3 levels, n], with paired bootstrap intervals over the realizations."""
    def statistic(*columns: np.ndarray, axis: int = -1) -> np.ndarray:
        levels = np.stack(columns, axis=0)  # [3, ..., n]
        means = np.moveaxis(reduce(levels, axis=axis), 0, -1)  # [..., 3]
        order, value = richardson(means)
        errors = means - value[..., None]
        return np.moveaxis(np.concatenate([means, order[..., None], value[..., None], errors], axis=-1), -1, 0)

    point = statistic(*values)
    boot = stats.bootstrap(tuple(values), statistic, paired=True, vectorized=True, n_resamples=RESAMPLES,
                           method="percentile", random_state=np.random.default_rng(seed))
    low, high = boot.confidence_interval
    names = ["mean_1", "mean_0.5", "mean_0.25", "order", "richardson", "error_1", "error_0.5", "error_0.25"]
    return {name: {"value": float(p), "lower": float(lo), "upper": float(hi)}
            for name, p, lo, hi in zip(names, point, low, high)}


def mesh_order(order: dict) -> list[float] | None:
    """[low, value, high] rounded, where the order's interval shows an asymptotic range; else None."""
    low, value, high = order["lower"], order["value"], order["upper"]
    inside = np.isfinite([low, value, high]).all() and ASYMPTOTIC[0] <= low and high <= ASYMPTOTIC[1]
    return [round(low, 2), round(value, 2), round(high, 2)] if inside else None


def exceeded_with(probability: float):
    """The reducer of the distance exceeded with ``probability`` (the 1 - P quantile over realizations)."""
    return lambda x, axis: np.quantile(x, 1.0 - probability, axis=axis)


def report(cases: list[str], cells: list[float]) -> None:
    lines = ["# The embedded MPM's mesh error on the Monte Carlo's realizations", "",
             "`python benchmarks/mesh_levels.py --run --cases case1 case3` then `python benchmarks/mesh_levels.py` "
             "(method: its docstring). B-spline shape functions, the default config's engine settings and "
             "run length; 95 % percentile bootstrap intervals over the realizations. Times: wall seconds per "
             "realization on one thread of a 2-core machine with other work running.", ""]
    record: dict = {}
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    for case in cases:
        indices, values, seconds = saved(case, cells)
        if len(indices) < 2:
            continue
        r_half = values["runout_m"][1]
        thresholds = {p: float(np.quantile(r_half, 1.0 - p)) for p in PROBABILITIES}
        fits = {key: fit(v) for key, v in values.items()}
        for p in PROBABILITIES:
            for key in ("runout_m", "influence_m"):
                fits[f"{key} exceeded with P {p}"] = fit(values[key], exceeded_with(p))
        for p, r in thresholds.items():  # the indicators the exceedance curve averages, at the 0.5 m level's distances
            fits[f"P(R > {r:.2f} m)"] = fit((values["runout_m"] > r).astype(float))
        record[case] = {"realizations": indices.tolist(), "seconds": seconds, "thresholds_m": thresholds,
                        "fits": fits}
        lines += [f"## {case}: {len(indices)} realizations ({', '.join(map(str, indices))}) at every level", "",
                  "Seconds per realization: " + ", ".join(f"h {h:g} m {s:.0f} s" for h, s in seconds.items()) + ".", "",
                  "| quantity | mean at h = 1 / 0.5 / 0.25 m | order p [95 %] | Richardson f* [95 %] | "
                  "error of 0.5 m (f_0.5 − f*) [95 %] | error of 0.25 m [95 %] |",
                  "|---|---|---|---|---|---|"]

        def cell(entry: dict, digits: int = 2) -> str:
            return f"{entry['value']:.{digits}f} [{entry['lower']:.{digits}f}, {entry['upper']:.{digits}f}]"

        for key, f in fits.items():
            means = " / ".join(f"{f[f'mean_{h:g}']['value']:.2f}" for h in cells)
            lines.append(f"| {key} | {means} | {cell(f['order'])} | {cell(f['richardson'])} | "
                         f"{cell(f['error_0.5'])} | {cell(f['error_0.25'])} |")
        suggested = {key: mesh_order(fits[key]["order"]) for key in METRICS}
        record[case]["mesh_order"] = suggested
        lines += ["", f"As `montecarlo.fidelity.mesh_order` (an order whose interval lies within {ASYMPTOTIC[0]:g}–"
                  f"{ASYMPTOTIC[1]:g}, else null: no asymptotic range): `{json.dumps(suggested)}`."]
        lines.append("")
        for ax, key in zip(axes, METRICS):
            f = fits[key]
            ax.plot(cells, [f[f"mean_{h:g}"]["value"] for h in cells], "o-", label=f"{case} (n {len(indices)})")
            ax.errorbar([0.0], [f["richardson"]["value"]], yerr=[[f["richardson"]["value"] - f["richardson"]["lower"]],
                        [f["richardson"]["upper"] - f["richardson"]["value"]]], fmt="s", capsize=3,
                        color=ax.lines[-1].get_color())
            ax.set_xlabel("cell size h (m); h = 0: Richardson value [95 %]")
            ax.set_title(f"mean {key}")
    for ax in axes:
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(OUT / "mesh_levels.png", dpi=130)
    plt.close(fig)
    lines += ["A negative error is an answer short of the converged one. The order is that of the means; where "
              "its interval reaches below 0.5 or the differences change sign the Richardson value is not to "
              "be trusted, and the interval says so by its width.", ""]
    (OUT / "mesh_levels.md").write_text("\n".join(lines))
    (OUT / "mesh_levels.json").write_text(json.dumps(record, indent=1))
    print("\n".join(lines))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--run", action="store_true", help="run what is missing before the report")
    parser.add_argument("--cases", nargs="+", default=["case1", "case3"])
    parser.add_argument("--cells", nargs="+", type=float, default=[1.0, 0.5, 0.25])
    parser.add_argument("--realizations", type=int, default=8, help="run realizations first … this - 1")
    parser.add_argument("--first", type=int, default=0, help="the first realization to run (split across processes)")
    args = parser.parse_args()
    if args.run:
        torch.set_num_threads(1)
        run(load_config(REPO / "config" / "config.yaml"), args.cases, args.cells, args.realizations, args.first)
    report(args.cases, args.cells)


if __name__ == "__main__":
    main()
