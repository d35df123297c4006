"""The win64 library of the FMI 3.0 FMUs under wine: the project's minimal FMI 3.0 host
(tests/host/fmi3_host.c), built for linux64 and win64, runs each bundled FMU's default
experiment with early returns allowed on both libraries; the transcripts (every early return's
time, every Float64 output at every communication point, as hexadecimal floats) must be equal,
bit for bit (docs/fmi3.md)."""

import subprocess
import zipfile

import pytest
from fmpy import read_model_description

from conftest import SCENES
from test_windows import hosts  # noqa: F401  (the fixture: the FMI 2.0 hosts, wine and its prefix)
from windows_host import HOST_SOURCES, MINGW, windows_path


@pytest.fixture(scope="session")
def hosts3(hosts):  # noqa: F811
    """(linux64 build, win64 build) of fmi3_host.c, beside the FMI 2.0 hosts (and the stand-in
    bcryptprimitives.dll that wine lacks)."""
    linux, windows = hosts.dir / "fmi3_host", hosts.dir / "fmi3_host.exe"
    source = str(HOST_SOURCES / "fmi3_host.c")
    subprocess.run(["gcc", "-O2", "-std=c99", "-Wall", "-o", str(linux), source, "-ldl"], check=True)
    subprocess.run([MINGW, "-O2", "-s", "-std=c99", "-Wall", "-o", str(windows), source], check=True)
    return hosts, linux, windows


@pytest.mark.parametrize("name", SCENES)
def test_win64_runs_like_linux64_with_early_returns(hosts3, fmus3, name, tmp_path):
    hosts, linux, windows = hosts3
    with zipfile.ZipFile(fmus3[name]) as z:
        z.extractall(tmp_path)
    md = read_model_description(str(tmp_path))
    ident = md.coSimulation.modelIdentifier
    vrs = ",".join(str(v.valueReference) for v in md.modelVariables if v.causality == "output" and v.type == "Float64")
    experiment = [md.guid, md.defaultExperiment.stopTime, md.defaultExperiment.stepSize, "1", vrs]
    resources = tmp_path / "resources"
    runs = {}
    for platform, cmd in [
        ("x86_64-linux", [str(linux), str(tmp_path / "binaries/x86_64-linux" / f"{ident}.so"), f"{resources}/"]),
        ("x86_64-windows", [hosts.wine, str(windows), windows_path(tmp_path / "binaries/x86_64-windows" / f"{ident}.dll"),
                            windows_path(resources) + "\\"]),
    ]:
        result = subprocess.run(cmd + experiment, capture_output=True, text=True, env=hosts.env, timeout=600)
        assert result.returncode == 0, (platform, result.stdout[-2000:], result.stderr[-2000:])
        runs[platform] = result.stdout
    linux_lines, windows_lines = runs["x86_64-linux"].splitlines(), runs["x86_64-windows"].splitlines()
    assert linux_lines[-1] == "done"
    points = sum(line.startswith("point ") for line in linux_lines)
    assert points == round(float(md.defaultExperiment.stopTime) / float(md.defaultExperiment.stepSize))
    first = next((k for k, (a, b) in enumerate(zip(linux_lines, windows_lines)) if a != b), None)
    assert first is None and len(linux_lines) == len(windows_lines), (first, len(linux_lines), len(windows_lines))
    if name in ("bouncing_ball", "two_spheres", "pile_of_balls"):
        assert any(line.startswith("early ") for line in linux_lines)
