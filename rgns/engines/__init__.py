"""The engines: a realization (:class:`rgns.scene.case.Case`) in, its trajectory out.

:mod:`rgns.engines.mpm` is the embedded MPM (compiled CPU kernels, or PyTorch), which takes cases in memory and imports no file
format; :mod:`rgns.engines.cbgeo` writes and reads CB-Geo's case directories and runs the ``mpm``
binary on them; every
engine runs the case :mod:`rgns.scene.build` makes; :mod:`rgns.engines.chunk` runs a chunk
of cases through the configured one (``mpm.engine``) into trajectory files, and
:mod:`rgns.engines.batch` a batch of realizations in memory through the embedded one, with the
settings of :mod:`rgns.engines.settings` (config section ``mpm``, typed).
:mod:`rgns.engines.metrics` measures a run: runout R, sliding volume V and influence distance I;
:mod:`rgns.engines.paraview` writes a trajectory as a ParaView series.
"""
