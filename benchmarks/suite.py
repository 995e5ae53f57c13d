"""Time against error, side by side on the same realizations: MPM settings, GNS variants, skipping.

    python benchmarks/suite.py                       # the shipped GNS against the MPM routes
    python benchmarks/suite.py --realizations 4 --train-steps 500    # + GNS variants trained here
    python benchmarks/suite.py --cbgeo /path/to/mpm  # add the real CB-Geo to an existing suite.json
    python benchmarks/suite.py --endstate            # add the shipped end-state surrogate to it

Every route simulates the same default-config case-1 Monte Carlo realizations (drawn exactly as
``rgns.montecarlo.runs`` draws them; the random field on a fixed 1 m grid so a finer mesh samples the
same field) for the full 10 s, and is measured against one reference: the embedded MPM at 0.5 m
cells and cfl 0.1 with early stop off. Error of a metric (R, V, I) = mean absolute difference
from the reference over the realizations, in % of the reference's range over them; "error" is the
mean of the three. Wall time per realization is the batch's wall time over its size (one CPU
thread; a GNS rollout includes its MPM warm-up, ``montecarlo.rollout.warmup_s``).

* MPM: cell size 2 / 1 / 0.5 m, cfl 0.1 / 0.2 / 0.5, early stop on / off.
* GNS: the shipped model (rgns/models/gns.pt, or ``--model``) with rest-skipping, early stop, both
  (the Monte Carlo default) or neither, and both at other rest thresholds; with ``--train-steps``,
  architecture variants trained here on the pipeline's dataset (``results/dataset/train.h5`` of
  a ``gns.model: train`` run) for that many steps (checkpoints in benchmarks/results/models/,
  resumed when run again).
* End-state surrogate: the geometry-general model (rgns/models/endstate_general.pt), one network evaluation per
  realization in batches of montecarlo.batch_size, no MPM; ``--endstate`` adds it to an existing
  ``suite.json`` (the same realizations).
* CB-Geo (``--cbgeo``): the real ``mpm`` binary on the same realizations at the default 1 m cells,
  one thread, one realization after another, added to an existing ``suite.json`` (it is slow and
  cannot be installed from a package registry).
* Screen: a stronger variant of case 1 (friction mean 45 deg) where some realizations stand: how
  many the limit-equilibrium screen skips, whether the MPM would have run any of them out, and the
  time it saves.

Writes ``benchmarks/results/suite.json``, ``suite.md`` and ``pareto.png`` (time per realization
against error, every route, the Pareto front drawn).
"""

from __future__ import annotations

import argparse
import copy
import json
import platform
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402

from rgns.config import load_config  # noqa: E402
from rgns.engines.batch import simulate_mpm
from rgns.engines.cbgeo.runner import MPMDiverged, run_cbgeo, trajectory_from_cbgeo  # noqa: E402
from rgns.engines.cbgeo.writer import write_case  # noqa: E402
from rgns.engines.metrics import MetricSettings  # noqa: E402
from rgns.engines.settings import MpmSettings  # noqa: E402
from rgns.montecarlo.runs import (
    Simulated,
    factor_of_safety,
    measure,
    rollout_settings,
    simulate_endstate,  # noqa: E402
    simulate_gns,
)
from rgns.montecarlo.screening import ScreenSettings  # noqa: E402
from rgns.scene.realizations import CaseInputs, draw_realization  # noqa: E402
from rgns.surrogates.endstate.model import load_model  # noqa: E402
from rgns.surrogates.gns.rollout import RolloutSettings  # noqa: E402
from rgns.surrogates.gns.train import load_simulator, settings_from_config, train  # noqa: E402
from rgns.surrogates.shipped import MODELS  # noqa: E402
from rgns.trajectories import frame_count  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "benchmarks" / "results"
METRICS = ("runout_m", "volume_m2", "influence_m")


def case_inputs(config: dict, case: str, cell_size_m: float, friction_mean_deg: float | None = None) -> CaseInputs:
    """Case inputs at a given mesh cell size, the field on a fixed 1 m grid."""
    config = copy.deepcopy(config)
    config["mesh"]["cell_size_m"] = cell_size_m
    config["random_field"]["grid_spacing_m"] = 1.0
    if friction_mean_deg is not None:
        config["sets"][case][0]["friction_mean_deg"] = friction_mean_deg
    return CaseInputs.from_config(config, case)


