"""Runs an SSP system in libcosim, the co-simulation engine of the Open Simulation Platform,
through its Python binding libcosimpy.

    .venv/bin/python -m cosim.run_libcosim SYSTEM.ssp [--scenario cosim/system/set_point_step.json]
        [--stop-time T] [--csv OUT.csv] [--output driver.traction ...]

libcosim loads the `.ssp` itself (components, connectors, connections, the first parameter
set as initial values, the step of the `osp:FixedStepAlgorithm` annotation) and runs its
fixed-step algorithm: at each step every FMU steps from t_k to t_k+1 (in parallel threads), then
the outputs are transferred to the connected inputs, which the FMUs get before the next step
(Jacobi). The scenario file is given to libcosim's scenario manager, which applies an event due
at t_k before the step from t_k. A time-series observer records the connected variables.
"""

import sys
import tempfile
from pathlib import Path

from libcosimpy.CosimEnums import CosimVariableType
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimManipulator import CosimManipulator
from libcosimpy.CosimObserver import CosimObserver

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from cosim import pythonfmu_exit  # noqa: E402
    from cosim.run_system import command_line, report  # noqa: E402
    from cosim.ssp import SCENARIO, read_system  # noqa: E402
else:
    from . import pythonfmu_exit
    from .run_system import command_line, report
    from .ssp import SCENARIO, read_system


def samples(observer, index, vr, n):
    """Steps 0 ... n of a time series. libcosimpy trims the arrays it returns by the number of
    zero step numbers in them, which drops one sample whenever step 0 is asked for: ask for
    step 0 (with step 1) and for steps 1 ... n apart."""
    t0, s0, v0 = observer.time_series_real_samples(index, vr, from_step=0, sample_count=2)
    t, s, v = observer.time_series_real_samples(index, vr, from_step=1, sample_count=n)
    if list(s0[:1]) != [0] or list(s) != list(range(1, n + 1)):
        raise RuntimeError(f"the observer has not every step 0 ... {n}")
    return t0[:1] + t, s0[:1] + s, v0[:1] + v


def run(system_path, scenario=SCENARIO, stop_time=None, outputs=(), log_level=CosimLogLevel.WARNING):
    """Runs the system; returns {"time": [...], "<component>.<variable>": [...]} at every
    communication point t_0 ... t_n (t_0: the values after initialisation)."""
    log_output_level(log_level)
    with tempfile.TemporaryDirectory(prefix="cosim_ssd_") as tmp:
        # Our own reading of the SSD only names the variables to record and the stop time.
        system = read_system(system_path, tmp if str(system_path).endswith(".ssp") else None)
    t_stop = stop_time if stop_time is not None else system.stop_time
    h_ns = round(system.step_size * 1e9)
    n = round((t_stop - system.start_time) * 1e9) // h_ns

    execution = CosimExecution.from_ssp_file(str(system_path))
    columns = []
    for c in system.connections:
        columns += [f"{c.start_element}.{c.start_connector}", f"{c.end_element}.{c.end_connector}"]
    columns = list(dict.fromkeys(columns + list(outputs)))

    observer = CosimObserver.create_time_series(buffer_size=n + 1)
    execution.add_observer(observer)
    observed = []
    for column in columns:
        element, variable = column.split(".", 1)
        index = execution.slave_index_from_instance_name(element)
        if index is None:
            raise ValueError(f"no component {element!r} in the execution")
        refs = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
        observer.start_time_series(index, refs[variable], CosimVariableType.REAL)
        observed.append((index, refs[variable], column))
    if scenario:
        manipulator = CosimManipulator.create_scenario_manager()
        execution.add_manipulator(manipulator)
        if not execution.load_scenario(manipulator, str(scenario)):
            raise RuntimeError(f"libcosim did not load the scenario {scenario}")

    if not execution.simulate_until(round(t_stop * 1e9)):
        raise RuntimeError("libcosim stopped before the stop time")
    status = execution.status()
    result = {}
    for index, vr, column in observed:
        times, steps, values = samples(observer, index, vr, n)
        if "time" not in result:
            result["time"] = [t / 1e9 for t in times]
            result["step"] = list(steps)
        elif list(steps) != result["step"]:
            raise RuntimeError(f"{column}: samples at other steps than the others")
        result[column] = list(values)
    result.pop("step")
    result["status"] = status
    pythonfmu_exit.settle()  # while the execution still holds the driver's library
    return result


def main():
    args = command_line(__doc__, with_step=False).parse_args()
    result = run(args.system, args.scenario or None, args.stop_time, args.output)
    status = result.pop("status")
    print(f"libcosim: execution state {status.state}, error code {status.error_code}")
    report(result, args.csv)


if __name__ == "__main__":
    main()
