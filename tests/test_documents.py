"""The figures the README and docs render from committed result files (evidence)."""

import json
import re
import subprocess

import pytest

import evidence
from evidence import DocumentError, rendered, runs, sources, stale


def test_every_rendered_passage_matches_its_result_files():
    assert stale() == [], "run python -m evidence and commit the documents with their results"
    assert any("<!-- rendered:" in path.read_text() for path in evidence.documents())


def test_a_figure_edited_by_hand_is_caught_and_rewriting_restores_it(tmp_path):
    readme = (evidence.REPO / "docs" / "evidence.md").read_text()
    start = readme.index("<!-- rendered: default-run -->")
    edited = readme[:start] + readme[start:].replace(" min ", " min 1", 1)  # the run's time, edited
    assert edited != readme
    path = tmp_path / "evidence.md"
    path.write_text(edited)
    assert stale([path]) == [path]
    path.write_text(rendered(edited, str(path)))
    assert stale([path]) == [] and path.read_text() == readme


def test_a_passage_without_a_renderer_and_a_result_without_its_commit_are_named(tmp_path, monkeypatch):
    with pytest.raises(DocumentError, match=r"notes.md: rendered passage 'nothing' has no renderer"):
        rendered("<!-- rendered: nothing -->\nx\n<!-- end rendered -->\n", "notes.md")
    monkeypatch.setattr(sources, "RESULTS", tmp_path)
    monkeypatch.setattr(sources, "REPO", tmp_path.parent)
    (tmp_path / "fresh_run_site.json").write_text(json.dumps({"command": "python run.py", "cases": {}}))
    with pytest.raises(DocumentError, match=r"fresh_run_site.json: records no commit or commits"):
        runs.site_run()


def test_every_commit_a_document_cites_is_in_the_history():
    """A figure "measured at <commit>" must name a commit a reader can check out."""
    repo = evidence.REPO
    git = subprocess.run(["git", "rev-parse", "--is-shallow-repository"], cwd=repo, capture_output=True, text=True)
    if git.returncode != 0 or git.stdout.strip() != "false":
        pytest.skip("not a full git clone: the cited commits cannot be looked up")
    cited = {
        (token, path.relative_to(repo))
        for path in [*evidence.documents(), *(repo / "benchmarks" / "results").glob("*.md"), repo / "CHANGELOG.md"]
        for token in re.findall(r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,10}\b", path.read_text())
    }
    missing = [
        f"{path}: {token}"
        for token, path in sorted(cited)
        if subprocess.run(["git", "cat-file", "-e", f"{token}^{{commit}}"], cwd=repo, capture_output=True).returncode
    ]
    assert len(cited) >= 5 and missing == []


def test_no_current_benchmark_table_row_is_written_by_hand():
    """docs/benchmarks.md's current sections hold their tables only in passages rendered from result files: a
    table row outside them would go stale unseen when its file is re-run (mesh_levels.json had moved
    on to b17ca46 under a hand-written row that still said b0415a2)."""
    text = evidence.BLOCK.sub("", (evidence.REPO / "docs" / "benchmarks.md").read_text())  # what is by hand
    current = [part for part in re.split(r"^## ", text, flags=re.M) if part.startswith("Current")]
    assert current, "docs/benchmarks.md has no current section"
    by_hand = [line for part in current for line in part.splitlines() if line.startswith("|")]
    assert by_hand == [], by_hand


def test_the_pages_tail_caution_quotes_the_coverage_run_it_cites():
    """The page's caution beside a modelled tail distance (rgns.report.page.TAIL_COVERAGE) quotes the local
    population's coverage at P 0.1 and 0.01 and its count of replicates as pair_coverage_local.json holds them."""
    from rgns.report.page import TAIL_COVERAGE

    record = sources.result("pair_coverage_local.json")["normal"]
    quoted = [f"{100 * record['summary'][p]['converged']['at_order']['coverage']:.1f} %" for p in ("0.1", "0.01")]
    assert f"{len(record['replicates'])} replicates" in TAIL_COVERAGE, TAIL_COVERAGE
    assert all(figure in TAIL_COVERAGE for figure in quoted), (quoted, TAIL_COVERAGE)


def test_a_run_says_where_its_time_went_and_whether_it_met_15_min_on_2_cores():
    """The evidence page says the jobs' summed time, the largest rules first, and the run's wall time against 15 min."""
    rules = {
        "mc_chunk [paired]": {"jobs": 8, "job_seconds": 300.0},
        "mpm_run": {"jobs": 8, "job_seconds": 60.0},
        "mc_chunk [realizations]": {"jobs": 10, "job_seconds": 240.0},
    }
    within = runs.time_lines({"rules": rules, "seconds": 600.0, "cases": {"mine": {}}}, "mine")
    assert within[0].startswith("Its jobs' summed wall time, 10 min 00 s on 2 cores, went to mc_chunk [paired] 5 min")
    assert within[-1].endswith("**met**.")
    over = runs.time_lines({"rules": rules, "seconds": 1000.0, "cases": {"mine": {}}}, "mine")
    assert over[-1].endswith("**missed** by 1 min 40 s.")


def test_no_rendered_passage_names_a_path_of_the_machine_it_was_measured_on():
    """Commands recorded with absolute paths are shown relative to the checkout, scratch as <scratch>."""
    assert sources.portable("x --config /work/main/config/a.yaml --data /tmp/untouched") == (
        "x --config config/a.yaml --data <scratch>/untouched"
    )
    for path in evidence.documents():
        for match in evidence.BLOCK.finditer(path.read_text()):
            assert not sources.CHECKOUT.search(match["body"]) and "/tmp/" not in match["body"], path
