"""One explicit MPM step (update stress first), batched over realizations.

All particles of all realizations live in flat tensors with a ``batch`` index; the grid holds
one copy of every node per realization, so node ``n`` of realization ``b`` is ``b·Nn + n`` and
realizations never touch each other. The step reads like CB-Geo's USF scheme:

1. ``p2g``: nodal mass and momentum from the particles, nodal velocity, velocity constraints;
2. ``stress_update``: strain increment from the nodal velocities, Mohr-Coulomb stress, volume;
3. ``grid_update``: internal and gravity forces, acceleration, Coulomb floor friction,
   velocity constraints, new nodal velocity;
4. ``g2p``: FLIP velocity update (optionally blended with a little PIC), positions moved with
   the new nodal velocities.
"""
from __future__ import annotations

from dataclasses import dataclass

import torch

from rgns.mpm.mohr_coulomb import MohrCoulomb, elastic_increment, return_map
from rgns.mpm.shape import RegularGrid, Weights

MASS_TOLERANCE = 1e-15  # as CB-Geo: nodes lighter than this carry no velocity


@dataclass
class Boundary:
    """Nodal constraints shared by every realization of a batch (one grid, one case layout)."""

    fixed: torch.Tensor  # [Nn, 2] bool: velocity component held at zero
    friction: torch.Tensor  # [Nn] Coulomb μ of the floor (0 where none)
    floor: torch.Tensor  # [Nn] bool: node carries the floor friction (normal +y, sign −1)


@dataclass
class Particles:
    """The batched particle state; every tensor is [P, ...] over all realizations."""

    position: torch.Tensor  # [P, 2]
    velocity: torch.Tensor  # [P, 2]
    mass: torch.Tensor  # [P]
    volume: torch.Tensor  # [P]
    stress: torch.Tensor  # [P, 4] σxx σyy σzz τxy
    batch: torch.Tensor  # [P] realization of each particle, 0..B-1
    material: MohrCoulomb


@dataclass
class Nodal:
    """Per-step grid quantities [B·Nn, ...]."""

    flat: torch.Tensor  # [P, K] flat node ids of each particle's support
    mass: torch.Tensor
    velocity: torch.Tensor
    active: torch.Tensor


def _scatter(flat: torch.Tensor, values: torch.Tensor, size: int) -> torch.Tensor:
    """Sum per-particle-per-node values [P, K, ...] into nodes [size, ...]."""
    out = torch.zeros((size, *values.shape[2:]), dtype=values.dtype, device=values.device)
    return out.index_add_(0, flat.reshape(-1), values.reshape(-1, *values.shape[2:]))


def _constrain(vectors: torch.Tensor, fixed: torch.Tensor, batches: int) -> torch.Tensor:
    return vectors.masked_fill(fixed.repeat(batches, 1), 0.0)


def p2g(particles: Particles, weights: Weights, grid: RegularGrid, boundary: Boundary, batches: int) -> Nodal:
    """Nodal mass and velocity (momentum / mass) with the velocity constraints applied."""
    size = batches * grid.n_nodes
    flat = particles.batch[:, None] * grid.n_nodes + weights.nodes
    mass = _scatter(flat, weights.value * particles.mass[:, None], size)
    momentum = _scatter(flat, weights.value[..., None] * (particles.mass[:, None] * particles.velocity)[:, None, :], size)
    active = mass > MASS_TOLERANCE
    velocity = torch.where(active[:, None], momentum / mass.clamp_min(MASS_TOLERANCE)[:, None], 0.0)
    return Nodal(flat, mass, _constrain(velocity, boundary.fixed, batches), active)


