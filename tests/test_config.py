"""Config validation: good configs pass with defaults filled; bad ones name the key and value."""

from __future__ import annotations

import copy

import pytest
from conftest import REPO

from rgns.config import ConfigError, load_yaml, validate_config
from rgns.scene.sets import realization_group, set_size


def test_default_and_paper_configs_validate(default_config, paper_config):
    assert default_config["random_field"]["method"] == "kronecker"
    assert set_size(paper_config["sets"]["train"]) == 1000
    assert set_size(paper_config["sets"]["valid"]) == 50
    assert [set_size(paper_config["sets"][f"case{k}"]) for k in range(1, 5)] == [250] * 4
    assert (paper_config["domain"]["length_m"], paper_config["domain"]["height_m"]) == (240.0, 60.0)
    assert paper_config["mesh"]["cell_size_m"] == 2.0


def test_omitted_sections_get_the_schema_defaults(raw_default_config):
    for section in ("domain", "mesh", "random_field", "seed"):
        raw_default_config.pop(section)
    config = validate_config(raw_default_config)
    assert config["mesh"] == {"cell_size_m": 1.0, "particles_per_cell": 2}
    assert config["random_field"]["friction_bounds_deg"] == [5.0, 60.0]
    assert config["geometry"]["max_draws"] == 100
    assert isinstance(config["seed"], int)


def test_realizations_are_numbered_through_the_groups(default_config):
    groups = default_config["sets"]["train"]
    assert realization_group(groups, 0)[1]["family"] == "slope"
    assert realization_group(groups, 5)[1]["family"] == "slope"
    assert realization_group(groups, 6)[1]["family"] == "embankment"
    with pytest.raises(IndexError):
        realization_group(groups, 12)


def _set(config, path, value):
    node = config
    for part in path[:-1]:
        node = node.setdefault(part, {}) if isinstance(node, dict) else node[part]
    node[path[-1]] = value


