"""Rule train_endstate: the end-state surrogate trained on the test cases' training chunks."""

import json
from pathlib import Path

from rgns.logsetup import log_to_file
from rgns.surrogates.endstate.card import evaluation_of, plot_learning_curve
from rgns.surrogates.endstate.data import read_end_states
from rgns.surrogates.endstate.lattice import Lattice
from rgns.surrogates.endstate.train import EndStateTrainSettings, train, write_history

log = log_to_file(snakemake.log[0], "rgns")
params = snakemake.params
section = params.endstate
settings = EndStateTrainSettings(
    **{key: section[key] for key in EndStateTrainSettings.__dataclass_fields__ if key not in ("widths", "threshold_m")},
    widths=tuple(section["widths"]),
    threshold_m=params.threshold_m,
)
states = read_end_states(snakemake.input)
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
model, history = train(training, held_out, lattice, settings, params.checkpoints)
model.save(snakemake.output.model, {"history": history, "settings": settings.__dict__})
write_history(history, snakemake.output.history)
plot_learning_curve(history, snakemake.output.curve)
Path(snakemake.output.evaluation).write_text(json.dumps(evaluation_of(history), indent=2) + "\n")
