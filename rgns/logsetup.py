"""Send a rule script's logging and warnings to the rule's log file."""
from __future__ import annotations

import logging
import sys
from pathlib import Path


def log_to_file(path: str | Path, name: str = "rgns") -> logging.Logger:
    """Log INFO and above, with timestamps, to ``path``; stderr goes there too."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    handler = logging.FileHandler(path, mode="w")
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    root = logging.getLogger()
    root.handlers[:] = [handler]
    root.setLevel(logging.INFO)
    logging.captureWarnings(True)
    sys.stderr = open(path, "a", buffering=1)  # noqa: SIM115 - lives as long as the script
    return logging.getLogger(name)
