"""The hazard report: one self-contained HTML page (figures inlined) with captions and tables.

Captions are the ``docs/captions/*.rst`` files that ``snakemake --report`` also uses, rendered
with the same Jinja variables (``snakemake.wildcards``), so both reports say the same thing.
"""

from __future__ import annotations

import base64
import html
import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import jinja2
import pandas as pd

from rgns.surrogates.gate import SURROGATE_NAMES

CAPTIONS = Path(__file__).resolve().parents[2] / "docs" / "captions"
STYLE = """
body { font-family: sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }
h1 { border-bottom: 2px solid #444; } h2 { margin-top: 2em; border-bottom: 1px solid #aaa; }
figure { margin: 1.5em 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #444; margin-top: 0.4em; }
table { border-collapse: collapse; font-size: 0.85em; margin: 1em 0; }
td, th { border: 1px solid #ccc; padding: 3px 8px; text-align: right; } th { background: #f0f0f0; }
.note { background: #fff6d6; padding: 0.5em 1em; border-left: 4px solid #e0b000; }
"""


def caption(name: str, **wildcards: str) -> str:
    """The caption ``docs/captions/<name>.rst`` rendered for ``wildcards``."""
    text = (CAPTIONS / f"{name}.rst").read_text()
    return jinja2.Template(text).render(snakemake=SimpleNamespace(wildcards=SimpleNamespace(**wildcards)))


def rendered(text: str) -> str:
    """A caption's text as HTML: escaped, its reStructuredText literals (``x``) as code."""
    return re.sub(r"``(.+?)``", r"<code>\1</code>", html.escape(text))


def figure(path: str | Path, text: str) -> str:
    """An inlined PNG with its caption."""
    data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
    return (
        f'<figure><img alt="{html.escape(Path(path).name)}" src="data:image/png;base64,{data}">'
        f"<figcaption>{rendered(text)}</figcaption></figure>"
    )


def table(frame: pd.DataFrame, digits: int = 3) -> str:
    """An HTML table, floats rounded."""
    return frame.to_html(index=False, float_format=lambda v: f"{v:.{digits}f}", na_rep="–", border=0)


@dataclass
class Report:
    """Sections of HTML, in order."""

    title: str
    lead: str = ""  # HTML under the title, before the first section
    sections: list[tuple[str, str]] = field(default_factory=list)

    def add(self, heading: str, *parts: str) -> None:
        self.sections.append((heading, "\n".join(parts)))

    def html(self) -> str:
        body = "\n".join(f"<h2>{html.escape(h)}</h2>\n{content}" for h, content in self.sections)
        return (
            f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(self.title)}</title>"
            f"<style>{STYLE}</style></head><body><h1>{html.escape(self.title)}</h1>\n{self.lead}\n{body}\n"
            "</body></html>\n"
        )


def paragraph(text: str, note: bool = False) -> str:
    return f'<p class="note">{html.escape(text)}</p>' if note else f"<p>{html.escape(text)}</p>"


def hazard_sections(report: Report, case: str, files: dict[str, Path]) -> None:
    """One Monte Carlo case: a site's map view, then the best estimate (the multi-fidelity correction,
    where there is one), then the Monte Carlo's own exceedance, convergence and zoning."""
    if "map.png" in files:
        report.add(f"Site: {case} — map view", figure(files["map.png"], caption("site_map", case=case)))
    corrected = "multifidelity.json" in files
    if corrected:
        multifidelity_section(report, case, files)
    own = " (uncorrected: the Monte Carlo's simulator alone)" if corrected else ""
    exceedance = json.loads(files["exceedance.json"].read_text())
    convergence = json.loads(files["convergence.json"].read_text())
    zoning = json.loads(files["zoning.json"].read_text())
    distances = pd.DataFrame(
        [
            {
                "metric": metric,
                "probability": d["probability"],
                "distance_m": d["distance_m"],
                "lower_m": d["lower_m"],
                "upper_m": d["upper_m"],
                "note": d["note"],
            }
            for metric, entry in exceedance["metrics"].items()
            for d in entry["distances"]
        ]
    )
    deterministic = ", ".join(
        f"{metric} {entry['deterministic_m']:.2f} m"
        for metric, entry in exceedance["metrics"].items()
        if entry["deterministic_m"] is not None
    )
    screened = exceedance["screened"]
    stable = f"{screened} found stable by the limit-equilibrium screen and counted as no failure; " if screened else ""
    summary = (
        f"{exceedance['n']} realizations used ({stable}{exceedance['not_ok']} not ok and left out); "
        f"deterministic mean-field realization: {deterministic or 'not available'}."
    )
    report.add(
        f"Hazard: {case} — exceedance{own}",
        paragraph(summary),
        table(distances, 2),
        figure(files["exceedance.png"], caption("exceedance", case=case)),
    )
    converged = ", ".join(
        f"{metric}: "
        + (
            f"converged at n = {entry['converged_at']}"
            if entry["converged_at"]
            else f"not converged within n = {entry['n']}"
        )
        for metric, entry in convergence["metrics"].items()
    )
    report.add(
        f"Hazard: {case} — convergence{own}",
        paragraph(convergence["criterion"]),
        paragraph(converged),
        figure(files["convergence.png"], caption("convergence", case=case)),
    )
    report.add(
        f"Hazard: {case} — zoning{own}",
        table(pd.DataFrame(zoning["zones"]), 2),
        figure(files["zoning.png"], caption("zoning", case=case)),
    )


