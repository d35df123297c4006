"""Vertical track irregularity under the wheels of the rail vehicle, an FMI 2.0 Co-Simulation FMU
built with pythonfmu (`cosim/build_track.py` makes `track_irregularity.fmu` from this file).

The rail's vertical profile r(x) is a random-phase sum of harmonics whose amplitudes follow the
vertical-profile spectrum of the FRA track classes (Hamid and Yang's fit of the US Federal Railroad
Administration's measurements, as given by Garg and Dukkipati, Dynamics of Railway Vehicle
Systems, 1984):

    S(Omega) = k A_v Omega_c^2 / (Omega^2 (Omega^2 + Omega_c^2))    [cm^2 / (rad/m)]

with Omega the wavenumber [rad/m], k = 0.25, Omega_c = 0.8245 rad/m and A_v [cm^2 rad/m] from
FRA_CLASSES. S is read as a one-sided density: the profile's variance is the integral of S over
the band. The band [2 pi / wavelength_max, 2 pi / wavelength_min] is cut into `harmonics` equal
intervals dOmega; harmonic i has the interval's mid wavenumber Omega_i, the amplitude
sqrt(2 S(Omega_i) dOmega) and a phase drawn uniformly from [0, 2 pi) by Python's `random.Random(seed)`
(Mersenne Twister, whose stream for a given integer seed Python keeps from version to version): the
same seed gives the same track. The profile repeats after 2 pi / dOmega (1,519 m with the defaults).

The rails start flat: the profile is multiplied by a fade-in w(x) that is 0 up to `fade_start`, 1
from `fade_start + fade_length` on, and a quintic smoothstep between (w, w' and w'' continuous).
Placed ahead of the leading wheel (the vehicle's front wheels start at x = 10 m), it makes the
outputs' start values (0) exact. Both rails of a wheelset get the same profile (the mean vertical
profile: no cross-level).

Inputs: each wheel's longitudinal position x_<wheel> [m] and speed v_<wheel> [m/s] (the vehicle's
`wheel_<wheel>.r[1]` and `.v[1]`). Outputs: the rail's height z_<wheel> = w r (x), its rate
zd_<wheel> = z'(x) v and acceleration zdd_<wheel> = z''(x) v^2 + z'(x) a, for the vehicle's motion
inputs `rail_<wheel>.q`, `.qd`, `.qdd`.

Like the speed controller it is a sampled system: `fmi2DoStep(t, h)` takes the inputs present at
t and sets the outputs for t + h, at the position the wheel reaches then, x + v h + a h^2 / 2 (a,
the wheel's acceleration, from the speeds of the last two communication points; 0 at the first
step). So no output depends directly on an input (`dependencies=""`), and the loop vehicle ->
track -> vehicle is not algebraic. The vehicle then follows z + zd tau + zdd tau^2 / 2 over the next
step, the profile's Taylor expansion under the moving wheel.
"""

import math
import random
from xml.etree.ElementTree import SubElement

import numpy as np
from pythonfmu import Fmi2Causality, Fmi2Variability, Integer, Real

try:  # in the FMU: beside this script
    from sampled_slave import SampledSlave, insert_unit_definitions, outputs_depend_on_no_input
except ImportError:  # in the source tree
    from cosim.sampled_slave import SampledSlave, insert_unit_definitions, outputs_depend_on_no_input

WHEELS = ("fl1", "fl2", "fr1", "fr2", "rl1", "rl2", "rr1", "rr2")

# FRA track classes 1 ... 6: A_v [cm^2 rad/m] of the vertical-profile spectrum; Omega_c [rad/m]
FRA_CLASSES = {1: 1.2107, 2: 1.0181, 3: 0.6816, 4: 0.5376, 5: 0.2095, 6: 0.0339}
FRA_OMEGA_C = 0.8245
FRA_K = 0.25


def fra_psd(omega, track_class):
    """The FRA vertical-profile spectrum of `track_class` at the wavenumbers `omega` [rad/m], in
    m^2 / (rad/m) (one-sided)."""
    a_v = FRA_CLASSES[track_class]
    s_cm2 = FRA_K * a_v * FRA_OMEGA_C**2 / (omega**2 * (omega**2 + FRA_OMEGA_C**2))
    return 1e-4 * s_cm2


