"""The project's own FMI host (tests/host/fmi_host.c) for both platform libraries of an FMU:
built natively for linux64 with gcc and for win64 with MinGW-w64, the latter run under wine, so
that both libraries run the same script of calls and their transcripts can be compared.

`Hosts.run(platform, library, script)` returns the transcript (standard output) of one script;
scripts name files through `{path:...}` placeholders that become each platform's own paths
(`Z:\\...` under wine, where the drive Z: is the Linux root).
"""

import os
import random
import re
import shutil
import subprocess
import warnings
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HOST_SOURCES = ROOT / "tests" / "host"
MINGW = "x86_64-w64-mingw32-gcc"
# Set by ./run_tests.sh, which installs wine and MinGW-w64: the Windows tests then fail, instead
# of being skipped, when either is missing.
REQUIRED = os.environ.get("CONTACT_FMU_WINDOWS_TESTS") == "required"


def find_wine():
    """The 64-bit wine loader: $WINE64, Debian's /usr/lib/wine/wine64, or wine64 on PATH."""
    for candidate in (os.environ.get("WINE64"), "/usr/lib/wine/wine64", shutil.which("wine64")):
        if candidate and Path(candidate).is_file() and os.access(candidate, os.X_OK):
            return candidate
    return None


def wine_prefix():
    return Path(os.environ.get("WINEPREFIX") or Path.home() / ".wine")


def windows_path(path):
    """A Linux path as a Windows process under wine sees it (drive Z: is /)."""
    path = Path(path).resolve()
    drive_c = (wine_prefix() / "drive_c").resolve()
    if drive_c in path.parents or path == drive_c:
        return "C:\\" + str(path.relative_to(drive_c)).replace("/", "\\")
    return "Z:" + str(path).replace("/", "\\")


# The exit status of a win64 run that failed in wine itself (seen once in CI: the win64 host
# exited with 1 and wrote nothing to stderr; the same tests passed in 23 loops of 25 here,
# the other two stopped at setup).
WINE_FAILURE = 1


class HostError(RuntimeError):
    pass


class Hosts:
    """The two builds of tests/host/fmi_host.c, in `directory`."""

    def __init__(self, directory):
        self.dir = Path(directory)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.wine = find_wine()
        self.linux = self.dir / "fmi_host"
        self.windows = self.dir / "fmi_host.exe"
        subprocess.run(
            ["gcc", "-O2", "-std=c99", "-Wall", "-o", str(self.linux), str(HOST_SOURCES / "fmi_host.c"), "-ldl"],
            check=True,
        )
        subprocess.run(
            [MINGW, "-O2", "-s", "-std=c99", "-Wall", "-o", str(self.windows), str(HOST_SOURCES / "fmi_host.c")],
            check=True,
        )
        # wine 8 lacks bcryptprimitives.dll's ProcessPrng (Windows 10 has it); the loader looks
        # beside the .exe first
        subprocess.run(
            [MINGW, "-O2", "-s", "-shared", "-o", str(self.dir / "bcryptprimitives.dll"),
             str(HOST_SOURCES / "bcryptprimitives.c"), "-ladvapi32"],
            check=True,
        )
        self.env = {**os.environ, "WINEDEBUG": "-all"}
        # the first start creates the wine prefix (about 30 s); the host without arguments
        # prints its usage and exits with 2
        subprocess.run([self.wine, str(self.windows)], env=self.env, capture_output=True, timeout=600)

    def run(self, platform, library, script, workdir, timeout=600):
        """Runs `script` (text with `{path:NAME}` placeholders for files in `workdir`) with the
        host of `platform` ("linux64" or "win64") on `library`; returns standard output."""
        workdir = Path(workdir)
        to_path = windows_path if platform == "win64" else (lambda p: str(Path(p).resolve()))
        # quoted: a path may have spaces (the host takes "..." as one token)
        text = re.sub(r"(@?)\{path:([^}]*)\}", lambda m: f'"{m.group(1)}{to_path(workdir / m.group(2))}"', script)
        script_file = workdir / f"script.{platform}.txt"
        script_file.write_text(text)
        if platform == "win64":
            cmd = [self.wine, str(self.windows), windows_path(library), windows_path(script_file)]
        else:
            cmd = [str(self.linux), str(library), str(script_file)]
        result = subprocess.run(cmd, capture_output=True, text=True, env=self.env, timeout=timeout, cwd=workdir)
        if platform == "win64" and result.returncode == WINE_FAILURE:
            # Exit status 1 is not the host's: it exits with 0 or 2, and under wine a page fault
            # exits with 5 (and wine's message on stderr), a C abort() with 3 (measured with
            # a MinGW program under this wine). One retry, with the failed attempt kept beside
            # the transcript and reported as a warning.
            (workdir / f"failed.{platform}.txt").write_text(
                f"exit status {result.returncode}\n== stdout\n{result.stdout}\n== stderr\n{result.stderr}")
            warnings.warn(f"wine exited with {result.returncode} after {len(result.stdout.splitlines())} "
                          f"transcript lines ({workdir / f'failed.{platform}.txt'}); run again once")
            result = subprocess.run(cmd, capture_output=True, text=True, env=self.env, timeout=timeout, cwd=workdir)
        (workdir / f"stderr.{platform}.txt").write_text(result.stderr)
        (workdir / f"transcript.{platform}.txt").write_text(result.stdout)
        if result.returncode != 0:
            lines = result.stdout.splitlines()
            raise HostError(
                f"{platform} host exited with {result.returncode} after {len(lines)} transcript lines; "
                f"the last ones:\n" + "\n".join(lines[-10:]) + f"\nstderr:\n{result.stderr[-3000:]}")
        return result.stdout


