"""The FMI 2.0 call sequences of the fuzzer (scripts/fuzz_fmi.py, which runs them and reports).

A `Sequence` is drawn from one seed: random calls over all 34 functions of FMI 2.0
Co-Simulation, against a shadow of the FMI state machine that says what a correct FMU must be
in, with the oracles of scripts/fuzz_fmi.py checked after every call. What the sequences call
and with what values is in scripts/fuzz_fmi_targets.py; scripts/fuzz_fmi3.py builds its FMI 3.0
sequences on both.
"""

import ctypes
import math
import random
import struct
import time
from ctypes import byref, c_char, c_char_p, c_double, c_int, c_size_t, c_uint, c_void_p

from fuzz_fmi_targets import *  # noqa: F401,F403

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
