"""The hazard report: one self-contained HTML page (figures inlined) with captions and tables.

Captions are the ``rgns/report/captions/*.rst`` (package data) files that ``snakemake --report`` also uses, rendered
with the same Jinja variables (``snakemake.wildcards``), so both reports say the same thing.
"""

from __future__ import annotations

import base64
import html
import json
import math
import re
from collections.abc import Collection
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import jinja2
import pandas as pd

from rgns.hazard.exceedance import distance_at
from rgns.hazard.statistics import ZONE_COLOURS, ZONE_LEVELS
from rgns.surrogates.gate import SURROGATE_NAMES

CAPTIONS = Path(__file__).resolve().parent / "captions"
# what is known of a tail distance's interval (exceeded with P at most TAIL_PROBABILITY, its mesh step modelled
# from the cheap route's regressions), as measured (tests/test_documents.py checks the quote against the result file)
TAIL_PROBABILITY = 0.1
TAIL_COVERAGE = (
    "on a synthetic population whose relation bends, its sampling part covered 92.0 % at P 0.1 and 92.5 % at "
    "P 0.01 over 200 replicates, within 3 SE of 95 %, its misses mostly short (the reported interval, which adds "
    "the mesh order's range, covered all: benchmarks/results/pair_coverage_local.md)"
)
STYLE = """
body { font-family: sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }
h1 { border-bottom: 2px solid #444; } h2 { margin-top: 2em; border-bottom: 1px solid #aaa; }
figure { margin: 1.5em 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #444; margin-top: 0.4em; }
table { border-collapse: collapse; font-size: 0.85em; margin: 1em 0; }
td, th { border: 1px solid #ccc; padding: 3px 8px; text-align: right; } th { background: #f0f0f0; }
.note { background: #fff6d6; padding: 0.5em 1em; border-left: 4px solid #e0b000; }
h3 { margin-top: 1.5em; }
details { border-bottom: 1px solid #ddd; margin: 0.4em 0; }
summary { font-size: 1.15em; font-weight: bold; cursor: pointer; padding: 0.3em 0; }
table.answer { font-size: 0.95em; } table.answer td:first-child, table.answer td:last-child { text-align: left; }
table.answer td:first-child { white-space: nowrap; }
ol.notes { font-size: 0.85em; color: #444; margin-top: 0; }
div.zones { display: flex; height: 2.2em; border: 1px solid #888; margin: 0.5em 0 0.2em; }
div.zones div { display: flex; align-items: center; justify-content: center; font-size: 0.85em; overflow: hidden; }
div.axis { display: flex; justify-content: space-between; font-size: 0.8em; color: #555; margin-bottom: 1em; }
"""


def caption(name: str, **wildcards: str) -> str:
    """The caption ``rgns/report/captions/<name>.rst`` rendered for ``wildcards``."""
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


def table(frame: pd.DataFrame, digits: int = 3, classes: str | None = None) -> str:
    """An HTML table, floats rounded (``classes``: its CSS classes)."""
    return frame.to_html(index=False, float_format=lambda v: f"{v:.{digits}f}", na_rep="–", border=0, classes=classes)


@dataclass
class Report:
    """Sections of HTML, in order; a folded one is a <details> element, closed until the reader opens it."""

    title: str
    lead: str = ""  # HTML under the title, before the first section
    sections: list[tuple[str, str, bool]] = field(default_factory=list)

    def add(self, heading: str, *parts: str, folded: bool = False) -> None:
        self.sections.append((heading, "\n".join(parts), folded))

    def html(self) -> str:
        body = "\n".join(
            f"<details><summary>{html.escape(h)}</summary>\n{content}\n</details>"
            if folded
            else f"<h2>{html.escape(h)}</h2>\n{content}"
            for h, content, folded in self.sections
        )
        return (
            f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(self.title)}</title>"
            f"<style>{STYLE}</style></head><body><h1>{html.escape(self.title)}</h1>\n{self.lead}\n{body}\n"
            "</body></html>\n"
        )


def paragraph(text: str, note: bool = False) -> str:
    return f'<p class="note">{html.escape(text)}</p>' if note else f"<p>{html.escape(text)}</p>"


def subheading(text: str) -> str:
    return f"<h3>{html.escape(text)}</h3>"


def _number(value: Any, digits: int) -> str:
    """A number to ``digits`` decimals; None or NaN as an en dash."""
    return "–" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def with_interval(entry: list[Any], digits: int = 3) -> str:
    """[point, lower, upper] as "point [lower, upper]"."""
    point, lower, upper = entry
    return f"{_number(point, digits)} [{_number(lower, digits)}, {_number(upper, digits)}]"


