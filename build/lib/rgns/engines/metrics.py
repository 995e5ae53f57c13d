"""Runout metrics of one realization (paper §4.1), for slopes that face +x.

* A particle is *displaced* when its final displacement is at least ``threshold_m`` (1 m).
* Runout distance R: how far the front moved beyond the initial toe. Front and toe are the same
  percentile q (99) of x — the front over the displaced particles' final positions, the toe over
  every particle's initial position — so a single stray particle, and the thin tip of a sloping
  toe, count alike before and after: a rigid shift by d gives R = d exactly.
* Sliding volume V: the total volume of displaced particles (m² per metre width).
* Influence distance I: from the initial crest back to the back scarp, the rear-most displaced
  particle's initial x (no percentile: a scarp sheds no stray particles, and a percentile would
  cut off the thin back tip of a wedge).
All three are 0 when nothing is displaced, and R and I are never negative.

Energies (paper Fig. 12): Ep = Σ m g h (h above the floor y = 0), Ek = ½ Σ m v² with v the
per-frame finite difference, Ed = E0 − (Ep + Ek), all divided by the initial E0. Computed from
positions alone, so MPM and GNS trajectories are measured the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

DISPLACEMENT_THRESHOLD_M = 1.0
RUNOUT_PERCENTILE = 99.0


def displaced(initial: np.ndarray, final: np.ndarray, threshold_m: float = DISPLACEMENT_THRESHOLD_M) -> np.ndarray:
    """Mask [N] of particles displaced by at least ``threshold_m`` between [N, 2] positions."""
    return np.linalg.norm(np.asarray(final, dtype=float) - initial, axis=1) >= threshold_m


def runout_distance(
    initial: np.ndarray,
    final: np.ndarray,
    threshold_m: float = DISPLACEMENT_THRESHOLD_M,
    percentile: float = RUNOUT_PERCENTILE,
) -> float:
    """Horizontal travel of the flow front beyond the initial toe (m)."""
    moved = displaced(initial, final, threshold_m)
    if not moved.any():
        return 0.0
    front = np.percentile(np.asarray(final)[moved, 0], percentile)
    return max(0.0, float(front - toe_x(initial, percentile)))


def toe_x(initial: np.ndarray, percentile: float = RUNOUT_PERCENTILE) -> float:
    """The initial toe: the ``percentile`` of every particle's initial x."""
    return float(np.percentile(np.asarray(initial)[:, 0], percentile))


def sliding_volume(
    initial: np.ndarray, final: np.ndarray, volume: np.ndarray, threshold_m: float = DISPLACEMENT_THRESHOLD_M
) -> float:
    """Volume (area in 2-D) of the displaced particles."""
    return float(np.asarray(volume)[displaced(initial, final, threshold_m)].sum())


def influence_distance(
    initial: np.ndarray, final: np.ndarray, crest_x_m: float, threshold_m: float = DISPLACEMENT_THRESHOLD_M
) -> float:
    """Horizontal distance from the crest back to the rear-most displaced particle (initial x)."""
    moved = displaced(initial, final, threshold_m)
    if not moved.any():
        return 0.0
    return max(0.0, float(crest_x_m - np.asarray(initial)[moved, 0].min()))


# ground behind a crest slopes less than this; a face steeper (every face that can fail is), judged
# over at least CREST_BASE_M of horizontal distance, so that a bump in a DEM's ground is no face
CREST_GROUND_DEG = 10.0
CREST_BASE_M = 2.0


