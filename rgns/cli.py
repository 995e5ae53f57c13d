"""The ``rgns`` command: helpers beside the Snakemake workflow."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rgns.config import ConfigError, load_config
from rgns.config_reference import config_reference
from rgns.sets import set_size


def _check_config(args: argparse.Namespace) -> int:
    try:
        config = load_config(args.config)
    except ConfigError as error:
        print(f"{args.config}: {error}", file=sys.stderr)
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="rgns", description="rgns workflow helpers")
    commands = parser.add_subparsers(dest="command", required=True)
    check = commands.add_parser("check-config", help="validate a config file and summarise it")
    check.add_argument("config", type=Path)
    check.set_defaults(run=_check_config)
    reference = commands.add_parser("config-reference", help="write the Markdown config reference")
    reference.add_argument("--out", type=Path, help="file to write (default: stdout)")
    reference.set_defaults(run=_config_reference)
    args = parser.parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
