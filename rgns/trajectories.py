"""The trajectory format: one HDF5 file per realization, packed files per set, GNS export.

A trajectory file holds ``positions`` [T, N, 2] float32 (chunked one frame per chunk, so frames
read sequentially fast), ``time_s`` [T], and per particle ``particle_type``, ``friction_deg``,
``volume_m2``, ``mass_kg``; attributes ``frame_interval_s``, ``bounds`` [[x0, x1], [y0, y1]],
``engine``, ``set_name``, ``index`` and ``provenance`` (the JSON of the settings that made it).

``status`` is "ok" or "diverged: <reason>"; ``energies`` [T, 3] (kinetic, potential, elastic,
J per metre width) is present when the engine reports it.

A packed set file holds one group per realization under ``trajectories/<id>`` with the same
datasets, the same attributes at the root, and ``statistics/`` with per-axis mean and standard
deviation of velocity and acceleration **in per-frame units** (m/frame, m/frame²): finite
differences of consecutive frames, never divided by the MPM time step.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from rgns.atomic import atomic_path

SOIL = 6  # particle type of soil, as in the geoelements/gns datasets
FORMAT_VERSION = 1
PER_PARTICLE = ("particle_type", "friction_deg", "volume_m2", "mass_kg")

KEEP_MODES = ("all", "ends")  # frames a simulation keeps: every one, or the first and the last two


def check_keep(keep: str) -> None:
    """A ValueError naming ``keep`` unless it is one of KEEP_MODES."""
    if keep not in KEEP_MODES:
        raise ValueError(f"keep = {keep!r}: expected one of {KEEP_MODES}")


def frame_count(duration_s: float, frame_interval_s: float) -> int:
    """Frames of a run of ``duration_s`` written every ``frame_interval_s``, the initial one included."""
    return int(round(duration_s / frame_interval_s)) + 1


def kept_frames(keep: str, frames: int) -> np.ndarray:
    """The frame numbers a simulation of ``frames`` frames keeps under ``keep``."""
    check_keep(keep)
    return np.arange(frames) if keep == "all" else np.array([0, frames - 2, frames - 1])


class TrajectoryError(ValueError):
    """A trajectory or packed file is unreadable or inconsistent; the message names the file."""


@dataclass
class Trajectory:
    """One realization's particle frames and what the surrogate needs to know of its particles."""

    positions: np.ndarray  # [T, N, 2] float32
    time_s: np.ndarray  # [T]
    particle_type: np.ndarray  # [N] int
    friction_deg: np.ndarray  # [N]
    volume_m2: np.ndarray  # [N]
    mass_kg: np.ndarray  # [N]
    frame_interval_s: float
    bounds: np.ndarray  # [[x0, x1], [y0, y1]]
    engine: str
    set_name: str
    index: int
    provenance: dict[str, Any] = field(default_factory=dict)
    status: str = "ok"  # "ok", or "diverged: <reason>" (kept out of datasets)
    energies: np.ndarray | None = None  # [T, 3] kinetic, potential, elastic (J/m), when the engine gives them

    def __post_init__(self) -> None:
        self.positions = np.asarray(self.positions, dtype=np.float32)
        problems = validate_shapes(self)
        if problems:
            raise TrajectoryError(f"{self.set_name} {self.index:04d}: " + "; ".join(problems))

    @property
    def n_frames(self) -> int:
        return self.positions.shape[0]

    @property
    def n_particles(self) -> int:
        return self.positions.shape[1]


def validate_shapes(trajectory: Trajectory) -> list[str]:
    """Shape problems of a trajectory (empty when consistent)."""
    positions = trajectory.positions
    if positions.ndim != 3 or positions.shape[2] != 2:
        return [f"positions must be [T, N, 2], got {list(positions.shape)}"]
    frames, particles = positions.shape[:2]
    problems = []
    if frames < 2:
        problems.append(f"{frames} frame(s); at least 2 are needed")
    if len(trajectory.time_s) != frames:
        problems.append(f"time_s has {len(trajectory.time_s)} entries for {frames} frames")
    for name in PER_PARTICLE:
        values = getattr(trajectory, name)
        if np.shape(values) != (particles,):
            problems.append(f"{name} has shape {list(np.shape(values))}, expected [{particles}]")
    if trajectory.energies is not None and np.shape(trajectory.energies) != (frames, 3):
        problems.append(f"energies has shape {list(np.shape(trajectory.energies))}, expected [{frames}, 3]")
    if np.shape(trajectory.bounds) != (2, 2):
        problems.append(f"bounds must be [[x0, x1], [y0, y1]], got {np.asarray(trajectory.bounds).tolist()}")
    return problems


