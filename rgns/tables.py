"""CSV tables written atomically and read back with a clear error naming the file."""
from __future__ import annotations

import os
from pathlib import Path

import pandas as pd


class TableError(ValueError):
    """A table file is missing, unreadable or lacks a column; the message names the file."""


def write_csv(table: pd.DataFrame, path: str | Path) -> None:
    """Write ``table`` to ``path`` through a temporary file, so a killed job leaves no half table."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(path.name + ".partial")
    table.to_csv(partial, index=False)
    os.replace(partial, path)


def read_csv(path: str | Path, columns: list[str] | None = None) -> pd.DataFrame:
    """A table, checked for ``columns``."""
    try:
        table = pd.read_csv(path)
    except (OSError, ValueError) as error:
        raise TableError(f"{path}: not a readable CSV table ({error})") from error
    missing = [c for c in columns or [] if c not in table.columns]
    if missing:
        raise TableError(f"{path}: missing column(s) {missing}")
    return table


def concatenate_csv(paths: list[str | Path], key: str) -> pd.DataFrame:
    """Tables stacked and sorted by ``key``; a key seen twice is an error naming both files."""
    tables = [read_csv(path, [key]).assign(_source=str(path)) for path in paths]
    table = pd.concat(tables, ignore_index=True).sort_values(key, kind="stable")
    repeated = table[table.duplicated(key, keep=False)]
    if len(repeated):
        first = repeated.iloc[0]
        sources = sorted(set(repeated[repeated[key] == first[key]]["_source"]))
        raise TableError(f"{key} {first[key]} appears in more than one table: {', '.join(sources)}")
    return table.drop(columns="_source").reset_index(drop=True)
