"""What the pythonfmu FMUs of cosim/ share (the speed controller, the track irregularity):
`cosim/build_driver.py` packs this file into each FMU beside its script.

Both are sampled systems: `fmi2DoStep(t, h)` takes the inputs present at t and sets the outputs
for t + h, so no output depends directly on an input. Both check their parameters at the end of
initialisation and refuse every step after a failed check.
"""

import math
from xml.etree.ElementTree import Element, SubElement

from pythonfmu import Fmi2Slave
from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Status


class SampledSlave(Fmi2Slave):
    """The base of the cosim/ FMUs: their common attributes, the check of the parameters and the
    model description's units and output dependencies."""

    author = "contact-fmu contributors"
    license = "MIT"
    version = "1.0"
    copyright = "Copyright (c) contact-fmu contributors"

    def __init__(self, model_name, stop_time, step_size, **kwargs):
        """`kwargs`: pythonfmu's (instance name, resources...); the default experiment runs from
        0 to `stop_time` with communication steps `step_size` [s]."""
        super().__init__(**kwargs)
        self.modelName = model_name
        self.default_experiment = DefaultExperiment(start_time=0.0, stop_time=stop_time, step_size=step_size)

    def check_parameters(self, checks, descriptions):
        """Logs each parameter whose check (`checks`: name -> passed) failed or whose value is not
        finite as an error, `name = value: descriptions[name]`; every step is then refused
        (fmi2Discard). Not raised: pythonfmu turns a Python exception into fmi2Fatal, after which
        FMI allows no further call, not even fmi2FreeInstance. Returns whether all passed."""
        self.invalid = [
            f"{name} = {getattr(self, name)}: {descriptions[name]}"
            for name, ok in checks.items()
            if not ok or not math.isfinite(getattr(self, name))
        ]
        for message in self.invalid:
            self.log(message, Fmi2Status.error)
        return not self.invalid

    def step_refused(self):
        """Whether a step must be refused (a parameter failed its check); logs why."""
        if getattr(self, "invalid", None):
            self.log("no step with a parameter out of range: " + "; ".join(self.invalid), Fmi2Status.error)
            return True
        return False


def insert_unit_definitions(root, units):
    """Adds `UnitDefinitions` to the model description `root`: `units` maps a unit's name to the
    exponents of the SI base units and its display units (name, factor)."""
    definitions = Element("UnitDefinitions")
    for name, (exponents, displays) in units.items():
        unit = SubElement(definitions, "Unit", name=name)
        SubElement(unit, "BaseUnit", {k: str(v) for k, v in exponents.items()})
        for display, factor in displays:
            SubElement(unit, "DisplayUnit", name=display, factor=repr(factor))
    # UnitDefinitions follows CoSimulation in the FMI 2.0 schema.
    root.insert(list(root).index(root.find("CoSimulation")) + 1, definitions)


def outputs_depend_on_no_input(root):
    """Declares in the model description `root` that no output depends directly on an input;
    returns (ModelStructure, its Outputs)."""
    structure = root.find("ModelStructure")
    outputs = structure.find("Outputs")
    for unknown in outputs:
        unknown.set("dependencies", "")
    return structure, outputs
