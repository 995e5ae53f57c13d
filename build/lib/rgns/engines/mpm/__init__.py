"""rgns's embedded MPM engine: 2-D plane-strain explicit MPM, batched over realizations.

Runs the in-memory case of :mod:`rgns.scene.build` (or one read from a CB-Geo case directory);
``step.py`` reads like the method (p2g, grid update, g2p, stress update) in PyTorch, ``mohr_coulomb.py`` is the
constitutive model alone, ``kernels.py`` the same step as compiled CPU kernels (numba), a frame of steps per
call, which ``frame_kernels.py`` hands the solver's tensors to; ``solver.py`` runs the frames on either backend
(``mpm.embedded.backend``).
"""