def convergence_parts(case: str, files: dict[str, Path]) -> list[str]:
    """The Monte Carlo's convergence: its criterion, where each metric converged, the figure."""
    convergence = json.loads(files["convergence.json"].read_text())
    converged = ", ".join(
        f"{metric}: "
        + (
            f"converged at n = {entry['converged_at']}"
            if entry["converged_at"]
            else f"not converged within n = {entry['n']}"
        )
        for metric, entry in convergence["metrics"].items()
    )
    return [
        paragraph(convergence["criterion"]),
        paragraph(converged),
        figure(files["convergence.png"], caption("convergence", case=case)),
    ]


def monte_carlo_sections(report: Report, case: str, files: dict[str, Path], part: str) -> None:
    """One Monte Carlo case's own map, as its simulator drew it: its exceedance, zoning and a site's map view
    (``part`` "answer"), its convergence (``part`` "evidence"). Where the case has a multi-fidelity correction
    these are the uncorrected map, all folded among the details (``part`` "details")."""
    own = " (uncorrected: the Monte Carlo's simulator alone)" if "multifidelity.json" in files else ""
    folded = part == "details"
    if part == "evidence":
        report.add(f"Hazard: {case} — convergence{own}", *convergence_parts(case, files))
        return
    if "map.png" in files and not own:  # a corrected case's map view is drawn from its best estimate: its answer
        report.add(f"Site: {case} — map view", figure(files["map.png"], caption("site_map", case=case)), folded=folded)
    exceedance = json.loads(files["exceedance.json"].read_text())
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
        folded=folded,
    )
    if folded:
        report.add(f"Hazard: {case} — convergence{own}", *convergence_parts(case, files), folded=True)
    report.add(
        f"Hazard: {case} — zoning{own}",
        table(pd.DataFrame(zoning["zones"]), 2),
        figure(files["zoning.png"], caption("zoning", case=case)),
        folded=folded,
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
    plain = record.get("route_applied") == "plain MPM"
    line = (
        f"{case}: the cheap route does not pay, so the best estimate is a plain MPM Monte Carlo over the "
        f"{record['n_paired']} paired realizations ({record['allocation']['reason']}; raise "
        "montecarlo.fidelity.paired to narrow it). "
        if plain
        else f"{case}: "
    )
    line += (
        f"mean runout {own:.2f} m by the Monte Carlo's simulator{cheap}, {r['estimate']:.2f} m "
        f"[{r['lower']:.2f}, {r['upper']:.2f}] {'by the MPM alone' if plain else 'corrected towards the MPM'} at "
        f"{record['high_cell_size_m']:g} m cells "
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
        pairs = record["converged"]["n_pairs"]
        thin = [
            f"{key.removesuffix('_m')} exceeded with P {p}"
            for key, entries in record["converged"]["distances"].items()
            for p, entry in entries.items()
            if entry.get("mesh_step") is not None and pairs * float(p) < 1.0
        ]
        line += (
            f". The mesh step of the {', '.join(thin)} rests on the cheap route's regressions beyond the {pairs} "
            "pairs (fewer than one expected beyond that probability): a model's extrapolation (a line whose "
            f"residual spread follows the cheap value), {TAIL_COVERAGE}"
            if thin
            else ""
        )
    return line + ".", excluded


INFLUENCE_UNCONVERGED = (
    "no convergence order measured: at a time step converged in time it still grows a few tenths of a metre each "
    "time the cell is halved, and the default step (CFL 0.2) makes it longer: 12 % on case 1 at 0.5 m cells, "
    "5–13 % at 1 m, and on finer meshes lets a few lifted surface points set it (docs/evidence.md)"
)
UNCONVERGED = {
    "influence_m": INFLUENCE_UNCONVERGED,
    "volume_m2": (
        "no convergence order measured, and the default time step (CFL 0.2) makes it larger than a step converged "
        "in time: 5 % on case 1 at 0.5 m cells, 3–6 % at 1 m (docs/evidence.md)"
    ),
}


def cautions(
    record: dict[str, Any], key: str, p: str | None, upper: float | None, mesh_step: float | None
) -> list[str]:
    """Why to read one number (of quantity ``key``) of the answer with care, each reason in a few words (none where
    nothing is known against it): a best estimate by the MPM alone, a number left at the accurate mesh (the
    influence distance: it has no converged value), a tail distance whose mesh step is modelled (beyond the pairs,
    where fewer than one is expected past P), an interval these runs leave open."""
    said = []
    if record.get("route_applied") == "plain MPM":
        said.append(f"the MPM alone over {record['n_paired']} realizations: the cheap route does not pay")
    if "converged" in record:
        pairs = record["converged"]["n_pairs"]
        if mesh_step is None:
            why = UNCONVERGED.get(key, "no convergence order measured")
            said.append(f"at {record['high_cell_size_m']:g} m cells: {why}")
        elif p is not None and float(p) <= TAIL_PROBABILITY:
            said.append(f"mesh step modelled from the cheap route's regressions: {TAIL_COVERAGE}")
            if pairs * float(p) < 1.0:
                said.append(f"beyond the {pairs} pairs: fewer than one is expected past this probability")
    if p is not None and upper is None:
        said.append("open above: these runs do not bound it")
    return said


def band_ends(curve: dict[str, Any], p: str, entry: dict[str, Any]) -> tuple[float | None, float | None]:
    """Where the band of a corrected exceedance curve crosses P: the distance's interval at the accurate mesh
    (its upper end None where the runs leave it open above)."""
    lower = distance_at(curve["d_m"], curve["lower"], float(p))
    return lower, None if entry.get("open_above") else distance_at(curve["d_m"], curve["upper"], float(p))


def interval_text(lower: Any, upper: Any, digits: int = 2) -> str:
    """'[lower, upper]', an end the runs leave open (None) written 'open'."""
    low, high = ("open" if end is None else _number(end, digits) for end in (lower, upper))
    return f"[{low}, {high}]"


def headline_rows(record: dict[str, Any]) -> tuple[list[dict[str, Any]], list[str]]:
    """The answer, one row per number: the best estimate with its interval, the mesh it stands for (converged
    where a mesh step was taken) and the numbers of its notes; and the notes, each :func:`cautions` text once."""
    names = {"runout_m": "runout R (m)", "volume_m2": "volume V (m²)", "influence_m": "influence I (m)"}
    high = record["high_cell_size_m"]
    notes: list[str] = []

    def marks(said: list[str]) -> str:
        for text in said:
            if text not in notes:
                notes.append(text)
        return ", ".join(str(notes.index(text) + 1) for text in said)

    def row(key: str, p: str | None, value: Any, lower: Any, upper: Any, mesh_step: float | None) -> dict[str, Any]:
        return {
            "quantity": f"{names.get(key, key)} exceeded with P {p}"
            if p is not None
            else f"mean {names.get(key, key)}",
            "best estimate": value,
            f"{record['confidence']:.0%} interval": interval_text(lower, upper),
            "mesh": "converged" if mesh_step is not None else f"{high:g} m",
            "note": marks(cautions(record, key, p, upper, mesh_step)),
        }

    if "converged" in record:
        c = record["converged"]
        rows = [
            row(key, p, d["estimate"], d["lower"], d["upper"], d.get("mesh_step"))
            for key, entries in c["distances"].items()
            for p, d in entries.items()
        ] + [row(key, None, m["estimate"], m["lower"], m["upper"], m["mesh_step"]) for key, m in c["means"].items()]
    else:
        rows = [
            row(key, p, d["corrected"], *band_ends(curve, p, d), None)
            for key, curve in record["exceedance"].items()
            for p, d in curve["distances"].items()
        ] + [row(key, None, m["estimate"], m["lower"], m["upper"], None) for key, m in record["means"].items()]
    return rows, notes


def footnotes(notes: list[str]) -> str:
    """The answer's notes, numbered as its table marks them."""
    items = "".join(f"<li>{html.escape(text)}</li>" for text in notes)
    return f'<ol class="notes">{items}</ol>' if notes else ""


def zone_band(zones: list[dict[str, Any]]) -> str:
    """The zones as a coloured band along the section: one block per zone, as wide as its extent, in its level's
    colour (the zoning figure's), labelled with its level and its ends."""
    start, end = min(zone["x_from_m"] for zone in zones), max(zone["x_to_m"] for zone in zones)
    blocks = []
    for zone in zones:
        width = zone["x_to_m"] - zone["x_from_m"]
        colour = ZONE_COLOURS[ZONE_LEVELS.index(zone["level"])]
        label = f"{zone['level']}: {zone['x_from_m']:.1f}–{zone['x_to_m']:.1f} m"
        shown = html.escape(zone["level"]) if width / (end - start) > 0.08 else ""
        blocks.append(
            f'<div style="flex: {width:.4f}; background: {colour}" title="{html.escape(label)}">{shown}</div>'
        )
    axis = f'<div class="axis"><span>x = {start:g} m</span><span>x = {end:g} m</span></div>'
    return f'<div class="zones">{"".join(blocks)}</div>{axis}'


def folded(summary: str, *parts: str) -> str:
    """Parts inside a closed <details> element within a section."""
    return f"<details><summary>{html.escape(summary)}</summary>\n" + "\n".join(parts) + "\n</details>"


def answer_section(report: Report, case: str, files: dict[str, Path]) -> None:
    """The answer for a case with a multi-fidelity correction, first on the page: one table of the best estimate
    (the distances exceeded with each probability and the means, with intervals, at the converged mesh where
    the mesh extrapolation ran, and why to read a number with care beside it), the exceedance curves and the
    zoning along the section in one figure, the zones, and a site's map view (rgns.hazard.site_gis draws it
    from these zones)."""
    record = json.loads(files["multifidelity.json"].read_text())
    converged = "converged" in record
    zoning = record["converged"]["zoning"]["zones"] if converged else record["zoning"]["zones_corrected"]
    mesh = "the converged mesh" if converged else f"the MPM at {record['high_cell_size_m']:g} m cells"
    rows, notes = headline_rows(record)
    report.add(
        f"{case}: the answer at {mesh}",
        paragraph(
            f"The best estimate: {source(record)}"
            + (", carried to the converged mesh (the evidence below, step by step)." if converged else ".")
        ),
        table(pd.DataFrame(rows), 2, "answer"),
        footnotes(notes),
        figure(files["multifidelity.png"], caption("multifidelity", case=case)),
        paragraph(f"Zones along the section at {mesh} (hover a zone for its ends):"),
        zone_band(zoning),
        folded("The zones as a table", table(pd.DataFrame(zoning), 2)),
        *([figure(files["map.png"], caption("site_map", case=case))] if "map.png" in files else []),
    )


def source(record: dict[str, Any]) -> str:
    """Where a case's best estimate at the accurate mesh comes from, in words: the corrected cheap route, or the
    paired MPM runs alone where the allocation found that the cheap route does not pay."""
    high = record["high_cell_size_m"]
    if record.get("route_applied") == "plain MPM":
        return (
            f"the MPM at {high:g} m cells alone over its {record['n_paired']} paired realizations (a plain MPM Monte "
            f"Carlo: the cheap route does not pay, see the allocation; its values on all {record['n_low']} "
            "realizations stand beside it for comparison; an empty upper end: more realizations than these are "
            "needed to bound it)"
        )
    return (
        f"the cheap route on all {record['n_low']} realizations corrected by the {record['n_paired']} pairs run by "
        f"the MPM at {high:g} m cells"
    )


def corrected_table(record: dict[str, Any]) -> list[str]:
    """The best estimate where no mesh extrapolation ran: the cheap route corrected to the accurate MPM, the
    means with their intervals and the distances exceeded with each probability with the band of the
    corrected exceedance curve."""
    high = record["high_cell_size_m"]
    step = f"+ correction to MPM {high:g} m"

    def difference(corrected: float | None, cheap: float | None) -> float | None:
        return None if corrected is None or cheap is None else corrected - cheap

    rows = [
        {
            "quantity": f"mean {key}",
            "cheap route": m["low_mean"],
            step: m["estimate"] - m["low_mean"],
            "= best estimate": m["estimate"],
            "[lower": m["lower"],
            "upper]": m["upper"],
        }
        for key, m in record["means"].items()
    ]
    rows += [
        {
            "quantity": f"{key} exceeded with P {p}",
            "cheap route": d["uncorrected"],
            step: difference(d["corrected"], d["uncorrected"]),
            "= best estimate": d["corrected"],
            **dict(zip(("[lower", "upper]"), band_ends(curve, p, d))),
        }
        for key, curve in record["exceedance"].items()
        for p, d in curve["distances"].items()
    ]
    return [
        paragraph(
            f"The best estimate (m, m²): {source(record)}, with its {record['confidence']:.0%} "
            f"interval (a distance's: where the band of the corrected exceedance curve crosses its probability). "
            f"It stays at the {high:g} m "
            "mesh: no mesh extrapolation ran (montecarlo.fidelity.mesh_order)."
        ),
        table(pd.DataFrame(rows), 2),
    ]


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
            f"The best estimate, step by step (m, m²): {source(record)}, and the step from that mesh to the "
            "converged one: Richardson extrapolation of the pairs' difference "
            f"between {c['coarse_cell_size_m']:g} m and {high:g} m cells at the order measured for each "
            "quantity (benchmarks/results/mesh_levels.md; none where no asymptotic range was found, and "
            "that quantity stays at the accurate mesh)."
        ),
        table(pd.DataFrame(rows), 2),
    ]


