"""What made a result: the rgns version, the checkout's commit, a digest of the configuration and
the time, so that a report says which code and which inputs it comes from."""

from __future__ import annotations

import hashlib
import json
import subprocess
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path
from typing import Any

REPO_ROOT = Path(__file__).resolve().parent.parent
RESULTS = "benchmarks/results"  # relative to the checkout's root


def config_digest(config: dict[str, Any]) -> str:
    """The first 12 hex digits of the SHA-256 of the configuration as canonical JSON."""
    text = json.dumps(config, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:12]


def commit(root: Path = REPO_ROOT) -> str:
    """The checkout's short commit, marked when tracked files differ from it; 'no git checkout' otherwise. The
    benchmarks' result files are outputs, not code: a benchmark still writing its own does not mark another's."""

    def git(*args: str) -> str:
        return subprocess.run(
            ["git", "-C", str(root), *args], capture_output=True, text=True, check=True, timeout=30
        ).stdout.strip()

    try:
        head = git("rev-parse", "--short=10", "HEAD")
        return head + (
            " with local changes"
            if git("status", "--porcelain", "--untracked-files=no", "--", ".", f":(exclude){RESULTS}")
            else ""
        )
    except (OSError, subprocess.SubprocessError):
        return "no git checkout"


def version() -> str:
    """The installed rgns version ('not installed' when run from a bare checkout)."""
    try:
        return metadata.version("rgns")
    except metadata.PackageNotFoundError:
        return "not installed"


def provenance(config: dict[str, Any]) -> dict[str, str]:
    """Version, commit, config digest and the UTC time now."""
    return {
        "version": version(),
        "commit": commit(),
        "config_digest": config_digest(config),
        "made_utc": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
    }
