"""The graph network simulator: graphs, symmetries, training, resume, DDP, rollout."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import pytest
import torch
import torch.distributed as dist
import torch.multiprocessing as mp
from conftest import REPO

from rgns.surrogates.gns.data import WindowSampler
from rgns.surrogates.gns.graph import brute_force_graph, radius_graph
from rgns.surrogates.gns.rollout import RolloutSettings, rollout
from rgns.surrogates.gns.simulator import (
    GraphInput,
    LearnedSimulator,
    ModelSettings,
    Normalization,
    OneStepLoss,
    RolloutLoss,
)
from rgns.surrogates.gns.train import (
    TrainSettings,
    learning_rate,
    load_simulator,
    moving_average,
    pushforward,
    train,
)
from rgns.trajectories import SOIL, Trajectory, pack, write_trajectory

NORMALIZATION = Normalization([0.0, -0.01], [0.02, 0.03], [0.0, -0.001], [0.002, 0.003], 0.6, 0.1)
SMALL = ModelSettings(
    latent_size=16, mlp_width=16, mlp_hidden_layers=2, message_passing_steps=3, history=3, radius_m=1.2
)


@pytest.fixture(autouse=True)
def one_thread():
    torch.set_num_threads(1)


def _edges(senders: torch.Tensor, receivers: torch.Tensor) -> set:
    return set(zip(senders.tolist(), receivers.tolist()))


@pytest.mark.parametrize("radius", [0.3, 1.0, 2.5])
@pytest.mark.parametrize("graphs", [1, 4])
def test_cell_list_search_finds_exactly_the_brute_force_pairs(radius, graphs):
    generator = torch.Generator().manual_seed(int(radius * 10) + graphs)
    positions = torch.rand(1500, 2, generator=generator, dtype=torch.float64) * torch.tensor([30.0, 8.0]) - 3.0
    positions[:20] = positions[20:40] + 1e-3  # near-duplicates
    positions[40, :] = positions[41, :]  # an exact duplicate
    batch = torch.randint(0, graphs, (1500,), generator=generator)
    found = _edges(*radius_graph(positions, batch, radius))
    assert found == _edges(*brute_force_graph(positions, batch, radius))
    assert len(found) == len(radius_graph(positions, batch, radius)[0])  # no duplicates


def _graph(generator: torch.Generator, n: int = 120) -> GraphInput:
    start = torch.rand(n, 2, generator=generator) * torch.tensor([8.0, 4.0]) + 1.0
    steps = torch.cumsum(torch.randn(n, SMALL.history, 2, generator=generator) * 0.02, dim=1)
    positions = torch.cat([start[:, None], start[:, None] + steps], dim=1)
    return GraphInput(
        positions,
        torch.full((n,), SOIL),
        0.5 + 0.2 * torch.rand(n, generator=generator),
        torch.zeros(n, dtype=torch.long),
        1,
    )


def test_the_model_is_equivariant_to_particle_permutation():
    generator = torch.Generator().manual_seed(0)
    simulator = LearnedSimulator(SMALL, NORMALIZATION, np.array([[0.0, 30.0], [0.0, 10.0]]))
    graph = _graph(generator)
    order = torch.randperm(len(graph.batch), generator=generator)
    permuted = GraphInput(
        graph.positions[order], graph.particle_type[order], graph.tan_friction[order], graph.batch[order], 1
    )
    torch.testing.assert_close(
        simulator.next_positions(permuted), simulator.next_positions(graph)[order], rtol=1e-5, atol=1e-5
    )


def test_the_model_is_invariant_to_translation_away_from_walls():
    generator = torch.Generator().manual_seed(1)
    # walls far away: the clipped wall distances are all at +1 before and after the shift
    simulator = LearnedSimulator(SMALL, NORMALIZATION, np.array([[-100.0, 100.0], [-100.0, 100.0]]))
    graph = _graph(generator)
    shift = torch.tensor([3.7, -2.1])
    moved = GraphInput(graph.positions + shift, graph.particle_type, graph.tan_friction, graph.batch, 1)
    torch.testing.assert_close(
        simulator.next_positions(moved), simulator.next_positions(graph) + shift, rtol=1e-5, atol=1e-4
    )


def test_learning_rate_decays_exponentially_to_its_floor():
    settings = TrainSettings(learning_rate=1e-3, learning_rate_min=1e-6, decay_rate=0.1, decay_steps=1000)
    assert learning_rate(settings, 0) == pytest.approx(1e-3)
    assert learning_rate(settings, 1000) == pytest.approx(1e-6 + (1e-3 - 1e-6) * 0.1)
    assert learning_rate(settings, 10**7) == pytest.approx(1e-6)


def _sliding_trajectory(index: int, frames: int = 40) -> Trajectory:
    """A sheared block of particles sliding and slowing down: v_x(t) = v0(y)·exp(−k t), with the
    decay k growing with tan φ, so the acceleration −k·v_x is a function of the inputs."""
    x, y = np.meshgrid(np.arange(2.0, 8.0, 0.5), np.arange(0.25, 3.0, 0.5))
    start = np.column_stack([x.ravel(), y.ravel()])
    friction_deg = 25.0 + 5 * index
    k = 0.2 * np.tan(np.radians(friction_deg))
    v0 = (0.05 + 0.02 * index) * (1 + 0.2 * start[:, 1])
    t = np.arange(frames, dtype=float)[:, None]
    positions = np.repeat(start[None], frames, axis=0)
    positions[:, :, 0] += v0 / k * (1 - np.exp(-k * t))
    n = len(start)
    return Trajectory(
        positions,
        t[:, 0] * 0.025,
        np.full(n, SOIL),
        np.full(n, friction_deg),
        np.full(n, 0.25),
        np.full(n, 450.0),
        0.025,
        np.array([[0.0, 20.0], [0.0, 10.0]]),
        "test",
        "train",
        index,
    )


def _packed_blocks(directory: Path, change=None) -> dict[str, str]:
    """The sliding blocks packed into a training and a validation set, each trajectory through ``change``."""
    directory.mkdir(parents=True, exist_ok=True)
    packed = {}
    for name, indices in (("train", [0, 1, 2]), ("valid", [3])):
        paths = []
        for index in indices:
            paths.append(directory / f"{name}{index}.h5")
            trajectory = _sliding_trajectory(index)
            write_trajectory(paths[-1], change(trajectory) if change else trajectory)
        packed[name] = str(directory / f"{name}.h5")
        pack(paths, packed[name], name)
    return packed


@pytest.fixture(scope="module")
def tiny_dataset(tmp_path_factory):
    return _packed_blocks(tmp_path_factory.mktemp("gns_data"))


@pytest.fixture(scope="module")
def trained_small(tiny_dataset, tmp_path_factory):
    """The small model trained 800 steps on the sliding blocks, and its training summary."""
    directory = tmp_path_factory.mktemp("trained")
    settings = TrainSettings(
        steps=800,
        batch_graphs=2,
        learning_rate=3e-3,
        noise_std=0.0,
        smoothing_frames=0.0,
        log_every=25,
        validate_every=800,
        checkpoint_every=800,
        selection_trajectories=1,
    )
    torch.set_num_threads(1)
    return directory, train(SMALL, settings, tiny_dataset["train"], tiny_dataset["valid"], directory)


def test_training_on_a_tiny_dataset_lowers_the_loss_by_a_large_factor(trained_small):
    directory, summary = trained_small
    history = (directory / "history.csv").read_text().splitlines()
    losses = [float(line.split(",")[history[0].split(",").index("train_loss")]) for line in history[1:]]
    print(f"loss {losses[0]:.4g} -> {losses[-1]:.4g} in {summary['wall_s']:.1f} s")
    assert losses[-1] < losses[0] / 20
    simulator = load_simulator(directory / "gns.pt")
    assert simulator.settings == SMALL


@pytest.mark.parametrize("skipping", [False, True])
def test_a_trained_rollout_twice_the_training_horizon_stays_in_the_domain_and_slows_down(
    trained_small, tiny_dataset, skipping
):
    """Stability stress: 80 frames from a 40-frame training horizon, every realization of both sets."""
    directory, _ = trained_small
    simulator = load_simulator(directory / "gns.pt").eval()
    settings = RolloutSettings(skip_rest=skipping, early_stop=skipping)
    for name in ("train", "valid"):
        sampler = WindowSampler(tiny_dataset[name], SMALL.history)
        horizon = sampler.frames
        for k in range(sampler.n_trajectories):
            result = rollout(
                simulator,
                [sampler.frames_of(k, 0, SMALL.history + 1)],
                [sampler.particle_type[k].numpy()],
                [sampler.tan_friction[k].numpy()],
                2 * horizon,
                settings,
            )[0]
            positions = result.positions
            assert result.status == "ok" and np.isfinite(positions).all()
            lower, upper = simulator.bounds[:, 0].numpy(), simulator.bounds[:, 1].numpy()
            assert (positions >= lower).all() and (positions <= upper).all()
            kinetic = (np.diff(positions, axis=0) ** 2).sum(axis=2).mean(axis=1)  # mean squared velocity per frame
            first, last = kinetic[: horizon // 4].mean(), kinetic[-horizon // 4 :].mean()
            print(f"{name} {k}: mean v^2 {first:.3g} -> {last:.3g} over {2 * horizon} frames")
            assert last < 0.5 * first


def _ddp_worker(rank: int, world: int, init_file: str, batches: list, out: str) -> None:
    dist.init_process_group("gloo", init_method=f"file://{init_file}", rank=rank, world_size=world)
    torch.manual_seed(0)
    simulator = LearnedSimulator(SMALL, NORMALIZATION, np.array([[0.0, 30.0], [0.0, 10.0]]))
    wrapped = torch.nn.parallel.DistributedDataParallel(OneStepLoss(simulator))
    optimizer = torch.optim.Adam(simulator.parameters(), lr=1e-3)
    for step_batches in batches:
        graph, target = step_batches[rank]
        loss = wrapped(graph, target, torch.zeros_like(graph.positions))
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    torch.save(simulator.state_dict(), f"{out}.{rank}")
    dist.destroy_process_group()


def _combine(parts: list[tuple[GraphInput, torch.Tensor]]) -> tuple[GraphInput, torch.Tensor]:
    graphs = [g for g, _ in parts]
    batch = torch.cat([g.batch + i for i, g in enumerate(graphs)])
    combined = GraphInput(
        torch.cat([g.positions for g in graphs]),
        torch.cat([g.particle_type for g in graphs]),
        torch.cat([g.tan_friction for g in graphs]),
        batch,
        len(graphs),
    )
    return combined, torch.cat([t for _, t in parts])


def test_two_process_ddp_averages_gradients_like_one_process_on_the_combined_batch(tmp_path):
    generator = torch.Generator().manual_seed(5)
    batches = []
    for _ in range(3):
        step = []
        for _rank in range(2):
            graph = _graph(generator, n=60 + int(torch.randint(0, 40, (1,), generator=generator)))
            step.append((graph, graph.positions[:, -1] + 0.01 * torch.randn(len(graph.batch), 2, generator=generator)))
        batches.append(step)
    out = str(tmp_path / "params")
    mp.spawn(_ddp_worker, args=(2, str(tmp_path / "init"), batches, out), nprocs=2, join=True)
    rank0, rank1 = torch.load(f"{out}.0"), torch.load(f"{out}.1")
    torch.manual_seed(0)
    single = LearnedSimulator(SMALL, NORMALIZATION, np.array([[0.0, 30.0], [0.0, 10.0]]))
    objective = OneStepLoss(single)
    optimizer = torch.optim.Adam(single.parameters(), lr=1e-3)
    for step in batches:
        graph, target = _combine(step)
        loss = objective(graph, target, torch.zeros_like(graph.positions))
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    initial = LearnedSimulator(SMALL, NORMALIZATION, np.array([[0.0, 30.0], [0.0, 10.0]])).state_dict()
    moved = False
    for name, value in single.state_dict().items():
        torch.testing.assert_close(rank0[name], rank1[name], rtol=0, atol=0)  # identical on both ranks
        torch.testing.assert_close(rank0[name], value, rtol=1e-5, atol=1e-6)  # = one process, combined batch
        moved |= not torch.equal(value, initial[name])
    assert moved


def test_a_killed_training_resumes_from_its_last_checkpoint(tiny_dataset, tmp_path):
    script = f"""
