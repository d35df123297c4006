#!/usr/bin/env python3
"""Peer comparison with Exudyn (PyPI `exudyn`) at equal error.

The same three scenes are built in both codes with pure Hertz contact (K from the materials
as in contact-fmu, exponent 1.5, no damping: Exudyn's damping models are not the
Lankarani-Nikravesh law of `hertz_ln`, so the undamped law is the one both compute exactly):

- ball_plane: a steel ball (R = 10 mm) hits a steel plane at 1 m/s, no gravity. Closed form:
  it leaves at exactly 1 m/s.
- two_spheres: fmu/two_spheres (R = 10 and 15 mm, 1 m/s). Closed form: the elastic
  post-impact velocities (14)-(15) with e = 1.
- newtons_cradle: 4 balls in a row, 10 um apart, the first at 0.1 m/s (with 5 balls, Exudyn
  1.13.6 aborted with "DYNAMIC SOLVER FAILED" when the pulse reached the last pair). Reference: the final
  velocities of a contact-fmu dopri5 run at rtol 1e-12, confirmed by Exudyn's tightest run.

Exudyn runs rigid bodies (rotation-vector nodes) with ObjectContactSphereTriangle and
ObjectContactSphereSphere; its DOPRI5 (adaptive) and RK44 (fixed step) solvers are swept.
contact-fmu runs `contact-fmu bench run` (timing inside the process, setup excluded), dopri5
and rk4. Times are medians of 5 runs. For each error level, the fastest run of each code that
reaches it is compared. Writes docs/exudyn_comparison.csv and prints a table.

A fourth scene, ball_plane_10, is run on its own (so that the first table's figures stay as
they were measured): the ball dropped from 50 mm onto the plane under gravity, ten bounces
(2.02 s), so that solver start-up is not the measure. Reference: contact-fmu at rtol 1e-14 (the
smallest its solver.rtol allows) with its defaults (its runs at rtol 1e-13 and Exudyn's best run
are printed against it; contact-fmu's rtol 1e-13 run differs from it by 3e-10, its 1e-12 run by
3e-9, so the reference is good to a few 1e-11 and an error of 1e-9 can be scored). contact-fmu runs two [solver] variants written into its scene (BALL10_VARIANTS):
`defaults` (no method and no max_step: solver.method = "auto", which is Dormand-Prince
throughout on this scene, continuation across communication points, steps bounded by the time
to contact) and, for comparison, `former` (the former defaults: dopri5, max_step 1 ms, a
restart at each communication point). Exudyn's DOPRI5 is swept down to rtol 1e-13 here.
Times: CPU time (ours: the thread running the engine; Exudyn: its process, around
SolveDynamic), medians of BENCH_REPEATS (5) runs; wall clock in the CSV.

Run from the repository root after `cargo build --release`:
    .venv/bin/python scripts/bench_exudyn.py                               (the first three scenes)
    BENCH_SCENES=ball_plane_10 .venv/bin/python scripts/bench_exudyn.py    (ten bounces)
"""
import csv
import warnings
import math
import multiprocessing
import os
import statistics
import subprocess
import sys
import time

import numpy as np
import exudyn as exu
from exudyn.itemInterface import (MarkerBodyRigid, MarkerNodeRigid, NodeGenericData, ObjectContactSphereSphere,
                                  ObjectContactSphereTriangle, ObjectGround)
from exudyn.utilities import RigidBodyInertia

warnings.simplefilter("ignore", DeprecationWarning)
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXE = os.environ.get("BENCH_EXE") or os.path.join(ROOT, "target", "release", "contact-fmu")
WORK = os.path.join(ROOT, "target", "bench", "exudyn")
SHOW_HINTS = bool(os.environ.get("BENCH_HINTS"))
REPEATS = int(os.environ.get("BENCH_REPEATS", "5"))
E, NU = 210e9, 0.3


