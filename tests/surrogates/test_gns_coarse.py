"""Coarse nodes and frame strides for a lean GNS, and the static features that tell a node where it started."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import torch

from rgns.surrogates.gns.coarse import coarse_set, coarse_trajectory, node_labels
from rgns.surrogates.gns.data import WindowSampler
from rgns.surrogates.gns.rollout import RolloutSettings, rollout_soil
from rgns.surrogates.gns.simulator import (
    GraphInput,
    LearnedSimulator,
    ModelSettings,
    Normalization,
    OneStepLoss,
    static_features,
)
from rgns.trajectories import SOIL, Trajectory, TrajectoryError, pack_trajectories, read_packed

BOUNDS = np.array([[0.0, 20.0], [0.0, 10.0]])


def _slumping_slope(index: int = 0, frames: int = 41) -> Trajectory:
    """Particles 0.5 m apart in a slope against the left wall, each moving on its own path (random speeds, so a
    node's members part), masses and friction angles varying per particle."""
    rng = np.random.default_rng(index)
    x, y = np.meshgrid(np.arange(0.25, 12.0, 0.5), np.arange(0.25, 6.0, 0.5))
    start = np.column_stack([x.ravel(), y.ravel()])
    start = start[start[:, 1] <= 6.0 - 0.5 * start[:, 0]]  # a 1:2 face
    n = len(start)
    t = np.linspace(0.0, 1.0, frames)[:, None, None]
    velocity = rng.normal([1.0, -0.2], 0.3, (n, 2)) * (start[:, 1:] / 6.0)
    positions = start[None] + t * velocity[None]
    return Trajectory(
        positions,
        t[:, 0, 0] * 4.0,
        np.full(n, SOIL),
        rng.uniform(25.0, 40.0, n),
        np.full(n, 0.25),
        rng.uniform(400.0, 500.0, n),
        0.1,
        BOUNDS,
        "test",
        "train",
        index,
    )


def test_nodes_conserve_mass_and_volume_and_move_with_their_members_centre_of_mass():
    fine = _slumping_slope()
    coarse = coarse_trajectory(fine, 1.0, 4)
    assert coarse.n_particles < fine.n_particles / 3
    assert coarse.mass_kg.sum() == pytest.approx(fine.mass_kg.sum(), rel=1e-12)
    assert coarse.volume_m2.sum() == pytest.approx(fine.volume_m2.sum(), rel=1e-12)
    frames = [0, 4, 8, 12, 16, 20, 24, 28, 32, 36, 40]
    np.testing.assert_array_equal(coarse.time_s, fine.time_s[frames])
    assert coarse.frame_interval_s == pytest.approx(0.4)
    centre = (fine.positions[frames] * fine.mass_kg[:, None]).sum(1) / fine.mass_kg.sum()
    np.testing.assert_allclose((coarse.positions * coarse.mass_kg[:, None]).sum(1) / coarse.mass_kg.sum(), centre, 1e-5)
    labels = node_labels(fine.positions[0], BOUNDS, 1.0)  # fixed at the start: members part, nodes keep them
    first = labels == 0
    expected = (fine.positions[-1][first] * fine.mass_kg[first, None]).sum(0) / fine.mass_kg[first].sum()
    np.testing.assert_allclose(coarse.positions[-1, 0], expected, rtol=1e-5)
    tangent = np.tan(np.radians(fine.friction_deg[first])).mean()
    assert np.tan(np.radians(coarse.friction_deg[0])) == pytest.approx(tangent, rel=1e-12)


def test_the_last_frame_is_kept_whatever_the_stride_and_a_node_per_particle_is_the_particles():
    fine = _slumping_slope(frames=43)
    coarse = coarse_trajectory(fine, 0.5, 4)
    assert coarse.n_frames == 12 and coarse.time_s[-1] == fine.time_s[-1]
    order = np.lexsort((fine.positions[0, :, 0], fine.positions[0, :, 1]))  # row-major, as the nodes are numbered
    np.testing.assert_allclose(coarse.positions[-1], fine.positions[-1, order], rtol=1e-6)


def test_a_coarse_set_packs_every_trajectory_and_refuses_mixed_frame_layouts(tmp_path):
    pack_trajectories([("a", _slumping_slope(0)), ("b", _slumping_slope(1))], tmp_path / "train.h5", "train")
    assert coarse_set(tmp_path / "train.h5", tmp_path / "coarse.h5", 1.0, 2) == 2
    read = list(read_packed(tmp_path / "coarse.h5"))
    assert [t.n_frames for t in read] == [21, 21] and read[0].provenance["coarse"]["stride_frames"] == 2
    with pytest.raises(TrajectoryError, match="b: 30 frames at 0.1 s, but a has 41 .* one frame layout"):
        pack_trajectories([("a", _slumping_slope(0)), ("b", _slumping_slope(1, frames=30))], tmp_path / "mixed.h5", "m")
    with pytest.raises(ValueError, match="stride"):
        coarse_trajectory(_slumping_slope(), 1.0, 0)


def test_static_features_give_height_above_the_floor_and_depth_below_the_surface_of_the_column():
    initial = np.array([[1.0, 0.5], [1.0, 2.5], [1.2, 4.5], [5.0, 0.5], [5.0, 1.0]])
    features = static_features(initial, BOUNDS)
    np.testing.assert_allclose(features[:, 0], initial[:, 1] / 10.0, rtol=1e-6)
    np.testing.assert_allclose(features[:, 1], [0.4, 0.2, 0.0, 0.05, 0.0], atol=1e-7)


def test_a_gns_with_static_features_reads_them_in_training_windows_and_rollouts(tmp_path):
    pack_trajectories([("a", replace(_slumping_slope(0), set_name="valid"))], tmp_path / "valid.h5", "valid")
    sampler = WindowSampler(str(tmp_path / "valid.h5"), 3)
    window = sampler.sample(np.random.default_rng(0), 2)
    assert window.graph.static is not None and window.graph.static.shape == (len(window.graph.batch), 2)
    settings = ModelSettings(
        latent_size=8, mlp_width=8, mlp_hidden_layers=1, message_passing_steps=2, history=3, radius_m=1.2
    )
    normalization = Normalization([0.0, 0.0], [0.05, 0.05], [0.0, 0.0], [0.01, 0.01], 0.7, 0.1)
    torch.manual_seed(0)
    simulator = LearnedSimulator(replace(settings, static_features=True), normalization, BOUNDS)
    moved = replace(window.graph, static=window.graph.static + 0.5)
    assert not torch.allclose(simulator.next_positions(moved), simulator.next_positions(window.graph))
    with pytest.raises(ValueError, match="static_features"):
        simulator.next_positions(replace(window.graph, static=None))
    truth = sampler.frames_of(0, 0, sampler.frames)
    friction = [np.degrees(np.arctan(sampler.tan_friction[0].numpy()))]
    (result,) = rollout_soil(simulator, [truth], friction, sampler.frames, RolloutSettings(keep="ends"))
    assert result.status == "ok" and result.positions.shape == (3, truth.shape[1], 2)


def test_a_moving_weight_counts_moving_particles_more_in_their_graphs_mean():
    """Two graphs: in each, moving particles weigh 1 + w; w = 0 is the plain per-graph mean."""
    settings = ModelSettings(
        latent_size=8, mlp_width=8, mlp_hidden_layers=1, message_passing_steps=1, history=2, radius_m=1.2
    )
    normalization = Normalization([0.0, 0.0], [1.0, 1.0], [0.0, 0.0], [1.0, 1.0], 0.7, 0.1)
    simulator = LearnedSimulator(settings, normalization, BOUNDS)
    positions = torch.zeros(4, 3, 2)
    positions[:, :, 0] = torch.tensor([1.0, 3.0, 5.0, 7.0])[:, None]
    target = positions[:, -1].clone()
    target[[0, 2], 0] += 0.2  # particles 0 and 2 move 0.2 m in the last step: acceleration 0.2
    graph = GraphInput(positions, torch.full((4,), SOIL), torch.full((4,), 0.7), torch.tensor([0, 0, 1, 1]), 2)
    plain = OneStepLoss(simulator).mean_predictor(graph, target)
    weighted = OneStepLoss(simulator, moving_weight=3.0).mean_predictor(graph, target)
    assert float(plain) == pytest.approx(0.04 / 2)  # each graph: (0.04 + 0) / 2
    assert float(weighted) == pytest.approx(4 * 0.04 / 5)  # each graph: (4 · 0.04 + 0) / (4 + 1)
