"""Speed controller ("driver") of the rail vehicle, an FMI 2.0 Co-Simulation FMU built with
pythonfmu (`cosim/build_driver.py` makes `speed_controller.fmu` from this file).

A PI controller on the speed error with force limits and anti-windup:

    e = speed_set_point - speed                                   [m/s]
    traction = clamp(kp * (e + I / ti), -max_braking, max_traction)  [N]
    dI/dt = e, except while the output is saturated and e would drive it further out
    (conditional integration, the clamping form of anti-windup).

It is a sampled controller: `fmi2DoStep(t, h)` takes the inputs present at t, integrates I
over [t, t + h] (explicit Euler: I += e h) and sets the output `traction` for t + h, which the
master hands to the vehicle for its next step. So `traction` never depends directly on the
inputs (the model structure says `dependencies=""`): setting `speed` changes `traction` only
after the next step, and a loop vehicle -> driver -> vehicle is not algebraic.

Default gains for the bundled rail vehicle (43.6 t in total: car body 32 t, 4 bogie frames of
1.4 t, 8 wheels of 0.75 t; no running resistance, the only longitudinal force is `traction`):
kp = 80 kN per m/s (a proportional loop alone would have the time constant m / kp = 0.55 s),
ti = 4 s; the closed loop m s^2 + kp s + kp / ti = 0 has its poles at -0.3 and -1.5 1/s
(overdamped). Force limits: 40 kN of traction (0.92 m/s^2 at 43.6 t, the starting acceleration
of a regional train) and 50 kN of braking (1.15 m/s^2, a service brake).

Values are SI; the model description declares the units (the speeds display in km/h).
"""

import math
from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Status

KMH = 1.0 / 3.6  # m/s per km/h

# name -> (causality, variability, unit, display unit, description); the attribute of the same
# name holds the value.
VARIABLES = {
    "speed_set_point": (
        Fmi2Causality.input,
        Fmi2Variability.continuous,
        "m/s",
        "km/h",
        "speed set point (the master may change it at any communication point)",
    ),
    "speed": (Fmi2Causality.input, Fmi2Variability.continuous, "m/s", "km/h", "measured speed of the vehicle"),
    "traction": (
        Fmi2Causality.output,
        Fmi2Variability.discrete,
        "N",
        None,
        "force demanded from the vehicle: > 0 traction, < 0 braking; set at each communication "
        "point from the inputs of the previous one",
    ),
    "kp": (
        Fmi2Causality.parameter,
        Fmi2Variability.fixed,
        "N.s/m",
        None,
        "proportional gain (force per m/s of speed error); must be >= 0",
    ),
    "ti": (Fmi2Causality.parameter, Fmi2Variability.fixed, "s", None, "integral time; must be > 0"),
    "max_traction": (
        Fmi2Causality.parameter,
        Fmi2Variability.fixed,
        "N",
        None,
        "largest traction force; must be >= 0",
    ),
    "max_braking": (
        Fmi2Causality.parameter,
        Fmi2Variability.fixed,
        "N",
        None,
        "largest braking force (a magnitude); must be >= 0",
    ),
    "speed_error_integral": (
        Fmi2Causality.local,
        Fmi2Variability.continuous,
        "m",
        None,
        "integral of the speed error, the controller's state I",
    ),
}

# unit -> exponents of the SI base units, and its display units (name, factor, offset)
UNITS = {
    "m": ({"m": 1}, []),
    "m/s": ({"m": 1, "s": -1}, [("km/h", 1.0 / 3.6)]),
    "N": ({"kg": 1, "m": 1, "s": -2}, [("kN", 1000.0)]),
    "N.s/m": ({"kg": 1, "s": -1}, []),
    "s": ({"s": 1}, []),
}


def pi_step(kp, ti, max_traction, max_braking, integral, error, h):
    """One step of the controller: returns (new integral, output at the end of the step)."""
    candidate = integral + error * h
    demand = kp * (error + candidate / ti)
    # Conditional integration: do not integrate further into a saturated output.
    if (demand > max_traction and error > 0.0) or (demand < -max_braking and error < 0.0):
        candidate = integral
    output = kp * (error + candidate / ti)
    return candidate, min(max(output, -max_braking), max_traction)


class SpeedController(Fmi2Slave):
    author = "contact-fmu contributors"
    description = "PI speed controller with force limits and anti-windup (the driver of the rail vehicle)"
    license = "MIT"
    version = "1.0"
    copyright = "Copyright (c) contact-fmu contributors"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.modelName = "speed_controller"
        self.default_experiment = DefaultExperiment(start_time=0.0, stop_time=40.0, step_size=0.01)
        self.speed_set_point = 80.0 * KMH
        self.speed = 80.0 * KMH
        self.traction = 0.0
        self.kp = 80.0e3
        self.ti = 4.0
        self.max_traction = 40.0e3
        self.max_braking = 50.0e3
        self.speed_error_integral = 0.0
        for name, (causality, variability, _, _, description) in VARIABLES.items():
            self.register_variable(
                Real(name, causality=causality, variability=variability, description=description)
            )

    def exit_initialization_mode(self):
        # A parameter out of range is logged as an error, and every step is then refused
        # (fmi2Discard). Not raised: pythonfmu turns a Python exception into fmi2Fatal, after
        # which FMI allows no further call, not even fmi2FreeInstance.
        checks = {
            "kp": self.kp >= 0.0,
            "ti": self.ti > 0.0,
            "max_traction": self.max_traction >= 0.0,
            "max_braking": self.max_braking >= 0.0,
        }
        self.invalid = [
            f"{name} = {getattr(self, name)}: {VARIABLES[name][4]}"
            for name, ok in checks.items()
            if not ok or not math.isfinite(getattr(self, name))
        ]
        for message in self.invalid:
            self.log(message, Fmi2Status.error)

    def do_step(self, current_time, step_size):
        if getattr(self, "invalid", None):
            self.log("no step with a parameter out of range: " + "; ".join(self.invalid), Fmi2Status.error)
            return False
        self.speed_error_integral, self.traction = pi_step(
            self.kp,
            self.ti,
            self.max_traction,
            self.max_braking,
            self.speed_error_integral,
            self.speed_set_point - self.speed,
            step_size,
        )
        return True

    def to_xml(self, model_options=None):
        """pythonfmu's model description, completed with the units, the display units and the
        dependencies of the output (none: see the module's docstring)."""
        root = super().to_xml(model_options or {})
        units = Element("UnitDefinitions")
        for name, (exponents, displays) in UNITS.items():
            unit = SubElement(units, "Unit", name=name)
            SubElement(unit, "BaseUnit", {k: str(v) for k, v in exponents.items()})
            for display, factor in displays:
                SubElement(unit, "DisplayUnit", name=display, factor=repr(factor))
        # UnitDefinitions follows CoSimulation in the FMI 2.0 schema.
        position = list(root).index(root.find("CoSimulation")) + 1
        root.insert(position, units)
        for variable in root.find("ModelVariables"):
            _, _, unit, display, _ = VARIABLES[variable.get("name")]
            real = variable.find("Real")
            real.set("unit", unit)
            if display:
                real.set("displayUnit", display)
        structure = root.find("ModelStructure")
        outputs = structure.find("Outputs")
        for unknown in outputs:
            unknown.set("dependencies", "")
        # The output's initial value (0 until the first step) depends on no input either.
        initial = SubElement(structure, "InitialUnknowns")
        for unknown in outputs:
            SubElement(initial, "Unknown", index=unknown.get("index"), dependencies="")
        return root
