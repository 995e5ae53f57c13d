"""A lean GNS trained on one CPU thread and rolled out from the first frames (the paper's protocol): its learning
curve on a development set, in stretches that resume.

    python benchmarks/gns_cpu.py sets  --work W --train T.h5 --valid V.h5 --dev case1.h5 case2.h5 ...
    python benchmarks/gns_cpu.py train --work W --until 30000 --every 2000 [--static] --dev ...
    python benchmarks/gns_cpu.py report --work W --out benchmarks/results/gns_cpu --dev ...
    python benchmarks/gns_cpu.py timeline --model CHECKPOINT --out benchmarks/results/gns_cpu_timeline --dev ...
    python benchmarks/gns_cpu.py checkpoints --model C1 C2 ... [--average] --out OUT --dev ...

``sets`` coarse-grains packed MPM sets (rgns.surrogates.gns.coarse: nodes ``--spacing`` apart, a step of ``--stride``
frames; the default 0.5 m is the 1 m mesh's particle spacing, a node per particle: 1 m nodes put case 3's runout
3.9 m short of its particles') into ``W/sets``, and states how far R, V and I measured on the nodes sit from the
particles' on the development sets.
``train`` trains (rgns.surrogates.gns.train; checkpoints in ``W/model``, a killed run resumes) to ``--until``
steps, and after every ``--every`` steps rolls the development sets out from their first ``history + 1``
frames and records R², NRMSE and the relative bias of R, V and I per set against the MPM's (on the nodes), with
bootstrap intervals, in ``W/curve.jsonl``: the decision rule of issue 63 reads it. ``report`` writes the curve,
the spec and the nodes' fidelity as ``OUT.json`` and a table as ``OUT.md``. ``timeline`` rolls the development sets
out with one checkpoint and records, every ``--every`` frames, each run's runout and fastest node in the MPM and in
the GNS (when it follows the MPM and when it leaves it) as ``OUT.json``. ``checkpoints`` evaluates each checkpoint
named (and with ``--average`` the average of their weights) as ``train`` does, as ``OUT.json``.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch

from rgns.engines.metrics import runout_metrics
from rgns.provenance import commit
from rgns.surrogates.gns.coarse import coarse_set
from rgns.surrogates.gns.data import WindowSampler
from rgns.surrogates.gns.rollout import RolloutSettings, rollout_soil
from rgns.surrogates.gns.simulator import ModelSettings
from rgns.surrogates.gns.train import TrainSettings, load_simulator, particle_crest_x, train
from rgns.surrogates.validation import agreement
from rgns.trajectories import read_packed

METRICS = ("runout_m", "volume_m2", "influence_m")


def spec(
    static: bool,
    radius_m: float,
    moving_weight: float = 0.0,
    pushforward_steps: int = 0,
    learning_rate: float = 1e-3,
    ema_decay: float = 0.0,
    decay_steps: int = 30000,
    noise_std: float = 1e-3,
    rollout_steps: int = 0,
    batch_graphs: int = 4,
    rollout_from_frame: int = 0,
    message_passing_steps: int = 5,
    rest_head: bool = False,
) -> tuple[ModelSettings, TrainSettings]:
    """The prototype's spec (docs findings §5: 214 k parameters), its radius about 2.2 node spacings; with
    ``pushforward_steps``, each window's input is the model's own rollout over that many steps before the target;
    ``learning_rate`` is annealed to a hundredth of itself over ``decay_steps``; with ``ema_decay`` the model evaluated
    is the moving average of the weights; with ``rollout_steps`` the loss is over that many of the model's own steps
    (rgns.surrogates.gns.simulator.RolloutLoss); ``message_passing_steps`` sets the reach, that many radii; with
    ``rest_head`` the network also says whether a node is at rest after the step (ModelSettings.rest_head)."""
    model = ModelSettings(
        latent_size=64,
        mlp_width=64,
        mlp_hidden_layers=2,
        message_passing_steps=message_passing_steps,
        history=5,
        radius_m=radius_m,
        static_features=static,
        rest_head=rest_head,
    )
    training = TrainSettings(
        batch_graphs=batch_graphs,
        learning_rate=learning_rate,
        learning_rate_min=learning_rate / 100,
        decay_rate=0.01,
        decay_steps=decay_steps,  # a longer run continues the same schedule
        noise_std=noise_std,
        moving_weight=moving_weight,
        pushforward_steps=pushforward_steps,
        rollout_steps=rollout_steps,
        rollout_from_frame=rollout_from_frame,
        ema_decay=ema_decay,
        smoothing_frames=1.0,
        checkpoint_every=250,
        validate_every=1000,
        validation_windows=64,
        selection_trajectories=8,
        selection_warmup_frames=0,  # the paper's protocol: from the first history + 1 frames
        log_every=100,
    )
    return model, training


def metrics_of(initial: np.ndarray, final: np.ndarray, volume: np.ndarray) -> dict:
    return runout_metrics(initial, final, volume, particle_crest_x(initial)).as_row()


def make_sets(work: Path, train_set: Path, valid_set: Path, dev: list[Path], spacing_m: float, stride: int) -> None:
    out = work / "sets"
    out.mkdir(parents=True, exist_ok=True)
    for source in [train_set, valid_set, *dev]:
        count = coarse_set(source, out / source.name, spacing_m, stride)
        print(f"{source} -> {out / source.name}: {count} trajectories")
    rows = []  # (set, the particles' R, V, I, the nodes')
    for source in dev:
        for fine, coarse in zip(read_packed(source), read_packed(out / source.name)):
            particles = metrics_of(fine.positions[0], fine.positions[-1], fine.volume_m2)
            nodes = metrics_of(coarse.positions[0], coarse.positions[-1], coarse.volume_m2)
            rows.append((source.stem, particles, nodes))

    def of(chosen: list[tuple[str, dict, dict]]) -> dict:
        return agreements([row[1] for row in chosen], [row[2] for row in chosen])

    report = {"spacing_m": spacing_m, "stride_frames": stride, "runs": len(rows)} | of(rows)
    report["sets"] = {p.stem: of([row for row in rows if row[0] == p.stem]) for p in dev}
    (work / "nodes_vs_particles.json").write_text(json.dumps(report, indent=1))
    for metric in METRICS:
        row = report[metric]
        print(
            f"nodes vs particles, {metric}: R² {row['r2']:.3f} [{row['r2_low']:.3f}, {row['r2_high']:.3f}], "
            f"relative bias {row['relative_bias']:+.3f} ({row['n']} runs)"
        )


def dev_runs(path: Path, history: int) -> tuple[WindowSampler, list[np.ndarray], list[np.ndarray]]:
    """A development set's sampler, each run's MPM frames and its particles' friction angles (deg)."""
    sampler = WindowSampler(str(path), history)
    truths = [sampler.frames_of(k, 0, sampler.frames) for k in range(sampler.n_trajectories)]
    friction = [np.degrees(np.arctan(f.numpy())) for f in sampler.tan_friction]
    return sampler, truths, friction


