"""Rule scene_preview: picture the first realizations of a set."""

from rgns.logsetup import log_to_file
from rgns.report.plots import plot_scenes
from rgns.scene.fields import read_field
from rgns.scene.geometry import read_scene

log = log_to_file(snakemake.log[0])
plot_scenes(
    [read_scene(p) for p in snakemake.input.scenes],
    [read_field(p) for p in snakemake.input.fields],
    snakemake.output[0],
)
log.info("wrote %s", snakemake.output[0])