def harmonics(track_class, seed, count, wavelength_min, wavelength_max, scale=1.0):
    """The profile's harmonics: (wavenumbers [rad/m], amplitudes [m], phases [rad]) as arrays."""
    omega_min, omega_max = 2.0 * math.pi / wavelength_max, 2.0 * math.pi / wavelength_min
    d_omega = (omega_max - omega_min) / count
    omega = omega_min + (np.arange(count) + 0.5) * d_omega
    amplitude = scale * np.sqrt(2.0 * fra_psd(omega, track_class) * d_omega)
    rng = random.Random(seed)
    phase = np.array([2.0 * math.pi * rng.random() for _ in range(count)])
    return omega, amplitude, phase


def fade(x, start, length):
    """The fade-in w and its first two derivatives at the positions x (arrays)."""
    s = np.clip((x - start) / length, 0.0, 1.0)
    w = s**3 * (10.0 - 15.0 * s + 6.0 * s * s)
    dw = 30.0 * s * s * (1.0 - s) ** 2 / length
    ddw = 60.0 * s * (1.0 - s) * (1.0 - 2.0 * s) / length**2
    return w, dw, ddw


def profile(x, omega, amplitude, phase, fade_start, fade_length):
    """The rail profile z and its derivatives z', z'' along the track at the positions x (array)."""
    theta = np.outer(x, omega) + phase
    cos, sin = np.cos(theta), np.sin(theta)
    r = np.sum(amplitude * cos, axis=1)
    dr = -np.sum(amplitude * omega * sin, axis=1)
    ddr = -np.sum(amplitude * omega**2 * cos, axis=1)
    w, dw, ddw = fade(x, fade_start, fade_length)
    return w * r, dw * r + w * dr, ddw * r + 2.0 * dw * dr + w * ddr


# name -> (type, start value, unit, description) of the parameters; the attribute of the same name
# holds the value.
PARAMETERS = {
    "track_class": (Integer, 4, "", "FRA track class, 1 (worst) ... 6 (best): A_v of the vertical-profile spectrum"),
    "seed": (Integer, 1, "", "seed of the harmonics' random phases (the same seed, the same track)"),
    "harmonics": (Integer, 1000, "", "number of harmonics, >= 1"),
    "amplitude_scale": (Real, 1.0, "", "factor on every amplitude (1: the class's spectrum; 0: a flat track); >= 0"),
    "wavelength_min": (Real, 1.5, "m", "shortest wavelength of the profile; > 0"),
    "wavelength_max": (Real, 120.0, "m", "longest wavelength of the profile; > wavelength_min"),
    "fade_start": (Real, 10.0, "m", "the rails are flat up to this position along the track"),
    "fade_length": (Real, 20.0, "m", "length over which the irregularity fades in; > 0"),
}
SIGNALS = {
    "x": (Fmi2Causality.input, "m", "longitudinal position of wheel {w} (the vehicle's wheel_{w}.r[1])"),
    "v": (Fmi2Causality.input, "m/s", "longitudinal speed of wheel {w} (the vehicle's wheel_{w}.v[1])"),
    "z": (Fmi2Causality.output, "m", "rail height under wheel {w} (for the vehicle's rail_{w}.q)"),
    "zd": (Fmi2Causality.output, "m/s", "rate of the rail height under wheel {w} (for rail_{w}.qd)"),
    "zdd": (Fmi2Causality.output, "m/s2", "acceleration of the rail height under wheel {w} (for rail_{w}.qdd)"),
}
# unit -> exponents of the SI base units, and its display units (none)
UNITS = {
    "m": ({"m": 1}, []),
    "m/s": ({"m": 1, "s": -1}, []),
    "m/s2": ({"m": 1, "s": -2}, []),
}


