"""Run a batch of case directories that share a grid: time stepping, frames, early stop, divergence.

The time step follows the CFL condition dt = cfl · h / (c_p + |v|max), capped at ``dt_max_s`` and
shrunk so a whole number of steps fills each frame interval, per realization: each takes the steps its
own particles ask for, so its trajectory is the same alone and in any batch. A realization stops early once, at
every frame for ``early_stop_duration_s``, none of its particles has moved more than
``early_stop_displacement_m`` over the preceding ``early_stop_duration_s`` (net displacement:
particle kinetic energy is no test, FLIP noise keeps it up and even growing in a deposit at rest);
one that produces a non-finite state, moves a particle past a wall, the floor or the mesh edge
(out of the basis's region), or gains more than
``energy_growth_limit`` of its initial total energy is flagged as diverged. Either way it leaves
the batch (the tensors are compacted) and its remaining frames repeat its last state, so every
trajectory keeps the same length and the others go on. With ``keep="ends"`` only the first
and the last two frames are kept (what a Monte Carlo measurement reads); energies stay per frame.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from rgns.engines.mpm.backend import uses_kernels
from rgns.engines.mpm.frame_kernels import FrameKernels
from rgns.engines.mpm.mohr_coulomb import MohrCoulomb
from rgns.engines.mpm.shape import BASES, Basis, Region, RegularGrid
from rgns.engines.mpm.step import Boundary, Particles, substep
from rgns.scene.case import Case, CaseError
from rgns.trajectories import frame_count, kept_frames

log = logging.getLogger(__name__)


@dataclass
class EngineSettings:
    """Numerical settings of the embedded engine (config section ``mpm.embedded``)."""

    shape_function: str = "bspline"
    cfl: float = 0.2
    dt_max_s: float = 2.5e-3
    pic_blend: float = 0.0
    early_stop: bool = True
    early_stop_displacement_m: float = 0.01
    early_stop_duration_s: float = 0.5
    energy_growth_limit: float = 0.05
    friction_source: str = "exact"
    dtype: str = "float64"
    device: str = "cpu"
    backend: str = "auto"

    @classmethod
    def from_config(cls, section: dict[str, Any]) -> EngineSettings:
        return cls(**{key: section[key] for key in cls.__dataclass_fields__ if key in section})

    @property
    def kernels(self) -> bool:
        """Whether the compiled CPU kernels run the steps (backend numba, or auto on the CPU in float64)."""
        return uses_kernels(self.backend, self.device, self.dtype)


@dataclass
class RunResult:
    """One realization's frames and what happened to it."""

    positions: np.ndarray  # [T, N, 2] (keep "all") or [3, N, 2] (keep "ends")
    time_s: np.ndarray  # [T] or [3], the time of each stored frame
    energies: np.ndarray  # [T, 3]: kinetic, potential, elastic (J per metre width)
    status: str = "ok"  # "ok" or "diverged: <reason>"
    stopped_at_s: float | None = None
    final_stress: np.ndarray | None = None  # [N, 4] σxx σyy σzz τxy when it finished or stopped
    steps: int = 0
    wall_s: float = 0.0
    notes: list[str] = field(default_factory=list)


def grid_of(case: Case) -> RegularGrid:
    """The regular grid of a case's row-by-row ED2Q4 mesh."""
    nodes = case.nodes
    origin = nodes.min(axis=0)
    xs, ys = np.unique(nodes[:, 0]), np.unique(nodes[:, 1])
    h = float(xs[1] - xs[0])
    grid = RegularGrid((float(origin[0]), float(origin[1])), h, (len(xs) - 1, len(ys) - 1))
    expected = np.column_stack([np.tile(xs, len(ys)), np.repeat(ys, len(xs))])
    if abs(ys[1] - ys[0] - h) > 1e-9 * h or nodes.shape != expected.shape or not np.allclose(nodes, expected):
        raise CaseError(f"{case.source}: the embedded engine needs a regular grid of square cells numbered row by row")
    return grid


@dataclass(frozen=True)
class Walls:
    """The straight constrained lines of a case: (axis, side) → coordinate, side 0 lower, 1 upper; floor μ."""

    lines: dict[tuple[int, int], float]
    floor: tuple[float, float] | None  # (y, Coulomb μ) of the friction floor, if any


