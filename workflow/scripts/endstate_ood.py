"""Rule endstate_ood: the trained end-state surrogate against the validation sets' MPM end states."""
import json
from pathlib import Path

import pandas as pd
import torch

from rgns.endstate.data import read_end_states
from rgns.endstate.evaluate import agreement_rows, markdown_table, paired_metrics
from rgns.endstate.model import load_model
from rgns.logsetup import log_to_file
from rgns.metrics import MetricSettings
from rgns.realizations import CaseInputs

log = log_to_file(snakemake.log[0], "rgns")
torch.set_num_threads(snakemake.threads)
model = load_model(snakemake.input.model)
metrics = MetricSettings(**snakemake.params.metrics)
rows = []
for case, params in snakemake.params.inputs.items():
    files = [path for path in snakemake.input.data if Path(path).parent.name == case]
    pairs = paired_metrics(model, read_end_states(files), CaseInputs.from_params(params), metrics)
    rows += agreement_rows(pairs)
    log.info("%s: %d realizations", case, len(pairs))
table = pd.DataFrame(rows)
Path(snakemake.output.table).write_text(json.dumps(table.to_dict("records"), indent=2) + "\n")
Path(snakemake.output.markdown).write_text(markdown_table(table))
