"""A trajectory's particles as coarse nodes, its frames at a stride: what a lean GNS learns from on the CPU.

A node is the group of particles that start in one square cell of side ``spacing_m`` (anchored at the domain's
lower corner, so the groups are Lagrangian: a particle never changes node). It moves with its members'
mass-weighted centroid and carries their summed volume and mass and the mean of their tan φ (as the angle of
that tangent). One network step then spans ``stride`` frames and sees a few hundred nodes where the MPM has
thousands of particles. R, V and I measured on the nodes follow the particles' (tests/surrogates/test_gns_coarse.py).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from itertools import chain
from pathlib import Path

import numpy as np

from rgns.trajectories import Trajectory, TrajectoryError, pack_trajectories, read_packed


def node_labels(initial: np.ndarray, bounds: np.ndarray, spacing_m: float) -> np.ndarray:
    """The node [N] of each particle: its starting cell, numbered 0 … G − 1 in row-major order of the cells."""
    if not spacing_m > 0:
        raise ValueError(f"node spacing must be positive, got {spacing_m}")
    cells = np.floor((np.asarray(initial, dtype=float) - np.asarray(bounds, dtype=float)[:, 0]) / spacing_m)
    return np.unique(cells[:, ::-1].astype(np.int64), axis=0, return_inverse=True)[1].reshape(-1)


def group_sum(values: np.ndarray, labels: np.ndarray, groups: int) -> np.ndarray:
    """Sum of ``values`` [..., N] over each node's particles → [..., G]."""
    values = np.asarray(values, dtype=float)
    flat = values.reshape(-1, values.shape[-1])
    out = np.zeros((flat.shape[0], groups))
    for row, data in zip(out, flat):
        row += np.bincount(labels, weights=data, minlength=groups)
    return out.reshape(*values.shape[:-1], groups)


def coarse_trajectory(trajectory: Trajectory, spacing_m: float, stride: int) -> Trajectory:
    """The trajectory as nodes of ``spacing_m`` (see the module) at every ``stride``-th frame, the last real
    frame kept: a run is measured where it ended."""
    if stride < 1:
        raise ValueError(f"frame stride must be at least 1, got {stride}")
    labels = node_labels(trajectory.positions[0], trajectory.bounds, spacing_m)
    groups = int(labels.max()) + 1
    frames = np.arange(0, trajectory.n_frames, stride)
    if frames[-1] != trajectory.n_frames - 1:
        frames = np.append(frames, trajectory.n_frames - 1)
    mass = np.asarray(trajectory.mass_kg, dtype=float)
    node_mass = group_sum(mass, labels, groups)
    weighted = group_sum(np.moveaxis(trajectory.positions[frames] * mass[:, None], 2, 1), labels, groups)
    positions = np.moveaxis(weighted / node_mass, 1, 2)  # [T', G, 2]
    tangent = group_sum(np.tan(np.radians(trajectory.friction_deg)), labels, groups) / np.bincount(labels)
    return replace(
        trajectory,
        positions=positions.astype(np.float32),
        time_s=np.asarray(trajectory.time_s)[frames],
        particle_type=np.asarray(trajectory.particle_type)[np.unique(labels, return_index=True)[1]],
        friction_deg=np.degrees(np.arctan(tangent)),
        volume_m2=group_sum(trajectory.volume_m2, labels, groups),
        mass_kg=node_mass,
        frame_interval_s=trajectory.frame_interval_s * stride,
        energies=None if trajectory.energies is None else np.asarray(trajectory.energies)[frames],
        provenance=trajectory.provenance | {"coarse": {"node_spacing_m": spacing_m, "stride_frames": stride}},
    )


def coarse_set(packed: str | Path, out_path: str | Path, spacing_m: float, stride: int) -> int:
    """A packed set file's trajectories coarse-grained into a packed set of their own, one at a time (a training
    set is hundreds of megabytes); returns how many."""
    trajectories = read_packed(packed)
    first = next(trajectories, None)
    if first is None:
        raise TrajectoryError(f"{packed}: holds no trajectories")
    count = 0

    def coarse() -> Iterator[tuple[str, Trajectory]]:
        nonlocal count
        for trajectory in chain([first], trajectories):
            if trajectory.n_frames != first.n_frames:
                raise TrajectoryError(
                    f"{packed}: trajectories of {first.n_frames} and {trajectory.n_frames} frames; a set needs one "
                    "frame layout"
                )
            count += 1
            yield f"{packed} trajectory {trajectory.index:04d}", coarse_trajectory(trajectory, spacing_m, stride)

    pack_trajectories(coarse(), out_path, first.set_name)
    return count
