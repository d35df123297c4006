"""FMI 3.0 call sequences for the fuzzer (`python scripts/fuzz_fmi.py --fmi-version 3`).

`Sequence3` is the FMI 2.0 `Sequence` of scripts/fuzz_fmi.py with FMI 3.0's functions: the
actions, oracles, shadow state machine, FMU states (own, foreign, corrupted and random bytes)
and the forked processes are the FMI 2.0 fuzzer's; what differs is said here. `fmi3InstantiateCoSimulation` with good and bad names,
tokens, resource paths, callbacks, event mode, early return and intermediate variables;
`fmi3EnterInitializationMode` with the experiment's times; Get/Set of every FMI 3.0 type (the
ones this model uses: Float64, Int32, Int64 for enumerations, Boolean; the others: Float32,
Int8 ... UInt64, String) with nValues sometimes differing from the value references and
Boolean bytes other than 0 and 1; `fmi3DoStep` with NULL output arguments among its odd ones;
and the functions of what the FMU does not offer (event mode, clocks, Model Exchange,
derivatives).
"""

import ctypes
from ctypes import (POINTER, byref, c_bool, c_char_p, c_double, c_float, c_int, c_int8, c_int16, c_int32, c_int64,
                    c_size_t, c_uint8, c_uint16, c_uint32, c_uint64)

import fuzz_fmi as base
from fuzz_fmi import COMPLETE, ERROR, FAILED, INIT, INSTANTIATED, TERMINATED

FUNCTIONS3 = (
    ["fmi3GetVersion", "fmi3SetDebugLogging", "fmi3InstantiateCoSimulation", "fmi3FreeInstance",
     "fmi3EnterInitializationMode", "fmi3ExitInitializationMode", "fmi3Terminate", "fmi3Reset"]
    + [f"fmi3{op}{t}" for t in ("Float64", "Int32", "Int64", "Boolean", "String", "Float32", "Int8", "UInt8",
                                "Int16", "UInt16", "UInt32", "UInt64") for op in ("Get", "Set")]
    + ["fmi3GetFMUState", "fmi3SetFMUState", "fmi3FreeFMUState", "fmi3SerializedFMUStateSize",
       "fmi3SerializeFMUState", "fmi3DeserializeFMUState", "fmi3DoStep", "fmi3EnterStepMode"]
)

# FMI 2.0's names of the state functions -> FMI 3.0's
RENAMED = {"GetFMUstate": "GetFMUState", "SetFMUstate": "SetFMUState", "FreeFMUstate": "FreeFMUState",
           "SerializedFMUstateSize": "SerializedFMUStateSize", "SerializeFMUstate": "SerializeFMUState",
           "DeSerializeFMUstate": "DeserializeFMUState"}

# FMI 3.0 type -> (the fuzzer's kind of value references, the C type)
TYPES = {"Float64": ("Real", c_double), "Int32": ("Integer", c_int32), "Int64": ("Int64", c_int64),
         "Boolean": ("Boolean", c_bool), "String": ("String", c_char_p), "Float32": ("Real", c_float),
         "Int8": ("Integer", c_int8), "UInt8": ("Integer", c_uint8), "Int16": ("Integer", c_int16),
         "UInt16": ("Integer", c_uint16), "UInt32": ("Integer", c_uint32), "UInt64": ("Integer", c_uint64)}


# the FMI 2.0 kinds the base class asks for
FMI3_KIND = {"Real": "Float64", "Integer": "Int32"}


def load_slave3(info):
    """The FMU's library loaded through fmpy's FMI 3.0 class (no instance)."""
    from fmpy.fmi3 import FMU3Slave

    return FMU3Slave(guid=info.guid, unzipDirectory=str(info.dir), modelIdentifier=info.model_identifier,
                     instanceName="fuzz")


