#!/usr/bin/env python3
"""Two free spheres: contact-fmu against a scipy model of the same impact, at equal error.

The scene is fmu/two_spheres (steel spheres R = 10 and 15 mm, m = 0.0329 and 0.111 kg, the
small one at 1 m/s, central impact, pure Hertz, no gravity, 10 ms). The scipy model is plain
Python/numpy: the two centres of mass in 3-D (12 states; the impact is central, so the spheres
do not spin and their rotations are left out), `solve_ivp` (RK45, DOP853 and LSODA; the best
at each error level counts), piecewise: free flight
until a terminal event at touch (gap crossing zero downwards), Hertz contact F = K δ^1.5
(K from the materials as contact-fmu computes it) until a terminal event at separation, free
flight to the end. Outputs on the same grid: `t_eval`, restarted after each event.

contact-fmu runs in its own process through `contact-fmu bench run --read ...` (the engine
in-process, the same twelve values as the scipy model's state -- both centres' positions and
velocities -- read at every communication point in one `Simulation::get_many` call, as a
host's fmi2GetReal receives them, scene compilation excluded): both codes are timed in-process around the simulation alone, producing the same
grid of outputs. Times: medians of REPEATS runs, wall clock and CPU time of the running
thread (the machine is shared; CPU time is the figure to compare). The cost of the whole
`contact-fmu simulate --csv` process (start-up, scene compilation, CSV writing) is printed
as well for the fastest setting at each error level.

scipy's own settings: each method with its defaults, and with a bound of 1e-5 s on the steps of
the contact phase (about a seventh of the 69 us contact; without it DOP853's first step at the
touch is milliseconds long and the spheres pass through each other at tolerances looser than
1e-10); the fastest of the six that reaches an error level is compared.

Error: the largest deviation over the output grid from a tight reference (DOP853 at
rtol 1e-13 in the same piecewise model, checked against contact-fmu at rtol 1e-13 and
against the closed-form post-impact velocities), velocities divided by the approach speed,
positions by the distance travelled (v0 · 10 ms). A setting counts for an error level when it
and every tighter setting of the same code reach it.

Variants of contact-fmu's solver settings: `bundled` (fmu/two_spheres as shipped, which sets
no method and no max_step: the engine's defaults, solver.method = "auto" -- Dormand-Prince
throughout on this scene --, continuation across communication points, steps bounded by the
time to contact; only rtol and atol are set per run), and `former` (the former bundled
settings written into the scene: dopri5, max_step 1e-4 s, a restart at every communication
point), for comparison.

Run from the repository root after `cargo build --release`:
    .venv/bin/python scripts/bench_scipy.py        (BENCH_REPEATS=5 by default)
Writes docs/scipy_comparison.csv and prints the tables.
"""
import csv
import math
import os
import statistics
import subprocess
import sys
import time

import numpy as np
from scipy.integrate import solve_ivp

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXE = os.path.join(ROOT, "target", "release", "contact-fmu")
WORK = os.path.join(ROOT, "target", "bench", "scipy")
REPEATS = int(os.environ.get("BENCH_REPEATS", "5"))
SCENE = os.path.join(ROOT, "fmu", "two_spheres", "scene.toml")
# scipy's settings: its defaults, and a bound on the steps of the contact phase (its initial-step
# heuristic at the touch, where the force and its rate are zero, otherwise picks a step far
# longer than the 69 us contact). The faster one that reaches an error level is compared.
# The methods: the explicit ones for a non-stiff problem (RK45, DOP853) and LSODA (Adams with
# automatic switching to BDF), each with and without the contact-phase bound: the best of them
# at each error level is compared.
SCIPY_VARIANTS = {
    f"{method}{label}": (method, bound)
    for method in ("RK45", "DOP853", "LSODA")
    for label, bound in (("", math.inf), (", contact max_step 1e-5", 1e-5))
}

E, NU = 210e9, 0.3
M1, M2 = 0.0329, 0.111
R1, R2 = 0.01, 0.015
X1, X2 = np.array([-0.0105, 0.0, 0.0]), np.array([0.0155, 0.0, 0.0])
V0 = 1.0
T_END = 0.01
LENGTH = V0 * T_END
R_SUM = R1 + R2


def hertz_k(r_eff):
    h = (1 - NU * NU) / (math.pi * E)
    return 4.0 / (3.0 * math.pi * (2 * h)) * math.sqrt(r_eff)


K = hertz_k(R1 * R2 / R_SUM)


# ---------------------------------------------------------------- the scipy model
def free(t, y):
    return np.concatenate((y[6:], np.zeros(6)))


def contact(t, y):
    d = y[3:6] - y[0:3]
    dist = math.sqrt(d @ d)
    delta = max(R_SUM - dist, 0.0)
    f = K * delta * math.sqrt(delta) * d / dist  # on sphere 2, along the line of centres
    return np.concatenate((y[6:], -f / M1, f / M2))


