"""Procedural 2-D slopes: the training distribution of a surrogate meant for slopes it never saw.

A generated family names a ``generator`` kind and ``params``: each a number or a [min, max] range
drawn uniformly per realization. Every kind builds a ground surface from the toe back to the rear
and closes it along the floor (y = 0), so a polygon always rests on the floor:

* ``slope``: a face of ``face_angle_deg`` rising ``height_m`` from the toe, its angle varying with
  height by ``curvature`` (> 0 concave: steeper near the crest; < 0 convex), cut by ``benches``
  benches of ``bench_width_m``; a crest ``crest_length_m`` long rising at ``crest_tilt_deg``; the rear
  at the left wall, or (with probability ``free_rear``) a back face of ``back_angle_deg`` standing
  free of it.
* ``embankment``: a free-standing body with faces of ``face_angle_deg`` (right) and
  ``back_angle_deg`` (left), a crest ``crest_length_m`` wide tilted by ``crest_tilt_deg``, its left
  toe at ``left_toe_m``.
* ``terrain``: a hillside cut from a synthetic terrain the way rgns.scene.site cuts a DEM section: a
  smooth step of ``height_m`` over ``face_length_m`` plus ``bumps`` sinusoids of relative amplitude
  ``roughness``, a plateau tilted by ``crest_tilt_deg`` behind it, the body from the left wall to
  where the ground meets the base.

Draws that make an invalid polygon (rgns.scene.geometry.polygon_problems) are redrawn by the caller.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

GENERATED_KINDS = ("slope", "embankment", "terrain")
INTEGER_PARAMS = ("benches", "bumps")
FACE_SEGMENTS = 6  # straight pieces a curved face is drawn with


class GeneratorError(ValueError):
    """A generated family's spec is unusable; the message names the family and the parameter."""


def draw_params(family_name: str, family: dict[str, Any], rng: np.random.Generator) -> dict[str, float]:
    """Every parameter of a generated family: a number as it is, a [min, max] range drawn uniformly
    (integers for ``benches`` and ``bumps``, both ends included)."""
    drawn = {}
    for name, value in sorted(family["params"].items()):
        if isinstance(value, list):
            if name in INTEGER_PARAMS:
                drawn[name] = float(rng.integers(int(value[0]), int(value[1]) + 1))
            else:
                drawn[name] = float(rng.uniform(value[0], value[1]))
        else:
            drawn[name] = float(value)
    missing = sorted(set(REQUIRED[family["generator"]]) - set(drawn))
    if missing:
        raise GeneratorError(
            f"geometry family {family_name!r} (generator {family['generator']!r}): params lacks {', '.join(missing)}"
        )
    return drawn


def _face(height_m: float, angle_deg: float, curvature: float, benches: int, bench_width_m: float) -> np.ndarray:
    """The face from its toe (0, 0) up to the crest, as offsets [K, 2] running to the left (x ≤ 0)."""
    tiers = benches + 1
    points = [np.zeros(2)]
    for tier in range(tiers):
        for piece in range(FACE_SEGMENTS):
            t = (tier * FACE_SEGMENTS + piece + 0.5) / (tiers * FACE_SEGMENTS)  # relative height of the piece
            angle = np.clip(angle_deg + curvature * 15.0 * (2.0 * t - 1.0), 10.0, 85.0)
            rise = height_m / (tiers * FACE_SEGMENTS)
            points.append(points[-1] + [-rise / np.tan(np.radians(angle)), rise])
        if tier < tiers - 1:
            points.append(points[-1] + [-bench_width_m, 0.0])
    return np.array(points)


def slope_surface(p: dict[str, float], rng: np.random.Generator) -> np.ndarray:
    """Kind ``slope``: the polygon [K, 2], counter-clockwise from the rear toe (or the wall's foot)."""
    face = _face(p["height_m"], p["face_angle_deg"], p["curvature"], int(p["benches"]), p["bench_width_m"])
    crest_rise = p["crest_length_m"] * np.tan(np.radians(p["crest_tilt_deg"]))
    free = rng.uniform() < p["free_rear"]
    top = face[-1] + [-p["crest_length_m"], crest_rise]
    back = (top[1] / np.tan(np.radians(p["back_angle_deg"]))) if free else 0.0
    rear_x = p["rear_x_m"] if free else 0.0
    toe_x = rear_x + back + p["crest_length_m"] - face[-1][0]
    surface = [[toe_x, 0.0], *(face[1:] + [toe_x, 0.0]), top + [toe_x, 0.0]]
    rear = [[rear_x, 0.0]] if free else [[0.0, top[1]], [0.0, 0.0]]
    return _close(np.array(surface), np.array(rear))