def measured(batch, simulated, config: dict) -> list[dict]:
    """Each realization's Monte Carlo table row, measured as rgns.montecarlo.runs measures it."""
    mpm = config["mpm"]
    return [
        measure(
            r,
            result,
            MetricSettings(**config["metrics"]),
            mpm["density_kg_m3"],
            mpm["frame_interval_s"],
            mpm["gravity_m_s2"],
        )
        for r, result in zip(batch, simulated)
    ]


def errors(rows: list[dict], reference: list[dict]) -> dict:
    """Mean absolute error of R, V, I against the reference, in % of the reference's range."""
    out = {}
    pairs = [(r, ref) for r, ref in zip(rows, reference) if r["status"] == "ok" and ref["status"] == "ok"]
    for key in METRICS:
        values = np.array([ref[key] for ref in reference if ref["status"] == "ok"])
        spread = float(np.ptp(values)) or 1.0
        out[key] = (
            float(np.mean([abs(r[key] - ref[key]) for r, ref in pairs]) / spread * 100) if pairs else float("nan")
        )
    out["mean"] = float(np.mean([out[key] for key in METRICS]))
    out["ok"] = len(pairs)
    return out


def mpm_settings(config: dict, **embedded) -> MpmSettings:
    mpm = MpmSettings.from_config(config["mpm"])
    return replace(mpm, embedded=replace(mpm.embedded, **embedded))


def run_mpm_route(config: dict, cell_size_m: float, n: int, frames: int, **embedded) -> tuple[list[dict], float]:
    batch = [draw_realization(case_inputs(config, "case1", cell_size_m), i) for i in range(n)]
    start = time.perf_counter()
    simulated = simulate_mpm(batch, mpm_settings(config, **embedded), frames, keep="ends")
    return measured(batch, simulated, config), (time.perf_counter() - start) / n


def run_gns_route(config: dict, model: Path, n: int, frames: int, rollout: RolloutSettings) -> tuple[list[dict], float]:
    simulator = load_simulator(model).eval()
    batch = [draw_realization(case_inputs(config, "case1", config["mesh"]["cell_size_m"]), i) for i in range(n)]
    start = time.perf_counter()
    simulated = simulate_gns(simulator, batch, MpmSettings.from_config(config["mpm"]), frames, "cpu", rollout)
    return measured(batch, simulated, config), (time.perf_counter() - start) / n


def run_endstate_route(config: dict, model: Path, n: int) -> tuple[list[dict], float]:
    """The end-state surrogate on the same realizations, in the Monte Carlo's batches."""
    surrogate = load_model(model)
    batch = [draw_realization(case_inputs(config, "case1", config["mesh"]["cell_size_m"]), i) for i in range(n)]
    size = config["montecarlo"]["batch_size"]
    start = time.perf_counter()
    simulated = [s for k in range(0, n, size) for s in simulate_endstate(surrogate, batch[k : k + size])]
    return measured(batch, simulated, config), (time.perf_counter() - start) / n


def run_cbgeo_route(config: dict, binary: str, n: int, frames: int) -> tuple[list[dict], float]:
    """The same realizations through the real CB-Geo ``mpm`` (one thread, one after another);
    the time includes writing each case and reading its output back."""
    mpm = config["mpm"]
    case_settings = {key: value for key, value in mpm.items() if key not in ("engine", "cbgeo")}
    case_settings["duration_s"] = (frames - 1) * mpm["frame_interval_s"]
    options = {"binary": binary, "threads": 1, "keep_raw": False, "timeout_s": 7200}
    batch = [draw_realization(case_inputs(config, "case1", config["mesh"]["cell_size_m"]), i) for i in range(n)]
    simulated = []
    with tempfile.TemporaryDirectory(prefix="rgns-suite-cbgeo-") as scratch:
        start = time.perf_counter()
        for r in batch:
            label, work = f"case1 realization {r.index:04d}", Path(scratch) / f"{r.index:04d}"
            case_dir = write_case(work / "case", r.scene, r.friction_deg, case_settings)
            try:
                case, raw, _ = run_cbgeo(case_dir, work / "run", work / "mpm.log", options, label)
                simulated.append(Simulated(trajectory_from_cbgeo(case, raw, label, {}).positions, "ok"))
            except MPMDiverged as error:
                simulated.append(Simulated(np.empty(0), f"diverged: {error}"))
        seconds = (time.perf_counter() - start) / n
    return measured(batch, simulated, config), seconds


