"""Rule shipped_model: the pretrained GNS of the package, checked to serve this config."""

from pathlib import Path

from rgns.logsetup import log_to_file
from rgns.surrogates.shipped import install

log = log_to_file(snakemake.log[0])
card = install(
    Path(snakemake.input.card).parent,
    snakemake.params.config,
    snakemake.output.model,
    snakemake.output.curve,
    snakemake.output.evaluation,
)
log.info(
    "shipped GNS: %d steps (kept step %d), data %s", card["steps"], card["selected_step"], card["data_fingerprint"]
)