def walls_of(case: Case) -> Walls:
    """The zero-velocity walls and the friction floor of a case, from its node-set constraints."""
    nodes = case.nodes
    mesh = case.config["mesh"]["boundary_conditions"]

    def line(node_set: np.ndarray, axis: int) -> tuple[tuple[int, int], float]:
        wall = nodes[node_set, axis]
        if len(wall) == 0 or np.ptp(wall) > 1e-9:
            raise CaseError(f"{case.source}: a constrained node set is not a straight wall along axis {axis}")
        middle = 0.5 * (nodes[:, axis].min() + nodes[:, axis].max())
        return (axis, 0 if wall[0] < middle else 1), float(wall[0])

    lines: dict[tuple[int, int], float] = {}
    for constraint in mesh.get("velocity_constraints", []):
        if float(constraint["velocity"]) != 0.0:
            raise CaseError(f"{case.source}: only zero velocity constraints are supported")
        key, value = line(case.node_sets[int(constraint["nset_id"])], int(constraint["dir"]))
        lines[key] = value
    floor = None
    for constraint in mesh.get("friction_constraints", []):
        if int(constraint["dir"]) != 1 or int(constraint["sign_n"]) != -1:
            raise CaseError(f"{case.source}: only floor friction (dir 1, sign_n -1) is supported")
        key, value = line(case.node_sets[int(constraint["nset_id"])], 1)
        if key != (1, 0):
            raise CaseError(f"{case.source}: floor friction is supported on the bottom of the mesh only")
        floor = (value, float(constraint["friction"]))
    return Walls(lines, floor)


def region_of(grid: RegularGrid, walls: Walls) -> Region:
    """The cells between the walls and above the floor; the mesh edge where there is no wall."""
    lower, upper = [0, 0], list(grid.cells)
    for (axis, side), value in walls.lines.items():
        cell = int(round((value - grid.origin[axis]) / grid.h))
        if side == 0:
            lower[axis] = cell
        else:
            upper[axis] = cell
    return Region((lower[0], lower[1]), (upper[0], upper[1]))


def boundary_of(walls: Walls, basis: Basis, device: torch.device) -> Boundary:
    """Velocity and friction constraints of every DOF at or beyond a wall (padding nodes included)."""
    x, y = basis.dof_coordinates()
    coordinate = (x.numpy(), y.numpy())
    tolerance = 1e-9 * basis.grid.h
    fixed = [np.zeros(basis.n_nodes, dtype=bool), np.zeros(basis.n_nodes, dtype=bool)]
    for (axis, side), value in walls.lines.items():
        fixed[axis] |= coordinate[axis] <= value + tolerance if side == 0 else coordinate[axis] >= value - tolerance
    floor = np.zeros(basis.n_nodes, dtype=bool)
    friction = np.zeros(basis.n_nodes)
    if walls.floor is not None:
        floor = coordinate[1] <= walls.floor[0] + tolerance
        friction[floor] = walls.floor[1]
    return Boundary(
        torch.as_tensor(fixed[0], device=device),
        torch.as_tensor(fixed[1], device=device),
        torch.as_tensor(floor, device=device),
        torch.as_tensor(friction, device=device),
    )


def basis_of(case: Case, shape_function: str, device: torch.device) -> tuple[Basis, Boundary]:
    """The shape functions of a case (on the region between its walls) and their constraints."""
    grid = grid_of(case)
    walls = walls_of(case)
    try:
        basis = BASES[shape_function](grid, region_of(grid, walls))
    except ValueError as error:
        raise CaseError(f"{case.source}: {error}") from error
    return basis, boundary_of(walls, basis, device)


