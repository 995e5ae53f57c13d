"""Where a document's figures come from: the committed result files and model cards, checked to say what made them."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks" / "results"


# an absolute path in a recorded command: the checkout it ran in (up to a folder of the repository), or scratch
CHECKOUT = re.compile(r"(?<![\w/.])/(?:[\w.+-]+/)+?(?=(?:config|rgns|benchmarks|tests|docs|results)/)")
SCRATCH = re.compile(r"(?<![\w/.])/tmp/")


def portable(command: str) -> str:
    """A recorded command as a reader can run it: paths inside the checkout it ran in made relative, scratch
    folders shown as ``<scratch>/``."""
    return SCRATCH.sub("<scratch>/", CHECKOUT.sub("", command))


class DocumentError(ValueError):
    """A rendered passage that names no renderer, or a result file that lacks what a passage needs."""


def parts(record: Any) -> Iterator[dict[str, Any]]:
    """Every dict within a result record, itself first (a result made in runs records each run's commit)."""
    if isinstance(record, dict):
        yield record
        for value in record.values():
            yield from parts(value)
    elif isinstance(record, list):
        for value in record:
            yield from parts(value)


def result(name: str, legacy: bool = False) -> dict[str, Any]:
    """A committed result file, checked to record its command and commit. ``legacy``: a file made before results
    recorded their commit must say which commit committed it (``"committed_in"``), named in its place."""
    path = RESULTS / name
    shown = path.relative_to(REPO) if path.is_relative_to(REPO) else path
    if not path.exists():
        raise DocumentError(f"{shown}: no such result file")
    record = json.loads(path.read_text())
    made = list(parts(record))
    for part in made:
        if isinstance(part.get("command"), str):
            part["command"] = portable(part["command"])
    if legacy and not any(part.get(key) for part in made for key in ("commit", "commits")):
        if not record.get("committed_in"):
            raise DocumentError(f"{shown}: records no commit, nor the commit that committed it ('committed_in')")
        return record
    for keys in (("commit", "commits"), ("command", "commands")):
        if not any(part.get(key) for part in made for key in keys):
            raise DocumentError(f"{shown}: records no {' or '.join(keys)}")
    return record


def card(name: str) -> dict[str, Any]:
    """A shipped model's card (rgns/models/<name>), written by the rule that trained the model beside it."""
    path = REPO / "rgns" / "models" / name
    if not path.exists():
        raise DocumentError(f"{path.relative_to(REPO)}: no such model card")
    return json.loads(path.read_text())


def made_note(record: dict[str, Any]) -> str:
    """The commit a result file records, or the one that committed it where it records none."""
    return record.get("commit") or f"committed in {record['committed_in']}, which the file does not record"
