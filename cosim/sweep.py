"""Parameter studies of an FMU on dask.distributed: one FMU run per point of a parameter grid,
the results gathered into one CSV table and a plot.

    .venv/bin/python -m cosim.sweep FMU --param NAME=V1,V2,... [--param ...] --output NAME [...]
        [--stop-time T] [--step H] [--workers N | --scheduler tcp://HOST:8786]
        [--csv OUT.csv] [--plot OUT.png [--plot-y COLUMN]] [--serial] [--batch N]

- `--param NAME=...`: values of a parameter (or input) set before initialisation ends; NAME may
  hold shell-style wildcards (`susp_*.damping`) to give every matching variable the same value.
  The grid is the Cartesian product of all `--param`s, the first varying slowest.
- `--output NAME`: a Real or Integer variable; the table has its value at the stop time and its
  least and largest value over the communication points (`min(NAME)`, `max(NAME)`).
- `--stop-time`, `--step` (communication step): default the FMU's default experiment.
- `--workers N` starts a `LocalCluster` of N worker processes (one thread each) on this
  machine; `--scheduler ADDRESS` uses a running cluster (`dask scheduler` and
  `dask worker ADDRESS` on its machines, each with fmpy installed); `--serial` runs every case
  in this process, without dask.
- `--batch N`: cases per dask task (default: the cases split into two tasks per worker). A task
  runs its cases one after the other in one FMU instance, reset by fmi2Reset between them, so
  dask's cost per task is paid once per batch.

The FMU is sent to each worker once (a worker plugin) and unpacked there once, in the worker's
local directory; every task then instantiates it from that directory once for its batch of cases
(no zip is opened per case). The workers need fmpy and numpy, not this repository: the functions travel by value.
docs/sweeps.md has an example, the speed-up measured on this machine and the cluster setup.
"""

import argparse
import csv
import fnmatch
import hashlib
import itertools
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave


# Tasks per worker by default (cosim.sweep.batch_size): each task is a batch of cases run in one
# FMU instance, so dask's cost per task (scheduling, transfer, the instance) is paid per batch;
# two batches per worker leave the scheduler room to even out cases of unequal cost.
BATCHES_PER_WORKER = 2


class FmuRunner:
    """An FMU unpacked once into `directory`; `run` makes one case (one instance)."""

    def __init__(self, fmu, directory):
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(fmu) as z:
            z.extractall(directory)
        self.extractions = 1
        self.directory = directory
        self.md = read_model_description(str(directory))
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.slave = FMU2Slave(
            guid=self.md.guid,
            unzipDirectory=str(directory),
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName="sweep",
        )

    def names(self, pattern):
        """The variables a `--param` name stands for."""
        found = [n for n in self.vars if fnmatch.fnmatchcase(n, pattern)]
        if not found:
            raise KeyError(f"no variable matches {pattern!r}")
        return found

    def run(self, case, outputs, stop_time=None, step=None):
        """Runs one case (parameter name or pattern -> value) in an instance of its own; returns
        the row of the table: the case, then for each output its value at the stop time, its
        min and max."""
        return self.run_batch([case], outputs, stop_time, step)[0]

    def run_batch(self, cases, outputs, stop_time=None, step=None):
        """Runs the cases one after the other in one instance, brought back to its state after
        instantiation by fmi2Reset between them (which gives the numbers of a fresh instance);
        returns their rows."""
        s = self.slave
        s.instantiate()
        try:
            rows = []
            for k, case in enumerate(cases):
                if k > 0:
                    s.reset()
                rows.append(self._simulate(case, outputs, stop_time, step))
            return rows
        finally:
            # fmi2FreeInstance alone: fmpy's freeInstance also unloads the library, which the
            # next case would then call into.
            s.fmi2FreeInstance(s.component)

    def _simulate(self, case, outputs, stop_time, step):
        """One case in the instantiated (or reset) instance, up to fmi2Terminate."""
        de = self.md.defaultExperiment
        stop_time = stop_time if stop_time is not None else float(de.stopTime)
        step = step if step is not None else float(de.stepSize)
        n = round(stop_time / step)
        outs = [self.vars[name] for name in outputs]
        reals = [v.valueReference for v in outs if v.type == "Real"]
        ints = [v.valueReference for v in outs if v.type != "Real"]
        order = [("r", reals.index(v.valueReference)) if v.type == "Real" else ("i", ints.index(v.valueReference)) for v in outs]
        s = self.slave
        s.setupExperiment(startTime=0.0, stopTime=stop_time)
        s.enterInitializationMode()
        for pattern, value in case.items():
            for name in self.names(pattern):
                v = self.vars[name]
                if v.type == "Real":
                    s.setReal([v.valueReference], [float(value)])
                elif v.type in ("Integer", "Enumeration"):
                    s.setInteger([v.valueReference], [int(value)])
                else:
                    s.setBoolean([v.valueReference], [bool(value)])
        s.exitInitializationMode()
        samples = np.empty((n + 1, len(outs)))

        def sample(k):
            r = s.getReal(reals) if reals else []
            i = s.getInteger(ints) if ints else []
            samples[k] = [r[j] if kind == "r" else i[j] for kind, j in order]

        sample(0)
        for k in range(n):
            # The communication points are k * step, computed so, not accumulated.
            s.doStep(currentCommunicationPoint=k * step, communicationStepSize=(k + 1) * step - k * step)
            sample(k + 1)
        s.terminate()
        row = dict(case)
        for j, name in enumerate(outputs):
            row[name] = float(samples[-1, j])
            row[f"min({name})"] = float(samples[:, j].min())
            row[f"max({name})"] = float(samples[:, j].max())
        return row


