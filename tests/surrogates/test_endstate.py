"""The end-state surrogate's parts: the lattice, learning a known rule, exact resume, files, the
Monte Carlo and validation routes (the shipped model's accuracy: tests/surrogates/test_endstate_general.py)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

import rgns.surrogates.endstate.train as training
from rgns.engines.metrics import MetricSettings, crest_x
from rgns.montecarlo.runs import MonteCarloError, RunSettings, run_realizations
from rgns.scene.geometry import Scene, seed_particles
from rgns.scene.realizations import CaseInputs, draw_realization
from rgns.surrogates.endstate.card import check_serves
from rgns.surrogates.endstate.data import EndState, EndStateDataError, read_end_states, write_end_states
from rgns.surrogates.endstate.evaluate import EvaluationError, agreement_rows, paired_finals
from rgns.surrogates.endstate.lattice import Lattice, LatticeError
from rgns.surrogates.endstate.model import EndStateModel, EndStateModelError, Normalization, load_model, on_side
from rgns.surrogates.endstate.train import EndStateTrainSettings, examples, held_out_loss, normalization_of, train
from rgns.surrogates.pairing import pair_end_states
from rgns.surrogates.shipped import ShippedModelError
from rgns.trajectories import Trajectory

LATTICE = Lattice.for_domain(20.0, 8.0, 1.0, 2)
SLOPE = np.array([[0.0, 0.0], [12.0, 0.0], [6.0, 5.0], [0.0, 5.0]])


def synthetic_states(count: int, seed: int) -> list[EndState]:
    """Slopes whose upper points slide by (32 - mean friction) / 2 m when the mean friction is below
    32 degrees: a rule that needs the whole slope's field, not each point's own."""
    rng = np.random.default_rng(seed)
    initial, volume = seed_particles(SLOPE, 1.0, 2)
    states = []
    for index in range(count):
        friction = 30.0 + 4.0 * rng.standard_normal() + rng.standard_normal(len(initial))
        slide = max(0.0, (32.0 - friction.mean()) / 2.0)
        final = initial + np.where(initial[:, 1:] > 2.5, [slide, -0.2 * slide], 0.0)
        states.append(EndState("synthetic", index, initial, final, friction, volume))
    return states


def test_lattice_round_trip_and_refusals():
    initial, _ = seed_particles(SLOPE, 1.0, 2)
    moved = initial + np.column_stack([initial[:, 0] * 0.1, -initial[:, 1] * 0.05])
    image = LATTICE.targets(initial, moved, 0.5)
    assert image.shape == (2, 16, 40)
    np.testing.assert_allclose(LATTICE.gather(image, initial) * 0.5, moved - initial, atol=1e-6)
    inputs = LATTICE.inputs(initial, np.full(len(initial), 35.0), 30.0, 5.0)
    assert inputs[0].sum() == len(initial) and np.allclose(inputs[1][inputs[0] == 1], 1.0)
    with pytest.raises(LatticeError, match="not on the 0.5 m lattice"):
        LATTICE.pixels(initial + 0.1)
    with pytest.raises(LatticeError, match="outside the model's 20.0 x 8.0 m domain"):
        LATTICE.pixels(initial + [0.0, 4.0])
    with pytest.raises(LatticeError, match="share a lattice pixel"):
        LATTICE.pixels(np.vstack([initial, initial[:1]]))


def test_learns_a_rule_that_needs_the_whole_slope(tmp_path):
    """Held-out loss far below the mean predictor's, and the slide of held-out slopes recovered."""
    torch.manual_seed(0)
    settings = EndStateTrainSettings(
        widths=(8, 16, 32), steps=300, batch_size=8, learning_rate=3e-3, checkpoint_every=300, threads=1
    )
    held = synthetic_states(24, seed=2)
    model, history = train(synthetic_states(96, seed=1), held, LATTICE, settings, tmp_path)
    assert history[-1]["valid_loss"] < 0.05 * history[-1]["valid_mean_predictor_loss"]
    finals = model.predict([s.initial for s in held], [s.friction_deg for s in held])
    truth = np.array([(s.final - s.initial)[:, 0].max() for s in held])
    predicted = np.array([(f - s.initial)[:, 0].max() for f, s in zip(finals, held)])
    assert np.corrcoef(truth, predicted)[0, 1] > 0.95
    assert np.abs(predicted - truth).mean() < 0.25 * truth.std()


