"""Training windows from a packed set file: ``history + 1`` input frames and the frames after.

Two things about MPM trajectories decide whether a GNS can learn from them (docs/gns-training.md):

* A run that stopped early is padded with copies of its last state; those frames are not
  simulation and are never drawn (``real_frames``).
* The per-frame MPM acceleration is mostly frame-scale jitter that no function of the inputs
  predicts; windows are read from trajectories smoothed in time with a Gaussian of
  ``smoothing_frames`` (0 = raw). Rollouts still start from the raw frames (``frames_of``).

Small sets are read into memory once; large ones are read window by window from the HDF5 file
(positions are chunked one frame per chunk, so a window is a few chunk reads).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import h5py
import numpy as np
import torch
from scipy.ndimage import gaussian_filter1d

from rgns.surrogates.gns.simulator import GraphInput, Normalization, static_features
from rgns.trajectories import TrajectoryError

IN_MEMORY_BYTES = 2 * 1024**3
TRUNCATE = 4.0  # the Gaussian filter's reach in standard deviations (scipy's default)


@dataclass
class Window:
    """A batch of windows: inputs, the targets after them (``targets`` [N, steps, 2])."""

    graph: GraphInput
    targets: torch.Tensor


def real_frames(positions: np.ndarray) -> int:
    """Frames before the padding of an early stop: up to the last frame that differs from its predecessor."""
    changed = np.flatnonzero(np.any(positions[1:] != positions[:-1], axis=(1, 2)))
    return int(changed[-1]) + 2 if len(changed) else 1


class WindowSampler:
    """Random (trajectory, start frame) windows of a packed set's real frames, batched as disjoint graphs."""

    def __init__(self, path: str, history: int, target_steps: int = 1, smoothing_frames: float = 0.0):
        self.path, self.history, self.length = path, history, history + 1 + target_steps
        self.first_frame = 0
        self.smoothing_frames = float(smoothing_frames)
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
        self.tan_friction = [
            torch.tensor(np.tan(np.radians(g["friction_deg"][()])), dtype=torch.float32) for g in self.groups
        ]
        self.volume_m2 = [g["volume_m2"][()] for g in self.groups]
        size = sum(g["positions"].size for g in self.groups) * 4
        self.positions = [g["positions"][()] for g in self.groups] if size <= IN_MEMORY_BYTES else None
        self.static = [
            torch.from_numpy(static_features(self.frames_of(k, 0, 1)[0], self.bounds)) for k in range(len(self.groups))
        ]
        self.real = [
            real_frames(self.positions[k] if self.positions is not None else g["positions"][()])
            for k, g in enumerate(self.groups)
        ]
        self.starts = self._window_starts()

    def _window_starts(self) -> np.ndarray:
        """Per trajectory, how many windows of ``length`` frames start at ``first_frame`` or later."""
        # windows lie inside a trajectory's real frames; where a run went on to the last frame, the
        # smoothing would hold that frame, so the last reach of frames is left out too (an early-stopped
        # run is at rest at its end and an MPM run at its start: holding those is right)
        reach = math.ceil(TRUNCATE * self.smoothing_frames) if self.smoothing_frames > 0 else 0
        usable = [real if real < self.frames else self.frames - reach for real in self.real]
        starts = np.array([max(0, end - self.length + 1 - self.first_frame) for end in usable])
        if starts.sum() == 0:
            raise TrajectoryError(
                f"{self.path}: no trajectory has {self.length} frames from frame {self.first_frame} before it stopped"
            )
        return starts

    def windows_from(self, first_frame: int, target_steps: int) -> WindowSampler:
        """The same set's windows of ``target_steps`` targets starting at ``first_frame`` or later, sharing this
        sampler's data (nothing is read again)."""
        view = copy.copy(self)
        view.length, view.first_frame = self.history + 1 + target_steps, first_frame
        view.starts = view._window_starts()
        return view

    @property
    def n_trajectories(self) -> int:
        return len(self.groups)

    @property
    def bounds(self) -> np.ndarray:
        return self.file.attrs["bounds"][()]

    def frames_of(self, trajectory: int, start: int, count: int) -> np.ndarray:
        """Raw frames [count, N, 2] of one trajectory from ``start``."""
        source = self.positions[trajectory] if self.positions is not None else self.groups[trajectory]["positions"]
        return np.asarray(source[start : start + count], dtype=np.float32)

    def smoothed_frames_of(self, trajectory: int, start: int, count: int) -> np.ndarray:
        """Frames [count, N, 2] of the trajectory smoothed in time over its real frames (edges held)."""
        if self.smoothing_frames <= 0:
            return self.frames_of(trajectory, start, count)
        reach = math.ceil(TRUNCATE * self.smoothing_frames)
        end = self.real[trajectory]
        first, last = max(0, start - reach), min(end, start + count + reach)
        smooth = gaussian_filter1d(
            self.frames_of(trajectory, first, last - first),
            self.smoothing_frames,
            axis=0,
            mode="nearest",
            truncate=TRUNCATE,
        )
        return smooth[start - first : start - first + count].astype(np.float32)

    def window(self, picks: list[tuple[int, int]]) -> Window:
        """The windows starting at (trajectory, frame) for each pick, as one batch."""
        positions, types, friction, batch, static = [], [], [], [], []
        for graph, (trajectory, start) in enumerate(picks):
            frames = torch.from_numpy(self.smoothed_frames_of(trajectory, start, self.length)).transpose(0, 1)
            positions.append(frames)
            types.append(self.particle_type[trajectory])
            friction.append(self.tan_friction[trajectory])
            static.append(self.static[trajectory])
            batch.append(torch.full((frames.shape[0],), graph, dtype=torch.long))
        positions = torch.cat(positions)
        inputs = positions[:, : self.history + 1]
        graph = GraphInput(
            inputs.contiguous(), torch.cat(types), torch.cat(friction), torch.cat(batch), len(picks), torch.cat(static)
        )
        return Window(graph, positions[:, self.history + 1 :].contiguous())

    def draw(self, rng: np.random.Generator, graphs: int) -> list[tuple[int, int]]:
        """``graphs`` (trajectory, start) picks, uniform over every window of real frames from ``first_frame``."""
        flat = rng.integers(0, int(self.starts.sum()), graphs)
        trajectories = np.searchsorted(np.cumsum(self.starts), flat, side="right")
        offsets = flat - np.concatenate([[0], np.cumsum(self.starts)])[trajectories] + self.first_frame
        return list(zip(trajectories.tolist(), offsets.tolist()))

    def sample(self, rng: np.random.Generator, graphs: int) -> Window:
        """A batch of ``graphs`` windows drawn uniformly over the real frames of all trajectories."""
        return self.window(self.draw(rng, graphs))

    def normalization(self, noise_std: float = 0.0) -> Normalization:
        """Velocity / acceleration statistics of the (smoothed) real frames, with the training noise
        folded in as DeepMind's learning_to_simulate does (std' = √(std² + noise²)), and tan φ's."""
        sums = np.zeros((2, 3, 2))  # velocity / acceleration × (count, sum, sum of squares) × axis
        for k in range(self.n_trajectories):
            frames = self.smoothed_frames_of(k, 0, self.real[k]).astype(np.float64)
            for order, values in enumerate((np.diff(frames, 1, axis=0), np.diff(frames, 2, axis=0))):
                flat = values.reshape(-1, 2)
                sums[order] += [np.full(2, len(flat)), flat.sum(0), (flat**2).sum(0)]
        count = np.maximum(sums[:, 0], 1)
        mean = sums[:, 1] / count
        std = np.sqrt(np.maximum(sums[:, 2] / count - mean**2, 0.0) + noise_std**2)
        std = np.maximum(std, 1e-8)  # a set at rest must not divide by zero
        tangent = torch.cat(self.tan_friction).numpy().astype(np.float64)
        return Normalization(
            velocity_mean=mean[0].tolist(),
            velocity_std=std[0].tolist(),
            acceleration_mean=mean[1].tolist(),
            acceleration_std=std[1].tolist(),
            tan_friction_mean=float(tangent.mean()),
            tan_friction_std=float(max(tangent.std(), 1e-3)),
        )
