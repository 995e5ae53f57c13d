"""A rule script's failure reaches the console in one line; its traceback stays in the rule's log."""

import subprocess
import sys


def test_an_uncaught_error_is_one_console_line_and_a_logged_traceback(tmp_path):
    script = (
        "from rgns.logsetup import log_to_file\n"
        "log = log_to_file('logs/rule.log')\n"
        "log.info('started')\n"
        "raise ValueError('results/mc/case1/chunk_001.csv: cut short; delete it and run again')\n"
    )
    result = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True)
    assert result.returncode == 1
    assert result.stderr == (
        "ERROR (full log: logs/rule.log): ValueError: results/mc/case1/chunk_001.csv: cut short; "
        "delete it and run again\n"
    )
    logged = (tmp_path / "logs" / "rule.log").read_text()
    assert "INFO rgns: started" in logged and "Traceback (most recent call last)" in logged
