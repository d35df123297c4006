#!/usr/bin/env python3
"""FMI call-sequence fuzzer for the exported FMUs: FMI 2.0 (target/fmu/*.fmu) and, with
FMI 3.0 (target/fmu3/*.fmu) through scripts/fuzz_fmi3.py, which adds its sequences to this one.

Each sequence is a random series of calls over all 34 functions of FMI 2.0 Co-Simulation,
drawn from one seed: instantiation with good and bad arguments, setup with odd tolerances and
times, Get/Set of every type with valid, wrong-type and unknown value references and values
such as NaN, infinity, 1e300 and negative numbers, fmi2DoStep with odd communication points
and step sizes (1e300, 1e9, 1e3 without a stop time among them), cancel, status queries, FMU
states (get, set, free, serialize, deserialize; corrupted bytes, states and bytes of another
FMU, freed and garbage handles), reset, terminate, free, and calls out of order or on freed
instances. Every sequence runs in its own forked process, so that a crash (the process dies
by a signal) or a hang (it does not finish within the time limit) is caught and reported
with its seed; `--seed N --verbose` replays one sequence call by call.

Oracles, checked after every call:
  crash        the sequence's process died by a signal
  hang         the sequence did not finish within --timeout seconds
  nan_after_ok a Real output or calculated parameter read as NaN or infinite, either by an
               fmi2GetReal that returned fmi2OK or, after any call that returned fmi2OK on an
               instance in a readable state, by the fuzzer's own read of all of them
  bad_status   a status outside the fmi2Status enumeration (0..5)
  slow_step    an fmi2DoStep that used more than --slow seconds of CPU time (its thread's, so
               that a busy machine does not count; reported, counted apart)

The hosts' values for `solver.max_steps` are drawn from 1..20000: that parameter is the
per-step budget of integrator steps a host grants (default 5000), and granting two billion
makes a step to t = 1e300 legitimately long.

Usage:
  python scripts/fuzz_fmi.py --sequences 300 --jobs 2          # a short run
  python scripts/fuzz_fmi.py --sequences 100000 --jobs 2       # the campaign: table + docs/fuzz.csv
  python scripts/fuzz_fmi.py --seed 1234 --verbose             # replay one sequence
  python scripts/fuzz_fmi3.py --sequences 300                    # the FMI 3.0 functions
  python scripts/fuzz_fmi.py --long-steps --csv docs/long_steps.csv   # overlong steps timed
"""

import argparse
import ctypes
import json
import math
import os
import random
import select
import signal
import struct
import sys
import tempfile
import time
import urllib.parse
import zipfile
from ctypes import POINTER, byref, c_char, c_char_p, c_double, c_int, c_size_t, c_uint, c_void_p
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FMU_DIR = ROOT / "target" / "fmu"

FUNCTIONS = [
    "fmi2GetTypesPlatform",
    "fmi2GetVersion",
    "fmi2SetDebugLogging",
    "fmi2Instantiate",
    "fmi2FreeInstance",
    "fmi2SetupExperiment",
    "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode",
    "fmi2Terminate",
    "fmi2Reset",
    "fmi2GetReal",
    "fmi2GetInteger",
    "fmi2GetBoolean",
    "fmi2GetString",
    "fmi2SetReal",
    "fmi2SetInteger",
    "fmi2SetBoolean",
    "fmi2SetString",
    "fmi2GetFMUstate",
    "fmi2SetFMUstate",
    "fmi2FreeFMUstate",
    "fmi2SerializedFMUstateSize",
    "fmi2SerializeFMUstate",
    "fmi2DeSerializeFMUstate",
    "fmi2GetDirectionalDerivative",
    "fmi2SetRealInputDerivatives",
    "fmi2GetRealOutputDerivatives",
    "fmi2DoStep",
    "fmi2CancelStep",
    "fmi2GetStatus",
    "fmi2GetRealStatus",
    "fmi2GetIntegerStatus",
    "fmi2GetBooleanStatus",
    "fmi2GetStringStatus",
]
STATUS_NAMES = ["OK", "Warning", "Discard", "Error", "Fatal", "Pending"]
# the FMI 2.0 name of each type of a model description (FMI 3.0's Float64, Int32)
TYPES = {"Real": "Real", "Float64": "Real", "Integer": "Integer", "Int32": "Integer", "Boolean": "Boolean",
         "String": "String", "Enumeration": "Enumeration"}
ORACLES = ["crash", "hang", "nan_after_ok", "bad_status", "slow_step"]

# Shadow of the FMI state machine (what a correct FMU must be in), to know when reading the
# outputs is allowed without disturbing the sequence.
INSTANTIATED, INIT, COMPLETE, FAILED, TERMINATED, ERROR, FATAL, UNKNOWN = range(8)
READABLE = {INIT, COMPLETE, FAILED, TERMINATED, ERROR}

REAL_SPECIALS = [
    0.0, -0.0, 1.0, -1.0, 0.5, 2.0, 1e-3, 1e-300, 5e-324, -5e-324, 1e300, -1e300, 1.7976931348623157e308,
    float("inf"), float("-inf"), float("nan"), 1e9, -1e9, 1e3, 1e-15,
]
INT_SPECIALS = [0, 1, -1, 2, 3, 4, 5, 6, 7, 100, 2**31 - 1, -(2**31), 2**30, 5000]
STEP_SIZES = [1e-3, 1e-3, 1e-3, 1e-2, 1e-4, 1e-6, 0.1, 1.0, 1e3, 1e9, 1e300, 1.7976931348623157e308,
              0.0, -0.0, -1e-3, float("nan"), float("inf"), float("-inf"), 5e-324, 1e-15]
MAX_STEPS_CEILING = 20000


# --------------------------------------------------------------------------------------
# The FMUs
# --------------------------------------------------------------------------------------


class FmuInfo:
    """One exported FMU, unzipped: its variables and where its library is."""

    def __init__(self, path, unzip_root, extract=True):
        from fmpy import read_model_description

        self.path = Path(path)
        self.name = self.path.stem
        self.dir = Path(unzip_root) / self.name
        if extract:
            # once per campaign: rewriting a library another process has loaded crashes it
            with zipfile.ZipFile(self.path) as z:
                z.extractall(self.dir)
        md = read_model_description(str(self.dir))
        self.guid = md.guid
        self.model_identifier = md.coSimulation.modelIdentifier
        self.fmi3 = md.fmiVersion.startswith("3")
        # (FMI 3.0's independent variable time comes after the table: it is the first value
        # reference past n_vars's last, which the fuzzer also tries)
        self.vars = [(v.valueReference, v.name, TYPES[v.type], v.causality) for v in md.modelVariables
                     if v.causality != "independent"]
        # settable Reals with a nonzero start value: varied by a factor for plausible settings
        self.plausible = [
            (v.valueReference, float(v.start))
            for v in md.modelVariables
            if TYPES[v.type] == "Real" and v.causality in ("parameter", "input") and v.start not in (None, "")
            and float(v.start) != 0.0
        ]
        self.n_vars = len(self.vars)
        by_type = {"Real": [], "Integer": [], "Int64": [], "Boolean": [], "String": []}
        for vr, _, t, _ in self.vars:
            # enumerations: fmi2GetInteger, fmi3GetInt64
            by_type[("Int64" if self.fmi3 else "Integer") if t == "Enumeration" else t].append(vr)
        self.by_type = by_type
        self.checked = [vr for vr, _, t, c in self.vars if t == "Real" and c in ("output", "calculatedParameter")]
        self.max_steps_vr = next((vr for vr, n, _, _ in self.vars if n == "solver.max_steps"), None)
        self.solver_integers = [
            (n, vr) for vr, n, _, _ in self.vars if n in ("solver.method", "solver.max_steps", "solver.steps")
        ]
        resources = self.dir / "resources"
        self.uri = "file:///" + urllib.parse.quote(str(resources).lstrip("/"))
        self.uri_forms = [
            self.uri,
            "file:/" + urllib.parse.quote(str(resources).lstrip("/")),
            "file:////" + urllib.parse.quote(str(resources).lstrip("/")),
            "file://localhost/" + urllib.parse.quote(str(resources).lstrip("/")),
            str(resources),
            self.uri + "/",
        ]
        if self.fmi3:
            # FMI 3.0 passes a path (with a trailing separator); the URIs are accepted too
            self.uri = str(resources) + os.sep
            self.uri_forms = [self.uri, self.uri, str(resources)] + self.uri_forms[:2]

    def to_json(self):
        return {"path": str(self.path), "dir": str(self.dir)}