def agreement_table(validation: dict[str, dict[str, Any]]) -> str:
    """A pair validation (rgns.fidelity.pair_validation's format) as a table: n, R², NRMSE and bias per metric."""
    rows = [
        {
            "metric": key,
            "n": entry["n"],
            "R² [lower, upper]": with_interval(entry["r2"]),
            "NRMSE": _number(entry["nrmse"][0], 3),
            "bias [lower, upper]": with_interval(entry["bias"]),
        }
        for key, entry in validation.items()
    ]
    return table(pd.DataFrame(rows))


def pair_validation_parts(case: str, record: dict[str, Any]) -> list[str]:
    """The learned simulator against the MPM on the case's own pairs, weighted by their design: the
    correction's cheap route against the accurate MPM (``record["pair_validation"]``) and the Monte Carlo's
    simulator against the MPM at its own mesh (``record["simulator_validation"]``), where the record holds them
    (as rgns.fidelity.pair_validation returns them)."""
    parts: list[str] = []
    statistics = (
        "R² = 1 − E_w[(l − h)²] / Var_w(h), h the MPM and l the other route; NRMSE = sqrt(E_w[(l − h)²]) over "
        "the MPM's range on the pairs; bias = E_w[l − h] (m, m² for the volume); "
        f"{record['confidence']:.0%} bootstrap intervals resampling the pairs within their strata; n: the pairs "
        "finite at both routes for that metric."
    )
    design = (
        "each pair weighted by the design: a pair of stratum s stands for N_s / N of the Monte Carlo's "
        "realizations, shared by the stratum's n_s pairs, so these are the statistics over the Monte Carlo's "
        "realizations, not over the pairs as drawn."
    )
    if record.get("pair_validation"):
        parts += [
            agreement_table(record["pair_validation"]),
            paragraph(
                f"{case}: the correction's cheap route ({record.get('cheap_route', 'the Monte Carlo simulator')}) "
                f"against the MPM at {record['high_cell_size_m']:g} m cells on this case's own "
                f"{record['n_paired']} paired realizations (those of the correction above, not the test cases'), "
                f"{design} {statistics}"
            ),
        ]
    if record.get("simulator_validation"):
        mesh = (
            f" ({record['converged']['coarse_cell_size_m']:g} m cells)"
            if "converged" in record and "coarse_cell_size_m" in record["converged"]
            else ""
        )
        parts += [
            agreement_table(record["simulator_validation"]),
            paragraph(
                f"{case}: the Monte Carlo's simulator against the MPM at its own mesh{mesh} on the same pairs, "
                f"weighted alike: how far the runs of the uncorrected map (among the details) are from the MPM. "
                f"{statistics}"
            ),
        ]
    return [subheading("The pairs' validation"), *parts] if parts else []