def _runout_line(case: str, record: dict[str, Any]) -> tuple[str, bool]:
    """One sentence on the mean runout, the Monte Carlo's against the corrected, and whether the interval
    excludes the Monte Carlo's mean."""
    r = record["means"]["runout_m"]
    own = record["simulator_means"]["runout_m"] if "simulator_means" in record else r["low_mean"]
    excluded = not r["lower"] <= own <= r["upper"]
    cheap = (
        ""
        if record.get("cheap_is_simulator", True)
        else f", {r['low_mean']:.2f} m by the correction's cheap route ({record['cheap_route']})"
    )
    line = (
        f"{case}: mean runout {own:.2f} m by the Monte Carlo's simulator{cheap}, {r['estimate']:.2f} m "
        f"[{r['lower']:.2f}, {r['upper']:.2f}] corrected towards the MPM at {record['high_cell_size_m']:g} m cells "
        f"over {record['n_paired']} paired realizations (cheap-route bias on the pairs {r['bias']:+.2f} m, "
        f"correlation {r['correlation']:.3f})"
    )
    if "converged" in record and record["converged"]["means"]["runout_m"]["mesh_step"] is not None:
        c = record["converged"]
        m, order = c["means"]["runout_m"], c["order"]["runout_m"]
        best = m["estimate"]
        excluded = not m["lower"] <= own <= m["upper"]
        line += (
            f"; carried to the converged mesh, {m['estimate']:.2f} m [{m['lower']:.2f}, {m['upper']:.2f}]: the "
            f"{record['high_cell_size_m']:g} m mesh is short by {m['mesh_step']:.2f} m ({m['mesh_step_range'][0]:.2f}"
            f" to {m['mesh_step_range'][1]:.2f} over the order's interval {order[0]:g}–{order[2]:g}; "
            f"Richardson on the {c['n_pairs']} pairs also run at {c['coarse_cell_size_m']:g} m)"
        )
    else:
        best = r["estimate"]
    line += f"; the uncorrected hazard below is biased by about {own - best:+.2f} m" if excluded else ""
    if "converged" in record:
        stays = [f"mean {key}" for key, m in record["converged"]["means"].items() if m["mesh_step"] is None]
        line += (
            f". Not carried to the converged mesh (no convergence order measured, montecarlo.fidelity.mesh_order): "
            f"{', '.join(stays)}; their {record['high_cell_size_m']:g} m values may still differ from the converged "
            "answer (benchmarks/results/mesh_levels.md)"
            if stays
            else ""
        )
        open_ends = [
            f"{key.removesuffix('_m')} exceeded with P {p}"
            for key, entries in record["converged"]["distances"].items()
            for p, entry in entries.items()
            if entry["estimate"] is not None and None in (entry["lower"], entry["upper"])
        ]
        line += (
            f". These runs do not bound the interval of the {', '.join(open_ends)} (a tail the paired "
            "realizations hardly reach): read it as open"
            if open_ends
            else ""
        )
    return line + ".", excluded


