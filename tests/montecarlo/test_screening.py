"""Limit-equilibrium screen: Bishop's minimum FS against the infinite slope, Taylor's chart and symmetry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rgns.montecarlo.screening import ScreenResult, ScreenSettings, minimum_factor_of_safety, surface_height
from rgns.scene.geometry import seed_particles

GAMMA = 1800.0 * 9.81
DOMAIN_LENGTH_M = 80.0
SLOPE = np.array([[0.0, 0.0], [36.0, 0.0], [24.0, 10.0], [0.0, 10.0]])  # the long slope: face atan(10/12)
FACE_TAN = 10.0 / 12.0


def _screen(
    vertices: np.ndarray,
    friction_deg,
    cohesion: float = 1.0,
    settings: ScreenSettings | None = None,
    domain_length_m: float = DOMAIN_LENGTH_M,
) -> ScreenResult:
    positions, _ = seed_particles(vertices, 1.0, 2)
    friction = friction_deg(positions) if callable(friction_deg) else np.full(len(positions), float(friction_deg))
    return minimum_factor_of_safety(
        vertices, positions, friction, 1.0, GAMMA, cohesion, settings or ScreenSettings(), domain_length_m
    )


def _infinite_slope(phi_deg: float) -> float:
    return math.tan(math.radians(phi_deg)) / FACE_TAN


def _cut(beta_deg: float, height_m: float = 10.0, crest_m: float = 30.0) -> np.ndarray:
    """A slope of face angle beta against the left wall, its toe on the firm floor (depth factor 1)."""
    toe = crest_m + height_m / math.tan(math.radians(beta_deg))
    return np.array([[0.0, 0.0], [toe, 0.0], [crest_m, height_m], [0.0, height_m]])


def test_surface_height_is_the_top_and_bottom_of_the_polygon():
    top, bottom = surface_height(SLOPE, np.array([-1.0, 0.0, 24.0, 30.0, 36.0, 37.0]))
    np.testing.assert_allclose(top, [np.nan, 10.0, 10.0, 5.0, 0.0, np.nan])
    np.testing.assert_allclose(bottom, [np.nan, 0.0, 0.0, 0.0, 0.0, np.nan])


@pytest.mark.parametrize("phi_deg", [25.0, 30.0, 35.0, 45.0])
def test_cohesionless_slope_is_near_the_infinite_slope(phi_deg):
    """c ~ 0: the critical circle is a shallow slide along the face, FS -> tan(phi)/tan(beta) from above.

    No circle beats the planar limit; with min_depth one cell (1 m) the slide must bulge 1 m below a
    15.6 m face, whose curvature puts FS about 2.5 % above the limit (0.3 % with min_depth 0.25 m).
    """
    result = _screen(SLOPE, phi_deg)
    assert 0.99 <= result.factor_of_safety / _infinite_slope(phi_deg) <= 1.05
    assert result.exit_x == pytest.approx(36.0, abs=1.0)  # out at the toe, in just behind the crest
    assert result.entry_x == pytest.approx(24.0, abs=1.0)


@pytest.mark.parametrize(("beta_deg", "taylor"), [(90.0, 0.261), (60.0, 0.191)])
def test_purely_cohesive_cut_matches_taylor(beta_deg, taylor):
    """phi = 0: Bishop is the ordinary method and exact for circles, so N_s = c/(gamma H FS) is Taylor's (1937)."""
    height = 10.0
    cohesion = taylor * GAMMA * height  # FS near 1
    result = _screen(_cut(beta_deg, height), 0.0, cohesion)
    stability_number = cohesion / (GAMMA * height * result.factor_of_safety)
    assert stability_number == pytest.approx(taylor, rel=0.03)
    assert result.exit_x == pytest.approx(_cut(beta_deg, height)[1, 0])  # a toe circle


def test_factor_of_safety_scales_with_strength():
    cut = _cut(60.0)
    single = _screen(cut, 0.0, 30e3).factor_of_safety
    assert _screen(cut, 0.0, 60e3).factor_of_safety == pytest.approx(2.0 * single, rel=1e-6)
    weaker, stronger = _screen(SLOPE, 28.0).factor_of_safety, _screen(SLOPE, 32.0).factor_of_safety
    assert weaker < stronger


