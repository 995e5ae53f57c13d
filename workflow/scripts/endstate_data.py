"""Rule endstate_data: one chunk of a test case's end-state training realizations, run by the embedded MPM."""

import torch

from rgns.logsetup import log_to_file
from rgns.scene.realizations import CaseInputs
from rgns.surrogates.endstate.data import simulate_end_states, write_end_states

log = log_to_file(snakemake.log[0])
torch.set_num_threads(snakemake.threads)
params = snakemake.params[0]
inputs = CaseInputs.from_params(params["inputs"])
states, statuses = simulate_end_states(inputs, params["indices"], params["mpm"], params["frames"])
write_end_states(snakemake.output[0], states, statuses)
log.info(
    "%s: realizations %d-%d, %d finished (%s)",
    inputs.case,
    params["indices"][0],
    params["indices"][-1],
    len(states),
    ", ".join(sorted(set(statuses))),
)
