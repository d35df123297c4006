#!/usr/bin/env python3
"""Peer comparison with MuJoCo (PyPI `mujoco`): N spheres in a box, speed and accuracy.

The scene is contact-fmu's own `sphere_box` generator (src/bench/scenes.rs), written to a
scene file by `contact-fmu bench scaling --n N --write-scene PATH` and translated here into
MJCF: one free body per sphere (sphere geom, same radius, mass and inertia 2/5 m R²), the
box walls as planes, the initial velocities set into qvel, no gravity, no friction
(condim 1: the scene is frictionless). contact-fmu declares 3 neighbour pairs per sphere and
a wall only for the spheres facing it (valid while no sphere travels farther than a lattice
spacing, 25 mm); the MJCF model declares exactly those pairs (`<contact><pair>`, collisions
by contype/conaffinity off), so both codes compute the same contact set ("same pairs").
A second MuJoCo model lets every geom collide with every other (MuJoCo's own broad phase),
which is valid for a whole simulated second ("all pairs").

MuJoCo's contact is a soft constraint, not a force law. In its "direct" form
(solref = (-s, -b)) with impedance d(δ) from solimp = (d0, dmax, w, mid, p) the normal
dynamics of a contact are (MuJoCo's documentation, "Solver parameters")

    δ̈ = -(d/dmax)² s δ - (d/dmax) b δ̇ + (1 - d) a0,

a0 the acceleration without the contact. Hertz is δ̈ = -(K/μ) δ^1.5 (μ the reduced mass).
So: dmax small (0.005: the (1 - d) a0 term is a0 to 0.5 %), s = (K/μ) √w, and the solimp
shape (d0/dmax, mid, p; p ≥ 1) fitted so that (d/dmax)² ≈ (δ/w)^0.5 on 0.01 ≤ δ/w ≤ 1. MuJoCo
cannot reproduce δ^0.25 near 0 (its shape functions are powers ≥ 1), so the fit is
approximate (the script prints its largest force error), and beyond δ = w the law is linear
(softer than Hertz). w is set to WIDTH_FACTOR × the Hertz δ_max of the fastest impact
expected (sphere-sphere at 2 × 0.3·√3 m/s, wall at 0.3·√3 m/s). b is calibrated (bisection on
a MuJoCo run of one contact) so that the restitution at the scene's typical speed equals the
one contact-fmu's `hertz_ln` (e = 0.8) gives, measured by a contact-fmu run.

Timestep: MuJoCo's semi-implicit Euler, MJ_DT = 1e-4 s (contact duration 1.66 ms at 0.3 m/s:
16 steps per impact; the accuracy section sweeps dt and prints the error of each).

contact-fmu runs `contact-fmu bench run` (timing inside the process, setup excluded), the
scene's own settings (dopri5, rtol 1e-6), stop time FMU_TIME[N]; MuJoCo runs the same window
with the same pairs, and 1 s with all pairs. contact-fmu also runs the same spheres with contact
groups (every pair may touch, as in MuJoCo's "all pairs"; the scene of `contact-fmu bench
islands`, written by its --write-scene): the default method (auto, rtol 1e-6) as independent
islands, the same window. Times are per simulated second, medians of
BENCH_REPEATS (3) runs, wall clock and CPU time (contact-fmu: its engine thread; MuJoCo: the
process around mj_step).

Accuracy: (a) one ball (R = 10 mm, 32.9 g, K = 1e7 N/m^1.5 as in sphere_box) thrown at a plane
at 0.1, 0.3, 1 m/s without gravity (so that the closed form is exact): peak penetration,
contact duration and rebound speed against δ_max = (5 m v²/(4K))^(2/5), t_c = 2.94328 δ_max/v,
v_out = v (pure Hertz, undamped: contact-fmu `hertz`, MuJoCo b = 0); then the damped laws'
restitution. (b) a column of COLUMN balls resting on the floor under gravity: each contact's
penetration after 1 s against static Hertz δ = (F/K)^(2/3), F the weight above it.

Writes docs/mujoco_comparison.csv, docs/mujoco_accuracy.csv, docs/img/mujoco_comparison.png.
Run from the repository root after `cargo build --release`, with a Python that has mujoco,
numpy and matplotlib:
    python3 -m venv .venv-mj && .venv-mj/bin/pip install mujoco numpy matplotlib
    .venv-mj/bin/python scripts/bench_mujoco.py
Environment: BENCH_N (default 100,300,1000), BENCH_REPEATS (3), MJ_DT (1e-4),
BENCH_PARTS (speed,accuracy), BENCH_MJ_ONLY_N (N run by MuJoCo only, e.g. 3000).
"""
import csv
import math
import os
import statistics
import subprocess
import sys
import time
import tomllib

