"""The report's top: every gate verdict, the route of each Monte Carlo case, what made the page."""

import json
import re

import pandas as pd
import pytest

from rgns.hazard.statistics import ZONE_COLOURS, ZONE_LEVELS
from rgns.report.page import Report, _runout_line, gate_section, provenance_line, routes

GATE = {
    "case1": {
        "passed": True,
        "failures": [],
        "simulator": "endstate",
        "evidence": ["runout R² 0.99 [0.97, 1.00] on 16"],
    },
    "case2": {"passed": False, "failures": ["volume R² 0.93 [0.76, 0.97]: lower bound < 0.9"], "simulator": "endstate"},
    "case4": {
        "passed": False,
        "failures": ["influence R² 0.71 [0.39, 0.87]: lower bound < 0.9"],
        "simulator": "endstate",
    },
}


def test_every_verdict_is_in_the_report_also_of_cases_outside_the_monte_carlo():
    report = Report("r")
    gate_section(report, GATE, ["case1", "case2"], pd.DataFrame({"case": ["case1"]}), "endstate")
    page = report.html()
    assert "case1: the end-state surrogate passed the validation gate" in page
    assert "case2: the end-state surrogate FAILED the validation gate" in page
    assert (
        "Validated, not in the Monte Carlo (a report of the end-state surrogate): case4 FAILED (influence R² 0.71 "
        "[0.39, 0.87]: lower bound &lt; 0.9)."
    ) in page


def test_the_lead_names_the_route_of_each_case():
    """Which simulator ran each case, and that pairs corrected it; the gate's verdict only where nothing did."""
    case_routes = routes(["case1", "case2", "site"], GATE, "endstate")
    assert case_routes == {
        "case1": "end-state surrogate alone (passed its validation gate)",
        "case2": "end-state surrogate alone, which failed its validation gate (below)",
        "site": "MPM (configured)",
    }
    corrected = routes(["case1", "case2", "site"], GATE, "endstate", {"case1": 32, "case2": 16, "site": 8})
    assert corrected == {
        "case1": "end-state surrogate, corrected by 32 MPM pairs",
        "case2": "end-state surrogate, corrected by 16 MPM pairs",
        "site": "MPM (configured), corrected by 8 MPM pairs",
    }
    made = {
        "version": "0.1.0",
        "commit": "0123456789",
        "config_digest": "abcdef012345",
        "made_utc": "2026-11-25 09:00 UTC",
    }
    page = Report("r", provenance_line(made, case_routes)).html()
    assert (
        "Made by rgns 0.1.0 (commit 0123456789) from configuration abcdef012345 (SHA-256 prefix) on "
        "2026-11-25 09:00 UTC. Monte Carlo: case1: end-state surrogate alone (passed its validation gate); case2: "
        "end-state surrogate alone, which failed its validation gate (below); site: MPM (configured)."
    ) in page


def test_captions_render_their_literals():
    from rgns.report.page import caption, rendered

    text = rendered(caption("scenes", set="case1"))
    assert "<code>case1</code>" in text and "``" not in text


def test_fewer_runs_than_made_is_a_warning_at_the_top(tmp_path):

    from rgns.report.page import shrinkage_notes

    (tmp_path / "exceedance.json").write_text(json.dumps({"n": 61, "not_ok": 3}))
    notes = shrinkage_notes(
        {"case1": {"exceedance.json": tmp_path / "exceedance.json"}},
        [{"case": "case1", "realizations": 16, "diverged": 1}, {"case": "case2", "realizations": 16, "diverged": 0}],
    )
    assert notes == [
        '<p class="note">case1: the validation compares 15 of its 16 realizations (1 learned runs '
        "diverged and are left out).</p>",
        '<p class="note">case1: the hazard rests on 61 of 64 Monte Carlo realizations (3 did not finish '
        "and are left out).</p>",
    ]