def embankment_surface(p: dict[str, float], rng: np.random.Generator) -> np.ndarray:
    """Kind ``embankment``: a free trapezoid (two faces, a tilted crest)."""
    rise = p["crest_length_m"] * np.tan(np.radians(p["crest_tilt_deg"]))
    left_crest = [p["left_toe_m"] + p["height_m"] / np.tan(np.radians(p["back_angle_deg"])), p["height_m"]]
    right_crest = [left_crest[0] + p["crest_length_m"], p["height_m"] - rise]
    right_toe = [right_crest[0] + right_crest[1] / np.tan(np.radians(p["face_angle_deg"])), 0.0]
    return np.array([[p["left_toe_m"], 0.0], right_toe, right_crest, left_crest])


def terrain_surface(p: dict[str, float], rng: np.random.Generator) -> np.ndarray:
    """Kind ``terrain``: a synthetic hillside sampled every metre, cut at the base like a DEM section."""
    x = np.arange(0.0, p["crest_length_m"] + 3.0 * p["face_length_m"] + 1e-9, 1.0)
    centre = p["crest_length_m"] + 1.5 * p["face_length_m"]
    step = 1.0 / (1.0 + np.exp(4.0 * (x - centre) / p["face_length_m"]))  # 1 on the plateau, 0 at the foot
    z = p["height_m"] * step + np.tan(np.radians(p["crest_tilt_deg"])) * (centre - x) * step
    for _ in range(int(p["bumps"])):
        wavelength = rng.uniform(6.0, 30.0)
        z += (
            p["roughness"]
            * p["height_m"]
            * step
            * (1 - step)
            * 4.0
            * np.sin(2 * np.pi * x / wavelength + rng.uniform(0, 2 * np.pi))
        )
    z -= 0.05 * p["height_m"]  # the base sits a little above the foot, so the body ends at a toe
    below = np.flatnonzero(z <= 0.0)
    end = below[0] if len(below) else len(x) - 1
    if end < 2:
        return np.zeros((0, 2))
    toe_x = x[end - 1] + z[end - 1] / (z[end - 1] - z[end]) if z[end] <= 0 else x[end]
    surface = np.column_stack([x[:end], z[:end]])[::-1]
    return np.vstack([[[0.0, 0.0], [toe_x, 0.0]], surface])


def _close(surface: np.ndarray, rear: np.ndarray) -> np.ndarray:
    """The polygon counter-clockwise: rear foot, toe, the surface up and back, the rear."""
    return np.vstack([rear[-1:], surface, rear[:-1]])


BUILDERS: dict[str, Callable[[dict[str, float], np.random.Generator], np.ndarray]] = {
    "slope": slope_surface,
    "embankment": embankment_surface,
    "terrain": terrain_surface,
}
REQUIRED = {
    "slope": (
        "height_m",
        "face_angle_deg",
        "curvature",
        "benches",
        "bench_width_m",
        "crest_length_m",
        "crest_tilt_deg",
        "free_rear",
        "back_angle_deg",
        "rear_x_m",
    ),
    "embankment": ("height_m", "face_angle_deg", "back_angle_deg", "crest_length_m", "crest_tilt_deg", "left_toe_m"),
    "terrain": ("height_m", "face_length_m", "crest_length_m", "crest_tilt_deg", "bumps", "roughness"),
}


def midpoint_family(family: dict[str, Any]) -> dict[str, Any]:
    """The family with every range at its midpoint (integers rounded down): its mean slope."""

    def middle(name: str, value: float | list[float]) -> float:
        if not isinstance(value, list):
            return float(value)
        return float(int(np.mean(value))) if name in INTEGER_PARAMS else float(np.mean(value))

    return family | {"params": {name: middle(name, value) for name, value in family["params"].items()}}


def generate_vertices(family_name: str, family: dict[str, Any], rng: np.random.Generator) -> np.ndarray:
    """One polygon [K, 2] of a generated family (validity is the caller's check)."""
    kind = family["generator"]
    if kind not in BUILDERS:
        raise GeneratorError(f"geometry family {family_name!r}: generator {kind!r} is not one of {GENERATED_KINDS}")
    vertices = BUILDERS[kind](draw_params(family_name, family, rng), rng)
    return _drop_repeats(vertices)


def _drop_repeats(vertices: np.ndarray) -> np.ndarray:
    """Consecutive vertices closer than a millimetre merged (a zero-length crest or bench)."""
    if len(vertices) == 0:
        return vertices
    keep = np.r_[True, np.linalg.norm(np.diff(vertices, axis=0), axis=1) > 1e-3]
    vertices = vertices[keep]
    if len(vertices) > 1 and np.linalg.norm(vertices[0] - vertices[-1]) <= 1e-3:
        vertices = vertices[:-1]
    return vertices