import numpy as np
import mujoco

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXE = os.path.join(ROOT, "target", "release", "contact-fmu")
WORK = os.path.join(ROOT, "target", "bench", "mujoco")
REPEATS = int(os.environ.get("BENCH_REPEATS", "3"))
MJ_DT = float(os.environ.get("MJ_DT", "1e-4"))
NS = [int(x) for x in os.environ.get("BENCH_N", "100,300,1000").split(",") if x]
MJ_ONLY_NS = [int(x) for x in os.environ.get("BENCH_MJ_ONLY_N", "").split(",") if x]
PARTS = os.environ.get("BENCH_PARTS", "speed,accuracy").split(",")
# contact-fmu's simulated time per N [s]: the declared pairs hold while no sphere travels
# farther than a lattice spacing (25 mm; 0.3 m/s per axis at most), and large N is slow
FMU_TIME = {10: 0.1, 30: 0.1, 100: 0.1, 300: 0.1, 1000: 0.05, 3000: 0.05}
MJ_TIME_ALL = 1.0  # MuJoCo, all pairs: a whole simulated second
R, M, K = 0.01, 0.0329, 1e7  # sphere_box's balls and contact stiffness
V_TYP = 0.3  # the scene's typical speed [m/s] (velocities uniform in ±0.3 per axis)
DMAX = 0.005
WIDTH_FACTOR = 1.5
COLUMN = 4
GAP = 1e-6  # the column's balls start 1 µm apart (and 1 µm above the floor)
G = 9.81


# ---------------------------------------------------------------- Hertz and MuJoCo's law
def hertz_dmax(mu, k, v):
    return (5 * mu * v * v / (4 * k)) ** 0.4


def mj_impedance_shape(x, c, mid, p):
    """MuJoCo's impedance d(x)/dmax for x = δ/w (solimp shape; c = d0/dmax)."""
    x = np.clip(np.asarray(x, dtype=float), 0.0, 1.0)
    if p == 1:
        y = x
    else:
        y = np.where(x <= mid, x ** p / mid ** (p - 1), 1 - (1 - x) ** p / (1 - mid) ** (p - 1))
    return c + (1 - c) * y


def fit_shape():
    """(c, mid, p) with (d/dmax)² closest to x^0.5 on 0.01 ≤ x ≤ 1 (largest log error)."""
    xs = np.logspace(-2, 0, 200)
    target = 0.5 * np.log(xs)
    best = None
    for c in np.linspace(0.02, 0.9, 45):
        for mid in [0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9]:
            for p in [1, 1.25, 1.5, 1.75, 2, 2.5, 3, 4, 5, 6]:
                err = np.max(np.abs(2 * np.log(mj_impedance_shape(xs, c, mid, p)) - target))
                if best is None or err < best[0]:
                    best = (err, c, mid, p)
    err, c, mid, p = best
    return dict(c=c, mid=mid, p=p, log_err=err, force_err=math.exp(err) - 1)


SHAPE = None


def mj_contact(mu, k, v_max, damping=0.0):
    """solref, solimp of a Hertz contact (stiffness k, reduced mass mu) fitted up to the
    penetration of an impact at v_max."""
    w = WIDTH_FACTOR * hertz_dmax(mu, k, v_max)
    s = (k / mu) * math.sqrt(w)
    c, mid, p = SHAPE["c"], SHAPE["mid"], SHAPE["p"]
    solimp = [max(c * DMAX, 1e-4), DMAX, w, mid, p]
    return [-s, -damping], solimp


def fmt(v):
    return " ".join(f"{x:.9g}" for x in v)