def train_variant(config: dict, models: Path, name: str, steps: int, **model) -> Path:
    """A GNS variant trained on the pipeline's dataset (resumed from its checkpoint if present)."""
    model_settings, train_settings = settings_from_config(config["gns"], config["mesh"]["cell_size_m"])
    out = models / name
    target = out / "gns.pt"
    if not target.exists():
        train(
            replace(model_settings, **model),
            replace(train_settings, steps=steps, threads=2),
            str(REPO / "results/dataset/train.h5"),
            str(REPO / "results/dataset/valid.h5"),
            out,
            target,
        )
        torch.set_num_threads(1)
    return target


def screen_benchmark(config: dict, n: int, frames: int, friction_mean_deg: float) -> dict:
    """Screen a stronger case 1; simulate every realization anyway to count false skips."""
    inputs = case_inputs(config, "case1", config["mesh"]["cell_size_m"], friction_mean_deg)
    batch = [draw_realization(inputs, i) for i in range(n)]
    settings = ScreenSettings(**(config["montecarlo"]["screen"] | {"enabled": True}))
    mpm = MpmSettings.from_config(config["mpm"])
    start = time.perf_counter()
    safety = [factor_of_safety(r, mpm, settings) for r in batch]
    screen_s = (time.perf_counter() - start) / n
    start = time.perf_counter()
    rows = measured(batch, simulate_mpm(batch, mpm, frames, keep="ends"), config)
    mpm_s = (time.perf_counter() - start) / n
    skipped = [settings.skips(fs) for fs in safety]
    false_skips = [row["index"] for row, skip in zip(rows, skipped) if skip and row.get("runout_m", 0.0) > 0.0]
    return {
        "friction_mean_deg": friction_mean_deg,
        "threshold": settings.threshold,
        "n": n,
        "factor_of_safety": safety,
        "mpm_runout_m": [row.get("runout_m") for row in rows],
        "mpm_volume_m2": [row.get("volume_m2") for row in rows],
        "screened": int(sum(skipped)),
        "false_skips": false_skips,
        "screen_s_per_realization": screen_s,
        "mpm_s_per_realization": mpm_s,
        "time_saved_fraction": sum(skipped) / n - screen_s / mpm_s,
    }


def pareto_plot(routes: dict, path: Path) -> None:
    """Every route as a numbered point (key in the legend), the Pareto front dashed."""
    fig, ax = plt.subplots(figsize=(10, 5.5))
    names = [name for name in routes if name != "reference"]
    points = np.array([[routes[name]["s_per_realization"], routes[name]["error"]["mean"]] for name in names])
    for number, ((x, y), name) in enumerate(zip(points, names), start=1):
        color = "C1" if name.startswith("GNS") else "C2" if name.startswith("end-state") else "C0"
        ax.scatter(x, y, color=color, zorder=3, label=f"{number}: {name}")
        ax.annotate(str(number), (x, y), fontsize=8, xytext=(4, 3), textcoords="offset points")
    front, best = [], np.inf
    for k in np.argsort(points[:, 0]):
        if points[k, 1] < best:
            front.append(points[k])
            best = points[k, 1]
    front = np.array(front)
    ax.step(front[:, 0], front[:, 1], where="post", color="0.5", linestyle="--", label="Pareto front")
    ax.set_xscale("log")
    ax.set_xlabel("wall time per realization (s, one CPU thread)")
    ax.set_ylabel("error in R, V, I (mean abs., % of range)")
    ax.set_title(
        "Time against error, against the embedded MPM at 0.5 m cells, cfl 0.1 (blue: MPM, orange: GNS, green: end-state)",
        fontsize=10,
    )
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)