def test_resume_continues_exactly(tmp_path, monkeypatch):
    """Killed after its step-10 checkpoint and resumed, a training ends with the weights of an
    uninterrupted one."""
    settings = EndStateTrainSettings(widths=(4, 8), steps=20, batch_size=4, checkpoint_every=10, threads=1)
    states, held = synthetic_states(12, seed=3), synthetic_states(4, seed=4)
    whole, _ = train(states, held, LATTICE, settings, tmp_path / "whole")
    calls = {"n": 0}
    original = training.masked_loss

    def dying(model, batch, threshold=None):
        calls["n"] += 1
        if calls["n"] == 13:  # 10 steps, the checkpoint's held-out loss, step 11, then killed in step 12
            raise KeyboardInterrupt
        return original(model, batch, threshold)

    monkeypatch.setattr(training, "masked_loss", dying)
    with pytest.raises(KeyboardInterrupt):
        train(states, held, LATTICE, settings, tmp_path / "killed")
    monkeypatch.setattr(training, "masked_loss", original)
    resumed, history = train(states, held, LATTICE, settings, tmp_path / "killed")
    assert [row["step"] for row in history] == [10, 20]
    for name, value in whole.state_dict().items():
        torch.testing.assert_close(resumed.state_dict()[name], value, rtol=0, atol=0)


def test_end_state_files_round_trip_and_a_bad_file_is_named(tmp_path):
    states = synthetic_states(3, seed=5)
    path = tmp_path / "chunk_000.h5"
    write_end_states(path, states, ["ok"] * 3 + ["diverged: NaN"])
    back = read_end_states([path])
    assert [s.index for s in back] == [0, 1, 2]
    np.testing.assert_array_equal(back[1].final, states[1].final)
    bad = tmp_path / "chunk_001.h5"
    bad.write_bytes(b"not hdf5")
    with pytest.raises(EndStateDataError, match="chunk_001.h5"):
        read_end_states([path, bad])


def test_model_file_round_trip_and_a_bad_file_is_named(tmp_path):
    states = synthetic_states(8, seed=6)
    settings = EndStateTrainSettings(widths=(4, 8), steps=2, batch_size=2, checkpoint_every=2, threads=1)
    model, _ = train(states, states, LATTICE, settings, tmp_path)
    model.save(tmp_path / "endstate.pt")
    loaded = load_model(tmp_path / "endstate.pt")
    inputs = [s.initial for s in states], [s.friction_deg for s in states]
    for a, b in zip(model.predict(*inputs), loaded.predict(*inputs)):
        np.testing.assert_array_equal(a, b)
    (tmp_path / "broken.pt").write_bytes(b"nothing")
    with pytest.raises(EndStateModelError, match="broken.pt"):
        load_model(tmp_path / "broken.pt")


def test_normalization_and_mean_predictor(tmp_path):
    states = synthetic_states(16, seed=7)
    normalization = normalization_of(states)
    assert 25.0 < normalization.friction_center_deg < 35.0
    moved = np.concatenate([np.linalg.norm(s.final - s.initial, axis=1) for s in states])
    assert normalization.displacement_scale_m == pytest.approx(np.sqrt(np.mean(moved**2)))
    settings = EndStateTrainSettings(widths=(4, 8), steps=1, batch_size=2, checkpoint_every=1, threads=1)
    model, _ = train(states, states, LATTICE, settings, tmp_path)
    batch = examples(model, states)
    _, mean_loss = held_out_loss(model, batch)
    targets = batch.targets.permute(1, 0, 2, 3)[:, batch.mask[:, 0].bool()]  # [2, points of every slope]
    assert mean_loss == pytest.approx(float(targets.var(dim=1, unbiased=False).mean()), rel=1e-5)


def sliding_model(slide_m: float) -> EndStateModel:
    """A model on the default 80 x 20 m lattice whose every point slides ``slide_m`` in x (the head's bias)."""
    model = EndStateModel(Lattice.for_domain(80.0, 20.0, 1.0, 2), Normalization(30.0, 5.0, slide_m), (4, 8))
    with torch.no_grad():
        model.network.head.weight.zero_()
        model.network.head.bias.copy_(torch.tensor([1.0, 0.0]))
    return model.eval()


