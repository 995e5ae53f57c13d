"""Rule site_gis: a site's zones as GeoJSON, exceedance per chainage as CSV, and its map view."""

import json
from pathlib import Path

from rgns.hazard.outputs import finished
from rgns.hazard.site_gis import best_estimate_zoning, write_site_gis
from rgns.logsetup import log_to_file
from rgns.scene.site_section import read_section
from rgns.tables import read_csv

log = log_to_file(snakemake.log[0])
settings = snakemake.params[0]
table = finished(
    read_csv(snakemake.input.realizations, ["index", "status", "toe_x_m", "crest_x_m", "rear_x_m", "front_x_m"])
)
section = read_section(settings["section"], settings["cell_size_m"])
correction = json.loads(Path(snakemake.input.correction[0]).read_text()) if snakemake.input.correction else None
zoning = best_estimate_zoning(json.loads(Path(snakemake.input.zoning).read_text()), correction)
features = write_site_gis(table, zoning, section, settings, dict(snakemake.output.items()))
log.info("zones from %s", zoning["basis"])
for feature in features["features"]:
    p = feature["properties"]
    log.info("%s: chainage %.2f to %.2f m", p["level"], p["chainage_from_m"], p["chainage_to_m"])
