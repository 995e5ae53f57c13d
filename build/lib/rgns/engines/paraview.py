"""ParaView output: a trajectory as a VTU time series (one file per frame, meshio) + a .pvd index.

Open ``trajectory.pvd`` in ParaView and press play: the particles move (each frame holds the
current positions), coloured by displacement, velocity or friction angle.
"""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from rgns.trajectories import Trajectory

INDEX_FILE = "trajectory.pvd"


def write_vtu_series(trajectory: Trajectory, directory: str | Path, every_nth_frame: int = 1) -> Path:
    """Write ``frame_<k>.vtu`` files and ``trajectory.pvd`` into ``directory``; returns the .pvd.

    Point data: displacement from frame 0 (m), velocity as the backward difference of frames over
    the frame interval (m/s; zero at frame 0), friction angle (deg).
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    positions = trajectory.positions.astype(np.float64)
    n = trajectory.n_particles
    zeros = np.zeros((n, 1))
    cells = [meshio.CellBlock("vertex", np.arange(n).reshape(-1, 1))]
    entries = []
    for frame in range(0, trajectory.n_frames, every_nth_frame):
        velocity = (
            (positions[frame] - positions[frame - 1]) / trajectory.frame_interval_s if frame else np.zeros((n, 2))
        )
        name = f"frame_{frame:05d}.vtu"
        meshio.write(
            directory / name,
            meshio.Mesh(
                np.hstack([positions[frame], zeros]),
                cells,
                point_data={
                    "displacement": np.hstack([positions[frame] - positions[0], zeros]),
                    "velocity": np.hstack([velocity, zeros]),
                    "friction_deg": trajectory.friction_deg.astype(np.float64),
                },
            ),
            binary=True,
        )
        entries.append(f'    <DataSet timestep="{trajectory.time_s[frame]:.6g}" file={quoteattr(name)}/>')
    index = directory / INDEX_FILE
    index.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
        + "\n".join(entries)
        + "\n  </Collection>\n</VTKFile>\n"
    )
    return index
