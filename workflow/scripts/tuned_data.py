"""Rule tuned_data: one chunk of a case's tuning realizations, run by the accurate MPM and coarse-grained."""

import torch

from rgns.logsetup import log_to_file
from rgns.scene.realizations import CaseInputs
from rgns.surrogates.endstate.data import write_end_states
from rgns.surrogates.endstate.tuning import simulate_tuning_states

log = log_to_file(snakemake.log[0])
torch.set_num_threads(snakemake.threads)
params = snakemake.params[0]
coarse, fine = CaseInputs.from_params(params["coarse"]), CaseInputs.from_params(params["fine"])
states, statuses = simulate_tuning_states(coarse, fine, params["indices"], params["mpm"], params["frames"])
write_end_states(snakemake.output[0], states, statuses)
log.info(
    "%s: realizations %d-%d at %s m cells, %d finished (%s)",
    coarse.case,
    params["indices"][0],
    params["indices"][-1],
    fine.mesh["cell_size_m"],
    len(states),
    ", ".join(sorted(set(statuses))),
)