def multifidelity_section(report: Report, case: str, files: dict[str, Path]) -> None:
    """The corrected means, exceedance distances and zones beside the uncorrected ones, costs, allocation."""
    record = json.loads(files["multifidelity.json"].read_text())
    own = {} if record.get("cheap_is_simulator", True) else record["simulator_means"]
    means = pd.DataFrame(
        [
            {
                "quantity": f"mean {key}",
                **({"Monte Carlo": own[key]} if own else {}),
                "cheap route": m["low_mean"],
                "corrected": m["estimate"],
                "lower": m["lower"],
                "upper": m["upper"],
                "bias on the pairs": m["bias"],
                "correlation": m["correlation"],
            }
            for key, m in record["means"].items()
        ]
    )
    distances = pd.DataFrame(
        [
            {
                "metric": key,
                "probability": p,
                **({"Monte Carlo (m)": d["simulator"]} if own else {}),
                "cheap route (m)": d["uncorrected"],
                "corrected (m)": d["corrected"],
            }
            for key, curve in record["exceedance"].items()
            for p, d in curve["distances"].items()
        ]
    )
    cost, allocation = record["cost"], record["allocation"]
    parts = [paragraph(_runout_line(case, record)[0])]
    if "converged" in record:
        parts += mesh_chain(record)
    parts += [
        table(means, 3),
        table(distances, 2),
        paragraph(
            f"Cheap route: {record.get('cheap_route', 'the Monte Carlo simulator')}. "
            f"Cost per realization: cheap route {cost['low_s']:.3g} s, accurate MPM {cost['high_s']:.2f} s "
            f"({record['n_low']} and {record['n_paired']} realizations). With the runout correlation "
            f"{allocation['correlation_runout']:.2f}, the optimal ratio of cheap to paired runs is "
            f"{allocation['optimal_ratio']:.1f} and multi-fidelity reaches a given error "
            f"{allocation['speedup_at_equal_error']:.2f}x faster than the accurate MPM alone."
        ),
    ]
    if "target" in allocation:
        target = allocation["target"]
        parts.append(
            paragraph(
                f"For a {record['confidence']:.0%} half-width of {target['half_width_m']:g} m on the "
                f"mean runout: {target['n_high']} paired and {target['n_low']} cheap realizations "
                f"({target['cost']:.0f} s against {target['plain_cost']:.0f} s by the accurate MPM alone)."
            )
        )
    if "plan" in record:
        plan = record["plan"]
        if plan["reached"]:
            verdict = "reached"
        elif plan["needed"] is None:
            verdict = (
                f"NOT reachable with {plan['n_low']} cheap realizations, whatever the pairs "
                "(raise montecarlo.realizations)"
            )
        else:
            verdict = f"NOT reached within the cap of {plan['cap']} pairs (montecarlo.fidelity.max_paired)"
        parts.append(
            paragraph(
                f"Pairs chosen by the run for a {record['confidence']:.0%} half-width of {plan['target_half_width_m']:g} m "
                f"on the mean runout: from a pilot of {plan['pilot']} pairs (std of R {plan['std_m']:.2f} m, correlation "
                f"{plan['correlation']:.3f}) and {plan['n_low']} cheap realizations, {plan['n_paired']} paired; predicted "
                f"half-width {plan['predicted_half_width_m']:.3g} m, {verdict}."
            )
        )
    if "converged" in record:
        zoning = record["converged"]["zoning"]
        parts += [
            paragraph(
                f"Zones at the converged mesh (fronts moved {zoning['front_step_m']:+.2f} m, "
                f"{zoning['front_step_range_m'][0]:+.2f} to {zoning['front_step_range_m'][1]:+.2f} over the "
                f"runout's order interval; back scarps {zoning['rear_step_m']:+.2f} m, "
                f"{zoning['rear_step_range_m'][0]:+.2f} to {zoning['rear_step_range_m'][1]:+.2f}):"
            ),
            table(pd.DataFrame(zoning["zones"]), 2),
            paragraph(f"Zones corrected to the MPM at {record['high_cell_size_m']:g} m cells:"),
        ]
    parts += [
        table(pd.DataFrame(record["zoning"]["zones_corrected"]), 2),
        figure(files["multifidelity.png"], caption("multifidelity", case=case)),
    ]
    title = "multi-fidelity correction and mesh extrapolation" if "converged" in record else "multi-fidelity correction"
    report.add(f"Hazard: {case} — {title}: the best estimate", *parts)


