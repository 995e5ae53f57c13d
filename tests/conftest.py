"""Shared fixtures: the repository's configs, loaded and validated; the order the test files run in."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
from workflow_helpers import snakemake, write_config

from rgns.config import load_config, load_yaml

REPO = Path(__file__).resolve().parent.parent
TINY_CONFIG = REPO / "tests" / "data" / "tiny.yaml"
# The README's test command runs the files on two workers (pytest-xdist, --dist loadfile), each taking the next
# file as it finishes one; the longest first, so that neither is left running one alone at the end (measured with
# --durations on 2 cores: these took 4-12 min each, the rest under 3).
LONGEST_FIRST = (
    "tests/test_workflow.py",
    "tests/test_faults.py",
    "tests/engines/test_mpm_physics.py",
    "tests/fidelity/test_mesh_extrapolation.py",
    "tests/scene/test_site.py",
    "tests/test_slurm.py",
    "tests/surrogates/test_endstate_general.py",
)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The files of LONGEST_FIRST first, in that order; every other test keeps its place after them."""
    rank = {name: k for k, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.nodeid.split("::")[0], len(rank)))


@pytest.fixture(scope="session")
def default_config() -> dict:
    return load_config(REPO / "config" / "config.yaml")


@pytest.fixture(scope="session")
def paper_config() -> dict:
    return load_config(REPO / "config" / "paper.yaml")


@pytest.fixture()
def raw_default_config() -> dict:
    """The default config as written, before defaults are filled: a copy to break."""
    return copy.deepcopy(load_yaml(REPO / "config" / "config.yaml"))


@pytest.fixture(scope="session")
def built(tmp_path_factory):
    """The tiny workflow run to completion once, for the tests that change, break or rerun it
    (tests that change files work on a copy, or restore what they change)."""
    workdir = tmp_path_factory.mktemp("tiny")
    config = load_yaml(TINY_CONFIG)
    path = write_config(workdir / "config.yaml", config)
    result = snakemake(workdir, "--cores", "2", "hazard_map", config=path)
    assert result.returncode == 0, result.stderr
    return workdir, config