def _compression(kind: str) -> dict[str, Any]:
    return {
        "gzip": {"compression": "gzip", "compression_opts": 1, "shuffle": True},
        "lzf": {"compression": "lzf", "shuffle": True},
        "none": {},
    }[kind]


def _write_group(group: h5py.Group, trajectory: Trajectory, compression: str) -> None:
    frames, particles = trajectory.positions.shape[:2]
    group.create_dataset("positions", data=trajectory.positions, chunks=(1, particles, 2), **_compression(compression))
    group.create_dataset("time_s", data=np.asarray(trajectory.time_s, dtype=np.float64))
    group.create_dataset("particle_type", data=np.asarray(trajectory.particle_type, dtype=np.int32))
    for name in PER_PARTICLE[1:]:
        group.create_dataset(name, data=np.asarray(getattr(trajectory, name), dtype=np.float32))
    group.attrs["frame_interval_s"] = trajectory.frame_interval_s
    group.attrs["bounds"] = np.asarray(trajectory.bounds, dtype=np.float64)
    group.attrs["engine"] = trajectory.engine
    group.attrs["set_name"] = trajectory.set_name
    group.attrs["index"] = trajectory.index
    group.attrs["provenance"] = json.dumps(trajectory.provenance, sort_keys=True)
    group.attrs["status"] = trajectory.status
    if trajectory.energies is not None:
        group.create_dataset("energies", data=np.asarray(trajectory.energies, dtype=np.float64))


def _read_group(group: h5py.Group, where: str) -> Trajectory:
    try:
        return Trajectory(
            positions=group["positions"][()],
            time_s=group["time_s"][()],
            particle_type=group["particle_type"][()],
            friction_deg=group["friction_deg"][()],
            volume_m2=group["volume_m2"][()],
            mass_kg=group["mass_kg"][()],
            frame_interval_s=float(group.attrs["frame_interval_s"]),
            bounds=group.attrs["bounds"][()],
            engine=str(group.attrs["engine"]),
            set_name=str(group.attrs["set_name"]),
            index=int(group.attrs["index"]),
            provenance=json.loads(group.attrs["provenance"]),
            status=str(group.attrs.get("status", "ok")),
            energies=group["energies"][()] if "energies" in group else None,
        )
    except KeyError as error:
        raise TrajectoryError(f"{where}: missing {error}") from error
    except TrajectoryError as error:
        raise TrajectoryError(f"{where}: {error}") from error


@contextmanager
def _atomic_h5(path: str | Path) -> Iterator[h5py.File]:
    """An HDF5 file written under a temporary name and renamed only when complete."""
    with atomic_path(path) as partial, h5py.File(partial, "w") as handle:
        handle.attrs["format_version"] = FORMAT_VERSION
        yield handle


def write_trajectory(path: str | Path, trajectory: Trajectory, compression: str = "gzip") -> None:
    """Write one realization's trajectory file (atomically: a partial file never has the name)."""
    with _atomic_h5(path) as handle:
        _write_group(handle, trajectory, compression)


def read_trajectory(path: str | Path) -> Trajectory:
    """Read a trajectory file, naming it on any defect (truncated, missing data, wrong shapes)."""
    try:
        with h5py.File(path, "r") as handle:
            return _read_group(handle, str(path))
    except OSError as error:
        raise TrajectoryError(f"{path}: not a readable HDF5 trajectory ({error})") from error


def read_status(path: str | Path) -> str:
    """Just the status of a trajectory file ("ok" or "diverged: ...")."""
    try:
        with h5py.File(path, "r") as handle:
            return str(handle.attrs.get("status", "ok"))
    except OSError as error:
        raise TrajectoryError(f"{path}: not a readable HDF5 trajectory ({error})") from error


@dataclass(frozen=True)
class MotionStatistics:
    """Per-axis mean and standard deviation of velocity and acceleration, per-frame units."""

    velocity_mean: np.ndarray
    velocity_std: np.ndarray
    acceleration_mean: np.ndarray
    acceleration_std: np.ndarray


class _Moments:
    """Running per-axis sums for a mean and standard deviation over many arrays."""

    def __init__(self) -> None:
        self.count, self.total, self.squares = 0, np.zeros(2), np.zeros(2)

    def add(self, values: np.ndarray) -> None:
        flat = values.reshape(-1, 2).astype(np.float64)
        self.count += len(flat)
        self.total += flat.sum(axis=0)
        self.squares += (flat * flat).sum(axis=0)

    def mean_std(self) -> tuple[np.ndarray, np.ndarray]:
        mean = self.total / self.count
        return mean, np.sqrt(np.maximum(self.squares / self.count - mean * mean, 0.0))


