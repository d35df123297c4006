"""Draws docs/img/track_ride.png from the runs of cosim/track_study.py: the rail profile under the
leading wheel, the car body's vertical acceleration and the leading wheel's load, for both track
classes at the higher speed (libcosim's run dashed over fmpy's where it was run: the same
numbers)."""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

if __package__ in (None, ""):
    from cosim import ride  # noqa: E402
else:
    from . import ride


def plot(runs, start, vehicle_mass, output):
    speed = max(s for s, _, _ in runs)
    classes = sorted({c for s, c, _ in runs if s == speed})
    q0 = ride.static_wheel_load(vehicle_mass)
    fig, (ax1, ax2, ax3) = plt.subplots(3, 1, figsize=(8, 8.5))
    for cls in classes:
        a = runs[(speed, cls, "fmpy")]
        t = a["time"]
        window = t >= start
        x, z = a["track.x_fl1"], a["track.z_fl1"]
        ax1.plot(x, 1e3 * z, label=f"FRA class {cls}")
        acc = ride.derivative(t, a["vehicle.car.v[3]"])
        (line,) = ax2.plot(t[window], acc[window], lw=0.8, label=f"class {cls}, fmpy")
        ax3.plot(t[window], a["vehicle.contact_fl1.force"][window] / q0, lw=0.8, label=f"class {cls}, fmpy")
        b = runs.get((speed, cls, "libcosim"))
        if b is not None:
            acc_b = ride.derivative(b["time"], b["vehicle.car.v[3]"])
            ax2.plot(b["time"][window], acc_b[window], "--", lw=0.8, color="k", label=f"class {cls}, libcosim")
            ax3.plot(b["time"][window], b["vehicle.contact_fl1.force"][window] / q0, "--", lw=0.8, color="k",
                     label=f"class {cls}, libcosim")
    ax1.set_xlabel("position of the leading wheel along the track [m]")
    ax1.set_ylabel("rail height [mm]")
    ax1.set_title(f"rail height under the leading wheel (the track FMU's output), {speed:.0f} km/h run")
    ax2.set_ylabel("car body a_z [m/s²]")
    ax2.set_title("car body vertical acceleration at its centre of mass")
    ax3.set_ylabel("Q / Q0, leading wheel")
    ax3.set_xlabel("t [s]")
    ax3.set_title(f"wheel-rail normal force over the static wheel load Q0 = {q0 / 1e3:.2f} kN")
    for ax in (ax1, ax2, ax3):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
    fig.suptitle(f"Rail vehicle (43.6 t) over FRA class {' and '.join(map(str, classes))} track at {speed:.0f} km/h")
    fig.tight_layout()
    Path(output).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(output, dpi=110)
    plt.close(fig)
    return output
