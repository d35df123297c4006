"""The rail vehicle over a track irregularity, co-simulated (docs/track.md): the ride and wheel-load
table for two speeds and two FRA track classes, and its figure.

    .venv/bin/python -m cosim.track_study [--stop-time 14] [--start 4] [--seeds 1] [--libcosim]
        [--plot] [--csv docs/track_ride.csv]

Each case is the system `cosim/track/SystemStructure.ssd` with the speed (every body's initial
velocity along the track, the wheels rolling) and the track class changed in its parameter sets,
packed into `target/cosim/track_<speed>kmh_class<c>.ssp` and run by fmpy (cosim/run_system.py);
with `--libcosim` also by libcosim (cosim/run_libcosim.py), and the two results compared number
for number (every recorded column at every communication point; the script stops if they
differ). The measures (cosim/ride.py) are taken over t >= start: the vehicle starts off its
equilibrium (its springs at their free length) and settles within about 3 s.

The FMUs are taken from target/fmu (the main job `cargo run --release` exports the vehicle; the
track FMU is built when missing).
"""

import argparse
import csv
import re
import sys
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from cosim import build_track, ride, run_libcosim, run_system  # noqa: E402
    from cosim.ssp import ROOT  # noqa: E402
    from cosim.track_plot import plot  # noqa: E402
else:
    from . import build_track, ride, run_libcosim, run_system
    from .ssp import ROOT
    from .track_plot import plot

SPEEDS_KMH = (80.0, 120.0)
TRACK_CLASSES = (4, 6)
WHEEL_RADIUS = 0.46  # m, the wheels' contact radius in fmu/rail_vehicle_track/scene.toml
CSV = ROOT / "docs" / "track_ride.csv"
FIGURE = ROOT / "docs" / "img" / "track_ride.png"
OUTPUTS = (
    ["vehicle.car.v[3]", "vehicle.car.w[2]"]
    + [f"vehicle.contact_{w}.force" for w in ride.WHEELS]
    + ["vehicle.energy.total", "vehicle.energy.dissipated", "vehicle.energy.input_work", "vehicle.energy.kinetic"]
)


def set_parameter(ssd_text, name, value):
    """The SSD text with the value of the parameter `name` (exactly one in the text) replaced."""
    pattern = r'(<ssv:Parameter name="%s"><ssv:(?:Real|Integer) value=")[^"]*"' % re.escape(name)
    text, count = re.subn(pattern, lambda m: m.group(1) + repr(value) + '"', ssd_text)
    if count != 1:
        raise ValueError(f"the SSD has {count} parameters named {name}")
    return text


def variant(speed_kmh, track_class, ssd=build_track.SSD, **track):
    """The SSD text of the system at `speed_kmh` on FRA class `track_class` (and other track
    parameters by name)."""
    text = Path(ssd).read_text()
    v = speed_kmh / 3.6
    for name in re.findall(r'<ssv:Parameter name="([^"]+\.velocity\[1\])"', text):
        text = set_parameter(text, name, v)
    for name in re.findall(r'<ssv:Parameter name="([^"]+\.angular_velocity\[2\])"', text):
        text = set_parameter(text, name, v / WHEEL_RADIUS)
    text = set_parameter(text, "track_class", int(track_class))
    for name, value in track.items():
        text = set_parameter(text, name, value)
    return text


def pack_variant(output, speed_kmh, track_class, vehicle=build_track.VEHICLE, track_fmu=None, **track):
    """Packs the variant into the .ssp `output`; returns its path."""
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    ssd = output.with_suffix(".ssd")
    ssd.write_text(variant(speed_kmh, track_class, **track))
    return build_track.build(output, vehicle, track_fmu or build_track.TRACK, ssd)


def run(ssp, master, stop_time, outputs=OUTPUTS):
    """A run of the system by "fmpy" or "libcosim": columns as numpy arrays."""
    if master == "fmpy":
        result = run_system.run(ssp, scenario=None, stop_time=stop_time, outputs=outputs)
    else:
        result = run_libcosim.run(ssp, scenario=None, stop_time=stop_time, outputs=outputs)
        status = result.pop("status")
        if status.error_code != 0:
            raise RuntimeError(f"libcosim: error code {status.error_code}")
    return {k: np.asarray(v) for k, v in result.items()}


def identical(a, b):
    """The columns of two runs that differ (as bits) or are missing in one."""
    return [k for k in a if k not in b or a[k].shape != b[k].shape or not np.array_equal(a[k], b[k])]


