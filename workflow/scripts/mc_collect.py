"""Rules mc_collect and mc_control_collect: one table of every Monte Carlo realization of a case, in index order."""

from rgns.logsetup import log_to_file
from rgns.montecarlo.runs import collect_chunks
from rgns.tables import write_csv

log = log_to_file(snakemake.log[0])
params = snakemake.params
table = collect_chunks(snakemake.input, params.realizations, params.chunk_size)
write_csv(table, snakemake.output[0])
log.info(
    "%d realizations from %d chunks, %d not ok", len(table), len(snakemake.input), int((table["status"] != "ok").sum())
)
