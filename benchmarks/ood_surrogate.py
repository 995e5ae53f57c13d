"""The end-state surrogate on slopes and soils it was never trained on, against the 1 m MPM.

    snakemake --cores 2 --configfile config/pretrain_general.yaml --directory work/pretrain_general \
        --until endstate_validation_data
    python benchmarks/ood_surrogate.py --model rgns/models/endstate_general.pt --compare <previous model>.pt

The first command runs the MPM end states of config/pretrain_general.yaml's endstate.validation
sets (three geometry families no training set drew, a field model outside every training draw,
the four test cases; 64 realizations each from a seed no development choice touched), as the
pipeline's rule endstate_ood does before carding a model. This script runs the model on the
same slopes and writes, per set and metric, R², NRMSE, bias and relative bias with bootstrap 95 %
intervals over realizations, and the failed/stood confusion (``--output``.{json,md}); with
``--compare`` a second model (e.g. the previous shipped one) on the same slopes. It also times the
model and the MPM per realization, one thread each, side by side. ``--simulate`` runs the end states that
``--data`` lacks here (one thread, chunks of 16), ``--data-seed`` draws them from another seed (realizations
nothing touched).
"""

from __future__ import annotations

import argparse
import copy
import json
import time
from pathlib import Path

import pandas as pd
import torch

from rgns.config import load_config
from rgns.engines.metrics import MetricSettings
from rgns.provenance import commit
from rgns.scene.realizations import CaseInputs
from rgns.surrogates.endstate.data import EndState, read_end_states, simulate_end_states, write_end_states
from rgns.surrogates.endstate.evaluate import agreement_of, markdown_table, paired_finals, paired_metrics
from rgns.surrogates.endstate.model import load_model
from rgns.surrogates.validation import METRICS, r2_difference
from rgns.trajectories import frame_count

REPO = Path(__file__).resolve().parent.parent


def seeded(config: dict) -> dict:
    """The config drawing its sets from endstate.validation.data_seed."""
    return config | {"seed": config["endstate"]["validation"]["data_seed"]}


def set_states(data: Path, name: str, realizations: int | None = None) -> list[EndState]:
    """A set's end states in ``data`` (its first ``realizations``; None: all)."""
    states = read_end_states(sorted((data / name).glob("chunk_*.h5")))
    return [s for s in states if realizations is None or s.index < realizations]


def pairs(model_path: str, config: dict, data: Path, sets: list[str], realizations: int) -> dict[str, pd.DataFrame]:
    """Per set, R, V and I of each realization by the MPM and by a model (the first ``realizations`` of each)."""
    model = load_model(model_path)
    return {
        name: paired_metrics(
            model,
            set_states(data, name, realizations),
            CaseInputs.from_config(seeded(config), name),
            MetricSettings(**config["metrics"]),
        )
        for name in sets
    }


