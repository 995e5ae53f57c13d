"""Mohr-Coulomb elasto-plasticity in plane strain, equivalent to CB-Geo's ``MohrCoulomb2D``
without softening: friction φ, dilation ψ, cohesion c, tension cutoff T. Tension positive.

Stresses are [P, 4] tensors (σxx, σyy, σzz, τxy). The return mapping works in principal stresses
(σ1 ≥ σ2 ≥ σ3, with σzz one of them) against

    f = σ1 (1 + sin φ) − σ3 (1 − sin φ) − 2 c cos φ ≤ 0,       g = σ1 (1 + sin ψ) − σ3 (1 − sin ψ)

first to the main plane; if that breaks the principal order, to the edge it crossed (two planes
active, a 2 × 2 solve); if that fails too, to the apex. The plastic flow is D·∂g/∂σ, so the
correction is exact for linear elasticity (Clausen et al. 2006, non-associated). A tension cutoff
finally caps every principal stress at T.
"""
from __future__ import annotations

from dataclasses import dataclass

import torch


@dataclass
class MohrCoulomb:
    """Per-particle material constants [P] (SI units, angles in radians)."""

    shear_modulus: torch.Tensor
    lame_lambda: torch.Tensor
    sin_phi: torch.Tensor
    sin_psi: torch.Tensor
    cohesion: torch.Tensor
    tension_cutoff: torch.Tensor

    @classmethod
    def from_parameters(cls, youngs_modulus, poisson_ratio, friction_deg, dilation_deg, cohesion, tension_cutoff,
                        like: torch.Tensor) -> "MohrCoulomb":
        """Build from scalars or [P] arrays, as tensors shaped and typed like ``like`` [P]."""
        def tensor(value):
            return torch.as_tensor(value, dtype=like.dtype, device=like.device).expand_as(like).clone()

        e, nu = tensor(youngs_modulus), tensor(poisson_ratio)
        return cls(
            shear_modulus=e / (2 * (1 + nu)),
            lame_lambda=e * nu / ((1 + nu) * (1 - 2 * nu)),
            sin_phi=torch.sin(torch.deg2rad(tensor(friction_deg))),
            sin_psi=torch.sin(torch.deg2rad(tensor(dilation_deg))),
            cohesion=tensor(cohesion),
            tension_cutoff=tensor(tension_cutoff),
        )

    @property
    def p_wave_modulus(self) -> torch.Tensor:
        return self.lame_lambda + 2 * self.shear_modulus


def elastic_increment(strain_increment: torch.Tensor, material: MohrCoulomb) -> torch.Tensor:
    """Stress increment [P, 4] of a plane-strain increment (dεxx, dεyy, dγxy) [P, 3]."""
    lam, g = material.lame_lambda, material.shear_modulus
    volumetric = strain_increment[:, 0] + strain_increment[:, 1]
    return torch.stack([
        lam * volumetric + 2 * g * strain_increment[:, 0],
        lam * volumetric + 2 * g * strain_increment[:, 1],
        lam * volumetric,
        g * strain_increment[:, 2],
    ], dim=1)


