"""This machine's pace today against the cost table's, with the code of each commit named, in one run.

    python benchmarks/machine_pace.py                       # HEAD's code
    python benchmarks/machine_pace.py --code d1a5a17 HEAD   # each commit's own code

A timed fresh run (benchmarks/fresh_run.py) is only comparable with another made at the same pace. The cost
table (benchmarks/mesh_levels.py's one-thread runs) timed case 1's realization 0 at 0.5 m cells alone in a
process; this runs the same realization the same way, once per commit named, in a temporary worktree of it (its
``rgns`` first on ``PYTHONPATH``, so an old commit's own code runs, not this checkout's; the checkout's own cost
table stays as it is), and records
its wall time, steps and runout beside the cost table's. The same runout with a longer time says the machine
slowed, not the code. Appends one entry per run to ``benchmarks/results/machine_pace.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from datetime import datetime, timezone
from pathlib import Path

import mesh_levels as ml

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "benchmarks" / "results" / "machine_pace.json"
STORE = Path("benchmarks/results/mesh_levels_runs.jsonl")  # the cost table's runs, relative to a checkout
KEY = ("case1", 0.5, 0)  # the cost table's run in it
OLD_RUN = Path("benchmarks/results/mesh_levels/case1/h0.5/0000.json")  # the same, where a commit kept a file per run
RECORDED = ("seconds", "runout_m")


def git(*args: str, cwd: Path = REPO) -> str:
    return subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True, check=True).stdout.strip()


def cost_run(read: Callable[[Path], str | None]) -> dict | None:
    """The cost table's run as ``read`` (a path relative to a checkout -> its text, None where absent) finds it: in
    the runs' store, else in its own file (a commit from before the store); None where neither holds it."""
    store = read(STORE)
    if store is not None:
        return ml.parse_runs(store).get(KEY)
    old = read(OLD_RUN)
    return None if old is None else json.loads(old)


def in_checkout(checkout: Path) -> Callable[[Path], str | None]:
    return lambda path: (checkout / path).read_text() if (checkout / path).exists() else None


def in_commit(code: str) -> Callable[[Path], str | None]:
    def read(path: Path) -> str | None:
        shown = subprocess.run(["git", "show", f"{code}:{path}"], cwd=REPO, capture_output=True, text=True)
        return shown.stdout if shown.returncode == 0 else None

    return read


def made_in(table: dict) -> list[str]:
    """The commit (short hash, date) that saved the cost table's run as it is: the oldest of the unbroken line of
    latest commits of its store (or, before the store, of its own file) that hold it so."""
    commits = [line.split() for line in git("log", "--format=%h %cs", "--", str(STORE), str(OLD_RUN)).splitlines()]
    made = commits[0]
    for code, date in commits:
        held = cost_run(in_commit(code))
        if held is None or any(held[k] != table[k] for k in RECORDED):
            break
        made = [code, date]
    return made


def timed_run(checkout: Path) -> dict:
    """Case 1's realization 0 at 0.5 m, one thread, by ``checkout``'s own code, in a fresh process."""
    if (checkout / STORE).exists():
        (checkout / STORE).unlink()  # a temporary worktree: its store then holds the timed run alone
    else:
        (checkout / OLD_RUN).unlink(missing_ok=True)  # a commit from before the store
    env = os.environ | {"PYTHONPATH": str(checkout), "OMP_NUM_THREADS": "1"}
    command = [
        sys.executable,
        "benchmarks/mesh_levels.py",
        "--run",
        "--cases",
        "case1",
        "--cells",
        "0.5",
        "--realizations",
        "1",
    ]
    began = time.perf_counter()
    done = subprocess.run(command, cwd=checkout, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - began
    record = cost_run(in_checkout(checkout))
    if record is None:  # the run failed (an old commit's report of one realization may fail after it: no matter)
        raise RuntimeError(f"{checkout}: no run saved:\n{done.stderr[-2000:]}")
    return {"seconds": record["seconds"], "process_s": wall, "runout_m": record["runout_m"]}


def measure(code: str) -> dict:
    """One run with the code of commit ``code``, in a temporary worktree of it."""
    folder = Path(tempfile.mkdtemp(prefix="pace_"))
    try:
        git("worktree", "add", "--detach", str(folder / "tree"), code)
        return timed_run(folder / "tree") | {"code": git("rev-parse", "--short=10", "HEAD", cwd=folder / "tree")}
    finally:
        subprocess.run(["git", "worktree", "remove", "--force", str(folder / "tree")], cwd=REPO, capture_output=True)
        shutil.rmtree(folder, ignore_errors=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--code", nargs="+", default=["HEAD"], help="commits whose own code runs")
    args = parser.parse_args()
    table = cost_run(in_checkout(REPO))
    assert table is not None, f"{STORE} holds no {KEY}"
    made = made_in(table)
    record = json.loads(OUT.read_text()) if OUT.exists() else {"runs": []}
    record |= {
        "command": "python benchmarks/machine_pace.py --code <commits>",
        "cost_table": {"seconds": table["seconds"], "runout_m": table["runout_m"], "commit": made[0], "date": made[1]},
    }
    load = os.getloadavg()[0]
    for code in args.code:
        entry = measure(code) | {
            "date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "load_before": load,
            "machine": f"{platform.machine()}, {os.cpu_count()} cores",
            "commit": git("rev-parse", "--short=10", "HEAD"),
        }
        print(
            f"{entry['code']}: {entry['seconds']:.1f} s (the cost table's {table['seconds']:.1f} s: "
            f"{entry['seconds'] / table['seconds']:.2f}x), runout {entry['runout_m']!r} m "
            f"(the table's {table['runout_m']!r})",
            flush=True,
        )
        record["runs"].append(entry)
        OUT.write_text(json.dumps(record, indent=1) + "\n")
        load = os.getloadavg()[0]


if __name__ == "__main__":
    main()
