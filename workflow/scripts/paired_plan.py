"""Checkpoint paired_plan: how many realizations of a case to pair for the target half-width
(rgns.fidelity.outputs.plan_pairs)."""

import json

from rgns.fidelity.outputs import plan_pairs
from rgns.logsetup import log_to_file
from rgns.montecarlo.runs import collect_whole_chunks
from rgns.tables import read_csv

log = log_to_file(snakemake.log[0])
settings = snakemake.params.settings
pilot = collect_whole_chunks(snakemake.input.pilot, settings["chunk_size"], settings["realizations"])
plan = plan_pairs(read_csv(snakemake.input.realizations), pilot, settings)
with open(snakemake.output[0], "w") as out:
    json.dump(plan, out, indent=1)
log.info(
    "%s: %d pilot pairs, std of R %.2f m, correlation %.3f: %d paired realizations (%d chunks) for a "
    "half-width of %.3g m, predicted %.3g m%s",
    snakemake.wildcards.case,
    plan["pilot"],
    plan["std_m"],
    plan["correlation"],
    plan["n_paired"],
    plan["chunks"],
    plan["target_half_width_m"],
    plan["predicted_half_width_m"],
    "" if plan["reached"] else f" (not reached within the cap {plan['cap']})",
)
