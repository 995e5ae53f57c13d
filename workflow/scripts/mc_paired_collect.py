"""Rules mc_paired_collect and mc_coarse_collect: one table of a case's paired realizations, each chunk
checked to hold exactly its share of those rule paired_plan chose (rgns.montecarlo.runs.collect_listed)."""

import json
from pathlib import Path

from rgns.logsetup import log_to_file
from rgns.montecarlo.runs import collect_listed
from rgns.tables import write_csv

log = log_to_file(snakemake.log[0])
chosen = json.loads(Path(snakemake.input.plan).read_text())["indices"]
table = collect_listed(snakemake.input.chunks, chosen)
write_csv(table, snakemake.output[0])
log.info(
    "%d paired realizations from %d chunks, %d not ok",
    len(table),
    len(snakemake.input.chunks),
    int((table["status"] != "ok").sum()),
)