BAD = [
    (("domain", "width_m"), 5.0, r"'domain'.*'width_m' was unexpected"),
    (("sets", "train", 0, "correlation_length_x_m"), -5.0, r"'sets.train\[0\].correlation_length_x_m' = -5.0"),
    (("sets", "case2", 0, "correlation_length_y_m"), 0.0, r"'sets.case2\[0\].correlation_length_y_m' = 0.0"),
    (("sets", "case1", 0, "friction_std_deg"), 0.0, r"'sets.case1\[0\].friction_std_deg' = 0.0"),
    (("sets", "case1", 0, "friction_std_deg"), -2.0, r"'sets.case1\[0\].friction_std_deg' = -2.0"),
    (("sets", "case4", 0, "friction_mean_deg"), 95.0, r"'sets.case4\[0\].friction_mean_deg' = 95.0"),
    (("sets", "case4", 0, "friction_mean_deg"), 0.0, r"'sets.case4\[0\].friction_mean_deg' = 0.0"),
    (
        ("sets", "train", 1, "friction_mean_deg"),
        [10.0, 95.0],
        r"'sets.train\[1\].friction_mean_deg' = \[10.0, 95.0\]: 95.0 is greater than or equal to the maximum of 90",
    ),
    (
        ("sets", "train", 1, "friction_mean_deg"),
        [35.0, 20.0],
        r"'sets.train\[1\].friction_mean_deg' = \[35.0, 20.0\]: min 35.0 > max 20.0",
    ),
    (
        ("geometry", "families", "slope", "vertices", 1, "x_m"),
        [30.0, 24.0],
        r"'geometry.families.slope.vertices\[1\].x_m' = \[30.0, 24.0\]: min 30.0 > max 24.0",
    ),
    (
        ("geometry", "families", "slope", "vertices", 1, "x_m"),
        [28.0, 95.0],
        r"'geometry.families.slope.vertices\[1\].x_m' = \[28.0, 95.0\]: outside the domain",
    ),
    (
        ("geometry", "families", "column", "vertices", 2, "y_m"),
        25.0,
        r"'geometry.families.column.vertices\[2\].y_m' = 25.0: outside the domain",
    ),
    (
        ("geometry", "families", "column", "vertices", 1, "x_m"),
        -3.0,
        r"'geometry.families.column.vertices\[1\].x_m' = -3.0: outside the domain",
    ),
    (("sets", "case3", 0, "family"), "cliff", r"'sets.case3\[0\].family' = 'cliff': no such family"),
    (("sets", "case3", 0, "count"), 0, r"'sets.case3\[0\].count' = 0"),
    (("domain", "length_m"), 80.5, r"'domain.length_m' = 80.5: not a whole number of cells"),
    (("mesh", "cell_size_m"), "2 m", r"'mesh.cell_size_m' = '2 m': '2 m' is not of type 'number'"),
    (("random_field", "method"), "fft", r"'random_field.method' = 'fft'"),
    (
        ("random_field", "friction_bounds_deg"),
        [40.0, 10.0],
        r"'random_field.friction_bounds_deg' = \[40.0, 10.0\]: min 40.0 > max 10.0",
    ),
    (("geometry", "runout_room_m"), 60.0, r"'geometry.families.slope.vertices'.*right wall"),
    (("montecarlo", "cases"), ["case9"], r"'montecarlo.cases\[0\]' = 'case9': not a test-case set"),
    (("montecarlo", "cases"), ["train"], r"'montecarlo.cases\[0\]' = 'train': not a test-case set"),
    (("montecarlo", "simulator"), "fem", r"'montecarlo.simulator' = 'fem'"),
    (("montecarlo", "realizations"), 1, r"'montecarlo.realizations' = 1"),
    (("montecarlo", "chunk_size"), 10, r"'montecarlo.chunk_size' = 10: not a multiple of montecarlo.batch_size = 4"),
    (
        ("montecarlo", "fidelity", "paired"),
        1,
        r"'montecarlo.fidelity.paired' = 1: 0 \(off\) or between 2 and montecarlo.realizations = 10000",
    ),
    (("montecarlo", "fidelity", "paired"), 10001, r"'montecarlo.fidelity.paired' = 10001: 0 \(off\) or between 2"),
    (
        ("montecarlo", "fidelity", "high_cell_size_m"),
        1.0,
        r"'montecarlo.fidelity.high_cell_size_m' = 1.0: must be finer than mesh.cell_size_m = 1.0",
    ),
    (
        ("montecarlo", "cases"),
        ["case1", "case2"],
        r"'montecarlo.fidelity.cheap' = 'tuned': the shipped tuned end-state surrogate does not serve this config: "
        r"montecarlo.cases has case2, it was tuned on case1 \(set endstate.tuned.model: train",
    ),
    (
        ("montecarlo", "fidelity", "high_cell_size_m"),
        0.25,
        r"'montecarlo.fidelity.cheap' = 'tuned': .*montecarlo.fidelity.high_cell_size_m is 0.25, the model was trained at 0.5",
    ),
    (
        ("hazard", "zoning_thresholds"),
        [0.9, 0.1, 0.5, 0.01],
        r"'hazard.zoning_thresholds' = \[0.9, 0.1, 0.5, 0.01\]: must be strictly decreasing",
    ),
    (("hazard", "zoning_thresholds"), [0.9, 0.5, 0.1], r"'hazard.zoning_thresholds' = \[0.9, 0.5, 0.1\]"),
    (("metrics", "runout_percentile"), 120.0, r"'metrics.runout_percentile' = 120.0"),
]


@pytest.mark.parametrize("path, value, message", BAD, ids=[".".join(map(str, b[0])) + "=" + str(b[1]) for b in BAD])
def test_a_bad_value_fails_with_a_message_naming_key_and_value(raw_default_config, path, value, message):
    raw_default_config.setdefault("montecarlo", {})["batch_size"] = 4
    _set(raw_default_config, path, value)
    with pytest.raises(ConfigError, match=message):
        validate_config(raw_default_config)


