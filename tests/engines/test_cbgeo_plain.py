"""Plain CB-Geo case directories (only CB-Geo's own files) run in ``rgns mpm``; every missing or
malformed file is a CaseError naming it."""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from conftest import TINY_CONFIG

from rgns.cli import main
from rgns.config import load_config
from rgns.engines.cbgeo.case import FRICTION_FILE, META_FILE, read_case
from rgns.engines.cbgeo.writer import write_case
from rgns.scene.case import CaseError
from rgns.scene.realizations import CaseInputs, draw_realization
from rgns.trajectories import read_trajectory

DURATION_S = 0.5  # what mpm.json says: nsteps × dt
Damage = Callable[[Path], None]  # breaks one file of a case directory


@pytest.fixture(scope="module")
def tiny_column():
    """Realization 0 of the tiny config's case 1: a 6 m × 5 m column of 120 particles, φ ≈ 30°."""
    config = load_config(TINY_CONFIG)
    settings = config["mpm"] | {"duration_s": DURATION_S}
    return draw_realization(CaseInputs.from_config(config, "case1"), 0), settings


def plain_case(directory: Path, tiny_column) -> Path:
    """A case directory holding only CB-Geo's files: rgns's two own files removed."""
    realization, settings = tiny_column
    write_case(directory, realization.scene, realization.friction_deg, settings)
    (directory / META_FILE).unlink()
    (directory / FRICTION_FILE).unlink()
    return directory


@pytest.fixture()
def plain(tmp_path, tiny_column) -> Path:
    return plain_case(tmp_path / "cases" / "column", tiny_column)


def test_a_plain_case_reads_friction_from_its_materials_time_from_mpm_json_and_bounds_from_its_mesh(plain, tiny_column):
    realization, settings = tiny_column
    case = read_case(plain)
    assert sorted(path.name for path in plain.iterdir()) == [
        "entity_sets.json",
        "mesh.txt",
        "mpm.json",
        "particles-stresses.txt",
        "particles-volumes.txt",
        "particles.txt",
    ]
    materials = {m["id"]: m["friction"] for m in json.loads((plain / "mpm.json").read_text())["materials"]}
    np.testing.assert_array_equal(case.friction_deg, [materials[k] for k in case.material_id])
    bin_width = (realization.friction_deg.max() - realization.friction_deg.min()) / settings["friction_bins"]
    assert np.abs(case.friction_deg - realization.friction_deg).max() <= 0.5 * bin_width + 1e-6
    assert (case.set_name, case.index, case.source) == ("column", 0, str(plain))
    assert (case.duration_s, case.frame_interval_s) == (DURATION_S, settings["frame_interval_s"])
    np.testing.assert_array_equal(case.bounds, [[-1.0, 41.0], [-1.0, 11.0]])  # the padded mesh


def test_an_rgns_case_keeps_its_name_index_and_domain(tmp_path, tiny_column):
    realization, settings = tiny_column
    case = read_case(write_case(tmp_path / "case", realization.scene, realization.friction_deg, settings))
    assert (case.set_name, case.index) == ("case1", 0)
    np.testing.assert_array_equal(case.bounds, [[0.0, 40.0], [0.0, 10.0]])
    np.testing.assert_array_equal(case.friction_deg, realization.friction_deg)


@pytest.mark.parametrize("duration", [0.25, None])
def test_rgns_mpm_runs_a_directory_holding_only_cbgeo_files(plain, tmp_path, duration, capsys):
    out = tmp_path / "out"
    flags = ["--duration", str(duration)] if duration else []  # None: mpm.json's nsteps × dt
    assert main(["mpm", str(plain), "--out", str(out), *flags]) == 0
    print(capsys.readouterr().out)
    trajectory = read_trajectory(out / "column_0000.h5")
    simulated = duration or DURATION_S
    assert trajectory.status == "ok" and trajectory.time_s[-1] == pytest.approx(simulated)
    assert len(trajectory.time_s) == round(simulated / 0.025) + 1
    start, end = trajectory.positions[0], trajectory.positions[-1]
    assert np.average(start[:, 1] - end[:, 1], weights=trajectory.mass_kg) > 0.02  # its centre of mass came down
    assert end[:, 0].max() > start[:, 0].max() + 0.1  # its foot spread to the right
    assert (end[:, 1] - start[:, 1]).max() < 0.05  # nothing was thrown up
    assert end[:, 1].min() >= 0.0 and end[:, 0].min() >= 0.0  # nothing went through the floor or the left wall


