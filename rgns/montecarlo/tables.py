"""A route's realization table: its columns, and its chunk tables collected in the route's order.

Kept apart from :mod:`rgns.montecarlo.runs` (which loads the engines and the learned simulators, PyTorch
among them) so that rule mc_collect, run once per route of every case, starts without them.
"""

from __future__ import annotations

import pandas as pd

from rgns.montecarlo.routes import chunk_labels, chunk_share
from rgns.tables import TableError, read_chunk

COLUMNS = [
    "index",
    "status",
    "n_particles",
    "friction_mean_deg",
    "factor_of_safety",
    "runout_m",
    "volume_m2",
    "influence_m",
    "displaced_fraction",
    "toe_x_m",
    "crest_x_m",
    "front_x_m",
    "rear_x_m",
    "potential_final",
    "kinetic_final",
    "dissipated_final",
    "simulator",
]


def collect_listed(paths: list[str], indices: list[int], chunk_size: int) -> pd.DataFrame:
    """Chunk tables that together hold the listed realizations, in the list's order, chunk k its k-th share
    of ``chunk_size`` (rgns.montecarlo.routes.chunk_share), each checked to hold exactly those: one cut
    short, or left over from another montecarlo config or pair plan, is named."""
    if len(paths) != len(chunk_labels(len(indices), chunk_size)):
        raise TableError(f"{len(paths)} chunk tables for {len(indices)} realizations in chunks of {chunk_size}")
    tables = [read_chunk(path, sorted(chunk_share(indices, k, chunk_size)), COLUMNS) for k, path in enumerate(paths)]
    table = pd.concat(tables, ignore_index=True).set_index("index", drop=False)
    return table.loc[list(indices)].reset_index(drop=True)