def hertz_k(r_eff):
    h = (1 - NU * NU) / (math.pi * E)
    return 4.0 / (3.0 * math.pi * (2 * h)) * math.sqrt(r_eff)


def ball(name, mass, inertia, pos, vel, radius):
    return dict(name=name, mass=mass, inertia=inertia, pos=pos, vel=vel, radius=radius)


def scenes():
    m, j, r = 0.0329, 1.316e-6, 0.01
    out = {}
    # ball on plane
    kbp = hertz_k(r)
    dmax = (5 * m * 1.0 ** 2 / (4 * kbp)) ** 0.4
    tc = 2.94328 * dmax / 1.0
    out["ball_plane"] = dict(
        bodies=[ball("ball", m, j, [0, 0, r + 1e-3], [0, 0, -1.0], r)],
        plane=True, pairs=[], t_end=1e-3 + 2 * tc, truth={"ball": [0, 0, 1.0]}, v_scale=1.0)
    # ball on a plane under gravity, ten bounces: dropped from 50 mm above the plane, pure Hertz
    # (elastic), 10 bounce periods (2 sqrt(2h/g) each)
    h, g = 0.05, 9.81
    out["ball_plane_10"] = dict(
        bodies=[ball("ball", m, j, [0, 0, r + h], [0, 0, 0.0], r)],
        plane=True, pairs=[], t_end=10 * 2 * math.sqrt(2 * h / g), truth=None, v_scale=math.sqrt(2 * g * h),
        gravity=[0, 0, -g], variants=BALL10_VARIANTS, rk4=[], rk44=[1e-5, 3e-6, 1e-6], exudyn_min_step=1e-12,
        reference_rtol=1e-14, reference_variant="defaults",
        tols=[1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13],
        exudyn_tols=[1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13])
    # two spheres (fmu/two_spheres)
    m1, m2, v0 = 0.0329, 0.111, 1.0
    out["two_spheres"] = dict(
        bodies=[ball("small", m1, 1.316e-6, [-0.0105, 0, 0], [v0, 0, 0], 0.01),
                ball("large", m2, 9.99e-6, [0.0155, 0, 0], [0, 0, 0], 0.015)],
        plane=False, pairs=[(0, 1)], t_end=0.01,
        truth={"small": [(m1 - m2) * v0 / (m1 + m2), 0, 0], "large": [2 * m1 * v0 / (m1 + m2), 0, 0]}, v_scale=v0)
    # Newton's cradle
    n, gap, v0 = 4, 1e-5, 0.1
    out["newtons_cradle"] = dict(
        bodies=[ball(f"b{i}", m, j, [i * (2 * r + gap), 0, 0], [v0 if i == 0 else 0, 0, 0], r) for i in range(n)],
        plane=False, pairs=[(i, i + 1) for i in range(n - 1)], t_end=3e-3, truth=None, v_scale=v0)
    return out


# contact-fmu's [solver] settings besides method and tolerances (set per run): "today" is the
# setting of the first comparison (largest step 1 ms, a restart at every communication point);
# "continuation" continues the integrator across communication points and leaves max_step to
# its default; "continuation, max_step 0.1" lifts the bound on the step (safe here: event
# location finds every touch, also after a long step).
VARIANTS = {"today": 'method = "dopri5"\nmax_step = 1e-3\ncontinuation = false\n'}
# ball_plane_10: the engine's defaults (no method, no max_step: "auto", continuation, steps
# bounded by the time to contact) and the former defaults for comparison.
BALL10_VARIANTS = {"defaults": "", "former": 'method = "dopri5"\nmax_step = 1e-3\ncontinuation = false\n'}
ALL_VARIANTS = {**VARIANTS, **BALL10_VARIANTS}


