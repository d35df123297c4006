"""Runs an SSP system (`.ssp` or `.ssd`) with fmpy: a fixed-step co-simulation master of the
Jacobi type.

    .venv/bin/python -m cosim.run_system SYSTEM.ssp [--scenario cosim/system/set_point_step.json]
        [--step H] [--stop-time T] [--csv OUT.csv] [--output driver.traction ...]

The master, at each communication point t_k = t_0 + k h (k counted in whole nanoseconds, as
libcosim counts time, so that both masters hand the FMUs the same times):

1. applies the scenario's events due at t_k (an `override` sets an input until the next one);
2. reads every connected output of every FMU;
3. records the requested variables, as they are before the inputs of t_k are set (the values at
   the end of the step that reached t_k: what libcosim's observer records, so that the two masters
   give the same numbers also for inputs and for outputs that depend directly on inputs);
4. sets every connected input (Jacobi: all FMUs see the outputs of t_k, whatever their order);
5. steps every FMU from t_k to t_k+1 (`fmi2DoStep` with the step t_k+1 - t_k, which is h up
   to rounding: the FMUs land on t_k+1 exactly and time does not drift; libcosim does the same).

Jacobi rather than Gauss-Seidel because it is what libcosim's fixed-step algorithm does, so
the two engines run the same algorithm and their results can be compared number for number.
Before running, the master looks for algebraic loops (`cosim.ssp.algebraic_loops`: cycles of
connections and of the outputs' declared direct dependencies on inputs) and refuses a system
that has one. Initialisation: enter initialisation mode, set the parameter values of the SSD's first
parameter set, propagate the connected values (as libcosim does: one pass of reading every
connected output and setting the inputs per FMU of the system), exit initialisation mode; the
first exchange of the loop happens at t_0, before the first step. The step h is `--step`, else the SSD's `osp:FixedStepAlgorithm baseStepSize`.
"""

import argparse
import csv
import sys
import tempfile
from pathlib import Path

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from cosim import pythonfmu_exit  # noqa: E402
    from cosim.ssp import SCENARIO, algebraic_loops, event_step, read_scenario, read_system  # noqa: E402
else:
    from . import pythonfmu_exit
    from .ssp import SCENARIO, algebraic_loops, event_step, read_scenario, read_system


class Slave:
    """One FMU of the system: its description, its instance, its variables by name."""

    def __init__(self, name, fmu, workdir):
        self.name = name
        self.md = read_model_description(str(fmu))
        self.unzipdir = extract(str(fmu), unzipdir=str(Path(workdir) / name))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.fmu = FMU2Slave(
            guid=self.md.guid,
            unzipDirectory=self.unzipdir,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName=name,
        )

    def set_parameter(self, name, value):
        """Sets a Real or an Integer variable (a parameter of the SSD's parameter set)."""
        v = self.vars[name]
        if v.type == "Integer":
            self.fmu.setInteger([v.valueReference], [value])
        elif v.type == "Real":
            self.fmu.setReal([v.valueReference], [value])
        else:
            raise ValueError(f"{self.name}.{name}: only Real and Integer parameters are set, not {v.type}")

    def vr(self, name):
        v = self.vars[name]
        if v.type != "Real":
            raise ValueError(f"{self.name}.{name}: only Real variables are exchanged, not {v.type}")
        return v.valueReference


def batches(pairs):
    """Groups (slave, value reference) pairs by slave, keeping their order: a list of (slave,
    value references, positions in the original sequence)."""
    groups = {}
    for position, (slave, vr) in enumerate(pairs):
        group = groups.setdefault(slave.name, (slave, [], []))
        group[1].append(vr)
        group[2].append(position)
    return list(groups.values())


def read(groups):
    """The Real values of `batches(...)`, in the original order."""
    values = [None] * sum(len(positions) for _, _, positions in groups)
    for slave, vrs, positions in groups:
        for position, value in zip(positions, slave.fmu.getReal(vrs)):
            values[position] = value
    return values


def write(groups, values):
    """Sets the Real inputs of `batches(...)` to `values` (in the original order)."""
    for slave, vrs, positions in groups:
        slave.fmu.setReal(vrs, [values[position] for position in positions])


def free(fmu, md):
    """Frees an FMU2Slave's instance. An FMU made by pythonfmu keeps its library loaded (its
    own thread holds it; fmpy's `freeInstance` would try to unload it), and its interpreter
    state is reset at once (`cosim.pythonfmu_exit`: otherwise the process may abort at exit)."""
    if (md.generationTool or "").startswith("PythonFMU"):
        fmu.fmi2FreeInstance(fmu.component)
        pythonfmu_exit.settle()
    else:
        fmu.freeInstance()


