"""Config section ``mpm`` typed: every key a case is built from, and the embedded engine's settings."""

from conftest import REPO

from rgns.config import load_yaml
from rgns.engines.mpm.solver import EngineSettings
from rgns.engines.settings import MpmSettings


def test_the_settings_carry_every_key_of_the_section_but_the_engine_choice_and_the_chunking(default_config):
    section = default_config["mpm"]
    mpm = MpmSettings.from_config(section)
    keys = load_yaml(REPO / "config" / "schema.yaml")["properties"]["mpm"]["properties"]
    assert sorted(mpm.case) == sorted(set(keys) - {"engine", "chunk_size", "embedded", "cbgeo"})
    assert mpm.case == {key: section[key] for key in mpm.case}
    assert mpm.embedded == EngineSettings.from_config(section["embedded"])
