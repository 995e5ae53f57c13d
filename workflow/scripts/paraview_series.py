"""Rule paraview_series: one realization as VTU frames + a .pvd index for ParaView."""
from rgns.logsetup import log_to_file
from rgns.paraview import write_vtu_series
from rgns.trajectories import read_trajectory

log = log_to_file(snakemake.log[0])
index = write_vtu_series(read_trajectory(snakemake.input[0]), snakemake.output[0], snakemake.params.every_nth_frame)
log.info("wrote %s", index)
