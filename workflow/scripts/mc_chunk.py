"""Rule mc_chunk: simulate and measure one chunk of one route of a case's realizations (rgns.montecarlo.routes).

A route that runs the pairs takes its realizations from the list rule paired_plan chose. With a learned
simulator and validation.acceptance.on_failure stop, a case that failed the validation gate stops here with
the failures named; otherwise the gate decides nothing."""

import sys

import torch

from rgns.logsetup import log_to_file
from rgns.montecarlo.routes import chunk_share, route_realizations
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
listing = snakemake.params.listing
listed = route_realizations(listing["listed"], snakemake.input.plan)
indices = chunk_share(listed, int(snakemake.wildcards.chunk), listing["chunk_size"])
loaders = {
    "gns": lambda path: load_simulator(path, settings.device).eval(),
    "endstate": lambda path: load_model(path, settings.device),
}
use_model = snakemake.input.model and settings.simulator in SURROGATES
simulator = loaders[settings.simulator](snakemake.input.model[0]) if use_model else None
table = run_realizations(inputs, indices, settings, simulator)
write_csv(table, snakemake.output[0])
log.info(
    "%s, route %s: %d realizations by %s, %d screened as stable, %d not ok",
    inputs.case,
    snakemake.wildcards.route,
    len(table),
    settings.simulator,
    int((table["status"] == "screened").sum()),
    int((~table["status"].isin(FINISHED)).sum()),
)