def vehicle_mass(fmu=build_track.VEHICLE):
    """The vehicle's mass: the `<body>.mass` start values of the FMU, rail heads excepted."""
    from fmpy import read_model_description

    md = read_model_description(str(fmu))
    return sum(
        float(v.start)
        for v in md.modelVariables
        if v.name.endswith(".mass") and not v.name.startswith("railhead_")
    )


ROW = (
    "| {speed:.0f} km/h | {cls} | {seed} | {rms:.3f} | {peak:.3f} | {wz:.2f} | {awk:.3f} | {wz_t:.2f} | "
    "{qmax:.3f} | {qmin:.3f} | {qrms:.4f} | {unloaded} | {drift:.1e} |"
)
HEADER = (
    "| speed | FRA class | seed | a_z RMS [m/s²] | a_z peak [m/s²] | Wz | a_w (Wk) [m/s²] | Wz, leading truck | "
    "Q_max / Q0 | Q_min / Q0 | RMS (Q − Q0) / Q0 | a wheel unloads | energy balance |\n"
    "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
)


def case(speed, cls, seed, args, mass):
    """Runs one case (and compares the engines with --libcosim); prints its row. Returns the
    row, the fmpy run and the libcosim run (or None)."""
    ssp = pack_variant(ROOT / "target" / "cosim" / f"track_{speed:.0f}kmh_class{cls}.ssp", speed, cls, seed=seed)
    outputs = OUTPUTS + ["track.profile_rms"]
    a = run(ssp, "fmpy", args.stop_time, outputs)
    b = None
    if args.libcosim:
        b = run(ssp, "libcosim", args.stop_time, outputs)
        differ = identical(a, b)
        if differ:
            raise SystemExit(f"{speed} km/h, class {cls}, seed {seed}: fmpy and libcosim differ in {differ}")
    m = ride.evaluate(a, args.start, mass)
    row = {
        "speed_kmh": speed,
        "track_class": cls,
        "seed": seed,
        "profile_rms_mm": 1e3 * float(a["track.profile_rms"][-1]),
        "az_rms": m["centre"]["rms"],
        "az_peak": m["centre"]["peak"],
        "wz": m["centre"]["wz"],
        "a_wk": m["centre"]["a_wk"],
        "wz_leading_truck": m["leading truck"]["wz"],
        "a_wk_leading_truck": m["leading truck"]["a_wk"],
        "q_max": m["q_max"],
        "q_min": m["q_min"],
        "q_rms": m["q_rms"],
        "unloaded": m["unloaded"],
        "mean_load": m["mean_load"],
        "energy_drift": m["energy_drift"],
        "window_s": m["window"][1] - m["window"][0],
        "libcosim_identical": bool(args.libcosim),
    }
    print(
        ROW.format(
            speed=speed, cls=cls, seed=seed, rms=row["az_rms"], peak=row["az_peak"], wz=row["wz"], awk=row["a_wk"],
            wz_t=row["wz_leading_truck"], qmax=row["q_max"], qmin=row["q_min"], qrms=row["q_rms"],
            unloaded="yes" if row["unloaded"] else "no", drift=row["energy_drift"],
        ),
        flush=True,
    )
    return row, a, b


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stop-time", type=float, default=14.0)
    parser.add_argument("--start", type=float, default=4.0, help="measures over t >= start [s]")
    parser.add_argument("--seeds", default="1", help="seeds of the track's phases, comma-separated")
    parser.add_argument("--libcosim", action="store_true", help="run libcosim too and compare")
    parser.add_argument("--plot", action="store_true", help=f"draw {FIGURE.relative_to(ROOT)}")
    parser.add_argument("--csv", type=Path, default=CSV)
    args = parser.parse_args()
    if not build_track.TRACK.exists():
        build_track.build_track_fmu()
    mass = vehicle_mass()
    rows, runs = [], {}
    print(HEADER)
    seeds = [int(x) for x in args.seeds.split(",")]
    for speed in SPEEDS_KMH:
        for cls in TRACK_CLASSES:
            for seed in seeds:
                row, a, b = case(speed, cls, seed, args, mass)
                rows.append(row)
                if seed == seeds[0]:  # the figure shows the first seed's runs
                    runs[(speed, cls, "fmpy")] = a
                    if b is not None:
                        runs[(speed, cls, "libcosim")] = b
    args.csv.parent.mkdir(parents=True, exist_ok=True)
    with open(args.csv, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for row in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
    print(f"wrote {args.csv}")
    if args.plot:
        print(f"wrote {plot(runs, args.start, mass, FIGURE)}")


if __name__ == "__main__":
    main()