class Unpacked:
    """An FMU unzipped into a folder: its GUID, default experiment, outputs and libraries."""

    def __init__(self, fmu, directory):
        from fmpy import read_model_description

        self.dir = Path(directory)
        with zipfile.ZipFile(fmu) as z:
            z.extractall(self.dir)
        md = read_model_description(str(self.dir))
        self.md = md
        self.guid = md.guid
        self.identifier = md.coSimulation.modelIdentifier
        self.stop = float(md.defaultExperiment.stopTime)
        self.step = float(md.defaultExperiment.stepSize)
        self.outputs = [v for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
        self.reals = [v for v in md.modelVariables if v.type == "Real"]
        self.by_causality = {}
        for v in md.modelVariables:
            self.by_causality.setdefault((v.causality, v.type), []).append(v)

    def library(self, platform):
        ext = "dll" if platform.startswith("win") else "so"
        return self.dir / "binaries" / platform / f"{self.identifier}.{ext}"

    @property
    def resources(self):
        return self.dir / "resources"


def parse_points(transcript):
    """{point index: (status, [floats])} of the `point` lines of a transcript."""
    points = {}
    for line in transcript.splitlines():
        if line.startswith("point "):
            parts = line.split()
            points[int(parts[1])] = (int(parts[2]), [float.fromhex(x) for x in parts[3:]])
    return points


def statuses(transcript):
    """The transcript without the values read (command and status only): what must agree
    exactly between the platforms whatever their rounding."""
    out = []
    for line in transcript.splitlines():
        parts = line.split()
        if parts and parts[0] in ("get_real", "point", "status"):
            out.append(" ".join(parts[:2] if parts[0] != "point" else parts[:3]))
        elif parts and parts[0] == "serialize":
            out.append(" ".join(parts[:2]))
        else:
            out.append(line)
    return out


# --------------------------------------------------------------------------------------
# Bad input, in the fuzzer's categories (scripts/fuzz_fmi.py): illegal call sequences, NULL and
# garbage handles and pointers, damaged and foreign states, odd values and step sizes.
# --------------------------------------------------------------------------------------

ODD_REALS = ["nan", "inf", "-inf", "1e308", "-1e308", "0", "-0", "5e-324", "1e300", "-1"]
ODD_STEPS = ["0", "-1e-3", "nan", "inf", "1e300", "5e-324"]
GARBAGE = ["1", "8", "1000", "DEADBEEF", "7FFFFFFFFFFFFFF8"]


def bad_input_script(unpacked, seed, cases=12):
    """A script of `cases` independent cases drawn from `seed`; each ends by freeing what it
    made. Files: `{path:state.bin}` (a good state) and `{path:bad.bin}` (the test writes
    damaged copies of it before the run: see `damaged_states`)."""
    rng = random.Random(seed)
    guid = unpacked.guid
    params = [v.valueReference for v in unpacked.by_causality.get(("parameter", "Real"), [])]
    outputs = [v.valueReference for v in unpacked.outputs]
    n_vars = len(unpacked.md.modelVariables)
    lines = []

    def fresh(slot=0, logger="logger"):
        lines.extend([
            f"instantiate {slot} case {guid} @{{path:resources}} {logger} 0",
            f"setup {slot} 0 0 0 0 1 {unpacked.stop!r}",
        ])

    def ready(slot=0):
        fresh(slot)
        lines.extend([f"enter {slot}", f"exit {slot}"])

    def read(slot=0):
        picks = rng.sample(outputs, min(3, len(outputs)))
        lines.append(f"get_real {slot} " + " ".join(map(str, picks)))

    kinds = ["sequence", "null", "garbage", "damaged", "values", "steps", "foreign"]
    for _ in range(cases):
        kind = rng.choice(kinds)
        lines.append(f"echo case {kind}")
        if kind == "sequence":
            fresh()
            calls = ["enter 0", "exit 0", "dostep 0 0 0.001 1", "terminate 0", "reset 0",
                     "setup 0 0 0 0 0 1", "get_state 0 0", "set_state 0 0", "cancel 0", "status 0 0"]
            for _ in range(rng.randint(3, 8)):
                lines.append(rng.choice(calls))
                read()
            lines.append("free_state 0 0")
        elif kind == "null":
            lines.append(rng.choice([
                "instantiate 0 NULL NULL NULL logger 0",
                f"instantiate 0 case NULL @{{path:resources}} logger 0",
                f"instantiate 0 case {guid} NULL logger 0",
                f"instantiate 0 case {guid} @{{path:resources}} null 0",
                f'instantiate 0 "" {guid} @{{path:resources}} logger 0',
                f"instantiate 0 case {{00000000-0000-0000-0000-000000000000}} @{{path:resources}} logger 0",
                f"instantiate 0 case {guid} file:///nonexistent/resources logger 0",
            ]))
            ready(1)
            lines.append(f"get_real_null 1 {rng.choice([0, 1, 3])}")
            lines.append("debug 1 1 2 NULL logEvents")
            lines.append("free 0")
            lines.append("free 1")
        elif kind == "garbage":
            g = rng.choice(GARBAGE)
            lines.append(f"garbage 2 {g}")
            for call in rng.sample(["enter 2", "exit 2", "dostep 2 0 0.001 1", "terminate 2", "reset 2",
                                    "get_real 2 0", "set_real 2 0 1", "get_state 2 0", "status 2 0", "free 2"], 4):
                lines.append(call)
            ready()
            lines.append(f"garbage_state 3 {rng.choice(GARBAGE)}")
            lines.append("set_state 0 3")
            lines.append("free_state 0 3")
            read()
        elif kind == "damaged":
            ready()
            lines.append(f"dostep 0 0 {unpacked.step!r} 1")
            lines.append(f"deserialize 0 {{path:bad{rng.randrange(8)}.bin}} 4")
            lines.append("set_state 0 4")
            read()
            lines.append(f"dostep 0 {unpacked.step!r} {unpacked.step!r} 1")
            read()
        elif kind == "values":
            fresh()
            lines.append("enter 0")
            for _ in range(rng.randint(1, 3)):
                vr = rng.choice(params + [n_vars, n_vars + 7, 4294967295]) if params else n_vars
                lines.append(f"set_real 0 {vr} {rng.choice(ODD_REALS)}")
            lines.append(f"set_integer 0 {rng.randrange(n_vars + 3)} {rng.choice([-1, 0, 7, 2147483647])}")
            lines.append("exit 0")
            read()
            lines.append(f"dostep 0 0 {unpacked.step!r} 1")
            read()
        elif kind == "steps":
            ready()
            lines.append(f"dostep 0 {rng.choice(['0', '1', '-1', 'nan'])} {rng.choice(ODD_STEPS)} 1")
            read()
            lines.append(f"dostep 0 0 {unpacked.step!r} 1")
            read()
        elif kind == "foreign":
            ready()
            lines.append("deserialize 0 {path:foreign.bin} 5")
            lines.append("set_state 0 5")
            read()
        lines.append("free 0")
        lines.append("free_state 0 0")
    return "\n".join(lines) + "\n"


def damaged_states(good, workdir, seed):
    """Writes bad0.bin ... bad7.bin from the serialized state `good` (bytes): flipped bytes in
    the header, the body and the checksum, truncated, extended, emptied."""
    rng = random.Random(seed)
    variants = []
    for where in (0, 9, len(good) // 2, len(good) - 1):
        b = bytearray(good)
        b[where] ^= 1 << rng.randrange(8)
        variants.append(bytes(b))
    variants.append(good[: len(good) // 2])
    variants.append(good + b"\0" * 8)
    variants.append(b"")
    b = bytearray(good)
    for _ in range(16):
        b[rng.randrange(len(b))] = rng.randrange(256)
    variants.append(bytes(b))
    for i, v in enumerate(variants):
        (Path(workdir) / f"bad{i}.bin").write_bytes(v)
