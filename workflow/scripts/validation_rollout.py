"""Rule validation_rollout: the learned simulator (GNS or end-state surrogate) on every MPM
realization of one test case, paired."""

import numpy as np
import torch

from rgns.engines.metrics import MetricSettings
from rgns.logsetup import log_to_file
from rgns.montecarlo.runs import rollout_settings
from rgns.scene.geometry import read_scene
from rgns.surrogates.endstate.model import load_model
from rgns.surrogates.gns.train import load_simulator
from rgns.surrogates.pairing import pair_case, pair_end_states
from rgns.tables import write_csv
from rgns.trajectories import read_packed

log = log_to_file(snakemake.log[0])
torch.set_num_threads(snakemake.threads)
params = snakemake.params
trajectories = list(read_packed(snakemake.input.packed))
scenes = {scene.index: scene for scene in map(read_scene, snakemake.input.scenes)}
metrics = MetricSettings(**params.metrics)
if params.surrogate == "endstate":
    paired = pair_end_states(
        load_model(snakemake.input.model, params.device),
        trajectories,
        scenes,
        metrics,
        params.gravity_m_s2,
        params.device,
    )
else:
    simulator = load_simulator(snakemake.input.model, params.device).eval()
    paired = pair_case(
        simulator,
        trajectories,
        scenes,
        metrics,
        params.gravity_m_s2,
        params.batch_size,
        params.device,
        rollout_settings(params.rollout, trajectories[0].frame_interval_s),
    )
write_csv(paired.pairs, snakemake.output.pairs)
np.savez_compressed(snakemake.output.energies, **paired.energies())
log.info(
    "%s: %d realizations paired, %d %s runs not ok",
    snakemake.wildcards.case,
    len(paired.pairs),
    int((paired.pairs["gns_status"] != "ok").sum()),
    params.surrogate,
)
