"""Rule geometry: draw one realization's polygon and particles, write its scene file."""

from rgns.logsetup import log_to_file
from rgns.scene.geometry import build_scene, write_scene

log = log_to_file(snakemake.log[0])
params = snakemake.params[0]
scene = build_scene(
    set_name=snakemake.wildcards.set,
    index=int(snakemake.wildcards.index),
    family_name=params["family_name"],
    family=params["family"],
    domain=params["domain"],
    mesh=params["mesh"],
    geometry=params["geometry"],
    seed=params["seed"],
)
write_scene(snakemake.output[0], scene)
log.info(
    "%s %s: family %s, %d particles, area %.2f m2, %d draw(s)",
    scene.set_name,
    snakemake.wildcards.index,
    scene.family,
    len(scene.positions),
    scene.area_m2,
    scene.draws,
)
