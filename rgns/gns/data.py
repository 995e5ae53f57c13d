"""Training windows from a packed set file: ``history + 1`` input frames and the frames after.

Small sets are read into memory once; large ones are read window by window from the HDF5 file
(positions are chunked one frame per chunk, so a window is a few chunk reads).
"""
from __future__ import annotations

from dataclasses import dataclass

import h5py
import numpy as np
import torch

from rgns.gns.simulator import GraphInput, Normalization
from rgns.trajectories import TrajectoryError, read_statistics

IN_MEMORY_BYTES = 2 * 1024 ** 3


@dataclass
class Window:
    """A batch of windows: inputs, the targets after them (``targets`` [N, steps, 2])."""

    graph: GraphInput
    targets: torch.Tensor


class WindowSampler:
    """Random (trajectory, start frame) windows of a packed set, batched as disjoint graphs."""

    def __init__(self, path: str, history: int, target_steps: int = 1):
        self.path, self.history, self.length = path, history, history + 1 + target_steps
        try:
            self.file = h5py.File(path, "r")
            group = self.file["trajectories"]
        except (OSError, KeyError) as error:
            raise TrajectoryError(f"{path}: not a readable packed trajectory file ({error})") from error
        self.groups = [group[name] for name in sorted(group)]
        if not self.groups:
            raise TrajectoryError(f"{path}: holds no trajectories")
        self.frames = self.groups[0]["positions"].shape[0]
        if self.frames < self.length:
            raise TrajectoryError(f"{path}: {self.frames} frames, fewer than the {self.length} a window needs")
        self.particle_type = [torch.as_tensor(g["particle_type"][()], dtype=torch.long) for g in self.groups]
        self.tan_friction = [torch.tensor(np.tan(np.radians(g["friction_deg"][()])), dtype=torch.float32)
                             for g in self.groups]
        size = sum(g["positions"].size for g in self.groups) * 4
        self.positions = [g["positions"][()] for g in self.groups] if size <= IN_MEMORY_BYTES else None

    @property
    def n_trajectories(self) -> int:
        return len(self.groups)

    @property
    def bounds(self) -> np.ndarray:
        return self.file.attrs["bounds"][()]

    def frames_of(self, trajectory: int, start: int, count: int) -> np.ndarray:
        """Frames [count, N, 2] of one trajectory from ``start``."""
        source = self.positions[trajectory] if self.positions is not None else self.groups[trajectory]["positions"]
        return np.asarray(source[start:start + count], dtype=np.float32)

    def window(self, picks: list[tuple[int, int]]) -> Window:
        """The windows starting at (trajectory, frame) for each pick, as one batch."""
        positions, types, friction, batch = [], [], [], []
        for graph, (trajectory, start) in enumerate(picks):
            frames = torch.from_numpy(self.frames_of(trajectory, start, self.length)).transpose(0, 1)  # [N, L, 2]
            positions.append(frames)
            types.append(self.particle_type[trajectory])
            friction.append(self.tan_friction[trajectory])
            batch.append(torch.full((frames.shape[0],), graph, dtype=torch.long))
        positions = torch.cat(positions)
        inputs = positions[:, :self.history + 1]
        graph = GraphInput(inputs.contiguous(), torch.cat(types), torch.cat(friction), torch.cat(batch), len(picks))
        return Window(graph, positions[:, self.history + 1:].contiguous())

    def sample(self, rng: np.random.Generator, graphs: int) -> Window:
        """``graphs`` windows drawn uniformly over trajectories and start frames."""
        trajectories = rng.integers(0, self.n_trajectories, graphs)
        starts = rng.integers(0, self.frames - self.length + 1, graphs)
        return self.window(list(zip(trajectories.tolist(), starts.tolist())))


def normalization_of(path: str) -> Normalization:
    """Velocity / acceleration statistics of a packed set and the mean / std of its tan φ."""
    statistics = read_statistics(path)
    with h5py.File(path, "r") as handle:
        group = handle["trajectories"]
        tangent = np.concatenate([np.tan(np.radians(group[name]["friction_deg"][()])) for name in group])
    floor = 1e-8  # a constant feature or a set at rest must not divide by zero
    return Normalization(
        velocity_mean=statistics.velocity_mean.tolist(),
        velocity_std=np.maximum(statistics.velocity_std, floor).tolist(),
        acceleration_mean=statistics.acceleration_mean.tolist(),
        acceleration_std=np.maximum(statistics.acceleration_std, floor).tolist(),
        tan_friction_mean=float(tangent.mean()),
        tan_friction_std=float(max(tangent.std(), 1e-3)),
    )