def runout_record(distances: dict[str, dict]) -> dict:
    """A case's multifidelity record as rule multifidelity writes it, carried to the converged mesh."""
    mean = {"estimate": 9.3, "lower": 9.0, "upper": 9.7, "low_mean": 8.7, "bias": -0.6, "correlation": 0.99}
    step = {"mesh_step": 1.2, "mesh_step_range": [0.9, 1.9], "estimate": 10.5, "lower": 9.7, "upper": 11.9}
    return {
        "means": {"runout_m": mean},
        "high_cell_size_m": 0.5,
        "n_paired": 16,
        "converged": {
            "means": {"runout_m": step, "volume_m2": {"mesh_step": None}, "influence_m": {"mesh_step": None}},
            "order": {"runout_m": [0.69, 0.94, 1.2]},
            "n_pairs": 16,
            "coarse_cell_size_m": 1.0,
            "distances": {"runout_m": distances},
        },
    }


def test_the_headline_says_where_the_runs_leave_a_distances_interval_open():
    """A distance whose interval these runs do not bound is named beside the headline; closed ones are not."""
    closed = {"estimate": 10.0, "lower": 9.0, "upper": 12.0}
    line, _ = _runout_line(
        "case1", runout_record({"0.5": closed, "0.01": {"estimate": 17.0, "lower": 15.0, "upper": None}})
    )
    assert "do not bound the interval of the runout exceeded with P 0.01" in line and "P 0.5" not in line
    line, _ = _runout_line("case1", runout_record({"0.5": closed, "0.1": closed}))
    assert "do not bound" not in line


def test_the_headline_warns_where_a_distances_mesh_step_rests_on_the_regressions_beyond_the_pairs():
    """With 16 pairs, the step at P 0.01 (0.16 pairs expected beyond it) is named; at P 0.1 (1.6) it is not."""
    stepped = {"estimate": 10.0, "lower": 9.0, "upper": 12.0, "mesh_step": 1.0}
    line, _ = _runout_line("case1", runout_record({"0.1": stepped, "0.01": stepped}))
    assert (
        "The mesh step of the runout exceeded with P 0.01 rests on the cheap route's regressions beyond the 16" in line
    )
    assert "P 0.1 rests" not in line and "P 0.1," not in line
    line, _ = _runout_line("case1", runout_record({"0.01": stepped | {"mesh_step": None}}))
    assert "regressions beyond" not in line


