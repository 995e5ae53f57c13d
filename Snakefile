# rgns: random fields -> MPM -> GNS -> Monte Carlo runout hazard maps. This file is the table of
# contents: configuration, validation, the rule files, the targets.
import os
import sys

from snakemake.utils import min_version

min_version("9.0")
sys.path.insert(0, workflow.basedir)  # the rgns package of this checkout, installed or not

from rgns.config import validate_config


# A --configfile replaces the default config instead of being merged into it, so a smaller
# config (fewer sets, fewer families) means exactly what it says.
if not workflow.overwrite_configfiles:

    configfile: os.path.join(workflow.basedir, "config/config.yaml")


validate_config(config, os.path.join(workflow.basedir, "config/schema.yaml"))


include: "rules/common.smk"
include: "rules/geometry.smk"
include: "rules/fields.smk"


rule hazard_map:
    """Everything built so far for the hazard map: all scenes and fields, and their previews."""
    input:
        all_scene_files("geometry", "json"),
        all_scene_files("fields", "npz"),
        expand("results/plots/{set}/scenes.png", set=SETS),


rule all:
    input:
        rules.hazard_map.input,
    default_target: True
