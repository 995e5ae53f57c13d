"""The tuned end-state surrogate's card (rgns/models/endstate_tuned_card.{json,md}) and what it serves.

Beyond the base model's ties (lattice, MPM), the tuned model is tied to the accurate mesh it learned
(montecarlo.fidelity.high_cell_size_m) and to the random-field models of the cases it was tuned on;
a config asking it for another case or mesh is refused with the key named.
"""

from __future__ import annotations

import json
from typing import Any

import pandas as pd

from rgns.surrogates.endstate.card import served
from rgns.surrogates.shipped import ShippedModelError, data_fingerprint, refuse_unserved
from rgns.tables import markdown_table

SETTING = "endstate.tuned.model"
# the model a tuning starts from, by endstate.model
BASES = {
    "general": "the geometry-general end-state surrogate (rgns/models/endstate_general.pt)",
    "train": "this run's end-state surrogate (results/model/endstate.pt)",
}


def tuned_served(config: dict[str, Any], cases: list[str]) -> dict[str, Any]:
    """The values of the keys the tuned model is tied to."""
    return (
        served(config)
        | {"montecarlo.fidelity.high_cell_size_m": config["montecarlo"]["fidelity"]["high_cell_size_m"]}
        | {f"sets.{case}": config["sets"][case] for case in cases}
    )


def check_tuned_serves(card: dict[str, Any], config: dict[str, Any]) -> None:
    """Raise naming the key when ``config`` asks the tuned model for a case or a setting it was not tuned at."""
    untuned = [case for case in config["montecarlo"]["cases"] if case not in card["cases"]]
    if untuned:
        raise ShippedModelError(
            f"the shipped tuned end-state surrogate does not serve this config: montecarlo.cases "
            f"has {', '.join(untuned)}, it was tuned on {', '.join(card['cases'])} (set {SETTING}: "
            "train to tune one for them, or montecarlo.fidelity.cheap: simulator)"
        )
    refuse_unserved(card["serves"], config, "tuned end-state surrogate", SETTING)


def make_tuned_card(
    config: dict[str, Any],
    data_paths: list[str],
    history: list[dict[str, Any]],
    before: dict[str, float],
    agreement: pd.DataFrame,
    cases: list[str],
) -> dict[str, Any]:
    """The card: the config and data it came from, the fine-tune's history, and its held-out agreement."""
    last = history[-1]
    return {
        "config": config,
        "cases": list(cases),
        "data_fingerprint": data_fingerprint(data_paths),
        "steps": int(last["step"]),
        "wall_s": float(last["elapsed_s"]),
        "before": before,
        "history": history,
        "evaluation": {
            "steps": int(last["step"]),
            "wall_s": float(last["elapsed_s"]),
            "valid_loss": float(last["valid_loss"]),
            "valid_mean_predictor_loss": float(last["valid_mean_predictor_loss"]),
        },
        "agreement": agreement.to_dict("records"),
        "serves": tuned_served(config, cases),
    }


def render_tuned_card(card: dict[str, Any]) -> str:
    """The card as Markdown."""
    tuned = card["config"]["endstate"]["tuned"]
    cell = card["serves"]["montecarlo.fidelity.high_cell_size_m"]
    last = card["evaluation"]
    lines = [
        "# The shipped tuned end-state surrogate: model card",
        "",
        "Produced by the pipeline: `snakemake --cores 2 --configfile config/pretrain_tuned.yaml --directory "
        'work/pretrain_tuned pretrain_tuned` (docs/fidelity.md, "Multi-fidelity correction"). The control variate of the '
        "multi-fidelity correction (`montecarlo.fidelity.cheap: tuned`); it does not draw a map of its own.",
        "",
        "## What it serves",
        "",
        "Configs whose keys below equal these values, for Monte Carlo cases among "
        f"{', '.join(card['cases'])}; `rgns.surrogates.endstate.tuned_card.check_tuned_serves` refuses any other, naming the key.",
        "",
        *(f"* `{key}`: {json.dumps(value)}" for key, value in card["serves"].items()),
        "",
        "## Tuning",
        "",
        f"* from: {BASES[card['config']['endstate']['model']]}, which learned the MPM at "
        f"{card['serves']['mesh.cell_size_m']} m cells",
        f"* data: {tuned['realizations']} realizations per case drawn from seed {tuned['data_seed']}, run by the "
        f"embedded MPM at {cell} m cells and coarse-grained onto the model's lattice, plus {tuned['held_out']} held "
        f"out per case; SHA-256 `{card['data_fingerprint'][:16]}…`",
        f"* {card['steps']} steps (AdamW, learning rate {tuned['learning_rate']:g} with cosine decay) in "
        f"{card['wall_s'] / 60:.1f} min ({card['config']['endstate']['threads']} CPU threads)",
        f"* held-out loss {card['before']['valid_loss']:.4g} before tuning → {last['valid_loss']:.4g} after "
        f"(mean predictor {last['valid_mean_predictor_loss']:.4g})",
        "",
        "![learning curve](endstate_tuned_curve.png)",
        "",
        f"## Agreement with the held-out {cell} m runs (coarse-grained), before and after tuning",
        "",
        "R, V and I measured on the model's lattice, for the model and for the accurate runs coarse-grained onto "
        "it (what the model learns). Measured on the accurate runs' own points, as the paired runs of every "
        "multi-fidelity report measure them, the fronts are sharper and R longer: that report's correlation and "
        "bias on the pairs are the check against the accurate MPM itself (the correction removes any bias; the "
        "correlation sets its gain).",
        "",
        markdown_table(pd.DataFrame(card["agreement"])).strip(),
        "",
        "## Config it was tuned with",
        "",
        "```json",
        json.dumps(card["config"], indent=2),
        "```",
        "",
    ]
    return "\n".join(lines)
