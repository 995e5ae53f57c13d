"""Rule paraview_series: one realization as VTU frames + a .pvd index for ParaView."""

from pathlib import Path

from rgns.engines.chunk import trajectory_name
from rgns.engines.paraview import write_vtu_series
from rgns.logsetup import log_to_file
from rgns.trajectories import read_trajectory

log = log_to_file(snakemake.log[0])
trajectory = read_trajectory(Path(snakemake.input[0]) / trajectory_name(int(snakemake.wildcards.index)))
index = write_vtu_series(trajectory, snakemake.output[0], snakemake.params.every_nth_frame)
log.info("wrote %s", index)