@torch.no_grad()
def evaluate(model_path: Path, dev: list[Path], rest_gate: bool = True) -> dict:
    """R², NRMSE and relative bias of R, V, I per development set and pooled over all ("all"), rolled out from the
    first frames (``rest_gate``: as RolloutSettings'); each run's MPM and GNS values kept ("runs")."""
    simulator = load_simulator(model_path)
    out, pooled = {}, {"mpm": [], "gns": []}
    for path in dev:
        sampler, truths, friction = dev_runs(path, simulator.settings.history)
        began = time.perf_counter()
        results = rollout_soil(
            simulator,
            truths,
            friction,
            sampler.frames,
            RolloutSettings(early_stop=True, keep="ends", rest_gate=rest_gate),
        )
        seconds = time.perf_counter() - began
        mpm = [metrics_of(t[0], t[-1], v) for t, v in zip(truths, sampler.volume_m2)]
        gns = [metrics_of(t[0], r.positions[-1], v) for t, r, v in zip(truths, results, sampler.volume_m2)]
        pooled["mpm"] += mpm
        pooled["gns"] += gns
        out[path.stem] = agreements(mpm, gns) | {
            "diverged": sum(r.status != "ok" for r in results),
            "rollout_s_per_realization": seconds / len(results),
            "runs": {"mpm": [[m[k] for k in METRICS] for m in mpm], "gns": [[g[k] for k in METRICS] for g in gns]},
        }
    out["all"] = agreements(pooled["mpm"], pooled["gns"])
    return out


