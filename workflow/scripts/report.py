"""Rule report: the HTML page collecting every figure and table of the run."""

import json
from pathlib import Path

from rgns.logsetup import log_to_file
from rgns.provenance import provenance
from rgns.report.page import build_report
from rgns.tables import read_csv

log = log_to_file(snakemake.log[0])
inputs, params = snakemake.input, snakemake.params
validation_figures = {Path(p).stem: Path(p) for p in inputs.validation_figures}
hazard = {case: {Path(p).name: Path(p) for p in inputs.hazard if Path(p).parent.name == case} for case in params.cases}
learned = params.surrogate is not None  # a plain MPM Monte Carlo has no learned simulator, curve nor validation
page = build_report(
    title="rgns landslide runout hazard report",
    overview=params.config_summary,
    scenes={name: Path(p) for name, p in zip(params.sets, inputs.scenes)},
    learning_curve=Path(inputs.curve[0]) if learned else None,
    evaluation=json.loads(Path(inputs.evaluation[0]).read_text()) if learned else None,
    validation_table=read_csv(inputs.validation_table[0]) if learned else None,
    validation_summary=json.loads(Path(inputs.validation_summary[0]).read_text()) if learned else [],
    validation_figures=validation_figures,
    hazard=hazard,
    gate=json.loads(Path(inputs.gate[0]).read_text()) if inputs.gate else None,
    surrogate=params.surrogate,
    made=provenance(params.config),
)
Path(snakemake.output[0]).write_text(page)
log.info("report of %d Monte Carlo case(s) written (%.1f MB)", len(hazard), len(page) / 1e6)
