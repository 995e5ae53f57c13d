"""Rule mpm_input: write one realization's CB-Geo case directory."""

from rgns.engines.cbgeo.writer import write_case
from rgns.logsetup import log_to_file
from rgns.scene.fields import read_field
from rgns.scene.geometry import read_scene

log = log_to_file(snakemake.log[0])
scene = read_scene(snakemake.input.scene)
field = read_field(snakemake.input.field)
write_case(snakemake.output[0], scene, field.friction_deg, snakemake.params[0])
log.info(
    "%s %s: case with %d particles written to %s",
    scene.set_name,
    snakemake.wildcards.index,
    len(scene.positions),
    snakemake.output[0],
)
