"""Encode-process-decode graph network (Battaglia et al. 2018; Sanchez-Gonzalez et al. 2020).

Knows nothing about physics: node and edge feature vectors in, one vector per node out. The
processor is a stack of unshared interaction layers with residual updates of both edges and
nodes; messages are summed at the receivers.
"""

from __future__ import annotations

import torch
from torch import nn


def mlp(inputs: int, width: int, hidden_layers: int, outputs: int, layer_norm: bool = True) -> nn.Sequential:
    """``hidden_layers`` ReLU layers of ``width``, a linear output, optionally LayerNorm."""
    layers: list[nn.Module] = []
    size = inputs
    for _ in range(hidden_layers):
        layers += [nn.Linear(size, width), nn.ReLU()]
        size = width
    layers.append(nn.Linear(size, outputs))
    if layer_norm:
        layers.append(nn.LayerNorm(outputs))
    return nn.Sequential(*layers)


class InteractionLayer(nn.Module):
    """One round of message passing: edge update from (edge, sender, receiver), node update
    from (node, summed messages), both residual. The edge MLP's first layer is applied to the
    nodes before gathering (W·[e, h_s, h_r] = W_e e + (W_s h)_s + (W_r h)_r), which is the
    same function with fewer operations."""

    def __init__(self, latent: int, width: int, hidden_layers: int):
        super().__init__()
        self.edge_in = nn.Linear(latent, width)
        self.sender_in = nn.Linear(latent, width, bias=False)
        self.receiver_in = nn.Linear(latent, width, bias=False)
        self.edge_rest = nn.Sequential(nn.ReLU(), mlp(width, width, hidden_layers - 1, latent))
        self.node_mlp = mlp(2 * latent, width, hidden_layers, latent)

    def forward(
        self, nodes: torch.Tensor, edges: torch.Tensor, senders: torch.Tensor, receivers: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        hidden = self.edge_in(edges) + self.sender_in(nodes)[senders] + self.receiver_in(nodes)[receivers]
        messages = self.edge_rest(hidden)
        summed = torch.zeros_like(nodes).index_add_(0, receivers, messages)
        return nodes + self.node_mlp(torch.cat([nodes, summed], dim=1)), edges + messages


class EncodeProcessDecode(nn.Module):
    """Node / edge encoders, ``steps`` interaction layers, a node decoder."""

    def __init__(
        self,
        node_features: int,
        edge_features: int,
        outputs: int,
        latent: int,
        width: int,
        hidden_layers: int,
        steps: int,
    ):
        super().__init__()
        self.node_encoder = mlp(node_features, width, hidden_layers, latent)
        self.edge_encoder = mlp(edge_features, width, hidden_layers, latent)
        self.processor = nn.ModuleList(InteractionLayer(latent, width, hidden_layers) for _ in range(steps))
        self.decoder = mlp(latent, width, hidden_layers, outputs, layer_norm=False)

    def forward(
        self, node_features: torch.Tensor, edge_features: torch.Tensor, senders: torch.Tensor, receivers: torch.Tensor
    ) -> torch.Tensor:
        nodes, edges = self.node_encoder(node_features), self.edge_encoder(edge_features)
        for layer in self.processor:
            nodes, edges = layer(nodes, edges, senders, receivers)
        return self.decoder(nodes)
