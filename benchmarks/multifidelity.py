"""Multi-fidelity against plain high-fidelity Monte Carlo at equal wall time, on the same realizations.

    python benchmarks/multifidelity.py --realizations 96 --workers 2   # runs, then analyses
    python benchmarks/multifidelity.py --analyse       # again from multifidelity.json (+ mc_routes.json's GNS,
                                                       #   + the shipped end-state surrogate, run here)

A pool of default-config case-1 realizations (drawn as ``rgns.montecarlo.runs`` draws them, the field
on the 1 m grid so every mesh samples the same field) is run by the embedded MPM at 0.5 m cells
(the high fidelity: 1.2 % of range from the 0.5 m / cfl 0.1 reference in ``suite.md``) and by the
cheap routes: the MPM at 1 m (the default) and at 2 m, the geometry-general end-state surrogate
(``rgns/models/endstate_general.pt``, run here on the same realizations: it costs milliseconds) and, when
``benchmarks/results/mc_routes.json`` holds them for the same realizations, the shipped GNS. Wall time per realization is measured per
route (one thread per worker; each batch of montecarlo.batch_size runs every MPM route in turn, so
load weighs on each alike).

The pool is the population: its high-fidelity mean of each quantity Q (mean R; P(R > r) at r =
the pool's 50 % and 10 % exceedance distances) is the reference. At equal wall time B, plain MC
draws B / c_H realizations with replacement; multi-fidelity MC draws n pairs and N = r n cheap
runs (r the MFMC optimal ratio from the pool's correlation and the measured costs) with
n c_H + N c_L = B, and combines them with ``rgns.fidelity.multifidelity.control_variate``. The mean squared
error over 2,000 draws per budget, plain over multi-fidelity, is the speed-up at equal error (both
errors scale as 1/B). Writes ``benchmarks/results/multifidelity.json``, ``multifidelity.md`` and
``multifidelity.png``.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
from suite import case_inputs, measured  # noqa: E402  (benchmarks/suite.py: the same drawing and measuring)

from rgns.config import load_config  # noqa: E402
from rgns.engines.batch import simulate_mpm  # noqa: E402
from rgns.engines.settings import MpmSettings  # noqa: E402
from rgns.fidelity.multifidelity import (
    optimal_ratio,
    point_estimate,
    predicted_exceedance,  # noqa: E402
    regression_point_estimate,
    speedup,
)
from rgns.montecarlo.runs import simulate_endstate  # noqa: E402
from rgns.scene.realizations import FINISHED, draw_realization  # noqa: E402
from rgns.surrogates.endstate.model import load_model  # noqa: E402
from rgns.trajectories import frame_count  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "benchmarks" / "results"
HIGH = "MPM 0.5 m"
# name: (cell size, overrides of mpm.embedded); CFL 0.8: larger steps, tried as the cheap route and rejected
MPM_ROUTES = {
    HIGH: (0.5, {}),
    "MPM 1 m": (1.0, {}),
    "MPM 1 m, cfl 0.8": (1.0, {"cfl": 0.8, "dt_max_s": 0.0125}),
    "MPM 2 m": (2.0, {}),
}
DRAWS = 2000


def run_chunk(indices: list[int]) -> dict[str, tuple[list[dict], float]]:
    """Per MPM route: the rows of realizations ``indices`` and their wall time (the routes one after
    another on the same realizations, so the machine's load weighs on each alike)."""
    torch.set_num_threads(1)
    config = load_config(REPO / "config" / "config.yaml")
    out = {}
    for name, (cell_size_m, embedded) in MPM_ROUTES.items():
        mpm = MpmSettings.from_config(config["mpm"] | {"embedded": config["mpm"]["embedded"] | embedded})
        batch = [draw_realization(case_inputs(config, "case1", cell_size_m), i) for i in indices]
        start = time.perf_counter()
        simulated = simulate_mpm(batch, mpm, frame_count(mpm.duration_s, mpm.frame_interval_s), keep="ends")
        seconds = time.perf_counter() - start
        rows = measured(batch, simulated, config)
        out[name] = (
            [{k: row[k] for k in ("index", "status", "runout_m", "volume_m2", "influence_m")} for row in rows],
            seconds,
        )
    return out


def run_routes(n: int, workers: int) -> dict:
    """Every MPM route over realizations 0..n-1, in batches of montecarlo.batch_size (as the pipeline's
    chunks run them) spread over ``workers`` processes."""
    size = load_config(REPO / "config" / "config.yaml")["montecarlo"]["batch_size"]
    chunks = [list(range(i, min(i + size, n))) for i in range(0, n, size)]
    with ProcessPoolExecutor(workers) as pool:
        results = []
        for done, result in enumerate(pool.map(run_chunk, chunks), start=1):
            results.append(result)
            print(f"chunk {done} of {len(chunks)} done", flush=True)
    routes = {}
    for name in MPM_ROUTES:
        rows = [row for result in results for row in result[name][0]]
        routes[name] = {"rows": rows, "s_per_realization": sum(result[name][1] for result in results) / n}
        print(f"{name}: {routes[name]['s_per_realization']:.2f} s per realization", flush=True)
    return routes


def add_gns_route(routes: dict, n: int) -> None:
    """The shipped GNS's rows of the same realizations, from ``mc_routes.json``, when it holds them."""
    path = OUT / "mc_routes.json"
    if path.exists():
        record = json.loads(path.read_text())["routes"]["gns"]
        if len(record["rows"]) >= n:
            routes["GNS (shipped)"] = {"rows": record["rows"][:n], "s_per_realization": record["s_per_realization"]}


def add_endstate_route(
    routes: dict,
    n: int,
    model_path: Path = REPO / "rgns" / "models" / "endstate_general.pt",
    name: str = "end-state surrogate (general)",
) -> None:
    """An end-state surrogate's rows of realizations 0..n-1 and its seconds per realization, as route
    ``name`` (one thread, the batches of montecarlo.batch_size the pipeline uses; drawing not counted,
    as for MPM)."""
    torch.set_num_threads(1)
    config = load_config(REPO / "config" / "config.yaml")
    model = load_model(model_path)
    size = config["montecarlo"]["batch_size"]
    rows, seconds = [], 0.0
    for first in range(0, n, size):
        batch = [draw_realization(case_inputs(config, "case1", 1.0), i) for i in range(first, min(first + size, n))]
        start = time.perf_counter()
        simulated = simulate_endstate(model, batch)
        seconds += time.perf_counter() - start
        rows += [
            {k: row[k] for k in ("index", "status", "runout_m", "volume_m2", "influence_m")}
            for row in measured(batch, simulated, config)
        ]
    routes[name] = {"rows": rows, "s_per_realization": seconds / n}


QUANTITY_NAMES = (
    "mean R",
    "P(R > r50)",
    "P(R > r10)",
    "P(R > r50), regression",
    "P(R > r10), regression",
    "mean V",
    "mean I",
)
MEANS = {0: "runout_m", 5: "volume_m2", 6: "influence_m"}  # quantity index: the metric whose mean it is


def mse_over_draws(
    high_v: np.ndarray,
    low_v: np.ndarray,
    thresholds: np.ndarray,
    n_pairs: int,
    n_low: int,
    k: int,
    truth: float,
    rng: np.random.Generator,
) -> float:
    """Mean squared error of quantity k's multi-fidelity estimate over DRAWS draws of n_pairs paired and
    n_low − n_pairs unpaired realizations (with replacement) from the pool; ``high_v``, ``low_v`` are the
    values of the metric it is about (R, or V or I for their means)."""
    pick = rng.integers(0, high_v.size, (DRAWS, n_low))
    h, low = high_v[pick[:, :n_pairs]], low_v[pick]
    if k in MEANS:
        estimate = point_estimate(h, low[:, :n_pairs], low[:, n_pairs:], axis=1)
    elif k < 3:
        t = thresholds[k - 1]
        estimate = point_estimate(
            (h > t).astype(float), (low[:, :n_pairs] > t).astype(float), (low[:, n_pairs:] > t).astype(float), axis=1
        )
    else:
        estimate = regression_point_estimate(
            h[..., None], low[:, :n_pairs, None], low[:, n_pairs:, None], thresholds[[k - 3]]
        )[:, 0]
    return float(((estimate - truth) ** 2).mean())


def analyse(record: dict, budgets_in_high_runs: tuple[int, ...] = (8, 16, 32), seed: int = 0) -> dict:
    """Plain high-fidelity against multi-fidelity MSE at equal wall time, per cheap route and quantity:
    the means of R, V and I, and P(R > r) by the indicator control variate 1[l > r] and by the
    regression one (the cheap route's predicted P(h > r | l), ``regression_control_variate``)."""
    routes = record["routes"]
    ok = np.array([all(r["rows"][i]["status"] in FINISHED for r in routes.values()) for i in range(record["n"])])

    def values(route: dict, key: str) -> np.ndarray:
        return np.array([row[key] for row in route["rows"]])[ok]

    def metric_of(k: int) -> str:
        return MEANS.get(k, "runout_m")

    high_r = values(routes[HIGH], "runout_m")
    thresholds = np.quantile(high_r, [0.5, 0.9])
    high_q = np.column_stack(
        [
            high_r,
            high_r[:, None] > thresholds,
            high_r[:, None] > thresholds,
            values(routes[HIGH], "volume_m2"),
            values(routes[HIGH], "influence_m"),
        ]
    )
    truth = high_q.mean(axis=0)
    c_high = routes[HIGH]["s_per_realization"]
    rng = np.random.default_rng(seed)
    out = {
        "thresholds_m": thresholds.tolist(),
        "truth": truth.tolist(),
        "n_ok": int(ok.sum()),
        "quantities": list(QUANTITY_NAMES),
        "cheap": {},
    }
    for name, route in routes.items():
        if name == HIGH:
            continue
        low_r = values(route, "runout_m")
        predicted = predicted_exceedance(high_r, low_r, low_r, thresholds)  # the pool's regression control variate
        low_vi = [values(route, "volume_m2"), values(route, "influence_m")]
        low_q = np.column_stack([low_r, low_r[:, None] > thresholds, predicted, *low_vi])
        c_low = route["s_per_realization"]
        correlation = [
            float(np.corrcoef(high_q[:, k], low_q[:, k])[0, 1]) if low_q[:, k].std() > 0 else 0.0
            for k in range(len(QUANTITY_NAMES))
        ]
        ratios = [optimal_ratio(c_high, c_low, rho) for rho in correlation]
        result = {
            "s_per_realization": c_low,
            "correlation": correlation,
            "ratio": ratios,
            "bias": (
                np.column_stack([low_r, low_r[:, None] > thresholds, low_r[:, None] > thresholds, *low_vi]).mean(0)
                - truth
            ).tolist(),
            "predicted_speedup": [speedup(c_high, c_low, rho) for rho in correlation],
            "budgets": [],
        }
        for budget in budgets_in_high_runs:
            plain = np.array([high_q[rng.integers(0, high_r.size, budget)].mean(0) for _ in range(DRAWS)])
            row = {
                "high_runs": budget,
                "n_pairs": [],
                "n_low": [],
                "mse_plain": ((plain - truth) ** 2).mean(0).tolist(),
                "mse_multi": [],
            }
            for k, ratio in enumerate(ratios):  # each quantity with its own optimal allocation
                n_pairs = max(3, int(budget * c_high // (c_high + ratio * c_low)))
                n_low = max(n_pairs, int((budget - n_pairs) * c_high // c_low))
                row["n_pairs"].append(n_pairs)
                row["n_low"].append(n_low)
                row["mse_multi"].append(
                    mse_over_draws(
                        values(routes[HIGH], metric_of(k)),
                        values(route, metric_of(k)),
                        thresholds,
                        n_pairs,
                        n_low,
                        k,
                        truth[k],
                        rng,
                    )
                )
            row["speedup"] = (np.array(row["mse_plain"]) / np.array(row["mse_multi"])).tolist()
            result["budgets"].append(row)
        out["cheap"][name] = result
    return out


def markdown(record: dict) -> str:
    a = record["analysis"]
    lines = [
        f"Case 1, {a['n_ok']} realizations run by every route (the pool); high fidelity {HIGH} at "
        f"{record['routes'][HIGH]['s_per_realization']:.2f} s per realization; r50 / r10 = "
        f"{a['thresholds_m'][0]:.2f} / {a['thresholds_m'][1]:.2f} m; {DRAWS} draws per budget; machine: "
        f"{record['machine']}",
        "",
        "| cheap route | s per realization | quantity | correlation | bias of the cheap route | N/n | "
        "predicted speed-up | measured speed-up at 8 / 16 / 32 high-fidelity runs' time |",
        "|---|---:|---|---:|---:|---:|---:|---|",
    ]
    for name, r in a["cheap"].items():
        for k, quantity in enumerate(QUANTITY_NAMES):
            measured = " / ".join(f"{b['speedup'][k]:.2f}" for b in r["budgets"])
            lines.append(
                f"| {name} | {r['s_per_realization']:.2f} | {quantity} | {r['correlation'][k]:.3f} | "
                f"{r['bias'][k]:+.3f} | {r['ratio'][k]:.2f} | {r['predicted_speedup'][k]:.2f} | {measured} |"
            )
    return "\n".join(lines) + "\n"


def plot(record: dict, path: Path) -> None:
    a = record["analysis"]
    fig, axes = plt.subplots(1, len(QUANTITY_NAMES), figsize=(4.3 * len(QUANTITY_NAMES), 4))
    c_high = record["routes"][HIGH]["s_per_realization"]
    for k, (ax, quantity) in enumerate(zip(axes, QUANTITY_NAMES)):
        first = next(iter(a["cheap"].values()))
        cost = [b["high_runs"] * c_high for b in first["budgets"]]
        ax.loglog(cost, [b["mse_plain"][k] for b in first["budgets"]], "k-o", label=f"plain, {HIGH}")
        for j, (name, r) in enumerate(a["cheap"].items()):
            ax.loglog(
                cost,
                [b["mse_multi"][k] for b in r["budgets"]],
                "--o",
                color=f"C{j}",
                label=f"multi-fidelity, cheap: {name}",
            )
        ax.set_title(quantity)
        ax.set_xlabel("wall time (s, one thread)")
        ax.set_ylabel("mean squared error")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--realizations", type=int, default=96)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--analyse", action="store_true", help="analyse the existing multifidelity.json again")
    args = parser.parse_args()
    path = OUT / "multifidelity.json"
    if args.analyse:
        record = json.loads(path.read_text())
    else:
        record = {
            "n": args.realizations,
            "routes": run_routes(args.realizations, args.workers),
            "machine": f"{platform.processor() or platform.machine()}, torch {torch.__version__}, "
            f"{args.workers} workers of 1 thread, CPU",
        }
    add_gns_route(record["routes"], record["n"])
    add_endstate_route(record["routes"], record["n"])
    record["analysis"] = analyse(record)
    path.write_text(json.dumps(record, indent=1, default=float) + "\n")
    (OUT / "multifidelity.md").write_text(markdown(record))
    plot(record, OUT / "multifidelity.png")
    print(markdown(record))


if __name__ == "__main__":
    main()
