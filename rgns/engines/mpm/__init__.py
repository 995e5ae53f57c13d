"""rgns's embedded MPM engine: 2-D plane-strain explicit MPM in PyTorch, batched over realizations.

Reads the CB-Geo case directories the writer produces; ``step.py`` reads like the method
(p2g, grid update, g2p, stress update), ``mohr_coulomb.py`` is the constitutive model alone.
"""
