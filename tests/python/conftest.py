"""Shared fixtures: the release build, the exported bundled FMUs, log capture.

The FMUs under test are the real exported files `target/fmu/<name>.fmu` (one per
`fmu/<name>/scene.toml`; their FMI 3.0 twins `target/fmu3/<name>.fmu`, fixture `fmus3`). `./run_tests.sh` builds and exports them before pytest runs; when
pytest is run on its own, the session fixture builds (the command line, and the library the
FMUs ship with, for linux64 and win64, by `scripts/build_fmu_library.sh`) and (re-)exports
whatever is missing or older than the libraries or the scene.
"""

import ctypes
import os
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest
from fmpy import calloc, free, read_model_description
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

ROOT = Path(__file__).resolve().parents[2]
TARGET = ROOT / "target" / "release"
BINARY = TARGET / "contact-fmu"
LIBRARY = TARGET / "libcontact_fmu.so"
# The library packed into the FMUs (cargo profile `dist`, built by scripts/build_fmu_library.sh).
DIST_LIBRARY = ROOT / "target" / "x86_64-unknown-linux-gnu" / "dist" / "libcontact_fmu.so"
DIST_DLL = ROOT / "target" / "x86_64-pc-windows-gnu" / "dist" / "contact_fmu.dll"
FMU_DIR = ROOT / "target" / "fmu"
FMU3_DIR = ROOT / "target" / "fmu3"
SCENES = sorted(p.parent.name for p in (ROOT / "fmu").glob("*/scene.toml"))


def scene_path(name):
    return ROOT / "fmu" / name / "scene.toml"


def _build():
    if os.environ.get("CONTACT_FMU_SKIP_BUILD") != "1":
        subprocess.run(["cargo", "build", "--release", "--quiet"], cwd=ROOT, check=True)
        subprocess.run([str(ROOT / "scripts" / "build_fmu_library.sh")], cwd=ROOT, check=True)