def toml(name, sc, variant="today"):
    gravity = [float(x) for x in sc.get("gravity", [0, 0, 0])]
    s = [f'[model]\nname = "{name}"\ngravity = {gravity}\nstop_time = {sc["t_end"]!r}\n'
         f'interval = {sc["t_end"] / 10!r}\n\n[solver]\n{ALL_VARIANTS[variant]}\n'
         '[[material]]\nname = "steel"\nyoungs_modulus = 210e9\npoisson_ratio = 0.3\n']
    for b in sc["bodies"]:
        s.append(f'[[body]]\nname = "{b["name"]}"\nmass = {b["mass"]!r}\ninertia = [{b["inertia"]!r}, {b["inertia"]!r}, '
                 f'{b["inertia"]!r}]\nposition = {list(map(float, b["pos"]))}\nvelocity = {list(map(float, b["vel"]))}\n')
    if sc["plane"]:
        b = sc["bodies"][0]
        s.append(f'[[contact]]\nname = "floor"\ntype = "sphere_plane"\nlaw = "hertz"\nsphere_body = "{b["name"]}"\n'
                 f'center = {list(map(float, b["pos"]))}\nradius = {b["radius"]!r}\nsphere_material = "steel"\n'
                 'body = "ground"\nmaterial = "steel"\norigin = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n'
                 'u_axis = [1.0, 0.0, 0.0]\nsize = [1.0, 1.0]\n')
    for (a, c) in sc["pairs"]:
        A, C = sc["bodies"][a], sc["bodies"][c]
        s.append(f'[[contact]]\nname = "c{a}_{c}"\ntype = "sphere_sphere"\nlaw = "hertz"\nsphere_body = "{A["name"]}"\n'
                 f'center = {list(map(float, A["pos"]))}\nradius = {A["radius"]!r}\nsphere_material = "steel"\n'
                 f'body = "{C["name"]}"\nmaterial = "steel"\nother_center = {list(map(float, C["pos"]))}\n'
                 f'other_radius = {C["radius"]!r}\n')
    return "\n".join(s)


# ---------------------------------------------------------------- contact-fmu
def ours(path, method, tol, repeats=REPEATS):
    """`method` None: the scene's own (its default when the scene sets none)."""
    sets = [f"solver.method={method}"] if method else []
    if method == "rk4":
        sets.append(f"solver.max_step={tol!r}")
    else:
        sets += [f"solver.rtol={tol!r}", f"solver.atol={tol * 1e-3!r}"]
    traj = os.path.join(WORK, "traj.csv")
    cmd = [EXE, "bench", "run", path, "--repeats", str(repeats), "--csv", traj]
    for s in sets:
        cmd += ["--set", s]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        return None
    kv = dict(x.split("=", 1) for x in res.stdout.split() if "=" in x)
    with open(traj) as f:
        rows = list(csv.DictReader(f))
    last = rows[-1]
    return dict(seconds=float(kv["seconds"]), cpu=float(kv["cpu_seconds"]), steps=int(kv["steps"]), rhs=int(kv["rhs_evals"]),
                status=kv["status"], final=lambda b, k: float(last[f"{b}.v[{k + 1}]"]))


