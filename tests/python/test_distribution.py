"""What is shipped: each bundled FMU carries a linux64 and a win64 library and is at most 5 MB;
the linux64 library is the stripped release build that needs glibc 2.17 at most (read with
`objdump -T`, as a user checking portability would) and it loads and runs in fmpy; the win64
library exports the 34 FMI 2.0 and 75 FMI 3.0 functions and nothing else and imports only DLLs of
Windows 10
(read with MinGW's objdump); neither takes a transcendental function from the platform's C
library (their results would differ in the last bit between the platforms).
"""

import os
import re
import shutil
import subprocess
import zipfile

import fmpy
import numpy as np
import pytest

from conftest import BINARY, LIBRARY, ROOT, SCENES, scene_path

MAX_FMU_BYTES = 5_000_000
GLIBC_FLOOR = (2, 17)


def packed_library(fmu, name, tmp_path, platform="linux64"):
    """Extracts binaries/<platform>/<name>.<so|dll> of the FMU and returns its path."""
    entry = f"binaries/{platform}/{name}.{'dll' if platform == 'win64' else 'so'}"
    with zipfile.ZipFile(fmu) as z:
        assert entry in z.namelist(), z.namelist()
        z.extract(entry, tmp_path)
    return tmp_path / entry


def glibc_versions(symbols):
    """The (major, minor) of every GLIBC_x.y[.z] symbol version in `objdump -T` output."""
    return {(int(a), int(b)) for a, b in re.findall(r"\bGLIBC_(\d+)\.(\d+)(?:\.\d+)?\b", symbols)}


def objdump(*args):
    tool = shutil.which("objdump")
    if tool is None:
        pytest.skip("objdump (binutils) is not installed")
    result = subprocess.run([tool, *args], capture_output=True, text=True, check=True)
    return result.stdout


@pytest.mark.parametrize("name", SCENES)
def test_fmu_is_at_most_5_mb(fmus, name):
    size = fmus[name].stat().st_size
    assert size <= MAX_FMU_BYTES, f"{fmus[name]}: {size} bytes"


@pytest.mark.parametrize("name", SCENES)
def test_packed_library_needs_glibc_2_17_at_most(fmus, name, tmp_path):
    library = packed_library(fmus[name], name, tmp_path)
    symbols = objdump("-T", str(library))
    versions = glibc_versions(symbols)
    assert versions, "no GLIBC symbol version found: is this a glibc shared library?"
    too_new = sorted(v for v in versions if v > GLIBC_FLOOR)
    lines = [line for line in symbols.splitlines() if any(f"GLIBC_{a}.{b}" in line for a, b in too_new)]
    assert not too_new, "symbols newer than glibc 2.17:\n" + "\n".join(lines[:20])


@pytest.mark.parametrize("name", SCENES)
def test_packed_library_is_stripped_without_debug_information(fmus, name, tmp_path):
    library = packed_library(fmus[name], name, tmp_path)
    sections = set(re.findall(r"^\s*\d+\s+(\S+)", objdump("-h", str(library)), re.MULTILINE))
    assert ".dynsym" in sections
    assert not {".symtab", ".debug_info", ".debug_line"} & sections, sorted(sections)
    # The FMI functions are exported.
    assert re.search(r"\bfmi2DoStep\b", objdump("-T", str(library)))


CLOCK_FUNCTIONS = {"clock_gettime", "clock_getres", "clock", "gettimeofday", "time", "times", "getrusage", "clock_nanosleep"}


@pytest.mark.parametrize("name", SCENES)
def test_packed_library_calls_no_clock_function(fmus, name, tmp_path):
    """The FMU functions read no clock (the benchmarks' CPU clock is not on their path), so
    the library imports none: results cannot depend on the time of day and the library
    needs no clock API of the platform."""
    library = packed_library(fmus[name], name, tmp_path)
    imported = {m.group(1) for m in re.finditer(r"\*UND\*.*\s(\w+)$", objdump("-T", str(library)), re.MULTILINE)}
    assert imported, "no imported symbol found: is this a shared library?"
    assert not imported & CLOCK_FUNCTIONS, sorted(imported & CLOCK_FUNCTIONS)


@pytest.mark.parametrize("name", SCENES)
def test_shipped_fmu_loads_and_runs_in_fmpy(fmus, name):
    md = fmpy.read_model_description(str(fmus[name]))
    stop = min(0.1, float(md.defaultExperiment.stopTime))
    result = fmpy.simulate_fmu(str(fmus[name]), stop_time=stop, output_interval=stop / 20)
    assert result["time"][-1] == pytest.approx(stop)
    assert np.all(np.isfinite(result["energy.total"]))


