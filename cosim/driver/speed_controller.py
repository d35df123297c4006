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

from xml.etree.ElementTree import SubElement

from pythonfmu import Fmi2Causality, Fmi2Variability, Real

try:  # in the FMU: beside this script
    from sampled_slave import SampledSlave, insert_unit_definitions, outputs_depend_on_no_input
except ImportError:  # in the source tree
    from cosim.sampled_slave import SampledSlave, insert_unit_definitions, outputs_depend_on_no_input

KMH = 1.0 / 3.6  # m/s per km/h

# name -> (causality, variability, start value, unit, display unit, description); the attribute
# of the same name holds the value.
VARIABLES = {
    "speed_set_point": (
        Fmi2Causality.input,
        Fmi2Variability.continuous,
        80.0 * KMH,
        "m/s",
        "km/h",
        "speed set point (the master may change it at any communication point)",
    ),
    "speed": (Fmi2Causality.input, Fmi2Variability.continuous, 80.0 * KMH, "m/s", "km/h", "measured speed of the vehicle"),
    "traction": (
        Fmi2Causality.output,
        Fmi2Variability.discrete,
        0.0,
        "N",
        None,
        "force demanded from the vehicle: > 0 traction, < 0 braking; set at each communication "
        "point from the inputs of the previous one",
    ),
    "kp": (
        Fmi2Causality.parameter,
        Fmi2Variability.fixed,
        80.0e3,
        "N.s/m",
        None,
        "proportional gain (force per m/s of speed error); must be >= 0",
    ),
    "ti": (Fmi2Causality.parameter, Fmi2Variability.fixed, 4.0, "s", None, "integral time; must be > 0"),
    "max_traction": (
        Fmi2Causality.parameter,
        Fmi2Variability.fixed,
        40.0e3,
        "N",
        None,
        "largest traction force; must be >= 0",
    ),
    "max_braking": (
        Fmi2Causality.parameter,
        Fmi2Variability.fixed,
        50.0e3,
        "N",
        None,
        "largest braking force (a magnitude); must be >= 0",
    ),
    "speed_error_integral": (
        Fmi2Causality.local,
        Fmi2Variability.continuous,
        0.0,
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


class SpeedController(SampledSlave):
    description = "PI speed controller with force limits and anti-windup (the driver of the rail vehicle)"

    def __init__(self, **kwargs):
        super().__init__("speed_controller", 40.0, 0.01, **kwargs)
        for name, (causality, variability, start, _, _, description) in VARIABLES.items():
            setattr(self, name, start)
            self.register_variable(
                Real(name, causality=causality, variability=variability, description=description)
            )

    def exit_initialization_mode(self):
        self.check_parameters(
            {
                "kp": self.kp >= 0.0,
                "ti": self.ti > 0.0,
                "max_traction": self.max_traction >= 0.0,
                "max_braking": self.max_braking >= 0.0,
            },
            {name: VARIABLES[name][5] for name in VARIABLES},
        )

    def do_step(self, current_time, step_size):
        if self.step_refused():
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
        insert_unit_definitions(root, UNITS)
        for variable in root.find("ModelVariables"):
            _, _, _, unit, display, _ = VARIABLES[variable.get("name")]
            real = variable.find("Real")
            real.set("unit", unit)
            if display:
                real.set("displayUnit", display)
        structure, outputs = outputs_depend_on_no_input(root)
        # The output's initial value (0 until the first step) depends on no input either.
        initial = SubElement(structure, "InitialUnknowns")
        for unknown in outputs:
            SubElement(initial, "Unknown", index=unknown.get("index"), dependencies="")
        return root
