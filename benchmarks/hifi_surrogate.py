"""Can a cheap route correlate better with the 0.5 m MPM than the 1 m MPM does? The shipped end-state
surrogate fine-tuned on 0.5 m MPM runs, as the cheap route of the multi-fidelity benchmark.

    python benchmarks/hifi_surrogate.py --realizations 80 --train 64 --steps 600 --learning-rate 3e-4

1. Case-1 realizations of another seed (``--seed``; the pool is the default seed's 0..63) run by the
   embedded MPM at 0.5 m cells, each end state coarse-grained onto the 1 m mesh's point lattice: a
   coarse point moves by the mean displacement of the four fine points in its pixel (they share its
   friction angle; the field is on the 1 m grid). Chunks of 8, cached in ``--data``.
2. The shipped model (``rgns/models/endstate.pt``) trained further on the first ``--train`` of them
   (AdamW, cosine learning rate, the gradient norm clipped at 1, batches of 16); the rest are held out.
3. Both models run on the pool of ``benchmarks/multifidelity.py`` (its ``multifidelity.json``) and
   analysed there as cheap routes against the 0.5 m MPM: correlation and speed-up at equal error.

Writes ``benchmarks/results/hifi_surrogate.{json,md,png}``; the data and the tuned model stay in
``benchmarks/results/models/hifi/`` (not committed).
"""
from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import torch

import multifidelity as mf
from rgns.config import load_config
from rgns.endstate.data import EndState, read_end_states, write_end_states
from rgns.endstate.model import EndStateModel, load_model
from rgns.endstate.train import Examples, examples, held_out_loss, training_step
from rgns.montecarlo import simulate_mpm
from rgns.realizations import draw_realization
from rgns.trajectories import frame_count
from suite import case_inputs

REPO = Path(__file__).resolve().parent.parent
WORK = REPO / "benchmarks" / "results" / "models" / "hifi"
CHUNK = 8


def coarse_grained(coarse_initial: np.ndarray, fine_initial: np.ndarray, fine_final: np.ndarray,
                   coarse_spacing_m: float) -> np.ndarray:
    """Final positions of the coarse points: each moved by the mean displacement of the fine points
    in its lattice pixel (a coarse point with none stays)."""
    def pixel(p: np.ndarray) -> np.ndarray:
        cells = np.floor(p / coarse_spacing_m).astype(np.int64)
        return cells[:, 0] * 100_000 + cells[:, 1]
    coarse, fine = pixel(coarse_initial), pixel(fine_initial)
    order = np.argsort(coarse)
    slot = order[np.clip(np.searchsorted(coarse[order], fine), 0, len(coarse) - 1)]
    inside = coarse[slot] == fine
    total, count = np.zeros_like(coarse_initial), np.zeros(len(coarse_initial))
    np.add.at(total, slot[inside], (fine_final - fine_initial)[inside])
    np.add.at(count, slot[inside], 1.0)
    return coarse_initial + total / np.maximum(count, 1.0)[:, None]


def run_chunk(seed: int, indices: list[int], data: Path) -> tuple[int, float, list[str]]:
    """Realizations ``indices`` by the 0.5 m MPM, coarse-grained, written as one end-state chunk."""
    torch.set_num_threads(1)
    config = load_config(REPO / "config" / "config.yaml")
    config["seed"] = seed
    mpm = config["mpm"]
    fine = [draw_realization(case_inputs(config, "case1", 0.5), i) for i in indices]
    coarse = [draw_realization(case_inputs(config, "case1", 1.0), i) for i in indices]
    start = time.perf_counter()
    runs = simulate_mpm(fine, mpm, frame_count(mpm["duration_s"], mpm["frame_interval_s"]), keep="ends")
    seconds = time.perf_counter() - start
    spacing = config["mesh"]["cell_size_m"] / config["mesh"]["particles_per_cell"]
    states = [EndState("case1", c.index, c.scene.positions,
                       coarse_grained(c.scene.positions, f.scene.positions, run.positions[-1], spacing),
                       c.friction_deg, c.scene.volumes)
              for f, c, run in zip(fine, coarse, runs) if run.status == "ok"]
    statuses = [run.status for run in runs]
    write_end_states(data / f"s{seed}_{indices[0]:04d}.h5", states, statuses)
    return indices[0], seconds, statuses


