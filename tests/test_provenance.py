"""What made a result: the config digest changes with any value and not with key order; the commit
of this checkout; a directory that is no checkout says so."""

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
