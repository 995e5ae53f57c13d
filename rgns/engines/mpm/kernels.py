"""The explicit MPM step of :mod:`rgns.engines.mpm.step` as compiled CPU kernels (numba), a frame per call.

The same scheme as the torch step, written per particle, with floating-point sums free to be reordered
(``FAST``: reassociation, fused multiply-adds, reciprocals; NaN and infinity kept as IEEE, which the divergence
checks read): the scatters run particle by particle, gravity enters a node as its mass times g, and a particle's
stress is scaled by its volume once, not per node. A run agrees with the torch engine to rounding (final
stresses within about 1e-12 of the largest after thousands of steps; R, V, I identical on the reference
realizations: benchmarks/results/engine_backends.md). A call advances every realization of a batch by its own
substeps of one frame, one realization after another (they never share a node), so no Python runs between
substeps. The grid is cleared and updated only over the box of rows and columns the particles reach (no other node
is read). A particle's weights are held as its first DOF and the 1-D factors along each axis (12 numbers, not a
weight, a gradient and an id per slot), each slot's weight and gradient formed where it is used. Serial
``@njit(fastmath=FAST, cache=True)``: no threading layer beside torch's OpenMP, and a fresh process loads the compiled kernel from
the cache (``__pycache__`` beside this file, or ``NUMBA_CACHE_DIR``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

MASS_TOLERANCE = 1e-15  # as rgns.engines.mpm.step
FAST = {"reassoc", "contract", "nsz", "arcp"}  # no "nnan" or "ninf": the checks read NaN and infinity


@njit(fastmath=FAST, cache=True, inline="always")
def _maximum(a: float, b: float) -> float:
    """torch.maximum: NaN if either is NaN."""
    if a != a or b != b:
        return a + b
    return a if a >= b else b


@njit(fastmath=FAST, cache=True, inline="always")
def _minimum(a: float, b: float) -> float:
    """torch.minimum: NaN if either is NaN."""
    if a != a or b != b:
        return a + b
    return a if a <= b else b


@njit(fastmath=FAST, cache=True, inline="always")
def _sign(a: float) -> float:
    if a > 0.0:
        return 1.0
    if a < 0.0:
        return -1.0
    return a * 0.0  # ±0 stays 0, NaN stays NaN


@njit(fastmath=FAST, cache=True, inline="always")
def _clamp(a: float, low: float, high: float) -> float:
    return _minimum(_maximum(a, low), high)


@njit(fastmath=FAST, cache=True, inline="always")
def _finite_or_zero(a: float) -> float:
    """nan_to_num(a, 0, 0, 0)."""
    if a != a or a == np.inf or a == -np.inf:
        return 0.0
    return a


@njit(fastmath=FAST, cache=True, inline="always")
def _factor_loop(x, y, grid, base, factors, box, spline):
    """:func:`_factors` for one basis (``spline``, a literal at each call, so that the loop holds no branch and
    vectorises; it divides by h as torch does: a vector division costs little here)."""
    origin_x, origin_y, h, lower_x, lower_y = grid[0], grid[1], grid[2], grid[3], grid[4]
    nx, ny, mesh_nx, mesh_ny = int(grid[5]), int(grid[6]), int(grid[7]), int(grid[8])
    span = 2 if spline else 1  # the DOFs a particle reaches past its first, along each axis
    row = nx + 2 if spline else mesh_nx + 1
    wx0, wx1, wx2, dx0, dx1, dx2 = factors[0], factors[1], factors[2], factors[3], factors[4], factors[5]
    wy0, wy1, wy2, dy0, dy1, dy2 = factors[6], factors[7], factors[8], factors[9], factors[10], factors[11]
    outside = 0
    i_low, i_high, j_low, j_high = 1 << 30, -1, 1 << 30, -1
    for q in range(len(x)):
        u = (x[q] - origin_x) / h - lower_x
        v = (y[q] - origin_y) / h - lower_y
        outside += 1 - ((u >= 0.0) & (u <= nx) & (v >= 0.0) & (v <= ny))
        u = _finite_or_zero(u)
        v = _finite_or_zero(v)
        if spline:
            wx0[q], wx1[q], wx2[q], dx0[q], dx1[q], dx2[q], ci = _quadratic(u, nx)
            wy0[q], wy1[q], wy2[q], dy0[q], dy1[q], dy2[q], cj = _quadratic(v, ny)
        else:  # the cell's 2 nodes along each axis, in cells from the mesh origin
            wx0[q], wx1[q], dx0[q], dx1[q], ci = _linear(u + lower_x, mesh_nx)
            wy0[q], wy1[q], dy0[q], dy1[q], cj = _linear(v + lower_y, mesh_ny)
        i, j = int(ci), int(cj)
        i_low, i_high, j_low, j_high = min(i_low, i), max(i_high, i + span), min(j_low, j), max(j_high, j + span)
        base[q] = j * row + i
    box[0], box[1], box[2], box[3] = i_low, i_high, j_low, j_high
    return outside


@njit(fastmath=FAST, cache=True)
def _factors(x, y, grid, spline, base, factors, box):
    """Each particle's first DOF and the 1-D factors of its weights (shape.py's bases; ``grid`` as
    :func:`advance_frame`'s; ``x``, ``y`` one realization's): rows 0-2 wx, 3-5 ∂wx, 6-8 wy, 9-11 ∂wy along its
    DOFs' columns and rows (the bilinear cell uses rows 0-1, 3-4, 6-7, 9-10; a slot's weight is wy·wx, its gradient
    (wy·∂wx, ∂wy·wx) / h: the products the torch basis forms, made where they are used); ``box``: the first and last
    column and row of the DOFs they reach; returns how many lie outside the region. Compiled on its own (not
    inlined), which keeps :func:`advance_frame`'s compile short."""
    if spline:
        return _factor_loop(x, y, grid, base, factors, box, True)
    return _factor_loop(x, y, grid, base, factors, box, False)