# ---------------------------------------------------------------- MJCF
def ball_plane_mjcf(mass, solref, solimp, dt, gravity=0.0):
    # solref None: MuJoCo's default contact (solref 0.02 1, solimp 0.9 0.95 0.001 0.5 2)
    law = "" if solref is None else f'solref="{fmt(solref)}" solimp="{fmt(solimp)}"'
    return f"""<mujoco model="ball_plane">
  <option timestep="{dt!r}" gravity="0 0 {-gravity!r}" integrator="Euler"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1" contype="0" conaffinity="0"/>
    <body name="ball" pos="0 0 {R!r}"><freejoint/>
      <geom name="ball" type="sphere" size="{R!r}" mass="{mass!r}" contype="0" conaffinity="0"/></body>
  </worldbody>
  <contact><pair geom1="ball" geom2="floor" condim="1" {law}/></contact>
</mujoco>"""


def impact_mujoco(v, solref, solimp, dt, mass=M):
    """Ball at the plane (just touching) at speed v, no gravity: (δ_max, t_c, v_out)."""
    m = mujoco.MjModel.from_xml_string(ball_plane_mjcf(mass, solref, solimp, dt))
    d = mujoco.MjData(m)
    d.qpos[2] = R + 0.2 * v * dt  # touches within the first step
    d.qvel[2] = -v
    ts, deltas = [0.0], [R - d.qpos[2]]
    for _ in range(int(1.0 / (v * dt)) + 100000):
        mujoco.mj_step(m, d)
        ts.append(d.time)
        deltas.append(R - d.qpos[2])
        if deltas[-1] < 0 and deltas[-2] >= 0 and len(ts) > 3:
            break
    ts, deltas = np.array(ts), np.array(deltas)
    return impact_measures(ts, deltas) + (d.qvel[2],)


def impact_measures(ts, deltas, rates=None):
    """Peak penetration (parabola through the largest sample) and time between the two
    zero crossings (linear interpolation; with `rates`, for an output that reads 0 while
    apart, linear extrapolation with δ̇ from the first and the last positive sample)."""
    i = int(np.argmax(deltas))
    if 0 < i < len(deltas) - 1:
        y0, y1, y2 = deltas[i - 1:i + 2]
        den = y0 - 2 * y1 + y2
        peak = y1 - 0.125 * (y0 - y2) ** 2 / den if den != 0 else y1
    else:
        peak = deltas[i]
    pos = deltas > 0
    cross = [j for j in range(1, len(deltas)) if pos[j] != pos[j - 1]]
    tz = [ts[j - 1] + (ts[j] - ts[j - 1]) * deltas[j - 1] / (deltas[j - 1] - deltas[j]) for j in cross]
    if rates is not None:
        inside = np.flatnonzero(pos)
        a, b = inside[0], inside[-1]
        tz = [ts[a] - deltas[a] / rates[a], ts[b] - deltas[b] / rates[b]]
    tc = tz[1] - tz[0] if len(tz) >= 2 else float("nan")
    return peak, tc


def calibrate_damping(mu, k, v_max, v_ref, e_target, dt):
    """b such that MuJoCo's rebound ratio at v_ref is e_target (bisection)."""
    lo, hi = 0.0, 1.0
    while True:
        solref, solimp = mj_contact(mu, k, v_max, hi)
        if impact_mujoco(v_ref, solref, solimp, dt, mass=mu)[2] / v_ref < e_target:
            break
        hi *= 2
    for _ in range(40):
        b = 0.5 * (lo + hi)
        solref, solimp = mj_contact(mu, k, v_max, b)
        e = impact_mujoco(v_ref, solref, solimp, dt, mass=mu)[2] / v_ref
        lo, hi = (b, hi) if e > e_target else (lo, b)
    return 0.5 * (lo + hi)


