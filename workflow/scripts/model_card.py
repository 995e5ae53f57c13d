"""Rule model_card: the card of the trained model (rgns/models/card.json and card.md when shipped)."""

import json
from pathlib import Path

from rgns.logsetup import log_to_file
from rgns.surrogates.shipped import make_card, render_card

log = log_to_file(snakemake.log[0])
evaluation = json.loads(Path(snakemake.input.evaluation).read_text())
card = make_card(
    dict(snakemake.params.config), list(snakemake.input.data), snakemake.input.history, evaluation, evaluation
)
Path(snakemake.output.card).write_text(json.dumps(card, indent=2) + "\n")
Path(snakemake.output.markdown).write_text(render_card(card))
log.info("model card: %d steps, kept step %d", card["steps"], card["selected_step"])