@njit(fastmath=FAST, cache=True, inline="always")
def _weight(factors, r, c, q):
    """Slot (r, c)'s weight of particle q: wy·wx, as the torch basis forms it."""
    return factors[6 + r, q] * factors[c, q]


@njit(fastmath=FAST, cache=True, inline="always")
def _gradient(factors, r, c, q, inverse_h):
    """Slot (r, c)'s weight gradient of particle q: (wy·∂wx, ∂wy·wx) / h, the division a product by ``inverse_h``."""
    return factors[6 + r, q] * factors[3 + c, q] * inverse_h, factors[9 + r, q] * factors[c, q] * inverse_h


@njit(fastmath=FAST, cache=True, inline="always")
def _quadratic(t, n):
    """shape.clamped_quadratic_1d at one point: weights, derivatives of DOFs c, c + 1, c + 2, and c. Every piece is
    formed and one chosen (selects, not branches), the same products as the torch basis."""
    c = _clamp(np.floor(t), 0.0, n - 1.0)
    s = _clamp(t - c, 0.0, 1.0)
    r = 1 - s
    first, last = c == 0, c == n - 1
    w0_first, w0_inner = r * r, 0.5 * r * r
    d0_first, d0_inner = -2 * r, -r
    w1_first, w1_last, w1_inner = 2 * s - 1.5 * s * s, 2 * r - 1.5 * r * r, 0.5 + s - s * s
    d1_first, d1_last, d1_inner = 2 - 3 * s, 3 * r - 2, 1 - 2 * s
    w2_last, w2_inner = s * s, 0.5 * s * s
    d2_last, d2_inner = 2 * s, s
    w0 = w0_first if first else w0_inner
    d0 = d0_first if first else d0_inner
    w1 = w1_first if first else (w1_last if last else w1_inner)
    d1 = d1_first if first else (d1_last if last else d1_inner)
    w2 = w2_last if last else w2_inner
    d2 = d2_last if last else d2_inner
    return w0, w1, w2, d0, d1, d2, c


@njit(fastmath=FAST, cache=True, inline="always")
def _linear(t, n):
    """LinearBasis along one axis at one point (t in cells from the mesh origin): weights and derivatives of
    nodes c and c + 1, and c."""
    c = _clamp(np.floor(t), 0.0, n - 1.0)
    xi = _clamp(t - c, 0.0, 1.0)
    return 1 - xi, xi, -1.0, 1.0, c


