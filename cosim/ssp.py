"""The system structure (SSP 1.0) of a co-simulation: reading an `.ssd`, packing an `.ssp`, and
the set-point scenario.

An `.ssp` is a zip holding `SystemStructure.ssd` and the FMUs it names (`source` relative to the
archive's root). `read_system` takes either an `.ssp` (extracted into a directory) or an `.ssd`.
"""

import argparse
import json
import math
import shutil
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree

ROOT = Path(__file__).resolve().parents[1]
SYSTEM_DIR = ROOT / "cosim" / "system"
SSD = SYSTEM_DIR / "SystemStructure.ssd"
SCENARIO = SYSTEM_DIR / "set_point_step.json"

NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
}


@dataclass
class Component:
    name: str
    fmu: Path  # absolute path of the FMU file
    connectors: dict = field(default_factory=dict)  # name -> kind
    parameters: dict = field(default_factory=dict)  # name -> float or int (the first parameter set)


@dataclass
class Connection:
    start_element: str
    start_connector: str
    end_element: str
    end_connector: str


@dataclass
class System:
    name: str
    components: dict  # name -> Component, in document order
    connections: list
    start_time: float
    stop_time: float
    step_size: float  # the OSP FixedStepAlgorithm's baseStepSize, or None


def read_system(path, workdir=None):
    """Reads an `.ssd`, or an `.ssp` extracted into `workdir` (required then)."""
    path = Path(path)
    if path.suffix == ".ssp":
        if workdir is None:
            raise ValueError("an .ssp needs a directory to be extracted into")
        with zipfile.ZipFile(path) as z:
            z.extractall(workdir)
        path = Path(workdir) / "SystemStructure.ssd"
    root = ElementTree.parse(path).getroot()
    system = root.find("ssd:System", NS)
    components = {}
    for element in system.find("ssd:Elements", NS):
        if element.tag != f"{{{NS['ssd']}}}Component":
            raise ValueError(f"{path}: only Components are supported as elements, not {element.tag}")
        c = Component(name=element.get("name"), fmu=(path.parent / element.get("source")).resolve())
        for connector in element.iterfind("ssd:Connectors/ssd:Connector", NS):
            c.connectors[connector.get("name")] = connector.get("kind")
        sets = element.findall("ssd:ParameterBindings/ssd:ParameterBinding/ssd:ParameterValues/ssv:ParameterSet", NS)
        if sets:  # as libcosim: the first set gives the initial values
            for parameter in sets[0].iterfind("ssv:Parameters/ssv:Parameter", NS):
                real, integer = parameter.find("ssv:Real", NS), parameter.find("ssv:Integer", NS)
                if real is not None:
                    c.parameters[parameter.get("name")] = float(real.get("value"))
                elif integer is not None:
                    c.parameters[parameter.get("name")] = int(integer.get("value"))
                else:
                    raise ValueError(f"{path}: parameter {parameter.get('name')}: only Real and Integer values are supported")
        components[c.name] = c
    connections = []
    for connection in system.iterfind("ssd:Connections/ssd:Connection", NS):
        conn = Connection(
            connection.get("startElement"),
            connection.get("startConnector"),
            connection.get("endElement"),
            connection.get("endConnector"),
        )
        for element, connector in ((conn.start_element, conn.start_connector), (conn.end_element, conn.end_connector)):
            if connector not in components[element].connectors:
                raise ValueError(f"{path}: connection names {element}.{connector}, which is not a declared connector")
        connections.append(conn)
    experiment = root.find("ssd:DefaultExperiment", NS)
    fixed = root.find(".//osp:FixedStepAlgorithm", NS)
    return System(
        name=root.get("name"),
        components=components,
        connections=connections,
        start_time=float(experiment.get("startTime", 0.0)),
        stop_time=float(experiment.get("stopTime")),
        step_size=float(fixed.get("baseStepSize")) if fixed is not None else None,
    )


def pack_ssp(output, fmus, ssd=SSD):
    """Writes the `.ssp` archive `output`: `ssd` as `SystemStructure.ssd` and each FMU of
    `fmus` (the name of its `source` in the SSD, e.g. `resources/rail_vehicle.fmu` -> a file)."""
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(output, "w", zipfile.ZIP_DEFLATED) as z:
        z.write(ssd, "SystemStructure.ssd")
        for source, fmu in fmus.items():
            z.write(fmu, source)
    return output


