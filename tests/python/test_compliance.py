"""The FMI community's FMU Compliance Checker (a second, independent FMI host) on every bundled
FMU: it checks the model description and the calling sequence and simulates the default
experiment. Zero warnings and zero errors, from the FMU and from the checker, are required.

The checker binary is named by the environment variable FMU_CHECK; without it the test looks
where the test machines keep it (see docs/fmi.md, "Tests") and skips, saying so, only where
there is none.
"""

import os
import re
import subprocess
from pathlib import Path

import pytest

from conftest import ROOT, SCENES

CHECKER = Path(os.environ.get("FMU_CHECK") or ROOT.parent / "shared" / "tools" / "fmuCheck.linux64")


def summary(log):
    """(FMU warnings and errors, checker warnings, checker errors) from the closing lines."""
    fmu = re.findall(r"FMU reported:\s*(\d+) warning\(s\) and error\(s\)", log)
    checker = re.findall(r"Checker reported:\s*(\d+) Warning\(s\)\s*(\d+) Error\(s\)", log)
    assert fmu and checker, "the checker printed no summary:\n" + log[-3000:]
    return int(fmu[-1]), int(checker[-1][0]), int(checker[-1][1])


@pytest.mark.parametrize("name", SCENES)
def test_compliance_checker_reports_no_warning_and_no_error(fmus, name, tmp_path):
    if not CHECKER.is_file():
        pytest.skip(f"the FMU Compliance Checker is not installed at {CHECKER}")
    log_file = tmp_path / "log.txt"
    result = subprocess.run(
        [str(CHECKER), "-e", str(log_file), "-o", str(tmp_path / "out.csv"), str(fmus[name])],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=600,
    )
    log = log_file.read_text(errors="replace") if log_file.exists() else result.stderr
    problems = "\n".join(line for line in log.splitlines() if re.match(r"\[(WARNING|ERROR|FATAL)\]", line))
    assert result.returncode == 0, f"exit code {result.returncode}\n{problems or log[-3000:]}"
    assert summary(log) == (0, 0, 0), problems
    # The default experiment was simulated: a result row per communication point.
    rows = (tmp_path / "out.csv").read_text().splitlines()
    assert len(rows) > 10