def synthetic_record(converged: bool, pair_validation: bool) -> dict:
    """A case's multifidelity.json with what the page reads: means, two exceedance distances, zones, costs, the
    plan of the pairs; with ``converged`` the mesh extrapolation's chain, with ``pair_validation`` the pairs'
    validation as rgns.fidelity.pair_validation returns it."""
    means = {
        key: {"estimate": 1.1 * v, "lower": v, "upper": 1.2 * v, "low_mean": 0.9 * v, "bias": -0.1, "correlation": 0.95}
        for key, v in (("runout_m", 9.0), ("volume_m2", 40.0), ("influence_m", 4.0))
    }
    record: dict = {
        "n_low": 64,
        "n_paired": 16,
        "high_cell_size_m": 0.5,
        "cheap_route": "the Monte Carlo's simulator",
        "confidence": 0.95,
        "cost": {"low_s": 0.2, "high_s": 20.0},
        "means": means,
        "exceedance": {
            "runout_m": {
                "d_m": [0.0, 5.0, 10.0, 15.0],
                "lower": [1.0, 0.6, 0.05, 0.0],
                "upper": [1.0, 0.9, 0.3, 0.0],
                "distances": {"0.5": {"uncorrected": 8.0, "corrected": 9.0, "simulator": 8.0}},
            }
        },
        "zoning": {"zones_corrected": [{"level": "low", "x_from_m": 0.0, "x_to_m": 60.0}]},
        "allocation": {"correlation_runout": 0.95, "optimal_ratio": 6.0, "speedup_at_equal_error": 3.0},
        "cheap_is_simulator": True,
        "simulator_means": {key: m["low_mean"] for key, m in means.items()},
        "plan": {"bounds_m": [[0.0, 8.0], [8.0, 20.0]], "sizes": [48, 16], "pairs": [8, 8], "n_paired": 16},
    }
    if converged:
        step = {"mesh_step": 0.8, "mesh_step_range": [0.6, 1.2]}
        record["converged"] = {
            "order": {key: [1.0, 1.3, 1.6] for key in means},
            "n_pairs": 16,
            "coarse_cell_size_m": 1.0,
            "means": {
                key: {
                    "cheap_mean": m["low_mean"],
                    "accurate": m["estimate"],
                    "accurate_lower": m["lower"],
                    "accurate_upper": m["upper"],
                    **step,
                    "estimate": m["estimate"] + 0.8,
                    "lower": m["lower"] + 0.6,
                    "upper": m["upper"] + 1.2,
                }
                for key, m in means.items()
            },
            "distances": {
                "runout_m": {
                    "0.5": {
                        "accurate": 9.0,
                        "accurate_band": [8.0, 10.0],
                        **step,
                        "estimate": 9.8,
                        "lower": 8.6,
                        "upper": 11.2,
                    }
                }
            },
            "zoning": {
                "front_step_m": 0.8,
                "front_step_range_m": [0.6, 1.2],
                "rear_step_m": -0.3,
                "rear_step_range_m": [-0.5, -0.2],
                "zones": [{"level": "moderate", "x_from_m": 0.0, "x_to_m": 60.0}],
            },
        }
    if pair_validation:
        record["pair_validation"] = {
            key: {
                "n": 16,
                "r2": [0.952, 0.875, 1.0],
                "nrmse": [0.061, 0.04, 0.09],
                "bias": [-0.123, -0.2, -0.05],
                "relative_bias": [-0.01, -0.02, -0.005],
            }
            for key in means
        }
    return record


def synthetic_page(tmp_path, record: dict | None, learned: bool = True) -> str:
    """build_report over one Monte Carlo case with ``record`` (None: no multi-fidelity correction) and
    stand-in figures (any bytes inline); ``learned`` False: a plain MPM Monte Carlo, no learned simulator."""

    from rgns.report.page import build_report

    png = tmp_path / "figure.png"
    png.write_bytes(b"\x89PNG stand-in")
    case = tmp_path / "case1"
    case.mkdir()
    if record is not None:
        (case / "multifidelity.json").write_text(json.dumps(record))
    (case / "exceedance.json").write_text(
        json.dumps(
            {
                "n": 64,
                "not_ok": 0,
                "screened": 0,
                "metrics": {
                    "runout distance R": {
                        "deterministic_m": 8.0,
                        "distances": [
                            {"probability": 0.5, "distance_m": 8.0, "lower_m": 7.5, "upper_m": 8.5, "note": ""}
                        ],
                    }
                },
            }
        )
    )
    (case / "convergence.json").write_text(
        json.dumps({"criterion": "the running mean within 2 %", "metrics": {"runout": {"converged_at": 40, "n": 64}}})
    )
    (case / "zoning.json").write_text(json.dumps({"zones": [{"level": "low", "x_from_m": 0.0, "x_to_m": 60.0}]}))
    figures = ("exceedance.png", "convergence.png", "zoning.png") + (() if record is None else ("multifidelity.png",))
    files = {p.name: p for p in case.iterdir()} | {name: png for name in figures}
    return build_report(
        title="r",
        overview={"the_configuration_dump": 1},
        scenes={"case1": png} if learned else {},
        learning_curve=png if learned else None,
        evaluation={"steps": 10, "valid_loss": 0.01, "valid_mean_predictor_loss": 0.1} if learned else None,
        validation_table=pd.DataFrame({"case": ["case1"], "metric": ["runout"], "gns_mean": [9.0]})
        if learned
        else None,
        validation_summary=[{"case": "case1", "realizations": 16, "diverged": 0}] if learned else [],
        validation_figures={"histograms": png, "parity": png, "energy_case1": png} if learned else {},
        hazard={"case1": files},
        gate=GATE if learned else None,
        surrogate="endstate" if learned else None,
        made={"version": "0.1.0", "commit": "0123456789", "config_digest": "abcdef012345", "made_utc": "now"},
    )


