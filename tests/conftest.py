"""Shared fixtures: the repository's configs, loaded and validated; the order the test files run in."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
from workflow_helpers import snakemake, write_config

from rgns.config import load_config, load_yaml

REPO = Path(__file__).resolve().parent.parent
TINY_CONFIG = REPO / "tests" / "data" / "tiny.yaml"
# The README's test command runs the tests on two workers (pytest-xdist), one work unit at a time each: a file, or
# together the files that use the `built` workflow below, so that it is built once, on the worker that runs them
# all (they change it in place, so two workers cannot share one; xdist's own --dist loadgroup cannot group them
# under pytest 9, whose node ids it can no longer suffix). That unit first, then the other files that took minutes
# (measured with --durations on 2 cores), so that neither worker is left running a long one alone at the end;
# every other test keeps its place after them. The SLURM run leads them: most of its minutes are the cluster's
# polling and job starts, which the other worker's computing fills.
BUILT_USERS = ("tests/test_workflow.py", "tests/test_faults.py", "tests/scene/test_site.py")
LONGEST_FIRST = (
    "tests/test_slurm.py",
    "tests/engines/test_mpm_physics.py",
    "tests/fidelity/test_mesh_extrapolation.py",
    "tests/surrogates/test_endstate_general.py",
)


def work_unit(nodeid: str) -> str:
    """The unit a test is handed out in: its file, or "built" for the files of BUILT_USERS."""
    path = nodeid.split("::", 1)[0]
    return "built" if path in BUILT_USERS else path


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The units in the order they are handed out: "built", then LONGEST_FIRST, then the rest as collected."""
    rank = {name: k + 1 for k, name in enumerate(LONGEST_FIRST)} | {"built": 0}
    items.sort(key=lambda item: rank.get(work_unit(item.nodeid), len(rank)))


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log):
    """xdist's file-by-file scheduler, its units given by :func:`work_unit` and handed out in collection order."""
    from xdist.scheduler import LoadScopeScheduling

    class Units(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return work_unit(nodeid)

    config.option.loadscopereorder = False  # the order above, not the largest unit first
    return Units(config, log)


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