def sphere_box_mjcf(scene, params, dt, all_pairs):
    """MJCF of a contact-fmu sphere_box scene. params: {"ss": (solref, solimp), "wall": ...}."""
    bodies, walls, pairs = [], {}, []
    for b in scene["body"]:
        bodies.append(b)
    for c in scene["contact"]:
        if c["type"] == "sphere_sphere":
            pairs.append(("ss", c["sphere_body"], c["body"]))
        elif c["type"] == "sphere_plane":
            n = c["normal"]
            off = sum(a * b for a, b in zip(n, c["origin"]))
            key = (tuple(n), round(off, 12))
            if key not in walls:
                walls[key] = (f"wall{len(walls)}", c["origin"], n)
            pairs.append(("wall", c["sphere_body"], walls[key][0]))
        else:
            raise ValueError(f"contact type {c['type']} not translated")
    ss_ref, ss_imp = params["ss"]
    w_ref, w_imp = params["wall"]
    col = 'contype="1" conaffinity="1"' if all_pairs else 'contype="0" conaffinity="0"'
    out = [f'<mujoco model="sphere_box">\n  <option timestep="{dt!r}" gravity="0 0 0" integrator="Euler"/>',
           '  <size memory="500M"/>\n  <worldbody>']
    for name, o, n in walls.values():
        # walls win the parameter mixing (priority) in the all-pairs model
        out.append(f'    <geom name="{name}" type="plane" pos="{fmt(o)}" zaxis="{fmt(n)}" size="1 1 0.1" {col} '
                   f'condim="1" priority="1" solref="{fmt(w_ref)}" solimp="{fmt(w_imp)}"/>')
    for b in bodies:
        out.append(f'    <body name="{b["name"]}" pos="{fmt(b["position"])}"><freejoint/>'
                   f'<geom name="{b["name"]}" type="sphere" size="{R!r}" mass="{b["mass"]!r}" {col} condim="1" '
                   f'solref="{fmt(ss_ref)}" solimp="{fmt(ss_imp)}"/></body>')
    out.append("  </worldbody>")
    if not all_pairs:
        out.append("  <contact>")
        for kind, g1, g2 in pairs:
            ref, imp = params[kind]
            out.append(f'    <pair geom1="{g1}" geom2="{g2}" condim="1" solref="{fmt(ref)}" solimp="{fmt(imp)}"/>')
        out.append("  </contact>")
    out.append("</mujoco>")
    return "\n".join(out)


