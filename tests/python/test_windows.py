"""The Windows library of every bundled FMU (binaries/win64/<name>.dll) against its Linux
library (binaries/linux64/<name>.so), run by the project's own FMI host (tests/host/fmi_host.c:
gcc for Linux, MinGW-w64 for Windows, the latter under wine), and by the FMU Compliance Checker
built for Windows.

- the default experiment: every Real output at every communication point, bit-identical or
  within 1e-9 of the output's range over the run (the table of the comparison is written to
  target/test-output/win64_comparison.csv and shown in docs/fmi.md);
- FMU states on win64: saved mid-run, serialized, restored into a new instance, the rest of the
  run bit for bit; a state serialized by the linux64 library restores on win64 (the format is the
  same little-endian bytes on both) and continues like the linux64 run;
- resource URIs as a Windows process makes them: file:///Z:/... and file:///C:/... (a copy of
  the FMU on wine's drive C:);
- bad input (cases in the fuzzer's categories): the same statuses, call by call, on both.

Without wine or MinGW-w64 the tests are skipped, saying so; ./run_tests.sh installs both and
sets CONTACT_FMU_WINDOWS_TESTS=required, under which they fail instead.
"""

import csv
import math
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from conftest import ROOT, SCENES
from windows_host import (
    MINGW,
    REQUIRED,
    Hosts,
    Unpacked,
    bad_input_script,
    damaged_states,
    find_wine,
    parse_points,
    statuses,
    wine_prefix,
)

RELATIVE_LIMIT = 1e-9
REPORT = ROOT / "target" / "test-output" / "win64_comparison.csv"
CHECKER = Path(os.environ.get("FMU_CHECK_WIN64") or ROOT.parent / "shared" / "tools" / "fmuCheck.win64.exe")


def unavailable(what):
    if REQUIRED:
        pytest.fail(f"{what} (CONTACT_FMU_WINDOWS_TESTS=required)")
    pytest.skip(what)


@pytest.fixture(scope="session")
def hosts(tmp_path_factory):
    if find_wine() is None:
        unavailable("wine (64-bit) is not installed (Debian: apt-get install wine64)")
    if shutil.which(MINGW) is None:
        unavailable(f"{MINGW} is not installed (Debian: apt-get install gcc-mingw-w64-x86-64)")
    return Hosts(tmp_path_factory.mktemp("hosts"))


@pytest.fixture(scope="session")
def unpacked(fmus, tmp_path_factory):
    return {name: Unpacked(fmu, tmp_path_factory.mktemp(f"win_{name}")) for name, fmu in fmus.items()}


def experiment_script(u, resources="{path:resources}", state_in=None):
    """The default experiment, with the state saved at the middle point and a second instance
    that restores it (from `state_in` when given, else from the state this run saved) and runs
    the rest again."""
    n = round(u.stop / u.step)
    mid = n // 2
    vrs = " ".join(str(v.valueReference) for v in u.outputs)
    restore = state_in or "{path:state.bin}"
    return f"""
instantiate 0 run {u.guid} @{resources} logger 0
setup 0 0 0 0 1 {u.stop!r}
enter 0
exit 0
run 0 {u.step!r} 0 {mid} {vrs}
get_state 0 0
serialize 0 0 {{path:state.bin}}
echo rest
run 0 {u.step!r} {mid} {n} {vrs}
terminate 0
free 0
echo restored
instantiate 1 restored {u.guid} @{resources} logger 0
setup 1 0 0 0 1 {u.stop!r}
enter 1
exit 1
deserialize 1 {restore} 1
set_state 1 1
run 1 {u.step!r} {mid} {n} {vrs}
free_state 1 1
free 1
"""


def sections(transcript):
    """(first half and rest, restored rest) of an experiment transcript."""
    first, restored = transcript.split("echo restored", 1)
    return parse_points(first), parse_points(restored)


def compare(u, a, b):
    """(bit-identical, largest |difference| / range over the outputs, the worst output) of two
    runs' points."""
    assert sorted(a) == sorted(b), "the runs stopped at different points"
    identical, worst, worst_name = True, 0.0, ""
    for j, var in enumerate(u.outputs):
        xs = [a[k][1][j] for k in sorted(a)]
        ys = [b[k][1][j] for k in sorted(b)]
        if any(x.hex() != y.hex() for x, y in zip(xs, ys)):
            identical = False
        finite = [x for x in xs if math.isfinite(x)]
        span = (max(finite) - min(finite)) if finite else 0.0
        scale = span if span > 0 else max(max((abs(x) for x in finite), default=0.0), 1e-300)
        for x, y in zip(xs, ys):
            if math.isnan(x) and math.isnan(y):
                continue
            d = abs(x - y) / scale if x != y else 0.0
            if d > worst:
                worst, worst_name = d, var.name
    return identical, worst, worst_name


