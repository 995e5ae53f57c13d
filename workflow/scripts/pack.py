"""Rule pack: one HDF5 file per set, with per-frame motion statistics; diverged runs left out."""

from pathlib import Path

from rgns.logsetup import log_to_file
from rgns.trajectories import pack

log = log_to_file(snakemake.log[0])
paths = sorted(path for chunk in snakemake.input for path in Path(chunk).glob("*.h5"))
expected = snakemake.params.realizations
if len(paths) != expected:  # never a quiet n - 1: a chunk folder short of a trajectory is no set
    raise ValueError(
        f"{', '.join(snakemake.input)}: {len(paths)} trajectories, the set has {expected}; "
        "run hazard_map again to make the missing ones"
    )
statistics, excluded = pack(paths, snakemake.output[0], snakemake.wildcards.set, snakemake.params.compression)
for line in excluded:
    log.error("left out: %s", line)
log.info(
    "packed %d of %d trajectories into %s; velocity std %s, acceleration std %s (per frame)",
    len(paths) - len(excluded),
    len(paths),
    snakemake.output[0],
    statistics.velocity_std,
    statistics.acceleration_std,
)
