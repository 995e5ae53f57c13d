"""The end-state surrogate's card (rgns/models/endstate_general_card.{json,md}), what it serves, and its
learning curve.

The model is tied to the lattice spacing it reads (the mesh), to the MPM it imitates (its material,
gravity and run length) and to what it was trained on. A model with ``body`` position features
(rgns.surrogates.endstate.lattice) serves any domain up to the one it was trained in (``bounds``); a first,
``domain``-feature model only its own. A config that differs in a tied key, or exceeds a bound, is
refused with the key named. The slopes and soils it learned (``ranges``: generator parameters,
field statistics, body heights) are stated; a Monte Carlo case outside them is not refused but
named, and the validation gate decides on it as on every case.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from rgns.surrogates.shipped import ShippedModelError, data_fingerprint, refuse_unserved, tied_values

DOMAIN_KEYS = (("domain", "length_m"), ("domain", "height_m"))
TIED_KEYS = (
    ("mesh", "cell_size_m"),
    ("mesh", "particles_per_cell"),
    ("mpm", "duration_s"),
    ("mpm", "gravity_m_s2"),
    ("mpm", "density_kg_m3"),
    ("mpm", "cohesion_pa"),
    ("mpm", "youngs_modulus_pa"),
    ("mpm", "floor_friction"),
)
SERVED_KEYS = DOMAIN_KEYS + TIED_KEYS
FIELD_RANGE_KEYS = ("friction_mean_deg", "friction_std_deg", "correlation_length_x_m", "correlation_length_y_m")


def served(config: dict[str, Any], features: str = "domain") -> dict[str, Any]:
    """The values of the keys the model is tied to (with body features, the domain is a bound instead)."""
    return tied_values(config, TIED_KEYS if features == "body" else SERVED_KEYS)


def check_serves(card: dict[str, Any], config: dict[str, Any]) -> None:
    """Raise naming every tied key whose value differs between the card and ``config``, and every
    domain extent beyond the card's bounds."""
    beyond = [
        f"{key} is {value!r}, the model serves at most {card['bounds'][key]!r}"
        for key, value in tied_values(config, DOMAIN_KEYS).items()
        if key in card.get("bounds", {}) and value > card["bounds"][key]
    ]
    try:
        refuse_unserved(card["serves"], config, "end-state surrogate", "endstate.model")
    except ShippedModelError as error:
        if not beyond:
            raise
        raise ShippedModelError(f"{error}; and {'; '.join(beyond)}") from error
    if beyond:
        raise ShippedModelError(
            "the shipped end-state surrogate does not serve this config: "
            + "; ".join(beyond)
            + " (a smaller domain that still holds the slope and its runout, or endstate.model: "
            "train)"
        )


def training_ranges(config: dict[str, Any], cases: list[str]) -> dict[str, Any]:
    """What the training sets drew: each field statistic's [min, max] over the sets, and each
    family's generator parameters or vertices."""
    groups = [group for case in cases for group in config["sets"][case]]
    field = {}
    for key in FIELD_RANGE_KEYS:
        values = [v for group in groups for v in (group[key] if isinstance(group[key], list) else [group[key]])]
        field[key] = [float(min(values)), float(max(values))]
    families = {group["family"]: config["geometry"]["families"][group["family"]] for group in groups}
    return {"field": field, "families": families}


def body_height_m(vertices: np.ndarray) -> float:
    """A polygon's height above the floor."""
    return float(np.asarray(vertices)[:, 1].max())


def outside_ranges(card: dict[str, Any], config: dict[str, Any], cases: list[str]) -> list[str]:
    """One line per Monte Carlo case's field statistic or body height outside the card's ranges."""
    from rgns.scene.realizations import mean_vertices  # local: only needed here

    ranges = card.get("ranges")
    if not ranges:
        return []
    lines = []
    for case in (case for case in cases if case in config["sets"]):  # an unknown case is named elsewhere
        for g, group in enumerate(config["sets"][case]):
            for key in FIELD_RANGE_KEYS:
                low, high = ranges["field"][key]
                values = group[key] if isinstance(group[key], list) else [group[key]]
                if min(values) < low or max(values) > high:
                    lines.append(
                        f"config key 'sets.{case}[{g}].{key}' = {group[key]!r} is outside the end-state "
                        f"surrogate's training range [{low:g}, {high:g}]: its validation gate decides"
                    )
            height = body_height_m(mean_vertices(config["geometry"]["families"][group["family"]]))
            low, high = card["ranges"]["body_height_m"]
            if not low <= height <= high:
                lines.append(
                    f"config key 'sets.{case}[{g}].family' = {group['family']!r}: a body {height:.1f} m high "
                    f"is outside the end-state surrogate's training range [{low:g}, {high:g}] m: its "
                    "validation gate decides"
                )
    return lines