def load_slave(info):
    """The FMU's library loaded through fmpy (no instance); its raw ctypes functions are used."""
    from fmpy.fmi2 import FMU2Slave

    return FMU2Slave(
        guid=info.guid, unzipDirectory=str(info.dir), modelIdentifier=info.model_identifier, instanceName="fuzz"
    )


# --------------------------------------------------------------------------------------
# One sequence (runs inside its own process)
# --------------------------------------------------------------------------------------


class Violation(Exception):
    pass


class Sequence:
    def __init__(self, seed, infos, slaves, verbose=False, slow=1.0, inject=None):
        from fmpy import calloc, free
        from fmpy.fmi2 import (
            fmi2CallbackAllocateMemoryTYPE,
            fmi2CallbackFreeMemoryTYPE,
            fmi2CallbackFunctions,
            fmi2CallbackLoggerTYPE,
        )
        from fmpy.logging import addLoggerProxy

        self.rng = random.Random(seed)
        self.seed = seed
        # how often a choice is odd (an invalid handle, value reference, value, time...): a
        # sequence is anything from a careful host to a hostile one
        self.chaos = self.rng.choice([0.02, 0.05, 0.15, 0.4, 0.8])
        self.verbose = verbose
        self.slow = slow
        self.inject = inject
        # one or two FMUs (two: states and bytes of another FMU)
        k = 1 if self.rng.random() < 0.6 or len(infos) == 1 else 2
        chosen = self.rng.sample(range(len(infos)), k)
        self.fmus = [(infos[i], slaves[i]) for i in chosen]
        self.instances = []  # dicts: fmu, handle, shadow state, time, stop, alive
        self.states = []  # dicts: fmu index, handle (c_void_p), shadow lifecycle, time, alive
        self.blobs = []  # (fmu index, bytes)
        self.calls = []  # (function, status, seconds)
        self.violations = []
        self.log_count = 0
        self.last_message = ""

        def logger(env, name, status, category, message):
            self.log_count += 1
            self.last_message = message.decode(errors="replace")
            if self.verbose:
                print(f"      log[{status}] {category.decode() if category else None}: {message.decode(errors='replace')}")

        self._logger = fmi2CallbackLoggerTYPE(logger)
        cb = fmi2CallbackFunctions()
        cb.logger = self._logger
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        addLoggerProxy(byref(cb))
        self.callbacks_logger = cb
        self.callbacks_silent = fmi2CallbackFunctions()  # all NULL

    # -- helpers -------------------------------------------------------------------------

    def odd(self, scale=1.0):
        """True when this choice is to be an odd one."""
        return self.rng.random() < self.chaos * scale

    def f(self, fmu, name):
        return self.fmus[fmu][1]._functions[name]

    def call(self, fmu, name, *args, inst=None, describe=""):
        fn = self.f(fmu, name)
        t0, c0 = time.perf_counter(), time.thread_time()
        res = fn(*args)
        dt, cpu = time.perf_counter() - t0, time.thread_time() - c0
        status = res if fn.restype is c_int else None
        self.calls.append((name, status, dt, cpu))
        if self.verbose:
            s = STATUS_NAMES[status] if status is not None and 0 <= status < len(STATUS_NAMES) else status
            who = ""
            if inst is not None:
                who = f"#{self.instances.index(inst)} " if inst in self.instances else "garbage "
            print(f"  [{len(self.calls) - 1:3d}] {who}{self.fmus[fmu][0].name}: {name}({describe}) -> {s}  ({dt * 1e3:.2f} ms)")
        if status is not None and not (0 <= status <= 5):
            self.violations.append(("bad_status", len(self.calls) - 1, f"{name} returned {status}"))
        if inst is not None and status is not None:
            self.update_shadow(inst, name, status)
        if name.endswith("DoStep") and cpu > self.slow:
            self.violations.append(
                ("slow_step", len(self.calls) - 1,
                 f"{name}({describe}) took {cpu:.2f} s CPU, {dt:.2f} s wall{self.solver_settings(inst)}")
            )
        self.last = (inst, status)
        return res

    def update_shadow(self, inst, name, status):
        if not inst["alive"]:
            return
        if status == 3:
            inst["state"] = ERROR
        elif status == 4:
            inst["state"] = FATAL
        elif status == 2 and name.endswith("DoStep"):
            # (a step's discard; a status query's leaves the instance as it was)
            inst["state"] = FAILED

    def model(self, inst):
        """The FMU whose model an instance runs (the variables it has)."""
        return self.fmus[inst.get("model", inst["fmu"])][0]

    def solver_settings(self, inst):
        """`solver.*` Integer values of an instance in a readable state (for the report of a
        slow step: its method and step budget)."""
        info = self.model(inst)
        if not inst["alive"] or inst["state"] not in READABLE or not info.solver_integers:
            return ""
        names = [n for n, _ in info.solver_integers]
        vrs = (c_uint * len(names))(*[vr for _, vr in info.solver_integers])
        out = (c_int * len(names))()
        if self.f(inst["fmu"], "fmi2GetInteger")(inst["handle"], vrs, len(names), out) != 0:
            return ""
        return " (" + ", ".join(f"{n} = {x}" for n, x in zip(names, out)) + ")"

    def check_outputs(self, inst):
        """Reads every Real output and calculated parameter of a live instance in a readable
        state; any NaN or infinity after fmi2OK is a violation."""
        if not inst["alive"] or inst["state"] not in READABLE:
            return
        info = self.model(inst)
        vrs = info.checked
        if not vrs:
            return
        arr = (c_uint * len(vrs))(*vrs)
        out = (c_double * len(vrs))()
        self.last_message = ""
        status = self.read_reals(inst, arr, len(vrs), out)
        if status == 0:
            self.check_values(info, vrs, out, "after the call")
        elif status != 3 or inst["state"] not in (ERROR, INIT):
            # A read in a readable state must succeed; in initialization mode it compiles the
            # model from the parameters set so far, which fails (with a message naming the
            # parameter) when one is out of its range. An output that overflowed (a value set
            # near the largest double) is refused rather than handed out as NaN: that is the
            # rule, not a violation, when the log says so (an instance without a logger, or
            # whose error category was switched off, cannot tell, and is not judged).
            why = self.last_message
            if why and "is not a finite number" not in why:
                self.violations.append(
                    ("read_refused", len(self.calls) - 1, f"reading the outputs returned {status}: {why}")
                )
            inst["state"] = ERROR if status == 3 else inst["state"]

    def read_reals(self, inst, vrs, n, out):
        """The fuzzer's own read of Real outputs (not counted as a call)."""
        return self.f(inst["fmu"], "fmi2GetReal")(inst["handle"], vrs, n, out)

    def fn(self, name):
        """The function of this FMI version called `name` in FMI 2.0 without its prefix."""
        return "fmi2" + name

    def check_values(self, info, vrs, values, when):
        checked = set(info.checked)
        for vr, x in zip(vrs, values):
            if vr in checked and not math.isfinite(x):
                name = next(n for v, n, _, _ in info.vars if v == vr)
                self.violations.append(("nan_after_ok", len(self.calls) - 1, f"{name} = {x} {when}"))
                return

    def real(self):
        r = self.rng.random()
        if self.odd():
            return self.rng.choice(REAL_SPECIALS)
        if r < 0.6:
            return self.rng.gauss(0.0, 1.0) * 10 ** self.rng.randint(-12, 12)
        return struct.unpack("<d", struct.pack("<Q", self.rng.getrandbits(64)))[0]

    def integer(self):
        return self.rng.randint(-(2**31), 2**31 - 1) if self.odd() else self.rng.choice(INT_SPECIALS)

    def vrs(self, fmu, kind):
        """A list of value references: mostly of the right type, sometimes any, unknown or huge."""
        info = self.fmus[fmu][0]
        n = self.rng.choice([0, 1, 1, 1, 2, 3, 5])
        out = []
        for _ in range(n):
            typed = info.by_type[kind]
            if not self.odd() and typed:
                out.append(self.rng.choice(typed))
            elif self.rng.random() < 0.5:
                out.append(self.rng.randrange(info.n_vars))
            else:
                out.append(self.rng.choice([info.n_vars, info.n_vars + 1, 2**31, 2**32 - 1, 10**6]))
        return out

    def pick_instance(self):
        """An instance (live or freed) or a garbage handle."""
        r = self.rng.random()
        if self.instances and not self.odd(0.15):
            live = [i for i in self.instances if i["alive"]]
            if live and not self.odd(0.1):
                return self.rng.choice(live)
            return self.rng.choice(self.instances)
        handle = self.rng.choice([None, 1, 8, 0x1000, 0xDEADBEEF, 2**63 - 8])
        return {"fmu": 0, "handle": c_void_p(handle), "state": UNKNOWN, "alive": False, "time": 0.0, "stop": None}

    # -- actions -------------------------------------------------------------------------

    def instantiate(self, proper=False):
        fmu = self.rng.randrange(len(self.fmus))
        info = self.fmus[fmu][0]
        r = self.rng.random
        name = b"fuzz" if proper or not self.odd(0.3) else self.rng.choice([b"", b"%s%n%d", "\u00fcber".encode(), None])
        fmu_type = 1 if proper or not self.odd(0.2) else self.rng.choice([0, 2, -1])
        guid = info.guid.encode() if proper or not self.odd(0.3) else self.rng.choice(
            [b"", b"{00000000-0000-0000-0000-000000000000}", None, self.fmus[-1][0].guid.encode()]
        )
        if proper or not self.odd(0.3):
            uri = self.rng.choice(info.uri_forms).encode()
        else:
            uri = self.rng.choice(
                [None, b"", b"http://example.org/resources", b"file:///nonexistent/resources", b"file:///tmp/%zz",
                 b"file://server/share", str(self.fmus[-1][0].dir / "resources").encode()]
            )
        cb_choice = 0 if proper or not self.odd(0.5) else self.rng.choice([1, 1, 2])
        callbacks = [byref(self.callbacks_logger), byref(self.callbacks_silent), None][cb_choice]
        logging_on = self.rng.choice([0, 1])
        desc = f"name={name!r}, type={fmu_type}, guid={'ok' if guid == info.guid.encode() else guid!r}, uri={uri!r}, cb={cb_choice}"
        handle = self.call(fmu, "fmi2Instantiate", name, fmu_type, guid, uri, callbacks, 0, logging_on, describe=desc)
        # One library serves every scene: with another FMU's resources (and GUID) the
        # instance runs that FMU's model through this FMU's library.
        foreign = str(self.fmus[-1][0].dir / "resources").encode()
        model = len(self.fmus) - 1 if uri == foreign else fmu
        inst = {"fmu": fmu, "model": model, "handle": c_void_p(handle), "state": INSTANTIATED, "alive": bool(handle),
                "time": 0.0, "stop": None}
        self.instances.append(inst)
        return inst

    def experiment(self, proper=False):
        """(tolerance defined, tolerance, start, stop defined, stop): sometimes odd."""
        tol_def = self.rng.choice([0, 1])
        tol = self.rng.choice([1e-6, 1e-8, 1e-4, 1e-3])
        if self.odd():
            tol = self.rng.choice([0.0, -1.0, float("nan"), float("inf"), 1e300, 5e-324, 1.0, 1e-300])
        start = 0.0 if proper or not self.odd() else self.rng.choice([1.0, -1.0, 1e300, float("nan"), float("inf"), 1e9])
        stop_def = self.rng.choice([0, 0, 1])
        stop = self.rng.choice([1.0, 0.5, 10.0, start])
        if self.odd():
            stop = self.rng.choice([start - 1.0, float("nan"), float("inf"), 1e300, -1e300])
        if proper:
            tol_def, stop_def = 0, self.rng.choice([0, 1])
            stop = 10.0
        return tol_def, tol, start, stop_def, stop

    def setup(self, inst, proper=False):
        tol_def, tol, start, stop_def, stop = self.experiment(proper)
        st = self.call(inst["fmu"], "fmi2SetupExperiment", inst["handle"], tol_def, tol, start, stop_def, stop,
                       inst=inst, describe=f"tol={tol if tol_def else '-'}, start={start}, stop={stop if stop_def else '-'}")
        if st == 0 and inst["alive"]:
            inst["time"] = start
            inst["stop"] = stop if stop_def else None
        return st

    def enter_init(self, inst):
        st = self.call(inst["fmu"], "fmi2EnterInitializationMode", inst["handle"], inst=inst)
        if st == 0 and inst["alive"]:
            inst["state"] = INIT
        return st

    def exit_init(self, inst):
        st = self.call(inst["fmu"], self.fn("ExitInitializationMode"), inst["handle"], inst=inst)
        if st == 0 and inst["alive"]:
            inst["state"] = COMPLETE
            self.check_outputs(inst)
        return st

    def step_args(self, inst):
        """(current communication point, step size) of a step: mostly proper, sometimes odd."""
        r = self.rng.random()
        if self.odd() or r < 0.1:
            h = self.rng.choice(STEP_SIZES)
        elif r < 0.8:
            h = self.rng.choice([1e-3, 2e-3, 5e-3, 1e-2])
        else:
            h = abs(self.rng.gauss(0, 1)) * 10 ** self.rng.randint(-9, 1)
        t = inst["time"]
        if not self.odd(0.5):
            current = t
        elif self.rng.random() < 0.5:
            current = t * (1 + 1e-12) + 1e-15
        else:
            current = self.rng.choice([float("nan"), float("inf"), -1.0, t + 1.0, 1e300, -t])
        return current, h

    def do_step(self, inst):
        current, h = self.step_args(inst)
        st = self.call(inst["fmu"], "fmi2DoStep", inst["handle"], current, h, self.rng.choice([0, 1]), inst=inst,
                       describe=f"{current!r}, {h!r}")
        return self.after_step(inst, st, current + h)

    def after_step(self, inst, st, reached):
        """The shadow after a step that returned `st` (and, when OK, reached time `reached`)."""
        if st == 0 and inst["alive"]:
            inst["time"] = reached
            inst["state"] = COMPLETE
        elif st in (2, 3) and inst["alive"]:
            self.refresh_time(inst)
        return st

    def refresh_time(self, inst):
        if inst["state"] in (COMPLETE, FAILED, TERMINATED, ERROR):
            v = c_double(float("nan"))
            st = self.f(inst["fmu"], "fmi2GetRealStatus")(inst["handle"], 2, byref(v))
            if st == 0 and math.isfinite(v.value):
                inst["time"] = v.value

    def get_values(self, inst, kind):
        fmu = inst["fmu"]
        vrs = self.vrs(fmu, kind)
        n = len(vrs)
        arr = (c_uint * n)(*vrs) if n or self.rng.random() < 0.5 else None
        if n and self.odd(0.1):
            arr = None
        ctype = {"Real": c_double, "Integer": c_int, "Boolean": c_int, "String": c_char_p}[kind]
        out = (ctype * n)() if not (n and self.odd(0.1)) else None
        st = self.call(fmu, f"fmi2Get{kind}", inst["handle"], arr, n, out, inst=inst, describe=f"{vrs}")
        if st == 0 and kind == "Real" and out is not None:
            self.check_values(self.model(inst), vrs, list(out), "read by fmi2GetReal")
        return st

    def set_plausible(self, inst):
        """A parameter or input set to its start value times a factor in [0.5, 2]."""
        info = self.fmus[inst["fmu"]][0]
        if not info.plausible:
            return None
        vr, start = self.rng.choice(info.plausible)
        x = start * self.rng.uniform(0.5, 2.0)
        if self.rng.random() < 0.15 + 0.3 * self.chaos:
            # within the range of most parameters (> 0), but near the ends of double precision
            x = math.copysign(self.rng.choice([1.7976931348623157e308, 8e307, 1e305, 1e300, 1e-300, 5e-324]), start)
        return self.set_real(inst, vr, x)

    def set_real(self, inst, vr, x):
        """Sets one Real variable (counted as a call)."""
        return self.call(inst["fmu"], "fmi2SetReal", inst["handle"], (c_uint * 1)(vr), 1, (c_double * 1)(x), inst=inst,
                         describe=f"[{vr}] = [{x}] (start value scaled)")

    def set_values(self, inst, kind):
        fmu = inst["fmu"]
        info = self.model(inst)
        vrs = self.vrs(fmu, kind)
        n = len(vrs)
        if kind == "Real":
            vals = [self.real() for _ in vrs]
            arr_v = (c_double * n)(*vals)
        elif kind == "Integer":
            vals = [self.integer() for _ in vrs]
            vals = [
                (abs(v) % MAX_STEPS_CEILING) + 1 if vr == info.max_steps_vr and not 1 <= v <= MAX_STEPS_CEILING else v
                for vr, v in zip(vrs, vals)
            ]
            arr_v = (c_int * n)(*vals)
        elif kind == "Boolean":
            vals = [self.rng.choice([0, 1, 2, -1]) for _ in vrs]
            arr_v = (c_int * n)(*vals)
        else:
            vals = [self.rng.choice([b"", b"x", None]) for _ in vrs]
            arr_v = (c_char_p * n)(*vals)
        arr = (c_uint * n)(*vrs)
        if n and self.odd(0.1):
            arr = None
        if n and self.odd(0.1):
            arr_v = None
        return self.call(fmu, f"fmi2Set{kind}", inst["handle"], arr, n, arr_v, inst=inst, describe=f"{vrs} = {vals}")

    def get_state(self, inst):
        fmu = inst["fmu"]
        r = self.rng.random()
        own = [s for s in self.states if s["fmu"] == fmu and s["alive"]]
        if r < 0.7 or not self.states:
            slot = c_void_p(None)
            entry = None
        elif own and not self.odd():
            entry = self.rng.choice(own)
            slot = entry["handle"]
        else:
            entry = self.rng.choice(self.states)
            slot = c_void_p(entry["handle"].value)
        ptr = byref(slot) if not self.odd(0.05) else None
        st = self.call(fmu, self.fn("GetFMUstate"), inst["handle"], ptr, inst=inst,
                       describe="new" if entry is None else f"overwrite {entry['handle'].value:#x}")
        if st == 0 and inst["alive"] and entry is None and ptr is not None:
            self.states.append({"fmu": fmu, "handle": slot, "state": inst["state"], "time": inst["time"],
                                "stop": inst["stop"], "alive": True, "owner": inst})
        elif st == 0 and entry is not None:
            # (a state is the instance's that last wrote it)
            entry.update(state=inst["state"], time=inst["time"], stop=inst["stop"], owner=inst)
        return st

    def pick_state(self, fmu=None):
        """A state: mostly a live one of the instance's FMU, sometimes any (freed, foreign) or
        a garbage handle."""
        own = [s for s in self.states if s["alive"] and s["fmu"] == fmu]
        if own and not self.odd(0.5):
            return self.rng.choice(own)
        if self.states and not self.odd(0.3):
            return self.rng.choice(self.states)
        return {"fmu": -1, "handle": c_void_p(self.rng.choice([None, 16, 0xDEAD0000])), "alive": False, "state": UNKNOWN,
                "time": 0.0, "stop": None}

    def set_state(self, inst):
        s = self.pick_state(inst["fmu"])
        st = self.call(inst["fmu"], self.fn("SetFMUstate"), inst["handle"], s["handle"], inst=inst,
                       describe=f"{s['handle'].value}")
        if st == 0 and inst["alive"]:
            inst["state"], inst["time"], inst["stop"] = s["state"], s["time"], s["stop"]
            if inst["state"] == UNKNOWN:
                self.refresh_time(inst)
            self.check_outputs(inst)
        return st

    def free_state(self, inst):
        s = self.pick_state(inst["fmu"])
        slot = c_void_p(s["handle"].value)
        st = self.call(inst["fmu"], self.fn("FreeFMUstate"), inst["handle"], byref(slot) if self.rng.random() < 0.95 else None,
                       inst=inst, describe=f"{s['handle'].value}")
        if st == 0 and s["alive"] and slot.value is None and s["fmu"] == inst["fmu"]:
            s["alive"] = False
        return st

    def serialize(self, inst):
        fmu = inst["fmu"]
        s = self.pick_state(fmu)
        size = c_size_t(0)
        st = self.call(fmu, self.fn("SerializedFMUstateSize"), inst["handle"], s["handle"],
                       byref(size) if self.rng.random() < 0.95 else None, inst=inst, describe=f"{s['handle'].value}")
        if st != 0:
            return st
        n = size.value
        r = self.rng.random()
        given = n if not self.odd(0.5) else self.rng.choice([0, max(n - 1, 0), n + 7])
        buf = (self.BYTE * max(given, 1))()
        st = self.call(fmu, self.fn("SerializeFMUstate"), inst["handle"], s["handle"], buf, given, inst=inst,
                       describe=f"size {given} of {n}")
        if st == 0:
            self.blobs.append((fmu, bytes(buf)[:n]))
        return st

    def corrupt(self, blob):
        b = bytearray(blob)
        how = self.rng.randrange(7)
        if how == 0 and b:
            i = self.rng.randrange(len(b))
            b[i] ^= 1 << self.rng.randrange(8)
        elif how == 1:
            b = b[: self.rng.randrange(len(b) + 1)]
        elif how == 2:
            b += bytes(self.rng.getrandbits(8) for _ in range(self.rng.randint(1, 64)))
        elif how == 3:
            b = bytearray(self.rng.getrandbits(8) for _ in range(self.rng.randint(0, 512)))
        elif how == 4 and len(b) > 16:
            # a field overwritten with a huge or NaN number, keeping the header
            i = self.rng.randrange(16, len(b) - 8)
            b[i : i + 8] = struct.pack("<d", self.rng.choice([float("nan"), 1e300, -1.0, float("inf")]))
        elif how == 5 and len(b) > 24:
            i = self.rng.randrange(8, 24)
            b[i : i + 8] = struct.pack("<Q", self.rng.choice([0, 2**64 - 1, 2**32, 10**9]))
        else:
            b = bytearray()
        return bytes(b)

    def deserialize(self, inst):
        fmu = inst["fmu"]
        r = self.rng.random()
        if self.blobs and not self.odd():
            owner, blob = self.rng.choice(self.blobs)
            kind = "own" if owner == fmu else "foreign"
        elif self.blobs and r < 0.8:
            owner, blob = self.rng.choice(self.blobs)
            blob = self.corrupt(blob)
            kind = "corrupted"
        else:
            blob = bytes(self.rng.getrandbits(8) for _ in range(self.rng.randint(0, 64)))
            kind = "random"
        buf = (self.BYTE * max(len(blob), 1)).from_buffer_copy(blob or b"\0")
        slot = c_void_p(None)
        own = [s for s in self.states if s["fmu"] == fmu and s["alive"]]
        entry = None
        if own and self.rng.random() < 0.2:
            entry = self.rng.choice(own)
            slot = entry["handle"]
        ptr = byref(slot) if self.rng.random() < 0.97 else None
        data = buf if (blob or self.rng.random() < 0.5) else None
        st = self.call(fmu, self.fn("DeSerializeFMUstate"), inst["handle"], data, len(blob), ptr, inst=inst,
                       describe=f"{kind}, {len(blob)} bytes")
        if st == 0 and inst["alive"] and entry is None and ptr is not None:
            # its lifecycle is unknown to the shadow: read after a restore
            self.states.append({"fmu": fmu, "handle": slot, "state": UNKNOWN, "time": inst["time"], "stop": None,
                                "alive": True, "owner": inst})
        elif st == 0 and entry is not None:
            entry.update(state=UNKNOWN, owner=inst)
        return st

    def status_query(self, inst, which):
        fmu = inst["fmu"]
        kind = self.rng.choice([0, 1, 2, 3, 4, -1, 1000])
        ctype = {"": c_int, "Real": c_double, "Integer": c_int, "Boolean": c_int, "String": c_char_p}[which]
        v = ctype()
        ptr = byref(v) if self.rng.random() < 0.9 else None
        return self.call(fmu, f"fmi2Get{which}Status", inst["handle"], kind, ptr, inst=inst, describe=f"kind {kind}")

    def debug_logging(self, inst):
        cats = self.rng.sample(
            [b"logEvents", b"logStatusWarning", b"logStatusDiscard", b"logStatusError", b"logStatusFatal", b"logAll",
             b"nonsense", None], self.rng.randint(0, 3))
        arr = (c_char_p * len(cats))(*cats) if cats else None
        n = len(cats) if self.rng.random() < 0.95 else len(cats) + 2 if arr is None else len(cats)
        return self.call(inst["fmu"], self.fn("SetDebugLogging"), inst["handle"], self.rng.choice([0, 1]), n, arr, inst=inst,
                         describe=f"{cats}")

    def derivatives(self, inst, name):
        fmu = inst["fmu"]
        vrs = self.vrs(fmu, "Real")
        n = len(vrs)
        arr = (c_uint * n)(*vrs)
        if name == "fmi2GetDirectionalDerivative":
            known = (c_double * n)(*[self.real() for _ in vrs])
            unknown = (c_double * n)()
            return self.call(fmu, name, inst["handle"], arr, n, arr, n, known, unknown, inst=inst)
        order = (c_int * n)(*[self.rng.choice([0, 1, 2, -1]) for _ in vrs])
        vals = (c_double * n)(*[self.real() for _ in vrs])
        return self.call(fmu, name, inst["handle"], arr, n, order, vals, inst=inst)

    def simple(self, inst, name, new_state=None):
        st = self.call(inst["fmu"], name, inst["handle"], inst=inst)
        if st == 0 and inst["alive"] and new_state is not None:
            inst["state"] = new_state
            if new_state == INSTANTIATED:
                inst["time"], inst["stop"] = 0.0, None
        return st

    def recover(self, inst):
        good = [s for s in self.states if s["alive"] and s["fmu"] == inst["fmu"] and s["state"] == COMPLETE]
        if good and self.rng.random() < 0.7:
            s = self.rng.choice(good)
            st = self.call(inst["fmu"], self.fn("SetFMUstate"), inst["handle"], s["handle"], inst=inst, describe="recover")
            if st == 0:
                inst["state"], inst["time"], inst["stop"] = s["state"], s["time"], s["stop"]
                self.check_outputs(inst)
            return
        if self.simple(inst, self.fn("Reset"), INSTANTIATED) == 0:
            self.setup(inst, proper=True)
            self.enter_init(inst)
            self.exit_init(inst)

    def free_instance(self, inst):
        self.call(inst["fmu"], self.fn("FreeInstance"), inst["handle"], describe=f"{inst['handle'].value}")
        if inst["alive"]:
            inst["alive"] = False
            # the states it made (last wrote) are freed with it
            for s in self.states:
                if s.get("owner") is inst:
                    s["alive"] = False

    # -- the sequence --------------------------------------------------------------------

    VERSION_FUNCTIONS = ("fmi2GetTypesPlatform", "fmi2GetVersion")
    # the C type of a serialized state's bytes
    BYTE = c_char

    def actions(self):
        """(weight, action) of every action a sequence draws from."""
        return [
            (18, "doStep"), (6, "getReal"), (2, "getInteger"), (1, "getBoolean"), (1, "getString"),
            (5, "setReal"), (4, "setPlausible"), (3, "setInteger"), (1, "setBoolean"), (1, "setString"), (5, "getState"), (5, "setState"),
            (2, "freeState"), (4, "serialize"), (5, "deserialize"), (2, "reset"), (2, "terminate"),
            (1, "freeInstance"), (2, "instantiate"), (2, "setup"), (2, "enterInit"), (2, "exitInit"),
            (1, "cancel"), (1, "status"), (2, "realStatus"), (1, "integerStatus"), (1, "booleanStatus"),
            (1, "stringStatus"), (1, "debugLogging"), (1, "directional"), (1, "inputDerivatives"),
            (1, "outputDerivatives"), (1, "platform"),
        ]

    def dispatch(self, inst):
        """Action name -> the call that performs it on `inst`."""
        return {
            "doStep": lambda: self.do_step(inst),
            "getReal": lambda: self.get_values(inst, "Real"),
            "getInteger": lambda: self.get_values(inst, "Integer"),
            "getBoolean": lambda: self.get_values(inst, "Boolean"),
            "getString": lambda: self.get_values(inst, "String"),
            "setReal": lambda: self.set_values(inst, "Real"),
            "setPlausible": lambda: self.set_plausible(inst),
            "setInteger": lambda: self.set_values(inst, "Integer"),
            "setBoolean": lambda: self.set_values(inst, "Boolean"),
            "setString": lambda: self.set_values(inst, "String"),
            "getState": lambda: self.get_state(inst),
            "setState": lambda: self.set_state(inst),
            "freeState": lambda: self.free_state(inst),
            "serialize": lambda: self.serialize(inst),
            "deserialize": lambda: self.deserialize(inst),
            "reset": lambda: self.simple(inst, "fmi2Reset", INSTANTIATED),
            "terminate": lambda: self.simple(inst, "fmi2Terminate", TERMINATED),
            "freeInstance": lambda: self.free_instance(inst),
            "setup": lambda: self.setup(inst),
            "enterInit": lambda: self.enter_init(inst),
            "exitInit": lambda: self.exit_init(inst),
            "cancel": lambda: self.simple(inst, "fmi2CancelStep"),
            "status": lambda: self.status_query(inst, ""),
            "realStatus": lambda: self.status_query(inst, "Real"),
            "integerStatus": lambda: self.status_query(inst, "Integer"),
            "booleanStatus": lambda: self.status_query(inst, "Boolean"),
            "stringStatus": lambda: self.status_query(inst, "String"),
            "debugLogging": lambda: self.debug_logging(inst),
            "directional": lambda: self.derivatives(inst, "fmi2GetDirectionalDerivative"),
            "inputDerivatives": lambda: self.derivatives(inst, "fmi2SetRealInputDerivatives"),
            "outputDerivatives": lambda: self.derivatives(inst, "fmi2GetRealOutputDerivatives"),
        }

    def run(self, length):
        rng = self.rng
        # a proper start most of the time, so that the calls reach the running states
        if rng.random() < 0.85:
            inst = self.instantiate(proper=rng.random() < 0.9)
            if inst["alive"] and rng.random() < 0.9:
                self.setup(inst, proper=rng.random() < 0.8)
                self.enter_init(inst)
                for _ in range(rng.choice([0, 0, 1, 2, 3])):
                    if rng.random() < 0.7:
                        self.set_plausible(inst)
                    else:
                        self.set_values(inst, rng.choice(["Real", "Integer", "Boolean"]))
                self.exit_init(inst)
        if self.inject == "crash":
            # the oracle's self-test: this process dies on purpose; the traceback that Python's
            # fault handler (on under pytest) would print is not a finding
            import faulthandler

            faulthandler.disable()
            ctypes.string_at(0)
        if self.inject == "hang":
            time.sleep(3600)
        actions = self.actions()
        weights = [w for w, _ in actions]
        names = [a for _, a in actions]
        for _ in range(length):
            action = rng.choices(names, weights)[0]
            if action == "instantiate" or not self.instances:
                self.instantiate(proper=rng.random() < 0.5)
                continue
            if action == "platform":
                fmu = rng.randrange(len(self.fmus))
                for name in self.VERSION_FUNCTIONS:
                    self.call(fmu, name)
                continue
            inst = self.pick_instance()
            if inst["state"] in (ERROR, FAILED) and inst["alive"] and not self.odd():
                # recover as a host would: back to a saved state, or reset and initialise again
                self.recover(inst)
                continue
            dispatch = self.dispatch(inst)
            self.last = (None, None)
            dispatch[action]()
            # the shadow state is up to date now: read the outputs after an fmi2OK
            last_inst, last_status = self.last
            if last_status == 0 and last_inst is not None:
                self.check_outputs(last_inst)
        # clean up like a host: free the states, then the instances (also a check that
        # freeing in any state works)
        for s in self.states:
            owner = next((i for i in self.instances if i["alive"] and i["fmu"] == s["fmu"]), None)
            if s["alive"] and owner is not None:
                slot = s["handle"]
                self.call(s["fmu"], self.fn("FreeFMUstate"), owner["handle"], byref(slot), inst=owner, describe="cleanup")
        for inst in self.instances:
            if inst["alive"]:
                self.free_instance(inst)
        if self.inject == "nan":
            self.violations.append(("nan_after_ok", len(self.calls), "injected"))

    def result(self):
        per_function = {}
        for name, status, dt, cpu in self.calls:
            e = per_function.setdefault(name, {"calls": 0, "status": {}, "max_seconds": 0.0, "max_cpu_seconds": 0.0})
            e["calls"] += 1
            key = "none" if status is None else str(status)
            e["status"][key] = e["status"].get(key, 0) + 1
            e["max_seconds"] = max(e["max_seconds"], dt)
            e["max_cpu_seconds"] = max(e["max_cpu_seconds"], cpu)
        return {"seed": self.seed, "calls": len(self.calls), "violations": self.violations, "functions": per_function,
                "fmus": [info.name for info, _ in self.fmus]}


