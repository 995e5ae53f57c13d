"""One explicit MPM step (update stress first), batched over realizations.

All particles of all realizations live in flat [P] tensors with a ``batch`` index; the grid holds
one copy of every node per realization, so node ``n`` of realization ``b`` is ``b·Nn + n`` and
realizations never touch each other. Vectors are kept as separate x and y tensors (contiguous
memory is several times faster on a CPU than small trailing dimensions). The step reads like
CB-Geo's USF scheme:

1. ``p2g``: nodal mass and momentum from the particles, nodal velocity, velocity constraints;
2. ``stress_update``: strain increment from the nodal velocities, Mohr-Coulomb stress, volume;
3. ``grid_update``: internal and gravity forces, acceleration, Coulomb floor friction,
   velocity constraints, new nodal velocity;
4. ``g2p``: FLIP velocity update (optionally blended with a little PIC), positions moved with
   the new nodal velocities.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import torch

from rgns.engines.mpm.mohr_coulomb import MohrCoulomb, elastic_increment, return_map
from rgns.engines.mpm.shape import Weights

MASS_TOLERANCE = 1e-15  # as CB-Geo: nodes lighter than this carry no velocity


@dataclass
class Boundary:
    """Nodal constraints shared by every realization of a batch (one grid, one case layout), [Nn]."""

    fixed_x: torch.Tensor  # bool: x velocity held at zero (walls)
    fixed_y: torch.Tensor  # bool: y velocity held at zero (floor)
    floor: torch.Tensor  # bool: node carries the floor friction (normal +y, pushed when a_y < 0)
    friction: torch.Tensor  # Coulomb μ of the floor (0 where none)

    def repeat(self, batches: int) -> Boundary:
        """The constraints of every node copy of a batch, [B·Nn]."""
        return Boundary(*(getattr(self, f.name).repeat(batches) for f in fields(self)))


@dataclass
class Particles:
    """The batched particle state; every tensor is [P] over all realizations."""

    x: torch.Tensor
    y: torch.Tensor
    vx: torch.Tensor
    vy: torch.Tensor
    mass: torch.Tensor
    volume: torch.Tensor
    sxx: torch.Tensor
    syy: torch.Tensor
    szz: torch.Tensor
    txy: torch.Tensor
    batch: torch.Tensor  # realization of each particle, 0..B-1
    material: MohrCoulomb

    def subset(self, mask: torch.Tensor, new_batch: torch.Tensor) -> Particles:
        """The particles under ``mask``, with batch ids mapped through ``new_batch``."""
        values = {f.name: getattr(self, f.name)[mask] for f in fields(self) if f.name not in ("batch", "material")}
        return Particles(**values, batch=new_batch[self.batch[mask]], material=self.material.subset(mask))


@dataclass
class Nodal:
    """Per-step grid quantities [B·Nn] and each particle's flat node ids [K, P]."""

    flat: torch.Tensor
    mass: torch.Tensor
    vx: torch.Tensor
    vy: torch.Tensor
    active: torch.Tensor


def _scatter(flat: torch.Tensor, values: torch.Tensor, size: int) -> torch.Tensor:
    """Sum per-slot values [K, P] into nodes [size]."""
    return torch.zeros(size, dtype=values.dtype, device=values.device).scatter_add_(
        0, flat.reshape(-1), values.reshape(-1)
    )


def _gather(nodal: torch.Tensor, flat: torch.Tensor) -> torch.Tensor:
    return torch.take(nodal, flat)


def p2g(particles: Particles, weights: Weights, n_nodes: int, boundary: Boundary, batches: int) -> Nodal:
    """Nodal mass and velocity (momentum / mass) of ``n_nodes`` DOFs per realization, constraints applied."""
    size = batches * n_nodes
    flat = particles.batch * n_nodes + weights.nodes
    weighted_mass = weights.value * particles.mass
    mass = _scatter(flat, weighted_mass, size)
    active = mass > MASS_TOLERANCE
    inverse = torch.where(active, 1.0 / mass.clamp_min(MASS_TOLERANCE), 0.0)
    vx = _scatter(flat, weighted_mass * particles.vx, size) * inverse
    vy = _scatter(flat, weighted_mass * particles.vy, size) * inverse
    return Nodal(flat, mass, vx.masked_fill(boundary.fixed_x, 0.0), vy.masked_fill(boundary.fixed_y, 0.0), active)


def stress_update(particles: Particles, weights: Weights, nodal: Nodal, dt: torch.Tensor) -> torch.Tensor:
    """Update stresses and volumes from the nodal velocities; returns the yielding mask [P]."""
    vx, vy = _gather(nodal.vx, nodal.flat), _gather(nodal.vy, nodal.flat)
    dxx = dt * (vx * weights.grad_x).sum(0)
    dyy = dt * (vy * weights.grad_y).sum(0)
    dxy = dt * ((vx * weights.grad_y).sum(0) + (vy * weights.grad_x).sum(0))
    increment = elastic_increment(dxx, dyy, dxy, particles.material)
    trial = (
        particles.sxx + increment[0],
        particles.syy + increment[1],
        particles.szz + increment[2],
        particles.txy + increment[3],
    )
    (particles.sxx, particles.syy, particles.szz, particles.txy), yielded = return_map(*trial, particles.material)
    particles.volume = particles.volume * (1.0 + dxx + dyy)
    return yielded