@njit(fastmath=FAST, cache=True, inline="always")
def _principal_return(s1, s2, s3, k, sigma_c, lame_lambda, shear_modulus, m):
    """mohr_coulomb._principal_return for one stress: the returned principal stresses."""
    lam_trace = lame_lambda * (m - 1)
    g2 = 2 * shear_modulus
    g2m = g2 * m
    big, small = lam_trace + g2m, lam_trace - g2
    f1, f2, f3 = k * s1 - s3 - sigma_c, k * s2 - s3 - sigma_c, k * s1 - s2 - sigma_c
    m11 = k * big - small
    c12 = k * lam_trace - small
    c13 = k * big - lam_trace
    l1 = f1 / m11
    main0, main1, main2 = s1 - l1 * big, s2 - l1 * lam_trace, s3 - l1 * small
    if main0 >= main1 and main1 >= main2:
        return main0, main1, main2
    apex_value = sigma_c / (k - 1)
    det2 = m11 * m11 - c12 * c12
    p2, q2 = (m11 * f1 - c12 * f2) / det2, (m11 * f2 - c12 * f1) / det2
    e20, e21, e22 = s1 - p2 * big - q2 * lam_trace, s2 - p2 * lam_trace - q2 * big, s3 - (p2 + q2) * small
    if main1 > main0 and p2 >= 0 and q2 >= 0 and e20 + e21 + e22 <= 3 * apex_value:
        return e20, e21, e22
    det3 = m11 * m11 - c13 * c13
    p3, q3 = (m11 * f1 - c13 * f3) / det3, (m11 * f3 - c13 * f1) / det3
    e30, e31, e32 = s1 - (p3 + q3) * big, s2 - p3 * lam_trace - q3 * small, s3 - p3 * small - q3 * lam_trace
    if main2 > main1 and p3 >= 0 and q3 >= 0 and e30 + e31 + e32 <= 3 * apex_value:
        return e30, e31, e32
    return apex_value, apex_value, apex_value


@njit(fastmath=FAST, cache=True, inline="always")
def _trial(sxx, syy, szz, txy, dxx, dyy, dxy, g, lame_lambda):
    """mohr_coulomb.elastic_increment added to one particle's stress: the trial (σxx, σyy, σzz, τxy)."""
    volumetric = lame_lambda * (dxx + dyy)
    t_xx = sxx + (volumetric + 2 * g * dxx)
    t_yy = syy + (volumetric + 2 * g * dyy)
    t_zz = szz + volumetric
    t_xy = txy + g * dxy
    return t_xx, t_yy, t_zz, t_xy


@njit(fastmath=FAST, cache=True, inline="always")
def _circle(t_xx, t_yy, t_zz, t_xy):
    """The trial's Mohr circle in the plane and its extreme principal stresses s1 ≥ s3 with σzz."""
    centre = 0.5 * (t_xx + t_yy)
    half_difference = 0.5 * (t_xx - t_yy)
    radius = np.sqrt(half_difference**2 + t_xy**2)
    a, b = centre + radius, centre - radius
    s1, s3 = _maximum(a, t_zz), _minimum(b, t_zz)
    return half_difference, radius, a, b, s1, s3


@njit(fastmath=FAST, cache=True)
def _trial_stresses(
    sxx,
    syy,
    szz,
    txy,
    strain_xx,
    strain_yy,
    strain_xy,
    shear_modulus,
    lame_lambda,
    k,
    sigma_c,
    tension_cutoff,
    volume,
    yielding,
):
    """Each particle's elastic trial stress and new volume, in place; ``yielding``: whether its trial leaves the
    Mohr-Coulomb surface or passes the tension cutoff (its return is :func:`_returned`'s). No branch: the loop
    vectorises; compiled on its own."""
    for q in range(len(sxx)):
        dxx, dyy = strain_xx[q], strain_yy[q]
        t_xx, t_yy, t_zz, t_xy = _trial(
            sxx[q], syy[q], szz[q], txy[q], dxx, dyy, strain_xy[q], shear_modulus[q], lame_lambda[q]
        )
        half_difference, radius, a, b, s1, s3 = _circle(t_xx, t_yy, t_zz, t_xy)
        yielding[q] = (k[q] * s1 - s3 - sigma_c[q] > 0) | (s1 > tension_cutoff[q])
        sxx[q], syy[q], szz[q], txy[q] = t_xx, t_yy, t_zz, t_xy
        volume[q] = volume[q] * (1.0 + dxx + dyy)


