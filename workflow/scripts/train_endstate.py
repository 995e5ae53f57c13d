"""Rule train_endstate: the end-state surrogate trained on the sets' training chunks (from the shipped model's
weights with endstate.model finetune)."""

import json
from pathlib import Path

from rgns.logsetup import log_to_file
from rgns.surrogates.endstate.card import evaluation_of, plot_learning_curve
from rgns.surrogates.endstate.data import read_end_states
from rgns.surrogates.endstate.lattice import Lattice
from rgns.surrogates.endstate.model import load_model
from rgns.surrogates.endstate.train import EndStateTrainSettings, train, write_history

log = log_to_file(snakemake.log[0], "rgns")
params = snakemake.params
section = params.endstate
settings = EndStateTrainSettings(
    **{key: section[key] for key in EndStateTrainSettings.__dataclass_fields__ if key not in ("widths", "threshold_m")},
    widths=tuple(section["widths"]),
    threshold_m=params.threshold_m,
)
states = read_end_states(snakemake.input.data)
start = load_model(snakemake.input.start) if snakemake.input.start else None
training = [s for s in states if s.index < section["realizations"]]
held_out = [s for s in states if s.index >= section["realizations"]]
lattice = Lattice.for_domain(
    params.domain["length_m"],
    params.domain["height_m"],
    params.mesh["cell_size_m"],
    params.mesh["particles_per_cell"],
    section["features"],
)
log.info("%d training and %d held-out realizations", len(training), len(held_out))
if start is not None:
    log.info("fine-tuning %s", snakemake.input.start)
model, history = train(training, held_out, lattice, settings, params.checkpoints, start)
model.save(snakemake.output.model, {"history": history, "settings": settings.__dict__})
write_history(history, snakemake.output.history)
plot_learning_curve(history, snakemake.output.curve)
Path(snakemake.output.evaluation).write_text(json.dumps(evaluation_of(history), indent=2) + "\n")