def _short(value: Any) -> str:
    """A plan's value in a table cell: numbers to 4 significant digits, long lists cut."""
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, list):
        shown = ", ".join(_short(v) for v in value[:8])
        return f"[{shown}, … ({len(value)} values)]" if len(value) > 8 else f"[{shown}]"
    return str(value)


def allocation_parts(record: dict[str, Any]) -> list[str]:
    """The runs' costs, the MFMC allocation, the target's and the plan of the pairs (rule paired_plan)."""
    cost, allocation = record["cost"], record["allocation"]
    parts = [subheading("The allocation")]
    plan = record.get("plan")
    if plan:
        parts += [
            paragraph("The plan of the paired runs, as the run chose it:"),
            table(pd.DataFrame([{"key": key, "value": _short(value)} for key, value in plan.items()])),
        ]
    ratio, gain = allocation.get("optimal_ratio"), allocation.get("speedup_at_equal_error")
    allocated = (
        f"With the runout correlation {allocation['correlation_runout']:.2f}, the optimal ratio of cheap to paired "
        f"runs is {ratio:.1f} and multi-fidelity reaches a given error {gain:.2f}x faster than the accurate MPM alone."
        if ratio is not None and gain is not None
        else f"Runout correlation {allocation['correlation_runout']:.2f}; without both costs no allocation."
    )
    route = f" Route: {allocation['route']} ({allocation['reason']})." if "route" in allocation else ""
    parts.append(
        paragraph(
            f"Cheap route: {record.get('cheap_route', 'the Monte Carlo simulator')}. "
            f"Cost per realization: cheap route {cost['low_s']:.3g} s, accurate MPM {cost['high_s']:.2f} s "
            f"({record['n_low']} and {record['n_paired']} realizations). {allocated}{route}"
        )
    )
    if "target" in allocation:
        target = allocation["target"]
        parts.append(
            paragraph(
                f"For a {record['confidence']:.0%} half-width of {target['half_width_m']:g} m on the "
                f"mean runout: {target['n_high']} paired and {target['n_low']} cheap realizations "
                f"({target['cost']:.0f} s against {target['plain_cost']:.0f} s by the accurate MPM alone)."
            )
        )
    return parts


