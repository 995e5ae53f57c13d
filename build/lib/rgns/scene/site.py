"""A real site as a Monte Carlo case: its soil body, checked against the domain, added to the config.

The soil body is the ground between the section's surface and a flat base (``site.base_elevation_m``,
or ``site.base_depth_m`` below the ground at ``from``) over the chainage ``site.extent_m = [from, to]``.
In the model frame x = chainage - from (the body rests against the left wall there) and
y = elevation - base (the floor is the base). Without a ``domain`` section the domain is derived:
the body, ``geometry.runout_room_m`` beyond it and a cell of head room, in whole cells; with one,
the runout room is what that domain leaves beyond the toe. The site becomes a geometry family of fixed vertices
and a set of the same name with the site's field statistics: no perturbation, the same rules,
skipping, chunking and report as case 1.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np

from rgns.scene.fields import FIELD_KEYS
from rgns.scene.geometry import polygon_problems, signed_area
from rgns.scene.site_section import Section, SiteError, read_section

log = logging.getLogger(__name__)

# the lowest friction angle a field plausibly takes: its mean less this many standard deviations
FIELD_LOW_SIGMAS = 4.0


@dataclass
class SiteBody:
    """The soil body in the model frame, and where it sits on the section."""

    vertices: np.ndarray
    chainage_from_m: float
    base_elevation_m: float
    toe_x_m: float
    steepest_deg: float


def _crossing(x0: float, z0: float, x1: float, z1: float, level: float) -> float:
    """Where the segment (x0, z0)-(x1, z1) crosses z = level."""
    return x0 + (x1 - x0) * (z0 - level) / (z0 - z1)


def soil_body(section: Section, base_elevation_m: float, extent_m: list[float]) -> SiteBody:
    """The polygon between the surface and the base from ``extent[0]`` to the toe (or ``extent[1]``).

    The toe is the first point after ``from`` where the surface comes down to the base; beyond
    ``to`` the body ends in a vertical face. Counter-clockwise, as the geometry checks want.
    """
    start, end = (float(v) for v in extent_m)
    if not 0.0 <= start < end <= section.length_m + 1e-9:
        raise SiteError(
            f"site.extent_m = {list(extent_m)}: must satisfy 0 <= from < to <= the section's length "
            f"{section.length_m:.2f} m"
        )
    inside = (section.chainage_m > start) & (section.chainage_m < end)
    chainage = np.concatenate([[start], section.chainage_m[inside], [end]])
    surface = np.interp(chainage, section.chainage_m, section.elevation_m)
    height = surface - base_elevation_m
    rises = surface[-1] > surface[0]
    hint = (
        (
            "; the ground rises along the section: give site.section (line or chainage) from the top of the "
            "slope towards its toe"
        )
        if rises
        else ""
    )
    if height[0] <= 0.0:
        raise SiteError(
            f"site.base_elevation_m = {base_elevation_m}: at or above the ground surface "
            f"({surface[0]:.2f} m) at the start of site.extent_m (chainage {start} m){hint}"
        )
    if rises and np.all(height > 0.0):
        raise SiteError(
            f"site.section: the ground rises from {surface[0]:.2f} m at chainage {start} m to "
            f"{surface[-1]:.2f} m at {end} m: give site.section (line or chainage) from the top "
            "of the slope towards its toe"
        )
    below = np.flatnonzero(height <= 0.0)
    if below.size:
        k = below[0]
        toe = _crossing(chainage[k - 1], height[k - 1], chainage[k], height[k], 0.0)
        chainage, height = np.append(chainage[:k], toe), np.append(height[:k], 0.0)
    x = chainage - start
    top = np.column_stack([x, height])[::-1]  # the surface from the toe (or the end face) back to x = 0
    bottom = [[0.0, 0.0]] + ([[x[-1], 0.0]] if height[-1] > 0.0 else [])
    vertices = np.vstack([bottom, top])
    vertices = vertices[np.r_[True, np.any(np.diff(vertices, axis=0) != 0.0, axis=1)]]
    slopes = np.degrees(np.arctan(np.abs(np.diff(height) / np.diff(x))))
    return SiteBody(
        vertices=vertices,
        chainage_from_m=start,
        base_elevation_m=float(base_elevation_m),
        toe_x_m=float(x[-1]),
        steepest_deg=float(slopes.max()) if slopes.size else 0.0,
    )


def fit_problems(body: SiteBody, config: dict[str, Any]) -> list[str]:
    """Why the body does not fit the domain (with the runout room and a cell of head room), if it does not."""
    domain, mesh = config["domain"], config["mesh"]
    cell, room = mesh["cell_size_m"], config["geometry"]["runout_room_m"]
    problems = polygon_problems(body.vertices, domain["length_m"], domain["height_m"], room, headroom=cell)
    if not problems:
        return []
    spacing = cell / mesh["particles_per_cell"]
    area = abs(signed_area(body.vertices))
    length = body.vertices[:, 0].max() + room
    height = body.vertices[:, 1].max() + cell
    return [
        f"site: the soil body ({body.vertices[:, 0].max():.1f} m long, {body.vertices[:, 1].max():.1f} m high) "
        f"{'; '.join(problems)}. It needs a domain of at least {length:.1f} x {height:.1f} m (domain.length_m, "
        f"domain.height_m, with geometry.runout_room_m = {room} and a cell of head room), and would be about "
        f"{int(round(area / spacing**2)):,} material points at mesh.cell_size_m = {cell} with "
        f"{mesh['particles_per_cell']} x {mesh['particles_per_cell']} per cell"
    ]


def weak_slope_warning(body: SiteBody, site: dict[str, Any], bounds_deg: list[float]) -> str | None:
    """A warning when no face of the section is steeper than the lowest friction angle the field can take."""
    low = max(float(bounds_deg[0]), np.min(site["friction_mean_deg"]) - FIELD_LOW_SIGMAS * site["friction_std_deg"])
    if body.steepest_deg > low:
        return None
    return (
        f"site {site['name']!r}: the steepest face of the section is {body.steepest_deg:.1f} deg, not steeper "
        f"than the lowest friction angle the field takes ({low:.1f} deg: the mean less "
        f"{FIELD_LOW_SIGMAS:g} std, within random_field.friction_bounds_deg): no realization is likely to fail"
    )


def base_elevation(section: Section, site: dict[str, Any]) -> float:
    """The base: ``base_elevation_m``, or ``base_depth_m`` below the ground at the start of the extent."""
    given = [key for key in ("base_elevation_m", "base_depth_m") if site.get(key) is not None]
    if len(given) != 1:
        raise SiteError(
            f"config key 'site' gives {' and '.join(given) or 'neither base_elevation_m nor base_depth_m'}: "
            "give exactly one of base_elevation_m and base_depth_m"
        )
    if given == ["base_elevation_m"]:
        return float(site["base_elevation_m"])
    return float(np.interp(site["extent_m"][0], section.chainage_m, section.elevation_m) - site["base_depth_m"])


def site_body(config: dict[str, Any]) -> tuple[Section, SiteBody]:
    """Read the site's section at the mesh resolution and cut its soil body."""
    site = config["site"]
    section = read_section(site["section"], config["mesh"]["cell_size_m"])
    return section, soil_body(section, base_elevation(section, site), site["extent_m"])