@njit(fastmath=FAST, cache=True, inline="always")
def _returned(t_xx, t_yy, t_zz, t_xy, shear_modulus, lame_lambda, k, m, sigma_c, tension_cutoff):
    """mohr_coulomb.return_map of a yielding trial: the stress returned to the surface and the tension cutoff."""
    g = shear_modulus
    half_difference, radius, a, b, s1, s3 = _circle(t_xx, t_yy, t_zz, t_xy)
    plastic = k * s1 - s3 - sigma_c > 0
    s2 = a + b + t_zz - s1 - s3
    r1, r2, r3 = s1, s2, s3
    if plastic:
        r1, r2, r3 = _principal_return(s1, s2, s3, k, sigma_c, lame_lambda, g, m)
    r1, r2, r3 = _minimum(r1, tension_cutoff), _minimum(r2, tension_cutoff), _minimum(r3, tension_cutoff)
    z_top, z_bottom = t_zz >= a, t_zz < b
    new_z = r1 if z_top else (r3 if z_bottom else r2)
    new_a = r2 if z_top else r1
    new_b = r2 if z_bottom else r3
    centre, half = 0.5 * (new_a + new_b), 0.5 * (new_a - new_b)
    if radius > 0:
        cos2, sin2 = half_difference / radius, t_xy / radius
    else:
        cos2, sin2 = 1.0, 0.0
    return centre + half * cos2, centre - half * cos2, new_z, half * sin2


@njit(fastmath=FAST, cache=True, inline="always")
def _p2g(width, p0, count, row, base, factors, mass, vx, vy, node_mass, momentum_x, momentum_y):
    """mass[n] += w m, momentum[n] += w m v, particle by particle over its width × width DOFs (``width`` a literal
    at each call, so that the loop over them is unrolled; ``row``: DOFs in a row)."""
    for q in range(count):
        p = p0 + q
        particle_mass, particle_vx, particle_vy = mass[p], vx[p], vy[p]
        for s in range(width * width):
            r, c = s // width, s % width
            n = base[q] + r * row + c
            weighted = _weight(factors, r, c, q) * particle_mass
            node_mass[n] += weighted
            momentum_x[n] += weighted * particle_vx
            momentum_y[n] += weighted * particle_vy


@njit(fastmath=FAST, cache=True, inline="always")
def _internal_force(width, count, row, base, factors, inverse_h, stress, force_x, force_y):
    """force[n] += −v (σ · ∇w), particle by particle as :func:`_p2g`; ``stress`` [P, 3]: each particle's −v σxx,
    −v σyy, −v τxy."""
    for q in range(count):
        a, b, t = stress[q, 0], stress[q, 1], stress[q, 2]
        for s in range(width * width):
            r, c = s // width, s % width
            n = base[q] + r * row + c
            gx, gy = _gradient(factors, r, c, q, inverse_h)
            force_x[n] += a * gx + t * gy
            force_y[n] += t * gx + b * gy


@njit(fastmath=FAST, cache=True, inline="always")
def _strains(width, count, row, base, factors, inverse_h, node_vx, node_vy, dt, strain_xx, strain_yy, strain_xy):
    """Each particle's strain increments from the nodal velocities (four sums over its DOFs; ``width`` as
    :func:`_p2g`)."""
    for q in range(count):
        lxx = 0.0
        lyy = 0.0
        lxy = 0.0
        lyx = 0.0
        for s in range(width * width):
            r, c = s // width, s % width
            n = base[q] + r * row + c
            gx, gy = _gradient(factors, r, c, q, inverse_h)
            lxx += node_vx[n] * gx
            lyy += node_vy[n] * gy
            lxy += node_vx[n] * gy
            lyx += node_vy[n] * gx
        strain_xx[q], strain_yy[q], strain_xy[q] = dt * lxx, dt * lyy, dt * (lxy + lyx)


@njit(fastmath=FAST, cache=True, inline="always")
def _g2p(width, p0, count, row, base, factors, node_ax, node_ay, new_vx, new_vy, dt, pic_blend, x, y, vx, vy):
    """FLIP velocities (blended with PIC), positions with the new nodal velocities; ``width`` as :func:`_p2g`."""
    for q in range(count):
        p = p0 + q
        sum_ax = 0.0
        sum_ay = 0.0
        pic_x = 0.0
        pic_y = 0.0
        for s in range(width * width):
            r, c = s // width, s % width
            n = base[q] + r * row + c
            ws = _weight(factors, r, c, q)
            sum_ax += ws * node_ax[n]
            sum_ay += ws * node_ay[n]
            pic_x += ws * new_vx[n]
            pic_y += ws * new_vy[n]
        flip_x = vx[p] + dt * sum_ax
        flip_y = vy[p] + dt * sum_ay
        if pic_blend != 0.0:
            flip_x = (1 - pic_blend) * flip_x + pic_blend * pic_x
            flip_y = (1 - pic_blend) * flip_y + pic_blend * pic_y
        vx[p], vy[p] = flip_x, flip_y
        x[p] = x[p] + dt * pic_x
        y[p] = y[p] + dt * pic_y


