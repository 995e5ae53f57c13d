"""Rule train: train (or resume) the GNS, then evaluate it on the validation set."""

import json
from pathlib import Path

from rgns.logsetup import log_to_file
from rgns.report.plots import plot_learning_curve
from rgns.surrogates.gns.evaluate import evaluate
from rgns.surrogates.gns.rollout import RolloutSettings, warmup_frame_count
from rgns.surrogates.gns.train import load_simulator, settings_from_config, train

log = log_to_file(snakemake.log[0])
params = snakemake.params
model, settings = settings_from_config(
    params.gns, params.cell_size_m, warmup_frame_count(params.warmup_s, params.frame_interval_s)
)
out_dir = Path(snakemake.output.model).parent
summary = train(
    model,
    settings,
    snakemake.input.train,
    snakemake.input.valid,
    out_dir,
    snakemake.output.model,
    init_model=snakemake.input.init[0] if snakemake.input.init else None,
)
plot_learning_curve(snakemake.output.history, snakemake.output.curve)
handover = RolloutSettings(warmup_frames=settings.selection_warmup_frames)
evaluation = (
    evaluate(load_simulator(snakemake.output.model, settings.device), snakemake.input.valid, settings=handover)
    | summary
)
Path(snakemake.output.evaluation).write_text(json.dumps(evaluation, indent=2) + "\n")
log.info(
    "trained %d steps in %.0f s, kept step %d; validation one-step error %.4g m, rollout mean error %.4g m",
    summary["steps"],
    summary["wall_s"],
    summary["selected_step"],
    evaluation["one_step_error_m"],
    evaluation["rollout_mean_error_m"],
)
