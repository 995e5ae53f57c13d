"""The pretrained GNS shipped with the package (rgns/models/): its card, and whether it serves a config.

The card (``card.json``, rendered as ``card.md``) records the config the model was trained on, a
fingerprint of its training data, its steps, wall time and learning history. A model trained at one
scale is not used at another: its positions are metres, its walls the training domain's, its time
step the training frame interval, so a config that differs in any of those keys is refused with
the keys named (train or fine-tune a model for it instead).
"""

from __future__ import annotations

import hashlib
import json
import logging
import shutil
from pathlib import Path
from typing import Any

import pandas as pd

from rgns.scene.sets import test_cases

log = logging.getLogger(__name__)

MODELS = Path(__file__).resolve().parents[1] / "models"
# config keys a model is tied to: the walls it learned, the resolution and the time step
SERVED_KEYS = (
    ("domain", "length_m"),
    ("domain", "height_m"),
    ("mesh", "cell_size_m"),
    ("mesh", "particles_per_cell"),
    ("mpm", "frame_interval_s"),
    ("mpm", "gravity_m_s2"),
)


class ShippedModelError(ValueError):
    """The shipped model does not serve this config."""


def read_card(directory: str | Path = MODELS, name: str = "card.json") -> dict[str, Any]:
    path = Path(directory) / name
    try:
        return json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise ShippedModelError(f"{path}: not a readable model card ({error})") from error


def tied_values(config: dict[str, Any], keys: tuple[tuple[str, ...], ...] = SERVED_KEYS) -> dict[str, Any]:
    """The values of ``keys`` (paths such as (section, key)) in ``config``, named "section.key" (None if absent)."""

    def value(path: tuple[str, ...]) -> Any:
        node: Any = config
        for part in path:
            node = node.get(part) if isinstance(node, dict) else None
        return node

    return {".".join(key): value(key) for key in keys}


def refuse_unserved(trained: dict[str, Any], config: dict[str, Any], model: str, setting: str) -> None:
    """Raise naming every tied key whose value in ``config`` differs from ``trained`` (its values as trained)."""
    keys = tuple(tuple(name.split(".")) for name in trained)
    wrong = [
        f"{name} is {value!r}, the model was trained at {trained[name]!r}"
        for name, value in tied_values(config, keys).items()
        if value != trained[name]
    ]
    if wrong:
        raise ShippedModelError(
            f"the shipped {model} does not serve this config: "
            + "; ".join(wrong)
            + f" (set {setting}: train to train one for it)"
        )


def served(card: dict[str, Any]) -> dict[str, Any]:
    """The values of the keys the model is tied to, as trained."""
    return tied_values(card["config"])


def check_serves(card: dict[str, Any], config: dict[str, Any]) -> None:
    """Raise naming every tied key whose value differs between the card and ``config``."""
    refuse_unserved(served(card), config, "GNS", "gns.model")


def install(
    directory: str | Path,
    config: dict[str, Any],
    model_out: str | Path,
    curve_out: str | Path,
    evaluation_out: str | Path,
) -> dict[str, Any]:
    """Check the shipped model serves ``config`` and copy it, its learning curve and its evaluation."""
    directory = Path(directory)
    card = read_card(directory)
    check_serves(card, config)
    shutil.copyfile(directory / "gns.pt", model_out)
    shutil.copyfile(directory / "learning_curve.png", curve_out)
    evaluation = card["evaluation"] | {
        "steps": card["steps"],
        "selected_step": card["selected_step"],
        "wall_s": card["wall_s"],
        "shipped": True,
    }
    Path(evaluation_out).write_text(json.dumps(evaluation, indent=2) + "\n")
    return card


def data_fingerprint(paths: list[str | Path]) -> str:
    """SHA-256 over the packed training files' bytes: what the model learned from, exactly."""
    digest = hashlib.sha256()
    for path in paths:
        with open(path, "rb") as handle:
            for block in iter(lambda: handle.read(1 << 20), b""):
                digest.update(block)
    return digest.hexdigest()


def make_card(
    config: dict[str, Any],
    data_paths: list[str | Path],
    history_csv: str | Path,
    evaluation: dict[str, Any],
    summary: dict[str, Any],
) -> dict[str, Any]:
    """The card of a trained model: the config and data it came from, its steps, time and curve."""
    history = pd.read_csv(history_csv)
    validated = history.dropna(subset=["valid_one_step_loss"])
    last = validated.iloc[-1]
    kept = validated[validated["step"] == summary["selected_step"]]
    kept_row = (kept.iloc[0] if len(kept) else last).to_dict()
    return {
        "config": config,
        "data": [Path(p).name for p in data_paths],
        "data_fingerprint": data_fingerprint(data_paths),
        "steps": int(last["step"]),
        "selected_step": int(summary["selected_step"]),
        "wall_s": float(history["elapsed_s"].iloc[-1]),
        "last_validation": {key: float(value) for key, value in last.items() if key.startswith("valid")},
        "kept_validation": {key: float(value) for key, value in kept_row.items() if key.startswith("valid")},
        "evaluation": evaluation,
        "serves": served({"config": config}),
    }


