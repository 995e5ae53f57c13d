"""Rule mc_collect: one table of every Monte Carlo realization of a case, in index order."""

from rgns.logsetup import log_to_file
from rgns.montecarlo.runs import collect_chunks, collect_whole_chunks
from rgns.tables import write_csv

log = log_to_file(snakemake.log[0])
params = snakemake.params
if params.realizations:
    table = collect_chunks(snakemake.input, params.realizations, params.chunk_size)
else:  # the paired chunks paired_plan chose, whole chunks up to montecarlo.realizations
    table = collect_whole_chunks(snakemake.input, params.chunk_size, params.limit)
write_csv(table, snakemake.output[0])
log.info(
    "%d realizations from %d chunks, %d not ok", len(table), len(snakemake.input), int((table["status"] != "ok").sum())
)
