"""Rule validate: agreement of the learned simulator (GNS or end-state surrogate) with MPM over every
test case (Table 3, Figs. 8-12)."""

import json
from pathlib import Path

import numpy as np

from rgns.logsetup import log_to_file
from rgns.surrogates.gate import SURROGATE_NAMES, judge, write_verdicts
from rgns.surrogates.validation import best_median_worst, case_agreement, ok_rows, validation_table
from rgns.surrogates.validation_plots import plot_energy_evolution, plot_histograms, plot_parity
from rgns.tables import markdown_table, read_csv, write_csv

log = log_to_file(snakemake.log[0])
settings = snakemake.params.validation
cases = list(snakemake.params.cases)
pairs = {
    case: read_csv(path, ["index", "gns_status", "final_position_mse_m2"])
    for case, path in zip(cases, snakemake.input.pairs)
}
agreements, summaries = {}, []
for case in cases:
    agreements[case], summary = case_agreement(pairs[case], case, settings["bootstrap"], settings["confidence"])
    summaries.append(summary)
table = validation_table(agreements)
write_csv(table, snakemake.output.table)
Path(snakemake.output.markdown).write_text(markdown_table(table))
Path(snakemake.output.summary).write_text(json.dumps(summaries, indent=2) + "\n")
verdicts = judge(table, summaries, settings["acceptance"], snakemake.params.cell_size_m, snakemake.params.surrogate)
write_verdicts(verdicts, snakemake.output.gate)
for verdict in verdicts.values():
    (log.info if verdict.passed else log.warning)("%s", verdict.sentence())
name = SURROGATE_NAMES[snakemake.params.surrogate]
plot_histograms(pairs, snakemake.output.histograms, name)
plot_parity(pairs, snakemake.output.parity, name)
for case, energies_path, figure in zip(cases, snakemake.input.energies, snakemake.output.energy):
    candidates = pairs[case]
    if ok_rows(candidates).empty:
        log.error("%s: every %s rollout diverged; the energy figure shows diverged ones", case, name)
        candidates = candidates.assign(gns_status="ok")
    with np.load(energies_path) as energies:
        plot_energy_evolution(dict(energies), best_median_worst(candidates), case, figure, name)
log.info("validation table:\n%s", markdown_table(table))