def interval_parts(record: dict[str, Any]) -> list[str]:
    """What the best estimate's intervals hold, and what they do not."""
    high = record["high_cell_size_m"]
    text = (
        f"The {record['confidence']:.0%} intervals are percentile bootstraps that resample the paired and the "
        "unpaired realizations apart (within the pairs' design strata where the pairs were stratified), "
        "re-estimating the correction's weights in every resample, at Hesterberg's expanded level for the "
        "pairs: they hold the sampling of the cheap runs and of the pairs and the correction's weights."
    )
    if "converged" in record:
        text += " The mesh error is corrected for: at the converged mesh the interval also holds the order's interval."
        stays = [f"mean {key}" for key, m in record["converged"]["means"].items() if m["mesh_step"] is None]
        if stays:
            text += (
                f" Not carried to the converged mesh (no order measured): {', '.join(stays)}; their intervals "
                f"do not hold the error of the {high:g} m mesh."
            )
    else:
        text += f" They do not hold the error of the {high:g} m mesh itself: no mesh extrapolation ran."
    return [subheading("What the intervals hold"), paragraph(text)]


def evidence_section(report: Report, case: str, files: dict[str, Path]) -> None:
    """The evidence under a case's best estimate: what the runs say against the Monte Carlo's own map, the
    estimate step by step, the pairs' validation, the allocation, what the intervals hold."""
    record = json.loads(files["multifidelity.json"].read_text())
    steps = mesh_chain(record) if "converged" in record else corrected_table(record)
    if "converged" in record:
        zoning = record["converged"]["zoning"]
        steps.append(
            paragraph(
                f"The zones' mesh step: fronts moved {zoning['front_step_m']:+.2f} m "
                f"({zoning['front_step_range_m'][0]:+.2f} to {zoning['front_step_range_m'][1]:+.2f} over the "
                f"runout's order interval), back scarps {zoning['rear_step_m']:+.2f} m "
                f"({zoning['rear_step_range_m'][0]:+.2f} to {zoning['rear_step_range_m'][1]:+.2f})."
            )
        )
    line, excluded = _runout_line(case, record)
    report.add(
        f"{case}: the evidence",
        *[paragraph(text) for text in pairs_summary(record)],
        folded(
            "The statistics behind it",
            subheading("What the runs say"),
            paragraph(line, note=excluded),
            subheading("The best estimate, step by step"),
            *steps,
            *pair_validation_parts(case, record),
            *allocation_parts(record),
            *interval_parts(record),
        ),
    )


