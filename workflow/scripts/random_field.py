"""Rule random_field: draw one realization's friction field onto its scene's particles."""

from rgns.logsetup import log_to_file
from rgns.scene.fields import FieldGrid, friction_field, write_field
from rgns.scene.geometry import read_scene

log = log_to_file(snakemake.log[0])
params = snakemake.params[0]
scene = read_scene(snakemake.input.scene)
settings = params["random_field"]
grid = FieldGrid.covering(
    params["domain"]["length_m"], params["domain"]["height_m"], settings["grid_spacing_m"] or params["cell_size_m"]
)
field = friction_field(
    seed=params["seed"],
    set_name=snakemake.wildcards.set,
    index=int(snakemake.wildcards.index),
    group=params["group"],
    grid=grid,
    method=settings["method"],
    bounds_deg=tuple(settings["friction_bounds_deg"]),
    positions=scene.positions,
)
write_field(snakemake.output[0], field)
log.info(
    "%s %s: %s field on %s grid, mean %.2f deg, particles %.2f-%.2f deg, %.2f %% clipped",
    scene.set_name,
    snakemake.wildcards.index,
    field.method,
    grid.shape,
    field.mean_deg,
    field.friction_deg.min(),
    field.friction_deg.max(),
    100 * field.clipped_fraction,
)
