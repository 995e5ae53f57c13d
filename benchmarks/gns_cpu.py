"""A lean GNS trained on one CPU thread and rolled out from the first frames (the paper's protocol): its learning
curve on a development set, in stretches that resume.

    python benchmarks/gns_cpu.py sets  --work W --train T.h5 --valid V.h5 --dev case1.h5 case2.h5 ...
    python benchmarks/gns_cpu.py train --work W --until 30000 --every 1000 [--static]

``sets`` coarse-grains packed MPM sets (rgns.surrogates.gns.coarse: nodes ``--spacing`` apart, a step of ``--stride``
frames; the default 0.5 m is the 1 m mesh's particle spacing, a node per particle: 1 m nodes put case 3's runout
3.9 m short of its particles') into ``W/sets``, and states how far R, V and I measured on the nodes sit from the
particles' on the development sets.
``train`` trains (rgns.surrogates.gns.train; checkpoints in ``W/model``, a killed run resumes) to ``--until``
steps, and after every ``--every`` steps rolls the development sets out from their first ``history + 1``
frames and records R², NRMSE and the relative bias of R, V and I per set against the MPM's (on the nodes), with
bootstrap intervals, in ``W/curve.jsonl``: the decision rule of issue 63 reads it.
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch

from rgns.engines.metrics import runout_metrics
from rgns.surrogates.gns.coarse import coarse_set
from rgns.surrogates.gns.data import WindowSampler
from rgns.surrogates.gns.rollout import RolloutSettings, rollout_soil
from rgns.surrogates.gns.simulator import ModelSettings
from rgns.surrogates.gns.train import TrainSettings, load_simulator, particle_crest_x, train
from rgns.surrogates.validation import agreement
from rgns.trajectories import read_packed

METRICS = ("runout_m", "volume_m2", "influence_m")


def spec(static: bool, radius_m: float) -> tuple[ModelSettings, TrainSettings]:
    """The prototype's spec (docs findings §5: 214 k parameters), its radius about 2.2 node spacings."""
    model = ModelSettings(
        latent_size=64,
        mlp_width=64,
        mlp_hidden_layers=2,
        message_passing_steps=5,
        history=5,
        radius_m=radius_m,
        static_features=static,
    )
    training = TrainSettings(
        batch_graphs=4,
        learning_rate=1e-3,
        learning_rate_min=1e-5,
        decay_rate=0.01,
        decay_steps=30000,  # fixed: a longer run continues the same schedule
        noise_std=1e-3,
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
    rows = []
    for source in dev:
        for fine, coarse in zip(read_packed(source), read_packed(out / source.name)):
            particles = metrics_of(fine.positions[0], fine.positions[-1], fine.volume_m2)
            nodes = metrics_of(coarse.positions[0], coarse.positions[-1], coarse.volume_m2)
            rows.append(
                {"set": source.stem, **{f"{k}_particles": particles[k] for k in METRICS}}
                | {f"{k}_nodes": nodes[k] for k in METRICS}
            )
    report = {
        metric: asdict(
            agreement(
                np.array([r[f"{metric}_particles"] for r in rows]),
                np.array([r[f"{metric}_nodes"] for r in rows]),
                metric,
            )
        )
        for metric in METRICS
    }
    (work / "nodes_vs_particles.json").write_text(json.dumps(report, indent=1))
    for metric, row in report.items():
        print(
            f"nodes vs particles, {metric}: R² {row['r2']:.3f} [{row['r2_low']:.3f}, {row['r2_high']:.3f}], "
            f"relative bias {row['relative_bias']:+.3f} ({row['n']} runs)"
        )


@torch.no_grad()
def evaluate(model_path: Path, dev: list[Path], history: int) -> dict:
    """R², NRMSE and relative bias of R, V, I per development set, rolled out from the first frames."""
    simulator = load_simulator(model_path)
    out = {}
    for path in dev:
        sampler = WindowSampler(str(path), history)
        truths = [sampler.frames_of(k, 0, sampler.frames) for k in range(sampler.n_trajectories)]
        friction = [np.degrees(np.arctan(f.numpy())) for f in sampler.tan_friction]
        began = time.perf_counter()
        results = rollout_soil(
            simulator, truths, friction, sampler.frames, RolloutSettings(early_stop=True, keep="ends")
        )
        seconds = time.perf_counter() - began
        mpm = [metrics_of(t[0], t[-1], v) for t, v in zip(truths, sampler.volume_m2)]
        gns = [metrics_of(t[0], r.positions[-1], v) for t, r, v in zip(truths, results, sampler.volume_m2)]
        rows = {}
        for metric in METRICS:
            found = agreement(np.array([m[metric] for m in mpm]), np.array([g[metric] for g in gns]), metric)
            rows[metric] = {key: getattr(found, key) for key in ("r2", "r2_low", "r2_high", "nrmse", "relative_bias")}
        rows["diverged"] = sum(r.status != "ok" for r in results)
        rows["rollout_s_per_realization"] = seconds / len(results)
        out[path.stem] = rows
    return out


def train_in_stretches(work: Path, dev: list[Path], until: int, every: int, static: bool, radius_m: float) -> None:
    model, training = spec(static, radius_m)
    sets = work / "sets"
    curve = work / "curve.jsonl"
    done = {json.loads(line)["step"] for line in curve.read_text().splitlines()} if curve.exists() else set()
    for target in range(every, until + 1, every):
        training.steps = target
        summary = train(model, training, str(sets / "train.h5"), str(sets / "valid.h5"), work / "model")
        if target in done:
            continue
        row = {"step": target, "wall_s": summary["wall_s"], "static": static}
        row["dev"] = evaluate(work / "model" / "checkpoints" / "latest.pt", [sets / p.name for p in dev], model.history)
        with curve.open("a") as handle:
            handle.write(json.dumps(row) + "\n")
        print(json.dumps({"step": target} | {k: v["runout_m"] for k, v in row["dev"].items()}), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("action", choices=["sets", "train"])
    parser.add_argument("--work", type=Path, required=True)
    parser.add_argument("--train", type=Path)
    parser.add_argument("--valid", type=Path)
    parser.add_argument("--dev", type=Path, nargs="+", required=True)
    parser.add_argument("--until", type=int, default=30000)
    parser.add_argument("--every", type=int, default=2000)
    parser.add_argument("--spacing", type=float, default=0.5, help="node spacing (m)")
    parser.add_argument("--stride", type=int, default=4, help="MPM frames a GNS step spans")
    parser.add_argument("--radius", type=float, default=1.1, help="connectivity radius (m)")
    parser.add_argument("--static", action="store_true", help="give nodes where they started (static_features)")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    torch.set_num_threads(1)
    if args.action == "sets":
        make_sets(args.work, args.train, args.valid, args.dev, args.spacing, args.stride)
    else:
        train_in_stretches(args.work, args.dev, args.until, args.every, args.static, args.radius)


if __name__ == "__main__":
    main()