def validation_lines(card: dict[str, Any], validated_with: dict[str, Any]) -> list[str]:
    """What the validation table's realizations are: the validating run's seed, that no choice touched them, and
    per test case (every set but train and valid, as the workflow's) whether it lies in the training distribution
    of the model (its ``train`` set)."""
    from rgns.surrogates.endstate.card import distribution, training_ranges  # local: the end-state cards' helpers

    ranges = training_ranges(card["config"], ["train"])
    seed = validated_with["validation"]["seed"]
    cases = test_cases(validated_with["sets"])
    return [
        f"The {len(cases)} test cases ({', '.join(cases)}): realizations drawn from `validation.seed` {seed} (no "
        f"choice touched them: the model was trained on `config/pretrain.yaml`'s seed {card['config']['seed']} and "
        "its checkpoint chosen on that run's held-out set), run by the embedded MPM and by the GNS after the MPM "
        "hand-over; R², NRMSE and bias with bootstrap 95 % intervals over realizations (`snakemake "
        'results/report/validation/table.md --config \'montecarlo={"simulator": "gns"}\'`, then `rgns model-card '
        "rgns/models/card.json --validation results/report/validation/table.md --validated-with <its config> --out "
        "rgns/models/card.md`).",
        "",
        *(
            f"* {case}: {distribution(set(ranges['families']), ranges['field'], validated_with['sets'][case])}"
            for case in cases
        ),
        "",
    ]


def render_card(
    card: dict[str, Any], validation_markdown: str | None = None, validated_with: dict[str, Any] | None = None
) -> str:
    """The card as Markdown (``card.md``), with the validation table against fresh MPM runs if given, and what its
    realizations are when the validating run's config (``validated_with``) is."""
    kept, last = card["kept_validation"], card["last_validation"]
    ratio = kept["valid_one_step_loss"] / kept["valid_mean_predictor_loss"]
    lines = [
        "# The shipped GNS: model card",
        "",
        "Produced by the pipeline: `snakemake --cores 2 --configfile config/pretrain.yaml --directory work/pretrain "
        'pretrain` (README, "The shipped model").',
        "",
        "## What it serves",
        "",
        "Only configs whose keys below equal these values (positions are metres, walls the training domain's, the "
        "time step the training frame interval); `rgns.surrogates.shipped.check_serves` refuses any other, naming the key.",
        "",
        *(f"* `{key}`: {value}" for key, value in card["serves"].items()),
        "",
        "## Training",
        "",
        f"* data: {', '.join(card['data'])}, SHA-256 `{card['data_fingerprint'][:16]}…`",
        f"* {card['steps']} steps in {card['wall_s'] / 60:.0f} min (one CPU thread); kept: step "
        f"{card['selected_step']}, the best held-out rollout score",
        f"* kept model on {card['config']['gns'].get('validation_windows', 128)} fixed held-out windows: one-step "
        f"loss {kept['valid_one_step_loss']:.4g} against the mean predictor's "
        f"{kept['valid_mean_predictor_loss']:.4g} ({ratio:.2f} of it); mean |R error| over held-out rollouts "
        f"{kept['valid_runout_error_m']:.2f} m (the selection score: the best of the checkpoints compared, so biased "
        "low; the validation below, on fresh MPM runs, is the model's measure)",
        f"* last validation (step {card['steps']}): one-step loss {last['valid_one_step_loss']:.4g}, mean |R error| "
        f"{last['valid_runout_error_m']:.2f} m",
        *(f"* {note}" for note in card.get("notes", [])),
        "",
        "![learning curve](learning_curve.png)",
        "",
    ]
    if validation_markdown:
        about = validation_lines(card, validated_with) if validated_with else []
        lines += ["## Validation against fresh MPM runs of the test cases", "", *about, validation_markdown.strip(), ""]
    lines += ["## Config it was trained with", "", "```json", json.dumps(card["config"], indent=2), "```", ""]
    return "\n".join(lines)


def config_errors(config: dict[str, Any]) -> list[str]:
    """What the shipped models a config selects (the GNS, the end-state surrogate, the tuned one as the cheap
    route) say against it: each error names the key that chose the model; warnings for cases outside a card's
    training ranges go to the log. Torch-free: the cards only."""
    return _shipped_errors(config) + _shipped_endstate_errors(config) + _shipped_tuned_errors(config)


def _shipped_errors(config: dict[str, Any]) -> list[str]:
    """With gns.model: shipped and the GNS the Monte Carlo's simulator, the keys the shipped model is tied to must
    be its own (said before any job runs)."""
    if config["gns"]["model"] != "shipped" or config["montecarlo"]["simulator"] != "gns":
        return []
    try:
        check_serves(read_card(), config)
    except ShippedModelError as error:
        return [f"config key 'gns.model' = 'shipped': {error}"]
    return []


def _shipped_endstate_errors(config: dict[str, Any]) -> list[str]:
    """With the shipped end-state surrogate as the Monte Carlo's simulator, the keys it is tied to must be its own."""
    from rgns.surrogates.endstate.card import check_serves as endstate_serves  # local: only needed here
    from rgns.surrogates.endstate.card import outside_ranges

    if config["montecarlo"]["simulator"] != "endstate" or config["endstate"]["model"] != "general":
        return []
    try:
        card = read_card(MODELS, "endstate_general_card.json")
        endstate_serves(card, config)
    except ShippedModelError as error:
        return [f"config key 'endstate.model' = 'general': {error}"]
    for line in outside_ranges(card, config, config["montecarlo"]["cases"]):
        log.warning(line)
    return []


def _shipped_tuned_errors(config: dict[str, Any]) -> list[str]:
    """With the shipped tuned end-state surrogate as the correction's control, its cases and keys must be this config's."""
    from rgns.surrogates.endstate.tuned_card import check_tuned_serves  # local: only needed here

    fidelity = config["montecarlo"]["fidelity"]
    if not fidelity["paired"] or fidelity["cheap"] != "tuned" or config["endstate"]["tuned"]["model"] != "shipped":
        return []
    try:
        check_tuned_serves(read_card(MODELS, "endstate_tuned_card.json"), config)
    except ShippedModelError as error:
        return [f"config key 'montecarlo.fidelity.cheap' = 'tuned': {error}"]
    return []
