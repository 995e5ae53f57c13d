"""Rule endstate_ood: the trained end-state surrogate against the validation sets' MPM end states."""

import json
from pathlib import Path

import torch

from rgns.engines.metrics import MetricSettings
from rgns.logsetup import log_to_file
from rgns.scene.realizations import CaseInputs
from rgns.surrogates.endstate.data import read_end_states
from rgns.surrogates.endstate.evaluate import agreement_table, markdown_table
from rgns.surrogates.endstate.model import load_model

log = log_to_file(snakemake.log[0], "rgns")
torch.set_num_threads(snakemake.threads)
model = load_model(snakemake.input.model)
sets = {
    case: (
        read_end_states([path for path in snakemake.input.data if Path(path).parent.name == case]),
        CaseInputs.from_params(params),
    )
    for case, params in snakemake.params.inputs.items()
}
table = agreement_table(model, sets, MetricSettings(**snakemake.params.metrics))
log.info("%s", ", ".join(f"{case}: {len(states)} realizations" for case, (states, _) in sets.items()))
Path(snakemake.output.table).write_text(json.dumps(table.to_dict("records"), indent=2) + "\n")
Path(snakemake.output.markdown).write_text(markdown_table(table))
