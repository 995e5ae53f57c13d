# rgns: random fields -> MPM -> GNS -> Monte Carlo runout hazard maps. This file is the table of
# contents: configuration, validation, the rule files, the targets.
import os
import sys

from snakemake.utils import min_version

min_version("9.0")
sys.path.insert(0, workflow.basedir)  # the rgns package of this checkout, installed or not

from rgns.config import validate_config
from rgns.integrity import dry_run, locked, sweep
from rgns.montecarlo.routes import chunk_share


# A --configfile replaces the default config instead of being merged into it, so a smaller
# config (fewer sets, fewer families) means exactly what it says.
if not workflow.overwrite_configfiles:

    configfile: os.path.join(workflow.basedir, "config/config.yaml")


validate_config(config, os.path.join(workflow.basedir, "config/schema.yaml"))


include: "rules/common.smk"
include: "rules/geometry.smk"
include: "rules/fields.smk"
include: "rules/mpm.smk"
include: "rules/dataset.smk"
include: "rules/gns.smk"
include: "rules/endstate.smk"
include: "rules/validation.smk"
include: "rules/montecarlo.smk"
include: "rules/site.smk"
include: "rules/hazard.smk"


include: "rules/models.smk"  # the rules that make models: each defined only where the config asks for it


# Before the DAG: damaged intermediates removed (with the reason on the console), so that hazard_map,
# which asks for every table and run folder the report rests on, makes them again (rgns/integrity.py).
if workflow.is_main_process and not dry_run(sys.argv) and not locked():
    sweep(folders={f"results/mpm/{name}/chunk_{k}": [f"{i}.h5" for i in chunk_members(name, k)]
                   for name in RUN_SETS for k in chunk_ids(name)},
          chunks={path: chunk_share(route.listed(config), k, route.chunk_size)
                  for case in MC_CASES for route in ROUTES.values() if route.listed(config) is not None
                  for k, path in enumerate(route_chunks(case, route.name))})


# Light table and figure steps run where snakemake runs, not as cluster jobs of their own.
localrules:
    mc_collect,
    paired_plan,
    exceedance,
    zoning,
    multifidelity,
    report,


rule dataset:
    """MPM trajectories of every set, packed, and the train/valid export for geoelements/gns."""
    input:
        expand("results/dataset/{set}.h5", set=SETS),
        "results/dataset/gns/metadata.json",


rule hazard_map:
    """The whole chain: geometry, fields, MPM of the sets it needs (the test cases; the training sets too
    unless gns.model is shipped), GNS, validation gate, Monte Carlo, hazard report."""
    input:
        expand("results/dataset/{set}.h5", set=RUN_SETS),
        [] if config["gns"]["model"] == "shipped" or SURROGATE is None else "results/dataset/gns/metadata.json",
        "results/report/report.html",
        expand("results/site/{case}/{name}", case=SITE["name"], name=SITE_FILES) if SITE_FILES else [],
        report_foundations,


rule paraview:
    """ParaView time series of the previewed realizations of every set."""
    input:
        [f"results/paraview/{name}/{i}" for name in SETS for i in preview_ids(name)],


rule all:
    input:
        rules.hazard_map.input,
    default_target: True
