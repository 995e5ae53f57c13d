"""The docs match the code: the README's commands, CI, and the generated config reference."""

from __future__ import annotations

import re
from pathlib import Path

from conftest import REPO

from rgns.config_reference import config_reference


def _ci_command() -> str:
    lines = [line for line in (REPO / ".ci" / "run").read_text().splitlines() if line and not line.startswith("#")]
    return lines[-1]


def test_ci_runs_exactly_the_readme_test_command():
    command = _ci_command()
    assert command == "bash tests/run" and "\n.venv/bin/python -m pytest -n 2\n" in (REPO / "tests" / "run").read_text()
    assert f"\n{command}\n" in (REPO / "README.md").read_text()


def test_readme_has_the_hazard_map_command():
    assert "snakemake --cores 2 hazard_map\n" in (REPO / "README.md").read_text()


def test_the_config_reference_is_current():
    assert (REPO / "docs" / "config.md").read_text() == config_reference(), (
        "regenerate with: rgns config-reference --out docs/config.md"
    )


def test_every_rule_in_the_readme_data_flow_exists():
    rules = "".join(path.read_text() for path in (REPO / "rules").glob("*.smk")) + (REPO / "Snakefile").read_text()
    readme = (REPO / "README.md").read_text()
    for rule in (
        "geometry",
        "random_field",
        "scene_preview",
        "mpm_input",
        "mpm_run",
        "pack",
        "gns_export",
        "paraview_series",
        "train",
        "hazard_map",
    ):
        assert f"rule {rule}:" in rules and f"`{rule}`" in readme


def _anchor(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _anchors(path: Path) -> set[str]:
    fenced, found = False, set()
    for line in path.read_text().splitlines():
        fenced ^= line.startswith("```")
        if not fenced and line.startswith("#"):
            found.add(_anchor(line.lstrip("#")))
    return found


def test_every_relative_link_in_the_readme_and_docs_resolves_to_a_file_and_heading():
    pages = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
    broken = []
    for page in pages:
        for target in re.findall(r"\]\(([^)\s]+)\)", page.read_text()):
            if target.startswith(("http://", "https://", "mailto:")):
                continue
            file, _, anchor = target.partition("#")
            linked = (page.parent / file).resolve() if file else page
            if not linked.exists():
                broken.append(f"{page.name}: {target} (no such file)")
            elif anchor and linked.suffix == ".md" and anchor not in _anchors(linked):
                broken.append(f"{page.name}: {target} (no such heading)")
    assert not broken, broken


def test_the_readme_stays_a_guide_and_the_docs_index_lists_every_page():
    assert len((REPO / "README.md").read_text().splitlines()) <= 150
    index = (REPO / "docs" / "index.md").read_text()
    for page in sorted((REPO / "docs").glob("*.md")):
        if page.name != "index.md":
            assert f"]({page.name})" in index, page.name
