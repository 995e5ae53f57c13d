"""The docs match the code: the README's commands, CI, and the generated config reference."""
from __future__ import annotations

from rgns.config_reference import config_reference
from conftest import REPO


def _ci_command() -> str:
    lines = [line for line in (REPO / ".ci" / "run").read_text().splitlines() if line and not line.startswith("#")]
    return lines[-1]


def test_ci_runs_exactly_the_readme_test_command():
    command = _ci_command()
    assert "pytest" in command
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
    for rule in ("geometry", "random_field", "scene_preview", "mpm_input", "mpm_run", "pack", "gns_export",
                 "paraview_series", "train", "hazard_map"):
        assert f"rule {rule}:" in rules and f"`{rule}`" in readme