import sys
sys.path.insert(0, {str(REPO)!r})
import logging, torch
logging.basicConfig(level=logging.INFO, stream=sys.stdout, format="%(message)s", force=True)
torch.set_num_threads(1)
from rgns.surrogates.gns.simulator import ModelSettings
from rgns.surrogates.gns.train import TrainSettings, train
model = ModelSettings(**{SMALL.__dict__!r})
settings = TrainSettings(steps=int(sys.argv[1]), batch_graphs=1, log_every=10, validate_every=10_000,
                         checkpoint_every=20, selection_trajectories=1)
train(model, settings, {tiny_dataset["train"]!r}, {tiny_dataset["valid"]!r}, {str(tmp_path)!r})
"""
    first = subprocess.Popen([sys.executable, "-c", script, "100000"], stdout=subprocess.PIPE, text=True)
    checkpoint = tmp_path / "checkpoints" / "latest.pt"
    deadline = time.time() + 120
    while time.time() < deadline:
        if checkpoint.exists() and torch.load(checkpoint, weights_only=False)["step"] >= 40:
            break
        time.sleep(0.2)
    first.send_signal(signal.SIGKILL)
    first.wait()
    saved = torch.load(checkpoint, weights_only=False)["step"]
    assert saved >= 40 and saved % 20 == 0
    resumed = subprocess.run(
        [sys.executable, "-c", script, str(saved + 40)], capture_output=True, text=True, timeout=300
    )
    assert resumed.returncode == 0, resumed.stderr
    assert f"resumed from step {saved} of {saved + 40}" in resumed.stdout
    assert f"step {saved + 10}/{saved + 40}" in resumed.stdout and "step 10/" not in resumed.stdout
    assert torch.load(checkpoint, weights_only=False)["step"] == saved + 40
    assert (tmp_path / "gns.pt").exists()


QUICK = TrainSettings(  # ten-step stretches, checkpointed at each, no validation between
    steps=20,
    batch_graphs=1,
    decay_steps=1000,
    log_every=10,
    validate_every=10_000,
    checkpoint_every=10,
    selection_trajectories=1,
)


def _latest(folder: Path) -> dict:
    """The last checkpoint a training in ``folder`` saved."""
    return torch.load(folder / "checkpoints" / "latest.pt", weights_only=False)


def _regenerated(trajectory: Trajectory) -> Trajectory:
    """The trajectory as a rerun on another machine may store it: every other stored coordinate one float32
    step up (what differs in the last digit)."""
    stored = trajectory.positions.astype(np.float32)
    moved = stored.copy()
    moved.reshape(-1)[::2] = np.nextafter(stored.reshape(-1)[::2], np.float32(np.inf))
    return replace(trajectory, positions=moved.astype(np.float64))


def _faster(trajectory: Trajectory) -> Trajectory:
    """Other data: the blocks slide half as far again."""
    start = trajectory.positions[:1]
    return replace(trajectory, positions=start + 1.5 * (trajectory.positions - start))


def test_a_killed_training_resumes_to_identical_weights_and_on_regenerated_data_with_its_own_normalisation(
    tiny_dataset, tmp_path
):
    """Ten steps, stopped, then resumed to twenty give the weights of twenty in one go (the learning rate's
    schedule fixed by decay_steps). On the data regenerated with last-digit differences, whose recomputed
    normalisation differs from the checkpoint's, training goes on from the checkpoint with the checkpoint's
    normalisation (it used to start again from zero, the normalisation being part of the fingerprint); on other
    data it starts again, the old checkpoint kept."""
    regenerated = _packed_blocks(tmp_path / "regenerated", _regenerated)
    other = _packed_blocks(tmp_path / "other", _faster)

    def run(data: dict[str, str], folder: str, steps: int) -> dict:
        return train(SMALL, replace(QUICK, steps=steps), data["train"], data["valid"], tmp_path / folder)

    def saved(folder: str) -> dict:
        return _latest(tmp_path / folder)

    torch.set_num_threads(1)
    run(tiny_dataset, "whole", 20)
    run(tiny_dataset, "stopped", 10)
    assert run(tiny_dataset, "stopped", 20)["resumed_from"] == 10
    whole, resumed = saved("whole")["model"], saved("stopped")["model"]
    assert all(torch.equal(whole[key], resumed[key]) for key in whole)

    run(tiny_dataset, "moved", 10)
    before = saved("moved")["simulator"]["normalization"]
    window = WindowSampler(regenerated["train"], SMALL.history, 1, QUICK.smoothing_frames)
    assert asdict(window.normalization(QUICK.noise_std)) != before  # the regeneration moved the statistics
    assert run(regenerated, "moved", 20)["resumed_from"] == 10
    assert saved("moved")["simulator"]["normalization"] == before and saved("moved")["step"] == 20

    assert run(other, "moved", 30)["resumed_from"] == 0
    assert len(list((tmp_path / "moved" / "checkpoints").glob("stale-*.pt"))) == 1


def test_the_moving_average_warms_up_and_a_resumed_training_continues_both_weights(tiny_dataset, tmp_path):
    """The average's update n moves it (1 − min(decay, (1 + n) / (10 + n))) of the way to the weights. With
    ema_decay, the checkpoint's model (what load_simulator and the validation read) is the average and differs from
    the weights the optimiser goes on from; ten steps, stopped and resumed to twenty, give both of twenty in one go."""
    averaged, weights = [torch.zeros(3)], [torch.ones(3)]
    update, expected = moving_average(0.5), 0.0
    rates = []
    for count in range(1, 12):
        update(averaged, weights, count)
        rates.append(min(0.5, (1 + count) / (10 + count)))
        expected += (1 - rates[-1]) * (1 - expected)
        assert torch.allclose(averaged[0], torch.full((3,), expected))
    assert rates[0] < 0.2 and rates[-1] == 0.5  # the warm-up over, the decay rules

    averaging = replace(QUICK, ema_decay=0.9)

    def run(folder: str, steps: int) -> dict:
        return train(
            SMALL, replace(averaging, steps=steps), tiny_dataset["train"], tiny_dataset["valid"], tmp_path / folder
        )

    def saved(folder: str) -> dict:
        return _latest(tmp_path / folder)

    torch.set_num_threads(1)
    run("whole", 20)
    run("stopped", 10)
    assert run("stopped", 20)["resumed_from"] == 10
    whole, resumed = saved("whole"), saved("stopped")
    for part in ("model", "training_weights"):
        assert all(torch.equal(whole[part][key], resumed[part][key]) for key in whole[part])
    assert not all(torch.equal(whole["model"][key], whole["training_weights"][key]) for key in whole["model"])
    loaded = load_simulator(tmp_path / "whole" / "checkpoints" / "latest.pt").state_dict()
    assert all(torch.equal(loaded[key], whole["model"][key]) for key in loaded)


def test_batched_rollout_matches_one_realization_at_a_time_and_flags_divergence(tiny_dataset):
    torch.manual_seed(3)
    simulator = LearnedSimulator(SMALL, NORMALIZATION, np.array([[0.0, 20.0], [0.0, 10.0]]))
    sampler = WindowSampler(tiny_dataset["train"], SMALL.history)
    starts = [sampler.frames_of(k, 0, SMALL.history + 1) for k in range(3)]
    types = [t.numpy() for t in sampler.particle_type]
    friction = [f.numpy() for f in sampler.tan_friction]
    together = rollout(simulator, starts, types, friction, 20)
    for k in range(3):
        alone = rollout(simulator, [starts[k]], [types[k]], [friction[k]], 20)[0]
        np.testing.assert_allclose(together[k].positions, alone.positions, atol=1e-4)
    runaway = [s.copy() for s in starts]
    runaway[1][-1] += np.array([50.0, 0.0])  # a last step of 50 m per frame: leaves the domain at once
    flagged = rollout(simulator, runaway, types, friction, 20)
    assert flagged[1].status.startswith("diverged") and flagged[0].status == flagged[2].status == "ok"
    assert flagged[1].positions.shape == flagged[0].positions.shape


def test_rest_skipping_leaves_particles_at_rest_untouched_and_saves_work(tiny_dataset):
    torch.manual_seed(4)
    simulator = LearnedSimulator(SMALL, NORMALIZATION, np.array([[0.0, 20.0], [0.0, 10.0]]))
    sampler = WindowSampler(tiny_dataset["train"], SMALL.history)
    start = sampler.frames_of(0, 0, SMALL.history + 1)
    start[:] = start[0]  # everything at rest
    start[:, :5] += np.arange(SMALL.history + 1)[:, None, None] * np.array([0.05, 0.0])  # five particles moving
    types, friction = [sampler.particle_type[0].numpy()], [sampler.tan_friction[0].numpy()]
    frames = SMALL.history + 2  # one predicted frame
    skipped = rollout(simulator, [start], types, friction, frames, RolloutSettings(skip_rest=True))[0]
    full = rollout(simulator, [start], types, friction, frames)[0]
    last = start[-1]
    distance = np.linalg.norm(last[:, None] - last[None, :5], axis=2).min(axis=1)
    resting_neighbourhood = distance > SMALL.radius_m
    np.testing.assert_array_equal(skipped.positions[-1, resting_neighbourhood], last[resting_neighbourhood])
    np.testing.assert_allclose(skipped.positions[-1, :5], full.positions[-1, :5], atol=1e-5)
    assert not np.allclose(full.positions[-1, resting_neighbourhood], last[resting_neighbourhood])  # untrained: drifts
    assert skipped.node_updates < full.node_updates / 2


def test_a_missing_or_corrupt_model_file_is_named(tmp_path):
    with pytest.raises(ValueError, match=r"nothing.pt: not a usable GNS model file"):
        load_simulator(tmp_path / "nothing.pt")
    (tmp_path / "broken.pt").write_bytes(b"not a torch file")
    with pytest.raises(ValueError, match=r"broken.pt: not a usable GNS model file"):
        load_simulator(tmp_path / "broken.pt")


def test_rest_skipping_a_realization_entirely_at_rest_keeps_it_still(tiny_dataset):
    simulator = LearnedSimulator(SMALL, NORMALIZATION, np.array([[0.0, 20.0], [0.0, 10.0]]))
    sampler = WindowSampler(tiny_dataset["train"], SMALL.history)
    start = sampler.frames_of(0, 0, SMALL.history + 1)
    start[:] = start[0]
    result = rollout(
        simulator,
        [start],
        [sampler.particle_type[0].numpy()],
        [sampler.tan_friction[0].numpy()],
        SMALL.history + 4,
        RolloutSettings(skip_rest=True),
    )[0]
    np.testing.assert_array_equal(result.positions, np.repeat(start[:1], SMALL.history + 4, axis=0))
    assert result.node_updates == 0


def test_a_checkpoint_from_other_settings_is_set_aside_not_resumed(tiny_dataset, tmp_path):
    quick = TrainSettings(
        steps=20, batch_graphs=1, log_every=10, validate_every=10_000, checkpoint_every=10, selection_trajectories=1
    )
    train(SMALL, quick, tiny_dataset["train"], tiny_dataset["valid"], tmp_path)
    assert (
        train(SMALL, replace(quick, steps=30), tiny_dataset["train"], tiny_dataset["valid"], tmp_path)["resumed_from"]
        == 20
    )
    changed = replace(quick, learning_rate=5e-4, steps=30)
    summary = train(SMALL, changed, tiny_dataset["train"], tiny_dataset["valid"], tmp_path)
    assert summary["resumed_from"] == 0
    assert list((tmp_path / "checkpoints").glob("stale-*.pt"))  # nothing already computed is lost


def test_early_stop_ends_a_realization_at_rest_and_repeats_its_last_frame(tiny_dataset):
    simulator = LearnedSimulator(SMALL, NORMALIZATION, np.array([[0.0, 20.0], [0.0, 10.0]]))
    sampler = WindowSampler(tiny_dataset["train"], SMALL.history)
    start = sampler.frames_of(0, 0, SMALL.history + 1)
    start[:] = start[0]
    settings = RolloutSettings(skip_rest=True, early_stop=True, early_stop_frames=3)
    result = rollout(
        simulator,
        [start],
        [sampler.particle_type[0].numpy()],
        [sampler.tan_friction[0].numpy()],
        SMALL.history + 20,
        settings,
    )[0]
    assert result.stopped_at_frame == SMALL.history + 3
    assert result.positions.shape[0] == SMALL.history + 20


def _brief_training(dataset: dict, directory: Path, steps: int, model: ModelSettings = SMALL, **changes) -> dict:
    """``model`` (the small one) trained ``steps`` steps on two windows a step with ``changes`` to the settings, one
    checkpoint at the end and one held-out rollout: the summary."""
    settings = TrainSettings(
        steps=steps,
        batch_graphs=2,
        log_every=10,
        validate_every=10_000,
        checkpoint_every=steps,
        selection_trajectories=1,
        **changes,
    )
    return train(model, settings, dataset["train"], dataset["valid"], directory)


def test_pushforward_trains_on_the_model_s_own_prediction(tiny_dataset, tmp_path):
    torch.manual_seed(2)
    simulator = LearnedSimulator(SMALL, NORMALIZATION, np.array([[0.0, 20.0], [0.0, 10.0]]))
    window = WindowSampler(tiny_dataset["train"], SMALL.history, target_steps=2).sample(np.random.default_rng(0), 2)
    graph, target = pushforward(simulator, window.graph, window.targets)
    with torch.no_grad():
        predicted = simulator.next_positions(window.graph)
    torch.testing.assert_close(graph.positions[:, -1], predicted)
    torch.testing.assert_close(graph.positions[:, :-1], window.graph.positions[:, 1:])
    torch.testing.assert_close(target, window.targets[:, -1])
    assert _brief_training(tiny_dataset, tmp_path, 30, pushforward_steps=1)["steps"] == 30


def test_the_rollout_loss_is_the_one_step_loss_over_one_step_and_zero_on_the_model_s_own_rollout(
    tiny_dataset, tmp_path
):
    torch.manual_seed(3)
    simulator = LearnedSimulator(SMALL, NORMALIZATION, np.array([[-5.0, 40.0], [-5.0, 20.0]]))
    window = WindowSampler(tiny_dataset["train"], SMALL.history, target_steps=4).sample(np.random.default_rng(1), 2)
    graph, targets = window.graph, window.targets
    noise = torch.randn(graph.positions.shape, generator=torch.Generator().manual_seed(0)) * 1e-3
    one_step = OneStepLoss(simulator)(graph, targets[:, 0], noise)
    # the same error, reached through positions (float32: a relative 1e-5 of rounding)
    torch.testing.assert_close(RolloutLoss(simulator)(graph, targets[:, :1], noise), one_step, rtol=1e-4, atol=0.0)
    with torch.no_grad():  # targets the model itself reaches: nothing to learn, at every step
        positions, own = graph.positions, []
        for _ in range(4):
            own.append(simulator.next_positions(graph.moved_to(positions)))
            positions = torch.cat([positions[:, 1:], own[-1][:, None]], dim=1)
    zeros = torch.zeros_like(graph.positions)
    assert float(RolloutLoss(simulator)(graph, torch.stack(own, dim=1), zeros)) < 1e-9
    loss = RolloutLoss(simulator)(graph, targets, zeros)
    loss.backward()  # the later steps' errors reach the weights through the earlier steps' predictions
    assert all(p.grad is not None and torch.isfinite(p.grad).all() for p in simulator.parameters() if p.requires_grad)
    assert _brief_training(tiny_dataset, tmp_path, 20, rollout_steps=3)["steps"] == 20


def test_late_windows_start_at_their_frame_and_train_beside_the_one_step_loss(tiny_dataset, tmp_path):
    everywhere = WindowSampler(tiny_dataset["train"], SMALL.history, target_steps=3)
    late = everywhere.windows_from(4, target_steps=3)
    picks = late.draw(np.random.default_rng(0), 500)
    assert min(start for _, start in picks) == 4
    assert all(start + late.length <= late.real[k] for k, start in picks)
    assert late.starts.sum() == np.maximum(everywhere.starts - 4, 0).sum()
    window = late.window(picks[:1])
    k, start = picks[0]
    torch.testing.assert_close(
        window.targets[:, 0], torch.from_numpy(late.frames_of(k, start + SMALL.history + 1, 1)[0])
    )
    changes = {"noise_std": 0.0, "smoothing_frames": 0.0, "rollout_steps": 3, "rollout_from_frame": 4}
    assert _brief_training(tiny_dataset, tmp_path, 20, **changes)["steps"] == 20


def test_keeping_only_the_ends_returns_exactly_those_frames_of_the_full_rollout(tiny_dataset):
    torch.manual_seed(5)
    simulator = LearnedSimulator(SMALL, NORMALIZATION, np.array([[0.0, 20.0], [0.0, 10.0]]))
    sampler = WindowSampler(tiny_dataset["train"], SMALL.history)
    starts = [sampler.frames_of(k, 0, SMALL.history + 1) for k in range(3)]
    starts[1][:] = starts[1][0]  # at rest: stops early under early stop
    starts[2][-1] += np.array([50.0, 0.0])  # leaves the domain at once: diverged
    types = [t.numpy() for t in sampler.particle_type]
    friction = [f.numpy() for f in sampler.tan_friction]
    frames = SMALL.history + 15
    for early_stop in (False, True):
        settings = RolloutSettings(skip_rest=True, early_stop=early_stop, early_stop_frames=3)
        full = rollout(simulator, starts, types, friction, frames, settings)
        ends = rollout(simulator, starts, types, friction, frames, replace(settings, keep="ends"))
        for a, b in zip(full, ends):
            assert (a.status, a.stopped_at_frame) == (b.status, b.stopped_at_frame)
            np.testing.assert_array_equal(b.frame, [0, frames - 2, frames - 1])
            np.testing.assert_array_equal(b.positions, a.positions[[0, frames - 2, frames - 1]])
        assert ends[2].status.startswith("diverged") and (ends[1].stopped_at_frame is not None) == early_stop
    with pytest.raises(ValueError, match="keep = 'some'"):
        RolloutSettings(keep="some")


def _stopped_trajectory(index: int, moving: int = 25, frames: int = 60) -> Trajectory:
    """A sliding block that an early stop ended at frame ``moving``: the rest are copies of it."""
    full = _sliding_trajectory(index, frames)
    full.positions[moving:] = full.positions[moving - 1]
    return full


def test_padded_frames_of_an_early_stop_are_never_drawn_and_smoothing_needs_no_whole_trajectory(tmp_path):
    paths = []
    for index, moving in ((0, 25), (1, 60)):
        paths.append(tmp_path / f"t{index}.h5")
        write_trajectory(paths[-1], _stopped_trajectory(index, moving))
    pack(paths, tmp_path / "set.h5", "train")
    sampler = WindowSampler(str(tmp_path / "set.h5"), history=3, smoothing_frames=2.0)
    assert sampler.real == [25, 60]
    # trajectory 0: starts 0..(25 - 5); trajectory 1 ran to the end: the last 8 frames (4 σ) are left out
    assert sampler.starts.tolist() == [21, 60 - 8 - 5 + 1]
    picks = sampler.draw(np.random.default_rng(0), 5000)
    assert max(start for trajectory, start in picks if trajectory == 0) == 20
    assert {trajectory for trajectory, _ in picks} == {0, 1}
    # a window smoothed from a margin of frames equals the same frames of the whole trajectory smoothed
    from scipy.ndimage import gaussian_filter1d

    whole = gaussian_filter1d(sampler.frames_of(1, 0, 60), 2.0, axis=0, mode="nearest")
    np.testing.assert_allclose(sampler.smoothed_frames_of(1, 20, 5), whole[20:25], atol=1e-6)


def test_the_training_noise_is_folded_into_the_normalisation(tiny_dataset):
    sampler = WindowSampler(tiny_dataset["train"], SMALL.history)
    clean, noisy = sampler.normalization(0.0), sampler.normalization(3e-3)
    for key in ("velocity_std", "acceleration_std"):
        np.testing.assert_allclose(np.square(getattr(noisy, key)), np.square(getattr(clean, key)) + 3e-3**2, rtol=1e-6)
    assert noisy.velocity_mean == clean.velocity_mean


def test_fine_tuning_starts_from_the_given_model_and_refuses_another_architecture(
    trained_small, tiny_dataset, tmp_path
):
    directory, _ = trained_small
    settings = TrainSettings(
        steps=20,
        batch_graphs=2,
        noise_std=0.0,
        smoothing_frames=0.0,
        log_every=10,
        validate_every=20,
        checkpoint_every=20,
        selection_trajectories=0,
    )
    with pytest.raises(ValueError, match=r"gns.pt: its architecture differs from config gns in latent_size"):
        train(
            replace(SMALL, latent_size=24),
            settings,
            tiny_dataset["train"],
            tiny_dataset["valid"],
            tmp_path / "a",
            init_model=directory / "gns.pt",
        )
    train(
        SMALL, settings, tiny_dataset["train"], tiny_dataset["valid"], tmp_path / "b", init_model=directory / "gns.pt"
    )
    start = load_simulator(directory / "gns.pt")
    tuned = load_simulator(tmp_path / "b" / "gns.pt")
    assert tuned.normalization == start.normalization  # the shipped statistics are kept
    history = (tmp_path / "b" / "history.csv").read_text().splitlines()
    first_loss = float(history[1].split(",")[history[0].split(",").index("train_loss")])
    assert first_loss < 0.1  # it starts from the trained weights, not from scratch (about 1 there)


def test_a_soil_rollout_keeps_its_mpm_warm_up_and_hands_over_after_it(tiny_dataset):
    from rgns.surrogates.gns.rollout import rollout_soil

    torch.manual_seed(5)
    simulator = LearnedSimulator(SMALL, NORMALIZATION, np.array([[0.0, 20.0], [0.0, 10.0]]))
    sampler = WindowSampler(tiny_dataset["train"], SMALL.history)
    truth = sampler.frames_of(0, 0, 40)
    friction = [np.full(truth.shape[1], 25.0)]
    full = rollout_soil(simulator, [truth], friction, 40, RolloutSettings(warmup_frames=12))[0]
    assert full.positions.shape == truth.shape
    np.testing.assert_array_equal(full.positions[:12], truth[:12])  # the warm-up is the MPM's
    assert not np.allclose(full.positions[12:], truth[12:])  # then the (untrained) network's
    ends = rollout_soil(simulator, [truth], friction, 40, RolloutSettings(warmup_frames=12, keep="ends"))[0]
    np.testing.assert_array_equal(ends.positions, full.positions[[0, -2, -1]])
    assert ends.frame.tolist() == [0, 38, 39]
    # the paper's hand-over: right after history + 1 frames
    paper = rollout_soil(simulator, [truth], friction, 40)[0]
    np.testing.assert_array_equal(paper.positions[: SMALL.history + 1], truth[: SMALL.history + 1])


def test_the_rest_head_learns_when_the_blocks_stop(tiny_dataset, tmp_path):
    """Trained on the sliding blocks (each slows from 5-11 cm a frame to under 1 cm after 12-20 frames), the rest
    head tells a window whose next step moves under ``rest_m`` from one that moves more, on held-out windows, far
    better than always answering the commoner label; its loss is the one-step loss plus the head's cross-entropy."""
    torch.manual_seed(5)
    model = replace(SMALL, rest_head=True)
    _brief_training(tiny_dataset, tmp_path, 300, model, learning_rate=3e-3, noise_std=0.0, smoothing_frames=0.0)
    simulator = load_simulator(tmp_path / "gns.pt")
    sampler = WindowSampler(tiny_dataset["valid"], SMALL.history)
    frames = sampler.frames_of(0, 0, sampler.frames)
    right = labels = 0.0
    with torch.no_grad():
        for start in range(sampler.frames - SMALL.history - 1):
            window = frames[start : start + SMALL.history + 2]
            graph = GraphInput(
                torch.as_tensor(window[:-1]).transpose(0, 1).float(),
                sampler.particle_type[0],
                sampler.tan_friction[0],
                torch.zeros(window.shape[1], dtype=torch.long),
                1,
            )
            label = simulator.at_rest(graph.positions[:, -1], torch.as_tensor(window[-1]).float())
            right += float(((simulator(graph)[:, 2] > 0).float() == label).float().mean())
            labels += float(label.mean())
    windows = sampler.frames - SMALL.history - 1
    accuracy, commoner = right / windows, max(labels, windows - labels) / windows
    print(f"rest head: {accuracy:.3f} of held-out particle steps right, the commoner label {commoner:.3f}")
    assert 0.2 < labels / windows < 0.8  # both labels are there to learn
    assert accuracy > 0.95 and accuracy > commoner + 0.15


