"""Rule paired_plan: which of a case's realizations the MPM re-runs, stratified on the cheap route's runout
(rgns.fidelity.pair_design), or a simple random subsample of them without strata."""

import json

import numpy as np

from rgns.fidelity.pair_design import design_pairs
from rgns.logsetup import log_to_file
from rgns.scene.realizations import FINISHED
from rgns.tables import read_csv

log = log_to_file(snakemake.log[0])
settings = snakemake.params.settings
if snakemake.input.realizations:  # strata: the finished cheap runs and their runout
    cheap = read_csv(snakemake.input.realizations[0])
    cheap = cheap[cheap["status"].isin(FINISHED)]
    index, runout = cheap["index"].to_numpy(), cheap["runout_m"].to_numpy(float)
else:  # one stratum: every realization, whatever the cheap route says of it (no runout read: bounds unknown)
    index = np.arange(settings["realizations"])
    runout = np.full(index.size, np.nan)
design = design_pairs(
    index, runout, settings["paired"], list(settings["strata"]), settings["min_per_stratum"], settings["seed"]
)
with open(snakemake.output[0], "w") as out:
    json.dump(design.to_record(), out)
log.info(
    "%s: %d pairs over strata of the cheap runout %s (sizes %s): %s",
    snakemake.wildcards.case,
    len(design.indices),
    [[round(v, 2) for v in bounds] for bounds in design.bounds_m],
    design.sizes,
    design.pairs,
)