def mesh_chain(record: dict[str, Any]) -> list[str]:
    """The chain of each headline number: the cheap route, its correction to the accurate MPM, the mesh step
    to the converged answer, each with its size and the interval it ends in."""
    c, high = record["converged"], record["high_cell_size_m"]

    def step(entry: dict[str, Any], key: str) -> dict[str, Any]:
        if entry["mesh_step"] is None:
            return {"+ mesh step": None, "order": "none measured: not extrapolated"}
        low_order, order, high_order = c["order"][key]
        return {
            "+ mesh step": entry["mesh_step"],
            "step low": entry["mesh_step_range"][0],
            "step high": entry["mesh_step_range"][1],
            "order": f"{order:g} [{low_order:g}, {high_order:g}]",
        }

    rows = [
        {
            "quantity": f"mean {key}",
            "cheap route": m["cheap_mean"],
            f"+ correction to MPM {high:g} m": m["accurate"] - m["cheap_mean"],
            f"= MPM {high:g} m": m["accurate"],
            "[lower": m["accurate_lower"],
            "upper]": m["accurate_upper"],
            **step(m, key),
            "= best estimate": m["estimate"],
            "[lower ": m["lower"],
            "upper] ": m["upper"],
        }
        for key, m in c["means"].items()
    ]
    rows += [
        {
            "quantity": f"{key} exceeded with P {p}",
            f"= MPM {high:g} m": d["accurate"],
            "[lower": d["accurate_band"][0],
            "upper]": d["accurate_band"][1],
            **step(d, key),
            "= best estimate": d["estimate"],
            "[lower ": d["lower"],
            "upper] ": d["upper"],
        }
        for key, entries in c["distances"].items()
        for p, d in entries.items()
    ]
    return [
        paragraph(
            f"The best estimate, step by step (m, m²): the cheap route on all {record['n_low']} realizations, "
            f"its correction by the {record['n_paired']} pairs run by the MPM at {high:g} m cells, and the "
            f"step from that mesh to the converged one: Richardson extrapolation of the pairs' difference "
            f"between {c['coarse_cell_size_m']:g} m and {high:g} m cells at the order measured for each "
            "quantity (benchmarks/results/mesh_levels.md; none where no asymptotic range was found, and "
            "that quantity stays at the accurate mesh). The mesh error is corrected for; the interval "
            "holds the sampling, the correction's weights and the order's interval."
        ),
        table(pd.DataFrame(rows), 2),
    ]


def fidelity_summary(report: Report, hazard: dict[str, dict[str, Path]]) -> None:
    """At the top: how far the Monte Carlo's simulator is from the accurate MPM, where that was measured."""
    lines = [
        paragraph(*_runout_line(case, json.loads(files["multifidelity.json"].read_text())))
        for case, files in hazard.items()
        if "multifidelity.json" in files
    ]
    if lines:
        report.add("Multi-fidelity check", *lines)


def gate_section(
    report: Report,
    gate: dict[str, dict[str, Any]],
    cases: list[str],
    validation_table: pd.DataFrame,
    surrogate: str = "gns",
) -> None:
    """The validation gate's verdict for every Monte Carlo case and the table it was based on, first."""
    name = SURROGATE_NAMES[surrogate]
    lines = []
    for case in cases:
        verdict = gate.get(case)
        if verdict is None:
            lines.append(paragraph(f"{case}: the Monte Carlo ran MPM as configured; no surrogate was used."))
        elif verdict["passed"]:
            evidence = verdict.get("evidence") or []
            on = f" (the lower end of each R² interval at least the limit: {'; '.join(evidence)})" if evidence else ""
            lines.append(
                paragraph(
                    f"{case}: the {name} passed the validation gate against fresh MPM runs of this "
                    f"case{on}; the Monte Carlo below is drawn from it."
                )
            )
        else:
            then = (
                "the Monte Carlo below was run by MPM instead (on_failure: fallback), so it does not rest "
                f"on the {name}"
                if verdict["simulator"] == "mpm"
                else "the Monte Carlo was stopped"
            )
            lines.append(
                paragraph(
                    f"{case}: the {name} FAILED the validation gate ({'; '.join(verdict['failures'])}); {then}.",
                    note=True,
                )
            )
    for case, verdict in gate.items():  # validated test cases outside the Monte Carlo: their verdicts too
        if case not in cases:
            outcome = "passed" if verdict["passed"] else f"FAILED ({'; '.join(verdict['failures'])})"
            lines.append(
                paragraph(
                    f"{case} (validated, not in the Monte Carlo): the {name} {outcome} the validation gate.",
                    note=not verdict["passed"],
                )
            )
    report.add("Validation gate", *lines, table(validation_table))


def model_section(report: Report, surrogate: str, evaluation: dict[str, Any], learning_curve: Path) -> None:
    """What the learned simulator is and how it trained."""
    if surrogate == "endstate":
        card = evaluation.get("card", "rgns/models/endstate_card.md")
        origin = f"the model shipped with rgns (card: {card}), " if evaluation.get("shipped") else ""
        report.add(
            "End-state surrogate",
            paragraph(
                f"{origin}{evaluation['steps']} training steps; held-out loss "
                f"{evaluation['valid_loss']:.3g} against the mean predictor's "
                f"{evaluation['valid_mean_predictor_loss']:.3g} (mean squared scaled final displacement)."
            ),
            figure(learning_curve, caption("endstate_curve")),
        )
        return
    origin = "the model shipped with rgns (card: rgns/models/card.md), " if evaluation.get("shipped") else ""
    report.add(
        "Graph network simulator",
        paragraph(
            f"{origin}{evaluation.get('steps', '?')} training steps; validation one-step position error "
            f"{evaluation['one_step_error_m']:.3g} m, full-rollout mean position error "
            f"{evaluation['rollout_mean_error_m']:.3g} m over {evaluation['frames']} frames."
        ),
        figure(learning_curve, caption("learning_curve")),
    )


