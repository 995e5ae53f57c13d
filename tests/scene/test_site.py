"""A real site in (CSV section or DEM + line), GIS files out; every bad input named."""

from __future__ import annotations

import json
import logging
import shutil
import struct
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import rasterio
from conftest import REPO, TINY_CONFIG
from rasterio.transform import Affine
from workflow_helpers import scheduled, scheduled_routes, snakemake, write_config

from rgns.config import ConfigError, load_yaml, validate_config
from rgns.hazard.site_gis import best_estimate_zoning, exceedance_by_chainage, write_site_gis
from rgns.scene.geometry import build_scene
from rgns.scene.site_section import Section, SiteError, cumulative_length, read_section, sample_dem, site_file

WEST, NORTH, PIXEL = 1000.0, 2060.0, 1.0  # raster origin (m) and pixel size of the test DEMs
CRS = "EPSG:32632"


def profile(u: np.ndarray) -> np.ndarray:
    """A slope 5.5 m high with a break, piecewise linear with kinks on whole metres (pixel centres + 0.5)."""
    return np.interp(u, [0.0, 8.0, 11.0, 14.0, 60.0], [105.5, 105.5, 103.0, 100.0, 99.0])


def write_dem(path: Path, width: int = 60, height: int = 20, nodata_at: tuple[int, int] | None = None) -> Path:
    """A north-up DEM whose elevation depends on easting only: profile(easting - (WEST + 0.5))."""
    easting = WEST + PIXEL * (np.arange(width) + 0.5)
    elevation = np.tile(profile(easting - (WEST + 0.5)), (height, 1)).astype("float64")
    if nodata_at is not None:
        elevation[nodata_at] = -9999.0
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        width=width,
        height=height,
        count=1,
        dtype="float64",
        crs=CRS,
        transform=Affine(PIXEL, 0.0, WEST, 0.0, -PIXEL, NORTH),
        nodata=-9999.0,
    ) as dataset:
        dataset.write(elevation, 1)
    return path


def site_config(tmp_path: Path, **site: object) -> dict:
    """The tiny config with its sets replaced by a DEM site (a column of pixel centres as the line)."""
    config = load_yaml(TINY_CONFIG)
    config["site"] = {
        "name": "hill",
        "section": {
            "dem": str(write_dem(tmp_path / "dem.tif")),
            "crs": CRS,
            "line": [[WEST + 0.5, NORTH - 10.5], [WEST + 59.5, NORTH - 10.5]],
        },
        "base_elevation_m": 100.0,
        "extent_m": [0.0, 30.0],
        "realizations": 2,
        "friction_mean_deg": 30.0,
        "friction_std_deg": 5.0,
        "correlation_length_x_m": 8.0,
        "correlation_length_y_m": 4.0,
    } | site
    config["montecarlo"]["cases"] = ["hill"]
    return config


def config_error(config: dict) -> str:
    with pytest.raises(ConfigError) as error:
        validate_config(config)
    return str(error.value)


def test_a_csv_section_and_the_dem_sampled_along_the_same_line_give_the_same_scene(tmp_path):
    dem_config = validate_config(site_config(tmp_path))
    csv = tmp_path / "section.csv"
    u = np.arange(0.0, 60.0)
    pd.DataFrame({"chainage_m": u, "elevation_m": profile(u)}).to_csv(csv, index=False)
    csv_config = site_config(tmp_path)
    csv_config["site"]["section"] = {"csv": str(csv)}
    csv_config = validate_config(csv_config)
    vertices = [
        np.array([[v["x_m"], v["y_m"]] for v in c["geometry"]["families"]["hill"]["vertices"]])
        for c in (dem_config, csv_config)
    ]
    np.testing.assert_allclose(vertices[0], vertices[1], atol=1e-9)
    # the body: from x = 0 to the toe at chainage 14 (the ground reaches the base there), 5.5 m high
    assert vertices[0][:, 0].max() == pytest.approx(14.0) and vertices[0][:, 1].max() == pytest.approx(5.5)
    scenes = [
        build_scene(
            "hill", 0, "hill", c["geometry"]["families"]["hill"], c["domain"], c["mesh"], c["geometry"], c["seed"]
        )
        for c in (dem_config, csv_config)
    ]
    np.testing.assert_array_equal(scenes[0].positions, scenes[1].positions)
    assert scenes[0].area_m2 == pytest.approx(8 * 5.5 + 3 * 4.25 + 3 * 1.5, rel=1e-9)
    assert dem_config["sets"]["hill"][0]["count"] == 2


