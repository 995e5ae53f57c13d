"""The learned simulator: features, normalisation, integration and the training loss.

Inputs per particle are its last ``history + 1`` positions; features are the ``history``
velocities normalised per axis, the distances to the domain walls over the connectivity radius
(clipped to ±1), a particle-type embedding and the normalised tan φ, and optionally (``static_features``) where the
particle started: its height above the floor and its depth below the ground surface of its column, each over
the domain's height (:func:`static_features`: what lets a rollout from rest know where failure starts); edges carry only relative
displacement over the radius and its length. The network predicts a normalised acceleration,
integrated with semi-implicit Euler at dt = 1 frame. Training adds random-walk noise to the input
positions and corrects the target so the model learns to undo it.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import torch
from torch import nn

from rgns.surrogates.gns.graph import radius_graph
from rgns.surrogates.gns.network import EncodeProcessDecode

PARTICLE_TYPES = 9
TYPE_EMBEDDING = 16


@dataclass
class ModelSettings:
    """Architecture (config section ``gns``)."""

    latent_size: int = 128
    mlp_width: int = 128
    mlp_hidden_layers: int = 2
    message_passing_steps: int = 10
    history: int = 5
    radius_m: float = 4.0
    acceleration_features: bool = False  # also the history's accelerations, normalised as the targets are
    static_features: bool = False  # also where each particle started (static_features)
    rest_head: bool = False  # also the logit that a particle is at rest after the step (it moves under rest_m)
    rest_m: float = 0.01  # the step's displacement under which a particle is at rest (the rest head's label)


@dataclass
class Normalization:
    """Dataset statistics the model normalises with (per-frame units), a dataclass not a tuple."""

    velocity_mean: list[float]
    velocity_std: list[float]
    acceleration_mean: list[float]
    acceleration_std: list[float]
    tan_friction_mean: float
    tan_friction_std: float


@dataclass
class GraphInput:
    """A batch of disjoint particle sets: positions [N, history + 1, 2] and per-particle data."""

    positions: torch.Tensor
    particle_type: torch.Tensor  # [N] long
    tan_friction: torch.Tensor  # [N]
    batch: torch.Tensor  # [N] graph of each particle
    n_graphs: int
    static: torch.Tensor | None = None  # [N, STATIC] where each particle started (static_features)

    def moved_to(self, positions: torch.Tensor) -> GraphInput:
        """The same particles at other positions [N, history + 1, 2]."""
        return GraphInput(positions, self.particle_type, self.tan_friction, self.batch, self.n_graphs, self.static)

    def subset(self, ids: torch.Tensor) -> GraphInput:
        """The particles ``ids`` only (of the same graphs)."""
        static = None if self.static is None else self.static[ids]
        return GraphInput(
            self.positions[ids], self.particle_type[ids], self.tan_friction[ids], self.batch[ids], self.n_graphs, static
        )

    def to(self, device: torch.device) -> GraphInput:
        static = None if self.static is None else self.static.to(device)
        return GraphInput(
            self.positions.to(device),
            self.particle_type.to(device),
            self.tan_friction.to(device),
            self.batch.to(device),
            self.n_graphs,
            static,
        )


STATIC = 2
COLUMN_M = 1.0  # the width of the column whose highest particle is the ground surface above a particle


def static_features(initial: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """[N, STATIC] of particles at their start ``initial`` [N, 2]: the height above the floor and the depth below
    the highest particle within COLUMN_M / 2 across, each over the domain's height."""
    initial = np.asarray(initial, dtype=np.float64)
    floor, top = float(bounds[1][0]), float(bounds[1][1])
    order = np.argsort(initial[:, 0], kind="stable")
    x, y = initial[order, 0], initial[order, 1]
    first = np.searchsorted(x, x - COLUMN_M / 2, side="left")
    last = np.searchsorted(x, x + COLUMN_M / 2, side="right")
    surface = np.empty_like(y)
    for k, (a, b) in enumerate(zip(first, last)):
        surface[k] = y[a:b].max()
    features = np.empty((len(initial), STATIC))
    features[order, 0] = (y - floor) / (top - floor)
    features[order, 1] = (surface - y) / (top - floor)
    return features.astype(np.float32)


