"""A real site's ground profile: a surveyed cross-section (CSV) or a DEM sampled along a line.

Either way the result is a :class:`Section`: ground elevation at chainages spaced by the mesh cell
(from 0 at the line's first point), and, for a DEM, the map coordinates of each chainage in the
raster's coordinate reference system. Rasters are read with rasterio; the elevation between pixel
centres is bilinear, so a CSV of the same profile gives the same section.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd


class SiteError(ValueError):
    """A site's input is missing, unreadable or inconsistent; the message names the key, file or value."""


@dataclass
class Section:
    """Ground elevation along a section line; map coordinates where the section came from a DEM."""

    chainage_m: np.ndarray
    elevation_m: np.ndarray
    line: np.ndarray | None = None  # [k, 2] vertices of the section line in the CRS, or None (local frame)
    crs: str | None = None

    def map_points(self, chainage_m: np.ndarray) -> np.ndarray:
        """Map coordinates [n, 2] of chainages along the line (the local frame (chainage, 0) without one)."""
        chainage = np.asarray(chainage_m, dtype=float)
        if self.line is None:
            return np.column_stack([chainage, np.zeros_like(chainage)])
        return points_along(self.line, chainage)

    @property
    def length_m(self) -> float:
        return float(self.chainage_m[-1])


def cumulative_length(line: np.ndarray) -> np.ndarray:
    """Chainage of each vertex of a polyline, 0 at the first."""
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T))])


def points_along(line: np.ndarray, chainage_m: np.ndarray) -> np.ndarray:
    """Points of a polyline at the given distances along it from its first vertex."""
    knots = cumulative_length(line)
    return np.column_stack([np.interp(chainage_m, knots, line[:, 0]), np.interp(chainage_m, knots, line[:, 1])])


def chainage_grid(length_m: float, spacing_m: float) -> np.ndarray:
    """0, spacing, 2 spacing, ... up to the length (the last point at most one spacing short)."""
    return np.arange(0.0, length_m + 1e-9 * max(length_m, 1.0), spacing_m)


def read_csv_section(path: str | Path, spacing_m: float) -> Section:
    """A surveyed profile: columns ``chainage_m`` and ``elevation_m``, chainage strictly increasing."""
    try:
        table = pd.read_csv(path)
    except (OSError, ValueError) as error:
        raise SiteError(f"site.section.csv = {str(path)!r}: not a readable CSV ({error})") from error
    missing = {"chainage_m", "elevation_m"} - set(table.columns)
    if missing:
        raise SiteError(
            f"site.section.csv = {str(path)!r}: no column {', '.join(sorted(missing))} "
            f"(have: {', '.join(map(str, table.columns))})"
        )
    chainage = table["chainage_m"].to_numpy(float)
    elevation = table["elevation_m"].to_numpy(float)
    bad = np.flatnonzero(~np.isfinite(chainage) | ~np.isfinite(elevation))
    if bad.size:
        raise SiteError(
            f"site.section.csv = {str(path)!r}: row {bad[0] + 2} is not a number "
            f"(chainage {chainage[bad[0]]}, elevation {elevation[bad[0]]})"
        )
    steps = np.flatnonzero(np.diff(chainage) <= 0.0)
    if len(chainage) < 2 or steps.size:
        row = steps[0] + 3 if steps.size else 2
        raise SiteError(
            f"site.section.csv = {str(path)!r}: chainage must increase strictly, row {row} "
            f"has {chainage[min(row - 2, len(chainage) - 1)]} m after {chainage[max(row - 3, 0)]} m"
        )
    grid = chainage[0] + chainage_grid(chainage[-1] - chainage[0], spacing_m)
    return Section(chainage_m=grid - chainage[0], elevation_m=np.interp(grid, chainage, elevation))