def run(system_path, scenario=SCENARIO, step=None, stop_time=None, outputs=(), workdir=None):
    """Runs the system; returns {"time": [...], "<component>.<variable>": [...]} at every
    communication point (t_0 ... t_n), with every connected variable and `outputs`."""
    with tempfile.TemporaryDirectory(prefix="cosim_") as tmp:
        workdir = Path(workdir or tmp)
        system = read_system(system_path, workdir / "ssp" if str(system_path).endswith(".ssp") else None)
        loops = algebraic_loops(system)
        if loops:
            raise ValueError(
                "algebraic loop (outputs that depend directly on inputs, in a cycle): "
                + "; ".join(" -> ".join(loop) for loop in loops)
                + ". A Jacobi master would break it with a delay of one step, changing the model."
            )
        h = step or system.step_size
        t_stop = stop_time if stop_time is not None else system.stop_time
        h_ns = round(h * 1e9)
        n = round((t_stop - system.start_time) * 1e9) // h_ns
        events, _ = read_scenario(scenario) if scenario else ([], None)
        due = {}
        for e in events:
            due.setdefault(event_step(e.time, system.start_time, h), []).append(e)

        slaves = {name: Slave(name, c.fmu, workdir / "fmus") for name, c in system.components.items()}
        links = [
            (slaves[c.start_element], slaves[c.start_element].vr(c.start_connector),
             slaves[c.end_element], slaves[c.end_element].vr(c.end_connector))
            for c in system.connections
        ]
        recorded = []  # (slave, vr, column)
        for c in system.connections:
            for element, connector in ((c.start_element, c.start_connector), (c.end_element, c.end_connector)):
                recorded.append((slaves[element], slaves[element].vr(connector), f"{element}.{connector}"))
        for name in outputs:
            element, variable = name.split(".", 1)
            recorded.append((slaves[element], slaves[element].vr(variable), name))
        recorded = list({column: (s, vr, column) for s, vr, column in recorded}.values())
        # One fmi2GetReal per FMU for the connected outputs, one for the recorded variables, one
        # fmi2SetReal per FMU for the connected inputs (a system may have dozens of connections).
        reads = batches((src, vr) for src, vr, _, _ in links)
        writes = batches((dst, dst_vr) for _, _, dst, dst_vr in links)
        samples = batches((s, vr) for s, vr, _ in recorded)

        try:
            for name, s in slaves.items():
                s.fmu.instantiate()
                s.fmu.setupExperiment(startTime=system.start_time, stopTime=t_stop)
                s.fmu.enterInitializationMode()
                for p, value in system.components[name].parameters.items():
                    s.set_parameter(p, value)
            # As libcosim: in initialisation mode, as many passes of value propagation (connected
            # outputs to inputs) as there are FMUs.
            for _ in slaves:
                write(writes, read(reads))
            for s in slaves.values():
                s.fmu.exitInitializationMode()

            result = {"time": []}
            result.update({column: [] for _, _, column in recorded})
            for k in range(n + 1):
                t = system.start_time + (k * h_ns) / 1e9
                for e in due.get(k, []):
                    slaves[e.model].fmu.setReal([slaves[e.model].vr(e.variable)], [e.value])
                values = read(reads)
                result["time"].append(t)
                for (_, _, column), value in zip(recorded, read(samples)):
                    result[column].append(value)
                write(writes, values)
                if k < n:
                    # Step to exactly t_k+1 (h_k = t_k+1 - t_k is h up to rounding), as libcosim does.
                    h_k = (system.start_time + ((k + 1) * h_ns) / 1e9) - t
                    for s in slaves.values():
                        s.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h_k)
            for s in slaves.values():
                s.fmu.terminate()
        finally:
            for s in slaves.values():
                free(s.fmu, s.md)
        return result


def write_csv(result, path):
    columns = list(result)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(columns)
        for row in zip(*(result[c] for c in columns)):
            w.writerow([repr(x) for x in row])


def command_line(doc, with_step):
    """The arguments both runners take."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("system", help=".ssp archive or .ssd file")
    parser.add_argument("--scenario", default=str(SCENARIO), help="scenario file (libcosim JSON); '' for none")
    if with_step:
        parser.add_argument("--step", type=float, help="communication step [s] (default: the SSD's)")
    parser.add_argument("--stop-time", type=float, help="stop time [s] (default: the SSD's)")
    parser.add_argument("--output", action="append", default=[], help="another variable to record: component.variable")
    parser.add_argument("--csv", help="write the results to this CSV file")
    return parser


def report(result, csv_path):
    """Writes the CSV when asked; prints the last values."""
    if csv_path:
        write_csv(result, csv_path)
    t = result["time"]
    print(f"{len(t)} communication points, t = {t[0]} ... {t[-1]} s; last values:")
    for column in list(result)[1:]:
        print(f"{column:>24} = {result[column][-1]:.9g}")


def main():
    args = command_line(__doc__, with_step=True).parse_args()
    report(run(args.system, args.scenario or None, args.step, args.stop_time, args.output), args.csv)


if __name__ == "__main__":
    main()
