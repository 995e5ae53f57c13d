"""Rules mc_chunk, mc_mean_field, mc_control_chunk, mc_paired_chunk and mc_coarse_chunk: simulate and measure
some Monte Carlo realizations of a case.

The paired chunks take their realizations from the list rule paired_plan chose. With a learned simulator
and validation.acceptance.on_failure stop, a case that failed the validation gate stops here with the
failures named; otherwise the gate decides nothing."""

import json
import sys
from pathlib import Path

import torch

from rgns.logsetup import log_to_file
from rgns.montecarlo.runs import SURROGATES, CaseInputs, RunSettings, run_realizations
from rgns.scene.realizations import FINISHED
from rgns.surrogates.endstate.model import load_model
from rgns.surrogates.gate import GateError, simulator_for
from rgns.surrogates.gns.train import load_simulator
from rgns.tables import write_csv

log = log_to_file(snakemake.log[0])
torch.set_num_threads(snakemake.threads)
inputs = CaseInputs.from_params(snakemake.params.inputs)
settings = RunSettings.from_params(snakemake.params.run)
if snakemake.input.gate:
    try:
        simulator_for(snakemake.input.gate[0], inputs.case)
    except GateError as error:  # said in snakemake's own output too, not only in this job's log
        log.error("%s", error)
        print(f"rgns: {error}", file=sys.__stderr__, flush=True)
        sys.exit(1)
indices = snakemake.params.indices
if "plan" in snakemake.input.keys():  # a paired chunk: its share of the realizations paired_plan chose
    chosen = json.loads(Path(snakemake.input.plan).read_text())["indices"]
    first = indices["chunk"] * indices["chunk_size"]
    indices = chosen[first : first + indices["chunk_size"]]
loaders = {
    "gns": lambda path: load_simulator(path, settings.device).eval(),
    "endstate": lambda path: load_model(path, settings.device),
}
use_model = snakemake.input.model and settings.simulator in SURROGATES
simulator = loaders[settings.simulator](snakemake.input.model[0]) if use_model else None
table = run_realizations(inputs, list(indices), settings, simulator)
write_csv(table, snakemake.output[0])
log.info(
    "%s: %d realizations by %s, %d screened as stable, %d not ok",
    inputs.case,
    len(table),
    settings.simulator,
    int((table["status"] == "screened").sum()),
    int((~table["status"].isin(FINISHED)).sum()),
)