def motion_statistics(trajectories: Iterable[Trajectory]) -> MotionStatistics:
    """Velocity x[t] − x[t−1] and acceleration x[t+1] − 2x[t] + x[t−1] statistics, per axis."""
    velocity, acceleration = _Moments(), _Moments()
    for trajectory in trajectories:
        positions = trajectory.positions.astype(np.float64)
        velocity.add(np.diff(positions, axis=0))
        acceleration.add(np.diff(positions, n=2, axis=0))
    if velocity.count == 0:
        raise TrajectoryError("no trajectories to take statistics of")
    return MotionStatistics(*velocity.mean_std(), *acceleration.mean_std())


def pack(
    paths: list[str | Path], out_path: str | Path, set_name: str, compression: str = "gzip"
) -> tuple[MotionStatistics, list[str]]:
    """Pack realization files into one set file with motion statistics.

    Realizations whose status is not "ok" (diverged runs) are left out and listed in the file's
    ``excluded`` attribute. Returns the statistics and the exclusions ("<file>: <status>").
    """
    statuses = {str(path): read_status(path) for path in paths}
    excluded = [f"{path}: {status}" for path, status in statuses.items() if status != "ok"]
    paths = [path for path in paths if statuses[str(path)] == "ok"]
    if not paths:
        raise TrajectoryError(f"set {set_name}: no finished realization to pack ({len(excluded)} diverged)")
    sources = ((str(path), read_trajectory(path)) for path in paths)
    return pack_trajectories(sources, out_path, set_name, compression, excluded), excluded


def pack_trajectories(
    sources: Iterable[tuple[str, Trajectory]],
    out_path: str | Path,
    set_name: str,
    compression: str = "gzip",
    excluded: list[str] | None = None,
) -> MotionStatistics:
    """Pack trajectories of one frame layout, each named by where it came from (``sources``: name, trajectory),
    into a set file with motion statistics (``excluded``: what was left out, recorded in the file)."""
    with _atomic_h5(out_path) as handle:
        handle.attrs["set_name"] = set_name
        handle.attrs["excluded"] = json.dumps(excluded or [])
        group = handle.create_group("trajectories")
        first: list[tuple[str, Trajectory]] = []

        def copied() -> Iterator[Trajectory]:
            for source, trajectory in sources:
                if not first:
                    first.append((source, trajectory))
                    handle.attrs["frame_interval_s"] = trajectory.frame_interval_s
                    handle.attrs["bounds"] = trajectory.bounds
                elif (trajectory.frame_interval_s, trajectory.n_frames) != (
                    first[0][1].frame_interval_s,
                    first[0][1].n_frames,
                ):
                    name, one = first[0]
                    raise TrajectoryError(
                        f"{source}: {trajectory.n_frames} frames at {trajectory.frame_interval_s} s, but {name} has "
                        f"{one.n_frames} at {one.frame_interval_s} s; a set needs one frame layout"
                    )
                _write_group(group.create_group(f"{trajectory.index:04d}"), trajectory, compression)
                yield trajectory

        statistics = motion_statistics(copied())
        if not first:
            raise TrajectoryError(f"set {set_name}: no trajectory to pack")
        stats_group = handle.create_group("statistics")
        for name, value in vars(statistics).items():
            stats_group.create_dataset(name, data=value)
        stats_group.attrs["units"] = "per frame: m/frame and m/frame^2"
    return statistics


def read_packed(path: str | Path) -> Iterator[Trajectory]:
    """The trajectories of a packed set file, in index order."""
    try:
        with h5py.File(path, "r") as handle:
            group = handle["trajectories"]
            for name in sorted(group):
                yield _read_group(group[name], f"{path}:trajectories/{name}")
    except (OSError, KeyError) as error:
        raise TrajectoryError(f"{path}: not a readable packed trajectory file ({error})") from error


def read_statistics(path: str | Path) -> MotionStatistics:
    """The motion statistics of a packed set file."""
    try:
        with h5py.File(path, "r") as handle:
            group = handle["statistics"]
            return MotionStatistics(
                *(
                    group[name][()]
                    for name in ("velocity_mean", "velocity_std", "acceleration_mean", "acceleration_std")
                )
            )
    except (OSError, KeyError) as error:
        raise TrajectoryError(f"{path}: no readable statistics ({error})") from error