def crest_x(vertices: np.ndarray, ground_deg: float = CREST_GROUND_DEG, base_m: float = CREST_BASE_M) -> float:
    """x of the crest: the top of the face, reached from the rightmost highest vertex by walking right
    along the boundary until both the next edge and the ground over ``base_m`` ahead drop more steeply
    than ``ground_deg``.

    On a flat-topped polygon that is the rightmost vertex at the greatest height. Where the ground
    behind the face rises gently to the left (a real site's hinterland, or a drawn polygon whose
    wall-side corner came out higher than its crest), the highest vertex lies far behind the face,
    and I measured from it would be 0.
    """
    n = len(vertices)
    top = np.flatnonzero(vertices[:, 1] >= vertices[:, 1].max() - 1e-9)
    k = int(top[np.argmax(vertices[top, 0])])
    step = 1 if vertices[(k + 1) % n, 0] > vertices[(k - 1) % n, 0] else -1
    limit = np.tan(np.radians(ground_deg))
    for _ in range(n - 1):
        if vertices[(k + step) % n, 0] <= vertices[k, 0]:
            break  # the boundary turns back: k is the rightmost point
        j = (k + step) % n  # the first vertex ahead at least base_m away (or the last rightward)
        while vertices[j, 0] - vertices[k, 0] < base_m and vertices[(j + step) % n, 0] > vertices[j, 0]:
            j = (j + step) % n
        next_dx, next_dy = vertices[(k + step) % n] - vertices[k]
        dx, dy = vertices[j] - vertices[k]
        if next_dy < -limit * next_dx and dy < -limit * dx:  # the next edge and the ground over base_m drop steeply
            break
        k = (k + step) % n
    return float(vertices[k, 0])


@dataclass
class MetricSettings:
    """Config section ``metrics``: what counts as displaced, and the runout percentile."""

    displacement_threshold_m: float = DISPLACEMENT_THRESHOLD_M
    runout_percentile: float = RUNOUT_PERCENTILE


@dataclass
class RunoutMetrics:
    """R, V, I of one realization, with where its affected interval lies on the x axis."""

    runout_m: float
    volume_m2: float
    influence_m: float
    displaced_fraction: float
    toe_x_m: float
    crest_x_m: float

    @property
    def front_x_m(self) -> float:
        """The runout front (NaN when nothing moved)."""
        return self.toe_x_m + self.runout_m if self.displaced_fraction > 0 else float("nan")

    @property
    def rear_x_m(self) -> float:
        """The back scarp (NaN when nothing moved)."""
        return self.crest_x_m - self.influence_m if self.displaced_fraction > 0 else float("nan")

    def as_row(self) -> dict[str, float]:
        return {
            "runout_m": self.runout_m,
            "volume_m2": self.volume_m2,
            "influence_m": self.influence_m,
            "displaced_fraction": self.displaced_fraction,
            "toe_x_m": self.toe_x_m,
            "crest_x_m": self.crest_x_m,
            "front_x_m": self.front_x_m,
            "rear_x_m": self.rear_x_m,
        }


def runout_metrics(
    initial: np.ndarray, final: np.ndarray, volume: np.ndarray, crest_x_m: float, settings: MetricSettings | None = None
) -> RunoutMetrics:
    """R, V and I of one realization from its initial and final positions [N, 2]."""
    settings = settings or MetricSettings()
    threshold = settings.displacement_threshold_m
    return RunoutMetrics(
        runout_m=runout_distance(initial, final, threshold, settings.runout_percentile),
        volume_m2=sliding_volume(initial, final, volume, threshold),
        influence_m=influence_distance(initial, final, crest_x_m, threshold),
        displaced_fraction=float(displaced(initial, final, threshold).mean()),
        toe_x_m=toe_x(initial, settings.runout_percentile),
        crest_x_m=float(crest_x_m),
    )


def normalized_energies(
    positions: np.ndarray, mass_kg: np.ndarray, frame_interval_s: float, gravity_m_s2: float = 9.81
) -> np.ndarray:
    """[T, 3] potential, kinetic and dissipated energy per frame, each divided by E0."""
    positions = np.asarray(positions, dtype=float)
    mass = np.asarray(mass_kg, dtype=float)
    potential = gravity_m_s2 * positions[:, :, 1] @ mass
    velocity = np.zeros_like(positions)
    velocity[1:] = (positions[1:] - positions[:-1]) / frame_interval_s
    kinetic = 0.5 * (velocity**2).sum(axis=2) @ mass
    initial = potential[0]
    if initial <= 0:
        raise ValueError("initial potential energy must be positive (is the material above the floor y = 0?)")
    dissipated = initial - potential - kinetic
    return np.stack([potential, kinetic, dissipated], axis=1) / initial
