"""Damaged intermediates found before a run, so that the run rebuilds them.

A file cut short by a full disk, corrupted by a copy or half-written by a killed job outside
Snakemake's own bookkeeping still looks up to date to Snakemake, which then either fails the next
rule that reads it or, if nothing downstream needs to run, leaves it in place. Before the DAG is
built, :func:`sweep` reads every existing intermediate with the reader the pipeline uses for it
(a CSV table with :func:`rgns.tables.read_csv`, a trajectory with
:func:`rgns.trajectories.read_trajectory`, …); a damaged one is removed, a member of a folder
output with its whole folder, as is a folder output short of a member it must hold. Each removal
is printed with its reason. Target ``hazard_map`` asks for every table and run folder the report
rests on, so what was removed is rebuilt, and whatever was made from it runs again.

A file that passed is remembered by size and modification time (``results/.integrity.json``), so
a run with nothing changed reads nothing twice.
"""

from __future__ import annotations

import json
import shutil
import sys
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

RECORD = "results/.integrity.json"


def _read_csv(path: Path) -> None:
    from rgns.tables import read_csv

    read_csv(path)


def _read_npz(path: Path) -> None:
    with np.load(path) as data:
        for name in data.files:
            data[name]


def _read_json(path: Path) -> None:
    json.loads(path.read_text())


def _read_trajectory(path: Path) -> None:
    from rgns.trajectories import read_trajectory

    read_trajectory(path)


def _read_packed(path: Path) -> None:
    from rgns.trajectories import read_packed

    for _ in read_packed(path):
        pass


def _read_end_states(path: Path) -> None:
    from rgns.surrogates.endstate.data import read_end_states

    read_end_states([path])


def _read_zip(path: Path) -> None:
    """A PyTorch file is a zip archive: every member's checksum, without loading torch."""
    with zipfile.ZipFile(path) as archive:
        bad = archive.testzip()
    if bad is not None:
        raise ValueError(f"member {bad} fails its checksum")


def _read_scene(path: Path) -> None:
    from rgns.scene.geometry import read_scene

    read_scene(path)


def _read_field(path: Path) -> None:
    from rgns.scene.fields import read_field

    read_field(str(path))


@dataclass(frozen=True)
class Kind:
    """Files matching ``pattern`` (under the working directory), read by ``check``; ``folder``: each is
    a member of a folder output (its parent), removed as a whole."""

    pattern: str
    check: Callable[[Path], None]
    folder: bool = False


KINDS = (
    Kind("results/geometry/*/*.json", _read_scene),
    Kind("results/fields/*/*.npz", _read_field),
    Kind("results/mpm/*/chunk_*/*.h5", _read_trajectory, folder=True),
    Kind("results/dataset/*.h5", _read_packed),
    Kind("results/validation/*/pairs.csv", _read_csv),
    Kind("results/validation/*/energies.npz", _read_npz),
    Kind("results/endstate/**/*.h5", _read_end_states),
    Kind("results/model/*.pt", _read_zip),
    Kind("results/mc/**/*.csv", _read_csv),
    Kind("results/report/**/*.json", _read_json),
    Kind("results/report/**/*.csv", _read_csv),
)


def _remove(path: Path) -> None:
    if path.is_dir():
        shutil.rmtree(path)
    else:
        path.unlink(missing_ok=True)


def _indexed(expected: list[int]) -> Callable[[Path], None]:
    """A chunk table's check: whole, and holding exactly the realizations ``expected``."""

    def check(path: Path) -> None:
        from rgns.tables import read_chunk

        read_chunk(path, expected)

    return check


def sweep(
    root: str | Path = ".",
    folders: dict[str, list[str]] | None = None,
    chunks: dict[str, list[int]] | None = None,
    kinds: tuple[Kind, ...] = KINDS,
    say: Callable[[str], None] | None = None,
) -> list[str]:
    """Remove every damaged intermediate under ``root``, every folder output in ``folders`` (path to
    the member names it must hold) that lacks one and every chunk table in ``chunks`` (path to the
    realization indices it must hold) that holds others; the removed paths, each announced."""
    root = Path(root)
    say = say or (lambda line: print(line, file=sys.stderr))
    record_path = root / RECORD
    try:
        passed = json.loads(record_path.read_text())
    except (OSError, ValueError):
        passed = {}
    removed: list[str] = []
    for folder, members in (folders or {}).items():
        where = root / folder
        missing = [m for m in members if not (where / m).exists()]
        if where.is_dir() and missing:
            say(f"rgns: {folder} lacks {', '.join(missing)}: removed, so that this run makes it again")
            _remove(where)
            removed.append(folder)
    kinds = tuple(Kind(name, _indexed(indices)) for name, indices in (chunks or {}).items()) + kinds
    for kind in kinds:
        for path in sorted(root.glob(kind.pattern)):
            if not path.is_file():
                continue
            name = path.relative_to(root).as_posix()
            stat = path.stat()
            stamp = [stat.st_size, stat.st_mtime_ns]
            if passed.get(name) == stamp:
                continue
            try:
                kind.check(path)
            except Exception as error:  # noqa: BLE001 - any failure to read is damage
                target = path.parent if kind.folder else path
                what = f"{target.relative_to(root).as_posix()} (its member {path.name})" if kind.folder else name
                reason = str(error).split("; delete it and run again")[0].removeprefix(f"{path}: ")  # advice taken here
                say(
                    f"rgns: {what} is damaged ({type(error).__name__}: {reason}); removed, so that this run "
                    "makes it again"
                )
                _remove(target)
                removed.append(target.relative_to(root).as_posix())
                continue
            passed[name] = stamp
    passed = {
        key: value
        for key, value in passed.items()
        if not any(key == gone or key.startswith(gone + "/") for gone in removed)
    }
    if (root / "results").is_dir():
        record_path.write_text(json.dumps(passed, indent=0, sort_keys=True) + "\n")
    return removed


def locked(root: str | Path = ".") -> bool:
    """Whether another snakemake holds the working directory (its lock files): its outputs in progress
    would look damaged, so the sweep leaves them alone."""
    locks = Path(root) / ".snakemake" / "locks"
    return locks.is_dir() and any(locks.iterdir())


def dry_run(argv: list[str]) -> bool:
    """Whether a snakemake command line asks for a dry run (-n, --dry-run, --dryrun, or -n among short flags)."""
    return any(
        arg in ("--dry-run", "--dryrun")
        or (arg.startswith("-") and not arg.startswith("--") and arg[1:].isalpha() and "n" in arg[1:])
        for arg in argv
    )
