#!/usr/bin/env python3
"""Resident memory over many instantiate/free cycles of an exported FMU (benchmark).

One cycle is a short host session through fmpy's FMU2Slave: instantiate, setup, initialise,
one fmi2DoStep, get, serialize, deserialize and free an FMU state, terminate, free the
instance. The process's resident set size (VmRSS) is read every --every cycles, after a
warm-up of --warmup cycles; the growth per cycle is the least-squares slope over the
readings. Modes:

  loaded     the library is loaded once; --cycles cycles
  reloaded   fmpy's own pattern: every cycle loads the library and unloads it again
  leak-state control: like `loaded`, and a second instance that lives for the whole run saves
             one FMU state per cycle that is never freed (a deliberate leak of one saved
             state per cycle; a state the cycle's own instance made would be freed with it):
             shows the size of leak the measurement detects
  leak-instance control: the instance is never freed

Prints a table and writes docs/instance_cycles.csv (mode, fmu, cycles, rss at start and end
[KiB], growth [KiB], slope [bytes/cycle], seconds).

  python scripts/bench_instance_cycles.py                      # 10^4 cycles per mode
  python scripts/bench_instance_cycles.py --cycles 2000 --csv /tmp/x.csv
"""

import argparse
import gc
import sys
import tempfile
import time
import zipfile
from ctypes import byref, c_void_p
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODES = ["loaded", "reloaded", "leak-state", "leak-instance"]


def rss_kib():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError("no VmRSS")


class Unzipped:
    def __init__(self, fmu, root):
        from fmpy import read_model_description

        self.dir = Path(root) / Path(fmu).stem
        with zipfile.ZipFile(fmu) as z:
            z.extractall(self.dir)
        self.md = read_model_description(str(self.dir))
        self.step = float(self.md.defaultExperiment.stepSize)

    def slave(self):
        return slave_of(self.md, self.dir)


def slave_of(md, unzip_dir):
    """fmpy's FMU2Slave of the FMU unzipped in `unzip_dir` (model description `md`)."""
    from fmpy.fmi2 import FMU2Slave

    return FMU2Slave(
        guid=md.guid,
        unzipDirectory=str(unzip_dir),
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="cycle",
    )


def cycle(slave, step, free_state=True, free_instance=True):
    """One host session on a loaded library."""
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=step)
    state = slave.getFMUstate()
    data = slave.serializeFMUstate(state)
    copy = slave.deSerializeFMUstate(data)
    slave.setFMUstate(copy)
    slave.freeFMUstate(copy)
    if free_state:
        slave.freeFMUstate(state)
    slave.terminate()
    if free_instance:
        slave.fmi2FreeInstance(slave.component)
    slave.component = c_void_p(None)


def run(unz, mode, cycles, warmup, every):
    """Runs `warmup` then `cycles` cycles; returns the (cycle, rss) readings and seconds."""
    kept = None
    if mode != "reloaded":
        kept = unz.slave()
    keeper = None
    if mode == "leak-state":
        # (an instance frees the states it made when it is freed: the leaked states are made
        # by a second instance that lives for the whole run)
        keeper = unz.slave()
        keeper.instantiate()
        keeper.setupExperiment(startTime=0.0)
        keeper.enterInitializationMode()
        keeper.exitInitializationMode()

    def one():
        if mode == "reloaded":
            s = unz.slave()
            cycle(s, unz.step)
            s.freeLibrary()
        else:
            cycle(kept, unz.step, free_instance=mode != "leak-instance")
            if keeper is not None:
                keeper.getFMUstate()  # never freed

    for _ in range(warmup):
        one()
    gc.collect()
    readings = [(0, rss_kib())]
    t0 = time.perf_counter()
    for k in range(1, cycles + 1):
        one()
        if k % every == 0 or k == cycles:
            gc.collect()
            readings.append((k, rss_kib()))
    return readings, time.perf_counter() - t0


def slope(readings):
    """Least-squares growth per cycle [KiB]."""
    n = len(readings)
    mx = sum(k for k, _ in readings) / n
    my = sum(r for _, r in readings) / n
    sxx = sum((k - mx) ** 2 for k, _ in readings)
    return sum((k - mx) * (r - my) for k, r in readings) / sxx if sxx else 0.0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fmu", default=str(ROOT / "target" / "fmu" / "bouncing_ball.fmu"))
    ap.add_argument("--cycles", type=int, default=10000)
    ap.add_argument("--warmup", type=int, default=200)
    ap.add_argument("--every", type=int, default=500)
    ap.add_argument("--modes", default=",".join(MODES))
    ap.add_argument("--csv", default=str(ROOT / "docs" / "instance_cycles.csv"))
    args = ap.parse_args()
    unz = Unzipped(args.fmu, tempfile.mkdtemp(prefix="contact-fmu-cycles-"))
    rows = []
    print(f"{'mode':14s} {'fmu':14s} {'cycles':>7s} {'rss0 KiB':>9s} {'rss KiB':>9s} {'growth KiB':>11s}"
          f" {'B/cycle':>9s} {'s':>7s}")
    for mode in args.modes.split(","):
        # the controls leak on purpose: a tenth of the cycles shows the slope
        n = args.cycles if not mode.startswith("leak") else max(args.cycles // 10, 2 * args.every)
        readings, seconds = run(unz, mode, n, args.warmup, args.every)
        growth = readings[-1][1] - readings[0][1]
        per_cycle = slope(readings) * 1024
        rows.append((mode, Path(args.fmu).stem, n, readings[0][1], readings[-1][1], growth, per_cycle, seconds))
        print(f"{mode:14s} {Path(args.fmu).stem:14s} {n:7d} {readings[0][1]:9d} {readings[-1][1]:9d} {growth:11d}"
              f" {per_cycle:9.1f} {seconds:7.1f}", flush=True)
    if args.csv:
        lines = ["mode,fmu,cycles,rss_start_kib,rss_end_kib,growth_kib,bytes_per_cycle,seconds"]
        lines += [f"{m},{f},{n},{a},{b},{g},{p:.1f},{s:.1f}" for m, f, n, a, b, g, p, s in rows]
        Path(args.csv).write_text("\n".join(lines) + "\n")
        print(f"wrote {args.csv}")


if __name__ == "__main__":
    sys.exit(main())
