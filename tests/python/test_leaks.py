"""Resident memory stays flat over thousands of instantiate/free cycles with the library
loaded once, and the bound is tight enough to catch a deliberate leak of one FMU state per
cycle (the benchmark with 10^4 cycles: scripts/bench_instance_cycles.py, docs/robustness.md).
"""

import sys

from conftest import ROOT, SCENES

sys.path.insert(0, str(ROOT / "scripts"))
import bench_instance_cycles as cycles  # noqa: E402

CYCLES = 3000
BOUND_KIB = 1024  # a leaked FMU state of the bouncing ball is about 1.4 KB: 4 MB over the run


def growth_kib(fmus, tmp_path, mode):
    unz = cycles.Unzipped(fmus[SCENES[0]], tmp_path)
    readings, _ = cycles.run(unz, mode, CYCLES, warmup=100, every=500)
    return readings[-1][1] - readings[0][1]


def test_three_thousand_cycles_on_a_loaded_library_do_not_grow_memory(fmus, tmp_path):
    growth = growth_kib(fmus, tmp_path, "loaded")
    assert growth < BOUND_KIB, f"resident memory grew by {growth} KiB over {CYCLES} cycles"


def test_the_bound_catches_one_leaked_state_per_cycle(fmus, tmp_path):
    growth = growth_kib(fmus, tmp_path, "leak-state")
    assert growth > BOUND_KIB, f"a deliberate leak grew memory by only {growth} KiB"