def along_runs(runs: list[np.ndarray], volumes: list[np.ndarray], frames: list[int]) -> dict:
    """Each run's runout and the displacement of its fastest node over the frame before, at ``frames``."""
    return {
        "runout_m": [[metrics_of(r[0], r[f], v)["runout_m"] for f in frames] for r, v in zip(runs, volumes)],
        "fastest_m_per_frame": [[float(np.linalg.norm(r[f] - r[f - 1], axis=1).max()) for f in frames] for r in runs],
    }


@torch.no_grad()
def timeline(model_path: Path, dev: list[Path], every: int) -> dict:
    """Per development set, every ``every`` frames from the start: each run's runout and the speed of its fastest node
    (m/s) in the MPM and in the GNS rolled out from the first frames, without early stop."""
    simulator = load_simulator(model_path)
    out = {}
    for path in dev:
        sampler, truths, friction = dev_runs(path, simulator.settings.history)
        results = rollout_soil(simulator, truths, friction, sampler.frames, RolloutSettings(keep="all"))
        frames = list(range(every, sampler.frames, every))
        out[path.stem] = {
            "frame_interval_s": float(next(iter(read_packed(path))).frame_interval_s),
            "frames": frames,
            "mpm": along_runs(truths, sampler.volume_m2, frames),
            "gns": along_runs([r.positions for r in results], sampler.volume_m2, frames),
        }
    return out


def agreements(reference: list[dict], other: list[dict]) -> dict:
    """R², NRMSE and bias (rgns.surrogates.validation.agreement) of each metric of ``other``'s runs against
    ``reference``'s."""
    return {
        metric: asdict(
            agreement(np.array([r[metric] for r in reference]), np.array([o[metric] for o in other]), metric)
        )
        for metric in METRICS
    }


def spec_of(args: argparse.Namespace) -> tuple[ModelSettings, TrainSettings]:
    """The spec the command line's flags ask for."""
    return spec(
        args.static,
        args.radius,
        args.moving_weight,
        args.pushforward,
        args.learning_rate,
        args.ema_decay,
        args.decay_steps,
        args.noise,
        args.rollout_steps,
        args.batch,
        args.rollout_from,
        args.message_passing,
        args.rest_head,
    )


def spec_flags(args: argparse.Namespace) -> str:
    """The flags of that spec, as ``train`` takes them (the defaults left out, the radius always named)."""
    flags = " --static" if args.static else ""
    flags += f" --moving-weight {args.moving_weight:g}" if args.moving_weight else ""
    flags += f" --pushforward {args.pushforward}" if args.pushforward else ""
    flags += f" --learning-rate {args.learning_rate:g}" if args.learning_rate != 1e-3 else ""
    flags += f" --ema-decay {args.ema_decay:g}" if args.ema_decay else ""
    flags += f" --decay-steps {args.decay_steps}" if args.decay_steps != 30000 else ""
    flags += f" --noise {args.noise:g}" if args.noise != 1e-3 else ""
    flags += f" --rollout-steps {args.rollout_steps}" if args.rollout_steps else ""
    flags += f" --rollout-from {args.rollout_from}" if args.rollout_from else ""
    flags += f" --batch {args.batch}" if args.batch != 4 else ""
    flags += f" --init {args.init}" if args.init else ""
    flags += f" --message-passing {args.message_passing}" if args.message_passing != 5 else ""
    flags += " --rest-head" if args.rest_head else ""
    return flags + f" --radius {args.radius:g}"