def _floor_friction(
    ax: torch.Tensor, ay: torch.Tensor, vx: torch.Tensor, boundary: Boundary, dt: torch.Tensor
) -> torch.Tensor:
    """CB-Geo's Coulomb friction on floor nodes pushed into the floor: the new x acceleration."""
    pushing = boundary.floor & (ay < 0)
    limit = boundary.friction * ay.abs()
    moving = vx + dt * ax
    kinetic = torch.where(moving.abs() <= limit * dt, -vx / dt, ax - torch.sign(moving) * limit)
    static = torch.where(ax.abs() <= limit, torch.zeros_like(ax), ax - torch.sign(ax) * limit)
    return torch.where(pushing, torch.where(vx != 0, kinetic, static), ax)


def grid_update(
    particles: Particles,
    weights: Weights,
    nodal: Nodal,
    gravity: tuple[float, float],
    boundary: Boundary,
    dt: torch.Tensor,
    damping: float = 0.0,
) -> tuple[torch.Tensor, ...]:
    """Nodal acceleration and new velocity (x and y) from internal and gravity forces, friction, constraints.

    ``damping`` is CB-Geo's Cundall factor α: the unbalanced force f becomes f − α·|f|·sign(v).
    """
    size = nodal.mass.shape[0]
    v = particles.volume
    weighted_mass = weights.value * particles.mass
    fx = -v * (particles.sxx * weights.grad_x + particles.txy * weights.grad_y) + weighted_mass * gravity[0]
    fy = -v * (particles.txy * weights.grad_x + particles.syy * weights.grad_y) + weighted_mass * gravity[1]
    inverse = torch.where(nodal.active, 1.0 / nodal.mass.clamp_min(MASS_TOLERANCE), 0.0)
    force_x, force_y = _scatter(nodal.flat, fx, size), _scatter(nodal.flat, fy, size)
    if damping:
        magnitude = damping * torch.sqrt(force_x**2 + force_y**2)
        force_x, force_y = force_x - magnitude * torch.sign(nodal.vx), force_y - magnitude * torch.sign(nodal.vy)
    ax, ay = force_x * inverse, force_y * inverse
    ax = _floor_friction(ax, ay, nodal.vx, boundary, dt).masked_fill(boundary.fixed_x, 0.0)
    ay = ay.masked_fill(boundary.fixed_y, 0.0)
    return (
        ax,
        ay,
        (nodal.vx + dt * ax).masked_fill(boundary.fixed_x, 0.0),
        (nodal.vy + dt * ay).masked_fill(boundary.fixed_y, 0.0),
    )


def g2p(
    particles: Particles, weights: Weights, nodal: Nodal, nodal_update: tuple, dt: torch.Tensor, pic_blend: float
) -> None:
    """FLIP velocity update, optionally blended with PIC; positions move with nodal velocities."""
    ax, ay, vx, vy = (_gather(values, nodal.flat) for values in nodal_update)
    w = weights.value
    flip_x = particles.vx + dt * (w * ax).sum(0)
    flip_y = particles.vy + dt * (w * ay).sum(0)
    pic_x, pic_y = (w * vx).sum(0), (w * vy).sum(0)
    if pic_blend:
        flip_x, flip_y = (1 - pic_blend) * flip_x + pic_blend * pic_x, (1 - pic_blend) * flip_y + pic_blend * pic_y
    particles.vx, particles.vy = flip_x, flip_y
    particles.x, particles.y = particles.x + dt * pic_x, particles.y + dt * pic_y


def substep(
    particles: Particles,
    weights: Weights,
    n_nodes: int,
    boundary: Boundary,
    gravity: tuple[float, float],
    batches: int,
    dt: torch.Tensor,
    pic_blend: float,
    damping: float = 0.0,
) -> torch.Tensor:
    """Advance realization b by ``dt[b]`` (``boundary`` already repeated per batch); returns yielding.

    Each realization has its own step, so its trajectory does not depend on the batch it runs in; one
    with ``dt[b] = 0`` (it has taken its steps of the frame while others go on) is left exactly as it was.
    """
    particle_dt, node_dt = dt[particles.batch], dt.repeat_interleave(n_nodes)
    waiting = particle_dt == 0
    before = (particles.vx, particles.vy, particles.sxx, particles.syy, particles.szz, particles.txy)
    nodal = p2g(particles, weights, n_nodes, boundary, batches)
    yielded = stress_update(particles, weights, nodal, particle_dt)
    update = grid_update(particles, weights, nodal, gravity, boundary, node_dt, damping)
    g2p(particles, weights, nodal, update, particle_dt, pic_blend)
    if bool(waiting.any()):
        names = ("vx", "vy", "sxx", "syy", "szz", "txy")
        for name, old in zip(names, before):
            setattr(particles, name, torch.where(waiting, old, getattr(particles, name)))
        yielded = yielded & ~waiting
    return yielded