class Sequence3(base.Sequence):
    VERSION_FUNCTIONS = ("fmi3GetVersion",)
    BYTE = c_uint8

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        from fmpy.fmi3 import fmi3IntermediateUpdateCallback, fmi3LogMessageCallback

        def logger(env, status, category, message):
            self.log_count += 1
            self.last_message = message.decode(errors="replace")
            if self.verbose:
                print(f"      log[{status}] {category.decode() if category else None}: {self.last_message}")

        self._logger3 = fmi3LogMessageCallback(logger)
        # NULL function pointers
        self._no_logger3 = fmi3LogMessageCallback()
        self._no_update = fmi3IntermediateUpdateCallback()

    def fn(self, name):
        return "fmi3" + RENAMED.get(name, name)

    def read_reals(self, inst, vrs, n, out):
        return self.f(inst["fmu"], "fmi3GetFloat64")(inst["handle"], vrs, n, out, n)

    def solver_settings(self, inst):
        info = self.model(inst)
        names = [(n, vr) for n, vr in info.solver_integers if n != "solver.method"]  # (an enumeration)
        if not inst["alive"] or inst["state"] not in base.READABLE or not names:
            return ""
        vrs = (c_uint32 * len(names))(*[vr for _, vr in names])
        out = (c_int32 * len(names))()
        if self.f(inst["fmu"], "fmi3GetInt32")(inst["handle"], vrs, len(names), out, len(names)) != 0:
            return ""
        return " (" + ", ".join(f"{n} = {x}" for (n, _), x in zip(names, out)) + ")"

    def instantiate(self, proper=False):
        fmu = self.rng.randrange(len(self.fmus))
        info = self.fmus[fmu][0]
        other = self.fmus[-1][0]
        odd = (lambda scale: not proper and self.odd(scale))
        name = b"fuzz" if not odd(0.3) else self.rng.choice([b"", b"%s%n%d", "\u00fcber".encode(), None])
        token = info.guid.encode() if not odd(0.3) else self.rng.choice(
            [b"", b"{00000000-0000-0000-0000-000000000000}", None, other.guid.encode()])
        path = self.rng.choice(info.uri_forms).encode() if not odd(0.3) else self.rng.choice(
            [None, b"", b"/nonexistent/resources/", b"file:///tmp/%zz", str(other.dir / "resources").encode() + b"/"])
        logger = self._logger3 if not odd(0.5) else self._no_logger3
        event_mode = odd(0.2)
        early = self.rng.random() < 0.5
        required, n_required = (c_uint32 * 1)(0), 0
        if odd(0.1):
            required, n_required = self.rng.choice([((c_uint32 * 1)(0), 1), (None, 2)])
        desc = (f"name={name!r}, token={'ok' if token == info.guid.encode() else token!r}, path={path!r}, "
                f"log={logger is self._logger3}, eventMode={event_mode}, early={early}, nRequired={n_required}")
        handle = self.call(fmu, "fmi3InstantiateCoSimulation", name, token, path, False, self.rng.random() < 0.5,
                           event_mode, early, required, n_required, None, logger, self._no_update, describe=desc)
        foreign = str(other.dir / "resources").encode() + b"/"
        model = len(self.fmus) - 1 if path == foreign else fmu
        inst = {"fmu": fmu, "model": model, "handle": ctypes.c_void_p(handle), "state": INSTANTIATED,
                "alive": bool(handle), "time": 0.0, "stop": None}
        self.instances.append(inst)
        return inst

    def setup(self, inst, proper=False):
        """FMI 3.0 has no fmi2SetupExperiment: the experiment goes to the next
        fmi3EnterInitializationMode."""
        inst["experiment"] = self.experiment(proper)

    def enter_init(self, inst):
        tol_def, tol, start, stop_def, stop = inst.pop("experiment", None) or self.experiment()
        st = self.call(inst["fmu"], "fmi3EnterInitializationMode", inst["handle"], bool(tol_def), tol, start,
                       bool(stop_def), stop, inst=inst,
                       describe=f"tol={tol if tol_def else '-'}, start={start}, stop={stop if stop_def else '-'}")
        if st == 0 and inst["alive"]:
            inst["state"], inst["time"], inst["stop"] = INIT, start, stop if stop_def else None
        return st

    def do_step(self, inst):
        current, h = self.step_args(inst)
        outs = [c_bool(), c_bool(), c_bool()]
        last = c_double(float("nan"))
        pointers = [byref(x) for x in outs] + [byref(last)]
        if self.odd(0.3):
            pointers[self.rng.randrange(4)] = None
        st = self.call(inst["fmu"], "fmi3DoStep", inst["handle"], current, h, self.rng.random() < 0.5, *pointers,
                       inst=inst, describe=f"{current!r}, {h!r}")
        # the time reached: the end, or a contact event before it
        return self.after_step(inst, st, last.value)

    def refresh_time(self, inst):
        """The time from the independent variable `time` (FMI 3.0 has no status functions)."""
        if inst["state"] in (COMPLETE, FAILED, TERMINATED, ERROR):
            time_vr = (c_uint32 * 1)(self.model(inst).n_vars)
            v = (c_double * 1)(float("nan"))
            if self.f(inst["fmu"], "fmi3GetFloat64")(inst["handle"], time_vr, 1, v, 1) == 0:
                inst["time"] = v[0]

    def typed(self, inst, kind):
        """Value references and the C arrays of a get or set of FMI 3.0 type `kind`."""
        key, ctype = TYPES[FMI3_KIND.get(kind, kind)]
        vrs = self.vrs(inst["fmu"], key if kind != "Int64" else "Int64")
        n = len(vrs)
        arr = (c_uint32 * n)(*vrs) if not (n and self.odd(0.1)) else None
        n_values = n if not self.odd(0.2) else self.rng.choice([0, n + 1, max(n - 1, 0)])
        return vrs, arr, n_values, ctype

    def get_values(self, inst, kind):
        kind = FMI3_KIND.get(kind, kind)
        vrs, arr, n_values, ctype = self.typed(inst, kind)
        out = (ctype * max(n_values, 1))() if not (n_values and self.odd(0.1)) else None
        st = self.call(inst["fmu"], f"fmi3Get{kind}", inst["handle"], arr, len(vrs), out, n_values, inst=inst,
                       describe=f"{vrs}, nValues={n_values}")
        if st == 0 and kind == "Float64" and out is not None:
            self.check_values(self.model(inst), vrs, list(out)[: len(vrs)], "read by fmi3GetFloat64")
        return st

    def set_values(self, inst, kind):
        kind = FMI3_KIND.get(kind, kind)
        vrs, arr, n_values, ctype = self.typed(inst, kind)
        info = self.model(inst)
        m = max(n_values, 1)
        if kind in ("Float64", "Float32"):
            values = (ctype * m)(*[self.real() for _ in range(m)])
        elif kind == "Boolean":
            # bytes as a host might write them (2 and 255 are true)
            values = ctypes.cast((c_uint8 * m)(*[self.rng.choice([0, 1, 2, 255]) for _ in range(m)]), POINTER(c_bool))
        elif kind == "String":
            values = (ctype * m)(*[self.rng.choice([b"", b"x", None]) for _ in range(m)])
        else:
            vals = [self.integer() for _ in range(m)]
            vals = [(abs(v) % base.MAX_STEPS_CEILING) + 1 if k < len(vrs) and vrs[k] == info.max_steps_vr else v
                    for k, v in enumerate(vals)]
            if kind.startswith("UInt"):
                vals = [abs(v) for v in vals]
            values = (ctype * m)(*[max(min(v, 127), -128) if kind == "Int8" else v for v in vals])
        if n_values and self.odd(0.1):
            values = None
        return self.call(inst["fmu"], f"fmi3Set{kind}", inst["handle"], arr, len(vrs), values, n_values, inst=inst,
                         describe=f"{vrs}, nValues={n_values}")

    def set_real(self, inst, vr, x):
        return self.call(inst["fmu"], "fmi3SetFloat64", inst["handle"], (c_uint32 * 1)(vr), 1, (c_double * 1)(x), 1,
                         inst=inst, describe=f"[{vr}] = [{x}] (start value scaled)")

    def unsupported(self, inst):
        """A function of what this FMU does not offer, with plausible arguments."""
        h = inst["handle"]
        n = self.rng.choice([0, 1, 2])
        vrs = (c_uint32 * max(n, 1))(*([0] * max(n, 1)))
        reals = (c_double * max(n, 1))()
        flags = [c_bool() for _ in range(5)]
        size = c_size_t()
        name, args = self.rng.choice([
            ("fmi3EnterEventMode", ()),
            ("fmi3EnterConfigurationMode", ()),
            ("fmi3ExitConfigurationMode", ()),
            ("fmi3EvaluateDiscreteStates", ()),
            ("fmi3UpdateDiscreteStates", tuple(byref(f) for f in flags) + (byref(c_double()),)),
            ("fmi3GetDirectionalDerivative", (vrs, n, vrs, n, reals, n, reals, n)),
            ("fmi3GetAdjointDerivative", (vrs, n, vrs, n, reals, n, reals, n)),
            ("fmi3GetOutputDerivatives", (vrs, n, (c_int32 * max(n, 1))(1), reals, n)),
            ("fmi3GetClock", (vrs, n, (c_bool * max(n, 1))())),
            ("fmi3GetIntervalDecimal", (vrs, n, reals, (c_int * max(n, 1))())),
            ("fmi3SetShiftDecimal", (vrs, n, reals)),
            ("fmi3GetNumberOfVariableDependencies", (0, byref(size))),
            ("fmi3EnterContinuousTimeMode", ()),
            ("fmi3SetTime", (self.real(),)),
            ("fmi3GetContinuousStates", (reals, n)),
            ("fmi3GetNumberOfEventIndicators", (byref(size),)),
            ("fmi3ActivateModelPartition", (0, 0.0)),
        ])
        return self.call(inst["fmu"], name, h, *args, inst=inst)

    def actions(self):
        return [
            (18, "doStep"), (6, "getFloat64"), (2, "getInt32"), (1, "getInt64"), (1, "getBoolean"),
            (2, "getOther"), (5, "setFloat64"), (4, "setPlausible"), (3, "setInt32"), (1, "setInt64"),
            (1, "setBoolean"), (2, "setOther"), (5, "getState"), (5, "setState"), (2, "freeState"),
            (4, "serialize"), (5, "deserialize"), (2, "reset"), (2, "terminate"), (1, "freeInstance"),
            (2, "instantiate"), (2, "setup"), (2, "enterInit"), (2, "exitInit"), (1, "enterStepMode"),
            (1, "debugLogging"), (3, "unsupported"), (1, "platform"),
        ]

    def dispatch(self, inst):
        other = ["String", "Float32", "Int8", "UInt8", "Int16", "UInt16", "UInt32", "UInt64"]
        return {
            "doStep": lambda: self.do_step(inst),
            "getFloat64": lambda: self.get_values(inst, "Float64"),
            "getInt32": lambda: self.get_values(inst, "Int32"),
            "getInt64": lambda: self.get_values(inst, "Int64"),
            "getBoolean": lambda: self.get_values(inst, "Boolean"),
            "getOther": lambda: self.get_values(inst, self.rng.choice(other)),
            "setFloat64": lambda: self.set_values(inst, "Float64"),
            "setPlausible": lambda: self.set_plausible(inst),
            "setInt32": lambda: self.set_values(inst, "Int32"),
            "setInt64": lambda: self.set_values(inst, "Int64"),
            "setBoolean": lambda: self.set_values(inst, "Boolean"),
            "setOther": lambda: self.set_values(inst, self.rng.choice(other)),
            "getState": lambda: self.get_state(inst),
            "setState": lambda: self.set_state(inst),
            "freeState": lambda: self.free_state(inst),
            "serialize": lambda: self.serialize(inst),
            "deserialize": lambda: self.deserialize(inst),
            "reset": lambda: self.simple(inst, "fmi3Reset", INSTANTIATED),
            "terminate": lambda: self.simple(inst, "fmi3Terminate", TERMINATED),
            "freeInstance": lambda: self.free_instance(inst),
            "setup": lambda: self.setup(inst),
            "enterInit": lambda: self.enter_init(inst),
            "exitInit": lambda: self.exit_init(inst),
            "enterStepMode": lambda: self.simple(inst, "fmi3EnterStepMode"),
            "debugLogging": lambda: self.debug_logging(inst),
            "unsupported": lambda: self.unsupported(inst),
        }


base.VERSIONS[3] = (Sequence3, load_slave3, FUNCTIONS3)

if __name__ == "__main__":
    base.main(fmi_version=3)
