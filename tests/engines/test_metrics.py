"""Runout metrics and energies on constructed trajectories whose answers are known by hand."""

import numpy as np
import pytest

from rgns.engines.metrics import MetricSettings, crest_x, normalized_energies, runout_metrics
from rgns.scene.geometry import seed_particles, signed_area

SLOPE = np.array([[0.0, 0.0], [30.0, 0.0], [20.0, 10.0], [0.0, 10.0]])  # toe at x = 30, crest at x = 20
SPACING = 0.25


@pytest.fixture(scope="module")
def slope():
    positions, volumes = seed_particles(SLOPE, cell_size_m=0.5, particles_per_cell=2)
    return positions, volumes


def test_a_rigid_shift_of_2_m_displaces_everything(slope):
    positions, volumes = slope
    final = positions + [2.0, 0.0]
    measured = runout_metrics(positions, final, volumes, crest_x(SLOPE))
    assert measured.displaced_fraction == 1.0
    assert measured.volume_m2 == pytest.approx(volumes.sum(), rel=1e-12)
    assert measured.volume_m2 == pytest.approx(signed_area(SLOPE), rel=0.01)  # particles tile the polygon
    assert measured.runout_m == pytest.approx(2.0, abs=1e-9)
    assert measured.influence_m == pytest.approx(crest_x(SLOPE) - positions[:, 0].min())
    assert measured.front_x_m == pytest.approx(np.percentile(final[:, 0], 99.0))


def test_a_rigid_shift_of_half_a_metre_displaces_nothing(slope):
    positions, volumes = slope
    measured = runout_metrics(positions, positions + [0.5, 0.0], volumes, crest_x(SLOPE))
    assert (measured.runout_m, measured.volume_m2, measured.influence_m, measured.displaced_fraction) == (0, 0, 0, 0)
    assert np.isnan(measured.front_x_m) and np.isnan(measured.rear_x_m)


def test_the_displacement_threshold_is_configurable(slope):
    positions, volumes = slope
    measured = runout_metrics(
        positions, positions + [0.5, 0.0], volumes, crest_x(SLOPE), MetricSettings(displacement_threshold_m=0.4)
    )
    assert measured.displaced_fraction == 1.0


def test_a_single_stray_particle_does_not_move_the_runout_distance(slope):
    positions, volumes = slope
    final = positions + [3.0, 0.0]
    clean = runout_metrics(positions, final, volumes, crest_x(SLOPE))
    stray = final.copy()
    stray[np.argmax(positions[:, 0])] += [40.0, 0.0]  # one particle flung 40 m further
    with_stray = runout_metrics(positions, stray, volumes, crest_x(SLOPE))
    assert clean.runout_m == pytest.approx(3.0)
    assert abs(with_stray.runout_m - clean.runout_m) <= SPACING
    # with the percentile at 100 the stray particle sets R
    front = MetricSettings(runout_percentile=100.0)
    assert runout_metrics(positions, stray, volumes, crest_x(SLOPE), front).runout_m == pytest.approx(
        runout_metrics(positions, final, volumes, crest_x(SLOPE), front).runout_m + 40.0
    )


def test_one_stray_point_behind_the_scarp_sets_the_influence_distance_unless_it_moved_less_than_the_threshold(slope):
    """I is the rear-most displaced point, no percentile (a wedge's thin back tip must count): one point far
    behind the slide that moved the threshold sets it, one that moved less does not. docs/method.md says why the
    threshold stays at 1 m (benchmarks/results/threshold_scale.md)."""
    positions, volumes = slope
    crest = crest_x(SLOPE)
    final = positions.copy()
    sliding = positions[:, 0] > 15.0
    final[sliding] += [3.0, 0.0]
    clean = runout_metrics(positions, final, volumes, crest)
    assert clean.influence_m == pytest.approx(crest - positions[sliding, 0].min())
    stray = np.argmin(positions[:, 0])  # at the far wall, 20 m behind the crest
    for moved, influence in ((0.9, clean.influence_m), (1.0, crest - positions[stray, 0])):
        shifted = final.copy()
        shifted[stray] += [0.0, -moved]
        measured = runout_metrics(positions, shifted, volumes, crest)
        assert measured.influence_m == pytest.approx(influence)
        assert measured.runout_m == clean.runout_m


