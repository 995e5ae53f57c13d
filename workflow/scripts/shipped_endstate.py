"""Rule shipped_endstate: the pretrained end-state surrogate of the package, checked to serve this config."""

import json
import shutil
from pathlib import Path

from rgns.logsetup import log_to_file
from rgns.surrogates.endstate.card import check_serves
from rgns.surrogates.shipped import read_card

log = log_to_file(snakemake.log[0])
card = read_card(Path(snakemake.input.card).parent, Path(snakemake.input.card).name)
check_serves(card, snakemake.params.config)
shutil.copyfile(snakemake.input.model, snakemake.output.model)
shutil.copyfile(snakemake.input.curve, snakemake.output.curve)
evaluation = card["evaluation"] | {"card": f"rgns/models/{Path(snakemake.input.card).stem}.md"}
Path(snakemake.output.evaluation).write_text(json.dumps(evaluation, indent=2) + "\n")
log.info("shipped end-state surrogate: %d steps, data %s", card["steps"], card["data_fingerprint"])
