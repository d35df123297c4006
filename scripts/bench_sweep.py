"""Speed-up of a parameter sweep on dask.distributed with 1 and 2 worker processes
(cosim/sweep.py), against the same cases run serially in this process, and dask's cost per case.

    .venv/bin/python scripts/bench_sweep.py [--fmu target/fmu/rail_vehicle.fmu] [--repeats 3]
        [--csv docs/sweep_speedup.csv]

The study: the rail vehicle's 5 s default experiment over car body mass x suspension damping
(6 x 4 = 24 cases). Configurations: serial (one fresh instance per case, the reference), dask
with 1 worker and with 2 workers in batches (the default: two tasks per worker, each task's
cases in one instance reset by fmi2Reset), and 2 workers with one task per case (batch 1, as
the sweeps ran before batches). Each dask configuration gets its own cluster; after one sweep
that sends and unpacks the FMU on the workers (its time printed apart, like the cluster's
start-up), the whole sweep runs `--repeats` times, each time right after a serial sweep, so
that every speed-up is a ratio of medians measured in turns in one run (the machine's load and
clock drift between configurations). The table has the median and the least wall-clock time,
from the first submission to the last result. Every run's table must equal the serial one
exactly. Also given: the CPU seconds the computing processes used per sweep, the cores they
got on average (CPU time / wall time), dask's cost per case (the core time lost against the
serial run, `(workers x wall - serial wall) / cases`, and in CPU `(CPU - serial CPU) / cases`,
each also relative to a serial case), and the load average of the machine before each
configuration, since other processes share its cores.
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
    serial_load = os.getloadavg()[0]
    reference = sweep.run_serial(args.fmu, cases, OUTPUTS)
    serial_times, serial_cpu_total = [], 0.0
    for workers, batch in ((1, None), (2, 1), (2, None)):
        t = time.perf_counter()
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
        print(f"LocalCluster of {workers} worker(s) started in {time.perf_counter() - t:.2f} s")
        t = time.perf_counter()
        rows = sweep.run_dask(client, args.fmu, cases, OUTPUTS, batch=batch)
        print(f"  first sweep (the FMU sent and unpacked on the workers): {time.perf_counter() - t:.3f} s")
        if rows != reference:
            raise SystemExit(f"{workers} worker(s), batch {batch}: results differ from the serial run")
        load = os.getloadavg()[0]
        times, cpu, paired = [], 0.0, []
        for _ in range(args.repeats):
            # a serial sweep, then the dask sweep: the pairs see the same machine
            s_times, s_cpu, _ = timed(lambda: sweep.run_serial(args.fmu, cases, OUTPUTS), 1, time.process_time)
            serial_times.extend(s_times)
            serial_cpu_total += s_cpu
            paired.extend(s_times)
            d_times, d_cpu, rows = timed(
                lambda: sweep.run_dask(client, args.fmu, cases, OUTPUTS, batch=batch), 1, lambda: workers_cpu(client)
            )
            if rows != reference:
                raise SystemExit(f"{workers} worker(s), batch {batch}: results differ from the serial run")
            times.extend(d_times)
            cpu += d_cpu
        size = batch or sweep.batch_size(len(cases), workers)
        results.append(
            (f"dask, {workers} worker(s), {size} case(s) per task", workers, times, cpu, load, statistics.median(paired))
        )
        client.close()
        cluster.close()
    results.insert(0, ("serial", 0, serial_times, serial_cpu_total, serial_load, statistics.median(serial_times)))

    serial_wall = statistics.median(results[0][2])
    serial_cpu = results[0][3] / len(results[0][2])
    case = serial_wall / len(cases)
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
                "speedup_vs_serial",
                "cpu_s_per_sweep",
                "cores_used",
                "overhead_per_case_s",
                "overhead_per_case_rel",
                "cpu_overhead_per_case_s",
                "load_avg_1min_before",
            ]
        )
        print(f"one case, serial: {case * 1e3:.1f} ms wall, {serial_cpu / len(cases) * 1e3:.1f} ms CPU")
        print(
            f"{'run':<40}{'median [s]':>11}{'min [s]':>9}{'vs serial':>10}{'CPU [s]':>9}{'cores':>7}"
            f"{'cost/case [ms]':>15}{'rel':>7}{'CPU/case [ms]':>14}{'load':>6}"
        )
        for name, workers, times, cpu, load, paired_serial in results:
            median = statistics.median(times)
            cpu_per_sweep = cpu / len(times)
            cores = cpu / sum(times)
            lost = (max(workers, 1) * median - paired_serial) / len(cases)
            cpu_lost = (cpu_per_sweep - serial_cpu) / len(cases)
            w.writerow(
                [name, workers, len(cases)]
                + [f"{x:.3f}" for x in (median, min(times))]
                + [f"{paired_serial / median:.2f}", f"{cpu_per_sweep:.3f}", f"{cores:.2f}"]
                + [f"{lost:.4f}", f"{lost / case:.3f}", f"{cpu_lost:.4f}", f"{load:.2f}"]
            )
            print(
                f"{name:<40}{median:>11.3f}{min(times):>9.3f}{paired_serial / median:>9.2f}x"
                f"{cpu_per_sweep:>9.3f}{cores:>7.2f}{lost * 1e3:>15.1f}{lost / case:>7.2f}{cpu_lost * 1e3:>14.1f}{load:>6.2f}"
            )
    print(f"wrote {args.csv}")


if __name__ == "__main__":
    main()