# ---------------------------------------------------------------- Exudyn
def exudyn_run(sc, solver, tol):
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(ObjectGround())
    mg = mbs.AddMarker(MarkerBodyRigid(bodyNumber=ground, localPosition=[0, 0, 0]))
    nodes, markers = [], []
    for b in sc["bodies"]:
        d = mbs.CreateRigidBody(inertia=RigidBodyInertia(mass=b["mass"], inertiaTensor=np.diag([b["inertia"]] * 3)),
                                referencePosition=b["pos"], initialVelocity=b["vel"],
                                nodeType=exu.NodeType.RotationRotationVector, gravity=sc.get("gravity", [0, 0, 0]),
                                returnDict=True)
        nodes.append(d["nodeNumber"])
        markers.append(mbs.AddMarker(MarkerNodeRigid(nodeNumber=d["nodeNumber"])))
    if sc["plane"]:
        b = sc["bodies"][0]
        L = 0.5
        gd = mbs.AddNode(NodeGenericData(initialCoordinates=[0.1, 0, 0, 0], numberOfDataCoordinates=4))
        mbs.AddObject(ObjectContactSphereTriangle(
            markerNumbers=[markers[0], mg], nodeNumber=gd, sphereRadius=b["radius"],
            trianglePoints=exu.Vector3DList([[-L, -L, 0], [L, -L, 0], [0, L, 0]]), includeEdges=0,
            contactStiffness=hertz_k(b["radius"]), contactDamping=0, contactStiffnessExponent=1.5,
            restitutionCoefficient=1, impactModel=0))
    for (a, c) in sc["pairs"]:
        ra, rc = sc["bodies"][a]["radius"], sc["bodies"][c]["radius"]
        gd = mbs.AddNode(NodeGenericData(initialCoordinates=[0.1, 0, 0, 0], numberOfDataCoordinates=4))
        mbs.AddObject(ObjectContactSphereSphere(
            markerNumbers=[markers[a], markers[c]], nodeNumber=gd, spheresRadii=[ra, rc],
            contactStiffness=hertz_k(ra * rc / (ra + rc)), contactDamping=0, contactStiffnessExponent=1.5,
            restitutionCoefficient=1, impactModel=0))
    mbs.Assemble()
    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    ti.endTime = sc["t_end"]
    ti.verboseMode = 0
    ss.solutionSettings.writeSolutionToFile = False
    ss.solutionSettings.sensorsWritePeriod = 1e30
    if sc.get("exudyn_min_step"):
        # (ball_plane_10) Exudyn reduces the step where the contact switches ("recommended step
        # size"); below its smallest step it reports failure, which it did at every touch under
        # gravity with the defaults: allow it to go down to this
        ti.adaptiveStep = True
    if solver.startswith("DOPRI5"):
        # Largest step 1 ms as ours, or 10 us ("DOPRI5-h10us": without event location a large
        # step can jump deep into a stiff contact).
        hmax = 1e-5 if solver.endswith("h10us") else 1e-3
        ti.numberOfSteps = max(10, int(round(sc["t_end"] / hmax)))
        ti.automaticStepSize = True
        # Exudyn does not locate the touch; at the onset its step control can shrink the step
        # without end, so the smallest step is 1e-10 s (it then continues with a larger error,
        # which the error measurement shows).
        ti.minimumStepSize = 1e-10
        ti.relativeTolerance = tol
        ti.absoluteTolerance = tol * 1e-3
        st = exu.DynamicSolverType.DOPRI5
    else:
        ti.numberOfSteps = max(1, int(round(sc["t_end"] / tol)))
        ti.automaticStepSize = False
        st = exu.DynamicSolverType.RK44
    if sc.get("exudyn_min_step"):
        ti.minimumStepSize = sc["exudyn_min_step"]
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        ok = mbs.SolveDynamic(ss, solverType=st, showHints=SHOW_HINTS)
    except exu.SolverError:
        ok = False
    dt, cpu = time.perf_counter() - t0, time.process_time() - c0
    final = {b["name"]: mbs.GetNodeOutput(n, exu.OutputVariableType.Velocity) for b, n in zip(sc["bodies"], nodes)}
    return dt, ok, final, cpu


def _child(conn, sc, solver, tol):
    dt, ok, final, cpu = exudyn_run(sc, solver, tol)
    conn.send((dt, ok, {k: list(v) for k, v in final.items()}, cpu))


def exudyn_once(sc, solver, tol, timeout=60.0):
    """One run in a child process, abandoned after `timeout` seconds."""
    parent, child = multiprocessing.Pipe()
    p = multiprocessing.Process(target=_child, args=(child, sc, solver, tol))
    p.start()
    if parent.poll(timeout):
        res = parent.recv()
        p.join()
        return res
    p.kill()
    p.join()
    return timeout, False, None, timeout