def grid(params):
    """The cases of a grid {name: [values]}: the Cartesian product, the first name slowest."""
    names = list(params)
    return [dict(zip(names, values)) for values in itertools.product(*(params[n] for n in names))]


def run_serial(fmu, cases, outputs, stop_time=None, step=None, directory=None):
    """Every case in this process, from one unpacked copy of the FMU."""
    with tempfile.TemporaryDirectory(prefix="sweep_") as tmp:
        runner = FmuRunner(fmu, directory or Path(tmp) / "fmu")
        return [runner.run(case, outputs, stop_time, step) for case in cases]


def _plugin_class():
    from distributed.diagnostics.plugin import WorkerPlugin

    class UnpackFmu(WorkerPlugin):
        """Holds the FMU's bytes; unpacks them once on each worker, into its local directory.
        Idempotent: registering it again (another sweep of the same FMU, whose hash is in the
        name) changes nothing, so an FMU whose library is loaded is never unpacked over."""

        idempotent = True

        def __init__(self, name, data):
            self.name = name
            self.data = data
            self.runner = None

        def setup(self, worker):
            directory = Path(worker.local_directory) / self.name
            directory.mkdir(parents=True, exist_ok=True)
            fmu = directory / "model.fmu"
            fmu.write_bytes(self.data)
            self.runner = FmuRunner(fmu, directory / "unzipped")

    return UnpackFmu


def _run_on_worker(plugin_name, cases, outputs, stop_time, step):
    from distributed import get_worker

    return get_worker().plugins[plugin_name].runner.run_batch(cases, outputs, stop_time, step)


def plugin_name(fmu):
    return "fmu-" + hashlib.sha256(Path(fmu).read_bytes()).hexdigest()[:16]


# The FMUs registered with each client, by client id and plugin name (a hash of the FMU's
# bytes): a client's further sweeps of the same FMU do not send its bytes again.
_prepared = set()


def prepare(client, fmu):
    """Sends the FMU to every worker of `client` (now and joining later), unpacked once there
    for the life of the worker; returns the plugin's name. Functions of this module travel by
    value, so the workers need not have this repository. Once per client and FMU: sending the
    2.3 MB FMU through the scheduler at every call took about 10 % of a 24-case sweep of the
    rail vehicle (0.13 s); the name is still a hash of the file's contents, so a changed FMU is
    always sent."""
    import cloudpickle

    name = plugin_name(fmu)
    if (client.id, name) in _prepared:
        return name
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    client.register_plugin(_plugin_class()(name, Path(fmu).read_bytes()), name=name)
    _prepared.add((client.id, name))
    return name