@pytest.mark.parametrize("converged", [False, True])
def test_the_page_leads_with_the_best_estimate_and_folds_the_details(tmp_path, converged):
    """Provenance first, then the answer (one table of the best estimate with each number's caution, the
    figure, the zones), the evidence (the gate, which the pairs make a report of the model; what the runs say,
    the estimate step by step, the pairs' validation, the allocation, what the intervals hold), then the
    configuration and the rest folded in <details>; every figure once."""
    page = synthetic_page(tmp_path, synthetic_record(converged, pair_validation=True))
    lead = page.split("<h2>")[0]
    assert "Made by rgns 0.1.0" in lead and "case1: end-state surrogate, corrected by" in lead
    assert "validation gate" not in lead and "its gate" not in lead
    assert page.split("<h2>")[1].startswith("case1: the answer at")
    order = [
        page.index('<table class="dataframe answer">'),  # the one table of the answer
        page.index("<td>runout R (m) exceeded with P 0.5</td>"),
        page.index("<img"),  # its figure
        page.index("<h2>Validation gate</h2>"),
        page.index("<h3>What the runs say</h3>"),
        page.index("<h3>The best estimate, step by step</h3>"),
        page.index("<h3>The pairs&#x27; validation</h3>"),
        page.index("<h3>The allocation</h3>"),
        page.index("<h3>What the intervals hold</h3>"),
        page.index("<h2>Details</h2>"),
        page.index("the_configuration_dump"),
        page.index("Hazard: case1 — exceedance (uncorrected"),
    ]
    assert order == sorted(order)
    assert page.count('class="dataframe answer"') == 1 and page.count("= best estimate</th>") == 1
    configuration = re.search(r"<details><summary>Configuration</summary>\s*<pre>(.*?)</pre>\s*</details>", page, re.S)
    assert configuration and "the_configuration_dump" in configuration.group(1)
    assert "<details open" not in page  # folded by default
    for folded in (
        "Scenes",
        "End-state surrogate",
        "Validation against MPM on the test cases",
        "Hazard: case1 — the multi-fidelity correction in detail",
        "Hazard: case1 — exceedance (uncorrected",
        "Hazard: case1 — convergence (uncorrected",
        "Hazard: case1 — zoning (uncorrected",
    ):
        assert f"<details><summary>{folded}" in page, folded
    assert page.count("<img") == 1 + 1 + 3 + 4  # scenes, learning curve, validation, hazard: each once
    # the pairs' validation: n, R² and bias with their intervals, NRMSE, per metric, and what they are
    evidence = page[page.index("<h3>The pairs&#x27; validation</h3>") : page.index("<h3>The allocation</h3>")]
    assert evidence.count("<td>0.952 [0.875, 1.000]</td>") == 3 and "<td>-0.123 [-0.200, -0.050]</td>" in evidence
    assert "<td>0.061</td>" in evidence and "<td>16</td>" in evidence
    assert "this case&#x27;s own 16 paired realizations" in evidence and "weighted by the design" in evidence
    # the plan of the pairs as a small table
    allocation = page[page.index("<h3>The allocation</h3>") : page.index("<h3>What the intervals hold</h3>")]
    assert "<td>pairs</td>" in allocation and "<td>[8, 8]</td>" in allocation


def test_without_a_pair_validation_in_the_record_the_page_has_no_such_table(tmp_path):
    page = synthetic_page(tmp_path, synthetic_record(converged=False, pair_validation=False))
    assert "The pairs&#x27; validation" not in page and "R² [lower, upper]" not in page
    assert "<h3>The allocation</h3>" in page and page.index('class="dataframe answer"') < page.index("<pre>")


