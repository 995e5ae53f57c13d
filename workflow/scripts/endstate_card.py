"""Rule endstate_card: the trained end-state surrogate's card (rgns/models/endstate_general_card.* when shipped)."""

import json
from pathlib import Path

import pandas as pd

from rgns.logsetup import log_to_file
from rgns.surrogates.endstate.card import make_card, render_card, started_from

log = log_to_file(snakemake.log[0])
history = pd.read_csv(snakemake.input.history).to_dict("records")
start = started_from(*snakemake.input.start) if snakemake.input.start else None
card = make_card(
    dict(snakemake.params.config), list(snakemake.input.data), history, list(snakemake.params.cases), start
)
Path(snakemake.output.card).write_text(json.dumps(card, indent=2) + "\n")
Path(snakemake.output.markdown).write_text(
    render_card(card, Path(snakemake.input.validation).read_text(), snakemake.params.title)
)
log.info("end-state card: %d steps", card["steps"])