@pytest.mark.parametrize("cell_size_m, tolerance", [(0.5, 0.04), (0.25, 0.02), (0.1, 0.008)])
def test_a_known_wedge_slides_its_own_area(cell_size_m, tolerance):
    """Particles above the plane through the toe at 30 degrees slide 3 m down it: V tends to the
    wedge's area as the particles refine (the error is the particle rows cut by its edges)."""
    positions, volumes = seed_particles(SLOPE, cell_size_m, particles_per_cell=2)
    angle = np.radians(30.0)
    toe = np.array([30.0, 0.0])
    above = positions[:, 1] > (toe[0] - positions[:, 0]) * np.tan(angle)
    final = positions.copy()
    final[above] += 3.0 * np.array([np.cos(angle), -np.sin(angle)])
    # the wedge: toe, the crest corner, and the plane's exit on the crest level y = 10
    exit_x = toe[0] - 10.0 / np.tan(angle)
    wedge = np.array([toe, [20.0, 10.0], [exit_x, 10.0]])
    measured = runout_metrics(positions, final, volumes, crest_x(SLOPE))
    assert measured.volume_m2 == pytest.approx(abs(signed_area(wedge)), rel=tolerance)
    # the top particle row sits half a spacing below y = 10, where the plane is 0.5 s / tan 30° further on
    spacing = cell_size_m / 2
    assert measured.influence_m == pytest.approx(crest_x(SLOPE) - exit_x, abs=spacing * (1 + 0.5 / np.tan(angle)))


def test_a_body_at_rest_keeps_all_its_potential_energy():
    positions = np.repeat(np.array([[[0.0, 1.0], [1.0, 3.0]]]), 5, axis=0)
    energies = normalized_energies(positions, np.array([1.0, 2.0]), 0.1)
    np.testing.assert_allclose(energies, np.tile([1.0, 0.0, 0.0], (5, 1)), atol=1e-12)


def test_free_fall_converts_potential_to_kinetic_energy_without_dissipation():
    dt, g = 0.001, 9.81
    t = np.arange(0, 1.0 + dt / 2, dt)
    height = 10.0 - 0.5 * g * t**2
    positions = np.stack([np.zeros_like(t), height], axis=1)[:, None, :]
    energies = normalized_energies(positions, np.array([3.0]), dt, g)
    assert energies[-1, 0] == pytest.approx(height[-1] / 10.0)
    assert energies[-1, 1] == pytest.approx(0.5 * (g * t[-1]) ** 2 / (g * 10.0), rel=1e-3)
    assert np.abs(energies[1:, 2]).max() < 1e-3  # backward differences lag by half a frame


def test_a_block_that_slides_down_and_stops_has_dissipated_the_height_it_lost():
    positions = np.array([[[0.0, 4.0]], [[1.0, 3.0]], [[2.0, 2.0]], [[2.0, 2.0]]])
    energies = normalized_energies(positions, np.array([1.0]), 1.0, 10.0)
    np.testing.assert_allclose(energies[-1], [0.5, 0.0, 0.5])


def test_the_readme_metric_sketch_is_drawn_by_the_metric_code(tmp_path):
    from rgns.report.plots import plot_metric_sketch

    plot_metric_sketch(tmp_path / "metrics.png")
    assert (tmp_path / "metrics.png").stat().st_size > 20_000


def test_the_crest_is_the_top_of_the_face_behind_gently_rising_ground():
    # flat top: the rightmost highest vertex, whichever way the polygon runs
    assert crest_x(SLOPE) == 20.0 and crest_x(SLOPE[::-1]) == 20.0
    # the wall-side corner drawn higher than the crest (the slope family's ranges allow it): still the face's top
    assert crest_x(np.array([[0.0, 0.0], [30.0, 0.0], [22.0, 5.0], [16.0, 9.0], [0.0, 10.5]])) == 16.0
    # a site: ground rising 2 deg away from the face over 20 m, then a 35 deg face; a bump of 0.2 m on the way
    x = np.arange(0.0, 21.0)
    ground = 12.0 - np.tan(np.radians(2.0)) * x + np.where(x == 8.0, 0.2, 0.0)
    face_x = 20.0 + np.arange(1.0, 11.0)
    face = ground[-1] - np.tan(np.radians(35.0)) * (face_x - 20.0)
    surface = np.column_stack([np.concatenate([x, face_x]), np.concatenate([ground, face])])
    face_toe = surface[-1, 0] + surface[-1, 1] / np.tan(np.radians(35.0))
    site = np.vstack([[[0.0, 0.0], [face_toe, 0.0]], surface[::-1]])
    assert crest_x(site) == 20.0
    # an embankment, both crests at one height: the right one (runout is measured to the right)
    assert crest_x(np.array([[20.0, 0.0], [60.0, 0.0], [47.0, 8.0], [33.0, 8.0]])) == 47.0
