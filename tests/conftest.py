"""Shared fixtures: the repository's configs, loaded and validated."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
from workflow_helpers import snakemake, write_config

from rgns.config import load_config, load_yaml

REPO = Path(__file__).resolve().parent.parent
TINY_CONFIG = REPO / "tests" / "data" / "tiny.yaml"


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
