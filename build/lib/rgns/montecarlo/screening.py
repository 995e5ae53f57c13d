"""Limit-equilibrium screen of a realization: the minimum factor of safety over circular slip surfaces.

Before a Monte Carlo realization goes to the expensive MPM/GNS simulation, Bishop's simplified method
over trial circles says whether it can fail at all: a realization whose minimum FS is clearly above 1
is skipped and counted as a no-failure run. It is numpy (and a scipy k-d tree), vectorized over circles:
about 40-60 ms for a 1,200-point slope with the default search.

Circles are searched in a frame where the slide moves towards +x; the other direction is the same
search on the mirrored slope. A circle passes through an entry point A and a lower exit point B on the
ground surface and bulges below the chord AB by its sagitta s. The coarse search tries every pair of
``surface_points`` evenly spaced along the surface and ``radii`` sagittas from shallow to the deepest
admissible one (tangent to the floor, or with A level with the centre); ``refinements`` rounds then
zoom in on the best circle. The polygon rests on a rigid floor: arcs stay above it, and vertical edges
on the side walls (x = 0 and x = ``domain_length_m``) are not free faces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from rgns.scene.geometry import WALL_TOLERANCE_M

M_ALPHA_MIN = 0.2  # Whitman & Bailey (1967): Bishop's method is unreliable where m_alpha falls this low
FLOOR_TOLERANCE_M = 1e-6  # how far an arc may dip below the polygon's bottom (rounding)
FS_TOLERANCE = 1e-4  # relative change of FS that ends the fixed-point iteration
MAX_ITERATIONS = 100
MIN_SAGITTA_FRACTION = 1e-3  # the flattest circle the refinement may try, as a fraction of the deepest


@dataclass
class ScreenSettings:
    """Whether and how realizations are screened before simulation."""

    enabled: bool = False
    threshold: float = 1.2  # skip a realization when its minimum FS exceeds this
    min_depth_m: float | None = None  # thinner slides are ignored (MPM cannot resolve them); None: one cell
    surface_points: int = 24  # entry and exit candidates along the ground surface
    radii: int = 8  # sagittas per entry/exit pair
    refinements: int = 6  # zoom rounds around the best circle, each halving the step
    slices: int = 40

    def skips(self, factor_of_safety: float) -> bool:
        """Whether a realization with this minimum FS is counted as no failure without simulating it."""
        return self.enabled and factor_of_safety > self.threshold


@dataclass
class ScreenResult:
    """The minimum FS and its critical circle (nan when no circle is valid), in scene coordinates."""

    factor_of_safety: float
    centre: tuple[float, float]
    radius: float
    entry_x: float  # upslope end of the slip surface
    exit_x: float  # downslope end


def surface_height(vertices: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Top (ground surface) and bottom of the polygon along verticals at ``x``; nan outside it.

    Vertical edges are skipped: at their own x the top and bottom come from the neighbouring edges.
    """
    x = np.asarray(x, dtype=float)
    top, bottom = np.full(x.shape, -np.inf), np.full(x.shape, np.inf)
    for (x0, y0), (x1, y1) in zip(vertices, np.roll(vertices, -1, axis=0)):
        if x0 != x1:
            y = np.where((x >= min(x0, x1)) & (x <= max(x0, x1)), y0 + (x - x0) * ((y1 - y0) / (x1 - x0)), np.nan)
            top, bottom = np.fmax(top, y), np.fmin(bottom, y)
    outside = np.isinf(top)
    top[outside], bottom[outside] = np.nan, np.nan
    return top, bottom


