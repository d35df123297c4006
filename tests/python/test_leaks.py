"""Resident memory stays flat over thousands of instantiate/free cycles with the library
loaded once, and the bound is tight enough to catch a deliberate leak of one FMU state per
cycle (the benchmark with 10^4 cycles: scripts/bench_instance_cycles.py, docs/robustness.md).
"""

import csv
import subprocess
import sys

from conftest import ROOT, SCENES

CYCLES = 3000
BOUND_KIB = 1024  # a leaked FMU state of the bouncing ball is about 2.5 KB: 2.5 MB over 1,000 cycles


def growth_kib(fmus, tmp_path, mode):
    """Resident-memory growth of `mode` (scripts/bench_instance_cycles.py) in a fresh process:
    in the test process, heap that earlier tests freed would take a leak without growing."""
    out = tmp_path / f"{mode}.csv"
    subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "bench_instance_cycles.py"), "--fmu", str(fmus[SCENES[0]]),
         "--cycles", str(CYCLES), "--warmup", "100", "--every", "500", "--modes", mode, "--csv", str(out)],
        check=True, capture_output=True, text=True,
    )
    (row,) = csv.DictReader(out.open())
    return int(row["growth_kib"])


def test_three_thousand_cycles_on_a_loaded_library_do_not_grow_memory(fmus, tmp_path):
    growth = growth_kib(fmus, tmp_path, "loaded")
    assert growth < BOUND_KIB, f"resident memory grew by {growth} KiB over {CYCLES} cycles"


def test_the_bound_catches_one_leaked_state_per_cycle(fmus, tmp_path):
    growth = growth_kib(fmus, tmp_path, "leak-state")
    assert growth > BOUND_KIB, f"a deliberate leak grew memory by only {growth} KiB"
