"""Deterministic random streams: realization i of a set always draws the same numbers.

A stream is keyed by (base seed, set name, realization index, purpose), never by job order or
chunking, so re-running one realization, or splitting a set differently, reproduces it exactly.
"""

from __future__ import annotations

import zlib

import numpy as np

STREAMS = ("geometry", "field")  # Monte Carlo realizations reuse these: realization i of a case is drawn once


def _name_key(name: str) -> int:
    return zlib.crc32(name.encode("utf-8"))


def realization_seed(base_seed: int, set_name: str, index: int, stream: str) -> np.random.SeedSequence:
    """The seed sequence of one realization's stream (``stream`` in :data:`STREAMS`)."""
    if stream not in STREAMS:
        raise ValueError(f"unknown random stream {stream!r}; expected one of {STREAMS}")
    if index < 0:
        raise ValueError(f"realization index must be >= 0, got {index}")
    return np.random.SeedSequence(
        entropy=int(base_seed), spawn_key=(_name_key(set_name), int(index), STREAMS.index(stream))
    )


def realization_rng(base_seed: int, set_name: str, index: int, stream: str) -> np.random.Generator:
    """A generator for one realization's stream."""
    return np.random.default_rng(realization_seed(base_seed, set_name, index, stream))