def bishop_factor_of_safety(
    centre_x: np.ndarray,
    centre_y: np.ndarray,
    radius: np.ndarray,
    entry_x: np.ndarray,
    exit_x: np.ndarray,
    vertices: np.ndarray,
    points: cKDTree,
    tan_phi: np.ndarray,
    gamma: float,
    cohesion: float,
    slices: int = 40,
    min_depth_m: float = 0.0,
) -> np.ndarray:
    """FS of each circle [C] by Bishop's simplified method for a slide towards +x; inf where invalid.

    The mass between the lower arc and the ground surface, entry_x < x < exit_x, is cut into vertical
    slices; a slice base takes tan(phi) of the material point nearest to its midpoint (``points``, the
    tree of the positions). Slices where the arc runs above the ground carry nothing. A circle is
    invalid when its arc leaves the polygon or dips below its bottom, its slide is thinner than
    ``min_depth_m``, it drives nothing, m_alpha <= 0.2 where friction lowers it (alpha < 0, the toe),
    or the iteration does not converge. Mirror x for slides towards -x.
    """
    width = (exit_x - entry_x) / slices
    x = entry_x[:, None] + width[:, None] * (np.arange(slices) + 0.5)
    offset = x - centre_x[:, None]
    below_centre = np.sqrt(np.maximum(radius[:, None] ** 2 - offset**2, 0.0))
    base = centre_y[:, None] - below_centre
    sin_a, cos_a = -offset / radius[:, None], below_centre / radius[:, None]
    top, bottom = surface_height(vertices, x)
    thickness = top - base
    loaded = thickness > 0.0
    weight = gamma * width[:, None] * np.where(loaded, thickness, 0.0)
    driving = (weight * sin_a).sum(axis=1)
    with np.errstate(invalid="ignore"):  # nan outside the polygon fails the checks
        inside = (np.isfinite(top) & (~loaded | (base >= bottom - FLOOR_TOLERANCE_M))).all(axis=1)
        valid = inside & (thickness.max(axis=1) >= min_depth_m) & (driving > 0.0)
    fs = np.full(len(radius), np.inf)
    if not valid.any():
        return fs
    loaded, weight, sin_a, cos_a = loaded[valid], weight[valid], sin_a[valid], cos_a[valid]
    tan_base = np.zeros(loaded.shape)
    tan_base[loaded] = tan_phi[points.query(np.column_stack([x[valid][loaded], base[valid][loaded]]))[1]]
    resisting = np.where(loaded, cohesion * width[valid, None], 0.0) + weight * tan_base
    toe = loaded & (sin_a * tan_base < 0.0)
    factor = np.ones(len(resisting))
    converged = np.zeros(len(resisting), dtype=bool)
    for _ in range(MAX_ITERATIONS):
        m_alpha = cos_a + sin_a * tan_base / factor[:, None]
        m_alpha = np.where(loaded, np.where(toe, np.maximum(m_alpha, M_ALPHA_MIN), m_alpha), 1.0)
        update = (resisting / m_alpha).sum(axis=1) / driving[valid]
        converged = np.abs(update - factor) <= FS_TOLERANCE * update
        factor = update
        if converged.all():
            break
    m_alpha = cos_a + sin_a * tan_base / factor[:, None]
    stable = converged & ~(toe & (m_alpha <= M_ALPHA_MIN)).any(axis=1)
    fs[valid] = np.where(stable, factor, np.inf)
    return fs


def _ground_surface(vertices: np.ndarray, walls_x: np.ndarray) -> np.ndarray:
    """The ground-surface edges [E, 2 ends, 2], right to left: edges facing up and vertical faces off the walls."""
    start, end = vertices, np.roll(vertices, -1, axis=0)
    run = end[:, 0] - start[:, 0]
    vertical = np.abs(run) <= WALL_TOLERANCE_M
    on_wall = vertical & (np.abs(start[:, 0, None] - walls_x) <= WALL_TOLERANCE_M).any(axis=1)
    surface = (run < -WALL_TOLERANCE_M) | (vertical & ~on_wall)
    first = int(np.flatnonzero(surface & ~np.roll(surface, 1))[0])
    order = np.roll(np.arange(len(vertices)), -first)
    order = order[surface[order]]
    return np.stack([start[order], end[order]], axis=1)


