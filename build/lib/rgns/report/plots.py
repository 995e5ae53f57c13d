"""Figures (matplotlib, Agg backend): one function per figure, each writes one file."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from rgns.scene.fields import FrictionField  # noqa: E402
from rgns.scene.geometry import Scene  # noqa: E402


def plot_scenes(scenes: list[Scene], fields: list[FrictionField], path: str | Path) -> None:
    """Polygons and particles coloured by friction angle, one panel per realization."""
    columns = 2 if len(scenes) > 1 else 1
    rows = int(np.ceil(len(scenes) / columns))
    first = scenes[0]
    aspect = first.domain_height_m / first.domain_length_m
    figure, axes = plt.subplots(
        rows,
        columns,
        figsize=(6.0 * columns, 6.0 * columns * aspect * rows / columns + 1.0),
        squeeze=False,
        constrained_layout=True,
    )
    low = min(float(f.friction_deg.min()) for f in fields)
    high = max(float(f.friction_deg.max()) for f in fields)
    for axis, scene, field in zip(axes.flat, scenes, fields):
        points = axis.scatter(
            scene.positions[:, 0],
            scene.positions[:, 1],
            c=field.friction_deg,
            s=2.0,
            cmap="viridis",
            vmin=low,
            vmax=high,
            linewidths=0,
        )
        outline = np.vstack([scene.vertices, scene.vertices[:1]])
        axis.plot(outline[:, 0], outline[:, 1], color="black", linewidth=0.8)
        axis.set_xlim(0, scene.domain_length_m)
        axis.set_ylim(0, scene.domain_height_m)
        axis.set_aspect("equal")
        axis.set_title(
            f"{scene.set_name} {scene.index:04d} ({scene.family}): mean {field.mean_deg:.1f} deg",
            fontsize=9,
        )
        axis.set_xlabel("x (m)")
        axis.set_ylabel("y (m)")
    for axis in list(axes.flat)[len(scenes) :]:
        axis.set_visible(False)
    figure.colorbar(points, ax=axes, label="friction angle (deg)", shrink=0.8)
    figure.savefig(path, dpi=120)
    plt.close(figure)


def plot_learning_curve(history_csv: str | Path, path: str | Path) -> None:
    """Training loss, validation one-step loss beside the mean predictor's on the same windows,
    and the held-out rollout errors of R against step (the model kept is marked)."""
    import pandas as pd

    history = pd.read_csv(history_csv)
    figure, (loss_axis, error_axis) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    loss_axis.semilogy(history["step"], history["train_loss"], label="training (noisy one-step)", alpha=0.6)
    if "valid_one_step_loss" in history:
        valid = history.dropna(subset=["valid_one_step_loss"])
        loss_axis.semilogy(valid["step"], valid["valid_one_step_loss"], "o-", label="validation one-step")
        if "valid_mean_predictor_loss" in valid:
            loss_axis.semilogy(
                valid["step"], valid["valid_mean_predictor_loss"], "k--", label="mean predictor, same windows"
            )
        if "valid_runout_error_m" in valid:
            error_axis.plot(valid["step"], valid["valid_runout_error_m"], "o-", color="C2")
            best = valid.loc[valid["valid_rollout_score"].idxmin()]
            error_axis.plot(
                [best["step"]],
                [best["valid_runout_error_m"]],
                "*",
                color="C3",
                markersize=14,
                label=f"kept: step {int(best['step'])}",
            )
            error_axis.legend()
    loss_axis.set_xlabel("step")
    loss_axis.set_ylabel("MSE of normalised acceleration")
    loss_axis.legend()
    error_axis.set_xlabel("step")
    error_axis.set_ylabel("held-out rollouts: mean |R error| (m)")
    figure.savefig(path, dpi=110)
    plt.close(figure)


def plot_metric_sketch(path: str | Path) -> None:
    """The README's sketch of R, V and I, measured by rgns.engines.metrics on a constructed slide: the
    wedge above a 30° plane through the toe slides 6 m down it and spreads along the floor."""
    from rgns.engines.metrics import crest_x, displaced, runout_metrics
    from rgns.scene.geometry import seed_particles

    vertices = np.array([[0.0, 0.0], [30.0, 0.0], [20.0, 10.0], [0.0, 10.0]])
    initial, volumes = seed_particles(vertices, 0.5, 2)
    angle = np.radians(30.0)
    wedge = initial[:, 1] > (30.0 - initial[:, 0]) * np.tan(angle)
    final = initial.copy()
    depth = (initial[wedge, 1] - (30.0 - initial[wedge, 0]) * np.tan(angle)) / np.cos(angle)
    final[wedge, 0] = 30.0 + (initial[wedge, 0] - 12.0) * 0.9 + 6.0 * (1.0 - depth / 5.0).clip(0.2)
    final[wedge, 1] = depth * 0.45
    crest = crest_x(vertices)
    metrics = runout_metrics(initial, final, volumes, crest)
    moved = displaced(initial, final)

    figure, axis = plt.subplots(figsize=(9, 4.2), constrained_layout=True)
    outline = np.vstack([vertices, vertices[:1]])
    axis.plot(outline[:, 0], outline[:, 1], color="black", linewidth=1.0, label="initial slope")
    axis.scatter(*initial[moved].T, s=1.0, color="#e8a33d", label=f"displaced (≥ 1 m): V = {metrics.volume_m2:.1f} m²")
    axis.scatter(*final[moved].T, s=1.0, color="#8c4f1a", label="deposit (final positions)")
    axis.scatter(*initial[~moved].T, s=1.0, color="#bbbbbb")
    y_arrow = -1.2
    for start, end, text in (
        (metrics.toe_x_m, metrics.front_x_m, f"R = {metrics.runout_m:.1f} m"),
        (metrics.rear_x_m, crest, f"I = {metrics.influence_m:.1f} m"),
    ):
        axis.annotate("", (end, y_arrow), (start, y_arrow), arrowprops={"arrowstyle": "<->"})
        axis.text((start + end) / 2, y_arrow - 0.9, text, ha="center", va="top")
    for x, text in (
        (metrics.toe_x_m, "toe (P99 of\ninitial x)"),
        (metrics.front_x_m, "front (P99 of\ndisplaced final x)"),
        (crest, "crest"),
        (metrics.rear_x_m, "back scarp"),
    ):
        axis.axvline(x, color="grey", linestyle=":", linewidth=0.8)
        axis.text(x, 11.2, text, ha="center", va="bottom", fontsize=8)
    axis.set_xlim(-1, 58)
    axis.set_ylim(-4.5, 19.5)
    axis.set_aspect("equal")
    axis.set_xlabel("x (m)")
    axis.set_ylabel("y (m)")
    axis.legend(loc="upper right", fontsize=8, markerscale=6)
    figure.savefig(path, dpi=130)
    plt.close(figure)
