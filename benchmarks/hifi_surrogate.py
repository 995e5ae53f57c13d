"""Can a cheap route correlate better with the 0.5 m MPM than the 1 m MPM does? The geometry-general end-state
surrogate fine-tuned on 0.5 m MPM runs, as the cheap route of the multi-fidelity benchmark.

    python benchmarks/hifi_surrogate.py --realizations 80 --train 64 --steps 600 --learning-rate 3e-4

1. Case-1 realizations of another seed (``--seed``; the pool is the default seed's 0..63) run by the
   embedded MPM at 0.5 m cells, each end state coarse-grained onto the 1 m mesh's point lattice
   (``rgns.surrogates.endstate.tuning.simulate_tuning_states``, as the pipeline's rule tuned_data). Chunks of 8,
   cached in ``--data``.
2. The geometry-general model (``rgns/models/endstate_general.pt``; results before 2026-11-29 started from the
   retired test-case model) trained further on the first ``--train`` of them
   (``rgns.surrogates.endstate.tuning.fine_tune``, as the pipeline's rule tune_endstate); the rest are held out.
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

import multifidelity as mf
import torch
from suite import case_inputs

from rgns.config import load_config
from rgns.provenance import commit
from rgns.surrogates.endstate.data import read_end_states, write_end_states
from rgns.surrogates.endstate.model import load_model
from rgns.surrogates.endstate.train import examples, held_out_loss
from rgns.surrogates.endstate.tuning import TuneSettings, fine_tune, simulate_tuning_states
from rgns.trajectories import frame_count

REPO = Path(__file__).resolve().parent.parent
WORK = REPO / "benchmarks" / "results" / "models" / "hifi"
CHUNK = 8


def run_chunk(seed: int, indices: list[int], data: Path) -> tuple[int, float, list[str]]:
    """Realizations ``indices`` by the 0.5 m MPM, coarse-grained, written as one end-state chunk."""
    torch.set_num_threads(1)
    config = load_config(REPO / "config" / "config.yaml")
    config["seed"] = seed
    mpm = config["mpm"]
    start = time.perf_counter()
    states, statuses = simulate_tuning_states(
        case_inputs(config, "case1", 1.0),
        case_inputs(config, "case1", 0.5),
        indices,
        mpm,
        frame_count(mpm["duration_s"], mpm["frame_interval_s"]),
    )
    write_end_states(data / f"s{seed}_{indices[0]:04d}.h5", states, statuses)
    return indices[0], time.perf_counter() - start, statuses


def make_data(seed: int, count: int, data: Path, workers: int) -> None:
    """Every missing chunk of realizations 0..count-1."""
    data.mkdir(parents=True, exist_ok=True)
    starts = [i for i in range(0, count, CHUNK) if not (data / f"s{seed}_{i:04d}.h5").exists()]
    with ProcessPoolExecutor(workers) as pool:
        jobs = [pool.submit(run_chunk, seed, list(range(i, min(i + CHUNK, count))), data) for i in starts]
        for job in jobs:
            first, seconds, statuses = job.result()
            print(f"chunk {first}: {seconds:.0f} s, {statuses.count('ok')} of {len(statuses)} finished", flush=True)


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
    shipped = REPO / "rgns" / "models" / "endstate_general.pt"
    model = load_model(shipped)
    states = read_end_states(sorted(args.data.glob(f"s{args.seed}_*.h5")))
    train = examples(model, [s for s in states if s.index < args.train])
    held = examples(model, [s for s in states if s.index >= args.train])
    before = {"train_loss": held_out_loss(model, train)[0], "valid_loss": held_out_loss(model, held)[0]}
    start = time.perf_counter()
    history = fine_tune(model, train, held, TuneSettings(steps=args.steps, learning_rate=args.learning_rate))
    tuned = WORK / "endstate_hifi.pt"
    model.eval().save(tuned)
    record = json.loads((mf.OUT / "multifidelity.json").read_text())
    routes = {name: record["routes"][name] for name in (mf.HIGH, "MPM 1 m")}
    mf.add_endstate_route(routes, record["n"], shipped, "end-state surrogate, shipped (1 m)")
    mf.add_endstate_route(routes, record["n"], tuned, "end-state surrogate, tuned on 0.5 m")
    result = {
        "command": "python benchmarks/hifi_surrogate.py "
        + " ".join(f"--{k.replace('_', '-')} {v}" for k, v in vars(args).items() if k != "data"),
        "commit": commit(),
        "args": {k: str(v) for k, v in vars(args).items()},
        "train": len(train),
        "held_out": len(held),
        "before": before,
        "history": history,
        "fine_tune_s": time.perf_counter() - start,
        "n": record["n"],
        "routes": routes,
        "machine": record["machine"],
    }
    result["analysis"] = mf.analyse(result)
    (mf.OUT / "hifi_surrogate.json").write_text(json.dumps(result, indent=1, default=float) + "\n")
    text = (
        f"Fine-tuned on {len(train)} coarse-grained 0.5 m MPM runs of case 1 (seed {args.seed}), {len(held)} "
        f"held out: held-out loss {before['valid_loss']:.4g} (shipped) → {history[-1]['valid_loss']:.4g} "
        f"after {args.steps} steps at {args.learning_rate:g}.\n\n" + mf.markdown(result)
    )
    (mf.OUT / "hifi_surrogate.md").write_text(text)
    mf.plot(result, mf.OUT / "hifi_surrogate.png")
    print(text)


if __name__ == "__main__":
    main()