def sample_dem(path: str | Path, line: np.ndarray, crs: str | None, spacing_m: float) -> Section:
    """Bilinear ground elevation of a north-up GeoTIFF at every ``spacing_m`` along a polyline.

    The line's points are in the raster's CRS (``crs``, when given, must be the raster's). Every
    sample must lie between pixel centres with data: the error names the first that does not.
    """
    import rasterio
    from rasterio.crs import CRS
    from scipy.interpolate import RegularGridInterpolator

    try:
        dataset = rasterio.open(path)
    except (OSError, rasterio.errors.RasterioIOError) as error:
        raise SiteError(f"site.section.dem = {str(path)!r}: not a readable raster ({error})") from error
    with dataset:
        elevation = dataset.read(1, masked=True)
        transform, raster_crs = dataset.transform, dataset.crs
    if transform.b != 0.0 or transform.d != 0.0:
        raise SiteError(f"site.section.dem = {str(path)!r}: a rotated raster is not supported (transform {transform})")
    if crs is not None:
        try:
            wanted = CRS.from_user_input(crs)
        except rasterio.errors.CRSError as error:
            raise SiteError(f"site.section.crs = {crs!r}: not a coordinate reference system ({error})") from error
        if raster_crs is None or wanted != raster_crs:
            raise SiteError(
                f"site.section.crs = {crs!r} does not match the CRS of site.section.dem = "
                f"{str(path)!r} ({raster_crs.to_string() if raster_crs else 'none'}); give the "
                "line in the raster's CRS"
            )
    line = np.asarray(line, dtype=float)
    if line.ndim != 2 or line.shape[1] != 2 or len(line) < 2 or np.any(np.diff(cumulative_length(line)) <= 0.0):
        raise SiteError(f"site.section.line = {line.tolist()}: two or more distinct [x, y] points are needed")
    chainage = chainage_grid(float(cumulative_length(line)[-1]), spacing_m)
    points = points_along(line, chainage)
    rows, cols = elevation.shape
    x_centres = transform.c + transform.a * (np.arange(cols) + 0.5)
    y_centres = transform.f + transform.e * (np.arange(rows) + 0.5)
    lo_x, hi_x = sorted((x_centres[0], x_centres[-1]))
    lo_y, hi_y = sorted((y_centres[0], y_centres[-1]))
    outside = np.flatnonzero(
        (points[:, 0] < lo_x) | (points[:, 0] > hi_x) | (points[:, 1] < lo_y) | (points[:, 1] > hi_y)
    )
    if outside.size:
        k = outside[0]
        raise SiteError(
            f"site.section.line: the point at chainage {chainage[k]:.2f} m ({points[k, 0]:.2f}, "
            f"{points[k, 1]:.2f}) lies outside the pixel centres of site.section.dem = {str(path)!r} "
            f"(x {lo_x:.2f} to {hi_x:.2f}, y {lo_y:.2f} to {hi_y:.2f})"
        )
    order = np.argsort(y_centres)  # the interpolator wants increasing axes; a north-up raster's rows run south
    missing = np.ma.getmaskarray(elevation) | ~np.isfinite(np.ma.getdata(elevation))

    def interpolate(grid: np.ndarray) -> np.ndarray:
        return RegularGridInterpolator((y_centres[order], x_centres), grid[order], method="linear")(points[:, ::-1])

    sampled = interpolate(np.where(missing, 0.0, np.ma.getdata(elevation).astype(float)))
    nodata = np.flatnonzero(interpolate(missing.astype(float)) > 1e-9)  # a no-data pixel with a non-zero weight
    if nodata.size:
        k = nodata[0]
        raise SiteError(
            f"site.section.dem = {str(path)!r}: no-data cells on the section line, first at chainage "
            f"{chainage[k]:.2f} m ({points[k, 0]:.2f}, {points[k, 1]:.2f}); {nodata.size} of "
            f"{chainage.size} samples"
        )
    return Section(
        chainage_m=chainage, elevation_m=sampled, line=line, crs=raster_crs.to_string() if raster_crs else None
    )


def read_section(section: dict, spacing_m: float) -> Section:
    """The section of config ``site.section``: a CSV, or a DEM and a line."""
    given = sorted(key for key in ("csv", "dem", "line") if section.get(key))
    if given not in (["csv"], ["dem", "line"]):
        raise SiteError(
            f"config key 'site.section' gives {', '.join(given) or 'nothing'}: give either csv, or dem and line"
        )
    if section.get("csv"):
        return read_csv_section(site_file(section["csv"]), spacing_m)
    return sample_dem(
        site_file(section["dem"]), np.asarray(section["line"], dtype=float), section.get("crs"), spacing_m
    )


def site_file(path: str) -> str:
    """A site file as given, or, where a relative path is not found from the working directory (a run
    with ``--directory``), from the repository root, where the example sites live."""
    given = Path(path)
    if given.is_absolute() or given.exists():
        return path
    from_repo = Path(__file__).resolve().parents[2] / given
    return str(from_repo) if from_repo.exists() else path
