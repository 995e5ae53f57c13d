"""The package's import direction: its stage packages, in the order data flows, import no later one
(the scene first, imports none); the embedded engine takes the scene's realization and imports no
file format; outside the stages only shared infrastructure."""

from __future__ import annotations

import ast
import re
from pathlib import Path

from conftest import REPO

PACKAGE = REPO / "rgns"


STAGES = ("scene", "engines", "surrogates", "montecarlo", "hazard", "fidelity", "report")
INFRASTRUCTURE = (
    "atomic",
    "cli",
    "config",
    "config_reference",
    "integrity",
    "logsetup",
    "provenance",
    "tables",
    "trajectories",
)


def rgns_imports(folder: Path, pattern: str = "*.py") -> dict[str, set[str]]:
    """Every rgns module each module of ``folder`` imports (top level and inside functions)."""
    imports = {}
    for path in sorted(folder.glob(pattern)):
        found = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("rgns"):
                found.add(node.module)
            elif isinstance(node, ast.Import):
                found |= {alias.name for alias in node.names if alias.name.startswith("rgns")}
        imports[path.relative_to(folder).as_posix()] = found
    return imports


def test_rgns_holds_the_stages_in_the_order_data_flows_and_only_infrastructure_beside_them():
    packages = sorted(p.name for p in PACKAGE.iterdir() if (p / "__init__.py").exists())
    assert packages == sorted([*STAGES, "models"])
    flat = sorted(p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__")
    assert flat == sorted(INFRASTRUCTURE)


def test_no_stage_imports_a_later_one():
    later = {}
    for position, stage in enumerate(STAGES):
        for module, found in rgns_imports(PACKAGE / stage, "**/*.py").items():
            ahead = sorted(m for m in found if m.split(".")[1] in STAGES[position + 1 :])
            if ahead:
                later[f"{stage}/{module}"] = ahead
    assert later == {}


def test_every_stage_package_says_what_enters_and_leaves():
    for stage in STAGES:
        doc = ast.get_docstring(ast.parse((PACKAGE / stage / "__init__.py").read_text())) or ""
        assert re.search(r"\bin\b", doc, re.I) and re.search(r"\bout\b", doc, re.I), stage


def test_the_scene_imports_no_later_stage():
    later = {
        module: sorted(m for m in found if not m.startswith("rgns.scene"))
        for module, found in rgns_imports(PACKAGE / "scene").items()
    }
    assert {module: found for module, found in later.items() if found} == {}


def test_the_embedded_engine_imports_no_file_format():
    formats = {
        module: sorted(m for m in found if m.startswith("rgns.engines.cbgeo"))
        for module, found in rgns_imports(PACKAGE / "engines" / "mpm").items()
    }
    assert {module: found for module, found in formats.items() if found} == {}
    assert "rgns.scene.case" in rgns_imports(PACKAGE / "engines" / "mpm")["solver.py"]


def test_the_hazard_stage_reads_tables_and_scenes_only():
    """Hazard statistics, their files and figures, and a site's GIS outputs take a Monte Carlo table:
    nothing of the engines, the surrogates or the Monte Carlo's simulators."""
    allowed = ("rgns.hazard", "rgns.scene", "rgns.tables", "rgns.atomic")
    others = {
        module: sorted(m for m in found if not m.startswith(allowed))
        for module, found in rgns_imports(PACKAGE / "hazard").items()
    }
    assert {module: found for module, found in others.items() if found} == {}


def test_the_package_reads_nothing_of_the_lab():
    """rgns runs from an installed wheel: no module imports the evidence renderer or names the repository's
    benchmarks or docs folders; what it reads beside its code (models, captions) is package data."""
    offending = []
    for path in sorted(PACKAGE.glob("**/*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            imported = [a.name for a in node.names] if isinstance(node, ast.Import) else []
            if isinstance(node, ast.ImportFrom) and node.module:
                imported.append(node.module)
            named = node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else ""
            if any(m.split(".")[0] in ("evidence", "benchmarks") for m in imported) or named in ("benchmarks", "docs"):
                offending.append(path.relative_to(REPO).as_posix())
    assert offending == []