def test_a_case_without_a_correction_answers_with_its_own_map_unfolded(tmp_path):
    """No multifidelity.json: the Monte Carlo's own exceedance and zoning are the answer, its convergence the
    evidence, none of them folded or called uncorrected."""
    page = synthetic_page(tmp_path, None)
    order = [
        page.index("<h2>Hazard: case1 — exceedance</h2>"),
        page.index("<h2>Hazard: case1 — zoning</h2>"),
        page.index("<h2>Hazard: case1 — convergence</h2>"),
        page.index("<h2>Details</h2>"),
    ]
    assert order == sorted(order) and "uncorrected" not in page and "Multi-fidelity check" not in page
    assert page.count("<img") == 1 + 1 + 3 + 3


def test_a_plain_mpm_monte_carlo_has_no_model_on_its_page(tmp_path):
    """montecarlo.simulator: mpm: the route says MPM, and no learned simulator's section, scenes or
    validation appear (none was trained or validated)."""
    page = synthetic_page(tmp_path, None, learned=False)
    assert "case1: MPM (configured)" in page.split("<h2>")[0]
    assert "case1: the Monte Carlo ran MPM as configured; no surrogate was used." in page
    assert "<summary>End-state surrogate</summary>" not in page
    assert "<summary>Validation against MPM on the test cases" not in page
    assert "<summary>Scenes</summary>" not in page and "Hazard: case1" in page
    (tmp_path / "learned").mkdir()
    learned = synthetic_page(tmp_path / "learned", None)  # the same page with a learned simulator has them all
    assert "<summary>End-state surrogate</summary>" in learned and "<summary>Scenes</summary>" in learned
    assert "<summary>Validation against MPM on the test cases" in learned


def test_the_answer_gives_one_interval_column_each_caution_once_and_the_zones_as_a_band(tmp_path):
    """The answer's table holds one interval column; a caution shared by several numbers is one numbered note
    under it, said once on the page; the zones are drawn as a band of their levels' colours, as wide as each."""
    record = synthetic_record(True, pair_validation=True)
    c = record["converged"]
    tail = {"accurate": 12.0, "accurate_band": [11.0, 14.0], "mesh_step": 0.8, "mesh_step_range": [0.6, 1.2]}
    c["distances"]["runout_m"] |= {  # P 0.1: a modelled step; P 0.01: beyond the 16 pairs too, open above
        "0.1": tail | {"estimate": 12.8, "lower": 11.5, "upper": 15.0},
        "0.01": tail | {"estimate": 15.8, "lower": 14.0, "upper": None},
    }
    c["means"]["influence_m"] |= {"mesh_step": None, "mesh_step_range": None}
    c["zoning"]["zones"] = [
        {"level": level, "x_from_m": start, "x_to_m": end}
        for level, start, end in (("low", 0.0, 10.0), ("high", 10.0, 14.5), ("extremely high", 14.5, 60.0))
    ]
    page = synthetic_page(tmp_path, record)
    answer = page[page.index("the answer at") : page.index("<h2>Validation gate</h2>")]
    assert "95% interval</th>" in answer and "[95%" not in page and "interval]</th>" not in answer
    notes = re.findall(r"<li>(.*?)</li>", answer[answer.index('<ol class="notes">') :])
    assert notes and len(set(notes)) == len(notes)
    assert all(page.count(note) == 1 for note in notes)
    marks = re.findall(r"<td>(\d+(?:, \d+)*)</td>\s*</tr>", answer)
    assert {int(m) for mark in marks for m in mark.split(", ")} == set(range(1, len(notes) + 1))
    band = re.findall(r'<div style="flex: ([\d.]+); background: (\w+)"', answer)
    zones = c["zoning"]["zones"]
    assert [float(width) for width, _ in band] == pytest.approx([z["x_to_m"] - z["x_from_m"] for z in zones], abs=1e-4)
    assert [colour for _, colour in band] == [ZONE_COLOURS[ZONE_LEVELS.index(z["level"])] for z in zones]