def pairs_summary(record: dict[str, Any]) -> list[str]:
    """What the pairs say, in three lines: how well the cheap route agrees with the MPM on them, how far the
    correction and the mesh step moved the mean runout, what the intervals hold."""
    high, n = record["high_cell_size_m"], record["n_paired"]
    agreement = record.get("pair_validation", {}).get("runout_m")
    said = [
        f"{n} realizations were re-run by the MPM at {high:g} m cells"
        + (
            f": on them the cheap route ({record.get('cheap_route', 'the Monte Carlo simulator')}) agrees with the "
            f"MPM at runout R² {with_interval(agreement['r2'], 2)}, bias {_number(agreement['bias'][0], 2)} m."
            if agreement
            else "."
        )
    ]
    if "converged" in record:
        m = record["converged"]["means"]["runout_m"]
        step = (
            f", and the step to the converged mesh {m['mesh_step']:+.2f} m"
            if m["mesh_step"] is not None
            else "; no mesh step"
        )
        said.append(
            f"The correction moved the mean runout from {m['cheap_mean']:.2f} m (cheap route) to {m['accurate']:.2f} m "
            f"(MPM at {high:g} m){step}: best estimate {m['estimate']:.2f} m."
        )
    else:
        m = record["means"]["runout_m"]
        said.append(
            f"The correction moved the mean runout from {m['low_mean']:.2f} m (cheap route) to {m['estimate']:.2f} m "
            f"(MPM at {high:g} m)."
        )
    said.append(
        f"The {record['confidence']:.0%} intervals hold the sampling of the cheap runs and the pairs and the "
        "correction's weights"
        + (", and the mesh order's range." if "converged" in record else f", not the error of the {high:g} m mesh.")
    )
    return said