def make_data(seed: int, count: int, data: Path, workers: int) -> None:
    """Every missing chunk of realizations 0..count-1."""
    data.mkdir(parents=True, exist_ok=True)
    starts = [i for i in range(0, count, CHUNK) if not (data / f"s{seed}_{i:04d}.h5").exists()]
    with ProcessPoolExecutor(workers) as pool:
        jobs = [pool.submit(run_chunk, seed, list(range(i, min(i + CHUNK, count))), data) for i in starts]
        for job in jobs:
            first, seconds, statuses = job.result()
            print(f"chunk {first}: {seconds:.0f} s, {statuses.count('ok')} of {len(statuses)} finished", flush=True)


def fine_tune(model: EndStateModel, train: Examples, held: Examples, steps: int, learning_rate: float) -> list[dict]:
    """Continue training ``model`` on ``train``; the held-out loss every 100 steps."""
    torch.manual_seed(0)
    optimizer = torch.optim.AdamW(model.parameters(), learning_rate, weight_decay=1e-4)
    schedule = torch.optim.lr_scheduler.CosineAnnealingLR(optimizer, steps)
    batches = torch.Generator().manual_seed(1)
    history = []
    model.train()
    for step in range(1, steps + 1):
        loss = training_step(model, optimizer, schedule, train, 16, batches, 1.0)
        if step % 100 == 0 or step == steps:
            model.eval()
            history.append({"step": step, "train_loss": loss, "held_out_loss": held_out_loss(model, held)[0]})
            print(history[-1], flush=True)
            model.train()
    return history


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seed", type=int, default=4242)
    parser.add_argument("--realizations", type=int, default=80)
    parser.add_argument("--train", type=int, default=64)
    parser.add_argument("--steps", type=int, default=600)
    parser.add_argument("--learning-rate", type=float, default=3e-4)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--data", type=Path, default=WORK / "data")
    args = parser.parse_args()
    make_data(args.seed, args.realizations, args.data, args.workers)
    torch.set_num_threads(args.workers)
    shipped = REPO / "rgns" / "models" / "endstate.pt"
    model = load_model(shipped)
    states = read_end_states(sorted(args.data.glob(f"s{args.seed}_*.h5")))
    train = examples(model, [s for s in states if s.index < args.train])
    held = examples(model, [s for s in states if s.index >= args.train])
    before = {"train_loss": held_out_loss(model, train)[0], "held_out_loss": held_out_loss(model, held)[0]}
    start = time.perf_counter()
    history = fine_tune(model, train, held, args.steps, args.learning_rate)
    tuned = WORK / "endstate_hifi.pt"
    model.eval().save(tuned)
    record = json.loads((mf.OUT / "multifidelity.json").read_text())
    routes = {name: record["routes"][name] for name in (mf.HIGH, "MPM 1 m")}
    mf.add_endstate_route(routes, record["n"], shipped, "end-state surrogate, shipped (1 m)")
    mf.add_endstate_route(routes, record["n"], tuned, "end-state surrogate, tuned on 0.5 m")
    result = {"args": {k: str(v) for k, v in vars(args).items()}, "train": len(train), "held_out": len(held),
              "before": before, "history": history, "fine_tune_s": time.perf_counter() - start,
              "n": record["n"], "routes": routes, "machine": record["machine"]}
    result["analysis"] = mf.analyse(result)
    (mf.OUT / "hifi_surrogate.json").write_text(json.dumps(result, indent=1, default=float) + "\n")
    text = (f"Fine-tuned on {len(train)} coarse-grained 0.5 m MPM runs of case 1 (seed {args.seed}), {len(held)} "
            f"held out: held-out loss {before['held_out_loss']:.4g} (shipped) → {history[-1]['held_out_loss']:.4g} "
            f"after {args.steps} steps at {args.learning_rate:g}.\n\n" + mf.markdown(result))
    (mf.OUT / "hifi_surrogate.md").write_text(text)
    mf.plot(result, mf.OUT / "hifi_surrogate.png")
    print(text)


if __name__ == "__main__":
    main()