class LearnedSimulator(nn.Module):
    """Next positions from position histories, through :class:`EncodeProcessDecode`."""

    def __init__(self, settings: ModelSettings, normalization: Normalization, bounds: np.ndarray):
        super().__init__()
        self.settings = settings
        self.normalization = normalization
        for name in ("velocity_mean", "velocity_std", "acceleration_mean", "acceleration_std"):
            self.register_buffer(name, torch.tensor(getattr(normalization, name), dtype=torch.float32))
        self.register_buffer("bounds", torch.tensor(np.asarray(bounds), dtype=torch.float32))
        self.type_embedding = nn.Embedding(PARTICLE_TYPES, TYPE_EMBEDDING)
        node_features = 2 * settings.history + 4 + TYPE_EMBEDDING + 1
        if settings.acceleration_features:
            node_features += 2 * (settings.history - 1)
        if settings.static_features:
            node_features += STATIC
        self.network = EncodeProcessDecode(
            node_features,
            3,
            3 if settings.rest_head else 2,
            settings.latent_size,
            settings.mlp_width,
            settings.mlp_hidden_layers,
            settings.message_passing_steps,
        )

    def config(self) -> dict:
        """What it takes to rebuild this simulator (saved with the weights)."""
        return {
            "settings": asdict(self.settings),
            "normalization": asdict(self.normalization),
            "bounds": self.bounds.tolist(),
        }

    def graph_features(self, graph: GraphInput, senders: torch.Tensor, receivers: torch.Tensor):
        radius = self.settings.radius_m
        last = graph.positions[:, -1]
        raw_velocities = graph.positions[:, 1:] - graph.positions[:, :-1]
        velocities = (raw_velocities - self.velocity_mean) / self.velocity_std
        walls = torch.cat([last - self.bounds[:, 0], self.bounds[:, 1] - last], dim=1) / radius
        norm = self.normalization
        tan_friction = (graph.tan_friction - norm.tan_friction_mean) / norm.tan_friction_std
        parts = [velocities.flatten(1)]
        if self.settings.acceleration_features:
            accelerations = raw_velocities[:, 1:] - raw_velocities[:, :-1]
            parts.append(((accelerations - self.acceleration_mean) / self.acceleration_std).flatten(1))
        parts += [walls.clamp(-1.0, 1.0), self.type_embedding(graph.particle_type), tan_friction[:, None]]
        if self.settings.static_features:
            if graph.static is None:
                raise ValueError("this GNS reads where each particle started (static_features): the graph has none")
            parts.append(graph.static)
        nodes = torch.cat(parts, dim=1)
        displacement = (last[senders] - last[receivers]) / radius
        edges = torch.cat([displacement, displacement.norm(dim=1, keepdim=True)], dim=1)
        return nodes, edges

    def forward(self, graph: GraphInput, edges: tuple[torch.Tensor, torch.Tensor] | None = None) -> torch.Tensor:
        """Normalised acceleration [N, 2] of every particle; with the rest head a third column, the logit that the
        particle is at rest after the step."""
        senders, receivers = (
            edges if edges is not None else radius_graph(graph.positions[:, -1], graph.batch, self.settings.radius_m)
        )
        nodes, edge_features = self.graph_features(graph, senders, receivers)
        return self.network(nodes, edge_features, senders, receivers)

    def next_positions(self, graph: GraphInput, edges: tuple[torch.Tensor, torch.Tensor] | None = None) -> torch.Tensor:
        """Semi-implicit Euler with dt = 1 frame: v' = v + a, x' = x + v'."""
        return self.step(graph, edges)[0]

    def step(
        self, graph: GraphInput, edges: tuple[torch.Tensor, torch.Tensor] | None = None
    ) -> tuple[torch.Tensor, torch.Tensor | None]:
        """:meth:`next_positions` and the rest head's logits [N] (None without the head)."""
        output = self(graph, edges)
        acceleration = output[:, :2] * self.acceleration_std + self.acceleration_mean
        velocity = graph.positions[:, -1] - graph.positions[:, -2] + acceleration
        return graph.positions[:, -1] + velocity, output[:, 2] if self.settings.rest_head else None

    def at_rest(self, previous: torch.Tensor, following: torch.Tensor) -> torch.Tensor:
        """The rest head's label [N]: 1 where a particle moves less than ``rest_m`` from ``previous`` to ``following``."""
        return ((following - previous).norm(dim=1) < self.settings.rest_m).to(following.dtype)


def random_walk_noise(
    positions: torch.Tensor, noise_std: float, generator: torch.Generator | None = None
) -> torch.Tensor:
    """Noise [N, T, 2] for a position history: a random walk of velocities whose last step has
    standard deviation ``noise_std``; the first position is left clean."""
    steps = positions.shape[1] - 1
    velocity_noise = torch.randn(positions.shape[0], steps, 2, generator=generator) * (noise_std / steps**0.5)
    walk = torch.cumsum(velocity_noise, dim=1)
    return torch.cat([torch.zeros_like(walk[:, :1]), torch.cumsum(walk, dim=1)], dim=1).to(positions)