def gap(t, y):
    d = y[3:6] - y[0:3]
    return math.sqrt(d @ d) - R_SUM


def touch(t, y):
    return gap(t, y)


touch.terminal, touch.direction = True, -1


def separation(t, y):
    return gap(t, y)


separation.terminal, separation.direction = True, 1


def scipy_run(grid, rtol, atol, contact_max_step=math.inf, method="DOP853"):
    """The piecewise solution on `grid` (rows: t, x1, x2, v1, v2) by `solve_ivp`'s `method`;
    `contact_max_step` bounds the steps of the contact phase."""
    y = np.concatenate((X1, X2, [V0, 0, 0], [0, 0, 0]))
    t, phase, out_t, out_y = 0.0, "free", [], []
    while True:
        rhs, ev = (free, touch) if phase == "free" else (contact, separation)
        pts = grid[(grid >= t) & (grid <= T_END)]
        if out_t:
            pts = pts[pts > out_t[-1]]
        hmax = math.inf if phase == "free" else contact_max_step
        sol = solve_ivp(rhs, (t, T_END), y, method=method, rtol=rtol, atol=atol, events=ev, t_eval=pts,
                        max_step=hmax)
        if not sol.success:
            raise RuntimeError(sol.message)
        if len(sol.t):
            out_t.extend(sol.t)
            out_y.extend(sol.y.T)
        if sol.status == 1 and sol.t_events[0].size:
            t, y = sol.t_events[0][0], sol.y_events[0][0]
            phase = "contact" if phase == "free" else "free"
            if t >= T_END:
                break
        else:
            break
    return np.column_stack((out_t, out_y))


def scipy_timed(grid, rtol, atol, variant):
    method, contact_max_step = variant
    wall, cpu = [], []
    for _ in range(REPEATS):
        c0, w0 = time.thread_time(), time.perf_counter()
        traj = scipy_run(grid, rtol, atol, contact_max_step, method)
        wall.append(time.perf_counter() - w0)
        cpu.append(time.thread_time() - c0)
    return traj, statistics.median(wall), statistics.median(cpu)


# ---------------------------------------------------------------- contact-fmu
def scene_text(variant):
    """fmu/two_spheres with the [solver] section of `variant` (tolerances are set per run on
    the command line): `bundled` is the file as shipped."""
    text = open(SCENE).read()
    if variant == "bundled":
        return text
    head, rest = text.split("[solver]", 1)
    body = rest[rest.index("[[material]]"):]
    solver = '[solver]\nmethod = "dopri5"\nmax_step = 1e-4\ncontinuation = false\n'
    return head + solver + "\n" + body


COLS = ["small.r[1]", "small.r[2]", "small.r[3]", "large.r[1]", "large.r[2]", "large.r[3]",
        "small.v[1]", "small.v[2]", "small.v[3]", "large.v[1]", "large.v[2]", "large.v[3]"]


def ours(path, interval, rtol, repeats=REPEATS):
    traj = os.path.join(WORK, "traj.csv")
    cmd = [EXE, "bench", "run", path, "--repeats", str(repeats), "--read", ",".join(COLS), "--csv", traj,
           "--interval", repr(interval), "--set", f"solver.rtol={rtol!r}", "--set", f"solver.atol={rtol * 1e-3!r}"]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(res.stderr)
    kv = dict(x.split("=", 1) for x in res.stdout.split() if "=" in x)
    with open(traj) as f:
        rows = list(csv.DictReader(f))
    data = np.array([[float(r["time"])] + [float(r[c]) for c in COLS] for r in rows])
    return data, float(kv["seconds"]), float(kv["cpu_seconds"]), int(kv["steps"]), int(kv["rhs_evals"]), kv["status"]


def process_time(path, interval, rtol, repeats=REPEATS):
    """Wall time of the whole `contact-fmu simulate --csv` process."""
    out = os.path.join(WORK, "process.csv")
    cmd = [EXE, "simulate", path, "--quiet", "--csv", out, "--interval", repr(interval),
           "--set", f"solver.rtol={rtol!r}", "--set", f"solver.atol={rtol * 1e-3!r}"]
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def error(traj, ref):
    if traj.shape != ref.shape or np.any(np.abs(traj[:, 0] - ref[:, 0]) > 1e-12):
        return float("inf")
    dx = np.abs(traj[:, 1:7] - ref[:, 1:7]).max() / LENGTH
    dv = np.abs(traj[:, 7:13] - ref[:, 7:13]).max() / V0
    return max(dx, dv)


def best(points, target):
    """Fastest (CPU) setting of a code that reaches `target` with every tighter setting."""
    pts = sorted(points, key=lambda p: p["tol"], reverse=True)
    for i, p in enumerate(pts):
        if all(q["error"] <= target and q["status"] == "ok" for q in pts[i:]):
            return min((q for q in pts[i:]), key=lambda q: q["cpu"])
    return None


