"""Draws docs/img/cosim_speed_set_point.png: the rail vehicle's speed against the set point
and the driver's force, co-simulated in fmpy and in libcosim (the same numbers: both lines
are drawn, libcosim's dashed).

    .venv/bin/python -m cosim.plot_system [--ssp target/cosim/rail_vehicle_speed_control.ssp]

The .ssp is built first (cosim/build_ssp.py) when it is missing.
"""

import argparse
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from cosim import build_ssp, run_libcosim, run_system  # noqa: E402
    from cosim.ssp import ROOT, SCENARIO, read_scenario, read_system  # noqa: E402
else:
    from . import build_ssp, run_libcosim, run_system
    from .ssp import ROOT, SCENARIO, read_scenario, read_system

OUTPUT = ROOT / "docs" / "img" / "cosim_speed_set_point.png"


def set_point(t, system_start, events):
    """The set point over time: the SSD's start value, then the scenario's overrides."""
    sp = np.full_like(t, system_start)
    for e in events:
        sp[t >= e.time - 1e-12] = e.value
    return sp


def plot(ssp, output=OUTPUT):
    with tempfile.TemporaryDirectory() as tmp:
        start = read_system(ssp, tmp).components["driver"].parameters["speed_set_point"]
    events, _ = read_scenario(SCENARIO)
    a = run_system.run(ssp)
    b = run_libcosim.run(ssp)
    b.pop("status")
    t = np.array(a["time"])
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(7, 5.5))
    ax1.plot(t, 3.6 * set_point(t, start, events), "k:", label="set point")
    ax1.plot(t, 3.6 * np.array(a["vehicle.car.v[1]"]), label="speed, fmpy")
    ax1.plot(b["time"], 3.6 * np.array(b["vehicle.car.v[1]"]), "--", label="speed, libcosim")
    ax1.set_ylabel("speed [km/h]")
    ax1.legend()
    ax1.grid(True, alpha=0.3)
    ax2.plot(t, 1e-3 * np.array(a["driver.traction"]), label="fmpy")
    ax2.plot(b["time"], 1e-3 * np.array(b["driver.traction"]), "--", label="libcosim")
    ax2.set_ylabel("traction [kN]")
    ax2.set_xlabel("t [s]")
    ax2.legend()
    ax2.grid(True, alpha=0.3)
    fig.suptitle("Rail vehicle under PI speed control (43.6 t, step 80 -> 60 km/h at 5 s)")
    fig.tight_layout()
    Path(output).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(output, dpi=110)
    return output


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ssp", type=Path, default=build_ssp.DEFAULT_OUTPUT)
    parser.add_argument("-o", "--output", type=Path, default=OUTPUT)
    args = parser.parse_args()
    if not args.ssp.exists():
        build_ssp.build(args.ssp)
    print(f"wrote {plot(args.ssp, args.output)}")


if __name__ == "__main__":
    main()
