"""The sweep for damaged intermediates: what it removes, what it keeps, what it says, what it rereads."""

from pathlib import Path

from rgns.integrity import Kind, dry_run, locked, sweep


def table(path: Path, rows: list[int]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("index,runout_m\n" + "".join(f"{i},{i * 0.5}\n" for i in rows))
    return path


def test_a_damaged_table_is_removed_and_named_a_whole_one_kept_and_not_read_again(tmp_path):
    good = table(tmp_path / "results" / "mc" / "a" / "realizations.csv", [0, 1, 2])
    cut = table(tmp_path / "results" / "mc" / "b" / "realizations.csv", [0, 1, 2])
    cut.write_bytes(cut.read_bytes()[:-3])
    said: list[str] = []
    assert sweep(tmp_path, say=said.append) == ["results/mc/b/realizations.csv"]
    assert good.exists() and not cut.exists()
    assert said == [
        "rgns: results/mc/b/realizations.csv is damaged (TableError: cut short (no newline after "
        "its last row)); removed, so that this run makes it again"
    ]
    reads: list[Path] = []
    counting = (Kind("results/mc/**/*.csv", reads.append),)
    sweep(tmp_path, kinds=counting, say=said.append)
    assert reads == []  # passed before, unchanged since: not read again
    good.write_text(good.read_text() + "3,1.5\n")
    sweep(tmp_path, kinds=counting, say=said.append)
    assert reads == [good]


def test_a_folder_output_short_of_a_member_and_a_chunk_holding_other_realizations_are_removed(tmp_path):
    folder = tmp_path / "results" / "mpm" / "case1" / "chunk_000"
    folder.mkdir(parents=True)
    (folder / "0000.h5").write_bytes(b"")
    chunk = table(tmp_path / "results" / "mc" / "case1" / "realizations" / "chunk_001.csv", [2])
    said: list[str] = []
    removed = sweep(
        tmp_path,
        folders={"results/mpm/case1/chunk_000": ["0000.h5", "0001.h5"]},
        chunks={"results/mc/case1/realizations/chunk_001.csv": [2, 3]},
        kinds=(),
        say=said.append,
    )
    assert removed == ["results/mpm/case1/chunk_000", "results/mc/case1/realizations/chunk_001.csv"]
    assert not folder.exists() and not chunk.exists()
    assert said[0] == "rgns: results/mpm/case1/chunk_000 lacks 0001.h5: removed, so that this run makes it again"
    assert "holds realizations [2], not [2, 3]" in said[1]


def test_dry_runs_and_locked_directories_are_recognised(tmp_path):
    assert dry_run(["snakemake", "-n", "hazard_map"]) and dry_run(["-np"]) and dry_run(["--dry-run"])
    assert not dry_run(["snakemake", "--cores", "2", "-c2", "hazard_map", "--configfile", "config/site.yaml"])
    assert not locked(tmp_path)
    (tmp_path / ".snakemake" / "locks").mkdir(parents=True)
    (tmp_path / ".snakemake" / "locks" / "0.input.lock").write_text("")
    assert locked(tmp_path)
