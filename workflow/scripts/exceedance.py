"""Rule exceedance: exceedance curves and convergence of I and R for one Monte Carlo case."""

from rgns.hazard.outputs import write_exceedance
from rgns.logsetup import log_to_file
from rgns.tables import read_csv

log = log_to_file(snakemake.log[0])
columns = ["index", "status", "runout_m", "influence_m"]
table = read_csv(snakemake.input.realizations, columns)
mean_field = read_csv(snakemake.input.mean_field, columns)
summary = write_exceedance(table, mean_field, snakemake.params[0], dict(snakemake.output.items()))
for label, entry in summary["metrics"].items():
    log.info(
        "%s: %s",
        label,
        "; ".join(f"P = {d['probability']}: {d['distance_m']} m ({d['note']})" for d in entry["distances"]),
    )
