"""Rule mpm_kernels: compile the MPM's CPU kernels once (numba's cache), before the MPM jobs that load them."""

from pathlib import Path

from rgns.engines.mpm.frame_kernels import compile_kernels
from rgns.logsetup import log_to_file

log = log_to_file(snakemake.log[0])
seconds = compile_kernels()
log.info("the MPM kernels compiled or loaded from numba's cache in %.1f s", seconds)
Path(snakemake.output[0]).write_text(f"{seconds:.1f} s\n")