def main():
    os.makedirs(WORK, exist_ok=True)
    rows = []
    grids = {"bundled grid (1001 points)": 1e-5, "10 intervals (11 points)": 1e-3}
    tols = [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12]
    closed = np.array([(M1 - M2) * V0 / (M1 + M2), 2 * M1 * V0 / (M1 + M2)])
    summary = []
    for gname, interval in grids.items():
        n = int(round(T_END / interval))
        grid = np.linspace(0.0, T_END, n + 1)
        ref = scipy_run(grid, 1e-13, 1e-16)
        print(f"\n== {gname}: reference DOP853 rtol 1e-13; its final velocities differ from the closed form by "
              f"{np.abs(ref[-1, [7, 10]] - closed).max() / V0:.1e}", flush=True)
        scipy_pts = {}
        for variant, spec in SCIPY_VARIANTS.items():
            scipy_pts[variant] = []
            for tol in tols:
                try:
                    traj, wall, cpu = scipy_timed(grid, tol, tol * 1e-3, spec)
                except RuntimeError as e:
                    print(f"  scipy [{variant}] rtol {tol:.0e}: failed ({e})", flush=True)
                    continue
                p = dict(code="scipy", variant=variant, tol=tol, error=error(traj, ref), wall=wall, cpu=cpu,
                         steps=-1, rhs=-1, status="ok")
                scipy_pts[variant].append(p)
                print(f"  scipy [{variant}] rtol {tol:.0e}: error {p['error']:.2e}, cpu {cpu * 1e3:8.2f} ms, "
                      f"wall {wall * 1e3:8.2f} ms", flush=True)
        for variant in ["bundled", "former"]:
            path = os.path.join(WORK, f"two_spheres_{variant}.toml")
            with open(path, "w") as f:
                f.write(scene_text(variant))
            tight, *_ = ours(path, interval, 1e-13, repeats=1)
            print(f"  contact-fmu [{variant}] rtol 1e-13 against the reference: {error(tight, ref):.1e}")
            our_pts = []
            for tol in tols:
                traj, wall, cpu, steps, rhs, status = ours(path, interval, tol)
                p = dict(code="contact-fmu", variant=variant, tol=tol, error=error(traj, ref), wall=wall, cpu=cpu,
                         steps=steps, rhs=rhs, status=status)
                our_pts.append(p)
                print(f"  contact-fmu [{variant}] rtol {tol:.0e}: error {p['error']:.2e}, cpu {cpu * 1e3:8.3f} ms, "
                      f"wall {wall * 1e3:8.3f} ms, {steps} steps, {rhs} RHS", flush=True)
            for target in [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-10]:
                a = best(our_pts, target)
                cands = [x for x in (best(v, target) for v in scipy_pts.values()) if x]
                b = min(cands, key=lambda x: x["cpu"]) if cands else None
                proc = process_time(path, interval, a["tol"]) if a else float("nan")
                summary.append((gname, variant, target, a, b, proc))
            for p in our_pts:
                rows.append((gname, interval) + tuple(p[k] for k in ["code", "variant", "tol", "error", "wall", "cpu", "steps", "rhs", "status"]))
        for p in [p for v in scipy_pts.values() for p in v]:
            rows.append((gname, interval) + tuple(p[k] for k in ["code", "variant", "tol", "error", "wall", "cpu", "steps", "rhs", "status"]))
    with open(os.path.join(ROOT, "docs", "scipy_comparison.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["grid", "interval", "code", "setting", "rtol", "error", "wall_seconds", "cpu_seconds", "steps",
                    "rhs_evals", "status"])
        for r in rows:
            w.writerow(list(r[:4]) + [f"{r[4]:.0e}", f"{r[5]:.3e}", f"{r[6]:.6e}", f"{r[7]:.6e}"] + list(r[8:]))
    print("\n| grid | contact-fmu settings | error ≤ | contact-fmu CPU [ms] (rtol) | `simulate` process [ms] | "
          "scipy, best method, CPU [ms] (method, rtol) | scipy / contact-fmu |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for gname, variant, target, a, b, proc in summary:
        fa = f"{a['cpu'] * 1e3:.3f} ({a['tol']:.0e})" if a else "not reached"
        fb = f"{b['cpu'] * 1e3:.1f} ({b['variant']}, {b['tol']:.0e})" if b else "not reached"
        ratio = f"**{b['cpu'] / a['cpu']:.0f}×**" if a and b else "—"
        print(f"| {gname} | {variant} | {target:.0e} | {fa} | {proc * 1e3:.1f} | {fb} | {ratio} |")
    print("wrote docs/scipy_comparison.csv")


if __name__ == "__main__":
    sys.exit(main())