def export(scene, out, fmi_version=2):
    """Exports a scene file with the CLI (an FMI 2.0 or 3.0 FMU); returns the .fmu path."""
    result = subprocess.run(
        [str(BINARY), "export", str(scene), "-o", str(out), "--fmi-version", str(fmi_version)],
        check=False,
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr
    return Path(out)


def _exported(folder, fmi_version):
    """name -> path of every bundled FMU of one FMI version, (re-)exported when missing or
    older than the libraries or the scene."""
    _build()
    paths = {}
    for name in SCENES:
        fmu = folder / f"{name}.fmu"
        libraries = [p.stat().st_mtime for p in (LIBRARY, DIST_LIBRARY, DIST_DLL) if p.exists()]
        newest_input = max(*libraries, scene_path(name).stat().st_mtime)
        if not fmu.exists() or fmu.stat().st_mtime < newest_input:
            export(scene_path(name), fmu, fmi_version)
        paths[name] = fmu
    return paths


@pytest.fixture(scope="session")
def fmus():
    """name -> path of the exported bundled FMU (FMI 2.0)."""
    return _exported(FMU_DIR, 2)


@pytest.fixture(scope="session")
def fmus3():
    """name -> path of the exported bundled FMU as FMI 3.0 (`--fmi-version 3`)."""
    return _exported(FMU3_DIR, 3)


@pytest.fixture(scope="session")
def unzipped(fmus, tmp_path_factory):
    """name -> directory holding the extracted FMU."""
    dirs = {}
    for name, fmu in fmus.items():
        d = tmp_path_factory.mktemp(f"unzipped_{name}")
        with zipfile.ZipFile(fmu) as z:
            z.extractall(d)
        dirs[name] = d
    return dirs


@pytest.fixture
def export_scene(tmp_path):
    """Exports scene text (a variant of a bundled scene) and returns (fmu path, unzip dir)."""

    def _export(text, name="variant"):
        scene = tmp_path / f"{name}.toml"
        scene.write_text(text)
        fmu = export(scene, tmp_path / f"{name}.fmu")
        d = tmp_path / f"{name}_unzipped"
        with zipfile.ZipFile(fmu) as z:
            z.extractall(d)
        return fmu, d

    return _export


# fmpy's native logger proxy keeps the Python logger of the last `addLoggerProxy` call in one
# global slot, which every instance created with fmpy's default callbacks calls too. A capture
# that the garbage collector freed would leave that slot dangling (a crash at the next message
# of any instance, e.g. an energy-drift warning), so every capture stays alive for the session.
_CAPTURES = []


class LogCapture:
    """Collects the FMU's log messages as (status, category, text).

    The logger is registered through fmpy's native proxy, which formats the printf-style
    message in C exactly as a C host would.
    """

    def __init__(self):
        self.messages = []

        def logger(env, instance_name, status, category, message):
            self.messages.append((status, category.decode() if category else None, message.decode(errors="replace")))

        self._logger = fmi2CallbackLoggerTYPE(logger)
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = self._logger
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        from fmpy.logging import addLoggerProxy

        addLoggerProxy(ctypes.byref(self.callbacks))
        _CAPTURES.append(self)

    def text(self):
        return "\n".join(m[2] for m in self.messages)

    def clear(self):
        self.messages.clear()


@pytest.fixture
def log():
    return LogCapture()


class Instance:
    """One FMU instance driven call by call through fmpy's FMU2Slave."""

    def __init__(self, unzipdir, name="instance", callbacks=None, guid=None, instantiate=True):
        self.md = read_model_description(str(unzipdir))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.slave = FMU2Slave(
            guid=guid or self.md.guid,
            unzipDirectory=str(unzipdir),
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName=name,
        )
        self.callbacks = callbacks
        self.time = 0.0
        self.freed = False
        if instantiate:
            self.slave.instantiate(callbacks=callbacks)

    def vr(self, name):
        return self.vars[name].valueReference

    def init(self, start_values=None, stop_time=None):
        self.slave.setupExperiment(startTime=0.0, stopTime=stop_time)
        self.slave.enterInitializationMode()
        for k, v in (start_values or {}).items():
            self.set(k, v)
        self.slave.exitInitializationMode()
        self.time = 0.0

    def set(self, name, value):
        v = self.vars[name]
        if v.type == "Real":
            self.slave.setReal([v.valueReference], [value])
        elif v.type in ("Integer", "Enumeration"):
            self.slave.setInteger([v.valueReference], [int(value)])
        else:
            self.slave.setBoolean([v.valueReference], [bool(value)])

    def get(self, name):
        """One variable's value as a Python number (Integer and Enumeration as int, Boolean
        as bool)."""
        v = self.vars[name]
        if v.type == "Real":
            return self.slave.getReal([v.valueReference])[0]
        if v.type in ("Integer", "Enumeration"):
            return self.slave.getInteger([v.valueReference])[0]
        return bool(self.slave.getBoolean([v.valueReference])[0])

    def outputs(self):
        """Every output as Python numbers: Reals, then Integers, then Booleans. Reals are
        given as `float.hex` strings, so that comparing two lists compares bits (NaN equals
        NaN, -0.0 differs from 0.0)."""
        out = [v for v in self.md.modelVariables if v.causality == "output"]
        reals = [v.valueReference for v in out if v.type == "Real"]
        ints = [v.valueReference for v in out if v.type in ("Integer", "Enumeration")]
        bools = [v.valueReference for v in out if v.type == "Boolean"]
        return (
            [float(x).hex() for x in self.slave.getReal(reals)]
            + list(self.slave.getInteger(ints))
            + [bool(b) for b in self.slave.getBoolean(bools)]
        )

    def step(self, h):
        self.slave.doStep(currentCommunicationPoint=self.time, communicationStepSize=h)
        self.time += h

    def free(self):
        if not self.freed:
            self.freed = True
            self.slave.freeInstance()


@pytest.fixture
def make_instance():
    """Factory of instances that are freed at the end of the test."""
    made = []

    def _make(*args, **kwargs):
        inst = Instance(*args, **kwargs)
        made.append(inst)
        return inst

    yield _make
    for inst in made:
        inst.free()


def refused_at_exit_initialization(inst, variable, value):
    """Sets `variable` to `value` in initialization mode; exiting it must fail. Returns the
    raised exception."""
    from fmpy.fmi1 import FMICallException

    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    inst.set(variable, value)
    with pytest.raises(FMICallException) as raised:
        inst.slave.exitInitializationMode()
    return raised.value


def copy_tree_with_space(src, tmp_path):
    dst = tmp_path / "dir with space" / "my fmu"
    shutil.copytree(src, dst)
    return dst
