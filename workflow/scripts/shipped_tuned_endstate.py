"""Rule shipped_tuned_endstate: the tuned end-state surrogate of the package, checked to serve this config."""

import shutil
from pathlib import Path

from rgns.logsetup import log_to_file
from rgns.surrogates.endstate.tuned_card import check_tuned_serves
from rgns.surrogates.shipped import read_card

log = log_to_file(snakemake.log[0])
card = read_card(Path(snakemake.input.card).parent, Path(snakemake.input.card).name)
check_tuned_serves(card, snakemake.params.config)
shutil.copyfile(snakemake.input.model, snakemake.output.model)
shutil.copyfile(snakemake.input.card, snakemake.output.card)
log.info(
    "shipped tuned end-state surrogate: %d steps on %s, data %s",
    card["steps"],
    ", ".join(card["cases"]),
    card["data_fingerprint"],
)
