"""The real Snakemake workflow on the tiny config: DAG, bad-config stop, targeted reruns."""

from __future__ import annotations

import copy
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import REPO, TINY_CONFIG
from workflow_helpers import scheduled, scheduled_routes, snakemake, write_config

from rgns.config import load_config, load_yaml
from rgns.scene.fields import read_field
from rgns.scene.geometry import read_scene
from rgns.scene.realizations import CaseInputs, draw_realization
from rgns.scene.sets import format_id
from rgns.surrogates.endstate.data import read_end_states
from rgns.tables import read_csv
from rgns.trajectories import read_packed, read_trajectory

pytestmark = pytest.mark.workflow


def test_dry_run_of_the_default_config_runs_only_the_test_cases_with_the_shipped_model(tmp_path):
    """The shipped geometry-general end-state surrogate (the default): no training-set MPM run and no training
    is scheduled, and no MPM run of the whole Monte Carlo: the MPM runs only the test cases' validation
    (mpm_run) and the pairs (mc_chunk's routes paired and paired_coarse, over the plan's realizations only);
    every realization runs by the surrogate (route realizations) and the tuned control, gate or not."""
    dry_run = snakemake(tmp_path, "-n", "hazard_map")
    jobs = scheduled(dry_run)
    config = load_config(REPO / "config" / "config.yaml")
    assert config["montecarlo"]["simulator"] == "endstate" and config["endstate"]["model"] == "general"
    cases = {name: groups for name, groups in config["sets"].items() if name not in ("train", "valid")}
    sizes = [sum(group["count"] for group in groups) for groups in cases.values()]
    chunks = sum(-(-size // config["mpm"]["chunk_size"]) for size in sizes)
    montecarlo = config["montecarlo"]
    mc_cases = len(montecarlo["cases"])
    routes = scheduled_routes(dry_run)
    assert jobs == {
        "geometry": sum(sizes),
        "random_field": sum(sizes),
        "mpm_input": sum(sizes),
        "mpm_run": chunks,
        "pack": len(sizes),
        "scene_preview": len(sizes),
        "shipped_endstate": 1,
        "validation_rollout": len(cases),
        "validate": 1,
        "mc_chunk": sum(routes.values()),
        "mc_collect": mc_cases * len(routes),
        "exceedance": mc_cases,
        "zoning": mc_cases,
        "paired_plan": mc_cases,
        "multifidelity": mc_cases,
        "report": 1,
        "hazard_map": 1,
        "mpm_kernels": 1,  # the MPM's CPU kernels compiled once, before its jobs
        # the correction's control variate: the shipped tuned surrogate
        "shipped_tuned_endstate": 1,
    }
    every = -(-montecarlo["realizations"] // montecarlo["chunk_size"])
    pairs = -(-montecarlo["fidelity"]["paired"] // montecarlo["fidelity"]["chunk_size"])
    assert routes == {
        "realizations": mc_cases * every,  # every realization by the surrogate
        "mean_field": mc_cases,
        "control": mc_cases * every,  # and by the tuned surrogate, the correction's control variate
        "paired": mc_cases * pairs,  # the plan's pairs by the MPM at 0.5 m
        "paired_coarse": mc_cases * pairs,  # and at the Monte Carlo's mesh: the mesh extrapolation's coarse level
    }
    assert montecarlo["fidelity"]["cheap"] == "tuned" and montecarlo["realizations"] == 10_000
    assert config["validation"]["acceptance"]["on_failure"] == "report"  # mc_chunk does not wait for the gate
    assert min(sizes) >= 16  # enough realizations per test case for R² to mean something


def test_a_plain_mpm_monte_carlo_at_half_metre_cells_needs_no_learned_simulator(tmp_path):
    """montecarlo.simulator: mpm at 0.5 m cells (which no shipped model serves): accepted, and the DAG
    trains, validates and runs no learned simulator, nor any test case's MPM run: the MPM runs the
    Monte Carlo, and the report has no model to show."""
    config = load_config(REPO / "config" / "config.yaml")
    config["mesh"]["cell_size_m"] = 0.5
    config["montecarlo"] |= {"simulator": "mpm", "realizations": 16, "chunk_size": 8}
    config["montecarlo"]["fidelity"]["paired"] = 0
    jobs = scheduled(snakemake(tmp_path, "-n", "hazard_map", config=write_config(tmp_path / "mpm.yaml", config)))
    assert jobs == {
        "mpm_kernels": 1,  # compiled once before the MPM's jobs
        "mc_chunk": 3,
        "mc_collect": 2,
        "exceedance": 1,
        "zoning": 1,
        "report": 1,
        "hazard_map": 1,
    }


def test_training_from_scratch_schedules_the_training_sets_and_the_training(tmp_path):
    config = load_config(REPO / "config" / "config.yaml")
    config["gns"]["model"] = "train"
    config["montecarlo"]["simulator"] = "gns"
    jobs = scheduled(snakemake(tmp_path, "-n", "hazard_map", config=write_config(tmp_path / "c.yaml", config)))
    sizes = [sum(group["count"] for group in groups) for groups in config["sets"].values()]
    assert jobs["train"] == 1 and "shipped_model" not in jobs
    assert jobs["geometry"] == sum(sizes) and jobs["pack"] == len(sizes)


def test_a_nested_config_override_with_numbers_works_as_the_readme_writes_it(tmp_path):
    """``--config 'montecarlo={realizations: 320, chunk_size: 32}'`` (Snakemake passes the numbers as text)."""
    routes = scheduled_routes(
        snakemake(tmp_path, "-n", "hazard_map", "--config", "montecarlo={realizations: 320, chunk_size: 32}")
    )
    cases = len(load_config(REPO / "config" / "config.yaml")["montecarlo"]["cases"])
    assert routes["realizations"] == routes["control"] == 10 * cases


def test_a_bad_config_stops_before_any_job_runs_naming_key_and_value(tmp_path):
    config = load_yaml(TINY_CONFIG)
    config["sets"]["train"][0]["correlation_length_x_m"] = -8.0
    result = snakemake(tmp_path, "--cores", "1", "hazard_map", config=write_config(tmp_path / "bad.yaml", config))
    assert result.returncode != 0
    assert "'sets.train[0].correlation_length_x_m' = -8.0" in result.stderr + result.stdout
    assert not (tmp_path / "results").exists()


def test_the_tiny_workflow_writes_scenes_fields_previews_and_the_mpm_dataset(built):
    workdir, config = built
    scene = read_scene(workdir / "results" / "geometry" / "case1" / "0000.json")
    field = read_field(str(workdir / "results" / "fields" / "case1" / "0000.npz"))
    assert scene.family == "column" and len(scene.positions) == len(field.friction_deg) == 6 * 5 * 4
    assert field.grid.shape == (40, 10)
    assert (workdir / "results" / "plots" / "train" / "scenes.png").stat().st_size > 10_000
    trajectory = read_trajectory(workdir / "results" / "mpm" / "case1" / "chunk_000" / "0000.h5")
    frames = round(config["mpm"]["duration_s"] / 0.025) + 1
    assert trajectory.engine == "embedded" and trajectory.status == "ok"
    assert trajectory.positions.shape == (frames, len(scene.positions), 2)
    assert np.linalg.norm(trajectory.positions[-1] - trajectory.positions[0], axis=1).max() > 1.0  # the column fell
    assert [t.index for t in read_packed(workdir / "results" / "dataset" / "train.h5")] == [0, 1]
    assert (workdir / "results" / "dataset" / "gns" / "metadata.json").exists()
    assert scheduled(snakemake(workdir, "-n", "hazard_map", config=workdir / "config.yaml")) == {}


def test_changing_a_random_field_key_reruns_fields_but_not_geometry(built, tmp_path):
    workdir, config = built
    changed = copy.deepcopy(config)
    changed["sets"]["train"][0]["correlation_length_y_m"] = 2.0
    jobs = scheduled(snakemake(workdir, "-n", "hazard_map", config=write_config(tmp_path / "c.yaml", changed)))
    assert "geometry" not in jobs
    assert jobs["random_field"] == 2  # the two train realizations, nothing else
    assert jobs["scene_preview"] == 1


def test_realizations_run_in_chunks(tmp_path):
    config = load_yaml(TINY_CONFIG)
    config["mpm"]["chunk_size"] = 1
    jobs = scheduled(snakemake(tmp_path, "-n", "dataset", config=write_config(tmp_path / "c.yaml", config)))
    assert jobs["mpm_run"] == jobs["mpm_input"] == 5
    config["mpm"]["chunk_size"] = 8
    jobs = scheduled(snakemake(tmp_path, "-n", "dataset", config=write_config(tmp_path / "c.yaml", config)))
    assert jobs["mpm_run"] == 3 and jobs["mpm_input"] == 5  # one chunk per set
    assert jobs["pack"] == 3 and jobs["gns_export"] == 1


def test_changing_the_field_method_reruns_every_field_but_no_geometry(built, tmp_path):
    workdir, config = built
    changed = copy.deepcopy(config)
    changed["random_field"] = {"method": "cholesky"}
    jobs = scheduled(snakemake(workdir, "-n", "hazard_map", config=write_config(tmp_path / "c.yaml", changed)))
    assert "geometry" not in jobs and jobs["random_field"] == 5


def test_changing_a_geometry_key_reruns_geometry_and_its_fields(built, tmp_path):
    workdir, config = built
    changed = copy.deepcopy(config)
    changed["geometry"]["families"]["column"]["vertices"][1]["x_m"] = 7.0
    changed["geometry"]["families"]["column"]["vertices"][2]["x_m"] = 7.0
    jobs = scheduled(snakemake(workdir, "-n", "hazard_map", config=write_config(tmp_path / "c.yaml", changed)))
    assert jobs["geometry"] == 2 and jobs["random_field"] == 2  # case1's two columns


def test_the_tiny_workflow_runs_the_whole_chain_to_the_hazard_report(built):
    workdir, config = built
    results = workdir / "results"
    table = read_csv(results / "mc" / "case1" / "realizations.csv")
    assert list(table["index"]) == list(range(config["montecarlo"]["realizations"]))
    assert (table["status"] == "ok").all() and (table["n_particles"] == 120).all()
    # the realizations the gate validates on are drawn from validation.seed, not the Monte Carlo's
    config = load_config(workdir / "config.yaml")
    for index in range(2):
        field = read_field(str(results / "fields" / "case1" / f"{format_id(index)}.npz")).friction_deg
        own = draw_realization(CaseInputs.from_config(config | {"seed": config["validation"]["seed"]}, "case1"), index)
        monte_carlo = draw_realization(CaseInputs.from_config(config, "case1"), index)
        np.testing.assert_array_equal(field, own.friction_deg)
        assert np.abs(field - monte_carlo.friction_deg).max() > 1.0
    assert read_csv(results / "mc" / "case1" / "mean_field.csv")["index"].tolist() == [-1]
    validation = read_csv(results / "report" / "validation" / "table.csv")
    assert sorted(validation["metric"]) == ["influence", "runout", "volume"] and (validation["n"] == 2).all()
    exceedance = json.loads((results / "report" / "case1" / "exceedance.json").read_text())
    assert exceedance["n"] == 6 and set(exceedance["metrics"]) == {"influence distance I", "runout distance R"}
    zoning = json.loads((results / "report" / "case1" / "zoning.json").read_text())
    assert zoning["zones"][0]["x_from_m"] == 0.0 and zoning["zones"][-1]["x_to_m"] == config["domain"]["length_m"]
    page = (results / "report" / "report.html").read_text()
    for heading in (
        "Validation against MPM",
        "Hazard: case1 — exceedance",
        "Hazard: case1 — zoning",
        "What the runs say",
        "Hazard: case1 — the multi-fidelity correction in detail",
    ):
        assert heading in page
    # the best estimate (corrected) leads the page; the Monte Carlo's own map follows, named so
    assert page.split("<h2>")[1].startswith("case1: the answer at the converged mesh")
    assert page.index("case1: the answer at") < page.index(
        "Hazard: case1 — exceedance (uncorrected: the Monte Carlo&#x27;s simulator alone)"
    )
    assert page.count("<img") == 3 + 1 + 3 + 4  # scenes, learning curve, validation, hazard
    # what made the page, above everything else: version, commit, config digest, time, each case's route
    lead = page.split("<h2>")[0]
    assert re.search(
        r"Made by rgns \S+ \(commit [0-9a-f]{10}[^)]*\) from configuration [0-9a-f]{12} \(SHA-256 "
        r"prefix\) on \d{4}-\d\d-\d\d \d\d:\d\d UTC\. Monte Carlo: case1: ",
        lead,
    ), lead[-600:]
    # the realizations paired_plan drew again by the MPM at 0.5 m cells: the same field, a finer mesh
    plan = json.loads((results / "mc" / "case1" / "paired_plan.json").read_text())
    paired = read_csv(results / "mc" / "case1" / "paired.csv")
    assert list(paired["index"]) == plan["indices"] and len(plan["indices"]) == 2
    assert (paired["n_particles"] == 4 * 120).all()
    multifidelity = json.loads((results / "report" / "case1" / "multifidelity.json").read_text())
    assert (multifidelity["n_paired"], multifidelity["n_low"]) == (2, 6)
    # two pairs cannot show that the cheap route pays (its correlation's lower bound is 0): the allocation says
    # plain MPM, the run applies it, and the page's answer says so and why
    assert multifidelity["allocation"]["route"] == multifidelity["route_applied"] == "plain MPM"
    answer = page.split("case1: the evidence</h2>")[0]
    assert "(a plain MPM Monte Carlo: the cheap route does not pay, see the allocation" in answer
    assert "<li>the MPM alone over 2 realizations: the cheap route does not pay" in answer  # a note of the answer
    assert "plain MPM Monte Carlo over the 2 paired realizations (the cheap route correlates" in page
    # each route's cost per realization is its chunks' job seconds (Snakemake's benchmark files) over its runs
    job_seconds = {
        route: sum(pd.read_csv(path, sep="\t")["s"].sum() for path in (results / "mc" / "case1" / route).glob("*.tsv"))
        for route in ("realizations", "paired")
    }
    assert (
        multifidelity["cost"]["low_s"] == pytest.approx(job_seconds["realizations"] / 6)
        and job_seconds["realizations"] > 0
    )
    assert multifidelity["cost"]["high_s"] == pytest.approx(job_seconds["paired"] / 2) and job_seconds["paired"] > 0
    # and once more by the MPM at the Monte Carlo's 1 m mesh: the coarse level of the mesh extrapolation
    coarse = read_csv(results / "mc" / "case1" / "paired_coarse.csv")
    assert list(coarse["index"]) == plan["indices"] and (coarse["n_particles"] == 120).all()
    extrapolated = multifidelity["converged"]
    assert extrapolated["n_pairs"] == 2 and extrapolated["order"] == config["montecarlo"]["fidelity"]["mesh_order"]
    runout = extrapolated["means"]["runout_m"]
    assert runout["estimate"] == pytest.approx(runout["accurate"] + runout["mesh_step"])
    assert "carried to the converged mesh" in page and "case1: the answer at the converged mesh" in page
    # a quantity without a measured order stays at 0.5 m, and the answer's table says so beside it, in a note
    row = re.search(
        r"<td>mean volume V \(m²\)</td>(\s*<td>[^<]*</td>){2}\s*<td>0\.5 m</td>\s*<td>([\d, ]+)</td>", answer
    )
    notes = re.findall(r"<li>(.*?)</li>", answer)
    assert row and any("no convergence order" in notes[int(mark) - 1] for mark in row.group(2).split(", "))
    # the influence distance is not merely unmeasured: the page says it still grows under refinement
    row = re.search(
        r"<td>mean influence I \(m\)</td>(\s*<td>[^<]*</td>){2}\s*<td>0\.5 m</td>\s*<td>([\d, ]+)</td>", answer
    )
    assert row and any("still grows" in notes[int(mark) - 1] for mark in row.group(2).split(", "))
    assert "Not carried to the converged mesh (no convergence order measured" in page


def test_strata_pair_the_realizations_the_plan_drew_in_each_and_weigh_them(built, tmp_path):
    """montecarlo.fidelity.strata: paired_plan cuts the cheap runs at the cheap runout's median and draws 2
    pairs in each half; the paired tables hold exactly those, and the correction records the design."""
    workdir = tmp_path / "tiny"
    shutil.copytree(built[0], workdir, symlinks=True)
    config = copy.deepcopy(built[1])
    config["montecarlo"]["fidelity"] = {"paired": 4, "strata": [0.5], "min_per_stratum": 2}
    result = snakemake(
        workdir,
        "--cores",
        "2",
        "results/report/case1/multifidelity.json",
        config=write_config(tmp_path / "strata.yaml", config),
    )
    assert result.returncode == 0, result.stderr
    plan = json.loads((workdir / "results" / "mc" / "case1" / "paired_plan.json").read_text())
    assert plan["sizes"] == [3, 3] and plan["pairs"] == [2, 2]
    strata = dict(zip(plan["realizations"], plan["strata"]))
    assert [strata[i] for i in plan["indices"]] == [0, 0, 1, 1]
    paired = read_csv(workdir / "results" / "mc" / "case1" / "paired.csv")
    assert list(paired["index"]) == plan["indices"] and (paired["n_particles"] == 4 * 120).all()
    record = json.loads((workdir / "results" / "report" / "case1" / "multifidelity.json").read_text())
    assert record["n_paired"] == 4 and record["plan"]["pairs"] == [2, 2] and record["cost"]["high_s"] > 0
    assert record["pair_validation"]["runout_m"]["n"] == 4


def test_changing_a_zoning_threshold_reruns_only_zoning_and_the_report(built, tmp_path):
    workdir, config = built
    changed = copy.deepcopy(config)
    changed["hazard"] = {"zoning_thresholds": [0.8, 0.5, 0.1, 0.01]}
    jobs = scheduled(snakemake(workdir, "-n", "hazard_map", config=write_config(tmp_path / "c.yaml", changed)))
    assert jobs == {"zoning": 1, "multifidelity": 1, "report": 1, "hazard_map": 1}  # the corrected zones too


def test_deleting_one_monte_carlo_chunk_reruns_only_that_chunk_and_reproduces_it(built):
    """A run killed during the Monte Carlo leaves some chunks and nothing after them: only the
    missing chunk runs again, and gives the same bytes."""
    workdir, config = built
    results = workdir / "results"
    chunk = results / "mc" / "case1" / "realizations" / "chunk_001.csv"
    before = chunk.read_bytes()
    for path in [
        chunk,
        results / "mc" / "case1" / "realizations.csv",
        results / "report" / "report.html",
        *(results / "report" / "case1").iterdir(),
    ]:
        path.unlink()
    jobs = scheduled(snakemake(workdir, "-n", "hazard_map", config=workdir / "config.yaml"))
    assert jobs == {
        "mc_chunk": 1,
        "mc_collect": 1,
        "exceedance": 1,
        "zoning": 1,
        "multifidelity": 1,
        "report": 1,
        "hazard_map": 1,
    }
    result = snakemake(workdir, "--cores", "2", "hazard_map", config=workdir / "config.yaml")
    assert result.returncode == 0, result.stderr
    assert chunk.read_bytes() == before


def test_monte_carlo_results_do_not_depend_on_the_chunk_size(built, tmp_path):
    workdir, config = built
    copy_dir = tmp_path / "rechunked"
    shutil.copytree(workdir, copy_dir)
    changed = copy.deepcopy(config)
    changed["montecarlo"]["chunk_size"] = 3
    path = write_config(tmp_path / "c.yaml", changed)
    assert scheduled(snakemake(copy_dir, "-n", "results/mc/case1/realizations.csv", config=path)) == {
        "mc_chunk": 2,
        "mc_collect": 1,
    }
    result = snakemake(copy_dir, "--cores", "2", "results/mc/case1/realizations.csv", config=path)
    assert result.returncode == 0, result.stderr
    table = "results/mc/case1/realizations.csv"
    assert (copy_dir / table).read_bytes() == (workdir / table).read_bytes()


def test_jobs_ask_their_scheduler_for_a_gpu_exactly_when_their_device_is_cuda(tmp_path):
    """config/paper.yaml trains and rolls out on cuda: those jobs ask SLURM for a GPU; on the
    default config's cpu no job does."""

    def gpu_requests(config: Path) -> dict[str, set[str]]:
        output = snakemake(
            tmp_path, "-n", "results/mc/case1/realizations/chunk_000.csv", "results/model/gns.pt", config=config
        ).stdout
        requests: dict[str, set[str]] = {}
        for block in output.split("\nrule ")[1:]:
            match = re.search(r"gpu=(\d+)", block)
            requests.setdefault(block.split(":", 1)[0], set()).add(match.group(1) if match else "none")
        return requests

    paper = gpu_requests(REPO / "config" / "paper.yaml")
    assert paper["train"] == paper["mc_chunk"] == {"1"} and paper["mpm_run"] == {"none"}
    default = gpu_requests(REPO / "config" / "config.yaml")
    assert default["mc_chunk"] == {"0"} and "train" not in default  # the shipped model: nothing to train


def test_the_gate_reports_a_failed_model_or_stops_when_told(built, tmp_path):
    """The tiny 200-step model against an R² of 0.99: by default (on_failure report) the verdict is printed at
    the top of the report and decides nothing — the Monte Carlo runs the learned simulator, corrected by the
    case's MPM pairs, and no rule runs the Monte Carlo on the MPM; with on_failure stop the chunks fail naming
    the case and metric, and nothing already computed is lost."""
    workdir, config = built
    copy_dir = tmp_path / "strict"
    shutil.copytree(workdir, copy_dir)
    strict = copy.deepcopy(config)
    strict["validation"]["acceptance"] = {
        "metrics": {"runout": {"r2_min": 0.99, "relative_bias_max": 0.001}},
        "min_realizations": 1,
    }
    path = write_config(tmp_path / "strict.yaml", strict)
    result = snakemake(copy_dir, "--cores", "2", "hazard_map", config=path)
    assert result.returncode == 0, result.stderr
    gate = json.loads((copy_dir / "results" / "report" / "validation" / "gate.json").read_text())
    assert not gate["case1"]["passed"] and gate["case1"]["simulator"] == "gns"
    table = read_csv(copy_dir / "results" / "mc" / "case1" / "realizations.csv")
    assert (table["simulator"] == "gns").all()
    page = (copy_dir / "results" / "report" / "report.html").read_text()
    assert "FAILED the validation gate" in page.split("Configuration</h2>")[0]

    strict["validation"]["acceptance"]["on_failure"] = "stop"
    for chunk in (copy_dir / "results" / "mc" / "case1" / "realizations").glob("chunk_*.csv"):
        chunk.unlink()
    result = snakemake(copy_dir, "--cores", "2", "hazard_map", config=write_config(tmp_path / "stop.yaml", strict))
    assert result.returncode != 0
    assert "case1: the GNS failed the validation gate (runout R²" in result.stdout + result.stderr
    logs = [
        path.read_text() for path in (copy_dir / "logs" / "mc_chunk" / "case1" / "realizations").glob("chunk_*.log")
    ]
    assert any("case1: the GNS failed" in log for log in logs)  # the chunk that failed first says why
    assert (copy_dir / "results" / "validation" / "case1" / "pairs.csv").exists()


def test_a_plain_mpm_monte_carlo_runs_to_its_report_without_a_model(built, tmp_path):
    """montecarlo.simulator: mpm on the tiny run: every realization by the MPM, and a page that says so and
    shows no learned simulator."""
    workdir = tmp_path / "mpm"
    shutil.copytree(built[0], workdir, symlinks=True)
    config = copy.deepcopy(built[1])
    config["montecarlo"]["simulator"] = "mpm"
    result = snakemake(workdir, "--cores", "2", "hazard_map", config=write_config(tmp_path / "mpm.yaml", config))
    assert result.returncode == 0, result.stderr[-3000:]
    table = read_csv(workdir / "results" / "mc" / "case1" / "realizations.csv")
    assert (table["simulator"] == "mpm").all() and len(table) == config["montecarlo"]["realizations"]
    page = (workdir / "results" / "report" / "report.html").read_text()
    assert "case1: MPM (configured)" in page and "no surrogate was used" in page
    assert "<summary>Validation against MPM on the test cases" not in page


def test_the_tuned_control_variate_is_made_and_corrects_the_monte_carlo(built, tmp_path):
    """montecarlo.fidelity.cheap tuned with endstate.tuned.model train: the tuning runs at the accurate mesh
    (drawn from endstate.tuned.data_seed, coarse-grained), the fine-tune and its card, the tuned model on
    every Monte Carlo realization (its chunks timed), and the correction with it as cheap route; the
    Monte Carlo's own runs and their map are not redone."""
    workdir = tmp_path / "tuned"
    shutil.copytree(built[0], workdir, symlinks=True)
    config = copy.deepcopy(built[1])
    config["endstate"] = {
        "model": "train",
        "realizations": 2,
        "held_out": 1,
        "chunk_size": 3,
        "widths": [4, 8],
        "steps": 10,
        "checkpoint_every": 10,
        "threads": 1,
        "tuned": {"model": "train", "realizations": 2, "held_out": 2, "chunk_size": 2, "steps": 5},
    }
    config["montecarlo"]["fidelity"]["cheap"] = "tuned"
    results = workdir / "results"
    own = (results / "mc" / "case1" / "realizations.csv").stat().st_mtime_ns
    result = snakemake(workdir, "--cores", "2", "hazard_map", config=write_config(tmp_path / "tuned.yaml", config))
    assert result.returncode == 0, result.stderr
    assert (results / "mc" / "case1" / "realizations.csv").stat().st_mtime_ns == own
    tuned = read_end_states(sorted((results / "endstate" / "tuned" / "case1").glob("chunk_*.h5")))
    assert [s.index for s in tuned] == [0, 1, 2, 3] and all(len(s.initial) == 120 for s in tuned)  # coarse lattice
    card = json.loads((results / "model" / "endstate_tuned_card.json").read_text())
    assert card["cases"] == ["case1"] and card["steps"] == 5 and len(card["agreement"]) == 6
    assert card["serves"]["montecarlo.fidelity.high_cell_size_m"] == 0.5
    control = read_csv(results / "mc" / "case1" / "control.csv")
    assert list(control["index"]) == list(range(6)) and (control["simulator"] == "endstate").all()
    record = json.loads((results / "report" / "case1" / "multifidelity.json").read_text())
    assert record["cheap_route"] == "the end-state surrogate tuned to the accurate MPM"
    assert record["means"]["runout_m"]["low_mean"] == pytest.approx(control["runout_m"].mean())
    mc = read_csv(results / "mc" / "case1" / "realizations.csv")
    assert record["simulator_means"]["runout_m"] == pytest.approx(mc["runout_m"].mean())
    # the cheap route's cost is the tuned model's control chunks (not the Monte Carlo's own), from their job seconds
    job_seconds = {
        route: sum(pd.read_csv(path, sep="\t")["s"].sum() for path in (results / "mc" / "case1" / route).glob("*.tsv"))
        for route in ("control", "paired")
    }
    assert record["cost"]["low_s"] == pytest.approx(job_seconds["control"] / 6) and job_seconds["control"] > 0
    paired = read_csv(results / "mc" / "case1" / "paired.csv")
    assert record["cost"]["high_s"] == pytest.approx(job_seconds["paired"] / len(paired)) and job_seconds["paired"] > 0
    page = (results / "report" / "report.html").read_text()
    assert (
        "by the correction&#x27;s cheap route (the end-state surrogate tuned" in page
        or "by the correction's cheap route (the end-state surrogate tuned" in page
    )


def test_the_end_state_surrogate_trains_validates_and_runs_the_monte_carlo(built, tmp_path):
    """montecarlo.simulator endstate with endstate.model train: its training runs (drawn from
    endstate.data_seed), the training, the validation against the case's MPM runs, the gate and the
    Monte Carlo by it, and the report's model section; the MPM runs already made are not redone. The gate
    judges with the schema's limits (R² 0.9), not the tiny config's open ones: a 20-step model fails them,
    the page's top says so, and the Monte Carlo runs by it all the same (on_failure: report)."""
    workdir = tmp_path / "endstate"
    shutil.copytree(built[0], workdir, symlinks=True)
    config = copy.deepcopy(built[1])
    config["montecarlo"]["simulator"] = "endstate"
    config["endstate"] = {
        "model": "train",
        "realizations": 4,
        "held_out": 2,
        "chunk_size": 2,
        "widths": [4, 8],
        "steps": 20,
        "checkpoint_every": 10,
        "threads": 1,
        "validation": {"sets": ["case1"], "data_seed": 99, "realizations": 3, "chunk_size": 2},
    }
    config["validation"]["acceptance"] = {"min_realizations": 1}  # the schema's metric limits
    packed = workdir / "results" / "dataset" / "case1.h5"
    before = packed.stat().st_mtime_ns
    result = snakemake(workdir, "--cores", "2", "hazard_map", config=write_config(tmp_path / "endstate.yaml", config))
    assert result.returncode == 0, result.stderr
    results = workdir / "results"
    assert sorted(p.name for p in (results / "endstate" / "data" / "case1").glob("*.h5")) == [
        "chunk_000.h5",
        "chunk_001.h5",
        "chunk_002.h5",
    ]
    history = read_csv(results / "model" / "endstate_history.csv")
    assert list(history["step"]) == [10, 20]
    gate = json.loads((results / "report" / "validation" / "gate.json").read_text())
    assert gate["case1"]["surrogate"] == "endstate" and gate["case1"]["simulator"] == "endstate"
    assert not gate["case1"]["passed"] and gate["case1"]["failures"]
    table = read_csv(results / "mc" / "case1" / "realizations.csv")
    assert (table["simulator"] == "endstate").all() and (table["status"] == "ok").all()
    pairs = read_csv(results / "validation" / "case1" / "pairs.csv")
    assert len(pairs) == 2 and pairs["runout_m_gns"].notna().all()  # the validation's own realizations
    page = (results / "report" / "report.html").read_text()
    assert (
        "End-state surrogate" in page
        and "the end-state surrogate FAILED the validation gate" in page.split("Configuration</h2>")[0]
    )
    assert packed.stat().st_mtime_ns == before

    # its card: validated on endstate.validation's sets (their own seed) first; the model is not retrained
    model_time = (results / "model" / "endstate.pt").stat().st_mtime_ns
    result = snakemake(
        workdir, "--cores", "2", "pretrain_endstate", config=write_config(tmp_path / "endstate.yaml", config)
    )
    assert result.returncode == 0, result.stderr
    assert (results / "model" / "endstate.pt").stat().st_mtime_ns == model_time
    validation = read_end_states(sorted((results / "endstate" / "validation" / "case1").glob("chunk_*.h5")))
    assert [state.index for state in validation] == [0, 1, 2]
    assert not np.allclose(
        validation[0].friction_deg,
        read_end_states([results / "endstate" / "data" / "case1" / "chunk_000.h5"])[0].friction_deg,
    )  # another seed's draw
    ood = json.loads((results / "model" / "endstate_ood.json").read_text())
    assert [(row["set"], row["metric"], row["n"]) for row in ood] == [
        ("case1", m, 3) for m in ("runout", "volume", "influence")
    ]
    card = json.loads((results / "model" / "endstate_card.json").read_text())
    assert card["features"] == "body" and card["bounds"] == {"domain.length_m": 40.0, "domain.height_m": 10.0}
    assert card["ranges"]["field"]["friction_std_deg"] == [5.0, 5.0]
    assert "Validation on slopes and soils it never saw" in (results / "model" / "endstate_card.md").read_text()


def test_the_shipped_end_state_model_is_fine_tuned_from_the_first_stage_on_all_its_sets(tmp_path):
    """config/pretrain_general_wide.yaml after config/pretrain_general.yaml: the 45 sets' training runs, one training
    that starts from the shipped model, and a card that reads the shipped card."""
    dry_run = snakemake(
        tmp_path,
        "-n",
        "pretrain_endstate",
        "--configfile",
        str(REPO / "config" / "pretrain_general.yaml"),
        str(REPO / "config" / "pretrain_general_wide.yaml"),
    )
    assert dry_run.returncode == 0, dry_run.stderr[-3000:]
    jobs = scheduled(dry_run)
    assert jobs["endstate_data"] == 45 * 2 and jobs["train_endstate"] == jobs["endstate_card"] == 1
    train_job = dry_run.stdout.split("rule train_endstate:")[1].split("rule ")[0]
    assert "rgns/models/endstate_general.pt" in train_job
