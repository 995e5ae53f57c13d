"""CB-Geo MPM: the case-directory writer, the case reader both engines share, the runner, and the
reader of its per-step HDF5 output. Facts about the formats: docs/cbgeo.md of the design notes."""