def batches(cases, size):
    """The cases in consecutive batches of `size` (the last may be shorter)."""
    return [cases[i : i + size] for i in range(0, len(cases), size)]


def batch_size(n_cases, n_workers, per_worker=BATCHES_PER_WORKER):
    """Cases per task: `per_worker` batches for each worker (at least one case each)."""
    return max(1, -(-n_cases // max(1, n_workers * per_worker)))


def run_dask(client, fmu, cases, outputs, stop_time=None, step=None, show_progress=False, batch=None):
    """Every case on the workers of `client`, in tasks of `batch` consecutive cases (default
    [`batch_size`] for the workers there now), each run in one instance that fmi2Reset brings
    back between its cases; rows in the order of `cases`."""
    from distributed import progress

    name = prepare(client, fmu)
    size = batch or batch_size(len(cases), len(client.scheduler_info()["workers"]))
    futures = [
        client.submit(_run_on_worker, name, part, outputs, stop_time, step, pure=False)
        for part in batches(cases, size)
    ]
    if show_progress:
        progress(futures)
    return [row for part in client.gather(futures) for row in part]


def write_csv(rows, path):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    columns = list(rows[0])
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(columns)
        for row in rows:
            w.writerow([repr(row[c]) for c in columns])


def plot(rows, params, y, path):
    """`y` against the first parameter, one line per combination of the others."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    first, others = params[0], params[1:]
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    groups = {}
    for row in rows:
        groups.setdefault(tuple(row[p] for p in others), []).append(row)
    for key, group in groups.items():
        group.sort(key=lambda r: r[first])
        label = ", ".join(f"{p} = {v:g}" for p, v in zip(others, key)) or None
        ax.plot([r[first] for r in group], [r[y] for r in group], "o-", label=label)
    ax.set_xlabel(first)
    ax.set_ylabel(y)
    ax.grid(True, alpha=0.3)
    if others:
        ax.legend(fontsize="small")
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def parse_param(text):
    name, _, values = text.partition("=")
    if not values:
        raise argparse.ArgumentTypeError(f"{text!r}: expected NAME=V1,V2,...")
    return name, [float(v) for v in values.split(",")]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("fmu", type=Path)
    parser.add_argument("--param", type=parse_param, action="append", required=True, help="NAME=V1,V2,...")
    parser.add_argument("--output", action="append", required=True, help="output variable")
    parser.add_argument("--stop-time", type=float)
    parser.add_argument("--step", type=float, help="communication step [s]")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, default=2, help="LocalCluster of N worker processes (default 2)")
    where.add_argument("--scheduler", help="address of a running dask scheduler")
    where.add_argument("--serial", action="store_true", help="no dask: every case in this process")
    parser.add_argument("--batch", type=int, help="cases per dask task (default: two tasks per worker)")
    parser.add_argument("--csv", type=Path, default=Path("sweep.csv"))
    parser.add_argument("--plot", type=Path, help="PNG: a column against the first parameter")
    parser.add_argument("--plot-y", help="the column plotted (default: the first output)")
    args = parser.parse_args()

    params = dict(args.param)
    cases = grid(params)
    print(f"{len(cases)} cases of {args.fmu}")
    if args.serial:
        rows = run_serial(args.fmu, cases, args.output, args.stop_time, args.step)
    else:
        from distributed import Client, LocalCluster

        if args.scheduler:
            client = Client(args.scheduler)
        else:
            client = Client(LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True))
        with client:
            print(f"dashboard: {client.dashboard_link}")
            rows = run_dask(
                client, args.fmu, cases, args.output, args.stop_time, args.step, show_progress=True, batch=args.batch
            )
            print()
    write_csv(rows, args.csv)
    print(f"wrote {args.csv}")
    if args.plot:
        plot(rows, list(params), args.plot_y or args.output[0], args.plot)
        print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