def sequence_length(seed):
    return random.Random(seed ^ 0x5EED).randint(5, 60)


# --------------------------------------------------------------------------------------
# Running sequences in forked processes
# --------------------------------------------------------------------------------------

_WORKER = {}


# (the Sequence class, the library loader, the function names) per FMI version; the FMI 3.0
# ones are added by scripts/fuzz_fmi3.py when it is imported (it builds on this module)
VERSIONS = {2: (Sequence, load_slave, FUNCTIONS)}


def version_parts(fmi_version):
    """(the Sequence class, the library loader, the function names) of an FMI version."""
    if fmi_version not in VERSIONS:
        sys.exit(f"FMI {fmi_version}: not registered (for FMI 3.0 run scripts/fuzz_fmi3.py, or import fuzz_fmi3)")
    return VERSIONS[fmi_version]


def _worker_init(fmu_paths, unzip_root, slow, inject, fmi_version):
    infos = [FmuInfo(p, unzip_root, extract=False) for p in fmu_paths]
    sequence, loader, _ = version_parts(fmi_version)
    _WORKER.update(infos=infos, slaves=[loader(i) for i in infos], slow=slow, inject=inject, sequence=sequence)


def run_forked(seed, timeout):
    """Runs one sequence in a child process; returns its result with crash/hang detection."""
    w = _WORKER
    read_fd, write_fd = os.pipe()
    t0 = time.monotonic()
    pid = os.fork()
    if pid == 0:  # the child
        os.close(read_fd)
        code = 0
        try:
            seq = w["sequence"](seed, w["infos"], w["slaves"], slow=w["slow"], inject=w["inject"])
            seq.run(sequence_length(seed))
            data = json.dumps(seq.result()).encode()
        except BaseException as e:  # a Python-side problem is reported, not hidden
            data = json.dumps({"seed": seed, "error": f"{type(e).__name__}: {e}"}).encode()
            code = 3
        with os.fdopen(write_fd, "wb") as f:
            f.write(data)
        os._exit(code)
    os.close(write_fd)
    chunks = []
    hung = False
    while True:
        left = timeout - (time.monotonic() - t0)
        if left <= 0:
            hung = True
            break
        ready, _, _ = select.select([read_fd], [], [], left)
        if not ready:
            hung = True
            break
        chunk = os.read(read_fd, 1 << 16)
        if not chunk:
            break
        chunks.append(chunk)
    os.close(read_fd)
    if hung:
        os.kill(pid, signal.SIGKILL)
    _, status = os.waitpid(pid, 0)
    seconds = time.monotonic() - t0
    if hung:
        return {"seed": seed, "violations": [["hang", -1, f"no result after {timeout} s"]], "calls": 0,
                "functions": {}, "seconds": seconds}
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        return {"seed": seed, "violations": [["crash", -1, f"killed by signal {sig} ({signal.Signals(sig).name})"]],
                "calls": 0, "functions": {}, "seconds": seconds}
    try:
        result = json.loads(b"".join(chunks))
    except ValueError:
        result = {"seed": seed, "error": f"exit status {status}, no result"}
    if "error" in result:
        result.update(violations=[["fuzzer_error", -1, result["error"]]], calls=0, functions={})
    result["seconds"] = seconds
    return result


