"""CSV tables written atomically and read back with a clear error naming the file; tables as Markdown."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pandas as pd

from rgns.atomic import atomic_path


class TableError(ValueError):
    """A table file is missing, unreadable or lacks a column; the message names the file."""


def write_csv(table: pd.DataFrame, path: str | Path) -> None:
    """Write ``table`` to ``path`` through a temporary file, so a killed job leaves no half table."""
    with atomic_path(path) as partial:
        table.to_csv(partial, index=False)


def _last_byte(path: str | Path) -> bytes:
    """The file's last byte (empty for an empty file)."""
    with open(path, "rb") as handle:
        if handle.seek(0, os.SEEK_END) == 0:
            return b""
        handle.seek(-1, os.SEEK_END)
        return handle.read(1)


def read_csv(path: str | Path, columns: list[str] | None = None) -> pd.DataFrame:
    """A table, checked for ``columns`` and for being whole (every table written here ends with a
    newline; one cut short by a full disk or a copy would otherwise read as a row of blanks)."""
    try:
        if _last_byte(path) not in (b"", b"\n"):
            raise TableError(f"{path}: cut short (no newline after its last row); delete it and run again")
        table = pd.read_csv(path)
    except TableError:
        raise
    except (OSError, ValueError) as error:
        raise TableError(f"{path}: not a readable CSV table ({error})") from error
    missing = [c for c in columns or [] if c not in table.columns]
    if missing:
        raise TableError(f"{path}: missing column(s) {missing}")
    return table


def read_chunk(path: str | Path, expected: list[int], columns: list[str] | None = None) -> pd.DataFrame:
    """A Monte Carlo chunk table, checked to be whole and to hold exactly the realizations ``expected``
    (one cut short, or left over from another montecarlo config, is named)."""
    table = read_csv(path, columns or ["index"])
    held = sorted(table["index"].tolist())
    if held != list(expected):
        raise TableError(
            f"{path}: holds realizations {held}, not {list(expected)} (cut short, or from another "
            "montecarlo config); delete it and run again"
        )
    return table


def _markdown_cell(value: object, digits: int) -> str:
    """One table cell: floats to ``digits`` decimals, NaN as an en dash, pipes escaped."""
    if isinstance(value, (float, np.floating)):
        return "–" if math.isnan(value) else f"{value:.{digits}f}"
    return str(value).replace("|", "\\|")


def markdown_table(table: pd.DataFrame, digits: int = 3) -> str:
    """GitHub Markdown table of ``table``; numeric columns right-aligned."""
    numeric = [pd.api.types.is_numeric_dtype(table[column]) for column in table.columns]
    lines = [
        "| " + " | ".join(str(column) for column in table.columns) + " |",
        "| " + " | ".join("---:" if is_number else "---" for is_number in numeric) + " |",
    ]
    for row in table.itertuples(index=False):
        lines.append("| " + " | ".join(_markdown_cell(value, digits) for value in row) + " |")
    return "\n".join(lines) + "\n"