class OneStepLoss(nn.Module):
    """MSE of normalised accelerations, averaged per graph then over graphs (so each trajectory
    weighs the same whatever its size, and a batch split across processes averages to the same
    gradient). Normalised targets are clipped at ``target_clip``. With ``moving_weight`` w > 0 a particle
    that moves more than ``moving_m`` over its window (history and target) weighs 1 + w in its graph's mean,
    so that material at rest, most of a slope most of the time, does not swamp the loss. Calling this module,
    wrapped or not in DistributedDataParallel, is one step."""

    def __init__(
        self,
        simulator: LearnedSimulator,
        target_clip: float | None = None,
        moving_weight: float = 0.0,
        moving_m: float = 0.05,
    ):
        super().__init__()
        self.simulator, self.target_clip = simulator, target_clip
        self.moving_weight, self.moving_m = moving_weight, moving_m

    def forward(self, graph: GraphInput, target: torch.Tensor, noise: torch.Tensor) -> torch.Tensor:
        noisy = graph.moved_to(graph.positions + noise)
        # the target keeps the clean next position moved by the last noise step: only velocities are noised
        target_normalized = self.normalized_target(noisy, target + noise[:, -1])
        output = self.simulator(noisy)
        error = (output[:, :2] - target_normalized).pow(2).sum(dim=1)
        loss = self._graph_mean(error, graph, self.weights(graph, target))
        if self.simulator.settings.rest_head:
            loss = loss + self.rest_loss(output[:, 2], graph.positions[:, -1], target, graph)
        return loss

    def rest_loss(self, logits: torch.Tensor, previous: torch.Tensor, following: torch.Tensor, graph: GraphInput):
        """The rest head's binary cross-entropy against the clean step from ``previous`` to ``following``, averaged
        per graph then over graphs."""
        label = self.simulator.at_rest(previous, following)
        return self._graph_mean(nn.functional.binary_cross_entropy_with_logits(logits, label, reduction="none"), graph)

    def mean_predictor(self, graph: GraphInput, target: torch.Tensor) -> torch.Tensor:
        """The loss of always predicting the mean acceleration (0 normalised), noise-free: the baseline."""
        error = self.normalized_target(graph, target).pow(2).sum(dim=1)
        return self._graph_mean(error, graph, self.weights(graph, target))

    def weights(self, graph: GraphInput, target: torch.Tensor) -> torch.Tensor | None:
        """Each particle's weight [N] in its graph's mean (None: all alike)."""
        if not self.moving_weight:
            return None
        moved = (target - graph.positions[:, 0]).norm(dim=1) > self.moving_m
        return 1.0 + self.moving_weight * moved.to(target.dtype)

    def normalized_target(self, graph: GraphInput, target: torch.Tensor) -> torch.Tensor:
        """The acceleration that reaches ``target`` from the last two positions, normalised and clipped."""
        sim = self.simulator
        acceleration = target - 2 * graph.positions[:, -1] + graph.positions[:, -2]
        normalized = (acceleration - sim.acceleration_mean) / sim.acceleration_std
        if self.target_clip:  # a free fall or a floor impact of 26 g must not outweigh everything else
            normalized = normalized.clamp(-self.target_clip, self.target_clip)
        return normalized

    @staticmethod
    def _graph_mean(error: torch.Tensor, graph: GraphInput, weights: torch.Tensor | None = None) -> torch.Tensor:
        if weights is not None:
            error = error * weights
        per_graph = torch.zeros(graph.n_graphs, device=error.device).index_add_(0, graph.batch, error)
        if weights is None:
            counts = torch.bincount(graph.batch, minlength=graph.n_graphs).clamp_min(1)
        else:
            counts = torch.zeros(graph.n_graphs, device=error.device).index_add_(0, graph.batch, weights)
        return (per_graph / counts).mean()


class RolloutLoss(OneStepLoss):
    """A loss over a rollout of the model's own steps: from a window's (noised) history the model steps
    ``targets.shape[1]`` times on its own predictions, gradients through every step, put back inside the walls as a
    rollout is. Step k is scored by its position error over k(k + 1)/2, in units of the acceleration's spread: the
    mean acceleration error over the first k steps, which for k = 1 is the one-step loss's error and which a bias
    the model keeps step after step (a deposit that does not come to rest) cannot average away. The loss is the mean
    over the steps, each normalised error clipped at ``target_clip``; with the rest head each step adds the head's
    cross-entropy against the clean step (:meth:`OneStepLoss.rest_loss`)."""

    def forward(self, graph: GraphInput, targets: torch.Tensor, noise: torch.Tensor) -> torch.Tensor:
        sim = self.simulator
        positions = graph.positions + noise
        clean = torch.cat([graph.positions[:, -1:], targets], dim=1)  # the rest head's labels: the clean steps
        targets = targets + noise[:, -1:]  # as OneStepLoss's: the noise's last offset is kept, its velocity undone
        total = torch.zeros((), device=positions.device)
        for k in range(targets.shape[1]):
            following, logits = sim.step(graph.moved_to(positions))
            if logits is not None:
                total = total + self.rest_loss(logits, clean[:, k], clean[:, k + 1], graph)
            following = torch.maximum(torch.minimum(following, sim.bounds[:, 1]), sim.bounds[:, 0])
            error = (following - targets[:, k]) / (sim.acceleration_std * (k + 1) * (k + 2) / 2)
            if self.target_clip:
                error = error.clamp(-self.target_clip, self.target_clip)
            total = total + self._graph_mean(error.pow(2).sum(dim=1), graph, self.weights(graph, targets[:, k]))
            positions = torch.cat([positions[:, 1:], following[:, None]], dim=1)
        return total / targets.shape[1]