def train_in_stretches(
    work: Path,
    dev: list[Path],
    until: int,
    every: int,
    model: ModelSettings,
    training: TrainSettings,
    init: Path | None = None,
) -> None:
    sets = work / "sets"
    curve = work / "curve.jsonl"
    done = {json.loads(line)["step"] for line in curve.read_text().splitlines()} if curve.exists() else set()
    for target in range(every, until + 1, every):
        training.steps = target
        summary = train(
            model, training, str(sets / "train.h5"), str(sets / "valid.h5"), work / "model", init_model=init
        )
        if target in done:
            continue
        row = {"step": target, "wall_s": summary["wall_s"], "static": model.static_features}
        row["dev"] = evaluate(work / "model" / "checkpoints" / "latest.pt", [sets / p.name for p in dev])
        with curve.open("a") as handle:
            handle.write(json.dumps(row) + "\n")
        print(json.dumps({"step": target} | {k: v["runout_m"] for k, v in row["dev"].items()}), flush=True)


BAR = 0.8  # the decision rule: every development set's runout R² at two evaluations in a row (the pooled R² over
# the four cases measures mostly how their runouts differ: 0.90 at 4,000 steps where three cases had about 0)


def rule_power(dev: list[Path], trials: int = 20000) -> dict:
    """How often the decision rule passes a model whose errors give a true runout R² of r in every development set
    (unbiased normal errors on each set's own MPM runouts), at one evaluation and at two independent ones."""
    sets = [
        np.array([metrics_of(t.positions[0], t.positions[-1], t.volume_m2)["runout_m"] for t in read_packed(p)])
        for p in dev
    ]
    rng = np.random.default_rng(63)
    power = {}
    for true in (0.95, 0.9, 0.85, 0.8, 0.7):
        passed = np.ones(trials, dtype=bool)
        for runouts in sets:
            errors = rng.normal(0.0, np.sqrt(runouts.var() * (1.0 - true)), (trials, runouts.size))
            passed &= 1.0 - (errors**2).sum(1) / ((runouts - runouts.mean()) ** 2).sum() >= BAR
        once = float(passed.mean())
        power[str(true)] = {"once": once, "twice": once**2}
    return {
        "bar": BAR,
        "sets": [p.stem for p in dev],
        "runs": [len(r) for r in sets],
        "trials": trials,
        "pass_rate_by_true_r2": power,
    }


def averaged_checkpoint(paths: list[Path], out: Path) -> Path:
    """A checkpoint whose model weights are the mean of those of ``paths`` (the last one's otherwise), at ``out``."""
    states = [torch.load(path, map_location="cpu", weights_only=False) for path in paths]
    averaged = states[-1]
    averaged["model"] = {
        key: torch.stack([state["model"][key] for state in states]).mean(0) if value.is_floating_point() else value
        for key, value in averaged["model"].items()
    }
    torch.save(averaged, out)
    return out


def write_checkpoints(args: argparse.Namespace, command: str) -> None:
    """Each of ``--model``'s checkpoints (and their weights' average with ``--average``) evaluated on ``--dev`` as
    :func:`evaluate` does, as ``--out``.json; with ``--without-rest-gate`` each also with its rest head ignored."""
    models = {str(path): path for path in args.model}
    if args.average:
        models["average"] = averaged_checkpoint(args.model, args.out.with_suffix(".average.pt"))
    record: dict = {"command": command, "commit": commit(), "models": {}}
    runs = [(name, path, True) for name, path in models.items()]
    runs += [(f"{name} without the rest gate", path, False) for name, path in models.items() if args.without_rest_gate]
    for name, path, gate in runs:
        record["models"][name] = evaluate(path, args.dev, gate)
        row = {k: v["runout_m"] for k, v in record["models"][name].items()}
        print(json.dumps({"model": name} | row), flush=True)
        args.out.with_suffix(".json").write_text(json.dumps(record, indent=1) + "\n")
    args.out.with_suffix(".average.pt").unlink(missing_ok=True)