class _Search:
    """Trial circles of one slide direction (towards +x in this frame) and their FS."""

    def __init__(
        self,
        vertices: np.ndarray,
        walls_x: np.ndarray,
        points: cKDTree,
        tan_phi: np.ndarray,
        gamma: float,
        cohesion: float,
        min_depth_m: float,
        settings: ScreenSettings,
    ) -> None:
        self.vertices, self.points, self.tan_phi = vertices, points, tan_phi
        self.gamma, self.cohesion, self.min_depth_m, self.settings = gamma, cohesion, min_depth_m, settings
        self.edges = _ground_surface(vertices, walls_x)
        self.floor_y = float(vertices[:, 1].min())
        lengths = np.linalg.norm(self.edges[:, 1] - self.edges[:, 0], axis=1)
        self.cumulative = np.concatenate([[0.0], np.cumsum(lengths)])

    def surface_point(self, t: np.ndarray) -> np.ndarray:
        """Points [n, 2] at fractions ``t`` of the ground surface's length, from its right end."""
        along = t * self.cumulative[-1]
        edge = np.clip(np.searchsorted(self.cumulative, along, side="right") - 1, 0, len(self.edges) - 1)
        fraction = (along - self.cumulative[edge]) / (self.cumulative[edge + 1] - self.cumulative[edge])
        return self.edges[edge, 0] + fraction[:, None] * (self.edges[edge, 1] - self.edges[edge, 0])

    def circles(self, params: np.ndarray) -> tuple[np.ndarray, ...]:
        """Centre x, y, radius, entry x, exit x of the circles (t_entry, t_exit, sagitta fraction) [n, 3].

        The sagitta runs up to the deepest admissible one: the arc tangent to the floor (the polygon's lowest
        level), or the entry point level with the centre (beyond it the arc would turn back). Pairs whose entry is
        not upslope of and above the exit give nan.
        """
        a, b = self.surface_point(params[:, 0]), self.surface_point(params[:, 1])
        ok = (b[:, 0] - a[:, 0] > WALL_TOLERANCE_M) & (a[:, 1] - b[:, 1] > WALL_TOLERANCE_M)
        a, b, fraction = a[ok], b[ok], params[ok, 2]
        half = 0.5 * np.linalg.norm(b - a, axis=1)
        normal = np.column_stack([a[:, 1] - b[:, 1], b[:, 0] - a[:, 0]]) / (2.0 * half[:, None])  # up
        middle = 0.5 * (a + b)
        level = (a[:, 1] - middle[:, 1]) / normal[:, 1]
        deepest = np.hypot(level, half) - level
        # the arc tangent to the floor at T: PT^2 = PA * PB with P where the chord's line meets the floor
        above_a, above_b = a[:, 1] - self.floor_y, b[:, 1] - self.floor_y
        meet_x = a[:, 0] + (b[:, 0] - a[:, 0]) * above_a / (above_a - above_b)
        tangent_x = meet_x - np.sqrt(np.hypot(meet_x - a[:, 0], above_a) * np.hypot(meet_x - b[:, 0], above_b))
        radius = ((tangent_x - a[:, 0]) ** 2 + above_a**2) / (2.0 * above_a)
        lift = (tangent_x - middle[:, 0]) * normal[:, 0] + (self.floor_y + radius - middle[:, 1]) * normal[:, 1]
        sagitta = fraction * np.minimum(deepest, radius - lift)
        offset = (half**2 - sagitta**2) / (2.0 * sagitta)
        centre = middle + offset[:, None] * normal
        columns = np.full((5, len(params)), np.nan)
        columns[:3, ok] = centre[:, 0], centre[:, 1], offset + sagitta
        columns[3, ok], columns[4, ok] = a[:, 0], b[:, 0]
        return tuple(columns)

    def factor_of_safety(self, params: np.ndarray) -> np.ndarray:
        """FS of the circles given as (t_entry, t_exit, sagitta fraction) [n, 3]; inf where invalid."""
        circles = self.circles(params)
        ok = np.isfinite(circles[0])
        fs = np.full(len(params), np.inf)
        fs[ok] = bishop_factor_of_safety(
            *(column[ok] for column in circles),
            self.vertices,
            self.points,
            self.tan_phi,
            self.gamma,
            self.cohesion,
            self.settings.slices,
            self.min_depth_m,
        )
        return fs

    def minimum(self) -> tuple[float, np.ndarray]:
        """The smallest FS found and its circle parameters: a coarse grid, then zooming in."""
        settings = self.settings
        t = np.linspace(0.0, 1.0, settings.surface_points)
        fraction = np.arange(1, settings.radii + 1) / settings.radii
        params = np.stack(np.meshgrid(t, t, fraction, indexing="ij"), axis=-1).reshape(-1, 3)
        fs = self.factor_of_safety(params)
        best = int(np.argmin(fs))
        best_fs, best_params = float(fs[best]), params[best]
        if not math.isfinite(best_fs):
            return best_fs, best_params
        step = 0.5 * np.array([t[1], t[1], fraction[0]])
        stencil = np.stack(np.meshgrid(*[np.arange(-2.0, 3.0)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
        for _ in range(settings.refinements):
            trial = np.clip(best_params + stencil * step, [0.0, 0.0, MIN_SAGITTA_FRACTION], 1.0)
            fs = self.factor_of_safety(trial)
            best = int(np.argmin(fs))
            if fs[best] < best_fs:
                best_fs, best_params = float(fs[best]), trial[best]
            step /= 2.0
        return best_fs, best_params


def minimum_factor_of_safety(
    vertices: np.ndarray,
    positions: np.ndarray,
    friction_deg: np.ndarray,
    cell_size_m: float,
    gamma: float,
    cohesion: float,
    settings: ScreenSettings,
    domain_length_m: float = math.inf,
) -> ScreenResult:
    """Minimum Bishop FS of a slope over circles sliding either way, and the critical circle.

    ``vertices`` [K, 2] is the counter-clockwise soil polygon on the floor, ``positions`` [N, 2] its
    material points with friction angles ``friction_deg`` [N]; ``gamma`` (N/m3) and ``cohesion`` (Pa)
    are uniform. Vertical edges at x = 0 and x = ``domain_length_m`` are walls, not free faces.
    """
    min_depth_m = cell_size_m if settings.min_depth_m is None else settings.min_depth_m
    tan_phi = np.tan(np.radians(friction_deg))
    result = ScreenResult(math.inf, (math.nan, math.nan), math.nan, math.nan, math.nan)
    for sign in (1.0, -1.0):  # slides towards +x, then towards -x in the mirrored frame
        origin = float(np.min(sign * vertices[:, 0]))  # the frame starts at the polygon's left end
        frame = vertices[:: int(sign)] * [sign, 1.0] - [origin, 0.0]
        walls_x = sign * np.array([0.0, domain_length_m]) - origin
        points = cKDTree(positions * [sign, 1.0] - [origin, 0.0])
        search = _Search(frame, walls_x, points, tan_phi, gamma, cohesion, min_depth_m, settings)
        fs, params = search.minimum()
        if fs < result.factor_of_safety:
            centre_x, centre_y, radius, entry_x, exit_x = (float(c[0]) for c in search.circles(params[None]))
            result = ScreenResult(
                fs, (sign * (centre_x + origin), centre_y), radius, sign * (entry_x + origin), sign * (exit_x + origin)
            )
    return result