def correction_details(report: Report, case: str, files: dict[str, Path]) -> None:
    """The correction's own tables, folded: the means and distances of the cheap route beside the corrected
    ones, the cheap route's bias and correlation on the pairs, and the zones at the accurate mesh."""
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
    parts = [
        paragraph(
            f"The correction to the MPM at {record['high_cell_size_m']:g} m cells, quantity by quantity: the "
            "cheap route, corrected, and the cheap route's bias and correlation on the pairs."
        ),
        table(means, 3),
        table(distances, 2),
    ]
    if "converged" in record:  # else these zones are the best estimate's, shown above
        parts += [
            paragraph(f"Zones corrected to the MPM at {record['high_cell_size_m']:g} m cells:"),
            table(pd.DataFrame(record["zoning"]["zones_corrected"]), 2),
        ]
    report.add(f"Hazard: {case} — the multi-fidelity correction in detail", *parts, folded=True)


def gate_section(
    report: Report,
    gate: dict[str, dict[str, Any]],
    cases: list[str],
    validation_table: pd.DataFrame | None = None,
    surrogate: str = "gns",
    corrected: Collection[str] = (),
) -> None:
    """The validation gate's verdict for every Monte Carlo case, first (with ``validation_table``, the test
    cases' table it was based on, where given; the page shows that table among its details). ``corrected``:
    the cases whose best estimate the MPM pairs correct."""
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
            if case in corrected:
                then = (
                    f"the Monte Carlo ran the {name} all the same (validation.acceptance.on_failure: report): the "
                    f"best estimate is corrected to the MPM by this case's pairs, so it does not rest on the "
                    f"{name} being right (its errors widen the intervals)"
                )
            else:
                then = (
                    f"the Monte Carlo ran the {name} all the same (validation.acceptance.on_failure: report), "
                    "uncorrected: its map below rests on the failed model"
                )
            lines.append(
                paragraph(
                    f"{case}: the {name} FAILED the validation gate ({'; '.join(verdict['failures'])}); {then}.",
                    note=True,
                )
            )
    outside = {case: verdict for case, verdict in gate.items() if case not in cases}
    if outside:  # validated test cases outside the Monte Carlo: their verdicts too, in one paragraph
        outcomes = [
            f"{case} {'passed' if verdict['passed'] else 'FAILED (' + '; '.join(verdict['failures']) + ')'}"
            for case, verdict in outside.items()
        ]
        lines.append(
            paragraph(
                f"Validated, not in the Monte Carlo (a report of the {name}): {'; '.join(outcomes)}.",
                note=not all(verdict["passed"] for verdict in outside.values()),
            )
        )
    report.add("Validation gate", *lines, *([] if validation_table is None else [table(validation_table)]))


def model_section(
    report: Report, surrogate: str, evaluation: dict[str, Any], learning_curve: Path, folded: bool = False
) -> None:
    """What the learned simulator is and how it trained."""
    if surrogate == "endstate":
        card = evaluation.get("card", "rgns/models/endstate_general_card.md")
        origin = f"the model shipped with rgns (card: {card}), " if evaluation.get("shipped") else ""
        report.add(
            "End-state surrogate",
            paragraph(
                f"{origin}{evaluation['steps']} training steps; held-out loss "
                f"{evaluation['valid_loss']:.3g} against the mean predictor's "
                f"{evaluation['valid_mean_predictor_loss']:.3g} (mean squared scaled final displacement)."
            ),
            figure(learning_curve, caption("endstate_curve")),
            folded=folded,
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
        folded=folded,
    )


