"""Ride and wheel-load measures of a rail vehicle run (docs/track.md): the car body's vertical
acceleration, its RMS, two ride indices, the wheel-rail forces' dynamic increment and unloading.

- Sperling's ride index Wz (Sperling and Betzhold, Glasers Annalen 80, 1956; in the form given by
  Garg and Dukkipati, Dynamics of Railway Vehicle Systems, 1984): for each harmonic of the
  acceleration, amplitude b [cm/s^2] at the frequency f [Hz],

      Wz_i = 0.896 (b^3 F(f) / f)^(1/10),   Wz = (sum of Wz_i^10)^(1/10),

  with the vertical frequency correction F(f) = 0.325 f^2 (0.5 to 5.9 Hz), 400 / f^2 (5.9 to 20
  Hz), 1 (above 20 Hz), over 0.5 to 30 Hz. The harmonics are the lines of the discrete Fourier
  transform of the analysed record (its mean removed), so Wz depends weakly on the record's
  length T (as T^-0.05 for a broadband signal): the table gives T.
- The frequency-weighted RMS acceleration of ISO 2631-1:1997 with the weighting Wk (vertical,
  seated, comfort; Annex A: band limits 0.4 and 100 Hz, acceleration-velocity transition
  f3 = f4 = 12.5 Hz, Q4 = 0.63, upward step f5 = 2.37 Hz, Q5 = 0.91, f6 = 3.35 Hz, Q6 = 0.91),
  applied to the Fourier lines: a_w = sqrt(sum |Wk(f_i)|^2 P_i), P_i the power of line i.
"""

import math

import numpy as np

WHEELS = ("fl1", "fl2", "fr1", "fr2", "rl1", "rl2", "rr1", "rr2")
G = 9.81


def derivative(t, y):
    """dy/dt at the samples (second-order central differences; one-sided at the ends)."""
    return np.gradient(np.asarray(y, float), np.asarray(t, float), edge_order=2)


def lines(a, dt):
    """The one-sided Fourier lines of the record `a` (mean removed): frequencies [Hz], amplitudes
    (the peak amplitude of each harmonic) and powers (their mean squares; they sum to the
    record's variance)."""
    a = np.asarray(a, float) - np.mean(a)
    n = len(a)
    spectrum = np.fft.rfft(a)
    f = np.fft.rfftfreq(n, dt)
    amplitude = 2.0 * np.abs(spectrum) / n
    amplitude[0] = 0.0
    if n % 2 == 0:
        amplitude[-1] /= 2.0  # the Nyquist line is real: its amplitude is |X| / n
    power = amplitude**2 / 2.0
    if n % 2 == 0:
        power[-1] = amplitude[-1] ** 2
    return f, amplitude, power


def sperling_correction(f):
    """Sperling's vertical frequency correction F(f)."""
    f = np.asarray(f, float)
    return np.where(f < 5.9, 0.325 * f**2, np.where(f < 20.0, 400.0 / np.maximum(f, 1e-300) ** 2, 1.0))


def sperling_wz(a, dt, f_min=0.5, f_max=30.0):
    """Sperling's ride index Wz of the vertical acceleration record `a` [m/s^2] sampled at dt [s]."""
    f, amplitude, _ = lines(a, dt)
    band = (f >= f_min) & (f <= f_max)
    b = 100.0 * amplitude[band]  # cm/s^2
    terms = 0.896**10 * b**3 * sperling_correction(f[band]) / f[band]
    return float(np.sum(terms) ** 0.1)


