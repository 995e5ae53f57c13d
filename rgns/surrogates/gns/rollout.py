"""Batched rollout: many realizations advance as one graph, frame by frame.

Options, each switchable so their effect on error can be measured:

* ``skip_rest``: a particle that moved less than ``rest_velocity`` in each of its history frames,
  lies within ``rest_displacement`` of where the rollout started it, and whose neighbours are at
  rest too, keeps its position; the network runs only on the other particles and
  ``context_hops`` rings of neighbours around them. So the part of a slope that does not fail
  is skipped, while slide particles, even slowing down, are never frozen (freezing them changed
  V by up to 3.7 % of its range per realization); a deposit at rest is ended by early stop.
* ``early_stop``: a realization whose mean squared particle velocity stays below
  ``early_stop_fraction`` of its peak for ``early_stop_frames`` frames stops; its later frames
  repeat its last state.
* ``keep``: ``"all"`` frames, or only the ``"ends"`` a Monte Carlo measurement needs (the first
  and the last two, for R, V, I and the final kinetic energy), which spares copying every frame
  off the device and holding [T, N, 2] per realization.

A simulator with a rest head (``ModelSettings.rest_head``) holds a particle in place for a step where the head
calls it at rest and it lies more than ``rest_displacement`` from where the rollout started it: a deposit comes to
rest, while the slope that has not failed yet is left to the network's accelerations (a particle held at rest with
no velocity would stay so, and failure could never start).
The walls and the floor are rigid: a particle the network moves past one is put back on it (and
counted in ``pushed_back``). A realization with a non-finite position, or a particle moved more than
``domain_margin_m`` past the domain in one frame, is flagged ``diverged`` and stopped; the others go
on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from rgns.surrogates.gns.graph import radius_graph
from rgns.surrogates.gns.simulator import GraphInput, LearnedSimulator, static_features
from rgns.trajectories import SOIL, check_keep, kept_frames


@dataclass
class RolloutSettings:
    skip_rest: bool = False
    rest_velocity: float = 1e-4  # m per frame
    context_hops: int = 1
    rest_displacement: float = 0.1  # m from the start: a particle displaced more is never at rest
    early_stop: bool = False
    early_stop_fraction: float = 0.01
    early_stop_frames: int = 20
    domain_margin_m: float = 5.0
    keep: str = "all"
    warmup_frames: int = 0  # MPM frames a soil rollout starts from (at least history + 1)
    rest_gate: bool = True  # a simulator's rest head holds displaced particles it calls at rest (False: ignored)

    def __post_init__(self) -> None:
        check_keep(self.keep)

    def handover(self, history: int) -> int:
        """MPM frames before the GNS takes over: the warm-up, and at least the ``history + 1`` it reads."""
        return max(self.warmup_frames, history + 1)


def warmup_frame_count(warmup_s: float, frame_interval_s: float) -> int:
    """Frames of a warm-up of ``warmup_s`` seconds, frame 0 included."""
    return int(round(warmup_s / frame_interval_s)) + 1


@dataclass
class RolloutResult:
    positions: np.ndarray  # [len(frame), N, 2], the given history first when keep is "all"
    frame: np.ndarray | None = None  # the frame number of each stored position
    status: str = "ok"
    stopped_at_frame: int | None = None
    node_updates: int = 0  # particles the network was evaluated on, summed over frames
    pushed_back: int = 0  # particle steps the network moved past a wall or the floor, put back on it


def _subgraph(senders: torch.Tensor, receivers: torch.Tensor, keep: torch.Tensor):
    """Edges among the kept nodes, renumbered, and the kept node ids."""
    ids = torch.nonzero(keep).squeeze(1)
    renumber = torch.full((len(keep),), -1, dtype=torch.long, device=keep.device)
    renumber[ids] = torch.arange(len(ids), device=keep.device)
    inside = keep[senders] & keep[receivers]
    return renumber[senders[inside]], renumber[receivers[inside]], ids


@torch.no_grad()
def rollout(
    simulator: LearnedSimulator,
    histories: list[np.ndarray],
    particle_types: list[np.ndarray],
    tan_frictions: list[np.ndarray],
    frames: int,
    settings: RolloutSettings | None = None,
    device: str = "cpu",
    initial: list[np.ndarray] | None = None,
) -> list[RolloutResult]:
    """Roll every realization (history [H+1, N_b, 2]) forward to ``frames`` frames in total (``initial``: where each
    realization's particles started [N_b, 2], for a simulator that reads it; None: its history's first frame)."""
    settings = settings or RolloutSettings()
    device = torch.device(device)
    counts = [h.shape[1] for h in histories]
    history = torch.cat([torch.as_tensor(h, dtype=torch.float32).transpose(0, 1) for h in histories]).to(device)
    types = torch.cat([torch.as_tensor(t, dtype=torch.long) for t in particle_types]).to(device)
    friction = torch.cat([torch.as_tensor(f, dtype=torch.float32) for f in tan_frictions]).to(device)
    batch = torch.cat([torch.full((n,), b, dtype=torch.long) for b, n in enumerate(counts)]).to(device)
    bounds = simulator.bounds.to(device)
    static = None
    if simulator.settings.static_features:
        starts = initial if initial is not None else [h[0] for h in histories]
        bounds_m = bounds.cpu().numpy()
        static = torch.cat([torch.from_numpy(static_features(start, bounds_m)) for start in starts]).to(device)
    n_graphs = len(histories)
    keep_all = settings.keep == "all"
    stored = [list(h.astype(np.float32)) if keep_all else [h[0].astype(np.float32)] for h in histories]
    ends = [[h[-2].astype(np.float32), h[-1].astype(np.float32)] for h in histories]  # last two frames (keep "ends")
    results = [RolloutResult(np.empty(0)) for _ in histories]
    live = torch.ones(n_graphs, dtype=torch.bool, device=device)
    peak = torch.zeros(n_graphs, device=device)
    quiet = torch.zeros(n_graphs, dtype=torch.long, device=device)
    origin = history[:, -1].clone()
    margin = settings.domain_margin_m
    for frame in range(histories[0].shape[0], frames):
        active = live[batch]
        senders, receivers = radius_graph(
            history[:, -1], torch.where(active, batch, n_graphs), simulator.settings.radius_m
        )
        moving_edges = active[senders] & active[receivers]
        senders, receivers = senders[moving_edges], receivers[moving_edges]
        update = active.clone()
        if settings.skip_rest:
            speeds = (history[:, 1:] - history[:, :-1]).norm(dim=2).amax(dim=1)
            awake = (speeds > settings.rest_velocity) | (
                (history[:, -1] - origin).norm(dim=1) > settings.rest_displacement
            )
            near_awake = (
                torch.zeros_like(awake).index_add_(0, receivers, awake[senders])
                if len(senders)
                else torch.zeros_like(awake)
            )
            update = active & (awake | near_awake)
        involved = update.clone()
        for _ in range(settings.context_hops):  # neighbours of updated particles give context
            involved[senders[involved[receivers]]] = True
        sub_senders, sub_receivers, ids = _subgraph(senders, receivers, involved)
        graph = GraphInput(history, types, friction, batch, n_graphs, static).subset(ids)
        new = history[:, -1].clone()
        predicted, rest_logits = simulator.step(graph, (sub_senders, sub_receivers))
        # a displaced particle the rest head calls at rest stays where it is
        if rest_logits is not None and settings.rest_gate:
            last = graph.positions[:, -1]
            resting = (rest_logits > 0) & ((last - origin[ids]).norm(dim=1) > settings.rest_displacement)
            predicted = torch.where(resting[:, None], last, predicted)
        # the walls and the floor are rigid: a particle the network moves past one stays on it
        inside = torch.maximum(torch.minimum(predicted, bounds[:, 1]), bounds[:, 0])
        pushed_back = (inside != predicted).any(1)
        far = ~torch.isfinite(predicted).all(1) | ((predicted - inside).abs() > margin).any(1)
        predicted = torch.where(far[:, None], predicted, inside)
        chosen = update[ids]
        new[ids[chosen]] = predicted[chosen]
        for b in torch.nonzero(live).squeeze(1).tolist():
            mine = chosen & (batch[ids] == b)
            results[b].node_updates += int(mine.sum())
            results[b].pushed_back += int((mine & pushed_back).sum())
        history = torch.cat([history[:, 1:], new[:, None]], dim=1)

        velocity2 = (history[:, -1] - history[:, -2]).pow(2).sum(1)
        mean_v2 = torch.zeros(n_graphs, device=device).index_add_(0, batch, velocity2) / torch.as_tensor(
            counts, device=device, dtype=torch.float32
        )
        outside = torch.zeros_like(update)
        outside[ids[chosen]] = far[chosen]
        bad = torch.zeros(n_graphs, dtype=torch.long, device=device).index_add_(0, batch, outside.long()) > 0
        peak = torch.maximum(peak, mean_v2)
        quiet = torch.where(mean_v2 <= settings.early_stop_fraction * peak, quiet + 1, torch.zeros_like(quiet))
        stopping = live & bad
        if settings.early_stop:
            stopping |= live & (quiet >= settings.early_stop_frames)
        if keep_all or bool(stopping.any()) or frame == frames - 1:
            last_two = np.split(history[:, -2:].transpose(0, 1).cpu().numpy(), np.cumsum(counts)[:-1], axis=1)
            for b in torch.nonzero(live).squeeze(1).tolist():
                kept = last_two[b][:1] if bad[b] else last_two[b]  # a diverged step is not kept
                if keep_all:
                    stored[b].append(kept[-1])
                elif stopping[b] or frame == frames - 1:
                    ends[b] = [kept[0], kept[-1]]
        for b in torch.nonzero(stopping).squeeze(1).tolist():
            if bad[b]:
                results[b].status = f"diverged: a particle left the domain or became non-finite at frame {frame}"
            else:
                results[b].stopped_at_frame = frame
        live &= ~stopping
        if not live.any():
            break
    for b, result in enumerate(results):
        if keep_all:
            stored[b] += [stored[b][-1]] * (frames - len(stored[b]))
        else:
            stopped_early = result.stopped_at_frame is not None and result.stopped_at_frame < frames - 1
            last = ends[b][-1]
            stored[b] += [last, last] if stopped_early or result.status != "ok" else ends[b]
        result.positions = np.stack(stored[b])
        result.frame = kept_frames(settings.keep, frames)
    return results


def rollout_soil(
    simulator: LearnedSimulator,
    histories: list[np.ndarray],
    friction_deg: list[np.ndarray],
    frames: int,
    settings: RolloutSettings | None = None,
    device: str = "cpu",
) -> list[RolloutResult]:
    """Roll out soil-only realizations given each particle's friction angle, from MPM frames
    [W, N, 2] (or more): the GNS takes over after ``settings.warmup_frames`` = W frames of MPM
    (at least ``history + 1``, as every GNS rollout starts from simulator frames). The results
    hold frames from 0, the warm-up's own first."""
    settings = settings or RolloutSettings()
    length = simulator.settings.history + 1
    histories = [np.asarray(h, dtype=np.float32) for h in histories]
    # a warm-up longer than the MPM frames given (or than the run) is all of them
    warmup = min(settings.handover(simulator.settings.history), frames, *(h.shape[0] for h in histories))
    offset = warmup - length
    starts = [h[offset:warmup] for h in histories]
    types = [np.full(h.shape[1], SOIL, dtype=np.int64) for h in histories]
    tan_frictions = [np.tan(np.radians(np.asarray(f, dtype=float))).astype(np.float32) for f in friction_deg]
    initial = [h[0] for h in histories]
    results = rollout(simulator, starts, types, tan_frictions, frames - offset, settings, device, initial)
    for history, result in zip(histories, results):
        if settings.keep == "all":
            result.positions = np.concatenate([history[:offset], result.positions])
        else:
            result.positions[0] = history[0]
        result.frame = kept_frames(settings.keep, frames)
        if result.stopped_at_frame is not None:
            result.stopped_at_frame += offset
    return results