def _edit_json(name: str, edit: Callable[[dict], object]) -> Damage:
    def apply(directory: Path) -> None:
        document = json.loads((directory / name).read_text())
        edit(document)
        (directory / name).write_text(json.dumps(document))

    return apply


def _replace_text(name: str, old: str, new: str) -> Damage:
    def apply(directory: Path) -> None:
        text = (directory / name).read_text()
        assert old in text
        (directory / name).write_text(text.replace(old, new, 1))

    return apply


def _drop_line(name: str, line: int) -> Damage:
    def apply(directory: Path) -> None:
        lines = (directory / name).read_text().splitlines(keepends=True)
        (directory / name).write_text("".join(lines[:line] + lines[line + 1 :]))

    return apply


def _remove(name: str) -> Damage:
    return lambda directory: (directory / name).unlink()


def _write(name: str, text: str) -> Damage:
    return lambda directory: (directory / name).write_text(text)


BROKEN = {  # what is broken → (how, the file the message names, the message after the file)
    "mpm.json missing": (_remove("mpm.json"), "mpm.json", r"missing"),
    "mpm.json not JSON": (_write("mpm.json", '{"mesh": '), "mpm.json", r"not readable JSON"),
    "mesh missing": (_remove("mesh.txt"), "mesh.txt", r"missing \(named by .*mpm.json key 'mesh.mesh'\)"),
    "mesh short": (_drop_line("mesh.txt", 5), "mesh.txt", r"header says 559 nodes and 504 cells, found 1062 lines"),
    "particles missing": (
        _remove("particles.txt"),
        "particles.txt",
        r"missing \(named by .*mpm.json key 'particles\[0\].generator.location'\)",
    ),
    "particles not numbers": (_replace_text("particles.txt", "0.25", "x"), "particles.txt", r"not a table of numbers"),
    "volumes missing": (
        _remove("particles-volumes.txt"),
        "particles-volumes.txt",
        r"missing \(named by .*mpm.json key 'mesh.particles_volumes'\)",
    ),
    "volumes short": (
        _drop_line("particles-volumes.txt", 7),
        "particles-volumes.txt",
        r"needs exactly one volume per particle \(120 particles, 119 lines\)",
    ),
    "stresses missing": (
        _remove("particles-stresses.txt"),
        "particles-stresses.txt",
        r"missing \(named by .*mpm.json key 'mesh.particles_stresses'\)",
    ),
    "stresses short": (
        _drop_line("particles-stresses.txt", 3),
        "particles-stresses.txt",
        r"header says 120 rows, found 119",
    ),
    "entity sets missing": (
        _remove("entity_sets.json"),
        "entity_sets.json",
        r"missing \(named by .*mpm.json key 'mesh.entity_sets'\)",
    ),
    "entity sets not JSON": (_write("entity_sets.json", "node_sets"), "entity_sets.json", r"not readable JSON"),
    "entity set without ids": (
        _write("entity_sets.json", '{"node_sets": [{"set": [1, 2]}]}'),
        "entity_sets.json",
        r"every entry of 'node_sets' needs an integer 'id' and a list 'set'",
    ),
    "material of a material set missing": (
        _edit_json("mpm.json", lambda d: d["material_sets"][0].update(material_id=99)),
        "mpm.json",
        r"key 'material_sets\[0\].material_id' = 99: no material with that id in 'materials'",
    ),
    "material of the generator missing": (
        _edit_json("mpm.json", lambda d: d["particles"][0]["generator"].update(material_id=99)),
        "mpm.json",
        r"key 'particles\[0\].generator.material_id' = 99: no material with that id in 'materials'",
    ),
    "particle set missing": (
        _edit_json("mpm.json", lambda d: d["material_sets"][0].update(pset_id=99)),
        "mpm.json",
        r"key 'material_sets\[0\].pset_id' = 99: no particle set with that id in .*entity_sets.json",
    ),
    "node set missing": (
        _edit_json("mpm.json", lambda d: d["mesh"]["boundary_conditions"]["velocity_constraints"][0].update(nset_id=9)),
        "mpm.json",
        r"key 'mesh.boundary_conditions.velocity_constraints\[0\].nset_id' = 9: no node set",
    ),
    "constraint from a file": (
        _edit_json(
            "mpm.json",
            lambda d: d["mesh"]["boundary_conditions"].update(
                velocity_constraints=[{"file": "velocity-constraints.txt"}]
            ),
        ),
        "mpm.json",
        r"key 'mesh.boundary_conditions.velocity_constraints\[0\]' lacks \['nset_id', 'dir', 'velocity'\] "
        r"\(only node-set constraints are supported\)",
    ),
    "analysis.dt missing": (
        _edit_json("mpm.json", lambda d: d["analysis"].pop("dt")),
        "mpm.json",
        r"missing key 'analysis.dt'",
    ),
    "analysis.nsteps missing": (
        _edit_json("mpm.json", lambda d: d["analysis"].pop("nsteps")),
        "mpm.json",
        r"missing key 'analysis.nsteps'",
    ),
    "output_steps missing": (
        _edit_json("mpm.json", lambda d: d["post_processing"].pop("output_steps")),
        "mpm.json",
        r"missing key 'post_processing.output_steps'",
    ),
    "nsteps not a count": (
        _edit_json("mpm.json", lambda d: d["analysis"].update(nsteps=2.5)),
        "mpm.json",
        r"key 'analysis.nsteps' = 2.5: expected a positive int",
    ),
    "material type unsupported": (
        _edit_json("mpm.json", lambda d: [m.update(type="LinearElastic2D") for m in d["materials"]]),
        "mpm.json",
        r"material \d+ has type 'LinearElastic2D'; the embedded engine supports MohrCoulomb2D only",
    ),
    "material key missing": (
        _edit_json("mpm.json", lambda d: [m.pop("cohesion") for m in d["materials"]]),
        "mpm.json",
        r"material \d+ lacks key\(s\) \['cohesion'\]",
    ),
    "cell type unsupported": (
        _edit_json("mpm.json", lambda d: d["mesh"].update(cell_type="ED2T3")),
        "mpm.json",
        r"key 'mesh.cell_type' = 'ED2T3': only ED2Q4 meshes are supported",
    ),
    "rgns friction short": (_write(FRICTION_FILE, "30.0\n31.0\n"), FRICTION_FILE, r"2 values for 120 particles"),
}