def differences(new: dict[str, pd.DataFrame], old: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """Per set and metric, R² of the new model minus the old one's on the same realizations, with a paired bootstrap
    interval at the Bonferroni level of all the rows (95 % for the table as a whole): a row is ``worse`` or
    ``better`` where its interval excludes 0. A model exactly as good as the old one has a row called worse with
    probability at most 2.5 %."""
    rows = []
    count = len(new) * len(METRICS)
    for name, table in new.items():
        for metric, (stem, _) in METRICS.items():
            mpm, first, second = table[f"{stem}_mpm"], table[f"{stem}_model"], old[name][f"{stem}_model"]
            delta, low, high = r2_difference(mpm, first, second, confidence=1 - 0.05 / count)
            verdict = "worse" if high < 0 else "better" if low > 0 else "–"
            rows.append(
                {"set": name, "metric": metric, "delta_r2": delta, "low": low, "high": high, "verdict": verdict}
            )
    return pd.DataFrame(rows)


def simulate_missing(config: dict, data: Path, sets: list[str], realizations: int, chunk: int = 16) -> None:
    """The MPM end states of every set's first ``realizations`` that ``data`` lacks, written there in chunks as
    the pipeline's rule endstate_validation_data writes them (a re-run reuses them)."""
    frames = frame_count(config["mpm"]["duration_s"], config["mpm"]["frame_interval_s"])
    for name in sets:
        inputs = CaseInputs.from_config(seeded(config), name)
        for k, first in enumerate(range(0, realizations, chunk)):
            path = data / name / f"chunk_{k:03d}.h5"
            if path.exists():
                continue
            path.parent.mkdir(parents=True, exist_ok=True)
            began = time.perf_counter()
            states, statuses = simulate_end_states(
                inputs, list(range(first, min(first + chunk, realizations))), config["mpm"], frames
            )
            write_end_states(path, states, statuses)
            print(f"{name}: {path.name} in {time.perf_counter() - began:.0f} s", flush=True)


def mpm_floor(config: dict, data: Path, sets: list[str], realizations: int, cfl: float) -> pd.DataFrame:
    """The same MPM at CFL number ``cfl`` against the MPM of ``data``, as if it were a model: the agreement an exact
    surrogate of either run would show. Its end states are simulated once into ``data``'s sibling
    ``<name>_cfl<cfl>`` (a re-run reuses them)."""
    other = copy.deepcopy(config)
    other["mpm"]["embedded"]["cfl"] = cfl
    again_data = data.with_name(f"{data.name}_cfl{cfl:g}")
    simulate_missing(other, again_data, sets, realizations)
    paired = {}
    for name in sets:
        again = {s.index: s.final for s in set_states(again_data, name)}
        both = [s for s in set_states(data, name, realizations) if s.index in again]
        paired[name] = paired_finals(
            both,
            [again[s.index] for s in both],
            CaseInputs.from_config(seeded(config), name),
            MetricSettings(**config["metrics"]),
        )
    return agreement_of(paired)


def cost_per_realization(model_path: str, config: dict, case: str, count: int) -> dict[str, float]:
    """Seconds per realization on one thread: the MPM's run and the model's prediction, same slopes."""
    torch.set_num_threads(1)
    inputs = CaseInputs.from_config(seeded(config), case)
    began = time.perf_counter()
    states, _ = simulate_end_states(
        inputs,
        list(range(count)),
        config["mpm"],
        frame_count(config["mpm"]["duration_s"], config["mpm"]["frame_interval_s"]),
    )
    mpm_s = (time.perf_counter() - began) / count
    model = load_model(model_path)
    model.predict([states[0].initial], [states[0].friction_deg])  # warm-up
    began = time.perf_counter()
    model.predict([s.initial for s in states], [s.friction_deg for s in states])
    model_s = (time.perf_counter() - began) / len(states)
    return {"case": case, "realizations": count, "mpm_s": mpm_s, "model_s": model_s, "ratio": mpm_s / model_s}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--config", default=str(REPO / "config" / "pretrain_general.yaml"))
    parser.add_argument(
        "--data", default=str(REPO / "work" / "pretrain_general" / "results" / "endstate" / "validation")
    )
    parser.add_argument("--model", default=str(REPO / "rgns" / "models" / "endstate_general.pt"))
    parser.add_argument("--compare", help="a second model file, evaluated on the same slopes")
    parser.add_argument("--sets", nargs="+", help="sets of the config (default: all)")
    parser.add_argument("--realizations", type=int, default=64)
    parser.add_argument("--time-realizations", type=int, default=8, help="case-1 realizations timed (0: none)")
    parser.add_argument("--output", default=str(REPO / "benchmarks" / "results" / "ood_surrogate"))
    parser.add_argument("--data-seed", type=int, help="in place of the config's endstate.validation.data_seed")
    parser.add_argument("--simulate", action="store_true", help="run the MPM end states --data lacks (one thread)")
    parser.add_argument(
        "--mpm-floor",
        type=float,
        metavar="CFL",
        help="also the MPM at this CFL number (the config's: 0.2) against the MPM, as a model: what an exact "
        "surrogate of either run would score (its end states simulated once beside --data, one thread)",
    )
    args = parser.parse_args()
    config = load_config(args.config)
    if args.data_seed is not None:
        config["endstate"]["validation"]["data_seed"] = args.data_seed
    sets = args.sets or config["endstate"]["validation"]["sets"]
    if args.simulate:
        torch.set_num_threads(1)
        simulate_missing(config, Path(args.data), sets, args.realizations)
    result = {
        "command": "python benchmarks/ood_surrogate.py "
        + " ".join(
            f"--{k.replace('_', '-')}" + ("" if v is True else f" {' '.join(v) if isinstance(v, list) else v}")
            for k, v in vars(args).items()
            if v not in (None, False) and k != "output"
        ),
        "config": args.config,
        "data_seed": config["endstate"]["validation"]["data_seed"],
        "commit": commit(),
    }
    paired = {"model": pairs(args.model, config, Path(args.data), sets, args.realizations)}
    if args.compare:
        paired["compare"] = pairs(args.compare, config, Path(args.data), sets, args.realizations)
    tables = {name: agreement_of(table) for name, table in paired.items()}
    if args.compare:
        tables["difference"] = differences(paired["model"], paired["compare"])
    if args.mpm_floor:
        tables["mpm_floor"] = mpm_floor(config, Path(args.data), sets, args.realizations, args.mpm_floor)
    result |= {name: table.to_dict("records") for name, table in tables.items()}
    if args.time_realizations:
        result["cost"] = cost_per_realization(args.model, config, "case1", args.time_realizations)
    Path(args.output + ".json").write_text(json.dumps(result, indent=2) + "\n")
    lines = [
        f"# End-state surrogate out of distribution (seed {result['data_seed']})",
        "",
        f"`{result['command']}`",
        "",
        f"## {args.model}",
        "",
        markdown_table(tables["model"]),
    ]
    if args.compare:
        lines += [f"## {args.compare}", "", markdown_table(tables["compare"])]
        change = tables["difference"]
        lines += [
            f"## R² of {args.model} minus {args.compare}, same realizations",
            "",
            f"Paired bootstrap intervals at {100 * (1 - 0.05 / len(change)):.2f} % each (95 % for the {len(change)} "
            "rows together): a row is worse or better where its interval excludes 0.",
            "",
            "| set | metric | ΔR² | interval | verdict |",
            "| --- | --- | ---: | --- | --- |",
            *(
                f"| {r.set} | {r.metric} | {r.delta_r2:+.3f} | [{r.low:+.3f}, {r.high:+.3f}] | {r.verdict} |"
                for r in change.itertuples()
            ),
            "",
            f"Better in {(change.verdict == 'better').sum()} rows, worse in {(change.verdict == 'worse').sum()}, "
            f"higher point R² in {(change.delta_r2 > 0).sum()} of {len(change)}.",
            "",
        ]
    if args.mpm_floor:
        lines += [
            f"## The MPM at CFL {args.mpm_floor:g} against the MPM (as a model: an exact surrogate's agreement)",
            "",
            markdown_table(tables["mpm_floor"]),
        ]
    if "cost" in result:
        cost = result["cost"]
        lines += [
            f"Cost per realization, one thread, {cost['realizations']} case-1 realizations: MPM "
            f"{cost['mpm_s']:.2f} s, model {cost['model_s'] * 1000:.1f} ms ({cost['ratio']:.0f}× cheaper).",
            "",
        ]
    Path(args.output + ".md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