def stress_update(particles: Particles, weights: Weights, nodal: Nodal, dt: float) -> torch.Tensor:
    """Update stresses and volumes from the nodal velocities; returns the yielding mask [P]."""
    velocity = nodal.velocity[nodal.flat]  # [P, K, 2]
    gradient = torch.einsum("pka,pkb->pab", velocity, weights.grad)  # ∂v_a/∂x_b
    strain = dt * torch.stack([gradient[:, 0, 0], gradient[:, 1, 1], gradient[:, 0, 1] + gradient[:, 1, 0]], dim=1)
    trial = particles.stress + elastic_increment(strain, particles.material)
    particles.stress, yielded = return_map(trial, particles.material)
    particles.volume = particles.volume * (1.0 + strain[:, 0] + strain[:, 1])
    return yielded


def _floor_friction(acceleration: torch.Tensor, velocity: torch.Tensor, boundary: Boundary, batches: int,
                    dt: float) -> torch.Tensor:
    """CB-Geo's Coulomb friction on floor nodes pushed into the floor (normal y, sign −1)."""
    floor = boundary.floor.repeat(batches)
    mu = boundary.friction.repeat(batches)
    acc_n, acc_t, vel_t = acceleration[:, 1], acceleration[:, 0], velocity[:, 0]
    pushing = floor & (acc_n < 0)
    limit = mu * acc_n.abs()
    vel_net = vel_t + dt * acc_t
    kinetic = torch.where(vel_net.abs() <= limit * dt, -vel_t / dt, acc_t - torch.sign(vel_net) * limit)
    static = torch.where(acc_t.abs() <= limit, torch.zeros_like(acc_t), acc_t - torch.sign(acc_t) * limit)
    friction_t = torch.where(vel_t != 0, kinetic, static)
    return torch.stack([torch.where(pushing, friction_t, acc_t), acc_n], dim=1)


def grid_update(particles: Particles, weights: Weights, nodal: Nodal, gravity: torch.Tensor, boundary: Boundary,
                batches: int, dt: float) -> tuple[torch.Tensor, torch.Tensor]:
    """Nodal acceleration and new velocity from internal and gravity forces, friction, constraints."""
    sxx, syy, _, txy = particles.stress.unbind(1)
    traction = torch.stack([torch.stack([sxx, txy], 1), torch.stack([txy, syy], 1)], 1)  # [P, 2, 2]
    internal = -particles.volume[:, None, None] * torch.einsum("pab,pkb->pka", traction, weights.grad)
    external = (weights.value * particles.mass[:, None])[..., None] * gravity
    force = _scatter(nodal.flat, internal + external, nodal.mass.shape[0])
    acceleration = torch.where(nodal.active[:, None], force / nodal.mass.clamp_min(MASS_TOLERANCE)[:, None], 0.0)
    acceleration = _floor_friction(acceleration, nodal.velocity, boundary, batches, dt)
    acceleration = _constrain(acceleration, boundary.fixed, batches)
    velocity = _constrain(nodal.velocity + dt * acceleration, boundary.fixed, batches)
    return acceleration, velocity


def g2p(particles: Particles, weights: Weights, nodal: Nodal, acceleration: torch.Tensor, velocity: torch.Tensor,
        dt: float, pic_blend: float) -> None:
    """FLIP velocity update, optionally blended with PIC; positions move with nodal velocities."""
    w = weights.value[..., None]
    particle_acceleration = (w * acceleration[nodal.flat]).sum(1)
    particle_velocity = (w * velocity[nodal.flat]).sum(1)
    flip = particles.velocity + dt * particle_acceleration
    particles.velocity = flip if pic_blend == 0.0 else (1 - pic_blend) * flip + pic_blend * particle_velocity
    particles.position = particles.position + dt * particle_velocity


def substep(particles: Particles, weights: Weights, grid: RegularGrid, boundary: Boundary, gravity: torch.Tensor,
            batches: int, dt: float, pic_blend: float) -> torch.Tensor:
    """Advance every realization by ``dt``; returns the yielding mask [P]."""
    nodal = p2g(particles, weights, grid, boundary, batches)
    yielded = stress_update(particles, weights, nodal, dt)
    acceleration, velocity = grid_update(particles, weights, nodal, gravity, boundary, batches, dt)
    g2p(particles, weights, nodal, acceleration, velocity, dt, pic_blend)
    return yielded
