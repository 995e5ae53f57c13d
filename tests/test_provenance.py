"""What made a result: the config digest changes with any value and not with key order; the commit
of this checkout; a directory that is no checkout says so."""

import subprocess

from rgns.provenance import commit, config_digest, provenance


def test_the_config_digest_follows_the_values_not_the_key_order():
    one = {"seed": 1, "montecarlo": {"realizations": 64, "chunk_size": 16}}
    same = {"montecarlo": {"chunk_size": 16, "realizations": 64}, "seed": 1}
    assert config_digest(one) == config_digest(same) and len(config_digest(one)) == 12
    assert config_digest(one) != config_digest({"seed": 1, "montecarlo": {"realizations": 65, "chunk_size": 16}})


def test_the_commit_is_the_checkouts_or_says_there_is_none(tmp_path):
    assert commit(tmp_path) == "no git checkout"
    made = provenance({"seed": 1})
    assert set(made) == {"version", "commit", "config_digest", "made_utc"} and made["made_utc"].endswith("UTC")


def test_a_changed_file_marks_the_commit_and_a_benchmark_result_does_not(tmp_path):
    def git(*args: str) -> None:
        subprocess.run(["git", "-C", str(tmp_path), *args], check=True, capture_output=True)

    results = tmp_path / "benchmarks" / "results"
    results.mkdir(parents=True)
    (tmp_path / "code.py").write_text("a = 1\n")
    (results / "run.json").write_text("{}\n")
    git("init", "-q")
    git("add", ".")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "first")
    clean = commit(tmp_path)
    (results / "run.json").write_text('{"replicates": 1}\n')  # a benchmark still writing its result
    assert commit(tmp_path) == clean and "local changes" not in clean
    (tmp_path / "code.py").write_text("a = 2\n")
    assert commit(tmp_path) == f"{clean} with local changes"
