"""Runout metrics of one realization (paper §4.1), for slopes that face +x.

* A particle is *displaced* when its final displacement is at least ``threshold_m`` (1 m).
* Runout distance R: the ``percentile``-th (99) percentile of the displaced particles' final x,
  minus the initial toe (the rightmost initial particle). The percentile filters stray particles.
* Sliding volume V: the total volume of displaced particles (m² per metre width).
* Influence distance I: from the initial crest back to the rear-most displaced particle, measured
  on initial positions (the back scarp).
All three are 0 when nothing is displaced.
"""
from __future__ import annotations

import numpy as np

DISPLACEMENT_THRESHOLD_M = 1.0
RUNOUT_PERCENTILE = 99.0


def displaced(initial: np.ndarray, final: np.ndarray, threshold_m: float = DISPLACEMENT_THRESHOLD_M) -> np.ndarray:
    """Mask [N] of particles displaced by at least ``threshold_m`` between [N, 2] positions."""
    return np.linalg.norm(np.asarray(final, dtype=float) - initial, axis=1) >= threshold_m


def runout_distance(initial: np.ndarray, final: np.ndarray, threshold_m: float = DISPLACEMENT_THRESHOLD_M,
                    percentile: float = RUNOUT_PERCENTILE) -> float:
    """Horizontal travel of the flow front beyond the initial toe (m)."""
    moved = displaced(initial, final, threshold_m)
    if not moved.any():
        return 0.0
    return max(0.0, float(np.percentile(np.asarray(final)[moved, 0], percentile) - initial[:, 0].max()))


def sliding_volume(initial: np.ndarray, final: np.ndarray, volume: np.ndarray,
                   threshold_m: float = DISPLACEMENT_THRESHOLD_M) -> float:
    """Volume (area in 2-D) of the displaced particles."""
    return float(np.asarray(volume)[displaced(initial, final, threshold_m)].sum())


def influence_distance(initial: np.ndarray, final: np.ndarray, crest_x_m: float,
                       threshold_m: float = DISPLACEMENT_THRESHOLD_M) -> float:
    """Horizontal distance from the crest back to the rear-most displaced particle (initial x)."""
    moved = displaced(initial, final, threshold_m)
    if not moved.any():
        return 0.0
    return max(0.0, float(crest_x_m - initial[moved, 0].min()))


def crest_x(vertices: np.ndarray) -> float:
    """x of the crest: the rightmost vertex at the polygon's greatest height."""
    top = vertices[:, 1] >= vertices[:, 1].max() - 1e-9
    return float(vertices[top, 0].max())
