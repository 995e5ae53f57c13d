"""The package's import direction: the scene comes first and imports no later stage; the embedded
engine takes the scene's realization and imports no file format."""

from __future__ import annotations

import ast
from pathlib import Path

from conftest import REPO

PACKAGE = REPO / "rgns"


def rgns_imports(folder: Path) -> dict[str, set[str]]:
    """Every rgns module each module of ``folder`` imports (top level and inside functions)."""
    imports = {}
    for path in sorted(folder.glob("*.py")):
        found = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("rgns"):
                found.add(node.module)
            elif isinstance(node, ast.Import):
                found |= {alias.name for alias in node.names if alias.name.startswith("rgns")}
        imports[path.name] = found
    return imports


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
