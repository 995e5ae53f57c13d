"""rgns's embedded MPM engine: 2-D plane-strain explicit MPM in PyTorch, batched over realizations.

Runs the in-memory case of :mod:`rgns.scene.build` (or one read from a CB-Geo case directory);
``step.py`` reads like the method (p2g, grid update, g2p, stress update), ``mohr_coulomb.py`` is the
constitutive model alone.
"""