def evaluation_of(history: list[dict[str, Any]], shipped: bool = False) -> dict[str, Any]:
    """What the report says of a trained model: steps, wall time, the last held-out losses."""
    last = history[-1]
    return {
        "steps": int(last["step"]),
        "wall_s": float(last["elapsed_s"]),
        "valid_loss": float(last["valid_loss"]),
        "valid_mean_predictor_loss": float(last["valid_mean_predictor_loss"]),
        "shipped": shipped,
    }


def started_from(model_path: str | Path, card_path: str | Path) -> dict[str, Any]:
    """What a fine-tuned model started from: the model file's SHA-256 and its own training, from its card."""
    card = json.loads(Path(card_path).read_text())
    return {
        "sha256": data_fingerprint([model_path]),
        "steps": card["steps"],
        "wall_s": card["wall_s"],
        "hardware": _hardware(card["config"]),
        "sets": len(card["cases"]),
        "data_seed": card["config"]["endstate"]["data_seed"],
        "started_from": card.get("started_from"),
    }


def make_card(
    config: dict[str, Any],
    data_paths: list[str],
    history: list[dict[str, Any]],
    cases: list[str],
    start: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The card of a trained model: what it was trained on and how (``start``: what it was fine-tuned from,
    :func:`started_from`), and what it serves."""
    section = config["endstate"]
    evaluation = evaluation_of(history, shipped=True)
    features = section.get("features", "domain")
    card = {
        "config": config,
        "cases": list(cases),
        "data_fingerprint": data_fingerprint(data_paths),
        "realizations_per_case": section["realizations"],
        "held_out_per_case": section["held_out"],
        "steps": evaluation["steps"],
        "wall_s": evaluation["wall_s"],
        "evaluation": evaluation,
        "features": features,
        "serves": served(config, features),
    }
    if start is not None:
        card["started_from"] = start
    if features == "body":
        card["bounds"] = tied_values(config, DOMAIN_KEYS)
        card["ranges"] = training_ranges(config, cases) | {"body_height_m": body_heights(config, cases, data_paths)}
    return card


def body_heights(config: dict[str, Any], cases: list[str], data_paths: list[str]) -> list[float]:
    """The lowest and highest body of the training data (top of the material points + half a spacing)."""
    from rgns.surrogates.endstate.data import read_end_states  # local: h5py only when making a card

    spacing = config["mesh"]["cell_size_m"] / config["mesh"]["particles_per_cell"]
    tops = [float(state.initial[:, 1].max()) + spacing / 2 for state in read_end_states(data_paths)]
    return [min(tops), max(tops)]


def _serves_lines(card: dict[str, Any]) -> list[str]:
    """The card's "What it serves" section."""
    tied = [f"* `{key}`: {value}" for key, value in card["serves"].items()]
    if "bounds" not in card:
        groups = {case: card["config"]["sets"][case] for case in card["cases"]}
        return [
            "Configs whose keys below equal these values; `rgns.surrogates.endstate.card.check_serves` refuses any other, "
            "naming the key. It learned the random-field models of these test cases (family and field "
            "statistics); the validation gate re-checks it against fresh MPM runs on every run.",
            "",
            *tied,
            *(f"* `{case}`: {json.dumps(group)}" for case, group in groups.items()),
        ]
    ranges = card["ranges"]
    return [
        "Refused, naming the key (`rgns.surrogates.endstate.card.check_serves`): a config whose keys below differ, or a "
        "domain beyond the bounds. Any domain up to the bounds is served: the model reads positions relative to "
        "the floor and the ground surface, and a slope's image does not depend on the domain around it.",
        "",
        *tied,
        *(f"* `{key}` ≤ {value}" for key, value in card["bounds"].items()),
        "",
        "Learned, and stated here (`rgns.surrogates.endstate.card.outside_ranges` names a Monte Carlo case outside them; its "
        "validation gate decides, as for every case):",
        "",
        *(f"* `{key}`: {low:g} – {high:g}" for key, (low, high) in ranges["field"].items()),
        f"* body height above the floor: {ranges['body_height_m'][0]:.1f} – {ranges['body_height_m'][1]:.1f} m",
        "* geometry families:",
        "",
        "| family | kind | parameters or vertices |",
        "| --- | --- | --- |",
        *(
            f"| {name} | {family.get('generator', 'polygon')} | "
            f"{json.dumps(family.get('params', family.get('vertices')))} |"
            for name, family in ranges["families"].items()
        ),
    ]


def _validation_source(card: dict[str, Any]) -> list[str]:
    """Where the validation table's realizations come from, when the card was validated on its own sets."""
    section = card["config"]["endstate"].get("validation", {})
    if not section.get("sets"):
        return []
    loss = card["config"]["endstate"].get("threshold_weight", 0.0)
    trained = f"; trained with the moved / not-moved term at weight {loss:g}" if loss else ""
    return [
        f"{section['realizations']} realizations per set drawn from seed {section['data_seed']} "
        f"(`endstate.validation.data_seed`), run by the embedded MPM; R², NRMSE and bias with bootstrap 95 % "
        f"intervals over realizations{trained}. "
        + (
            f"The training data's seed is {card['config']['endstate']['data_seed']}: none of these trained it."
            if section["data_seed"] != card["config"]["endstate"]["data_seed"]
            else "**The training data's seed: these realizations may have trained it.**"
        ),
        "",
        *(f"* {name}: {distribution_of(card, name)}" for name in section["sets"]),
        "",
    ]


def distribution_of(card: dict[str, Any], name: str) -> str:
    """Whether a validation set of an end-state card lies in its training distribution (:func:`distribution`)."""
    sets = card["config"]["sets"]
    trained = {group["family"] for case in card["cases"] for group in sets[case]}
    return distribution(trained, card["ranges"]["field"], sets[name])


def distribution(trained: set[str], ranges: dict[str, list[float]], groups: list[dict[str, Any]]) -> str:
    """Whether the realization groups of a set lie in a model's training distribution: their geometry family among
    the ``trained`` ones or not, and their field statistics within the trained ``ranges`` ([min, max] per key of
    FIELD_RANGE_KEYS) or not."""
    family = "family trained on" if all(g["family"] in trained for g in groups) else "family never trained on"
    outside = sorted(
        {
            key
            for g in groups
            for key in FIELD_RANGE_KEYS
            for value in (g[key] if isinstance(g[key], list) else [g[key]])
            if not ranges[key][0] <= value <= ranges[key][1]
        }
    )
    field = f"field outside the trained ranges ({', '.join(outside)})" if outside else "field within the trained ranges"
    inside = family == "family trained on" and not outside
    return f"{'in' if inside else 'OUT OF'} distribution ({family}, {field})"


def _hardware(config: dict[str, Any]) -> str:
    """Where the training and its data's MPM runs ran."""
    device = config["endstate"].get("device", "cpu")
    if device == "cpu":
        return f"{config['endstate']['threads']} CPU threads"
    return f"training on {device}, the data's MPM batches on {config['mpm']['embedded']['device']}"


def _produced_lines(card: dict[str, Any]) -> list[str]:
    """How the pipeline made the model: one run, or a first model then its fine-tuning."""
    command = "snakemake --cores 2 --configfile config/pretrain_general.yaml{} --directory work/pretrain_general "
    if "started_from" not in card:
        return [f'Produced by the pipeline: `{command.format("")}pretrain_endstate` (docs: "The end-state surrogate").']
    return [
        f"Produced by the pipeline in two stages: `{command.format('')}pretrain_endstate` trains a first model, then "
        f"`{command.format(' config/pretrain_general_wide.yaml')}pretrain_endstate` fine-tunes it "
        '(`endstate.model: finetune`; docs: "The end-state surrogate").'
    ]


def _start_lines(card: dict[str, Any]) -> list[str]:
    """The training bullet of the model a fine-tuned one started from."""
    start = card.get("started_from")
    if start is None:
        return []
    return [
        f"* fine-tuned from a model (SHA-256 `{start['sha256'][:16]}…`) trained {start['steps']} steps in "
        f"{start['wall_s'] / 60:.1f} min ({start['hardware']}) on {start['sets']} sets drawn from seed "
        f"{start['data_seed']}; then, on the data above:"
    ]


def render_card(
    card: dict[str, Any],
    validation_markdown: str,
    validation_title: str = "Validation against fresh MPM runs of the test cases",
) -> str:
    """The card as Markdown, with a validation table against fresh MPM runs."""
    last = card["evaluation"]
    per = "set" if "bounds" in card else "test case"
    lines = [
        "# The shipped end-state surrogate: model card",
        "",
        *_produced_lines(card),
        "",
        "## What it serves",
        "",
        *_serves_lines(card),
        "",
        "## Training",
        "",
        f"* data: {card['realizations_per_case']} realizations per {per} ({len(card['cases'])} sets) drawn from seed "
        f"{card['config']['endstate']['data_seed']} and run by the embedded MPM, plus {card['held_out_per_case']} "
        f"held out per {per}; SHA-256 `{card['data_fingerprint'][:16]}…`",
        *_start_lines(card),
        f"* {card['steps']} steps in {card['wall_s'] / 60:.1f} min ({_hardware(card['config'])}); the last iterate "
        "is kept (one-cycle learning rate)",
        f"* held-out loss at the end {last['valid_loss']:.4g} against the mean predictor's "
        f"{last['valid_mean_predictor_loss']:.4g} ({last['valid_loss'] / last['valid_mean_predictor_loss']:.4f} of it)",
        "",
        "![learning curve](endstate_curve.png)",
        "",
        f"## {validation_title}",
        "",
        *_validation_source(card),
        validation_markdown.strip(),
        "",
        "## Config it was trained with",
        "",
        "```json",
        json.dumps(card["config"], indent=2),
        "```",
        "",
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
    axis.semilogy(steps, [row["valid_mean_predictor_loss"] for row in history], "k--", label="mean predictor, held out")
    axis.set_xlabel("step")
    axis.set_ylabel("MSE of scaled final displacement")
    axis.legend()
    figure.savefig(path, dpi=110)
    plt.close(figure)
