"""GIS files of a site's hazard: zones as GeoJSON along the section line, exceedance per chainage as CSV,
and a map view over the DEM's hillshade.

Model x is chainage - ``chainage_from_m``; the files are in the section's CRS (a DEM's), or in the
local frame (chainage, 0) for a CSV section, which the GeoJSON says in its ``frame`` member.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.colors import LightSource  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from rgns.hazard.plots import ZONE_COLOURS  # noqa: E402
from rgns.hazard.statistics import ZONE_LEVELS, clopper_pearson  # noqa: E402
from rgns.scene.site_section import Section, cumulative_length, site_file  # noqa: E402
from rgns.tables import write_csv  # noqa: E402

LOCAL_FRAME = (
    "local: x is the chainage along the section (m) from its first point, y is 0; the section "
    "has no coordinate reference system (a CSV cross-section)"
)
# an engineering CRS, so that a GIS does not take the local frame for longitude and latitude (GeoJSON's default)
LOCAL_CRS = 'LOCAL_CS["rgns section frame: x = chainage (m), y = 0",UNIT["metre",1]]'


def modelled_range(section: Section, chainage_from_m: float, domain_length_m: float) -> tuple[float, float]:
    """The chainages that both the section and the model domain cover."""
    return chainage_from_m, min(section.length_m, chainage_from_m + domain_length_m)


def _line_through(section: Section, start: float, end: float) -> list[list[float]]:
    """The section line from chainage ``start`` to ``end``, through every vertex between."""
    knots = cumulative_length(section.line) if section.line is not None else np.array([])
    inner = knots[(knots > start) & (knots < end)]
    return section.map_points(np.concatenate([[start], inner, [end]])).tolist()


def best_estimate_zoning(zoning: dict[str, Any], correction: dict[str, Any] | None) -> dict[str, Any]:
    """The zoning the GIS files carry: the best estimate's zones where the case was corrected by MPM pairs
    (``correction``: its multifidelity.json; at the converged mesh where the mesh extrapolation ran, else at
    the accurate mesh), the Monte Carlo simulator's own otherwise; ``basis`` says which."""
    if correction is None:
        return zoning | {"basis": "the Monte Carlo's simulator, uncorrected (no MPM pairs)"}
    high = correction["high_cell_size_m"]
    if "converged" in correction:
        zones = correction["converged"]["zoning"]["zones"]
        basis = f"the best estimate: corrected to the MPM at {high:g} m cells and carried to the converged mesh"
    else:
        zones = correction["zoning"]["zones_corrected"]
        basis = f"the best estimate: corrected to the MPM at {high:g} m cells"
    return zoning | {"zones": zones, "basis": basis}


def zone_features(
    zoning: dict[str, Any], section: Section, chainage_from_m: float, domain_length_m: float, name: str
) -> dict[str, Any]:
    """A GeoJSON FeatureCollection: one LineString per contiguous zone, in chainage order (``basis``, where
    the zoning gives one, recorded as what the zones rest on)."""
    low, high = modelled_range(section, chainage_from_m, domain_length_m)
    features = []
    for zone in zoning["zones"]:
        start = max(low, chainage_from_m + zone["x_from_m"])
        end = min(high, chainage_from_m + zone["x_to_m"])
        if end <= start:
            continue
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "LineString", "coordinates": _line_through(section, start, end)},
                "properties": {
                    "site": name,
                    "level": zone["level"],
                    "rank": ZONE_LEVELS.index(zone["level"]),
                    "probability": zoning["levels"][zone["level"]],
                    "chainage_from_m": round(start, 6),
                    "chainage_to_m": round(end, 6),
                },
            }
        )
    collection: dict[str, Any] = {"type": "FeatureCollection", "name": f"{name}_zones", "features": features}
    if "basis" in zoning:
        collection["zones_from"] = zoning["basis"]
    collection["crs"] = {"type": "name", "properties": {"name": section.crs or LOCAL_CRS}}
    if not section.crs:
        collection["frame"] = LOCAL_FRAME
    return collection


def exceedance_by_chainage(
    table: pd.DataFrame,
    section: Section,
    chainage_from_m: float,
    domain_length_m: float,
    resolution_m: float,
    confidence: float,
) -> pd.DataFrame:
    """P(D > d) with its interval at every chainage point: runout beyond the toe, retreat behind the crest.

    A point at chainage c ahead of the toe is exceeded by runout when a realization's front passes
    it (D = front - toe > c - toe); one behind the crest when the back scarp retreats past it.
    ``table`` holds the finished realizations (front and rear NaN where nothing moved).
    """
    low, high = modelled_range(section, chainage_from_m, domain_length_m)
    x = np.arange(0.0, high - low + 1e-9, resolution_m)
    n = len(table)
    toe, crest = float(table["toe_x_m"].iloc[0]), float(table["crest_x_m"].iloc[0])
    front = table["front_x_m"].to_numpy(float)
    rear = table["rear_x_m"].to_numpy(float)
    points = section.map_points(low + x)
    frame = pd.DataFrame({"chainage_m": low + x, "x_m": x, "map_x": points[:, 0], "map_y": points[:, 1]})
    for label, ahead, distance, count in (
        ("runout", x >= toe, x - toe, (front[None, :] > x[:, None]).sum(axis=1)),
        ("retreat", x <= crest, crest - x, (rear[None, :] < x[:, None]).sum(axis=1)),
    ):
        lower, upper = clopper_pearson(count, n, confidence)
        frame[f"{label}_distance_m"] = np.where(ahead, distance, np.nan)
        frame[f"p_{label}"] = np.where(ahead, count / n, np.nan)
        frame[f"p_{label}_low"] = np.where(ahead, lower, np.nan)
        frame[f"p_{label}_high"] = np.where(ahead, upper, np.nan)
    return frame


