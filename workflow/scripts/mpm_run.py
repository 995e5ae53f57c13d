"""Rule mpm_run: run one chunk of cases through the configured MPM engine."""

from rgns.engines.chunk import simulate_chunk
from rgns.logsetup import log_to_file

log = log_to_file(snakemake.log[0])
settings = snakemake.params.settings
log.info(
    "%s chunk %s: %d case(s), engine %s",
    snakemake.wildcards.set,
    snakemake.wildcards.chunk,
    len(snakemake.input.cases),
    settings["mpm"]["engine"],
)
statuses = simulate_chunk(
    list(snakemake.input.cases),
    snakemake.output[0],
    snakemake.params.scratch,
    snakemake.params.engine_logs,
    settings["mpm"],
    settings["compression"],
)
log.info("done: %d ok, %d diverged", statuses.count("ok"), len(statuses) - statuses.count("ok"))
