"""Geostatic initial stresses of a slope: σyy = −ρ g depth, σxx = σzz = K0 σyy (tension positive)."""

from __future__ import annotations

import numpy as np


def surface_height(vertices: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Height of the polygon's upper boundary above each x (the highest edge crossing x)."""
    top = np.full(x.shape, -np.inf)
    for a, b in zip(vertices, np.roll(vertices, -1, axis=0)):
        low, high = min(a[0], b[0]), max(a[0], b[0])
        crossing = (x >= low) & (x <= high)
        if a[0] == b[0]:
            y = np.full(x.shape, max(a[1], b[1]))
        else:
            y = a[1] + (x - a[0]) * (b[1] - a[1]) / (b[0] - a[0])
        top = np.where(crossing, np.maximum(top, y), top)
    return top


def geostatic_stresses(
    vertices: np.ndarray,
    positions: np.ndarray,
    friction_deg: np.ndarray,
    density_kg_m3: float,
    gravity_m_s2: float,
    k0: float | None = None,
) -> np.ndarray:
    """Per-particle stresses [N, 6] in CB-Geo order σxx σyy σzz τxy τyz τxz (Pa, tension +).

    Depth is measured down from the polygon's upper boundary; K0 is Jaky's 1 − sin φ of each
    particle unless given.
    """
    depth = np.maximum(surface_height(vertices, positions[:, 0]) - positions[:, 1], 0.0)
    vertical = -density_kg_m3 * gravity_m_s2 * depth
    lateral = (1.0 - np.sin(np.radians(friction_deg))) if k0 is None else np.full(len(positions), k0)
    stresses = np.zeros((len(positions), 6))
    stresses[:, 0] = lateral * vertical
    stresses[:, 1] = vertical
    stresses[:, 2] = lateral * vertical
    return stresses