@njit(fastmath=FAST, cache=True)
def advance_frame(
    x,
    y,
    vx,
    vy,
    mass,
    volume,
    sxx,
    syy,
    szz,
    txy,
    shear_modulus,
    lame_lambda,
    k,
    m,
    sigma_c,
    tension_cutoff,
    starts,
    substeps,
    dts,
    grid,
    spline,
    fixed_x,
    fixed_y,
    floor,
    friction,
    gravity_x,
    gravity_y,
    damping,
    pic_blend,
    outside,
):
    """Advance realization b (particles starts[b]..starts[b + 1]) by substeps[b] steps of dts[b], in place.

    ``grid``: origin x, y, cell h, region lower x, y, region cells nx, ny, mesh cells nx, ny; the basis is the
    clamped quadratic B-spline (``spline``) or the bilinear cell; ``fixed_x`` … ``friction`` are the
    constraints of one realization's DOFs. ``outside[b]`` counts particle steps out of the region.
    """
    n_nodes = fixed_x.shape[0]
    largest = 0
    for b in range(len(substeps)):
        largest = max(largest, starts[b + 1] - starts[b])
    base = np.empty(largest, dtype=np.int64)  # each particle's first DOF
    factors = np.empty((12, largest))  # and its weights' 1-D factors (_factors)
    strain_xx = np.empty(largest)
    strain_yy = np.empty(largest)
    strain_xy = np.empty(largest)
    stress = np.empty((largest, 3))
    yielding = np.empty(largest, dtype=np.bool_)
    node_mass = np.empty(n_nodes)
    inverse_mass = np.empty(n_nodes)
    node_vx = np.empty(n_nodes)
    node_vy = np.empty(n_nodes)
    force_x = np.empty(n_nodes)
    force_y = np.empty(n_nodes)
    node_ax = np.empty(n_nodes)
    node_ay = np.empty(n_nodes)
    new_vx = np.empty(n_nodes)
    new_vy = np.empty(n_nodes)
    box = np.empty(4, dtype=np.int64)
    row = int(grid[5]) + 2 if spline else int(grid[7]) + 1  # DOFs in a row
    inverse_h = 1.0 / grid[2]
    for b in range(len(substeps)):
        p0, p1 = starts[b], starts[b + 1]
        count = p1 - p0
        dt = dts[b]
        for _ in range(substeps[b]):
            outside[b] += _factors(x[p0:p1], y[p0:p1], grid, spline, base, factors, box)
            # p2g: nodal mass and momentum
            for j in range(box[2], box[3] + 1):
                for n in range(j * row + box[0], j * row + box[1] + 1):
                    node_mass[n] = 0.0
                    force_x[n] = 0.0  # momentum first, forces later
                    force_y[n] = 0.0
            if spline:
                _p2g(3, p0, count, row, base, factors, mass, vx, vy, node_mass, force_x, force_y)
            else:
                _p2g(2, p0, count, row, base, factors, mass, vx, vy, node_mass, force_x, force_y)
            for j in range(box[2], box[3] + 1):
                for n in range(j * row + box[0], j * row + box[1] + 1):
                    inverse = 1.0 / node_mass[n] if node_mass[n] > MASS_TOLERANCE else 0.0
                    inverse_mass[n] = inverse
                    node_vx[n] = 0.0 if fixed_x[n] else force_x[n] * inverse
                    node_vy[n] = 0.0 if fixed_y[n] else force_y[n] * inverse
                    force_x[n] = node_mass[n] * gravity_x  # gravity, then the internal forces
                    force_y[n] = node_mass[n] * gravity_y
            # strain increments from the nodal velocities
            if spline:
                _strains(3, count, row, base, factors, inverse_h, node_vx, node_vy, dt, strain_xx, strain_yy, strain_xy)
            else:
                _strains(2, count, row, base, factors, inverse_h, node_vx, node_vy, dt, strain_xx, strain_yy, strain_xy)
            # the stress update and the new volume
            _trial_stresses(
                sxx[p0:p1],
                syy[p0:p1],
                szz[p0:p1],
                txy[p0:p1],
                strain_xx[:count],
                strain_yy[:count],
                strain_xy[:count],
                shear_modulus[p0:p1],
                lame_lambda[p0:p1],
                k[p0:p1],
                sigma_c[p0:p1],
                tension_cutoff[p0:p1],
                volume[p0:p1],
                yielding,
            )
            for q in range(count):
                p = p0 + q
                if yielding[q]:
                    sxx[p], syy[p], szz[p], txy[p] = _returned(
                        sxx[p],
                        syy[p],
                        szz[p],
                        txy[p],
                        shear_modulus[p],
                        lame_lambda[p],
                        k[p],
                        m[p],
                        sigma_c[p],
                        tension_cutoff[p],
                    )
                minus_v = -volume[p]
                stress[q, 0], stress[q, 1], stress[q, 2] = minus_v * sxx[p], minus_v * syy[p], minus_v * txy[p]
            # grid update: the internal forces
            if spline:
                _internal_force(3, count, row, base, factors, inverse_h, stress, force_x, force_y)
            else:
                _internal_force(2, count, row, base, factors, inverse_h, stress, force_x, force_y)
            for j in range(box[2], box[3] + 1):
                for n in range(j * row + box[0], j * row + box[1] + 1):
                    inverse = inverse_mass[n]
                    f_x, f_y = force_x[n], force_y[n]
                    if damping != 0.0:
                        magnitude = damping * np.sqrt(f_x**2 + f_y**2)
                        f_x, f_y = f_x - magnitude * _sign(node_vx[n]), f_y - magnitude * _sign(node_vy[n])
                    ax, ay = f_x * inverse, f_y * inverse
                    if floor[n] and ay < 0:
                        limit = friction[n] * abs(ay)
                        v0 = node_vx[n]
                        if v0 != 0:
                            moving = v0 + dt * ax
                            ax = -v0 / dt if abs(moving) <= limit * dt else ax - _sign(moving) * limit
                        else:
                            ax = 0.0 if abs(ax) <= limit else ax - _sign(ax) * limit
                    if fixed_x[n]:
                        ax = 0.0
                    if fixed_y[n]:
                        ay = 0.0
                    node_ax[n], node_ay[n] = ax, ay
                    new_vx[n] = 0.0 if fixed_x[n] else node_vx[n] + dt * ax
                    new_vy[n] = 0.0 if fixed_y[n] else node_vy[n] + dt * ay
            # g2p: FLIP velocities (blended with PIC), positions with the new nodal velocities
            if spline:
                _g2p(3, p0, count, row, base, factors, node_ax, node_ay, new_vx, new_vy, dt, pic_blend, x, y, vx, vy)
            else:
                _g2p(2, p0, count, row, base, factors, node_ax, node_ay, new_vx, new_vy, dt, pic_blend, x, y, vx, vy)


