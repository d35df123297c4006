"""Speed-up of a parameter sweep on dask.distributed with 1 and 2 worker processes
(cosim/sweep.py), against the same cases run serially in this process.

    .venv/bin/python scripts/bench_sweep.py [--fmu target/fmu/rail_vehicle.fmu] [--repeats 3]
        [--csv docs/sweep_speedup.csv]

The study: the rail vehicle's 5 s default experiment over car body mass x suspension damping
(6 x 4 = 24 cases). Each configuration runs the whole sweep `--repeats` times; the table has the
median and the least wall-clock time, from the first submission to the last result, with the
cluster already started (its start-up time is printed apart); the first repeat includes sending
and unpacking the FMU on the workers (once per worker), the others find it there. Also given:
the CPU seconds the computing processes used per sweep, the cores they got on average (CPU
time / wall time), and the load average of the machine before each configuration, since other
processes share its cores.
"""

import argparse
import csv
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from cosim import sweep  # noqa: E402

PARAMS = {
    "car.mass": [24e3, 28e3, 32e3, 36e3, 40e3, 44e3],
    "susp_*.damping": [2.4e4, 3.6e4, 4.8e4, 6.0e4],
}
OUTPUTS = ["car.r[3]", "contact_fl1.force"]


def timed(fn, repeats, cpu):
    """Wall-clock times of `repeats` calls of `fn`, and the CPU seconds `cpu()` grew by."""
    times = []
    cpu0 = cpu()
    for _ in range(repeats):
        t = time.perf_counter()
        rows = fn()
        times.append(time.perf_counter() - t)
    return times, cpu() - cpu0, rows


def workers_cpu(client):
    """CPU seconds used so far by the worker processes of `client`, summed."""
    return sum(client.run(time.process_time).values())


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmu", type=Path, default=ROOT / "target" / "fmu" / "rail_vehicle.fmu")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--csv", type=Path, default=ROOT / "docs" / "sweep_speedup.csv")
    args = parser.parse_args()
    from distributed import Client, LocalCluster

    cases = sweep.grid(PARAMS)
    print(f"{len(cases)} cases of {args.fmu.name}, {os.cpu_count()} CPUs, {args.repeats} repeats")
    results = []
    load = os.getloadavg()[0]
    times, cpu, reference = timed(lambda: sweep.run_serial(args.fmu, cases, OUTPUTS), args.repeats, time.process_time)
    results.append(("serial", 0, times, cpu, load))
    for workers in (1, 2):
        t = time.perf_counter()
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
        print(f"LocalCluster of {workers} worker(s) started in {time.perf_counter() - t:.2f} s")
        load = os.getloadavg()[0]
        times, cpu, rows = timed(
            lambda: sweep.run_dask(client, args.fmu, cases, OUTPUTS), args.repeats, lambda: workers_cpu(client)
        )
        if rows != reference:
            raise SystemExit(f"{workers} worker(s): results differ from the serial run")
        results.append((f"dask, {workers} worker(s)", workers, times, cpu, load))
        client.close()
        cluster.close()

    one = statistics.median(results[1][2])
    args.csv.parent.mkdir(parents=True, exist_ok=True)
    with open(args.csv, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            [
                "run",
                "workers",
                "cases",
                "wall_median_s",
                "wall_min_s",
                "speedup_vs_1_worker",
                "cpu_s_per_sweep",
                "cores_used",
                "load_avg_1min_before",
            ]
        )
        print(
            f"{'run':<22}{'median [s]':>11}{'min [s]':>9}{'vs 1 worker':>12}{'CPU [s]':>9}{'cores used':>11}{'load':>6}"
        )
        for name, workers, times, cpu, load in results:
            median = statistics.median(times)
            cpu_per_sweep = cpu / len(times)
            cores = cpu / sum(times)
            w.writerow(
                [name, workers, len(cases)]
                + [f"{x:.3f}" for x in (median, min(times))]
                + [f"{one / median:.2f}", f"{cpu_per_sweep:.3f}", f"{cores:.2f}", f"{load:.2f}"]
            )
            print(
                f"{name:<22}{median:>11.3f}{min(times):>9.3f}{one / median:>11.2f}x"
                f"{cpu_per_sweep:>9.3f}{cores:>11.2f}{load:>6.2f}"
            )
    print(f"wrote {args.csv}")


if __name__ == "__main__":
    main()
