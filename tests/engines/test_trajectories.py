"""The trajectory format: round trips, packing with per-frame statistics, gns export, ParaView."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ElementTree

import h5py
import meshio
import numpy as np
import pytest

from rgns.engines.paraview import write_vtu_series
from rgns.surrogates.gns_export import export_gns
from rgns.trajectories import (
    SOIL,
    Trajectory,
    TrajectoryError,
    motion_statistics,
    pack,
    read_packed,
    read_statistics,
    read_trajectory,
    write_trajectory,
)

FRAMES, PARTICLES = 12, 30


def make_trajectory(
    index: int, velocity=(0.0, 0.0), acceleration=(0.0, 0.0), frame_interval_s=0.025, particles=PARTICLES, frames=FRAMES
) -> Trajectory:
    """Particles on a line moving with a constant per-frame velocity and acceleration."""
    start = np.column_stack([np.linspace(1.0, 5.0, particles), np.full(particles, 2.0)])
    t = np.arange(frames, dtype=float)[:, None, None]
    positions = start[None] + np.asarray(velocity) * t + 0.5 * np.asarray(acceleration) * t * (t - 1)
    return Trajectory(
        positions=positions,
        time_s=np.arange(frames) * frame_interval_s,
        particle_type=np.full(particles, SOIL),
        friction_deg=np.linspace(20.0, 40.0, particles),
        volume_m2=np.full(particles, 0.25),
        mass_kg=np.full(particles, 450.0),
        frame_interval_s=frame_interval_s,
        bounds=np.array([[0.0, 40.0], [0.0, 10.0]]),
        engine="test",
        set_name="train",
        index=index,
        provenance={"seed": 7},
    )


@pytest.mark.parametrize("compression", ["gzip", "lzf", "none"])
def test_a_trajectory_round_trips_exactly(tmp_path, compression):
    original = make_trajectory(3, velocity=(0.01, -0.002))
    path = tmp_path / "trajectory.h5"
    write_trajectory(path, original, compression)
    again = read_trajectory(path)
    np.testing.assert_array_equal(again.positions, original.positions)
    assert again.positions.dtype == np.float32 and again.positions.shape == (FRAMES, PARTICLES, 2)
    for name in ("time_s", "particle_type", "friction_deg", "volume_m2", "mass_kg", "bounds"):
        np.testing.assert_allclose(getattr(again, name), getattr(original, name), rtol=1e-6)
    assert (again.engine, again.set_name, again.index, again.provenance) == ("test", "train", 3, {"seed": 7})
    with h5py.File(path) as handle:
        assert handle["positions"].chunks == (1, PARTICLES, 2)  # one frame per chunk


def test_wrong_shapes_are_refused_naming_the_realization():
    good = make_trajectory(4)
    with pytest.raises(TrajectoryError, match=r"train 0004: positions must be \[T, N, 2\]"):
        Trajectory(**{**vars(good), "positions": good.positions[..., :1]})
    with pytest.raises(TrajectoryError, match=r"train 0004: friction_deg has shape \[29\]"):
        Trajectory(**{**vars(good), "friction_deg": good.friction_deg[:-1]})


def test_a_truncated_trajectory_file_is_reported_by_name(tmp_path):
    path = tmp_path / "0005.h5"
    write_trajectory(path, make_trajectory(5))
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.raises(TrajectoryError, match="0005.h5"):
        read_trajectory(path)


def test_statistics_are_per_frame_differences_whatever_the_frame_interval():
    for interval in (0.025, 1.0):
        stats = motion_statistics(
            [make_trajectory(0, velocity=(0.02, -0.01), acceleration=(0.001, -0.003), frame_interval_s=interval)]
        )
        np.testing.assert_allclose(stats.acceleration_mean, [0.001, -0.003], rtol=1e-3)
        np.testing.assert_allclose(stats.acceleration_std, 0.0, atol=1e-6)
        # velocity x[t] - x[t-1] = v + a·(t-1) for t = 1..T-1: mean v + a·(T-2)/2
        np.testing.assert_allclose(
            stats.velocity_mean, np.array([0.02, -0.01]) + np.array([0.001, -0.003]) * (FRAMES - 2) / 2, rtol=1e-3
        )


def test_packing_several_trajectories_keeps_each_and_the_pooled_statistics(tmp_path):
    trajectories = [make_trajectory(i, velocity=(0.01 * i, 0.0), particles=20 + i) for i in range(4)]
    paths = []
    for trajectory in trajectories:
        paths.append(tmp_path / f"{trajectory.index}.h5")
        write_trajectory(paths[-1], trajectory)
    packed = tmp_path / "train.h5"
    statistics, excluded = pack(paths, packed, "train")
    assert excluded == []
    again = list(read_packed(packed))
    assert [t.index for t in again] == [0, 1, 2, 3] and [t.n_particles for t in again] == [20, 21, 22, 23]
    for original, copy in zip(trajectories, again):
        np.testing.assert_array_equal(copy.positions, original.positions)
    velocities = np.concatenate([np.diff(t.positions.astype(float), axis=0).reshape(-1, 2) for t in trajectories])
    np.testing.assert_allclose(statistics.velocity_mean, velocities.mean(axis=0), atol=1e-9)
    np.testing.assert_allclose(statistics.velocity_std, velocities.std(axis=0), atol=1e-7)
    np.testing.assert_allclose(read_statistics(packed).velocity_std, statistics.velocity_std)


def test_packing_trajectories_of_different_lengths_fails_naming_the_file(tmp_path):
    write_trajectory(tmp_path / "a.h5", make_trajectory(0))
    write_trajectory(tmp_path / "b.h5", make_trajectory(1, frames=FRAMES + 1))
    with pytest.raises(TrajectoryError, match=r"b.h5: 13 frames"):
        pack([tmp_path / "a.h5", tmp_path / "b.h5"], tmp_path / "train.h5", "train")
    assert not (tmp_path / "train.h5").exists()


def test_gns_export_reloads_with_expected_shapes_and_metadata(tmp_path):
    packed = {}
    for name, count in (("train", 3), ("valid", 1)):
        paths = []
        for i in range(count):
            paths.append(tmp_path / f"{name}{i}.h5")
            write_trajectory(paths[-1], make_trajectory(i, velocity=(0.01, 0.0), particles=15 + i))
        packed[name] = tmp_path / f"{name}.h5"
        pack(paths, packed[name], name)
    export_gns(packed, tmp_path / "gns", radius_m=2.0)
    with np.load(tmp_path / "gns" / "train.npz", allow_pickle=True) as data:
        assert sorted(data.files) == [f"simulation_trajectory_{k}" for k in range(3)]
        positions, particle_type, material = data["simulation_trajectory_1"]
        assert positions.shape == (FRAMES, 16, 2) and particle_type.shape == (16,) and material.shape == (16,)
        np.testing.assert_allclose(material, np.tan(np.radians(np.linspace(20.0, 40.0, 16))), rtol=1e-6)
    with np.load(tmp_path / "gns" / "valid.npz", allow_pickle=True) as data:
        assert data.files == ["simulation_trajectory_0"]
    metadata = json.loads((tmp_path / "gns" / "metadata.json").read_text())
    assert {
        "bounds",
        "sequence_length",
        "default_connectivity_radius",
        "dim",
        "dt",
        "vel_mean",
        "vel_std",
        "acc_mean",
        "acc_std",
        "material_property",
    } <= set(metadata)
    assert metadata["sequence_length"] == FRAMES - 1 and metadata["dim"] == 2 and metadata["dt"] == 0.025
    np.testing.assert_allclose(metadata["vel_mean"], [0.01, 0.0], atol=1e-7)


def test_paraview_series_has_moving_points_and_point_data(tmp_path):
    trajectory = make_trajectory(0, velocity=(0.05, 0.0))
    index = write_vtu_series(trajectory, tmp_path / "pv", every_nth_frame=5)
    files = [node.attrib["file"] for node in ElementTree.parse(index).getroot().iter("DataSet")]
    assert files == ["frame_00000.vtu", "frame_00005.vtu", "frame_00010.vtu"]
    last = meshio.read(tmp_path / "pv" / files[-1])
    np.testing.assert_allclose(last.points[:, :2], trajectory.positions[10], rtol=1e-6)
    np.testing.assert_allclose(last.point_data["displacement"][:, 0], 0.5, rtol=1e-5)
    np.testing.assert_allclose(last.point_data["velocity"][:, 0], 0.05 / 0.025, rtol=1e-4)
    np.testing.assert_allclose(last.point_data["friction_deg"], trajectory.friction_deg, rtol=1e-6)