@njit(fastmath=FAST, cache=True)
def frame_summary(
    x,
    y,
    vx,
    vy,
    mass,
    volume,
    sxx,
    syy,
    szz,
    txy,
    shear_modulus,
    lame_lambda,
    starts,
    gravity,
    energy,
    non_finite,
    speed,
):
    """Per realization b, as solver.energies and the solver's checks: ``energy[b]`` (kinetic, potential from y = 0,
    elastic), ``non_finite[b]`` (particles with a non-finite position or velocity), ``speed[b]`` (the largest)."""
    for b in range(len(starts) - 1):
        kinetic = 0.0
        potential = 0.0
        elastic = 0.0
        bad = 0
        fastest = 0.0
        for p in range(starts[b], starts[b + 1]):
            g, lam = shear_modulus[p], lame_lambda[p]
            e = g * (3 * lam + 2 * g) / (lam + g)
            nu = lam / (2 * (lam + g))
            a, c, z, t = sxx[p], syy[p], szz[p], txy[p]
            density = (a**2 + c**2 + z**2 - 2 * nu * (a * c + c * z + z * a)) / (2 * e) + t**2 / (2 * g)
            squared = vx[p] ** 2 + vy[p] ** 2
            kinetic += 0.5 * mass[p] * squared
            potential += mass[p] * gravity * y[p]
            elastic += density * volume[p]
            if not (np.isfinite(x[p]) and np.isfinite(y[p]) and np.isfinite(vx[p]) and np.isfinite(vy[p])):
                bad += 1
            fastest = _maximum(fastest, np.sqrt(squared))
        energy[b, 0], energy[b, 1], energy[b, 2] = kinetic, potential, elastic
        non_finite[b], speed[b] = bad, fastest