def test_a_clockwise_family_fails_naming_the_family(raw_default_config):
    raw_default_config["geometry"]["families"]["embankment"]["vertices"].reverse()
    with pytest.raises(ConfigError, match=r"'geometry.families.embankment.vertices'.*counter-clockwise"):
        validate_config(raw_default_config)


def test_a_config_that_trains_without_a_training_set_fails(raw_default_config):
    del raw_default_config["sets"]["train"]
    validate_config(copy.deepcopy(raw_default_config))  # the shipped model needs no training set
    raw_default_config["gns"] = {"model": "train"}
    with pytest.raises(ConfigError, match=r"'sets': no train set, which gns.model = 'train' trains on"):
        validate_config(raw_default_config)


def test_a_config_with_no_set_and_no_site_fails(raw_default_config):
    raw_default_config["sets"] = {}
    raw_default_config["montecarlo"]["cases"] = []
    with pytest.raises(ConfigError, match=r"'sets': no set and no site"):
        validate_config(raw_default_config)


def test_every_error_is_reported_at_once(raw_default_config):
    _set(raw_default_config, ("sets", "case1", 0, "friction_std_deg"), -1.0)
    _set(raw_default_config, ("sets", "case2", 0, "correlation_length_x_m"), -1.0)
    with pytest.raises(ConfigError) as error:
        validate_config(raw_default_config)
    assert "case1[0].friction_std_deg" in str(error.value) and "case2[0].correlation_length_x_m" in str(error.value)


def test_the_tiny_test_config_is_valid():
    validate_config(load_yaml(REPO / "tests" / "data" / "tiny.yaml"))


def test_a_monte_carlo_case_with_two_groups_is_refused_naming_it(raw_default_config):
    raw_default_config["sets"]["case1"].append(dict(raw_default_config["sets"]["case1"][0]))
    raw_default_config["montecarlo"] = {"cases": ["case1"]}
    with pytest.raises(ConfigError, match=r"'montecarlo.cases\[0\]' = 'case1': set 'case1' has 2 groups"):
        validate_config(raw_default_config)


def test_numbers_given_as_text_by_a_nested_config_override_are_read_as_numbers(raw_default_config):
    """Snakemake hands ``--config 'montecarlo={realizations: 320}'`` over as text ('320'): read as the
    schema's type; text that is no number still fails naming key and value."""
    config = copy.deepcopy(raw_default_config)
    config["montecarlo"] |= {"realizations": "320", "chunk_size": "32"}
    config["metrics"] = {"displacement_threshold_m": "0.5"}
    checked = validate_config(config)
    assert checked["montecarlo"]["realizations"] == 320 and checked["montecarlo"]["chunk_size"] == 32
    assert checked["metrics"]["displacement_threshold_m"] == 0.5
    config = copy.deepcopy(raw_default_config)
    config["montecarlo"]["realizations"] = "many"
    with pytest.raises(ConfigError, match=r"config key 'montecarlo.realizations' = 'many': 'many' is not of type"):
        validate_config(config)


def test_a_misspelled_key_gets_the_nearest_valid_name(raw_default_config):
    config = copy.deepcopy(raw_default_config)
    config["montecarlo"]["realizatons"] = 320
    with pytest.raises(
        ConfigError,
        match=r"'realizatons' was unexpected\); did you mean 'realizations' for "
        r"'realizatons'\?",
    ):
        validate_config(config)


def test_a_missing_config_file_is_one_line(tmp_path, capsys):
    from rgns.cli import main

    with pytest.raises(ConfigError, match=r"nonexistent.yaml: cannot read the config file \(No such file"):
        load_yaml(tmp_path / "nonexistent.yaml")
    assert main(["check-config", str(tmp_path / "nonexistent.yaml")]) == 1
    assert (
        capsys.readouterr().err == f"{tmp_path / 'nonexistent.yaml'}: cannot read the config file (No such file "
        "or directory)\n"
    )
