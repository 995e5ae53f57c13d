"""The engines: a realization (:class:`rgns.scene.case.Case`) in, its trajectory out.

:mod:`rgns.engines.mpm` is the embedded PyTorch MPM, which takes cases in memory and imports no file
format; :mod:`rgns.engines.cbgeo` writes and reads CB-Geo's case directories and runs the ``mpm``
binary on them; :mod:`rgns.engines.chunk` runs a chunk of cases through the configured one
(``mpm.engine``) into trajectory files.
"""