def particles_of(cases: list[Case], settings: EngineSettings, device: torch.device) -> Particles:
    """The flat particle state of a batch of cases at rest, with their initial stresses."""
    dtype = getattr(torch, settings.dtype)

    def cat(arrays: list[np.ndarray]) -> torch.Tensor:
        return torch.as_tensor(np.concatenate(arrays), dtype=dtype, device=device)

    per_material: dict[str, list[np.ndarray]] = {
        k: [] for k in ("youngs_modulus", "poisson_ratio", "dilation", "cohesion", "tension_cutoff")
    }
    friction, stresses = [], []
    for case in cases:
        materials = case.materials
        for key, values in per_material.items():
            values.append(np.array([materials[int(k)][key] for k in case.material_id], dtype=float))
        friction.append(case.friction_deg if settings.friction_source == "exact" else case.binned_friction_deg)
        stresses.append(
            case.stresses[:, [0, 1, 2, 3]] if case.stresses is not None else np.zeros((len(case.positions), 4))
        )
    volume = cat([case.volumes for case in cases])
    material = MohrCoulomb.from_parameters(
        cat(per_material["youngs_modulus"]),
        cat(per_material["poisson_ratio"]),
        cat(friction),
        cat(per_material["dilation"]),
        cat(per_material["cohesion"]),
        cat(per_material["tension_cutoff"]),
        volume,
    )
    batch = torch.cat(
        [torch.full((len(case.positions),), b, dtype=torch.long, device=device) for b, case in enumerate(cases)]
    )
    position = cat([case.positions for case in cases])
    stress = cat(stresses)
    return Particles(
        x=position[:, 0].contiguous(),
        y=position[:, 1].contiguous(),
        vx=torch.zeros_like(volume),
        vy=torch.zeros_like(volume),
        mass=volume * cat([case.density_kg_m3 for case in cases]),
        volume=volume,
        sxx=stress[:, 0].contiguous(),
        syy=stress[:, 1].contiguous(),
        szz=stress[:, 2].contiguous(),
        txy=stress[:, 3].contiguous(),
        batch=batch,
        material=material,
    )


def energies(particles: Particles, gravity: float, batches: int) -> torch.Tensor:
    """Kinetic, potential (from y = 0) and elastic energy per realization [B, 3]."""
    m = particles.material
    sxx, syy, szz, txy = particles.sxx, particles.syy, particles.szz, particles.txy
    e = m.shear_modulus * (3 * m.lame_lambda + 2 * m.shear_modulus) / (m.lame_lambda + m.shear_modulus)
    nu = m.lame_lambda / (2 * (m.lame_lambda + m.shear_modulus))
    density = (sxx**2 + syy**2 + szz**2 - 2 * nu * (sxx * syy + syy * szz + szz * sxx)) / (2 * e) + txy**2 / (
        2 * m.shear_modulus
    )
    per_particle = torch.stack(
        [
            0.5 * particles.mass * (particles.vx**2 + particles.vy**2),
            particles.mass * gravity * particles.y,
            density * particles.volume,
        ],
        dim=1,
    )
    return torch.zeros((batches, 3), dtype=per_particle.dtype, device=per_particle.device).index_add_(
        0, particles.batch, per_particle
    )


def per_realization_max(values: torch.Tensor, batch: torch.Tensor, batches: int) -> list[float]:
    """The largest of non-negative per-particle ``values`` in each realization of a batch."""
    largest = torch.zeros(batches, dtype=values.dtype, device=values.device)
    return largest.scatter_reduce(0, batch, values, "amax").tolist()