def export_with_library(library, out):
    return subprocess.run(
        [str(BINARY), "export", str(scene_path("bouncing_ball")), "-o", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "CONTACT_FMU_LIBRARY": str(library)},
    )


def test_exporter_says_when_the_library_it_packs_needs_a_newer_glibc(tmp_path):
    newest = max(glibc_versions(objdump("-T", str(LIBRARY))))
    if newest <= GLIBC_FLOOR:
        pytest.skip(f"the development build of this machine needs glibc {newest[0]}.{newest[1]} only")
    result = export_with_library(LIBRARY, tmp_path / "native.fmu")
    assert result.returncode == 0, result.stderr
    assert f"needs glibc {newest[0]}.{newest[1]}" in result.stderr
    with zipfile.ZipFile(tmp_path / "native.fmu") as z:
        assert z.read("binaries/linux64/bouncing_ball.so") == LIBRARY.read_bytes()


def test_exporter_refuses_a_missing_library(tmp_path):
    result = export_with_library(tmp_path / "nothing.so", tmp_path / "none.fmu")
    assert result.returncode != 0
    assert "CONTACT_FMU_LIBRARY" in result.stderr and "no such file" in result.stderr
    assert not (tmp_path / "none.fmu").exists()


# Math functions whose results differ between C libraries in the last bit (the engine takes them
# from the libm crate, src/math.rs). sqrt and fmod are exact everywhere.
TRANSCENDENTAL = {
    "pow", "exp", "exp2", "expm1", "log", "log2", "log10", "log1p", "sin", "cos", "tan", "sincos",
    "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "hypot", "cbrt",
}
FMI2_FUNCTIONS = 34
FMI3_FUNCTIONS = 75  # every function of the FMI 3.0 headers (docs/fmi3.md)
WINDOWS_10_DLLS = {"kernel32.dll", "ntdll.dll", "msvcrt.dll", "bcryptprimitives.dll", "api-ms-win-core-synch-l1-2-0.dll"}


def pe_tables(library):
    """(exported names, {imported DLL (lower case): [names]}) of a Windows DLL, from MinGW's
    objdump -p."""
    tool = shutil.which("x86_64-w64-mingw32-objdump")
    if tool is None:
        pytest.skip("x86_64-w64-mingw32-objdump (Debian: binutils-mingw-w64-x86-64) is not installed")
    text = subprocess.run([tool, "-p", str(library)], capture_output=True, text=True, check=True).stdout
    exports = re.findall(r"^\s*\[\s*\d+\]\s+(\w+)$", text, re.MULTILINE)
    imports, current = {}, None
    for line in text.splitlines():
        m = re.match(r"\s*DLL Name: (\S+)", line)
        if m:
            current = m.group(1).lower()
            imports.setdefault(current, [])
            continue
        m = re.match(r"\s+[0-9a-f]+\s+\d+\s+(\w+)$", line)
        if m and current:
            imports[current].append(m.group(1))
    return exports, imports


@pytest.mark.parametrize("name", SCENES)
def test_win64_library_exports_fmi_and_imports_windows_10_only(fmus, name, tmp_path):
    exports, imports = pe_tables(packed_library(fmus[name], name, tmp_path, "win64"))
    fmi2 = [e for e in exports if e.startswith("fmi2")]
    fmi3 = [e for e in exports if e.startswith("fmi3")]
    assert (len(fmi2), len(fmi3), len(exports)) == (FMI2_FUNCTIONS, FMI3_FUNCTIONS, len(fmi2) + len(fmi3)), exports
    assert "fmi2DoStep" in exports and "fmi3DoStep" in exports and "fmi3InstantiateCoSimulation" in exports
    assert set(imports) <= WINDOWS_10_DLLS, sorted(set(imports) - WINDOWS_10_DLLS)
    taken = {f for names in imports.values() for f in names} & TRANSCENDENTAL
    assert not taken, sorted(taken)


@pytest.mark.parametrize("name", SCENES)
def test_linux64_library_takes_no_transcendental_function_from_libm(fmus, name, tmp_path):
    library = packed_library(fmus[name], name, tmp_path)
    imported = {m.group(1) for m in re.finditer(r"\*UND\*.*\s(\w+)$", objdump("-T", str(library)), re.MULTILINE)}
    assert imported
    assert not imported & TRANSCENDENTAL, sorted(imported & TRANSCENDENTAL)