def _scale_bar(axis: plt.Axes, width_m: float) -> None:
    """A bar of a round length (1, 2 or 5 x 10^k m) near a fifth of the map's width, lower left."""
    target = width_m / 5.0
    magnitude = 10.0 ** np.floor(np.log10(target))
    length = max(m for m in (1.0, 2.0, 5.0) if m * magnitude <= target) * magnitude
    x0, x1 = axis.get_xlim()
    y0, y1 = axis.get_ylim()
    left, bottom = x0 + 0.05 * (x1 - x0), y0 + 0.06 * (y1 - y0)
    axis.plot([left, left + length], [bottom, bottom], color="black", linewidth=4, solid_capstyle="butt")
    axis.text(
        left + length / 2,
        bottom + 0.02 * (y1 - y0),
        f"{length:g} m",
        ha="center",
        va="bottom",
        fontsize=9,
        bbox={"facecolor": "white", "alpha": 0.7, "edgecolor": "none"},
    )


def plot_map_view(
    dem_path: str | Path,
    section: Section,
    features: dict[str, Any],
    levels: dict[str, str],
    name: str,
    path: str | Path,
) -> None:
    """Hillshade over grey-blue elevation tints (no hue a hazard level uses), the section line coloured by hazard level, a scale bar and the CRS.

    ``levels`` maps each hazard level to its probability range (zoning.json's ``levels``).
    """
    import rasterio

    with rasterio.open(dem_path) as dataset:
        elevation = dataset.read(1, masked=True).astype(float)
        bounds = dataset.bounds
        resolution = dataset.res
    filled = np.ma.filled(elevation, float(elevation.mean()))
    shade = LightSource(azdeg=315, altdeg=45).hillshade(filled, vert_exag=1.0, dx=resolution[0], dy=resolution[1])
    figure, axis = plt.subplots(figsize=(8, 8 * (bounds.top - bounds.bottom) / (bounds.right - bounds.left) + 1))
    extent = (bounds.left, bounds.right, bounds.bottom, bounds.top)
    axis.imshow(filled, cmap="bone", extent=extent, origin="upper", vmin=filled.min() - 0.6 * np.ptp(filled))
    axis.imshow(shade, cmap="gray", extent=extent, origin="upper", alpha=0.45)
    contours = axis.contour(
        np.linspace(bounds.left, bounds.right, elevation.shape[1]),
        np.linspace(bounds.top, bounds.bottom, elevation.shape[0]),
        elevation,
        levels=10,
        colors="saddlebrown",
        linewidths=0.5,
        alpha=0.6,
    )
    axis.clabel(contours, fontsize=7, fmt="%.0f m")
    axis.plot(*section.line.T, color="black", linewidth=7, solid_capstyle="butt")
    segments = [np.asarray(f["geometry"]["coordinates"]) for f in features["features"]]
    colours = [ZONE_COLOURS[f["properties"]["rank"]] for f in features["features"]]
    axis.add_collection(LineCollection(segments, colors=colours, linewidths=5))
    axis.annotate("section start", section.line[0], xytext=(-10, 10), textcoords="offset points", fontsize=8)
    axis.ticklabel_format(useOffset=False, style="plain")
    axis.set_xlim(extent[:2])
    axis.set_ylim(extent[2:])
    axis.set_aspect("equal")
    _scale_bar(axis, bounds.right - bounds.left)
    axis.text(
        0.99,
        0.01,
        f"CRS {section.crs}",
        transform=axis.transAxes,
        ha="right",
        va="bottom",
        fontsize=9,
        bbox={"facecolor": "white", "alpha": 0.7, "edgecolor": "none"},
    )
    axis.set_xlabel("easting (m)")
    axis.set_ylabel("northing (m)")
    handles = [
        Line2D([], [], color=c, linewidth=5, label=f"{level} ({levels[level]})")
        for c, level in zip(ZONE_COLOURS, ZONE_LEVELS)
    ]
    axis.legend(handles=handles, loc="upper right", fontsize=8, title="hazard level", title_fontsize=8)
    axis.set_title(f"{name}: hazard zones along the section (black: outside the model)")
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def write_site_gis(
    table: pd.DataFrame, zoning: dict[str, Any], section: Section, settings: dict[str, Any], outputs: dict[str, str]
) -> dict[str, Any]:
    """zones.geojson, exceedance.csv and (for a DEM, ``settings["section"]["dem"]``) map.png of one site."""
    features = zone_features(
        zoning, section, settings["chainage_from_m"], settings["domain_length_m"], settings["name"]
    )
    Path(outputs["zones"]).write_text(json.dumps(features, indent=1) + "\n")
    write_csv(
        exceedance_by_chainage(
            table,
            section,
            settings["chainage_from_m"],
            settings["domain_length_m"],
            settings["resolution_m"],
            settings["confidence"],
        ),
        outputs["exceedance"],
    )
    if "map" in outputs:
        plot_map_view(
            site_file(settings["section"]["dem"]), section, features, zoning["levels"], settings["name"], outputs["map"]
        )
    return features