@pytest.fixture(scope="session")
def runs(hosts, unpacked):
    """name -> {platform: transcript} of the default experiment."""
    out = {}
    for name, u in unpacked.items():
        out[name] = {}
        for platform in ("linux64", "win64"):
            work = u.dir / f"work_{platform}"
            work.mkdir(exist_ok=True)
            (work / "resources").exists() or shutil.copytree(u.resources, work / "resources")
            out[name][platform] = (hosts.run(platform, u.library(platform), experiment_script(u), work), work)
    return out


def test_every_fmu_carries_linux64_and_win64(fmus):
    import zipfile

    for name, fmu in fmus.items():
        with zipfile.ZipFile(fmu) as z:
            names = set(z.namelist())
        assert f"binaries/linux64/{name}.so" in names, name
        assert f"binaries/win64/{name}.dll" in names, name


@pytest.mark.parametrize("name", SCENES)
def test_win64_runs_the_default_experiment_like_linux64(runs, unpacked, name):
    u = unpacked[name]
    linux, win = runs[name]["linux64"][0], runs[name]["win64"][0]
    assert statuses(linux) == statuses(win)
    (a, _), (b, _) = sections(linux), sections(win)
    n = round(u.stop / u.step)
    assert sorted(a) == list(range(n + 1)) and all(s == 0 for s, _ in a.values())
    identical, worst, worst_name = compare(u, a, b)
    REPORT.parent.mkdir(parents=True, exist_ok=True)
    rows = []
    if REPORT.exists():
        rows = [r for r in csv.DictReader(REPORT.open()) if r["fmu"] != name]
    rows.append({
        "fmu": name,
        "points": len(a),
        "outputs": len(u.outputs),
        "bit_identical": "yes" if identical else "no",
        "largest_difference_over_range": f"{worst:.3g}",
        "worst_output": worst_name,
    })
    rows.sort(key=lambda r: r["fmu"])
    with REPORT.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    assert worst <= RELATIVE_LIMIT, f"{worst_name}: {worst:.3g} of its range"


@pytest.mark.parametrize("name", SCENES)
def test_win64_state_restores_bit_for_bit(runs, unpacked, name):
    """Saved mid-run, serialized, deserialized into a second instance: the rest of the run is
    the first instance's, bit for bit, on win64 (and on linux64)."""
    for platform in ("linux64", "win64"):
        transcript = runs[name][platform][0]
        first, restored = transcript.split("echo restored", 1)
        rest = parse_points(first.split("echo rest", 1)[1])
        again = parse_points(restored)
        assert rest and sorted(rest) == sorted(again), platform
        assert {k: [x.hex() for x in v[1]] for k, v in rest.items()} == {
            k: [x.hex() for x in v[1]] for k, v in again.items()
        }, platform
        assert "deserialize 0" in restored and "set_state 0" in restored, platform


@pytest.mark.parametrize("name", SCENES)
def test_a_linux64_state_restores_on_win64(hosts, runs, unpacked, name):
    """The serialized state is the same little-endian bytes on both platforms: a state saved by
    the linux64 library is accepted by the win64 one and continues like the linux64 run."""
    u = unpacked[name]
    linux_work = runs[name]["linux64"][1]
    work = u.dir / "work_cross"
    work.mkdir(exist_ok=True)
    (work / "resources").exists() or shutil.copytree(u.resources, work / "resources")
    shutil.copy(linux_work / "state.bin", work / "linux_state.bin")
    transcript = hosts.run("win64", u.library("win64"), experiment_script(u, state_in="{path:linux_state.bin}"), work)
    _, restored = transcript.split("echo restored", 1)
    assert "deserialize 0" in restored and "set_state 0" in restored
    linux_rest = parse_points(runs[name]["linux64"][0].split("echo restored", 1)[0].split("echo rest", 1)[1])
    _, worst, worst_name = compare(u, linux_rest, parse_points(restored))
    assert worst <= RELATIVE_LIMIT, f"{worst_name}: {worst:.3g} of its range"


