"""Rule zoning: five-level hazard zoning along the cross-section for one Monte Carlo case."""

from rgns.hazard.outputs import write_zoning
from rgns.logsetup import log_to_file
from rgns.tables import read_csv

log = log_to_file(snakemake.log[0])
table = read_csv(snakemake.input.realizations, ["index", "status", "rear_x_m", "front_x_m"])
record = write_zoning(table, snakemake.params[0], dict(snakemake.output.items()))
for zone in record["zones"]:
    log.info("%s: x = %.2f to %.2f m", zone["level"], zone["x_from_m"], zone["x_to_m"])