def routes(
    cases: list[str], gate: dict[str, dict[str, Any]], surrogate: str, pairs: dict[str, int] | None = None
) -> dict[str, str]:
    """What ran each Monte Carlo case: the learned simulator corrected by the case's MPM pairs (``pairs``: their
    number per corrected case), the learned simulator alone (its gate's verdict said: nothing corrects it), or
    the MPM (configured)."""
    name, pairs = SURROGATE_NAMES[surrogate], pairs or {}

    def route(case: str) -> str:
        corrected = f", corrected by {pairs[case]} MPM pairs" if case in pairs else ""
        if case not in gate:
            return "MPM (configured)" + corrected
        if corrected:
            return name + corrected
        if gate[case]["passed"]:
            return f"{name} alone (passed its validation gate)"
        return f"{name} alone, which failed its validation gate (below)"

    return {case: route(case) for case in cases}


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
    learning_curve: Path | None,
    evaluation: dict[str, Any] | None,
    validation_table: pd.DataFrame | None,
    validation_summary: list[dict],
    validation_figures: dict[str, Path],
    hazard: dict[str, dict[str, Path]],
    gate: dict[str, dict[str, Any]] | None = None,
    surrogate: str | None = "gns",
    made: dict[str, str] | None = None,
) -> str:
    """The whole page, the answer first: (a) what made it and the route of each Monte Carlo case, with the
    warnings that concern every number (runs left out; the gate's verdicts, where a case's map rests on the
    learned simulator alone); (b) per case the answer: one table of the best estimate with each number's
    caution beside it, the figure of the exceedance curves and the zoning, the zones; (c) the evidence (the
    gate's verdicts where pairs correct every case, then per case what the runs say, the estimate step by
    step, the pairs' validation, the allocation, what the intervals hold; a case without a correction: its
    convergence); (d) folded details: configuration,
    scenes, the model, its validation on the test cases, each case's correction in detail and its uncorrected
    Monte Carlo map. ``surrogate`` (gns or endstate) is the learned simulator validated, whose curve and
    evaluation these are (None: a plain MPM Monte Carlo, no learned simulator, nor its curve, evaluation
    or validation); ``made`` the provenance (rgns.provenance)."""
    corrected = [case for case, files in hazard.items() if "multifidelity.json" in files]
    pairs = {case: json.loads(hazard[case]["multifidelity.json"].read_text())["n_paired"] for case in corrected}
    lead = provenance_line(made, routes(list(hazard), gate or {}, surrogate or "gns", pairs)) if made else ""
    report = Report(title, "\n".join([lead, *shrinkage_notes(hazard, validation_summary)]))
    # (a) the gate first where a case's map rests on the learned simulator alone (no pairs correct it)
    rests_on_model = any(case not in corrected for case in hazard)
    if rests_on_model:
        gate_section(report, gate or {}, list(hazard), None, surrogate or "gns", corrected)
    # (b) the answer, each number's caution beside it
    for case, files in hazard.items():
        if case in corrected:
            answer_section(report, case, files)
        else:
            monte_carlo_sections(report, case, files, "answer")
    # (c) the evidence
    if not rests_on_model:
        gate_section(report, gate or {}, list(hazard), None, surrogate or "gns", corrected)
    for case, files in hazard.items():
        if case in corrected:
            evidence_section(report, case, files)
        else:
            monte_carlo_sections(report, case, files, "evidence")
    # (d) the details, folded
    report.add(
        "Details",
        paragraph(
            "Folded: open a heading to read it. The configuration, the scenes, the learned simulator and its "
            "validation on the test cases (a report of the model: the best estimate above does not rest on it), "
            "each case's correction in detail and its Monte Carlo map as its simulator drew it."
        ),
    )
    report.add("Configuration", f"<pre>{html.escape(json.dumps(overview, indent=2))}</pre>", folded=True)
    if scenes:
        figures = (figure(path, caption("scenes", set=name)) for name, path in scenes.items())
        report.add("Scenes", *figures, folded=True)
    if surrogate is not None and evaluation is not None and learning_curve is not None:
        model_section(report, surrogate, evaluation, learning_curve, folded=True)
    if surrogate is not None and validation_table is not None:
        validation_section(report, surrogate, validation_table, validation_summary, validation_figures)
    for case in corrected:
        correction_details(report, case, hazard[case])
        monte_carlo_sections(report, case, hazard[case], "details")
    return report.html()


def validation_section(
    report: Report,
    surrogate: str,
    validation_table: pd.DataFrame,
    validation_summary: list[dict],
    validation_figures: dict[str, Path],
) -> None:
    """The learned simulator against the MPM on the test cases, folded: the gate's table and figures."""
    # the table's columns named after the simulator that ran (its files call every learned simulator gns)
    validation_table = validation_table.rename(
        columns=lambda column: (
            column.replace("gns", SURROGATE_NAMES[surrogate].replace(" ", "_").replace("-", "_"))
            if column.startswith("gns")
            else column
        )
    )
    report.add(
        "Validation against MPM on the test cases (the validation gate's table)",
        table(validation_table),
        table(pd.DataFrame(validation_summary)),
        figure(validation_figures["histograms"], caption("histograms")),
        figure(validation_figures["parity"], caption("parity")),
        *(
            figure(path, f"{name}: " + caption("energy"))
            for name, path in validation_figures.items()
            if name not in ("histograms", "parity")
        ),
        folded=True,
    )
