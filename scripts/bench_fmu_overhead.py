#!/usr/bin/env python3
"""Overhead of the FMI layer: the same scene run (a) natively in-process
(`contact-fmu bench run`, setup excluded), (b) as a process (`contact-fmu simulate --quiet`,
process start and scene compilation included), (c) through its FMU with fmpy
(`fmpy.simulate_fmu`, which also loads the shared library, instantiates and records every
output), and (d) through the FMU with a bare fmpy FMU2Slave loop of doStep calls (no
recording). Medians of 5 runs. Writes docs/fmu_overhead.csv.

Run from the repository root after `cargo build --release`:
    .venv/bin/python scripts/bench_fmu_overhead.py
"""
import csv
import os
import shutil
import statistics
import subprocess
import sys
import time

import fmpy
from fmpy import read_model_description, extract
from fmpy.fmi2 import FMU2Slave

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXE = os.path.join(ROOT, "target", "release", "contact-fmu")
WORK = os.path.join(ROOT, "target", "bench", "fmu")
REPEATS = int(os.environ.get("BENCH_REPEATS", "5"))


def median_time(fn):
    v = []
    for _ in range(REPEATS):
        t = time.perf_counter()
        fn()
        v.append(time.perf_counter() - t)
    return statistics.median(v)


def bare_loop(unzipped, md, stop, h):
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="bench")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    n = int(round(stop / h))
    t = 0.0
    for k in range(1, n + 1):
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=k * h - t)
        t = k * h
    fmu.terminate()
    fmu.freeInstance()


def main():
    os.makedirs(WORK, exist_ok=True)
    rows = []
    for name in sorted(os.listdir(os.path.join(ROOT, "fmu"))):
        scene = os.path.join(ROOT, "fmu", name, "scene.toml")
        if not os.path.isfile(scene):
            continue
        fmu_path = os.path.join(WORK, f"{name}.fmu")
        r = subprocess.run([EXE, "export", scene, "-o", fmu_path], capture_output=True, text=True)
        if r.returncode != 0:
            print(name, "export failed:", r.stderr.strip())
            continue
        md = read_model_description(fmu_path)
        stop, h = float(md.defaultExperiment.stopTime), float(md.defaultExperiment.stepSize)
        n = int(round(stop / h))
        out = subprocess.run([EXE, "bench", "run", scene, "--repeats", str(REPEATS)], capture_output=True, text=True)
        kv = dict(x.split("=", 1) for x in out.stdout.split() if "=" in x)
        native = float(kv["seconds"])
        process = median_time(lambda: subprocess.run([EXE, "simulate", scene, "--quiet"], check=True))
        fmpy_sim = median_time(lambda: fmpy.simulate_fmu(fmu_path))
        unzipped = extract(fmu_path)
        try:
            bare = median_time(lambda: bare_loop(unzipped, md, stop, h))
        finally:
            shutil.rmtree(unzipped, ignore_errors=True)
        per_step = (bare - native) / n
        rows.append([name, n, native, process, fmpy_sim, bare, per_step])
        print(f"{name:15s} steps {n:6d}  native {native:.4f} s  simulate {process:.4f} s  "
              f"fmpy.simulate_fmu {fmpy_sim:.4f} s  FMU2Slave loop {bare:.4f} s  "
              f"overhead {per_step * 1e6:.1f} us per doStep ({bare / native:.2f}x)")
    with open(os.path.join(ROOT, "docs", "fmu_overhead.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["scene", "communication_steps", "native_seconds", "simulate_process_seconds",
                    "fmpy_simulate_fmu_seconds", "fmpy_dostep_loop_seconds", "overhead_per_dostep_seconds"])
        for r in rows:
            w.writerow([r[0], r[1]] + [f"{x:.6e}" for x in r[2:]])


if __name__ == "__main__":
    sys.exit(main())