def test_the_dem_is_sampled_bilinearly_along_an_oblique_line(tmp_path):
    dem = write_dem(tmp_path / "dem.tif")
    line = np.array([[WEST + 2.5, NORTH - 3.5], [WEST + 30.5, NORTH - 17.5], [WEST + 50.5, NORTH - 12.5]])
    section = sample_dem(dem, line, CRS, 0.5)
    points = section.map_points(section.chainage_m)
    np.testing.assert_allclose(section.elevation_m, profile(points[:, 0] - (WEST + 0.5)), atol=1e-9)
    assert section.length_m == pytest.approx(cumulative_length(line)[-1], abs=0.5)
    assert section.crs == CRS


def _linestrings(path: Path) -> tuple[dict, list[np.ndarray], pd.DataFrame]:
    """A GeoJSON read back by GDAL (pyogrio): metadata, LineString vertices from WKB, attributes."""
    pyogrio = pytest.importorskip("pyogrio")
    meta, _, geometry, fields = pyogrio.raw.read(path)
    lines = []
    for blob in geometry:
        order = "<" if blob[0] == 1 else ">"
        kind, count = struct.unpack(order + "II", blob[1:9])
        assert kind % 1000 == 2, "not a LineString"
        lines.append(np.frombuffer(blob[9 : 9 + 16 * count], dtype=order + "f8").reshape(count, 2))
    return meta, lines, pd.DataFrame({name: column for name, column in zip(meta["fields"], fields)})


