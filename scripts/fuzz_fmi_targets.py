"""What the FMI call fuzzer (scripts/fuzz_fmi.py) calls and with what: the FMI 2.0 functions,
the shadow states of the FMI state machine, the special values and step sizes drawn, an FMU's
variables as the sequences use them (`FmuInfo`) and the library loader.
"""

import os
import urllib.parse
import zipfile
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