def routes(cases: list[str], gate: dict[str, dict[str, Any]], surrogate: str) -> dict[str, str]:
    """What ran each Monte Carlo case: the surrogate that passed its gate, MPM after a failed gate, or MPM."""
    name = SURROGATE_NAMES[surrogate]
    return {
        case: (
            "MPM (configured)"
            if case not in gate
            else f"{name} (passed its gate)"
            if gate[case]["passed"]
            else f"MPM (the {name} failed its gate)"
            if gate[case]["simulator"] == "mpm"
            else "stopped"
        )
        for case in cases
    }


def provenance_line(made: dict[str, str], case_routes: dict[str, str]) -> str:
    """One line: which code and configuration made the page, when, and the route of each case."""
    route_text = "; ".join(f"{case}: {route}" for case, route in case_routes.items())
    return paragraph(
        f"Made by rgns {made['version']} (commit {made['commit']}) from configuration "
        f"{made['config_digest']} (SHA-256 prefix) on {made['made_utc']}. Monte Carlo: {route_text}."
    )


def shrinkage_notes(hazard: dict[str, dict[str, Path]], validation_summary: list[dict]) -> list[str]:
    """Warnings, for the top of the page, wherever fewer runs entered a result than were made for it:
    validation pairs whose learned run diverged, Monte Carlo realizations that did not finish."""
    notes = [
        paragraph(
            f"{item['case']}: the validation compares {item['realizations'] - item['diverged']} of its "
            f"{item['realizations']} realizations ({item['diverged']} learned runs diverged and are left out).",
            note=True,
        )
        for item in validation_summary
        if item.get("diverged")
    ]
    for case, files in hazard.items():
        exceedance = json.loads(files["exceedance.json"].read_text())
        if exceedance["not_ok"]:
            total = exceedance["n"] + exceedance["not_ok"]
            notes.append(
                paragraph(
                    f"{case}: the hazard rests on {exceedance['n']} of {total} Monte Carlo realizations "
                    f"({exceedance['not_ok']} did not finish and are left out).",
                    note=True,
                )
            )
    return notes


def build_report(
    title: str,
    overview: dict[str, Any],
    scenes: dict[str, Path],
    learning_curve: Path,
    evaluation: dict[str, Any],
    validation_table: pd.DataFrame,
    validation_summary: list[dict],
    validation_figures: dict[str, Path],
    hazard: dict[str, dict[str, Path]],
    gate: dict[str, dict[str, Any]] | None = None,
    surrogate: str = "gns",
    made: dict[str, str] | None = None,
) -> str:
    """The whole page: what made it, the validation gate's verdict, then configuration, model, validation,
    hazard. ``surrogate`` (gns or endstate) is the learned simulator validated, whose curve and evaluation
    these are; ``made`` the provenance (rgns.provenance)."""
    lead = provenance_line(made, routes(list(hazard), gate or {}, surrogate)) if made else ""
    report = Report(title, "\n".join([lead, *shrinkage_notes(hazard, validation_summary)]))
    # the table's columns named after the simulator that ran (its files call every learned simulator gns)
    validation_table = validation_table.rename(
        columns=lambda column: (
            column.replace("gns", SURROGATE_NAMES[surrogate].replace(" ", "_").replace("-", "_"))
            if column.startswith("gns")
            else column
        )
    )
    gate_section(report, gate or {}, list(hazard), validation_table, surrogate)
    fidelity_summary(report, hazard)
    report.add("Configuration", f"<pre>{html.escape(json.dumps(overview, indent=2))}</pre>")
    report.add("Scenes", *(figure(path, caption("scenes", set=name)) for name, path in scenes.items()))
    model_section(report, surrogate, evaluation, learning_curve)
    summary = pd.DataFrame(validation_summary)
    report.add(
        "Validation against MPM",
        table(validation_table),
        table(summary),
        figure(validation_figures["histograms"], caption("histograms")),
        figure(validation_figures["parity"], caption("parity")),
        *(
            figure(path, f"{name}: " + caption("energy"))
            for name, path in validation_figures.items()
            if name not in ("histograms", "parity")
        ),
    )
    for case, files in hazard.items():
        hazard_sections(report, case, files)
    return report.html()
