"""Rule pack: one HDF5 file per set, with per-frame motion statistics."""
from rgns.logsetup import log_to_file
from rgns.trajectories import pack

log = log_to_file(snakemake.log[0])
statistics = pack(list(snakemake.input), snakemake.output[0], snakemake.wildcards.set, snakemake.params.compression)
log.info("packed %d trajectories into %s; velocity std %s, acceleration std %s (per frame)", len(snakemake.input),
         snakemake.output[0], statistics.velocity_std, statistics.acceleration_std)