def exudyn_timed(sc, solver, tol):
    times, cpus, final, ok = [], [], None, True
    for _ in range(REPEATS):
        dt, ok, final, cpu = exudyn_once(sc, solver, tol)
        times.append(dt)
        cpus.append(cpu)
        if dt > 10 or final is None:
            break
    return statistics.median(times), ok, final, statistics.median(cpus)


def error(final, truth, scale):
    return max(abs(final(b, k) - v[k]) for b, v in truth.items() for k in range(3)) / scale


def main():
    os.makedirs(WORK, exist_ok=True)
    # BENCH_SCENES=ball_plane_10 (comma-separated) runs those scenes only and writes
    # docs/exudyn_<names>.csv; without it, the first three scenes and docs/exudyn_comparison.csv.
    only = [x for x in os.environ.get("BENCH_SCENES", "").split(",") if x]
    selected = {k: v for k, v in scenes().items() if (k in only if only else k != "ball_plane_10")}
    rows = []
    for name, sc in selected.items():
        paths = {}
        for variant in sc.get("variants", ["today"]):
            paths[variant] = os.path.join(WORK, f"{name}.{variant.replace(' ', '').replace(',', '_')}.toml")
            with open(paths[variant], "w") as f:
                f.write(toml(name, sc, variant))
        truth = sc["truth"]
        # "today" (the first three scenes) forces dopri5; the ball_plane_10 variants keep the
        # scene's method (auto under the defaults)
        def method_of(variant):
            return "dopri5" if variant == "today" else None

        if truth is None:
            ref_tol = sc.get("reference_rtol", 1e-12)
            ref_variant = sc.get("reference_variant", "today")
            ref = ours(paths[ref_variant], method_of(ref_variant), ref_tol, repeats=1)
            truth = {b["name"]: [ref["final"](b["name"], k) for k in range(3)] for b in sc["bodies"]}
            for variant, path in paths.items():
                r = ours(path, method_of(variant), ref_tol, repeats=1)
                print(f"{name}: reference (rtol {ref_tol:.0e}, [{ref_variant}]) against [{variant}] at that rtol: "
                      f"{error(r['final'], truth, sc['v_scale']):.1e}")
            r = ours(paths[ref_variant], "dopri5", ref_tol, repeats=1)
            print(f"{name}: reference against dopri5 forced, [{ref_variant}], rtol {ref_tol:.0e}: "
                  f"{error(r['final'], truth, sc['v_scale']):.1e}")
        points = []
        for variant, path in paths.items():
            label = "dopri5" if variant == "today" else variant
            for tol in sc.get("tols", [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11]):
                r = ours(path, method_of(variant), tol)
                if r:
                    points.append(("contact-fmu", label, tol, error(r["final"], truth, sc["v_scale"]), r["seconds"],
                                   r["cpu"], r["steps"], r["status"]))
                    print(f"  contact-fmu {label} {tol:.0e}: err {points[-1][3]:.3e} cpu {r['cpu']:.3e} s", flush=True)
        for h in sc.get("rk4", [1e-5, 3e-6, 1e-6, 3e-7, 1e-7]):
            r = ours(paths.get("today", next(iter(paths.values()))), "rk4", h)
            if r:
                points.append(("contact-fmu", "rk4", h, error(r["final"], truth, sc["v_scale"]), r["seconds"], r["cpu"],
                               r["steps"], r["status"]))
        ex_tols = sc.get("exudyn_tols", [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11])
        for solver, tols in [("DOPRI5", ex_tols), ("DOPRI5-h10us", ex_tols),
                             ("RK44", sc.get("rk44", [1e-5, 3e-6, 1e-6, 3e-7, 1e-7]))]:
            for tol in tols:
                dt, ok, fin, cpu = exudyn_timed(sc, solver, tol)
                err = error(lambda b, k: fin[b][k], truth, sc["v_scale"]) if fin else float("nan")
                status = "ok" if ok else ("timeout" if fin is None else "failed")
                points.append(("exudyn", solver, tol, err, dt, cpu, -1, status))
                print(f"  exudyn {solver} {tol:.0e}: err {err:.3e} t {dt:.3e} s cpu {cpu:.3e} s {status}", flush=True)
                if dt > 10 or fin is None:
                    break
        if sc["truth"] is None:
            best_ex = min((p[3] for p in points if p[0] == "exudyn" and p[7] == "ok"), default=float("nan"))
            print(f"{name}: reference (contact-fmu dopri5 rtol {sc.get('reference_rtol', 1e-12):.0e}) agrees with Exudyn's best run to {best_ex:.2e}")
        for p in points:
            rows.append((name,) + p)
            print(f"{name:15s} {p[0]:12s} {p[1]:34s} {p[2]:9.1e} err {p[3]:10.3e} t {p[4]:10.3e} s cpu {p[5]:10.3e} s {p[7]}")
    csv_name = f"exudyn_{'_'.join(only)}.csv" if only else "exudyn_comparison.csv"
    with open(os.path.join(ROOT, "docs", csv_name), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["scene", "code", "solver", "tolerance", "error", "seconds", "cpu_seconds", "steps", "status"])
        for r in rows:
            w.writerow([r[0], r[1], r[2], f"{r[3]:e}", f"{r[4]:.6e}", f"{r[5]:.6e}", f"{r[6]:.6e}", r[7], r[8]])
    print(f"wrote docs/{csv_name}")
    # columns of a row: 0 scene, 1 code, 2 solver, 3 tolerance, 4 error, 5 wall, 6 cpu, 7 steps, 8 status
    for rule, strict in [("strict: the setting and every tighter setting of the same solver reach the error", True),
                         ("generous: the fastest single run that reaches the error", False)]:
        print(f"\nFastest run of each code at each error level ({rule}); times are CPU time, medians of {REPEATS}:")
        print("\n| scene | contact-fmu settings | error ≤ | contact-fmu [ms] | Exudyn [ms] | Exudyn / contact-fmu |")
        print("| --- | --- | --- | --- | --- | --- |")
        for name, sc in selected.items():
            targets = [1e-5, 1e-6, 1e-7, 1e-8, 1e-9] if name == "ball_plane_10" else [1e-3, 1e-5, 1e-7, 1e-9]
            groups = sorted({r[2] for r in rows if r[0] == name and r[1] == "contact-fmu"})
            ours_groups = [[g] for g in groups] + [groups]
            for target in targets:
                ex = best(rows, name, "exudyn", None, target, strict)
                for grp in ours_groups:
                    a = best(rows, name, "contact-fmu", grp, target, strict)
                    label = grp[0] if len(grp) == 1 else "any"
                    fa = f"{a[6] * 1e3:.3f} ({a[2]} {a[3]:.0e})" if a else "not reached"
                    fb = f"{ex[6] * 1e3:.3f} ({ex[2]} {ex[3]:.0e})" if ex else "not reached"
                    ratio = f"{ex[6] / a[6]:.1f}×" if a and ex else "—"
                    print(f"| {name} | {label} | {target:.0e} | {fa} | {fb} | {ratio} |")


def best(rows, name, code, solvers, target, strict):
    """The fastest (CPU) row of `code` (solvers: those only) that reaches `target`."""
    cands = []
    for solver in sorted({r[2] for r in rows if r[0] == name and r[1] == code}):
        if solvers is not None and solver not in solvers:
            continue
        pts = sorted([r for r in rows if r[0] == name and r[1] == code and r[2] == solver], key=lambda r: r[3],
                     reverse=True)
        for i, r in enumerate(pts):
            ok = (all(q[4] <= target and q[8] == "ok" for q in pts[i:]) if strict
                  else r[4] <= target and r[8] == "ok")
            if ok:
                cands.append(r)
                if strict:
                    break
    return min(cands, key=lambda r: r[6]) if cands else None


if __name__ == "__main__":
    sys.exit(main())
