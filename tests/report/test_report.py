"""The report's top: every gate verdict, the route of each Monte Carlo case, what made the page."""

import pandas as pd

from rgns.report.page import Report, _runout_line, gate_section, provenance_line, routes

GATE = {
    "case1": {
        "passed": True,
        "failures": [],
        "simulator": "endstate",
        "evidence": ["runout R² 0.99 [0.97, 1.00] on 16"],
    },
    "case2": {"passed": False, "failures": ["volume R² 0.93 [0.76, 0.97]: lower bound < 0.9"], "simulator": "mpm"},
    "case4": {"passed": False, "failures": ["influence R² 0.71 [0.39, 0.87]: lower bound < 0.9"], "simulator": "mpm"},
}


def test_every_verdict_is_in_the_report_also_of_cases_outside_the_monte_carlo():
    report = Report("r")
    gate_section(report, GATE, ["case1", "case2"], pd.DataFrame({"case": ["case1"]}), "endstate")
    page = report.html()
    assert "case1: the end-state surrogate passed the validation gate" in page
    assert "case2: the end-state surrogate FAILED the validation gate" in page
    assert (
        "case4 (validated, not in the Monte Carlo): the end-state surrogate FAILED (influence R² 0.71 "
        "[0.39, 0.87]: lower bound &lt; 0.9) the validation gate."
    ) in page


def test_the_lead_names_the_route_of_each_case():
    case_routes = routes(["case1", "case2", "site"], GATE, "endstate")
    assert case_routes == {
        "case1": "end-state surrogate (passed its gate)",
        "case2": "MPM (the end-state surrogate failed its gate)",
        "site": "MPM (configured)",
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
        "2026-11-25 09:00 UTC. Monte Carlo: case1: end-state surrogate (passed its gate); case2: MPM (the "
        "end-state surrogate failed its gate); site: MPM (configured)."
    ) in page


def test_captions_render_their_literals():
    from rgns.report.page import caption, rendered

    text = rendered(caption("scenes", set="case1"))
    assert "<code>case1</code>" in text and "``" not in text


def test_fewer_runs_than_made_is_a_warning_at_the_top(tmp_path):
    import json

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
