"""Rules mc_chunk and mc_mean_field: simulate and measure some Monte Carlo realizations of a case.

With a learned simulator (the GNS or the end-state surrogate), the validation gate decides: a case
it failed runs MPM (on_failure: fallback) or stops here with the failures named (on_failure: stop)."""

import sys
from dataclasses import replace

import torch

from rgns.logsetup import log_to_file
from rgns.montecarlo.runs import SURROGATES, CaseInputs, RunSettings, run_realizations
from rgns.scene.realizations import FINISHED
from rgns.surrogates.endstate.model import load_model
from rgns.surrogates.gate import SURROGATE_NAMES, GateError, simulator_for
from rgns.surrogates.gns.train import load_simulator
from rgns.tables import write_csv

log = log_to_file(snakemake.log[0])
torch.set_num_threads(snakemake.threads)
inputs = CaseInputs.from_params(snakemake.params.inputs)
settings = RunSettings.from_params(snakemake.params.run)
surrogate = settings.simulator
if snakemake.input.gate:
    try:
        settings = replace(settings, simulator=simulator_for(snakemake.input.gate[0], inputs.case))
    except GateError as error:  # said in snakemake's own output too, not only in this job's log
        log.error("%s", error)
        print(f"rgns: {error}", file=sys.__stderr__, flush=True)
        sys.exit(1)
    if settings.simulator not in SURROGATES:
        log.warning(
            "%s: the %s failed the validation gate: these realizations are run by MPM",
            inputs.case,
            SURROGATE_NAMES[surrogate],
        )
loaders = {
    "gns": lambda path: load_simulator(path, settings.device).eval(),
    "endstate": lambda path: load_model(path, settings.device),
}
use_model = snakemake.input.model and settings.simulator in SURROGATES
simulator = loaders[settings.simulator](snakemake.input.model[0]) if use_model else None
table = run_realizations(inputs, list(snakemake.params.indices), settings, simulator)
write_csv(table, snakemake.output[0])
log.info(
    "%s: %d realizations by %s, %d screened as stable, %d not ok",
    inputs.case,
    len(table),
    settings.simulator,
    int((table["status"] == "screened").sum()),
    int((~table["status"].isin(FINISHED)).sum()),
)