def pack_command(description, build, vehicle, other, output):
    """The command line of a script that packs the vehicle FMU with one `other` FMU into an
    `.ssp`: `--vehicle`, `--<other>` and `-o`, handed to `build(output, vehicle, other)`."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--vehicle", type=Path, default=vehicle)
    parser.add_argument(f"--{other}", type=Path)
    parser.add_argument("-o", "--output", type=Path, default=output)
    args = parser.parse_args()
    print(f"wrote {build(args.output, args.vehicle, getattr(args, other))}")


def unpack_ssd_dir(directory, fmus, ssd=SSD):
    """Lays the system out as a directory (the same files as the `.ssp`, unzipped)."""
    directory = Path(directory)
    (directory / "resources").mkdir(parents=True, exist_ok=True)
    shutil.copy(ssd, directory / "SystemStructure.ssd")
    for source, fmu in fmus.items():
        shutil.copy(fmu, directory / source)
    return directory / "SystemStructure.ssd"


@dataclass
class Event:
    time: float
    model: str
    variable: str
    value: float


def read_scenario(path=SCENARIO):
    """The `override` events of a scenario file in the format of libcosim's scenario manager
    (JSON), sorted by time; the scenario's end time."""
    data = json.loads(Path(path).read_text())
    defaults = data.get("defaults", {})
    events = []
    for e in data["events"]:
        action = e.get("action", defaults.get("action"))
        if action != "override":
            raise ValueError(f"{path}: only 'override' actions are supported, not {action!r}")
        events.append(
            Event(
                float(e["time"]),
                e.get("model", defaults.get("model")),
                e.get("variable", defaults.get("variable")),
                float(e["value"]),
            )
        )
    events.sort(key=lambda e: e.time)
    end = data.get("end")
    return events, (float(end) if end is not None else math.inf)


def event_step(event_time, start_time, step_size):
    """Index k of the first communication point t_k = start + k h at or after `event_time`,
    counted as libcosim counts it: in whole nanoseconds."""
    h_ns = round(step_size * 1e9)
    dt_ns = round((event_time - start_time) * 1e9)
    return -(-dt_ns // h_ns)


def direct_feedthrough(fmu):
    """output name -> the input names on which it depends directly (FMI 2.0
    `ModelStructure/Outputs`); an `Unknown` without a `dependencies` attribute depends on every
    input, as the standard says."""
    with zipfile.ZipFile(fmu) as z:
        root = ElementTree.fromstring(z.read("modelDescription.xml"))
    variables = list(root.find("ModelVariables"))
    inputs = {v.get("name") for v in variables if v.get("causality") == "input"}
    feedthrough = {}
    for unknown in root.iterfind("ModelStructure/Outputs/Unknown"):
        output = variables[int(unknown.get("index")) - 1].get("name")
        dependencies = unknown.get("dependencies")
        if dependencies is None:
            feedthrough[output] = set(inputs)
        else:
            names = {variables[int(i) - 1].get("name") for i in dependencies.split()}
            feedthrough[output] = names & inputs
    return feedthrough


def algebraic_loops(system, feedthrough=None):
    """The algebraic loops of a system: cycles of connections and direct feedthroughs
    (input -> output of one FMU), each as a list of "component.variable". `feedthrough`:
    component -> `direct_feedthrough` of its FMU (read from the FMUs when not given)."""
    if feedthrough is None:
        feedthrough = {name: direct_feedthrough(c.fmu) for name, c in system.components.items()}
    edges = {}
    for c in system.connections:
        edges.setdefault(f"{c.start_element}.{c.start_connector}", []).append(f"{c.end_element}.{c.end_connector}")
    for component, outputs in feedthrough.items():
        for output, inputs in outputs.items():
            for i in inputs:
                edges.setdefault(f"{component}.{i}", []).append(f"{component}.{output}")
    loops, state = [], {}  # state: 1 on the current path, 2 done

    def visit(node, path):
        state[node] = 1
        path.append(node)
        for nxt in edges.get(node, []):
            if state.get(nxt) == 1:
                loops.append(path[path.index(nxt):] + [nxt])
            elif nxt not in state:
                visit(nxt, path)
        path.pop()
        state[node] = 2

    for node in list(edges):
        if node not in state:
            visit(node, [])
    return loops