def run_mujoco(scene, params, dt, t_end, all_pairs, repeats=REPEATS):
    m = mujoco.MjModel.from_xml_string(sphere_box_mjcf(scene, params, dt, all_pairs))
    nsteps = int(round(t_end / dt))
    walls, cpus, kes, ncon = [], [], [], []
    for _ in range(repeats):
        d = mujoco.MjData(m)
        for i, b in enumerate(scene["body"]):
            d.qvel[6 * i:6 * i + 3] = b["velocity"]
        mujoco.mj_forward(m, d)
        t0, c0 = time.perf_counter(), time.process_time()
        counted = 0
        chunk = max(1, nsteps // 20)
        done = 0
        while done < nsteps:
            k = min(chunk, nsteps - done)
            mujoco.mj_step(m, d, nstep=k)
            done += k
            counted += d.ncon
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
        v = d.qvel.reshape(-1, 6)
        kes.append(0.5 * sum(b["mass"] * float(v[i, :3] @ v[i, :3]) for i, b in enumerate(scene["body"])))
        ncon.append(counted / math.ceil(nsteps / chunk))
    return dict(seconds=statistics.median(walls) / t_end, cpu=statistics.median(cpus) / t_end, steps=nsteps,
                ke=kes[-1], ncon=ncon[-1], npairs=m.npair)


# ---------------------------------------------------------------- contact-fmu
def write_scene(n):
    path = os.path.join(WORK, f"sphere_box_{n}.toml")
    subprocess.run([EXE, "bench", "scaling", "--n", str(n), "--time", "1.0", "--write-scene", path], check=True)
    with open(path, "rb") as f:
        return path, tomllib.load(f)


def write_islands_scene(n, t_end):
    """The same spheres with contact groups (every pair may touch, MuJoCo's "all pairs"), the
    default method, as independent islands: the scene of `contact-fmu bench islands`."""
    path = os.path.join(WORK, f"sphere_box_groups_{n}.toml")
    subprocess.run([EXE, "bench", "islands", "--n", str(n), "--time", repr(t_end), "--write-scene", path], check=True)
    return path


def run_fmu(path, t_end, repeats=REPEATS, sets=(), csv_path=None, interval=None):
    cmd = [EXE, "bench", "run", path, "--stop-time", repr(t_end), "--interval", repr(interval or t_end / 10),
           "--repeats", str(repeats)]
    if csv_path:
        cmd += ["--csv", csv_path]
    for s in sets:
        cmd += ["--set", s]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(res.stderr)
    kv = dict(x.split("=", 1) for x in res.stdout.split() if "=" in x)
    return dict(seconds=float(kv["seconds"]) / t_end, cpu=float(kv["cpu_seconds"]) / t_end, steps=int(kv["steps"]),
                events=int(kv["events"]), status=kv["status"])


def read_csv(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def toml_ball(law, v, restitution=0.8, gravity=0.0, t_end=None, column=1):
    """A column of `column` balls on a plane (the lowest just touching it, the others just
    touching the one below), the lowest moving down at v."""
    gap = GAP if column > 1 else v * 1e-5
    t_end = t_end or gap / v + 2 * 2.94328 * hertz_dmax(M, K, v) / v
    s = [f'[model]\nname = "mj_ball"\ngravity = [0.0, 0.0, {-gravity!r}]\nstop_time = {t_end!r}\ninterval = 1e-3\n\n'
         '[solver]\nmethod = "dopri5"\nrtol = 1e-10\natol = 1e-13\n']
    z = [R + gap + (2 * R + gap) * i for i in range(column)]
    for i in range(column):
        s.append(f'[[body]]\nname = "b{i}"\nmass = {M!r}\ninertia = [1.316e-6, 1.316e-6, 1.316e-6]\n'
                 f'position = [0.0, 0.0, {z[i]!r}]\nvelocity = [0.0, 0.0, {-v if i == 0 else 0.0!r}]\n')
    s.append(f'[[contact]]\nname = "floor"\ntype = "sphere_plane"\nlaw = "{law}"\nrestitution = {restitution!r}\n'
             f'stiffness = {K!r}\nsphere_body = "b0"\ncenter = [0.0, 0.0, {z[0]!r}]\nradius = {R!r}\nbody = "ground"\n'
             'origin = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nu_axis = [1.0, 0.0, 0.0]\nsize = [1.0, 1.0]\n')
    for i in range(1, column):
        s.append(f'[[contact]]\nname = "c{i}"\ntype = "sphere_sphere"\nlaw = "{law}"\nrestitution = {restitution!r}\n'
                 f'stiffness = {K!r}\nsphere_body = "b{i - 1}"\ncenter = [0.0, 0.0, {z[i - 1]!r}]\n'
                 f'radius = {R!r}\nbody = "b{i}"\nother_center = [0.0, 0.0, {z[i]!r}]\nother_radius = {R!r}\n')
    return "\n".join(s)


def impact_fmu(law, v, restitution=0.8):
    path = os.path.join(WORK, f"ball_{law}_{v}.toml")
    with open(path, "w") as f:
        f.write(toml_ball(law, v, restitution))
    t_end = 1e-5 + 2 * 2.94328 * hertz_dmax(M, K, v) / v
    traj = os.path.join(WORK, "ball_traj.csv")
    subprocess.run([EXE, "simulate", path, "--interval", repr(t_end / 4000), "--csv", traj, "--quiet"], check=True)
    c = read_csv(traj)
    peak, tc = impact_measures(c["time"], c["floor.delta"], c["floor.delta_dot"])
    return peak, tc, c["b0.v[3]"][-1]


# ---------------------------------------------------------------- parts
def accuracy(params_for):
    rows = []
    print(f"\nMuJoCo law: solimp shape d0/dmax = {SHAPE['c']:.3f}, midpoint {SHAPE['mid']}, power {SHAPE['p']}; "
          f"(d/dmax)² against (δ/w)^0.5 on 0.01 ≤ δ/w ≤ 1: largest force error {100 * SHAPE['force_err']:.1f} %")
    print("\n(a) one ball thrown at a plane, no gravity, pure Hertz (undamped), K = 1e7 N/m^1.5:")
    print(f"{'code':32s} {'v [m/s]':>7s} {'δ_max [µm]':>11s} {'err':>8s} {'t_c [ms]':>9s} {'err':>8s} "
          f"{'v_out/v':>9s}")
    v_max_wall = V_TYP * math.sqrt(3)
    for v in [0.1, 0.3, 1.0]:
        dm = hertz_dmax(M, K, v)
        tc = 2.94328 * dm / v
        print(f"{'closed form':32s} {v:7.2f} {dm * 1e6:11.4f} {'':8s} {tc * 1e3:9.5f} {'':8s} {1.0:9.6f}")
        res = [("contact-fmu hertz (dopri5 1e-10)",) + impact_fmu("hertz", v)]
        for dt in [2e-4, 1e-4, 5e-5, 2e-5, 1e-5]:
            solref, solimp = mj_contact(M, K, v_max_wall, 0.0)
            res.append((f"MuJoCo dt {dt:.0e}",) + impact_mujoco(v, solref, solimp, dt))
        res.append((f"MuJoCo defaults, dt {MJ_DT:.0e}",) + impact_mujoco(v, None, None, MJ_DT))
        for name, p, t, vo in res:
            vout = vo / v
            print(f"{name:32s} {v:7.2f} {p * 1e6:11.4f} {p / dm - 1:+8.2%} {t * 1e3:9.5f} {t / tc - 1:+8.2%} "
                  f"{vout:9.6f}")
            rows.append(dict(test="impact_hertz", code=name, v=v, quantity="delta_max", value=p, reference=dm))
            rows.append(dict(test="impact_hertz", code=name, v=v, quantity="contact_time", value=t, reference=tc))
            rows.append(dict(test="impact_hertz", code=name, v=v, quantity="rebound_ratio", value=vout, reference=1.0))
    print("\n    damped (the sphere_box laws: contact-fmu hertz_ln e = 0.8; MuJoCo b calibrated at "
          f"{V_TYP} m/s), rebound ratio v_out/v:")
    solref, solimp = params_for["wall"]
    for v in [0.1, 0.3, 1.0]:
        a = impact_fmu("hertz_ln", v)
        b = impact_mujoco(v, solref, solimp, MJ_DT)
        print(f"    v = {v:4.2f} m/s: contact-fmu {a[2] / v:.4f}, MuJoCo (dt {MJ_DT:.0e}) {b[2] / v:.4f}; "
              f"δ_max contact-fmu {a[0] * 1e6:.3f} µm, MuJoCo {b[0] * 1e6:.3f} µm")
        rows.append(dict(test="impact_damped", code="contact-fmu hertz_ln e=0.8", v=v, quantity="rebound_ratio",
                         value=a[2] / v, reference=float("nan")))
        rows.append(dict(test="impact_damped", code=f"MuJoCo dt {MJ_DT:.0e}", v=v, quantity="rebound_ratio",
                         value=b[2] / v, reference=a[2] / v))

    print(f"\n(b) a column of {COLUMN} balls resting on the floor, gravity, after 1 s; penetration of each contact:")
    loads = [(COLUMN - i) * M * G for i in range(COLUMN)]
    static = [(f / K) ** (2 / 3) for f in loads]
    path = os.path.join(WORK, "column.toml")
    with open(path, "w") as f:
        f.write(toml_ball("hertz_ln", 0.0, 0.8, gravity=G, t_end=1.0, column=COLUMN))
    traj = os.path.join(WORK, "column_traj.csv")
    subprocess.run([EXE, "simulate", path, "--interval", "0.01", "--csv", traj, "--quiet"], check=True)
    c = read_csv(traj)
    fmu = [c["floor.delta"][-1]] + [c[f"c{i}.delta"][-1] for i in range(1, COLUMN)]
    mj = {}
    for dt in [MJ_DT, MJ_DT / 10]:
        mj[dt] = column_mujoco(params_for, dt)
    print(f"{'contact':8s} {'load [N]':>9s} {'Hertz [µm]':>11s} {'contact-fmu':>12s} {'err':>9s}" +
          "".join(f" {'MuJoCo dt ' + format(dt, '.0e'):>16s} {'err':>8s}" for dt in mj))
    for i in range(COLUMN):
        name = "floor" if i == 0 else f"b{i - 1}-b{i}"
        line = (f"{name:8s} {loads[i]:9.4f} {static[i] * 1e6:11.4f} {fmu[i] * 1e6:12.4f} "
                f"{fmu[i] / static[i] - 1:+9.2e}")
        rows.append(dict(test="column", code="contact-fmu hertz_ln", v=i, quantity="delta", value=fmu[i],
                         reference=static[i]))
        for dt, vals in mj.items():
            line += f" {vals[i] * 1e6:16.4f} {vals[i] / static[i] - 1:+8.2%}"
            rows.append(dict(test="column", code=f"MuJoCo dt {dt:.0e}", v=i, quantity="delta", value=vals[i],
                             reference=static[i]))
        print(line)
    return rows


def column_mujoco(params_for, dt):
    w_ref, w_imp = params_for["wall"]
    s_ref, s_imp = params_for["ss"]
    bodies = "".join(f'<body name="b{i}" pos="0 0 {R + GAP + (2 * R + GAP) * i!r}"><freejoint/><geom name="b{i}" type="sphere" '
                     f'size="{R!r}" mass="{M!r}" contype="0" conaffinity="0"/></body>' for i in range(COLUMN))
    pairs = f'<pair geom1="b0" geom2="floor" condim="1" solref="{fmt(w_ref)}" solimp="{fmt(w_imp)}"/>' + "".join(
        f'<pair geom1="b{i - 1}" geom2="b{i}" condim="1" solref="{fmt(s_ref)}" solimp="{fmt(s_imp)}"/>'
        for i in range(1, COLUMN))
    xml = (f'<mujoco><option timestep="{dt!r}" gravity="0 0 {-G!r}" integrator="Euler"/><worldbody>'
           f'<geom name="floor" type="plane" size="1 1 0.1" contype="0" conaffinity="0"/>{bodies}</worldbody>'
           f'<contact>{pairs}</contact></mujoco>')
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_step(m, d, nstep=int(round(1.0 / dt)))
    z = [d.qpos[7 * i + 2] for i in range(COLUMN)]
    return [R - z[0]] + [2 * R - (z[i] - z[i - 1]) for i in range(1, COLUMN)]


def speed(params_for):
    rows = []
    print(f"\nsphere_box: time per simulated second [s] (medians of {REPEATS}; wall clock, CPU in brackets)")
    print(f"{'N':>6s} {'pairs':>6s} {'fmu T':>6s} {'contact-fmu':>20s} {'steps':>6s} {'events':>7s} "
          f"{'MuJoCo same pairs':>20s} {'MuJoCo all pairs 1 s':>21s} {'ratio (CPU)':>11s} {'KE end fmu/MJ':>14s} "
          f"{'islands CPU, / same, / all':>25s}")
    for n in sorted(set(NS + MJ_ONLY_NS)):
        path, scene = write_scene(n)
        t_fmu = FMU_TIME.get(n, 0.05)
        row = dict(n=n, contacts=len(scene["contact"]), fmu_time=t_fmu, mj_dt=MJ_DT)
        if n in NS:
            # (N ≥ 3,000: one run of ~2 minutes, as `bench scaling` does; no trajectory)
            traj = os.path.join(WORK, f"traj_{n}.csv") if n <= 1000 else None
            f = run_fmu(path, t_fmu, repeats=REPEATS if n < 3000 else 1, csv_path=traj)
            row.update(fmu_seconds=f["seconds"], fmu_cpu=f["cpu"], fmu_steps=f["steps"], fmu_events=f["events"],
                       fmu_status=f["status"])
            if traj:
                with open(traj) as fh:
                    last = list(csv.DictReader(fh))[-1]
                row["fmu_ke_end"] = float(last["energy.kinetic"]) + float(last["energy.contact"])
            g = run_fmu(write_islands_scene(n, t_fmu), t_fmu, repeats=REPEATS if n < 3000 else 1)
            row.update(fmu_islands_seconds=g["seconds"], fmu_islands_cpu=g["cpu"], fmu_islands_steps=g["steps"],
                       fmu_islands_status=g["status"])
        a = run_mujoco(scene, params_for, MJ_DT, t_fmu, all_pairs=False)
        b = run_mujoco(scene, params_for, MJ_DT, MJ_TIME_ALL, all_pairs=True)
        row.update(mj_same_seconds=a["seconds"], mj_same_cpu=a["cpu"], mj_ke_end=a["ke"], mj_same_ncon=a["ncon"],
                   mj_all_seconds=b["seconds"], mj_all_cpu=b["cpu"], mj_all_ncon=b["ncon"])
        fs = f"{row['fmu_seconds']:9.3g} ({row['fmu_cpu']:7.3g})" if "fmu_seconds" in row else f"{'—':>20s}"
        ratio = f"{row['fmu_cpu'] / row['mj_same_cpu']:11.0f}" if "fmu_cpu" in row else f"{'—':>11s}"
        ke = f"{row['fmu_ke_end'] / row['mj_ke_end']:14.4f}" if "fmu_ke_end" in row else f"{'—':>14s}"
        isl = (f"{row['fmu_islands_cpu']:9.3g} {row['fmu_islands_cpu'] / row['mj_same_cpu']:6.1f}x "
               f"{row['fmu_islands_cpu'] / row['mj_all_cpu']:6.1f}x") if "fmu_islands_cpu" in row else f"{'—':>25s}"
        print(f"{n:6d} {row['contacts']:6d} {t_fmu:6.2f} {fs} {row.get('fmu_steps', 0):6d} {row.get('fmu_events', 0):7d} "
              f"{a['seconds']:9.3g} ({a['cpu']:7.3g}) {b['seconds']:9.3g} ({b['cpu']:7.3g}) {ratio} {ke} {isl}", flush=True)
        rows.append(row)
    return rows


def slopes(rows):
    """Least-squares exponents of CPU time per simulated second against N (N ≥ 100)."""
    out = {}
    for key in ["fmu_cpu", "fmu_islands_cpu", "mj_same_cpu", "mj_all_cpu"]:
        pts = [(r["n"], r[key]) for r in rows if r["n"] >= 100 and r.get(key)]
        if len(pts) >= 2:
            x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
            out[key] = float(np.polyfit(x, y, 1)[0])
    print("fitted exponents (CPU time per simulated second ∝ N^k, N ≥ 100): " +
          ", ".join(f"{k} {v:.2f}" for k, v in out.items()))
    return out


def plot(rows):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4.2))
    r = [x for x in rows if "fmu_cpu" in x]
    ax.loglog([x["n"] for x in r], [x["fmu_cpu"] for x in r], "o-",
              label="contact-fmu, pair list, one integrator (dopri5, rtol 1e-6)")
    ri = [x for x in rows if "fmu_islands_cpu" in x]
    ax.loglog([x["n"] for x in ri], [x["fmu_islands_cpu"] for x in ri], "D-",
              label="contact-fmu, contact groups as islands (the defaults)")
    ax.loglog([x["n"] for x in rows], [x["mj_same_cpu"] for x in rows], "s-",
              label=f"MuJoCo, same pairs (dt {MJ_DT:g} s)")
    ax.loglog([x["n"] for x in rows], [x["mj_all_cpu"] for x in rows], "^--",
              label=f"MuJoCo, all pairs, 1 s (dt {MJ_DT:g} s)")
    ax.set_xlabel("N spheres")
    ax.set_ylabel("CPU time per simulated second [s]")
    ax.set_title("N spheres in a box: contact-fmu and MuJoCo")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    os.makedirs(os.path.join(ROOT, "docs", "img"), exist_ok=True)
    fig.savefig(os.path.join(ROOT, "docs", "img", "mujoco_comparison.png"), dpi=120)
    print("wrote docs/img/mujoco_comparison.png")