def markdown(record: dict) -> str:
    lines = [
        f"Realizations: {record['n']} (case 1, {record['duration_s']:g} s); GNS variants trained "
        f"{record['train_steps']} steps; machine: {record['machine']}",
        "",
        "| route | s per realization | error R % | error V % | error I % | error mean % | not ok |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for name, route in record["routes"].items():
        e = route["error"]
        lines.append(
            f"| {name} | {route['s_per_realization']:.2f} | {e['runout_m']:.1f} | {e['volume_m2']:.1f} | "
            f"{e['influence_m']:.1f} | {e['mean']:.1f} | {record['n'] - e['ok']} |"
        )
    skip = record["skipping"]
    lines += [
        "",
        f"GNS rest-skipping + early stop vs neither: {skip['speedup']:.2f}x faster; change of the R, V, I "
        f"errors: {skip['error_change_pct_of_range']} % of range (max per realization "
        f"{skip['max_change_pct_of_range']} %).",
    ]
    s = record["screen"]
    lines += [
        "",
        f"Screen (friction mean {s['friction_mean_deg']} deg, threshold {s['threshold']}): {s['screened']} of "
        f"{s['n']} screened, false skips (screened but the MPM ran out): {s['false_skips']}; "
        f"{s['screen_s_per_realization'] * 1000:.0f} ms per screen against {s['mpm_s_per_realization']:.2f} s "
        f"per MPM realization; time saved {s['time_saved_fraction']:.0%}.",
    ]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--realizations", type=int, default=8)
    parser.add_argument("--train-steps", type=int, default=0, help="train GNS variants this many steps (0: none)")
    parser.add_argument("--model", type=Path, default=MODELS / "gns.pt", help="the GNS of the GNS routes")
    parser.add_argument("--screen-friction", type=float, default=45.0)
    parser.add_argument("--duration-s", type=float, help="simulated time (default: mpm.duration_s, 10 s)")
    parser.add_argument("--models", type=Path, default=OUT / "models", help="where trained variants are kept")
    parser.add_argument("--replot", action="store_true", help="redraw pareto.png and suite.md from suite.json")
    parser.add_argument("--cbgeo", metavar="MPM", help="add a CB-Geo route (this mpm binary) to suite.json")
    parser.add_argument(
        "--endstate",
        nargs="?",
        const=MODELS / "endstate_general.pt",
        type=Path,
        metavar="MODEL",
        help="add the end-state surrogate route (default: the shipped one) to suite.json",
    )
    args = parser.parse_args()
    if args.replot or args.cbgeo or args.endstate:
        record = json.loads((OUT / "suite.json").read_text())
        if args.endstate:
            torch.set_num_threads(1)
            config = load_config(REPO / "config" / "config.yaml")
            rows, seconds = run_endstate_route(config, args.endstate, record["n"])
            name = "end-state surrogate (shipped)"
            record["routes"][name] = {
                "s_per_realization": seconds,
                "rows": rows,
                "error": errors(rows, record["routes"]["reference"]["rows"]),
            }
            print(f"{name}: {seconds:.4f} s per realization, error {record['routes'][name]['error']}", flush=True)
            (OUT / "suite.json").write_text(json.dumps(record, indent=1, default=float) + "\n")
        if args.cbgeo:
            torch.set_num_threads(1)
            config = load_config(REPO / "config" / "config.yaml")
            rows, seconds = run_cbgeo_route(config, args.cbgeo, record["n"], record["frames"])
            name = f"CB-Geo {config['mesh']['cell_size_m']:g} m, -p 1"
            record["routes"][name] = {
                "s_per_realization": seconds,
                "rows": rows,
                "error": errors(rows, record["routes"]["reference"]["rows"]),
            }
            print(f"{name}: {seconds:.2f} s per realization, error {record['routes'][name]['error']}", flush=True)
            (OUT / "suite.json").write_text(json.dumps(record, indent=1, default=float) + "\n")
        pareto_plot(record["routes"], OUT / "pareto.png")
        (OUT / "suite.md").write_text(markdown(record))
        return
    torch.set_num_threads(1)
    config = load_config(REPO / "config" / "config.yaml")
    duration_s = args.duration_s or config["mpm"]["duration_s"]
    frames = frame_count(duration_s, config["mpm"]["frame_interval_s"])
    n = args.realizations
    OUT.mkdir(parents=True, exist_ok=True)
    routes: dict[str, dict] = {}

    def record(name: str, rows: list[dict], seconds: float) -> None:
        routes[name] = {"s_per_realization": seconds, "rows": rows}
        print(f"{name}: {seconds:.2f} s per realization", flush=True)

    record("reference", *run_mpm_route(config, 0.5, n, frames, cfl=0.1, early_stop=False))
    for cell in (2.0, 1.0, 0.5):
        record(f"MPM {cell:g} m, cfl 0.2", *run_mpm_route(config, cell, n, frames))
    for cfl in (0.1, 0.5):
        record(f"MPM 1 m, cfl {cfl:g}", *run_mpm_route(config, 1.0, n, frames, cfl=cfl))
    record("MPM 1 m, cfl 0.2, no early stop", *run_mpm_route(config, 1.0, n, frames, early_stop=False))

    default_model = args.model
    mc = rollout_settings(config["montecarlo"]["rollout"], config["mpm"]["frame_interval_s"], "ends")
    plain = replace(mc, skip_rest=False, early_stop=False)
    record("GNS default, neither", *run_gns_route(config, default_model, n, frames, plain))
    record("GNS default, rest-skip", *run_gns_route(config, default_model, n, frames, replace(plain, skip_rest=True)))
    record("GNS default, early stop", *run_gns_route(config, default_model, n, frames, replace(plain, early_stop=True)))
    record("GNS default, both (MC default)", *run_gns_route(config, default_model, n, frames, mc))
    for rest in (2.5e-4, 1e-3):
        record(
            f"GNS default, both, rest {rest:g} m/frame",
            *run_gns_route(config, default_model, n, frames, replace(mc, rest_velocity=rest)),
        )
    variants = {
        "GNS latent 16, 3 MP": {"latent_size": 16, "mlp_width": 16, "message_passing_steps": 3},
        "GNS radius 1.0 m": {"radius_m": 1.0},
    }
    for name, model in variants.items() if args.train_steps else ():
        path = train_variant(config, args.models, name.replace(" ", "_").replace(",", ""), args.train_steps, **model)
        record(f"{name}, both", *run_gns_route(config, path, n, frames, mc))
    record("end-state surrogate (shipped)", *run_endstate_route(config, MODELS / "endstate_general.pt", n))

    reference = routes["reference"]["rows"]
    for route in routes.values():
        route["error"] = errors(route["rows"], reference)
    neither, both = routes["GNS default, neither"], routes["GNS default, both (MC default)"]
    change = {key: round(abs(both["error"][key] - neither["error"][key]), 2) for key in METRICS}
    per_realization = {}
    for key in METRICS:
        spread = float(np.ptp([r[key] for r in reference if r["status"] == "ok"])) or 1.0
        diffs = [
            abs(a[key] - b[key]) for a, b in zip(neither["rows"], both["rows"]) if a["status"] == b["status"] == "ok"
        ]
        per_realization[key] = round(max(diffs) / spread * 100, 2) if diffs else None
    skipping = {
        "speedup": neither["s_per_realization"] / both["s_per_realization"],
        "error_change_pct_of_range": change,
        "max_change_pct_of_range": per_realization,
    }
    result = {
        "n": n,
        "frames": frames,
        "duration_s": duration_s,
        "train_steps": args.train_steps,
        "routes": routes,
        "skipping": skipping,
        "screen": screen_benchmark(config, n, frames, args.screen_friction),
        "machine": f"{platform.processor() or platform.machine()}, torch {torch.__version__}, 1 thread, CPU",
    }
    (OUT / "suite.json").write_text(json.dumps(result, indent=1, default=float) + "\n")
    (OUT / "suite.md").write_text(markdown(result))
    pareto_plot(routes, OUT / "pareto.png")
    print(markdown(result))


if __name__ == "__main__":
    main()