@pytest.mark.parametrize("broken", BROKEN)
def test_a_missing_or_malformed_file_is_a_case_error_naming_it(plain, broken):
    damage, name, message = BROKEN[broken]
    damage(plain)
    with pytest.raises(CaseError) as error:
        read_case(plain)
    print(f"{broken}: {error.value}")
    assert re.match(re.escape(str(plain / name)) + ": " + message, str(error.value))


def test_rgns_mpm_reports_a_case_error_and_exits_2(plain, capsys):
    (plain / "mesh.txt").unlink()
    assert main(["mpm", str(plain)]) == 2
    assert f"rgns mpm: {plain / 'mesh.txt'}: missing" in capsys.readouterr().err


def test_output_names_that_would_collide_are_refused_before_running(tmp_path, tiny_column, capsys):
    realization, settings = tiny_column
    plain_dirs = [plain_case(tmp_path / parent / "column", tiny_column) for parent in ("a", "b")]
    rgns_dirs = [
        write_case(tmp_path / parent / "case", realization.scene, realization.friction_deg, settings)
        for parent in ("c", "d")
    ]
    for first, second in (plain_dirs, rgns_dirs):
        out = tmp_path / "out"
        assert main(["mpm", str(first), str(second), "--out", str(out)]) == 2
        name = "column_0000.h5" if first in plain_dirs else "case1_0000.h5"
        assert f"rgns mpm: {first} and {second} would all write {out / name}" in capsys.readouterr().err
        assert not out.exists()
