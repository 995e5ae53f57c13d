"""Realization sets: a list of groups, realizations numbered through the groups in order."""

from __future__ import annotations

from typing import Any


def test_cases(sets: dict[str, Any]) -> list[str]:
    """The sets that are test cases: every one but the training sets, ``train`` and ``valid``."""
    return [name for name in sets if name not in ("train", "valid")]


def set_size(groups: list[dict[str, Any]]) -> int:
    """Number of realizations in a set."""
    return sum(int(group["count"]) for group in groups)


def realization_group(groups: list[dict[str, Any]], index: int) -> tuple[int, dict[str, Any]]:
    """The (group number, group) that realization ``index`` of the set belongs to."""
    start = 0
    for number, group in enumerate(groups):
        if index < start + int(group["count"]):
            return number, group
        start += int(group["count"])
    raise IndexError(f"realization {index} is beyond the set's {start} realizations")


def realization_ids(groups: list[dict[str, Any]]) -> list[str]:
    """File-name ids of every realization of a set: '0000', '0001', ..."""
    return [format_id(i) for i in range(set_size(groups))]


def format_id(index: int) -> str:
    """The zero-padded id used in file names."""
    return f"{index:04d}"
