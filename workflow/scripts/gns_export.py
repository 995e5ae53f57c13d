"""Rule gns_export: the packed train / valid sets in the geoelements/gns layout."""

from pathlib import Path

from rgns.logsetup import log_to_file
from rgns.surrogates.gns_export import export_gns

log = log_to_file(snakemake.log[0])
export_gns(
    {"train": snakemake.input.train, "valid": snakemake.input.valid},
    Path(snakemake.output.metadata).parent,
    snakemake.params.radius_m,
)
log.info("wrote %s", ", ".join(snakemake.output))