def test_weak_zone_near_the_face_lowers_fs_and_one_far_behind_does_not():
    uniform = _screen(SLOPE, 35.0).factor_of_safety
    normal = np.array([10.0, 12.0]) / math.hypot(10.0, 12.0)  # the face's outward normal

    def face_band(positions):
        return np.where((np.array([36.0, 0.0]) - positions) @ normal < 2.0, 20.0, 35.0)

    def back_zone(positions):
        return np.where(positions[:, 0] < 6.0, 20.0, 35.0)

    band = _screen(SLOPE, face_band).factor_of_safety
    assert band < 0.6 * uniform
    assert band == pytest.approx(_infinite_slope(20.0), rel=0.05)
    assert _screen(SLOPE, back_zone).factor_of_safety == pytest.approx(uniform, rel=1e-3)


def test_mirrored_slope_and_field_give_the_same_fs():
    positions, _ = seed_particles(SLOPE, 1.0, 2)
    friction = 30.0 + 8.0 * np.sin(positions[:, 0] / 6.0) * np.cos(positions[:, 1] / 4.0)
    mirrored = np.column_stack([DOMAIN_LENGTH_M - SLOPE[::-1, 0], SLOPE[::-1, 1]])  # against the right wall
    mirrored_positions = np.column_stack([DOMAIN_LENGTH_M - positions[:, 0], positions[:, 1]])
    settings = ScreenSettings()
    right = minimum_factor_of_safety(SLOPE, positions, friction, 1.0, GAMMA, 1.0, settings, DOMAIN_LENGTH_M)
    left = minimum_factor_of_safety(mirrored, mirrored_positions, friction, 1.0, GAMMA, 1.0, settings, DOMAIN_LENGTH_M)
    assert left.factor_of_safety == pytest.approx(right.factor_of_safety, rel=1e-6)
    assert left.centre[0] == pytest.approx(DOMAIN_LENGTH_M - right.centre[0])
    mirrored_ends = (DOMAIN_LENGTH_M - right.entry_x, DOMAIN_LENGTH_M - right.exit_x)
    assert (left.entry_x, left.exit_x) == pytest.approx(mirrored_ends)


def test_embankment_fails_on_its_weaker_face():
    embankment = np.array([[20.0, 0.0], [60.0, 0.0], [47.0, 8.0], [33.0, 8.0]])
    result = _screen(embankment, lambda positions: np.where(positions[:, 0] < 40.0, 25.0, 35.0))
    assert result.exit_x == pytest.approx(20.0, abs=1.0) and result.entry_x > result.exit_x  # down the left face
    assert result.factor_of_safety == pytest.approx(math.tan(math.radians(25.0)) * 13.0 / 8.0, rel=0.05)


def test_deeper_minimum_depth_never_lowers_fs():
    fs = [
        _screen(SLOPE, 30.0, settings=ScreenSettings(min_depth_m=depth)).factor_of_safety
        for depth in (0.25, 1.0, 2.0, 4.0)
    ]
    assert fs == sorted(fs)
    assert fs[0] == pytest.approx(_infinite_slope(30.0), rel=0.01)


def test_side_walls_are_not_free_faces():
    layer = np.array([[0.0, 0.0], [80.0, 0.0], [80.0, 5.0], [0.0, 5.0]])  # wall to wall
    assert _screen(layer, 30.0).factor_of_safety == math.inf
    assert _screen(layer, 30.0, domain_length_m=math.inf).factor_of_safety < 1.0  # x = 80 is a free face
    assert _screen(layer * [0.5, 1.0], 30.0).factor_of_safety < 1.0


def test_settings_skip_only_when_enabled_and_above_threshold():
    assert not ScreenSettings().skips(5.0)
    assert ScreenSettings(enabled=True).skips(1.3)
    assert not ScreenSettings(enabled=True).skips(1.1)
