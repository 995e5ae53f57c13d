"""The end-state surrogate's card (rgns/models/endstate_card.{json,md}), what it serves, and its
learning curve.

The model is tied to the lattice it reads (domain and mesh), to the MPM it imitates (its material,
gravity and run length) and to the random-field models it was trained on (the test cases' sets):
a config that differs in the first two is refused with the keys named; the validation gate
re-checks the last on every run.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from rgns.shipped import data_fingerprint, refuse_unserved, tied_values

SERVED_KEYS = (("domain", "length_m"), ("domain", "height_m"), ("mesh", "cell_size_m"),
               ("mesh", "particles_per_cell"), ("mpm", "duration_s"), ("mpm", "gravity_m_s2"),
               ("mpm", "density_kg_m3"), ("mpm", "cohesion_pa"), ("mpm", "youngs_modulus_pa"), ("mpm", "floor_friction"))


def served(config: dict[str, Any]) -> dict[str, Any]:
    """The values of the keys the model is tied to."""
    return tied_values(config, SERVED_KEYS)


def check_serves(card: dict[str, Any], config: dict[str, Any]) -> None:
    """Raise naming every tied key whose value differs between the card and ``config``."""
    refuse_unserved(card["serves"], config, "end-state surrogate", "endstate.model")


def evaluation_of(history: list[dict[str, Any]], shipped: bool = False) -> dict[str, Any]:
    """What the report says of a trained model: steps, wall time, the last held-out losses."""
    last = history[-1]
    return {"steps": int(last["step"]), "wall_s": float(last["elapsed_s"]), "valid_loss": float(last["valid_loss"]),
            "valid_mean_predictor_loss": float(last["valid_mean_predictor_loss"]), "shipped": shipped}


def make_card(config: dict[str, Any], data_paths: list[str], history: list[dict[str, Any]],
              cases: list[str]) -> dict[str, Any]:
    """The card of a trained model: what it was trained on and how, and what it serves."""
    section = config["endstate"]
    evaluation = evaluation_of(history, shipped=True)
    return {"config": config, "cases": list(cases), "data_fingerprint": data_fingerprint(data_paths),
            "realizations_per_case": section["realizations"], "held_out_per_case": section["held_out"],
            "steps": evaluation["steps"], "wall_s": evaluation["wall_s"], "evaluation": evaluation,
            "serves": served(config)}


def render_card(card: dict[str, Any], validation_markdown: str) -> str:
    """The card as Markdown, with the validation table against fresh MPM runs of the test cases."""
    last = card["evaluation"]
    groups = {case: card["config"]["sets"][case] for case in card["cases"]}
    lines = [
        "# The shipped end-state surrogate: model card", "",
        "Produced by the pipeline: `snakemake --cores 2 --configfile config/pretrain_endstate.yaml --directory "
        "work/pretrain_endstate pretrain_endstate` (README, \"The end-state surrogate\").", "",
        "## What it serves", "",
        "Configs whose keys below equal these values; `rgns.endstate.card.check_serves` refuses any other, naming "
        "the key. It learned the random-field models of these test cases (family and field statistics); the "
        "validation gate re-checks it against fresh MPM runs on every run.", "",
        *(f"* `{key}`: {value}" for key, value in card["serves"].items()),
        *(f"* `{case}`: {json.dumps(group)}" for case, group in groups.items()), "",
        "## Training", "",
        f"* data: {card['realizations_per_case']} realizations per test case drawn from seed "
        f"{card['config']['endstate']['data_seed']} and run by the embedded MPM, plus {card['held_out_per_case']} "
        f"held out per case; SHA-256 `{card['data_fingerprint'][:16]}…`",
        f"* {card['steps']} steps in {card['wall_s'] / 60:.1f} min ({card['config']['endstate']['threads']} CPU "
        "threads); the last iterate is kept (one-cycle learning rate)",
        f"* held-out loss at the end {last['valid_loss']:.4g} against the mean predictor's "
        f"{last['valid_mean_predictor_loss']:.4g} ({last['valid_loss'] / last['valid_mean_predictor_loss']:.4f} of it)",
        "", "![learning curve](endstate_curve.png)", "",
        "## Validation against fresh MPM runs of the test cases", "", validation_markdown.strip(), "",
        "## Config it was trained with", "", "```json", json.dumps(card["config"], indent=2), "```", "",
    ]
    return "\n".join(lines)


def plot_learning_curve(history: list[dict[str, Any]], path: str | Path) -> None:
    """Training and held-out loss against step, beside the mean predictor's held-out loss."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps = [row["step"] for row in history]
    figure, axis = plt.subplots(figsize=(6, 4), constrained_layout=True)
    axis.semilogy(steps, [row["train_loss"] for row in history], label="training")
    axis.semilogy(steps, [row["valid_loss"] for row in history], "o-", label="held out")
    axis.semilogy(steps, [row["valid_mean_predictor_loss"] for row in history], "k--",
                  label="mean predictor, held out")
    axis.set_xlabel("step")
    axis.set_ylabel("MSE of scaled final displacement")
    axis.legend()
    figure.savefig(path, dpi=110)
    plt.close(figure)