def _principal_return(sigma: torch.Tensor, material: MohrCoulomb) -> torch.Tensor:
    """Return sorted principal stresses [P, 3] (σ1 ≥ σ2 ≥ σ3) onto the Mohr-Coulomb surface."""
    sin_phi, sin_psi = material.sin_phi, material.sin_psi
    k = (1 + sin_phi) / (1 - sin_phi)
    m = (1 + sin_psi) / (1 - sin_psi)
    sigma_c = 2 * material.cohesion * torch.sqrt(1 - sin_phi ** 2) / (1 - sin_phi)
    lam, g = material.lame_lambda[:, None], material.shear_modulus[:, None]
    zero, one = torch.zeros_like(k), torch.ones_like(k)

    def d_times(b: torch.Tensor) -> torch.Tensor:  # isotropic stiffness in principal space
        return lam * b.sum(dim=1, keepdim=True) + 2 * g * b

    # plane 1 (main): k σ1 − σ3; plane 2 (σ1 = σ2 edge): k σ2 − σ3; plane 3 (σ2 = σ3 edge): k σ1 − σ2
    a1, b1 = torch.stack([k, zero, -one], 1), torch.stack([m, zero, -one], 1)
    a2, b2 = torch.stack([zero, k, -one], 1), torch.stack([zero, m, -one], 1)
    a3, b3 = torch.stack([k, -one, zero], 1), torch.stack([m, -one, zero], 1)
    f1 = (a1 * sigma).sum(1) - sigma_c
    db1 = d_times(b1)
    main = sigma - (f1 / (a1 * db1).sum(1))[:, None] * db1

    def edge(a_other: torch.Tensor, b_other: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        db_other = d_times(b_other)
        f_other = (a_other * sigma).sum(1) - sigma_c
        m11, m12 = (a1 * db1).sum(1), (a1 * db_other).sum(1)
        m21, m22 = (a_other * db1).sum(1), (a_other * db_other).sum(1)
        det = m11 * m22 - m12 * m21
        l1 = (m22 * f1 - m12 * f_other) / det
        l2 = (m11 * f_other - m21 * f1) / det
        return sigma - l1[:, None] * db1 - l2[:, None] * db_other, (l1 >= 0) & (l2 >= 0)

    edge2, valid2 = edge(a2, b2)
    edge3, valid3 = edge(a3, b3)
    apex = (sigma_c / (k - 1))[:, None].expand(-1, 3)

    on_main = (main[:, 0] >= main[:, 1]) & (main[:, 1] >= main[:, 2])
    to_edge2 = ~on_main & (main[:, 1] > main[:, 0]) & valid2 & (edge2[:, 0] >= edge2[:, 2]) & (edge2.sum(1) <= apex.sum(1))
    to_edge3 = ~on_main & ~to_edge2 & (main[:, 2] > main[:, 1]) & valid3 & (edge3[:, 0] >= edge3[:, 2]) & (edge3.sum(1) <= apex.sum(1))
    returned = torch.where(on_main[:, None], main, apex)
    returned = torch.where(to_edge2[:, None], edge2, returned)
    returned = torch.where(to_edge3[:, None], edge3, returned)
    return torch.where((f1 > 0)[:, None], returned, sigma)


def return_map(trial: torch.Tensor, material: MohrCoulomb) -> tuple[torch.Tensor, torch.Tensor]:
    """Admissible stresses [P, 4] from elastic trial stresses, and a [P] mask of yielding particles."""
    sxx, syy, szz, txy = trial.unbind(1)
    centre = 0.5 * (sxx + syy)
    radius = torch.sqrt((0.5 * (sxx - syy)) ** 2 + txy ** 2)
    angle = 0.5 * torch.atan2(txy, 0.5 * (sxx - syy))  # direction of the larger in-plane stress
    in_plane = torch.stack([centre + radius, centre - radius, szz], dim=1)
    ordered, order = torch.sort(in_plane, dim=1, descending=True)
    returned = _principal_return(ordered, material)
    returned = torch.minimum(returned, material.tension_cutoff[:, None])
    back = torch.empty_like(returned).scatter_(1, order, returned)  # undo the sort
    s_a, s_b, s_z = back.unbind(1)
    new_centre, new_radius = 0.5 * (s_a + s_b), 0.5 * (s_a - s_b)
    cos2, sin2 = torch.cos(2 * angle), torch.sin(2 * angle)
    stress = torch.stack([new_centre + new_radius * cos2, new_centre - new_radius * cos2, s_z, new_radius * sin2], dim=1)
    yielded = (back - in_plane).abs().amax(dim=1) > 0
    return stress, yielded


def yield_function(stress: torch.Tensor, material: MohrCoulomb) -> torch.Tensor:
    """f(σ) [P] of the main plane (≤ 0 when admissible), for tests and diagnostics."""
    sxx, syy, szz, txy = stress.unbind(1)
    centre = 0.5 * (sxx + syy)
    radius = torch.sqrt((0.5 * (sxx - syy)) ** 2 + txy ** 2)
    principal = torch.stack([centre + radius, centre - radius, szz], dim=1)
    s1, s3 = principal.amax(1), principal.amin(1)
    return s1 * (1 + material.sin_phi) - s3 * (1 - material.sin_phi) - 2 * material.cohesion * torch.sqrt(1 - material.sin_phi ** 2)
