"""Send a rule script's logging and warnings to the rule's log file."""

from __future__ import annotations

import logging
import sys
from pathlib import Path
from types import TracebackType


class _Brief(logging.Formatter):
    """One line for the console: level, log file and message, no traceback (that stays in the log)."""

    def __init__(self, log_path: str):
        super().__init__()
        self.log_path = log_path

    def format(self, record: logging.LogRecord) -> str:
        return f"{record.levelname} (full log: {self.log_path}): {record.getMessage()}"


def _log_uncaught(kind: type[BaseException], error: BaseException, trace: TracebackType | None) -> None:
    """A rule script's uncaught exception: its message to the log and the console, its traceback to the log."""
    logging.getLogger("rgns").error("%s: %s", kind.__name__, error, exc_info=(kind, error, trace))


def log_to_file(path: str | Path, name: str = "rgns") -> logging.Logger:
    """Log INFO and above, with timestamps, to ``path``; stderr goes there too. Errors also reach the
    console (the original stderr), so that a failing rule shows its reason, not only "see the log"."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    handler = logging.FileHandler(path, mode="w")
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    console = logging.StreamHandler(sys.__stderr__)
    console.setLevel(logging.ERROR)
    console.setFormatter(_Brief(Path(path).as_posix()))
    root = logging.getLogger()
    root.handlers[:] = [handler, console]
    sys.excepthook = _log_uncaught
    root.setLevel(logging.INFO)
    logging.captureWarnings(True)
    sys.stderr = open(path, "a", buffering=1)  # noqa: SIM115 - lives as long as the script
    return logging.getLogger(name)