def iso2631_wk(f):
    """|Wk(f)| of ISO 2631-1:1997 (Annex A): the product of the band limits, the
    acceleration-velocity transition and the upward step, at the frequencies f [Hz]."""
    p = 2j * math.pi * np.asarray(f, float)
    w1, w2, w3, w4, w5, w6 = (2.0 * math.pi * x for x in (0.4, 100.0, 12.5, 12.5, 2.37, 3.35))
    q4, q5, q6 = 0.63, 0.91, 0.91
    with np.errstate(divide="ignore", invalid="ignore"):
        high_pass = 1.0 / (1.0 + math.sqrt(2.0) * w1 / p + (w1 / p) ** 2)
    low_pass = 1.0 / (1.0 + math.sqrt(2.0) * p / w2 + (p / w2) ** 2)
    transition = (1.0 + p / w3) / (1.0 + p / (q4 * w4) + (p / w4) ** 2)
    step = (1.0 + p / (q5 * w5) + (p / w5) ** 2) / (1.0 + p / (q6 * w6) + (p / w6) ** 2) * (w5 / w6) ** 2
    return np.nan_to_num(np.abs(high_pass * low_pass * transition * step))


def weighted_rms(a, dt, weighting=iso2631_wk):
    """Frequency-weighted RMS of the record `a` (mean removed)."""
    f, _, power = lines(a, dt)
    return float(math.sqrt(np.sum(weighting(f) ** 2 * power)))


def static_wheel_load(vehicle_mass, wheels=8):
    """The static wheel load Q0 [N] of a vehicle whose weight its wheels share equally."""
    return vehicle_mass * G / wheels


def evaluate(result, start, vehicle_mass, body_half_length=8.75, prefix="vehicle."):
    """The measures of a run (a runner's result: columns by name, `time` first) over t >= start.

    Returns a dict: car-body vertical acceleration (from the centre of mass's vertical velocity,
    and above the leading truck from the velocity v_z - w_y x of the point x = +body_half_length
    on the car's axis) RMS, peak, Sperling's Wz, ISO 2631 Wk-weighted RMS; wheel-rail forces
    Q: static load Q0, largest Q / Q0 and smallest Q / Q0 over all wheels, the RMS of (Q - Q0) / Q0,
    whether a wheel unloaded (Q reached 0), the mean of the sum of the forces over the total
    weight; and the energy balance's largest excursion relative to the energy scale (the larger
    of |energy.total(0)| and the largest kinetic energy, as the FMU's drift watch)."""
    t = np.asarray(result["time"])
    window = t >= start - 1e-12
    dt = float(np.median(np.diff(t)))
    vz = np.asarray(result[prefix + "car.v[3]"])
    wy = np.asarray(result[prefix + "car.w[2]"])
    accelerations = {
        "centre": derivative(t, vz)[window],
        "leading truck": derivative(t, vz - wy * body_half_length)[window],
    }
    out = {"window": (float(t[window][0]), float(t[window][-1])), "dt": dt}
    for where, a in accelerations.items():
        out[where] = {
            "rms": float(np.sqrt(np.mean((a - np.mean(a)) ** 2))),
            "peak": float(np.max(np.abs(a))),
            "wz": sperling_wz(a, dt),
            "a_wk": weighted_rms(a, dt),
        }
    q0 = static_wheel_load(vehicle_mass)
    forces = np.array([np.asarray(result[f"{prefix}contact_{w}.force"])[window] for w in WHEELS])
    out["q0"] = q0
    out["q_max"] = float(forces.max() / q0)
    out["q_min"] = float(forces.min() / q0)
    out["q_rms"] = float(np.sqrt(np.mean((forces / q0 - 1.0) ** 2)))
    out["unloaded"] = bool(forces.min() <= 0.0)
    out["mean_load"] = float(np.mean(forces.sum(axis=0)) / (8.0 * q0))
    balance = np.asarray(result[prefix + "energy.total"]) + np.asarray(result[prefix + "energy.dissipated"])
    balance = balance - np.asarray(result[prefix + "energy.input_work"])
    scale = max(abs(result[prefix + "energy.total"][0]), float(np.max(result[prefix + "energy.kinetic"])))
    out["energy_drift"] = float(np.max(np.abs(balance - balance[0])) / scale)
    return out