def derived_domain(body: SiteBody, cell_size_m: float, runout_room_m: float) -> dict[str, float]:
    """The smallest domain of whole cells that holds the body, the runout room beyond it and a cell of head room."""
    length = body.vertices[:, 0].max() + runout_room_m
    height = body.vertices[:, 1].max() + cell_size_m
    return {
        "length_m": float(np.ceil(length / cell_size_m - 1e-9) * cell_size_m),
        "height_m": float(np.ceil(height / cell_size_m - 1e-9) * cell_size_m),
    }


def apply_site(config: dict[str, Any], derive_domain: bool = False) -> list[str]:
    """Add the site's family and set to a default-filled config (and, with ``derive_domain``, its domain);
    the errors, one line each (empty if none).

    The site's realizations are drawn as any set's, with fixed vertices: every realization has the
    same geometry and its own friction field.
    """
    site = config.get("site")
    if not site:
        return []
    name = site["name"]
    taken = [
        f"{where}.{name}"
        for where, names in (("geometry.families", config["geometry"]["families"]), ("sets", config["sets"]))
        if name in names
    ]
    if taken:
        return [f"config key 'site.name' = {name!r}: already used by {' and '.join(taken)}"]
    try:
        section, body = site_body(config)
    except SiteError as error:
        return [str(error)]
    if derive_domain:
        config["domain"] = derived_domain(body, config["mesh"]["cell_size_m"], config["geometry"]["runout_room_m"])
        log.info(
            "site %r: domain derived from the site, %g x %g m",
            name,
            config["domain"]["length_m"],
            config["domain"]["height_m"],
        )
    problems = fit_problems(body, config)
    if problems:
        return problems
    warning = weak_slope_warning(body, site, config["random_field"]["friction_bounds_deg"])
    if warning:
        log.warning(warning)
    config["geometry"]["families"][name] = {
        "description": f"Site {name}: the ground of {site['section'].get('csv') or site['section']['dem']} "
        f"between chainage {body.chainage_from_m} m and the toe, above {body.base_elevation_m} m",
        "vertices": [{"x_m": float(x), "y_m": float(y)} for x, y in body.vertices],
    }
    config["sets"][name] = [{"family": name, "count": site["realizations"], **{k: site[k] for k in FIELD_KEYS}}]
    return []
