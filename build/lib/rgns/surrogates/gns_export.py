"""Export packed sets to the geoelements/gns dataset layout: ``<set>.npz`` + ``metadata.json``.

Each npz entry ``simulation_trajectory_<k>`` is the tuple (positions [T, N, 2], particle_type
[N], material_property [N]) with tan φ as the material property. ``metadata.json`` carries the
bounds, sequence length (frames − 1), connectivity radius, dim, the frame interval as ``dt`` and
the training set's velocity / acceleration statistics in per-frame units.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from rgns.trajectories import MotionStatistics, read_packed, read_statistics


def write_npz(packed_path: str | Path, out_path: str | Path) -> int:
    """Write one packed set as a gns npz; returns the number of trajectories."""
    entries = {}
    for k, trajectory in enumerate(read_packed(packed_path)):
        item = np.empty(3, dtype=object)
        item[0] = trajectory.positions.astype(np.float32)
        item[1] = trajectory.particle_type.astype(np.int64)
        item[2] = np.tan(np.radians(trajectory.friction_deg)).astype(np.float32)
        entries[f"simulation_trajectory_{k}"] = item
    np.savez_compressed(out_path, **entries)
    return len(entries)


def metadata(packed_train: str | Path, radius_m: float) -> dict:
    """The gns metadata.json contents, from the training set."""
    statistics: MotionStatistics = read_statistics(packed_train)
    first = next(read_packed(packed_train))
    return {
        "bounds": np.asarray(first.bounds).tolist(),
        "sequence_length": int(first.n_frames - 1),
        "default_connectivity_radius": float(radius_m),
        "dim": 2,
        "dt": float(first.frame_interval_s),
        "vel_mean": statistics.velocity_mean.tolist(),
        "vel_std": statistics.velocity_std.tolist(),
        "acc_mean": statistics.acceleration_mean.tolist(),
        "acc_std": statistics.acceleration_std.tolist(),
        "material_property": "tan(friction angle), one value per particle",
        "units": "velocity and acceleration in m/frame and m/frame^2 (dt = 1 frame)",
    }


def export_gns(packed: dict[str, str | Path], out_dir: str | Path, radius_m: float) -> None:
    """Write ``<name>.npz`` for every packed set and ``metadata.json`` from ``packed['train']``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    for name, path in packed.items():
        write_npz(path, out_dir / f"{name}.npz")
    (out_dir / "metadata.json").write_text(json.dumps(metadata(packed["train"], radius_m), indent=2))