def test_monte_carlo_route_measures_the_predicted_end_state(default_config):
    """A rigid slide of d = 2 m: R = d exactly, V = the whole slope, I from the crest to the wall,
    kinetic energy 0 at the end, and the status and simulator recorded."""
    params = {
        "montecarlo": default_config["montecarlo"] | {"simulator": "endstate", "batch_size": 2},
        "mpm": default_config["mpm"],
        "metrics": default_config["metrics"],
    }
    inputs = CaseInputs.from_config(default_config, "case1")
    table = run_realizations(inputs, [0, 1], RunSettings.from_params(params), sliding_model(2.0))
    scene = draw_realization(inputs, 0).scene
    assert list(table["status"]) == ["ok", "ok"] and list(table["simulator"]) == ["endstate"] * 2
    np.testing.assert_allclose(table["runout_m"], 2.0, atol=1e-5)
    np.testing.assert_allclose(table["volume_m2"], scene.volumes.sum())
    np.testing.assert_allclose(table["influence_m"], crest_x(scene.vertices) - scene.positions[:, 0].min())
    np.testing.assert_allclose(table["kinetic_final"], 0.0, atol=1e-12)
    with pytest.raises(MonteCarloError, match="'endstate' needs a trained model"):
        run_realizations(inputs, [0], RunSettings.from_params(params))


def test_validation_pairs_the_end_state_with_the_mpm_run():
    """The MPM trajectory moved by 2 m at its end and a model that slides 2 m agree exactly; the
    surrogate's energies exist at the start and the end only."""
    model = sliding_model(2.0)
    scene = Scene(
        "case1",
        0,
        "long_slope",
        np.array([[0.0, 0.0], [36.0, 0.0], [24.0, 10.0], [0.0, 10.0]]),
        *seed_particles(np.array([[0.0, 0.0], [36.0, 0.0], [24.0, 10.0], [0.0, 10.0]]), 1.0, 2),
        80.0,
        20.0,
        1.0,
        2,
        draws=0,
    )
    n = len(scene.positions)
    frames = np.stack(
        [scene.positions, scene.positions + [1.0, 0.0], scene.positions + [2.0, 0.0], scene.positions + [2.0, 0.0]]
    )
    trajectory = Trajectory(
        frames,
        np.arange(4) * 0.025,
        np.full(n, 6),
        np.full(n, 30.0),
        scene.volumes,
        scene.volumes * 1800.0,
        0.025,
        np.array([[0.0, 80.0], [0.0, 20.0]]),
        "embedded",
        "case1",
        0,
    )
    paired = pair_end_states(model, [trajectory], {0: scene}, MetricSettings(1.0, 99.0), 9.81)
    row = paired.pairs.iloc[0]
    for key in ("runout_m", "volume_m2", "influence_m"):
        assert row[f"{key}_gns"] == pytest.approx(row[f"{key}_mpm"], abs=1e-5)
    assert row["final_position_mse_m2"] < 1e-10
    assert np.isnan(paired.gns_energies[0, 1]).all() and np.isfinite(paired.gns_energies[0, [0, -1]]).all()


def test_a_body_feature_model_answers_the_same_for_a_slope_in_two_domain_sizes():
    """The same slope and soil in an 80 x 20 m and a 46 x 12 m domain: identical displacements from a
    body-feature model (its image of the slope does not depend on the domain); a first,
    domain-feature model sized to each domain answers differently."""
    torch.manual_seed(0)
    slope = np.array([[0.0, 0.0], [30.0, 0.0], [20.0, 9.0], [0.0, 9.0]])
    initial, _ = seed_particles(slope, 1.0, 2)
    friction = 30.0 + np.random.default_rng(1).standard_normal(len(initial))
    norm = Normalization(30.0, 5.0, 1.0)
    model = EndStateModel(Lattice.for_domain(80.0, 20.0, 1.0, 2, "body"), norm, (4, 8, 8)).eval()
    served = {"serves": {}, "bounds": {"domain.length_m": 80.0, "domain.height_m": 20.0}}
    for length, height in ((80.0, 20.0), (46.0, 12.0)):
        check_serves(served, {"domain": {"length_m": length, "height_m": height}})
    finals = [model.predict([initial], [friction])[0] for _ in range(2)]
    np.testing.assert_array_equal(finals[0], finals[1])
    sized = [
        EndStateModel(Lattice.for_domain(length, height, 1.0, 2, "domain"), norm, (4, 8, 8)).eval()
        for length, height in ((80.0, 20.0), (46.0, 12.0))
    ]
    for other in sized[1:]:
        other.load_state_dict(sized[0].state_dict())
    domain_finals = [m.predict([initial], [friction])[0] for m in sized]
    assert np.abs(domain_finals[0] - domain_finals[1]).max() > 1e-4
    with pytest.raises(ShippedModelError, match=r"domain.length_m is 100.0, the model serves at most 80.0"):
        check_serves(served, {"domain": {"length_m": 100.0, "height_m": 20.0}})


