# A real site's GIS files (config site): zones along the section line, exceedance per chainage, map view.
from rgns.scene.site_section import site_file

SITE = config.get("site")
# the GIS files of the site's Monte Carlo case (a map view only where a DEM was given)
SITE_FILES = (["zones.geojson", "exceedance.csv"] + (["map.png"] if SITE["section"].get("dem") else [])
              if SITE and SITE["name"] in MC_CASES else [])


def site_source(wildcards):
    """The file the site's ground profile is read from."""
    return site_file(SITE["section"].get("csv") or SITE["section"]["dem"])


def site_gis_params(wildcards):
    """The section, where the model sits on it, and the zoning grid."""
    hazard = config["hazard"]
    return {
        "name": SITE["name"],
        "section": SITE["section"],
        "cell_size_m": config["mesh"]["cell_size_m"],
        "chainage_from_m": float(SITE["extent_m"][0]),
        "domain_length_m": config["domain"]["length_m"],
        "resolution_m": hazard["zoning_resolution_m"],
        "confidence": hazard["confidence"],
    }


if SITE_FILES:

    localrules:
        site_gis,

    rule site_gis:
        """zones.geojson (one LineString per zone in the site's CRS: the best estimate's zones where MPM pairs
        corrected the case), exceedance.csv (P(D > d) per chainage for runout and retreat, by the Monte Carlo's
        simulator) and, for a DEM, the map view."""
        input:
            realizations="results/mc/{case}/realizations.csv",
            zoning="results/report/{case}/zoning.json",
            correction=[f"results/report/{{case}}/{name}" for name in MULTIFIDELITY_FILES if name.endswith(".json")],
            source=site_source,
        output:
            zones="results/site/{case}/zones.geojson",
            exceedance="results/site/{case}/exceedance.csv",
            **({"map": report("results/site/{case}/map.png", caption="../rgns/report/captions/site_map.rst",
                              category="Hazard")} if "map.png" in SITE_FILES else {}),
        params:
            site_gis_params,
        log:
            "logs/site_gis/{case}.log",
        conda:
            "../envs/rgns.yaml"
        script:
            "../workflow/scripts/site_gis.py"
