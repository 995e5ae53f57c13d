"""The ``rgns`` command: helpers beside the Snakemake workflow."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from rgns.config import ConfigError, load_config
from rgns.config_reference import config_reference
from rgns.scene.sets import set_size

if TYPE_CHECKING:
    from rgns.scene.case import Case


def _check_config(args: argparse.Namespace) -> int:
    try:
        config = load_config(args.config)
    except ConfigError as error:
        message = str(error)
        print(message if message.startswith(str(args.config)) else f"{args.config}: {message}", file=sys.stderr)
        return 1
    sizes = ", ".join(f"{name} {set_size(groups)}" for name, groups in config["sets"].items())
    print(f"{args.config}: valid; realizations per set: {sizes}")
    return 0


def _config_reference(args: argparse.Namespace) -> int:
    text = config_reference()
    if args.out:
        Path(args.out).write_text(text)
    else:
        sys.stdout.write(text)
    return 0


def _trajectory_paths(cases: list[Case], out: Path) -> list[Path]:
    """``out/<set>_<index>.h5`` per case; a CaseError naming the cases when two would share a file."""
    from rgns.scene.case import CaseError

    paths = [out / f"{case.set_name}_{case.index:04d}.h5" for case in cases]
    for path in sorted(set(paths)):
        clashing = [case.source for case, other in zip(cases, paths) if other == path]
        if len(clashing) > 1:
            raise CaseError(
                f"{' and '.join(clashing)} would all write {path} (the same set name and index, or "
                "directories of the same name): run them with separate --out directories"
            )
    return paths


def _mpm(args: argparse.Namespace) -> int:
    import logging

    import torch

    from rgns.engines.cbgeo.case import read_case, to_trajectory
    from rgns.engines.mpm.solver import EngineSettings, run_batch
    from rgns.scene.case import CaseError
    from rgns.trajectories import write_trajectory

    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    torch.set_num_threads(args.threads)
    settings = EngineSettings(
        shape_function=args.shape,
        cfl=args.cfl,
        dt_max_s=args.dt_max,
        pic_blend=args.pic_blend,
        early_stop=not args.no_early_stop,
        dtype=args.dtype,
        device=args.device,
    )
    try:
        cases = [read_case(directory) for directory in args.case_dirs]
        paths = _trajectory_paths(cases, args.out) if args.out else [None] * len(cases)
        results = run_batch(cases, settings, duration_s=args.duration)
    except CaseError as error:
        print(f"rgns mpm: {error}", file=sys.stderr)
        return 2
    particle_steps = sum(len(case.positions) for case in cases) * results[0].steps
    print(
        f"{len(cases)} case(s), {results[0].steps} steps, {results[0].wall_s:.2f} s wall, "
        f"{particle_steps / results[0].wall_s:.3g} particle-steps/s (counting every case at every step)"
    )
    for case, result, path in zip(cases, results, paths):
        stop = f", stopped at {result.stopped_at_s:.2f} s" if result.stopped_at_s is not None else ""
        print(f"  {case.source}: {result.status}{stop}")
        if args.out:
            trajectory = to_trajectory(
                case,
                result.positions,
                result.time_s,
                "embedded",
                {"engine": "embedded", "settings": vars(settings)},
                status=result.status,
                energies=result.energies,
            )
            write_trajectory(path, trajectory)
    return 0 if all(result.status == "ok" for result in results) else 3


def _train(args: argparse.Namespace) -> int:
    import logging

    from rgns.surrogates.gns.train import init_distributed_from_environment, settings_from_config, train, warmup_frames

    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    config = load_config(args.config)
    model, settings = settings_from_config(config["gns"], config["mesh"]["cell_size_m"], warmup_frames(config))
    init_distributed_from_environment()  # under torchrun: one process per GPU, gradients averaged
    summary = train(model, settings, str(args.train), str(args.valid), args.out)
    print(f"trained {summary['steps']} steps in {summary['wall_s']:.0f} s (resumed from {summary['resumed_from']})")
    return 0


def _model_card(args: argparse.Namespace) -> int:
    from rgns.surrogates.shipped import render_card

    card = json.loads(args.card.read_text())
    validation = args.validation.read_text() if args.validation else None
    validated_with = load_config(args.validated_with) if args.validated_with else None
    args.out.write_text(render_card(card, validation, validated_with))
    print(f"wrote {args.out}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="rgns", description="rgns workflow helpers")
    commands = parser.add_subparsers(dest="command", required=True)
    check = commands.add_parser("check-config", help="validate a config file and summarise it")
    check.add_argument("config", type=Path)
    check.set_defaults(run=_check_config)
    reference = commands.add_parser("config-reference", help="write the Markdown config reference")
    reference.add_argument("--out", type=Path, help="file to write (default: stdout)")
    reference.set_defaults(run=_config_reference)
    mpm = commands.add_parser("mpm", help="run case directories (sharing a grid) through the embedded MPM engine")
    mpm.add_argument(
        "case_dirs",
        nargs="+",
        type=Path,
        help="CB-Geo case directories (rgns-written or plain CB-Geo), run as one batch",
    )
    mpm.add_argument(
        "--out",
        type=Path,
        help="directory for the trajectory files <set>_<index>.h5 (a plain CB-Geo case: <directory name>_0000.h5)",
    )
    mpm.add_argument(
        "--duration", type=float, help="simulated time (s); default: the case's analysis.dt x analysis.nsteps"
    )
    mpm.add_argument(
        "--shape",
        choices=["linear", "bspline"],
        default="bspline",
        help="shape functions: bspline (locking-free, the default) or linear (CB-Geo's ED2Q4)",
    )
    mpm.add_argument("--cfl", type=float, default=0.2)
    mpm.add_argument("--dt-max", type=float, default=2.5e-3)
    mpm.add_argument("--pic-blend", type=float, default=0.0)
    mpm.add_argument("--no-early-stop", action="store_true")
    mpm.add_argument("--dtype", choices=["float64", "float32"], default="float64")
    mpm.add_argument("--device", default="cpu")
    mpm.add_argument("--threads", type=int, default=1)
    mpm.set_defaults(run=_mpm)
    trainer = commands.add_parser("train", help="train the GNS (resumes from OUT/checkpoints); works under torchrun")
    trainer.add_argument("config", type=Path)
    trainer.add_argument("--train", type=Path, required=True, help="packed training set (dataset/train.h5)")
    trainer.add_argument("--valid", type=Path, required=True, help="packed validation set (dataset/valid.h5)")
    trainer.add_argument("--out", type=Path, required=True, help="directory for gns.pt, history.csv, checkpoints/")
    trainer.set_defaults(run=_train)
    card = commands.add_parser(
        "model-card", help="render a model card (card.json) as Markdown, with a validation table"
    )
    card.add_argument("card", type=Path, help="card.json")
    card.add_argument("--validation", type=Path, help="results/report/validation/table.md of a run with this model")
    card.add_argument(
        "--validated-with", type=Path, help="that run's config: the card then says what its realizations are"
    )
    card.add_argument("--out", type=Path, required=True, help="card.md to write")
    card.set_defaults(run=_model_card)
    args = parser.parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