def write_timeline(args: argparse.Namespace, command: str) -> None:
    """:func:`timeline` of ``--model`` as ``--out``.json and a table of the sets' mean runout and fastest node over
    time as ``--out``.md."""
    sets = timeline(args.model[0], args.dev, args.frames_every)
    record = {"command": command, "commit": commit(), "model": str(args.model[0]), "sets": sets}
    args.out.with_suffix(".json").write_text(json.dumps(record, indent=1) + "\n")
    lines = [f"# A GNS rollout over time against the MPM's\n\n`{command}` at {record['commit']}.\n"]
    for name, run in sets.items():
        lines += [
            f"## {name}\n",
            "| time (s) | MPM mean R (m) | GNS mean R (m) | MPM fastest node (m/s) | GNS fastest node (m/s) |",
            "|---:|---:|---:|---:|---:|",
        ]
        step = run["frame_interval_s"]
        for k, frame in enumerate(run["frames"]):
            cells = [
                np.mean([r[k] for r in run[who][key]])
                for key in ("runout_m", "fastest_m_per_frame")
                for who in ("mpm", "gns")
            ]
            lines.append(
                f"| {frame * step:.1f} | {cells[0]:.2f} | {cells[1]:.2f} | {cells[2] / step:.2f} | {cells[3] / step:.2f} |"
            )
        lines.append("")
    args.out.with_suffix(".md").write_text("\n".join(lines))