def test_body_features_are_height_above_the_floor_and_depth_below_the_surface():
    lattice = Lattice.for_domain(20.0, 8.0, 1.0, 2, "body")
    initial, _ = seed_particles(SLOPE, 1.0, 2)
    image = lattice.inputs(initial, np.full(len(initial), 30.0), 30.0, 5.0)
    row, column = lattice.pixels(initial)
    np.testing.assert_allclose(image[2, row, column] * 20.0, initial[:, 1])
    top = {c: initial[column == c, 1].max() for c in np.unique(column)}
    depth = np.array([top[c] - y + 0.25 for c, y in zip(column, initial[:, 1])])
    np.testing.assert_allclose(image[3, row, column] * 10.0, depth, atol=1e-6)
    assert image[3][image[0] == 0].max() == 0.0


def test_threshold_term_pushes_points_across_the_threshold_the_metrics_count():
    """The moved / not-moved term: off at weight 0; for a point the MPM moved past the threshold
    (1.2 m) a prediction short of it (0.9 m) costs more than one past it (1.1 m) and its gradient
    lengthens it; the reverse for a point that stayed (0.5 m)."""
    assert training.ThresholdTerm.of(EndStateTrainSettings(), 2.0) is None
    term = training.ThresholdTerm.of(
        EndStateTrainSettings(threshold_weight=1.0, threshold_m=1.0, threshold_width_m=0.1), 2.0
    )
    assert term.threshold == 0.5 and term.width == 0.05
    mask = torch.ones(1, 1, 1, 1)

    def cost(predicted_m: float, target_m: float) -> tuple[float, float]:
        predicted = torch.tensor([predicted_m / 2.0, 0.0]).reshape(1, 2, 1, 1).requires_grad_()
        loss = term(predicted, torch.tensor([target_m / 2.0, 0.0]).reshape(1, 2, 1, 1), mask)
        loss.backward()
        return float(loss), float(predicted.grad[0, 0])

    (short, short_slope), (past, _) = cost(0.9, 1.2), cost(1.1, 1.2)
    assert short > 4 * past and short_slope < 0
    (stayed, _), (false_alarm, alarm_slope) = cost(0.5, 0.5), cost(1.1, 0.5)
    assert false_alarm > 5 * stayed and alarm_slope > 0


def test_agreement_of_two_final_states_of_the_same_points(default_config):
    """Another final state of the same points is scored as a model's: the MPM's own end state agrees exactly
    (R² 1, bias 0), one slid 0.5 m further has a runout bias of 0.5 m; points the config does not seed are refused."""
    inputs = CaseInputs.from_config(default_config, "case1")
    metrics = MetricSettings(**default_config["metrics"])
    states = []
    for index in range(6):
        scene = draw_realization(inputs, index).scene
        slide, cut = 2.0 + 0.5 * index, 20.0 - index  # the material past x = cut slides, further for later indices
        final = scene.positions + np.where(scene.positions[:, :1] > cut, [slide, 0.0], 0.0)
        states.append(EndState("case1", index, scene.positions, final, np.full(len(final), 30.0), scene.volumes))
    same = agreement_rows(paired_finals(states, [s.final for s in states], inputs, metrics))
    assert [row["r2"] for row in same] == [1.0, 1.0, 1.0] and all(row["bias"] == 0.0 for row in same)
    further = [s.final + np.where(s.final - s.initial != 0, [0.5, 0.0], 0.0) for s in states]
    runout = agreement_rows(paired_finals(states, further, inputs, metrics))[0]
    assert runout["metric"] == "runout" and runout["bias"] == pytest.approx(0.5, abs=1e-6)
    moved = [
        EndState(
            "case1",
            0,
            states[0].initial + 0.25,
            *[getattr(states[0], k) for k in ("final", "friction_deg", "volume_m2")],
        )
    ]
    with pytest.raises(EvaluationError, match="case1 realization 0"):
        paired_finals(moved, [states[0].final], inputs, metrics)


