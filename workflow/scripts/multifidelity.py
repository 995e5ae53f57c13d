"""Rule multifidelity: a case's hazard corrected towards the accurate MPM (rgns.fidelity.outputs)."""

import json
from pathlib import Path

from rgns.fidelity.outputs import costs, write_multifidelity
from rgns.logsetup import log_to_file
from rgns.montecarlo.routes import chunk_labels
from rgns.tables import read_csv

log = log_to_file(snakemake.log[0])
settings = snakemake.params[0]
low, high = read_csv(snakemake.input.realizations), read_csv(snakemake.input.paired)
simulator = read_csv(snakemake.input.simulator) if snakemake.input.simulator != snakemake.input.realizations else None
benchmarks = {
    "low_benchmarks": settings["low_benchmarks"],  # the paired chunks: as many as hold its rows
    "high_benchmarks": [
        settings["high_benchmark_pattern"].format(chunk=int(k)) for k in chunk_labels(len(high), settings["chunk_size"])
    ],
}
measured = {name: [p for p in paths if Path(p).exists()] for name, paths in benchmarks.items()}
if all(len(measured[name]) == len(benchmarks[name]) for name in measured):
    cost = costs(measured["low_benchmarks"], len(low), measured["high_benchmarks"], len(high))
else:  # chunks made before their runs were timed
    cost = {"low_s": float("nan"), "high_s": float("nan")}
    log.warning("some chunks have no benchmark file: the cost of each route is not known")
plan = json.loads(Path(snakemake.input.plan).read_text())
coarse = read_csv(snakemake.input.coarse[0]) if snakemake.input.coarse else None
record = write_multifidelity(
    low, high, settings, cost, dict(snakemake.output.items()), snakemake.wildcards.case, plan, simulator, coarse
)
runout = record["means"]["runout_m"]
log.info(
    "%s: mean R corrected %.3f m [%.3f, %.3f] from the cheap %.3f m (bias over %d pairs %+.3f m, "
    "correlation %.3f); %.2f s vs %.2f s per realization",
    snakemake.wildcards.case,
    runout["estimate"],
    runout["lower"],
    runout["upper"],
    runout["low_mean"],
    record["n_paired"],
    runout["bias"],
    runout["correlation"],
    cost["low_s"],
    cost["high_s"],
)
if "converged" in record:
    runout = record["converged"]["means"]["runout_m"]
    log.info(
        "%s: mean R at the converged mesh %.3f m [%.3f, %.3f] (mesh step %+.3f m, %+.3f to %+.3f over the order's "
        "interval)",
        snakemake.wildcards.case,
        runout["estimate"],
        runout["lower"],
        runout["upper"],
        runout["mesh_step"],
        *runout["mesh_step_range"],
    )