def _distance_to_polyline(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    a, b = line[:-1], line[1:]
    d = b - a
    t = np.clip(((points[:, None, :] - a) * d).sum(-1) / (d * d).sum(-1), 0.0, 1.0)
    nearest = a + t[..., None] * d
    return np.linalg.norm(points[:, None, :] - nearest, axis=-1).min(axis=1)


ZONING = {
    "levels": {
        "extremely high": "P ≥ 0.9",
        "high": "0.5 ≤ P < 0.9",
        "moderate": "0.1 ≤ P < 0.5",
        "low": "0.01 ≤ P < 0.1",
        "extremely low": "P < 0.01",
    },
    "zones": [
        {"level": "extremely low", "x_from_m": 0.0, "x_to_m": 3.5},
        {"level": "high", "x_from_m": 3.5, "x_to_m": 12.5},
        {"level": "extremely high", "x_from_m": 12.5, "x_to_m": 21.0},
        {"level": "moderate", "x_from_m": 21.0, "x_to_m": 27.25},
        {"level": "extremely low", "x_from_m": 27.25, "x_to_m": 40.0},
    ],
}


def _table() -> pd.DataFrame:
    """Four finished realizations: fronts at 20, 24, 30 m, one that did not move."""
    return pd.DataFrame(
        {
            "index": range(4),
            "status": "ok",
            "toe_x_m": 14.0,
            "crest_x_m": 8.0,
            "front_x_m": [20.0, 24.0, 30.0, np.nan],
            "rear_x_m": [6.0, 4.0, 7.0, np.nan],
        }
    )


def _hill_site(tmp_path: Path) -> tuple[np.ndarray, Section, dict, dict]:
    """A DEM section line with a bend, the site's settings (modelled from chainage 5 m over 40 m) and outputs."""
    dem = write_dem(tmp_path / "dem.tif")
    line = np.array([[WEST + 2.5, NORTH - 3.5], [WEST + 20.5, NORTH - 15.5], [WEST + 50.5, NORTH - 12.5]])
    section = sample_dem(dem, line, CRS, 1.0)
    outputs = {
        "zones": tmp_path / "zones.geojson",
        "exceedance": tmp_path / "exceedance.csv",
        "map": tmp_path / "map.png",
    }
    settings = {
        "name": "hill",
        "chainage_from_m": 5.0,
        "domain_length_m": 40.0,
        "resolution_m": 0.25,
        "confidence": 0.95,
        "section": {"dem": str(dem)},
    }
    return line, section, settings, outputs


def test_zones_geojson_reads_back_in_gdal_with_the_crs_on_the_line_and_in_order(tmp_path):
    line, section, settings, outputs = _hill_site(tmp_path)
    write_site_gis(_table(), ZONING, section, settings, outputs)
    meta, lines, attributes = _linestrings(outputs["zones"])
    assert meta["crs"] == CRS and meta["geometry_type"] == "LineString"
    assert list(attributes["level"]) == [z["level"] for z in ZONING["zones"]]
    for coordinates in lines:
        assert _distance_to_polyline(coordinates, line).max() < 1e-6
    # in order and without gaps: each zone starts where the last ended, on the line and in chainage
    np.testing.assert_allclose(attributes["chainage_from_m"][1:], attributes["chainage_to_m"][:-1])
    for k in range(1, len(lines)):
        np.testing.assert_allclose(lines[k][0], lines[k - 1][-1], atol=1e-9)
    assert attributes["chainage_from_m"].iloc[0] == 5.0
    assert attributes["chainage_to_m"].iloc[-1] == pytest.approx(min(section.length_m, 45.0))
    np.testing.assert_allclose(lines[0][0], line[0] + 5.0 * (line[1] - line[0]) / np.linalg.norm(line[1] - line[0]))
    # the line's bend (at chainage 21.6) is a vertex of the zone that spans it
    assert any(np.min(np.linalg.norm(c - line[1], axis=1)) < 1e-9 for c in lines)
    assert outputs["map"].stat().st_size > 10_000


def test_the_map_view_draws_each_zone_on_the_section_in_its_levels_colour(tmp_path, monkeypatch):
    """Read back from the map's axes: one coloured segment per GeoJSON zone, on the zone's own coordinates, in
    the colour of its level (red for extremely high … green for extremely low, as the section's zoning figure),
    the legend naming each level with its probability range, the CRS and a scale bar. Fails with the colours
    reversed or the segments drawn from the wrong zone."""
    import matplotlib.collections
    import matplotlib.pyplot as plt

    from rgns.hazard.statistics import ZONE_COLOURS, ZONE_LEVELS

    kept = []
    monkeypatch.setattr(plt, "close", kept.append)
    _, section, settings, outputs = _hill_site(tmp_path)
    features = write_site_gis(_table(), ZONING, section, settings, outputs)["features"]
    (figure,) = kept
    (axis,) = [a for a in figure.axes if a.get_legend() is not None]
    (zones,) = [
        c
        for c in axis.collections
        if isinstance(c, matplotlib.collections.LineCollection)
        and c.get_segments()
        and len(c.get_segments()) == len(features)
    ]
    for segment, colour, feature in zip(zones.get_segments(), zones.get_colors(), features, strict=True):
        np.testing.assert_allclose(segment, feature["geometry"]["coordinates"])
        level = feature["properties"]["level"]
        assert tuple(colour) == pytest.approx(matplotlib.colors.to_rgba(ZONE_COLOURS[ZONE_LEVELS.index(level)]))
    legend = [text.get_text() for text in axis.get_legend().get_texts()]
    assert legend == [f"{level} ({ZONING['levels'][level]})" for level in ZONE_LEVELS]
    texts = [text.get_text() for text in axis.texts]
    assert f"CRS {CRS}" in texts and any(text.endswith(" m") for text in texts)


def test_a_csv_section_has_no_map_crs_and_its_geojson_says_it_is_in_the_local_frame(tmp_path):
    csv = tmp_path / "section.csv"
    pd.DataFrame({"chainage_m": [0.0, 10.0, 60.0], "elevation_m": [105.0, 105.0, 99.0]}).to_csv(csv, index=False)
    section = read_section({"csv": str(csv)}, 1.0)
    outputs = {"zones": tmp_path / "zones.geojson", "exceedance": tmp_path / "exceedance.csv"}
    settings = {
        "name": "hill",
        "chainage_from_m": 0.0,
        "domain_length_m": 40.0,
        "resolution_m": 1.0,
        "confidence": 0.95,
    }
    write_site_gis(_table(), ZONING, section, settings, outputs)
    record = json.loads(outputs["zones"].read_text())
    assert record["frame"].startswith("local")
    meta, lines, _ = _linestrings(outputs["zones"])
    assert meta["crs"].startswith('LOCAL_CS["rgns section frame')  # not GeoJSON's default WGS 84
    assert all(np.all(c[:, 1] == 0.0) for c in lines)


def test_the_gis_zones_are_the_best_estimate_where_mpm_pairs_corrected_the_case():
    """The zones a GIS user takes: at the converged mesh where the mesh extrapolation ran, at the accurate mesh
    where only the correction ran, the simulator's own (and said so) without pairs."""
    converged = [{"level": "extremely high", "x_from_m": 0.0, "x_to_m": 30.0}]
    corrected = [{"level": "high", "x_from_m": 0.0, "x_to_m": 30.0}]
    record = {"high_cell_size_m": 0.5, "zoning": {"zones_corrected": corrected}}
    assert best_estimate_zoning(ZONING, None)["zones"] == ZONING["zones"]
    assert "uncorrected" in best_estimate_zoning(ZONING, None)["basis"]
    only = best_estimate_zoning(ZONING, record)
    assert only["zones"] == corrected and only["basis"].endswith("MPM at 0.5 m cells")
    both = best_estimate_zoning(ZONING, record | {"converged": {"zoning": {"zones": converged}}})
    assert both["zones"] == converged and both["basis"].endswith("converged mesh")
    assert both["levels"] == ZONING["levels"]


def test_exceedance_per_chainage_counts_the_fronts_past_a_point_and_the_scarps_behind_it():
    section = Section(chainage_m=np.arange(0.0, 61.0), elevation_m=np.zeros(61))
    frame = exceedance_by_chainage(_table(), section, 2.0, 40.0, 1.0, 0.95).set_index("x_m")
    # fronts 20, 24, 30 of 4: P(front > x) ahead of the toe (14 m); behind it no runout is defined
    assert np.isnan(frame.loc[13.0, "p_runout"])
    assert frame.loc[14.0, "p_runout"] == 0.75 and frame.loc[22.0, "p_runout"] == 0.5
    assert frame.loc[30.0, "p_runout"] == 0.0 and frame.loc[22.0, "runout_distance_m"] == 8.0
    # scarps at 4, 6, 7: P(rear < x) behind the crest (8 m)
    assert frame.loc[5.0, "p_retreat"] == 0.25 and frame.loc[8.0, "p_retreat"] == 0.75
    assert frame.loc[5.0, "retreat_distance_m"] == 3.0 and np.isnan(frame.loc[9.0, "p_retreat"])
    assert frame.loc[22.0, "chainage_m"] == 24.0
    inside = frame.dropna(subset=["p_runout"])
    assert np.all((inside["p_runout_low"] <= inside["p_runout"]) & (inside["p_runout"] <= inside["p_runout_high"]))


def test_the_example_site_config_loads_and_its_dem_is_what_its_script_writes(tmp_path):
    config = validate_config(load_yaml(REPO / "config" / "site.yaml"))
    assert config["montecarlo"]["cases"] == ["hillside"] and "hillside" in config["geometry"]["families"]
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_dem", REPO / "config" / "sites" / "hillside" / "make_dem.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.main(tmp_path / "dem.tif")
    with (
        rasterio.open(tmp_path / "dem.tif") as ours,
        rasterio.open(REPO / "config" / "sites" / "hillside" / "dem.tif") as shipped,
    ):
        np.testing.assert_array_equal(ours.read(1), shipped.read(1))
        assert ours.crs == shipped.crs and ours.transform == shipped.transform


# ---- bad input: each named, nothing half-done -------------------------------------------------------


def test_a_section_line_outside_the_raster_is_named(tmp_path):
    config = site_config(tmp_path)
    config["site"]["section"]["line"] = [[WEST + 0.5, NORTH - 10.5], [WEST + 80.5, NORTH - 10.5]]
    message = config_error(config)
    assert "site.section.line" in message and "outside" in message and "chainage 60.00 m" in message


def test_no_data_on_the_line_is_named_with_its_chainage(tmp_path):
    config = site_config(tmp_path)
    write_dem(Path(config["site"]["section"]["dem"]), nodata_at=(10, 20))
    message = config_error(config)
    assert "no-data cells on the section line, first at chainage 20.00 m" in message and "1 of 60 samples" in message


def test_a_crs_mismatch_is_named(tmp_path):
    config = site_config(tmp_path)
    config["site"]["section"]["crs"] = "EPSG:4326"
    message = config_error(config)
    assert "site.section.crs = 'EPSG:4326' does not match" in message and "EPSG:32632" in message


def test_non_increasing_chainage_is_named_with_its_row(tmp_path):
    csv = tmp_path / "section.csv"
    pd.DataFrame({"chainage_m": [0.0, 10.0, 10.0, 30.0], "elevation_m": [105.0, 105.0, 101.0, 99.0]}).to_csv(
        csv, index=False
    )
    config = site_config(tmp_path)
    config["site"]["section"] = {"csv": str(csv)}
    message = config_error(config)
    assert "chainage must increase strictly, row 4 has 10.0 m after 10.0 m" in message


def test_a_base_above_the_surface_is_named(tmp_path):
    config = site_config(tmp_path, base_elevation_m=106.0)
    message = config_error(config)
    assert "site.base_elevation_m = 106.0: at or above the ground surface (105.50 m)" in message


def test_a_section_no_field_can_fail_warns(tmp_path, caplog):
    config = site_config(tmp_path, friction_mean_deg=60.0, friction_std_deg=2.0)
    with caplog.at_level(logging.WARNING, logger="rgns.scene.site"):
        validate_config(config)
    assert (
        "no realization is likely to fail" in caplog.text and "steepest face of the section is 45.0 deg" in caplog.text
    )


def test_a_site_too_large_for_the_domain_says_how_many_particles_it_would_be(tmp_path):
    config = site_config(tmp_path, base_elevation_m=90.0)  # 15.5 m high in a 10 m domain
    message = config_error(config)
    assert "site: the soil body (30.0 m long, 15.5 m high)" in message
    assert "needs a domain of at least 38.0 x 16.5 m" in message and "material points" in message


def test_a_site_named_like_a_set_is_refused(tmp_path):
    config = site_config(tmp_path, name="case1")
    assert "config key 'site.name' = 'case1': already used by sets.case1" in config_error(config)


def test_a_site_needs_a_csv_or_a_dem_with_a_line(tmp_path):
    config = site_config(tmp_path)
    config["site"]["section"] = {"dem": config["site"]["section"]["dem"]}
    assert "config key 'site.section' gives dem: give either csv, or dem and line" in config_error(config)
    config["site"]["section"]["csv"] = "section.csv"
    assert "config key 'site.section' gives csv, dem: give either" in config_error(config)
    with pytest.raises(SiteError, match="not a readable CSV"):
        read_section({"csv": str(tmp_path / "missing.csv")}, 1.0)


@pytest.mark.workflow
def test_a_dem_site_runs_through_the_workflow_to_its_gis_files_and_its_map_in_the_report(built, tmp_path):
    """The tiny run with a site added: the site's chain and the validation run again, no training."""
    workdir, _ = built
    work = tmp_path / "work"
    shutil.copytree(workdir, work, symlinks=True)
    config = site_config(tmp_path)
    config["montecarlo"]["cases"] = ["case1", "hill"]
    path = write_config(tmp_path / "site.yaml", config)
    dry_run = snakemake(work, "-n", "hazard_map", config=path)
    plan, routes = scheduled(dry_run), scheduled_routes(dry_run)
    assert "train" not in plan and plan["site_gis"] == 1 and plan["geometry"] == 2
    # the site's chunks alone: the validation gate is decided anew over both cases, and decides nothing
    # (validation.acceptance.on_failure: report), so case 1's chunks stand
    assert routes == {"realizations": 3, "mean_field": 1, "paired": 1, "paired_coarse": 1}
    assert plan["validate"] == 1 and plan["validation_rollout"] == 1
    result = snakemake(work, "--cores", "2", "hazard_map", config=path)
    assert result.returncode == 0, result.stderr[-3000:]
    site = work / "results" / "site" / "hill"
    # the GeoJSON's zones are the best estimate's, corrected by the site's MPM pairs
    record = json.loads((work / "results" / "report" / "hill" / "multifidelity.json").read_text())
    best = record["converged"]["zoning"]["zones"] if "converged" in record else record["zoning"]["zones_corrected"]
    collection = json.loads((site / "zones.geojson").read_text())
    assert collection["zones_from"].startswith("the best estimate")
    assert [f["properties"]["level"] for f in collection["features"]] == [
        zone["level"] for zone in best if min(zone["x_to_m"], 40.0) > zone["x_from_m"]
    ]
    meta, lines, attributes = _linestrings(site / "zones.geojson")
    assert meta["crs"] == CRS and attributes["chainage_from_m"].iloc[0] == 0.0
    assert attributes["chainage_to_m"].iloc[-1] == pytest.approx(40.0)  # the domain's length along the line
    line = np.array(config["site"]["section"]["line"])
    assert all(_distance_to_polyline(c, line).max() < 1e-6 for c in lines)
    table = pd.read_csv(site / "exceedance.csv")
    assert table["chainage_m"].iloc[0] == 0.0 and table["p_runout"].dropna().is_monotonic_decreasing
    scenes = [json.loads(p.read_text()) for p in sorted((work / "results" / "geometry" / "hill").glob("*.json"))]
    assert len(scenes) == 2 and scenes[0]["positions"] == scenes[1]["positions"]  # one geometry, no perturbation
    page = (work / "results" / "report" / "report.html").read_text()
    # the map view is drawn from the best estimate's zones: it is part of the site's answer, not of the
    # Monte Carlo's own (uncorrected) map among the details
    answer = page[page.index("hill: the answer at") : page.index("hill: the evidence</h2>")]
    assert 'alt="map.png"' in answer and "Site: hill — map view" not in page


def test_a_section_that_rises_along_its_line_is_refused_with_the_way_round(tmp_path):
    config = site_config(tmp_path)
    config["site"]["section"]["line"] = config["site"]["section"]["line"][::-1]
    config["site"]["base_elevation_m"] = 98.0
    message = config_error(config)
    assert (
        "the ground rises from 99.02 m at chainage 0.0 m to 99.67 m at 30.0 m: give" in message
        and "from the top of the slope" in message
    )


def test_without_a_domain_section_the_domain_is_sized_to_the_site(tmp_path):
    config = site_config(tmp_path)
    del config["domain"]
    # the site alone (the tiny families need 40 m), trained on from scratch: the shipped GNS serves 80 x 20 m only
    group = {
        "family": "hill",
        "count": 1,
        "friction_mean_deg": 30.0,
        "friction_std_deg": 5.0,
        "correlation_length_x_m": 8.0,
        "correlation_length_y_m": 4.0,
    }
    config["sets"], config["geometry"]["families"] = {"train": [group], "valid": [group]}, {}
    config = validate_config(config)
    # the body 14 m long and 5.5 m high, 8 m of runout room, a cell of head room, whole 1 m cells
    assert config["domain"] == {"length_m": 22.0, "height_m": 7.0}
    assert validate_config(site_config(tmp_path))["domain"] == {"length_m": 40.0, "height_m": 10.0}  # given: kept


def test_a_base_given_as_a_depth_below_the_ground_at_the_start_is_flat_there(tmp_path):
    by_elevation = validate_config(site_config(tmp_path))["geometry"]["families"]["hill"]
    config = site_config(tmp_path, base_depth_m=5.5)
    del config["site"]["base_elevation_m"]
    assert validate_config(config)["geometry"]["families"]["hill"]["vertices"] == by_elevation["vertices"]
    config = site_config(tmp_path, base_depth_m=5.5)
    assert "gives base_elevation_m and base_depth_m: give exactly one" in config_error(config)
    del config["site"]["base_elevation_m"], config["site"]["base_depth_m"]
    assert "gives neither base_elevation_m nor base_depth_m" in config_error(config)


def test_a_derived_domain_the_shipped_model_does_not_serve_is_refused_before_any_job(tmp_path):
    config = site_config(tmp_path)
    del config["domain"]
    config["sets"], config["geometry"]["families"] = {}, {}
    config["gns"]["model"] = "shipped"
    config["montecarlo"]["simulator"] = "gns"
    message = config_error(config)
    assert (
        "config key 'gns.model' = 'shipped': the shipped GNS does not serve this config: domain.length_m is 22.0"
        in message
    )


def test_a_derived_domain_within_the_end_state_surrogates_bounds_is_served(tmp_path):
    config = site_config(tmp_path)
    del config["domain"]
    config["sets"], config["geometry"]["families"] = {}, {}
    config.setdefault("mpm", {})["duration_s"] = 10.0  # the general model's run length
    config.setdefault("montecarlo", {})["simulator"] = "endstate"
    config.setdefault("endstate", {})["model"] = "general"
    config["gns"]["model"] = "shipped"  # no GNS training sets; the shipped GNS is not used beside the end-state route
    assert validate_config(config)["domain"] == {"length_m": 22.0, "height_m": 7.0}


def test_a_relative_site_file_not_found_from_the_working_directory_is_taken_from_the_repository(tmp_path, monkeypatch):
    """A run with --directory elsewhere still finds the example site's DEM the config names relative to the repo."""
    monkeypatch.chdir(tmp_path)
    found = Path(site_file("config/sites/hillside/dem.tif"))
    assert found.is_absolute() and found.exists() and found.samefile(REPO / "config" / "sites" / "hillside" / "dem.tif")
    assert site_file("config/sites/no_such.tif") == "config/sites/no_such.tif"