class TrackIrregularity(SampledSlave):
    description = "Vertical track irregularity (FRA class spectrum, random-phase harmonics) under the 8 wheels of the rail vehicle"

    def __init__(self, **kwargs):
        super().__init__("track_irregularity", 14.0, 0.001, **kwargs)
        self.profile_rms = 0.0
        self.units = {}
        for name, (kind, start, unit, description) in PARAMETERS.items():
            setattr(self, name, start)
            self.register_variable(
                kind(name, causality=Fmi2Causality.parameter, variability=Fmi2Variability.fixed, description=description)
            )
            self.units[name] = unit
        self.register_variable(
            Real(
                "profile_rms",
                causality=Fmi2Causality.calculatedParameter,
                variability=Fmi2Variability.fixed,
                description="RMS of the profile once faded in: sqrt(sum of the harmonics' amplitudes^2 / 2)",
            )
        )
        self.units["profile_rms"] = "m"
        for w in WHEELS:
            for prefix, (causality, unit, description) in SIGNALS.items():
                name = f"{prefix}_{w}"
                setattr(self, name, 0.0)
                variability = Fmi2Variability.continuous if causality == Fmi2Causality.input else Fmi2Variability.discrete
                self.register_variable(
                    Real(name, causality=causality, variability=variability, description=description.format(w=w))
                )
                self.units[name] = unit
        self.previous_speeds = None  # the speeds at the last communication point, and its step

    def exit_initialization_mode(self):
        checks = {
            "track_class": self.track_class in FRA_CLASSES,
            "harmonics": self.harmonics >= 1,
            "amplitude_scale": self.amplitude_scale >= 0.0,
            "wavelength_min": self.wavelength_min > 0.0,
            "wavelength_max": self.wavelength_max > self.wavelength_min,
            "fade_length": self.fade_length > 0.0,
            "fade_start": True,
            "seed": True,
        }
        if not self.check_parameters(checks, {name: PARAMETERS[name][3] for name in PARAMETERS}):
            return
        self.omega, self.amplitude, self.phase = harmonics(
            self.track_class, self.seed, self.harmonics, self.wavelength_min, self.wavelength_max, self.amplitude_scale
        )
        self.profile_rms = float(np.sqrt(np.sum(self.amplitude**2) / 2.0))

    def do_step(self, current_time, step_size):
        if self.step_refused():
            return False
        x = np.array([getattr(self, f"x_{w}") for w in WHEELS])
        v = np.array([getattr(self, f"v_{w}") for w in WHEELS])
        if self.previous_speeds is None:
            a = np.zeros_like(v)
        else:
            v_before, h_before = self.previous_speeds
            a = (v - v_before) / h_before
        self.previous_speeds = (v, step_size)
        h = step_size
        x_next = x + v * h + 0.5 * a * h * h
        v_next = v + a * h
        z, dz, ddz = profile(x_next, self.omega, self.amplitude, self.phase, self.fade_start, self.fade_length)
        zd = dz * v_next
        zdd = ddz * v_next * v_next + dz * a
        for i, w in enumerate(WHEELS):
            setattr(self, f"z_{w}", float(z[i]))
            setattr(self, f"zd_{w}", float(zd[i]))
            setattr(self, f"zdd_{w}", float(zdd[i]))
        return True

    def to_xml(self, model_options=None):
        """pythonfmu's model description, completed with the units and the outputs' dependencies
        (none: see the module's docstring)."""
        root = super().to_xml(model_options or {})
        insert_unit_definitions(root, UNITS)
        for variable in root.find("ModelVariables"):
            unit = self.units[variable.get("name")]
            real = variable.find("Real")
            if unit and real is not None:
                real.set("unit", unit)
        structure, outputs = outputs_depend_on_no_input(root)
        # InitialUnknowns, by index: profile_rms (a calculated parameter: it depends on the
        # parameters, so no `dependencies` attribute), then the outputs (0 until the first step,
        # dependent on nothing).
        initial = SubElement(structure, "InitialUnknowns")
        variables = list(root.find("ModelVariables"))
        calculated = [i for i, v in enumerate(variables, 1) if v.get("causality") == "calculatedParameter"]
        for index in sorted(calculated + [int(u.get("index")) for u in outputs]):
            unknown = SubElement(initial, "Unknown", index=str(index))
            if index not in calculated:
                unknown.set("dependencies", "")
        return root