def test_fine_tuning_starts_from_the_trained_model(tmp_path):
    """Fine-tuned for 10 steps from a trained model, a model keeps that model's normalisation and its held-out loss
    (near the trained one's); the same 10 steps from scratch are nowhere near."""
    torch.manual_seed(0)
    settings = EndStateTrainSettings(widths=(8, 16, 32), steps=200, batch_size=8, learning_rate=3e-3, threads=1)
    held = synthetic_states(24, seed=2)
    base, trained = train(synthetic_states(96, seed=1), held, LATTICE, settings, tmp_path / "base")
    brief = EndStateTrainSettings(
        widths=(8, 16, 32), steps=10, batch_size=8, learning_rate=1e-4, checkpoint_every=10, threads=1
    )
    more = synthetic_states(48, seed=5)
    tuned, history = train(more, held, LATTICE, brief, tmp_path / "tuned", start=base)
    _, scratch = train(more, held, LATTICE, brief, tmp_path / "scratch")
    assert tuned.normalization == base.normalization
    assert history[-1]["valid_loss"] < 1.5 * trained[-1]["valid_loss"] < 0.1 * scratch[-1]["valid_loss"]


def test_the_moved_head_puts_each_displacement_on_its_side_of_the_threshold():
    """A point the head calls moved ends at least the threshold away along its own direction, one it calls still ends
    short of it; displacements already on their side are kept; a moved point with no displacement moves down."""
    displacement = np.array([[0.6, 0.8], [3.0, 0.0], [0.0, 1.2], [0.3, 0.0], [0.0, 0.0]])
    moved = np.array([True, True, False, False, True])
    placed = on_side(displacement, moved, threshold_m=1.0)
    length = np.linalg.norm(placed, axis=1)
    assert (length[moved] >= 1.0).all() and (length[~moved] < 1.0).all()
    np.testing.assert_allclose(placed[[1, 3]], displacement[[1, 3]])
    np.testing.assert_allclose(placed[0] / length[0], [0.6, 0.8])
    assert placed[4, 0] == 0.0 and placed[4, 1] < -1.0


def test_a_moved_head_grown_on_a_trained_model_starts_at_its_displacements_and_learns_from_the_threshold_term(
    tmp_path,
):
    """Grown on a two-channel model, the head starts at logit 0 and leaves the displacement channels as they were;
    the threshold term trains the head's logit (not the displacement's length); the head survives a save."""
    states = synthetic_states(8, seed=6)
    plain, _ = train(
        states, states, LATTICE, EndStateTrainSettings(widths=(4, 8), steps=2, batch_size=2, threads=1), tmp_path / "a"
    )
    headed = EndStateModel(plain.lattice, plain.normalization, plain.widths, moved_head=True)
    headed.load_state_dict(training.started_weights(plain, headed))
    inputs = examples(plain, states).inputs
    with torch.no_grad():
        out, before = headed(inputs), plain(inputs)
    torch.testing.assert_close(out[:, :2], before, rtol=0, atol=0)
    assert (out[:, 2] == 0).all()
    term = training.ThresholdTerm.of(EndStateTrainSettings(threshold_weight=1.0), 1.0)
    predicted = torch.tensor([0.1, 0.0, 5.0]).reshape(1, 3, 1, 1).requires_grad_()
    term(predicted, torch.tensor([2.0, 0.0]).reshape(1, 2, 1, 1), torch.ones(1, 1, 1, 1)).backward()
    assert predicted.grad[0, 0] == 0 and predicted.grad[0, 2] < 0  # a moved point: its logit pushed up
    headed.save(tmp_path / "headed.pt")
    loaded = load_model(tmp_path / "headed.pt")
    assert loaded.moved_head and loaded.threshold_m == 1.0
    with pytest.raises(ValueError, match="threshold_weight"):
        train(states, states, LATTICE, EndStateTrainSettings(widths=(4, 8), steps=1, moved_head=True), tmp_path / "b")