def write_rows(path, rows):
    keys = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6e}" if isinstance(v, float) else v) for k, v in r.items()})
    print(f"wrote {os.path.relpath(path, ROOT)}")


def main():
    global SHAPE
    os.makedirs(WORK, exist_ok=True)
    print(f"MuJoCo {mujoco.__version__}")
    SHAPE = fit_shape()
    # the restitution contact-fmu's hertz_ln (e = 0.8) gives at the typical speed (scale-free)
    e_fmu = impact_fmu("hertz_ln", V_TYP)[2] / V_TYP
    v_wall = V_TYP * math.sqrt(3)  # fastest wall impact: 0.3 m/s on each axis
    v_ss = 2 * v_wall  # fastest sphere-sphere impact
    b_wall = calibrate_damping(M, K, v_wall, V_TYP, e_fmu, MJ_DT)
    b_ss = calibrate_damping(M / 2, K, v_ss, V_TYP, e_fmu, MJ_DT)
    params_for = {"wall": mj_contact(M, K, v_wall, b_wall), "ss": mj_contact(M / 2, K, v_ss, b_ss)}
    print(f"contact-fmu hertz_ln e = 0.8 rebounds at {e_fmu:.4f} v; MuJoCo damping calibrated to it at {V_TYP} m/s")
    for k, (ref, imp) in params_for.items():
        print(f"  {k:5s}: solref = [{fmt(ref)}], solimp = [{fmt(imp)}]")
    if "accuracy" in PARTS:
        write_rows(os.path.join(ROOT, "docs", "mujoco_accuracy.csv"), accuracy(params_for))
    if "speed" in PARTS:
        rows = speed(params_for)
        write_rows(os.path.join(ROOT, "docs", "mujoco_comparison.csv"), rows)
        slopes(rows)
        plot(rows)


if __name__ == "__main__":
    sys.exit(main())