def summary(particles: Particles, gravity: float, batches: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per realization: kinetic, potential and elastic energy [B, 3], particles with a non-finite position or
    velocity [B], the largest particle speed [B] (the torch engine's; FrameKernels.summary the kernels')."""
    finite = (
        torch.isfinite(particles.x)
        & torch.isfinite(particles.y)
        & torch.isfinite(particles.vx)
        & torch.isfinite(particles.vy)
    )
    non_finite = torch.zeros(batches, dtype=torch.long, device=finite.device).index_add_(
        0, particles.batch, (~finite).long()
    )
    speed = per_realization_max(torch.sqrt(particles.vx**2 + particles.vy**2), particles.batch, batches)
    return energies(particles, gravity, batches).cpu().numpy(), non_finite.cpu().numpy(), np.array(speed)


def host_state(particles: Particles, kernels: FrameKernels | None) -> tuple[np.ndarray, np.ndarray]:
    """Positions [P, 2] (float32) and stresses [P, 4] on the host."""
    if kernels is not None:
        x, y, *_, sxx, syy, szz, txy = kernels.views(particles)[:10]
        return np.stack([x, y], 1).astype(np.float32), np.stack([sxx, syy, szz, txy], 1)
    positions = torch.stack([particles.x, particles.y], 1).cpu().numpy().astype(np.float32)
    return positions, torch.stack([particles.sxx, particles.syy, particles.szz, particles.txy], 1).cpu().numpy()


def frame_substeps(settings: EngineSettings, h: float, wave_speed: float, speed: float, frame_interval_s: float) -> int:
    """Steps of one realization over a frame: its CFL step cfl · h / (c_p + |v|max), capped at dt_max_s, fitted
    a whole number of times into the frame. Each realization's own: a batch's realizations do not share a step."""
    dt_cfl = settings.cfl * h / (wave_speed + speed)
    return max(1, math.ceil(frame_interval_s / min(dt_cfl, settings.dt_max_s) - 1e-9))


def _advance_torch(
    particles: Particles,
    basis: Basis,
    repeated: Boundary,
    gravity: tuple[float, float],
    substeps: list[int],
    dt: list[float],
    pic_blend: float,
    damping: float,
) -> torch.Tensor:
    """One frame of the torch engine: realization b takes substeps[b] steps of dt[b]; particle steps out of the region
    per realization [B]."""
    device, dtype = particles.x.device, particles.x.dtype
    outside_region = torch.zeros(len(substeps), dtype=torch.long, device=device)
    for k in range(max(substeps)):
        step_dt = torch.tensor([d if k < n else 0.0 for d, n in zip(dt, substeps)], dtype=dtype, device=device)
        weights = basis(particles.x, particles.y)
        if not bool(weights.inside.all()):
            outside_region.index_add_(0, particles.batch, (~weights.inside).long())
        substep(particles, weights, basis.n_nodes, repeated, gravity, len(substeps), step_dt, pic_blend, damping)
    return outside_region


def run_batch(
    cases: list[Case],
    settings: EngineSettings,
    duration_s: float | None = None,
    frame_interval_s: float | None = None,
    initial_velocity: list[np.ndarray] | None = None,
    keep: str = "all",
) -> list[RunResult]:
    """Simulate every case (same grid and constraints) to ``duration_s``; one result per case.

    ``duration_s`` and ``frame_interval_s`` default to the case's; ``initial_velocity`` gives
    each case's particles a starting velocity [N, 2] (they start at rest otherwise); ``keep`` is
    "all" frames or the "ends" (first and last two).
    """
    start_wall = time.perf_counter()
    device = torch.device(settings.device)
    basis, boundary = basis_of(cases[0], settings.shape_function, device)
    grid = basis.grid
    for case in cases[1:]:
        if not np.array_equal(case.nodes, cases[0].nodes):
            raise CaseError(f"{case.source}: a batch needs one grid; it differs from {cases[0].source}")
    gravity_vector = cases[0].config["external_loading_conditions"]["gravity"]
    dtype = getattr(torch, settings.dtype)
    gravity = (float(gravity_vector[0]), float(gravity_vector[1]))
    damping = float(cases[0].config["analysis"].get("damping", {}).get("damping_factor", 0.0))
    g = abs(gravity[1])
    frame_interval_s = frame_interval_s or cases[0].frame_interval_s
    duration_s = duration_s or cases[0].duration_s
    n_frames = frame_count(duration_s, frame_interval_s)
    kept = kept_frames(keep, n_frames)

    particles = particles_of(cases, settings, device)
    kernels = FrameKernels(basis, boundary, gravity, damping, settings.pic_blend) if settings.kernels else None
    if initial_velocity is not None:
        start = torch.as_tensor(np.concatenate(initial_velocity), dtype=dtype, device=device)
        particles.vx, particles.vy = start[:, 0].contiguous(), start[:, 1].contiguous()
    counts = [len(case.positions) for case in cases]
    live = list(range(len(cases)))  # case index of each batch slot
    frames = [[case.positions.astype(np.float32)] for case in cases]
    history: list[list[np.ndarray]] = [[] for _ in cases]
    results: list[RunResult | None] = [None] * len(cases)
    last_stress: list[np.ndarray | None] = [None] * len(cases)

    def summarize(batches: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return kernels.summary(particles, g) if kernels is not None else summary(particles, g, batches)

    initial, _, speeds = summarize(len(cases))
    for b in range(len(cases)):
        history[b].append(initial[b])
    window = max(1, int(round(settings.early_stop_duration_s / frame_interval_s)))
    recent = [[case.positions.astype(np.float32)] for case in cases]  # the last window + 1 frames
    quiet = np.zeros(len(cases))
    initial_total = initial.sum(1)
    wave_speed = per_realization_max(
        torch.sqrt(particles.material.p_wave_modulus * particles.volume / particles.mass), particles.batch, len(cases)
    )
    steps = [0] * len(cases)
    for frame in range(1, n_frames):
        substeps = [
            frame_substeps(settings, grid.h, wave_speed[c], float(speed), frame_interval_s)
            for c, speed in zip(live, speeds)
        ]
        dt = [frame_interval_s / n for n in substeps]
        if kernels is not None:
            outside_region = kernels.advance(particles, substeps, dt)
        else:
            outside_region = (
                _advance_torch(
                    particles, basis, boundary.repeat(len(live)), gravity, substeps, dt, settings.pic_blend, damping
                )
                .cpu()
                .numpy()
            )
        for c, n in zip(live, substeps):
            steps[c] += n
        now = frame * frame_interval_s
        energy_np, finite, speeds = summarize(len(live))
        positions, stress = host_state(particles, kernels)
        boundaries = np.cumsum([counts[c] for c in live])[:-1]
        split, stress_split = np.split(positions, boundaries), np.split(stress, boundaries)
        going_on = np.ones(len(live), dtype=bool)
        for slot, case_index in enumerate(live):
            frames[case_index].append(split[slot])
            if keep == "ends" and len(frames[case_index]) > 3:
                del frames[case_index][1]
            history[case_index].append(energy_np[slot])
            reason = None
            if finite[slot] > 0 or not np.isfinite(energy_np[slot]).all():
                reason = f"non-finite particle state at t = {now:.3f} s"
            elif outside_region[slot] > 0:
                reason = (
                    f"{int(outside_region[slot])} particle step(s) past a wall, the floor or the mesh edge "
                    f"by t = {now:.3f} s"
                )
            elif energy_np[slot].sum() > float(initial_total[case_index]) * (1 + settings.energy_growth_limit):
                growth = energy_np[slot].sum() / float(initial_total[case_index]) - 1
                reason = f"total energy grew {growth:.1%} by t = {now:.3f} s (limit {settings.energy_growth_limit:.0%})"
            if reason:
                frames[case_index][-1] = frames[case_index][-2]
                results[case_index] = RunResult(np.empty(0), np.empty(0), np.empty(0), status=f"diverged: {reason}")
                going_on[slot] = False
                continue
            recent[case_index] = (recent[case_index] + [split[slot]])[-(window + 1) :]
            moved = np.sqrt(((split[slot] - recent[case_index][0]) ** 2).sum(1).max())
            at_rest = len(recent[case_index]) > window and moved < settings.early_stop_displacement_m
            quiet[case_index] = quiet[case_index] + frame_interval_s if at_rest else 0.0
            last_stress[case_index] = stress_split[slot]
            if settings.early_stop and quiet[case_index] >= settings.early_stop_duration_s - 1e-9:
                results[case_index] = RunResult(np.empty(0), np.empty(0), np.empty(0), stopped_at_s=now)
                going_on[slot] = False
        if not going_on.all():
            keeping = torch.as_tensor(going_on, device=device)
            particles = particles.subset(keeping[particles.batch], torch.cumsum(keeping.long(), 0) - 1)
            live, speeds = [c for slot, c in enumerate(live) if going_on[slot]], speeds[going_on]
        if frame % 40 == 0 or not live:
            log.info(
                "t = %.2f s: %d of %d realizations running, dt = %.2e s (%d steps so far)",
                now,
                len(live),
                len(cases),
                min(dt),
                max(steps),
            )
        if not live:
            break
    wall = time.perf_counter() - start_wall
    time_s = np.arange(n_frames) * frame_interval_s
    out = []
    for case_index in range(len(cases)):
        result = results[case_index] or RunResult(np.empty(0), np.empty(0), np.empty(0))
        stored, energy_rows = frames[case_index], history[case_index]
        ran_to_end = len(energy_rows) == n_frames  # one energy row per frame simulated
        energy_rows += [energy_rows[-1]] * (n_frames - len(energy_rows))
        if keep == "all":
            stored += [stored[-1]] * (n_frames - len(stored))
        elif not ran_to_end:
            stored = [stored[0], stored[-1], stored[-1]]
        result.positions, result.time_s, result.energies = np.stack(stored), time_s[kept], np.stack(energy_rows)
        result.steps, result.wall_s, result.final_stress = steps[case_index], wall, last_stress[case_index]
        out.append(result)
    return out