def test_resource_uris_of_drive_z_and_drive_c(hosts, unpacked, tmp_path):
    """A Windows host passes file:///<drive>:/... URIs: Z: (wine's view of /) and C: (a copy of
    the FMU in wine's drive_c, a path with a space)."""
    u = unpacked["bouncing_ball"]
    drive_c = wine_prefix() / "drive_c" / "contact fmu test"
    shutil.rmtree(drive_c, ignore_errors=True)
    shutil.copytree(u.dir, drive_c / "bouncing ball", ignore=shutil.ignore_patterns("work_*"))
    try:
        script = (
            f"instantiate 0 z {u.guid} @{{path:resources}} logger 0\n"
            f"setup 0 0 0 0 1 1\nenter 0\nexit 0\nrun 0 0.1 0 10 {u.outputs[0].valueReference}\nfree 0\n"
        )
        work_z = tmp_path / "z"
        work_z.mkdir()
        shutil.copytree(u.resources, work_z / "resources")
        z = hosts.run("win64", u.library("win64"), script, work_z)
        c = hosts.run("win64", drive_c / "bouncing ball" / "binaries" / "win64" / "bouncing_ball.dll",
                      script, drive_c / "bouncing ball")
        assert "instantiate handle" in z and "instantiate handle" in c
        uris = (work_z / "stderr.win64.txt").read_text() + (drive_c / "bouncing ball" / "stderr.win64.txt").read_text()
        assert "resource URI file:///Z:/" in uris
        assert "resource URI file:///C:/contact%20fmu%20test/bouncing%20ball/resources" in uris
        assert parse_points(z) == parse_points(c)
    finally:
        shutil.rmtree(drive_c, ignore_errors=True)


@pytest.mark.parametrize("name", SCENES)
def test_bad_input_is_refused_on_win64_as_on_linux64(hosts, runs, unpacked, name):
    """Cases of the fuzzer's kinds (illegal call sequences, NULL and garbage handles and
    pointers, damaged and foreign states, odd values and steps): every call returns the same
    status on both platforms, the host survives, and what is read agrees."""
    u = unpacked[name]
    foreign_name = next(n for n in SCENES if n != name)
    results = {}
    for platform in ("linux64", "win64"):
        work = u.dir / f"bad_{platform}"
        work.mkdir(exist_ok=True)
        (work / "resources").exists() or shutil.copytree(u.resources, work / "resources")
        good = (runs[name][platform][1] / "state.bin").read_bytes()
        damaged_states(good, work, seed=len(name))
        shutil.copy(runs[foreign_name][platform][1] / "state.bin", work / "foreign.bin")
        script = "".join(bad_input_script(u, seed=1000 * k + len(name)) for k in range(4))
        results[platform] = hosts.run(platform, u.library(platform), script, work)
    linux, win = statuses(results["linux64"]), statuses(results["win64"])
    assert len(linux) > 100
    assert linux == win
    # the refusals happened: errors were returned and logged
    assert re.search(r"^\w+ 3\b", results["win64"], re.MULTILINE)
    assert "log 3 logStatusError" in results["win64"]


@pytest.mark.parametrize("name", SCENES)
def test_compliance_checker_for_windows(hosts, fmus, name, tmp_path):
    """The FMU Compliance Checker built for Windows loads binaries/win64 of the FMU under wine:
    0 warnings and 0 errors."""
    if not CHECKER.is_file():
        pytest.skip(f"the Windows Compliance Checker is not installed at {CHECKER}")
    from test_compliance import summary

    exe_dir = tmp_path / "checker"
    exe_dir.mkdir()
    shutil.copy(CHECKER, exe_dir / "fmuCheck.win64.exe")
    shutil.copy(hosts.dir / "bcryptprimitives.dll", exe_dir / "bcryptprimitives.dll")
    log_file = tmp_path / "log.txt"
    result = subprocess.run(
        [hosts.wine, str(exe_dir / "fmuCheck.win64.exe"), "-e", str(log_file), "-o", str(tmp_path / "out.csv"),
         str(fmus[name])],
        capture_output=True, text=True, cwd=tmp_path, timeout=900, env=hosts.env,
    )
    log = log_file.read_text(errors="replace") if log_file.exists() else result.stderr
    problems = "\n".join(line for line in log.splitlines() if re.match(r"\[(WARNING|ERROR|FATAL)\]", line))
    assert result.returncode == 0, f"exit code {result.returncode}\n{problems or log[-3000:]}"
    assert summary(log) == (0, 0, 0), problems
    assert len((tmp_path / "out.csv").read_text().splitlines()) > 10
