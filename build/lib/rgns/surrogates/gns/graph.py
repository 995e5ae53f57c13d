"""Radius graphs by cell lists in pure PyTorch (CPU and CUDA), for a batch of disjoint graphs.

Particles are binned into square cells of side r, keyed by (graph, cell row, cell column) so
graphs never mix; every particle looks in its own and the 8 surrounding cells (a sorted key
array and ``searchsorted`` give each cell's members), and candidate pairs closer than r are kept.
Exact: every pair within r, no neighbour cap, no self edges.
"""

from __future__ import annotations

import torch

OFFSETS = [(dx, dy) for dy in (-1, 0, 1) for dx in (-1, 0, 1)]


def radius_graph(positions: torch.Tensor, batch: torch.Tensor, radius: float) -> tuple[torch.Tensor, torch.Tensor]:
    """Directed edges (senders, receivers) between distinct particles of one graph within ``radius``."""
    device = positions.device
    if len(positions) == 0:
        empty = torch.zeros(0, dtype=torch.long, device=device)
        return empty, empty
    lower = positions.min(dim=0).values
    cell = torch.floor((positions - lower) / radius).long()
    nx = int(cell[:, 0].max()) + 3  # one empty column of margin on each side
    ny = int(cell[:, 1].max()) + 3
    cx, cy = cell[:, 0] + 1, cell[:, 1] + 1
    key = (batch * ny + cy) * nx + cx
    sorted_key, order = torch.sort(key)
    neighbour_keys = torch.stack([key + dy * nx + dx for dx, dy in OFFSETS], dim=1)  # [N, 9]
    start = torch.searchsorted(sorted_key, neighbour_keys, side="left")
    end = torch.searchsorted(sorted_key, neighbour_keys, side="right")
    counts = (end - start).reshape(-1)
    total = int(counts.sum())
    receivers = torch.arange(len(positions), device=device).repeat_interleave(9).repeat_interleave(counts)
    first = start.reshape(-1).repeat_interleave(counts)
    within = torch.arange(total, device=device) - (torch.cumsum(counts, 0) - counts).repeat_interleave(counts)
    senders = order[first + within]
    keep = (senders != receivers) & ((positions[senders] - positions[receivers]).pow(2).sum(1) <= radius * radius)
    return senders[keep], receivers[keep]


def brute_force_graph(positions: torch.Tensor, batch: torch.Tensor, radius: float) -> tuple[torch.Tensor, torch.Tensor]:
    """The same edges by checking every pair: O(N²), for tests."""
    distance = torch.cdist(positions, positions)
    close = (distance <= radius) & (batch[:, None] == batch[None, :])
    close.fill_diagonal_(False)
    receivers, senders = torch.nonzero(close, as_tuple=True)
    return senders, receivers