def report(args: argparse.Namespace, command: str) -> None:
    """The curve of ``--work`` as ``--out``.json (with the spec the training ran: give ``report`` the training's spec
    flags, and ``--train-config``, the config its training set was made by), and ``--coarser``'s nodes against the
    particles (a ``sets`` work folder of another spacing) beside the run's."""
    work, out, coarser, dev = args.work, args.out, args.coarser, args.dev
    rows = [json.loads(line) for line in (work / "curve.jsonl").read_text().splitlines()]
    model, training = spec_of(args)
    trained = f"python benchmarks/gns_cpu.py train --work {work}{spec_flags(args)}"
    record = {
        "command": command,
        "train_command": f"{trained} --every {rows[0]['step']} --dev " + " ".join(map(str, dev)),
        "commit": commit(),
        "init": str(args.init) if args.init else None,
        "model": asdict(model),
        "training": asdict(training),
        "train_data": {
            "config": args.train_config,
            "runs": WindowSampler(str(work / "sets" / "train.h5"), model.history).n_trajectories,
        },
        "nodes_vs_particles": json.loads((work / "nodes_vs_particles.json").read_text()),
        "coarser_nodes_vs_particles": json.loads((coarser / "nodes_vs_particles.json").read_text())
        if coarser
        else None,
        "curve": rows,
        "decision_rule": rule_power(dev),
    }
    out.with_suffix(".json").write_text(json.dumps(record, indent=1) + "\n")
    sets = [name for name in rows[-1]["dev"] if name != "all"]
    lines = [
        "# A lean GNS on one CPU thread, rolled out from the first frames",
        "",
        f"`{record['train_command']}`, then `{command}` at {record['commit']}: R² of each development set's 16 runs against the MPM's (1 m, "
        "rolled out from the first 6 frames at a step of 4 frames), 95 % bootstrap interval; relative bias of R.",
        "",
        "| steps | wall (min) | all R: R² | " + " | ".join(f"{name} R: R² | bias" for name in sets) + " | diverged |",
        "|---:|---:|---|" + "---|---:|" * len(sets) + "---:|",
    ]
    for row in rows:
        cells = []
        for name in sets:
            r = row["dev"][name]["runout_m"]
            cells += [f"{r['r2']:.2f} [{r['r2_low']:.2f}, {r['r2_high']:.2f}]", f"{r['relative_bias']:+.1%}"]
        diverged = sum(row["dev"][name]["diverged"] for name in sets)
        pooled = row["dev"].get("all", {}).get("runout_m")
        overall = f"{pooled['r2']:.2f} [{pooled['r2_low']:.2f}, {pooled['r2_high']:.2f}]" if pooled else "—"
        lines.append(
            f"| {row['step']:,} | {row['wall_s'] / 60:.0f} | {overall} | " + " | ".join(cells) + f" | {diverged} |"
        )
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("action", choices=["sets", "train", "report", "timeline", "checkpoints"])
    parser.add_argument("--model", type=Path, nargs="+", help="timeline, checkpoints: the checkpoints to roll out")
    parser.add_argument("--average", action="store_true", help="checkpoints: also their weights' average")
    parser.add_argument(
        "--without-rest-gate", action="store_true", help="checkpoints: also each with its rest head ignored"
    )
    parser.add_argument("--frames-every", type=int, default=10, help="timeline: frames between records")
    parser.add_argument("--out", type=Path, help="report: the result files' path without suffix")
    parser.add_argument("--coarser", type=Path, help="report: a sets work folder of coarser nodes, to compare")
    parser.add_argument("--work", type=Path)
    parser.add_argument("--train", type=Path)
    parser.add_argument("--valid", type=Path)
    parser.add_argument("--dev", type=Path, nargs="+", required=True)
    parser.add_argument("--until", type=int, default=30000)
    parser.add_argument("--every", type=int, default=2000)
    parser.add_argument("--spacing", type=float, default=0.5, help="node spacing (m)")
    parser.add_argument("--stride", type=int, default=4, help="MPM frames a GNS step spans")
    parser.add_argument("--radius", type=float, default=1.1, help="connectivity radius (m)")
    parser.add_argument("--moving-weight", type=float, default=0.0, help="extra loss weight of moving particles")
    parser.add_argument(
        "--pushforward", type=int, default=0, help="steps the model rolls a window on before its target"
    )
    parser.add_argument("--learning-rate", type=float, default=1e-3, help="initial learning rate")
    parser.add_argument("--ema-decay", type=float, default=0.0, help="evaluate the weights' moving average")
    parser.add_argument(
        "--decay-steps", type=int, default=30000, help="steps over which the learning rate falls a hundredfold"
    )
    parser.add_argument(
        "--noise", type=float, default=1e-3, help="input noise (m a step, random walk over the history)"
    )
    parser.add_argument("--rollout-steps", type=int, default=0, help="the loss over this many of the model's own steps")
    parser.add_argument(
        "--rollout-from", type=int, default=0, help="the rollout loss on windows from this frame, beside the one-step"
    )
    parser.add_argument("--message-passing", type=int, default=5, help="message-passing steps (the reach in radii)")
    parser.add_argument("--batch", type=int, default=4, help="windows a step")
    parser.add_argument("--init", type=Path, help="train: start from this checkpoint's weights (fine-tune)")
    parser.add_argument(
        "--train-config", default="config/pretrain.yaml", help="report: the config that made the training set"
    )
    parser.add_argument("--rest-head", action="store_true", help="a rest head: deposits held where it says at rest")
    parser.add_argument("--static", action="store_true", help="give nodes where they started (static_features)")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    torch.set_num_threads(1)
    if args.action == "sets":
        make_sets(args.work, args.train, args.valid, args.dev, args.spacing, args.stride)
    elif args.action == "train":
        train_in_stretches(args.work, args.dev, args.until, args.every, *spec_of(args), args.init)
    else:
        command = "python benchmarks/gns_cpu.py " + " ".join(sys.argv[1:])
        {"report": report, "timeline": write_timeline, "checkpoints": write_checkpoints}[args.action](args, command)


if __name__ == "__main__":
    main()