def test_a_rollout_holds_a_displaced_particle_the_rest_head_calls_at_rest_and_leaves_the_others(tiny_dataset):
    torch.manual_seed(6)
    simulator = LearnedSimulator(replace(SMALL, rest_head=True), NORMALIZATION, np.array([[0.0, 20.0], [0.0, 10.0]]))
    with torch.no_grad():
        simulator.network.decoder[-1].bias[2] = 100.0  # the head calls every particle at rest
    sampler = WindowSampler(tiny_dataset["train"], SMALL.history)
    start = sampler.frames_of(0, 0, SMALL.history + 1)
    start[:] = start[0]
    start[:, :5] += np.arange(SMALL.history + 1)[:, None, None] * np.array([0.04, 0.0])  # five sliding 4 cm a frame
    types, friction = [sampler.particle_type[0].numpy()], [sampler.tan_friction[0].numpy()]
    settings = RolloutSettings(rest_displacement=0.1)
    positions = rollout(simulator, [start], types, friction, SMALL.history + 12, settings)[0].positions
    moved = np.linalg.norm(positions[SMALL.history :] - start[-1], axis=2)  # from where the rollout started them
    sliding = moved[:, :5]
    held = np.all(positions[-4:, :5] == positions[-1, :5], axis=(0, 2))
    assert held.all() and (sliding[-1] > 0.1).all()  # each stopped once it was displaced past 0.1 m
    first_held = [int(np.argmax(np.all(positions[SMALL.history :, k] == positions[-1, k], axis=1))) for k in range(5)]
    assert all(sliding[f - 1, k] <= 0.1 < sliding[f, k] for k, f in enumerate(first_held))  # and not before
    resting = moved[:, 5:].max(axis=0) <= 0.1
    assert resting.any() and not np.all(positions[-1, 5:][resting] == start[-1, 5:][resting])  # untrained: drift
    ignored = RolloutSettings(rest_displacement=0.1, rest_gate=False)
    free = rollout(simulator, [start], types, friction, SMALL.history + 12, ignored)[0].positions
    assert not np.any(np.all(free[-2:, :5] == free[-1, :5], axis=(0, 2)))  # the head ignored: none held
