"""Rule tune_endstate: this run's end-state surrogate trained further on the accurate runs; its card."""

import json
from pathlib import Path

import torch

from rgns.logsetup import log_to_file
from rgns.surrogates.endstate.card import plot_learning_curve
from rgns.surrogates.endstate.data import read_end_states
from rgns.surrogates.endstate.model import load_model
from rgns.surrogates.endstate.train import examples, held_out_loss
from rgns.surrogates.endstate.tuned_card import make_tuned_card, render_tuned_card
from rgns.surrogates.endstate.tuning import TuneSettings, fine_tune, tuning_agreement

log = log_to_file(snakemake.log[0], "rgns")
torch.set_num_threads(snakemake.threads)
config = snakemake.params.config
section = config["endstate"]["tuned"]
settings = TuneSettings(
    steps=section["steps"],
    learning_rate=section["learning_rate"],
    batch_size=config["endstate"]["batch_size"],
    weight_decay=config["endstate"]["weight_decay"],
    gradient_clip=config["endstate"]["gradient_clip"],
)
base, model = load_model(snakemake.input.model), load_model(snakemake.input.model)
states = read_end_states(snakemake.input.data)
train = examples(model, [s for s in states if s.index < section["realizations"]])
held_states = [s for s in states if s.index >= section["realizations"]]
held = examples(model, held_states)
log.info("%d tuning and %d held-out realizations", len(train), len(held))
valid, mean = held_out_loss(model, held)
history = fine_tune(model, train, held, settings)
model.eval().save(snakemake.output.model, {"history": history})
agreement = tuning_agreement(base, model, held_states, config, list(snakemake.params.cases))
card = make_tuned_card(
    config,
    list(snakemake.input.data),
    history,
    {"valid_loss": valid, "valid_mean_predictor_loss": mean},
    agreement,
    list(snakemake.params.cases),
)
plot_learning_curve(history, snakemake.output.curve)
Path(snakemake.output.card).write_text(json.dumps(card, indent=2, default=float) + "\n")
Path(snakemake.output.markdown).write_text(render_tuned_card(card))
log.info("tuned: held-out loss %.4g -> %.4g in %d steps", valid, history[-1]["valid_loss"], settings.steps)
