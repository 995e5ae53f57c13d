"""Mohr-Coulomb elasto-plasticity in plane strain, equivalent to CB-Geo's ``MohrCoulomb2D``
without softening: friction φ, dilation ψ, cohesion c, tension cutoff T. Tension positive.

A stress is four [P] tensors (σxx, σyy, σzz, τxy). The return mapping works in principal
stresses (σ1 ≥ σ2 ≥ σ3, σzz being one of them) against

    f = k σ1 − σ3 − σc ≤ 0,   k = (1 + sin φ)/(1 − sin φ),   σc = 2 c cos φ/(1 − sin φ),

with plastic potential g = m σ1 − σ3, m = (1 + sin ψ)/(1 − sin ψ): first to the main plane along
D·∂g/∂σ; if that breaks the principal order, to the edge it crossed (two planes active, a 2 × 2
solve); if that fails too, to the apex. This is exact for linear elasticity (Clausen, Damkilde &
Andersen 2006, non-associated). A tension cutoff then caps every principal stress at T. Only the
particles that yield are returned; the rest keep their trial stress.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import torch


@dataclass
class MohrCoulomb:
    """Per-particle material constants [P] (SI units); k, m and σc as in the module docstring."""

    shear_modulus: torch.Tensor
    lame_lambda: torch.Tensor
    sin_phi: torch.Tensor
    k: torch.Tensor
    m: torch.Tensor
    sigma_c: torch.Tensor
    tension_cutoff: torch.Tensor

    @classmethod
    def from_parameters(
        cls, youngs_modulus, poisson_ratio, friction_deg, dilation_deg, cohesion, tension_cutoff, like: torch.Tensor
    ) -> MohrCoulomb:
        """Build from scalars or [P] arrays, as tensors shaped and typed like ``like`` [P]."""

        def tensor(value):
            return torch.as_tensor(value, dtype=like.dtype, device=like.device).expand_as(like).clone()

        e, nu = tensor(youngs_modulus), tensor(poisson_ratio)
        sin_phi = torch.sin(torch.deg2rad(tensor(friction_deg)))
        sin_psi = torch.sin(torch.deg2rad(tensor(dilation_deg)))
        return cls(
            shear_modulus=e / (2 * (1 + nu)),
            lame_lambda=e * nu / ((1 + nu) * (1 - 2 * nu)),
            sin_phi=sin_phi,
            k=(1 + sin_phi) / (1 - sin_phi),
            m=(1 + sin_psi) / (1 - sin_psi),
            sigma_c=2 * tensor(cohesion) * torch.sqrt(1 - sin_phi**2) / (1 - sin_phi),
            tension_cutoff=tensor(tension_cutoff),
        )

    def subset(self, index: torch.Tensor) -> MohrCoulomb:
        """The constants of the particles at ``index`` (or a boolean mask)."""
        return MohrCoulomb(**{f.name: getattr(self, f.name)[index] for f in fields(self)})

    @property
    def p_wave_modulus(self) -> torch.Tensor:
        return self.lame_lambda + 2 * self.shear_modulus

    @property
    def cohesion(self) -> torch.Tensor:
        return self.sigma_c * (1 - self.sin_phi) / (2 * torch.sqrt(1 - self.sin_phi**2))


def elastic_increment(dxx: torch.Tensor, dyy: torch.Tensor, dxy: torch.Tensor, material: MohrCoulomb) -> tuple:
    """Stress increments (σxx, σyy, σzz, τxy) of a plane-strain increment (dεxx, dεyy, dγxy)."""
    volumetric = material.lame_lambda * (dxx + dyy)
    g = material.shear_modulus
    return volumetric + 2 * g * dxx, volumetric + 2 * g * dyy, volumetric, g * dxy


def _principal_return(s1: torch.Tensor, s2: torch.Tensor, s3: torch.Tensor, material: MohrCoulomb) -> tuple:
    """Return sorted principal stresses (σ1 ≥ σ2 ≥ σ3), all beyond the surface, onto it.

    Planes: 1 (main) k σ1 − σ3, 2 (edge σ1 = σ2) k σ2 − σ3, 3 (edge σ2 = σ3) k σ1 − σ2, each with
    flow D·b, b = (m, 0, −1), (0, m, −1), (m, −1, 0); the products a_i·D·b_j are written out.
    """
    k, sigma_c = material.k, material.sigma_c
    lam_trace = material.lame_lambda * (material.m - 1)
    g2 = 2 * material.shear_modulus
    g2m = g2 * material.m
    big, small = lam_trace + g2m, lam_trace - g2  # components of D·b
    f1, f2, f3 = k * s1 - s3 - sigma_c, k * s2 - s3 - sigma_c, k * s1 - s2 - sigma_c
    m11 = k * big - small  # a_i·D·b_i, the same for the three planes
    c12 = k * lam_trace - small  # a1·D·b2 = a2·D·b1
    c13 = k * big - lam_trace  # a1·D·b3 = a3·D·b1
    l1 = f1 / m11
    main = (s1 - l1 * big, s2 - l1 * lam_trace, s3 - l1 * small)

    det2 = m11 * m11 - c12 * c12
    p2, q2 = (m11 * f1 - c12 * f2) / det2, (m11 * f2 - c12 * f1) / det2
    edge2 = (s1 - p2 * big - q2 * lam_trace, s2 - p2 * lam_trace - q2 * big, s3 - (p2 + q2) * small)
    det3 = m11 * m11 - c13 * c13
    p3, q3 = (m11 * f1 - c13 * f3) / det3, (m11 * f3 - c13 * f1) / det3
    edge3 = (s1 - (p3 + q3) * big, s2 - p3 * lam_trace - q3 * small, s3 - p3 * small - q3 * lam_trace)

    apex_value = sigma_c / (k - 1)
    on_main = (main[0] >= main[1]) & (main[1] >= main[2])
    to_edge2 = ~on_main & (main[1] > main[0]) & (p2 >= 0) & (q2 >= 0) & (sum(edge2) <= 3 * apex_value)
    to_edge3 = ~on_main & ~to_edge2 & (main[2] > main[1]) & (p3 >= 0) & (q3 >= 0) & (sum(edge3) <= 3 * apex_value)
    return tuple(
        torch.where(on_main, mi, torch.where(to_edge2, e2, torch.where(to_edge3, e3, apex_value)))
        for mi, e2, e3 in zip(main, edge2, edge3)
    )


def _principal(sxx, syy, szz, txy):
    """In-plane principal stresses s_a ≥ s_b, their angle, and the sorted triple with σzz."""
    centre = 0.5 * (sxx + syy)
    half_difference = 0.5 * (sxx - syy)
    radius = torch.sqrt(half_difference**2 + txy**2)
    s_a, s_b = centre + radius, centre - radius
    s1, s3 = torch.maximum(s_a, szz), torch.minimum(s_b, szz)
    return s_a, s_b, (s1, s_a + s_b + szz - s1 - s3, s3), (half_difference, txy, radius)


def return_map(
    sxx: torch.Tensor, syy: torch.Tensor, szz: torch.Tensor, txy: torch.Tensor, material: MohrCoulomb
) -> tuple[tuple, torch.Tensor]:
    """Admissible stresses (σxx, σyy, σzz, τxy) from elastic trial stresses, and the yielding mask."""
    _, _, (s1, _, s3), _ = _principal(sxx, syy, szz, txy)
    yielded = (material.k * s1 - s3 - material.sigma_c > 0) | (s1 > material.tension_cutoff)
    index = torch.nonzero(yielded).squeeze(1)
    if index.numel() == 0:
        return (sxx, syy, szz, txy), yielded
    sub = material.subset(index)
    t_xx, t_yy, t_zz, t_xy = sxx[index], syy[index], szz[index], txy[index]
    a, b, ordered, (half_difference, shear, radius) = _principal(t_xx, t_yy, t_zz, t_xy)
    plastic = sub.k * ordered[0] - ordered[2] - sub.sigma_c > 0
    returned = _principal_return(ordered[0], ordered[1], ordered[2], sub)
    r1, r2, r3 = (torch.minimum(torch.where(plastic, r, o), sub.tension_cutoff) for r, o in zip(returned, ordered))
    z_top, z_bottom = t_zz >= a, t_zz < b  # where σzz sat in the order; it keeps that slot
    new_z = torch.where(z_top, r1, torch.where(z_bottom, r3, r2))
    new_a = torch.where(z_top, r2, r1)
    new_b = torch.where(z_bottom, r2, r3)
    centre, half = 0.5 * (new_a + new_b), 0.5 * (new_a - new_b)
    safe = torch.where(radius > 0, radius, torch.ones_like(radius))
    cos2 = torch.where(radius > 0, half_difference / safe, torch.ones_like(radius))
    sin2 = torch.where(radius > 0, shear / safe, torch.zeros_like(radius))
    out = [sxx.clone(), syy.clone(), szz.clone(), txy.clone()]
    for tensor, value in zip(out, (centre + half * cos2, centre - half * cos2, new_z, half * sin2)):
        tensor[index] = value
    return tuple(out), yielded


def yield_function(sxx, syy, szz, txy, material: MohrCoulomb) -> torch.Tensor:
    """f(σ) [P] of the main plane, scaled as σ1(1 + sin φ) − σ3(1 − sin φ) − 2c cos φ."""
    _, _, (s1, _, s3), _ = _principal(sxx, syy, szz, txy)
    sin_phi = material.sin_phi
    return s1 * (1 + sin_phi) - s3 * (1 - sin_phi) - 2 * material.cohesion * torch.sqrt(1 - sin_phi**2)
