"""Rule mpm_run: run one case through the configured MPM engine."""
from rgns.engines import simulate
from rgns.logsetup import log_to_file

log = log_to_file(snakemake.log.script)
settings = snakemake.params.settings
label = f"{snakemake.wildcards.set} realization {snakemake.wildcards.index}"
log.info("%s: engine %s", label, settings["mpm"]["engine"])
simulate(snakemake.input.case, snakemake.output[0], snakemake.params.scratch, snakemake.log.engine,
         settings["mpm"], label, settings["compression"])
log.info("%s: wrote %s", label, snakemake.output[0])
