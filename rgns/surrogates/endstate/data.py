"""End states for training the end-state surrogate: realizations of the test cases drawn from an
independent seed, run by the embedded MPM, only their first and last frames kept.

One HDF5 file per chunk, one group per realization (``initial``, ``final`` [N, 2], ``friction_deg``,
``volume_m2`` [N]; attributes ``index``, ``case``), a root attribute ``statuses`` listing every run.
Runs that did not finish ("diverged: …") are listed there and not stored.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from rgns.atomic import atomic_path
from rgns.engines.batch import simulate_mpm
from rgns.engines.settings import MpmSettings
from rgns.scene.realizations import CaseInputs, draw_realization


class EndStateDataError(ValueError):
    """An end-state file that cannot be read; the message names it."""


@dataclass
class EndState:
    """One realization's material points at rest before and after its MPM run."""

    case: str
    index: int
    initial: np.ndarray  # [N, 2]
    final: np.ndarray  # [N, 2]
    friction_deg: np.ndarray  # [N]
    volume_m2: np.ndarray  # [N]


def simulate_end_states(
    inputs: CaseInputs, indices: list[int], mpm: dict[str, Any], frames: int
) -> tuple[list[EndState], list[str]]:
    """Run realizations ``indices`` of a case through the embedded MPM in one batch (config section ``mpm``,
    as the rule passes it); the finished ones as end states, and every run's status."""
    batch = [draw_realization(inputs, i) for i in indices]
    results = simulate_mpm(batch, MpmSettings.from_config(mpm), frames, keep="ends")
    states = [
        EndState(inputs.case, r.index, r.scene.positions, s.positions[-1], r.friction_deg, r.scene.volumes)
        for r, s in zip(batch, results)
        if s.status == "ok"
    ]
    return states, [s.status for s in results]


def write_end_states(path: str | Path, states: list[EndState], statuses: list[str]) -> None:
    """One chunk's end states, written atomically."""
    with atomic_path(path) as partial, h5py.File(partial, "w") as handle:
        handle.attrs["statuses"] = json.dumps(statuses)
        for state in states:
            group = handle.create_group(f"{state.case}/{state.index:05d}")
            group.attrs["index"], group.attrs["case"] = state.index, state.case
            for name in ("initial", "final", "friction_deg", "volume_m2"):
                group.create_dataset(name, data=np.asarray(getattr(state, name), dtype=np.float64))


def read_end_states(paths: list[str | Path]) -> list[EndState]:
    """Every end state of the chunk files, in file then index order."""
    states = []
    for path in paths:
        try:
            with h5py.File(path, "r") as handle:
                for case in handle:
                    for name in sorted(handle[case]):
                        group = handle[case][name]
                        states.append(
                            EndState(
                                str(group.attrs["case"]),
                                int(group.attrs["index"]),
                                *(group[key][()] for key in ("initial", "final", "friction_deg", "volume_m2")),
                            )
                        )
        except (OSError, KeyError) as error:
            raise EndStateDataError(
                f"{path}: not a readable end-state file ({error}); delete it and run again"
            ) from error
    return states