def _run_chunk(args):
    seeds, timeout = args
    return [run_forked(s, timeout) for s in seeds]


def campaign(fmu_paths, seeds, jobs=2, timeout=30.0, slow=1.0, inject=None, progress=None, fmi_version=2):
    """Runs the sequences of `seeds` on `jobs` worker processes (each sequence in a forked
    child) against FMUs of `fmi_version`; returns the list of results."""
    import multiprocessing

    seeds = list(seeds)
    unzip_root = tempfile.mkdtemp(prefix="contact-fmu-fuzz-")
    for p in fmu_paths:  # unzipped here, before the workers load the libraries
        FmuInfo(p, unzip_root)
    chunk = max(1, min(50, len(seeds) // (4 * jobs) or 1))
    chunks = [(seeds[i : i + chunk], timeout) for i in range(0, len(seeds), chunk)]
    ctx = multiprocessing.get_context("fork")
    results = []
    with ctx.Pool(jobs, initializer=_worker_init, initargs=([str(p) for p in fmu_paths], unzip_root, slow, inject, fmi_version)) as pool:
        try:
            for part in pool.imap_unordered(_run_chunk, chunks):
                results.extend(part)
                if progress:
                    progress(results)
        except KeyboardInterrupt:
            # an interrupted campaign (Ctrl-C, SIGTERM) reports the sequences it finished
            pool.terminate()
            print(f"interrupted after {len(results)} sequences", file=sys.stderr)
    import shutil

    shutil.rmtree(unzip_root, ignore_errors=True)
    results.sort(key=lambda r: r["seed"])
    return results


def summarize(results, functions=FUNCTIONS):
    counts = {k: 0 for k in ORACLES}
    other = {}
    bad_seeds = {}
    for r in results:
        kinds = set()
        for kind, _, _ in r["violations"]:
            kinds.add(kind)
        for kind in kinds:
            if kind in counts:
                counts[kind] += 1
            else:
                other[kind] = other.get(kind, 0) + 1
            bad_seeds.setdefault(kind, []).append(r["seed"])
    functions = {name: {"calls": 0, "status": {}, "max_seconds": 0.0, "max_cpu_seconds": 0.0} for name in functions}
    for r in results:
        for name, e in r["functions"].items():
            agg = functions.setdefault(name, {"calls": 0, "status": {}, "max_seconds": 0.0, "max_cpu_seconds": 0.0})
            agg["calls"] += e["calls"]
            for k, v in e["status"].items():
                agg["status"][k] = agg["status"].get(k, 0) + v
            agg["max_seconds"] = max(agg["max_seconds"], e["max_seconds"])
            agg["max_cpu_seconds"] = max(agg["max_cpu_seconds"], e["max_cpu_seconds"])
    return {"sequences": len(results), "calls": sum(r["calls"] for r in results), "counts": counts, "other": other,
            "bad_seeds": bad_seeds, "functions": functions}


def print_table(summary, seconds, jobs, first_seed):
    s = summary
    print(f"\nFMI call-sequence fuzzing: {s['sequences']} sequences (seeds from {first_seed}),"
          f" {s['calls']} calls, {jobs} jobs, {seconds:.0f} s")
    print(f"{'function':32s} {'calls':>8s} {'OK':>8s} {'Warn':>6s} {'Discard':>8s} {'Error':>8s} {'Fatal':>6s} {'max wall s':>10s} {'max CPU s':>9s}")
    for name in s["functions"]:
        e = s["functions"][name]
        st = e["status"]
        ok = st.get("0", 0) + st.get("none", 0)  # (functions without a status count as OK)
        print(f"{name:32s} {e['calls']:8d} {ok:8d} {st.get('1', 0):6d} {st.get('2', 0):8d} {st.get('3', 0):8d}"
              f" {st.get('4', 0):6d} {e['max_seconds']:10.3f} {e['max_cpu_seconds']:9.3f}")
    print()
    print(f"{'oracle':16s} {'sequences':>10s}  first seeds")
    for kind in ORACLES + sorted(s["other"]):
        n = s["counts"].get(kind, s["other"].get(kind, 0))
        seeds = s["bad_seeds"].get(kind, [])[:8]
        print(f"{kind:16s} {n:10d}  {' '.join(map(str, seeds))}")


def write_csv(summary, path, seconds, jobs, first_seed):
    s = summary
    lines = ["function,calls,ok,warning,discard,error,fatal,pending,other,max_wall_seconds,max_cpu_seconds"]
    for name in s["functions"]:
        e = s["functions"][name]
        st = dict(e["status"])
        none = st.pop("none", 0)
        ok = st.pop("0", 0) + none
        known = [st.pop(str(k), 0) for k in range(1, 6)]
        other = sum(st.values())
        lines.append(f"{name},{e['calls']},{ok},{','.join(map(str, known))},{other},{e['max_seconds']:.4f},{e['max_cpu_seconds']:.4f}")
    lines.append("")
    lines.append("oracle,sequences_violating")
    for kind in ORACLES + sorted(s["other"]):
        lines.append(f"{kind},{s['counts'].get(kind, s['other'].get(kind, 0))}")
    lines.append("")
    lines.append("sequences,calls,first_seed,jobs,wall_seconds")
    lines.append(f"{s['sequences']},{s['calls']},{first_seed},{jobs},{seconds:.0f}")
    Path(path).write_text("\n".join(lines) + "\n")


def long_steps(fmu_paths, csv=None):
    """fmi2DoStep(0, h) right after initialisation, without a stop time, for h = 1e300, 1e9,
    1e3, with every integration method and the default step budget: status, the time
    reached, wall and CPU seconds. Prints a table; writes `csv` when given."""
    from fmpy.fmi2 import fmi2CallbackFunctions

    root = tempfile.mkdtemp(prefix="contact-fmu-long-")
    rows = []
    print(f"{'fmu':14s} {'method':>6s} {'h':>7s} {'status':>8s} {'t reached':>10s} {'wall s':>7s} {'CPU s':>7s}")
    for path in fmu_paths:
        info = FmuInfo(path, root)
        f = load_slave(info)._functions
        method_vr = next(vr for vr, n, _, _ in info.vars if n == "solver.method")
        for method in (1, 2, 3, 4):
            for h in (1e300, 1e9, 1e3):
                cb = fmi2CallbackFunctions()
                c = f["fmi2Instantiate"](b"long", 1, info.guid.encode(), info.uri.encode(), byref(cb), 0, 0)
                assert f["fmi2SetupExperiment"](c, 0, 0.0, 0.0, 0, 0.0) == 0
                assert f["fmi2EnterInitializationMode"](c) == 0
                assert f["fmi2SetInteger"](c, (c_uint * 1)(method_vr), 1, (c_int * 1)(method)) == 0
                assert f["fmi2ExitInitializationMode"](c) == 0
                t0, c0 = time.perf_counter(), time.thread_time()
                status = f["fmi2DoStep"](c, 0.0, h, 1)
                wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
                reached = c_double(float("nan"))
                f["fmi2GetRealStatus"](c, 2, byref(reached))
                f["fmi2FreeInstance"](c)
                name = STATUS_NAMES[status] if 0 <= status < len(STATUS_NAMES) else str(status)
                rows.append((info.name, method, h, name, reached.value, wall, cpu))
                print(f"{info.name:14s} {method:6d} {h:7.0e} {name:>8s} {reached.value:10.4g} {wall:7.3f} {cpu:7.3f}",
                      flush=True)
    if csv:
        lines = ["fmu,method,h,status,time_reached,wall_seconds,cpu_seconds"]
        lines += [f"{n},{m},{h:g},{st},{t:.6g},{w:.4f},{c:.4f}" for n, m, h, st, t, w, c in rows]
        Path(csv).write_text("\n".join(lines) + "\n")
        print(f"wrote {csv}")
    return rows


def default_fmus(fmi_version=2):
    folder = FMU_DIR if fmi_version == 2 else FMU_DIR.parent / "fmu3"
    return sorted(folder.glob("*.fmu"))


def main(fmi_version=2):
    """The command line; `fmi_version` is the default of --fmi-version (scripts/fuzz_fmi3.py
    calls it with 3)."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sequences", type=int, default=300)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=30.0, help="seconds per sequence before it counts as a hang")
    ap.add_argument("--slow", type=float, default=1.0, help="an fmi2DoStep using more CPU seconds counts as slow_step")
    ap.add_argument("--fmu", action="append", help="FMU files (default: target/fmu/*.fmu)")
    ap.add_argument("--csv", default=None, help="CSV to write (default docs/fuzz.csv for >= 10000 sequences)")
    ap.add_argument("--seed", type=int, help="replay one sequence in this process, printing every call")
    ap.add_argument("--fmi-version", type=int, choices=sorted(VERSIONS), default=fmi_version,
                    help="fuzz the FMI 2.0 functions (target/fmu) or, from scripts/fuzz_fmi3.py, the FMI 3.0 "
                         "ones (target/fmu3)")
    ap.add_argument("--verbose", action="store_true")
    ap.add_argument("--inject", choices=["crash", "hang", "nan"], help="self-test: make every sequence fail so")
    ap.add_argument("--long-steps", action="store_true",
                    help="instead of fuzzing: time fmi2DoStep(0, 1e300 | 1e9 | 1e3) per FMU and method")
    args = ap.parse_args()
    fmus = [Path(p) for p in args.fmu] if args.fmu else default_fmus(args.fmi_version)
    sequence, loader, functions = version_parts(args.fmi_version)
    if not fmus:
        sys.exit("no FMUs: export them first (cargo run --release)")
    if args.long_steps:
        long_steps(fmus, args.csv)
        return
    if args.seed is not None:
        root = tempfile.mkdtemp(prefix="contact-fmu-fuzz-")
        infos = [FmuInfo(p, root) for p in fmus]
        seq = sequence(args.seed, infos, [loader(i) for i in infos], verbose=True, slow=args.slow, inject=args.inject)
        print(f"seed {args.seed}: {[i.name for i, _ in seq.fmus]}, {sequence_length(args.seed)} random calls")
        seq.run(sequence_length(args.seed))
        for v in seq.violations:
            print("VIOLATION", v)
        sys.exit(1 if seq.violations else 0)
    def interrupted(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, interrupted)
    t0 = time.monotonic()
    last = [t0]
    campaign_csv = "fuzz.csv" if args.fmi_version == 2 else "fuzz3.csv"
    csv = args.csv or (str(ROOT / "docs" / campaign_csv) if args.sequences >= 10000 else None)

    def progress(results):
        now = time.monotonic()
        if now - last[0] > 60:
            last[0] = now
            s = summarize(results, functions)
            print(f"  {len(results)}/{args.sequences} sequences, {now - t0:.0f} s, "
                  + ", ".join(f"{k} {v}" for k, v in s["counts"].items()), flush=True)
            if csv:  # an interrupted campaign leaves the figures of what it ran
                write_csv(s, csv, now - t0, args.jobs, args.first_seed)

    seeds = range(args.first_seed, args.first_seed + args.sequences)
    results = campaign(fmus, seeds, jobs=args.jobs, timeout=args.timeout, slow=args.slow, inject=args.inject,
                       progress=progress, fmi_version=args.fmi_version)
    seconds = time.monotonic() - t0
    summary = summarize(results, functions)
    print_table(summary, seconds, args.jobs, args.first_seed)
    if csv:
        write_csv(summary, csv, seconds, args.jobs, args.first_seed)
        print(f"wrote {csv}")
    findings = [{"seed": r["seed"], "fmus": r.get("fmus"), "violations": r["violations"]} for r in results if r["violations"]]
    if findings:
        path = ROOT / "target" / "fuzz_findings.json"
        path.parent.mkdir(exist_ok=True)
        path.write_text(json.dumps(findings, indent=1))
        print(f"the {len(findings)} sequences with findings: {path} (replay one: python scripts/fuzz_fmi.py --seed N)")
    failed = sum(summary["counts"][k] for k in ("crash", "hang", "nan_after_ok", "bad_status")) + sum(
        summary["other"].values())
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
