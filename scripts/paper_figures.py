#!/usr/bin/env python3
"""The paper's two examples, run as FMUs through fmpy: figures and the stiffness sweep.

Exports fmu/rail_vehicle and fmu/slider_crank to target/fmu/<name>.fmu (with the project's own
exporter), steps them with fmpy and writes

  docs/img/rail_vertical_displacement.png   paper Fig. 8: car body vertical displacement
  docs/img/rail_vertical_velocity.png       paper Fig. 9: car body vertical velocity
  docs/img/slider_crank_block_displacement.png   paper Fig. 11: block displacement
  docs/img/slider_crank_block_velocity.png       paper Fig. 12: block velocity
  docs/slider_crank_sweep.csv               the stiffness sweep (contact duration, differences
                                            between the continuous and piecewise analyses,
                                            run time, RHS evaluations)

and prints the sweep as a Markdown table (pasted into docs/examples.md).

Usage (from the repository root):  .venv/bin/python scripts/paper_figures.py [--runs N] [--no-export]
"""

import argparse
import csv
import multiprocessing
import os
import statistics
import subprocess
import sys
import time

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi2 import FMU2Slave  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
IMG = os.path.join(ROOT, "docs", "img")

LAW_HERTZ_LN = 3
LAW_IMPULSE = 6
METHOD_RK4 = 3
E_ALUMINIUM = 70e9
# The paper's sweep of the elastic modulus (Fig. 11-12: x1, x1e-2, x1e-4) and the decades between.
SCALES = [1.0, 1e-1, 1e-2, 1e-3, 1e-4]
FIGURE_SCALES = [1.0, 1e-2, 1e-4]


def export(name, build):
    fmu = os.path.join(ROOT, "target", "fmu", f"{name}.fmu")
    if build:
        os.makedirs(os.path.dirname(fmu), exist_ok=True)
        subprocess.run(
            ["cargo", "run", "--release", "--quiet", "--", "export", f"fmu/{name}/scene.toml", "-o", fmu],
            cwd=ROOT,
            check=True,
        )
    return fmu


class Fmu:
    """One extracted FMU; `run` instantiates it afresh for every experiment."""

    def __init__(self, path):
        self.path = path
        self.md = read_model_description(path)
        self.dir = extract(path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.types = {v.name: v.type for v in self.md.modelVariables}
        self.start = {v.name: v.start for v in self.md.modelVariables}
        self.stop_time = float(self.md.defaultExperiment.stopTime)

    def instance(self, params):
        fmu = FMU2Slave(
            guid=self.md.guid,
            unzipDirectory=self.dir,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName="paper",
        )
        fmu.instantiate(loggingOn=False)
        fmu.setupExperiment(startTime=0.0, stopTime=self.stop_time)
        fmu.enterInitializationMode()
        for name, value in params.items():
            if self.types[name] in ("Integer", "Enumeration"):
                fmu.setInteger([self.vr[name]], [int(value)])
            else:
                fmu.setReal([self.vr[name]], [float(value)])
        fmu.exitInitializationMode()
        return fmu

    def get(self, fmu, names):
        return fmu.getReal([self.vr[n] for n in names])

    def sample(self, params, outputs, h, stop=None):
        """Steps with communication step h; returns time and outputs as arrays."""
        stop = self.stop_time if stop is None else stop
        fmu = self.instance(params)
        n = int(round(stop / h))
        rows = [[0.0] + list(self.get(fmu, outputs))]
        for k in range(n):
            fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
            rows.append([(k + 1) * h] + list(self.get(fmu, outputs)))
        fmu.terminate()
        fmu.freeInstance()
        a = np.array(rows)
        return a[:, 0], {name: a[:, i + 1] for i, name in enumerate(outputs)}

    def timed(self, cases, h, runs):
        """Median CPU time of this process (FMU included) in the doStep loop over `runs` runs of
        each parameter set in `cases`, interleaved (run 1 of every case, then run 2, ...) so that
        a changing load on the machine affects every case alike; and each case's RHS evaluations
        and steps."""
        times = [[] for _ in cases]
        counts = [None] * len(cases)
        n = int(round(self.stop_time / h))
        for _ in range(runs):
            for i, params in enumerate(cases):
                fmu = self.instance(params)
                t0 = time.process_time()
                for k in range(n):
                    fmu.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
                times[i].append(time.process_time() - t0)
                counts[i] = tuple(fmu.getInteger([self.vr["solver.rhs_evals"], self.vr["solver.steps"]]))
                fmu.terminate()
                fmu.freeInstance()
        return [(statistics.median(t),) + c for t, c in zip(times, counts)]

    def _final_value(self, params, output, conn):
        """Child process: runs to the stop time with communication step 1e-2, sends the final
        `output` and the RHS evaluations (or None when a step fails)."""
        fmu = self.instance(params)
        try:
            n = int(round(self.stop_time / 1e-2))
            for k in range(n):
                fmu.doStep(currentCommunicationPoint=k * 1e-2, communicationStepSize=1e-2)
            (evals,) = fmu.getInteger([self.vr["solver.rhs_evals"]])
            conn.send((self.get(fmu, [output])[0], evals))
        except Exception:  # a failed step (penetration beyond max_penetration): too coarse
            conn.send(None)

    def fixed_step_needed(self, params, reference, tol=1e-3, output="block.v[1]", timeout=10.0):
        """Largest fixed RK4 step (1e-3 s halved until it fits) whose final `output` is within
        `tol` (relative) of `reference`, and the RHS evaluations it costs. Each trial runs in a
        child process with a time limit, so that a trial that does not finish counts as a
        failure instead of stopping the script."""
        h_step = 1e-3
        while h_step > 1e-7:
            p = dict(params, **{"solver.method": METHOD_RK4, "solver.max_step": h_step})
            parent, child = multiprocessing.Pipe(duplex=False)
            proc = multiprocessing.Process(target=self._final_value, args=(p, output, child))
            proc.start()
            result = parent.recv() if parent.poll(timeout) else "timeout"
            proc.join(1.0)
            if proc.is_alive():
                proc.kill()
                proc.join()
            if result == "timeout":
                print(f"  RK4 step {h_step:g} s: no result within {timeout:g} s", file=sys.stderr)
            elif result is not None and abs(result[0] - reference) <= tol * abs(reference):
                return h_step, result[1]
            h_step /= 2
        return float("nan"), 0

    def contact_duration(self, params, contact="impact"):
        """Duration of the first contact, by stepping coarsely (1e-4 s) to the touch and then
        re-running that stretch from a saved FMU state in steps of 1/2000 of its length."""
        h = 1e-4
        fmu = self.instance(params)
        t = 0.0
        active = f"{contact}.active"
        vr_active = self.vr[active]
        state = fmu.getFMUstate()
        t_state = 0.0
        n_active = 0
        while t < self.stop_time - 0.5 * h:
            if n_active == 0:
                fmu.freeFMUstate(state)
                state, t_state = fmu.getFMUstate(), t
            fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
            t += h
            if fmu.getBoolean([vr_active])[0]:
                n_active += 1
            elif n_active > 0:
                break
        if n_active == 0:
            return 0.0
        fmu.setFMUstate(state)
        fmu.freeFMUstate(state)
        dt = (n_active + 1) * h / 2000.0
        t = t_state
        t_touch = None
        while True:
            fmu.doStep(currentCommunicationPoint=t, communicationStepSize=dt)
            t += dt
            on = fmu.getBoolean([vr_active])[0]
            if on and t_touch is None:
                t_touch = t
            if not on and t_touch is not None:
                break
        fmu.terminate()
        fmu.freeInstance()
        return t - t_touch


def rail_figures(rail):
    t, y = rail.sample({}, ["car.r[3]", "car.v[3]"], 1e-2)
    z0 = y["car.r[3]"][0]
    for key, label, fname, scale in [
        ("car.r[3]", "vertical displacement [mm]", "rail_vertical_displacement.png", 1e3),
        ("car.v[3]", "vertical velocity [m/s]", "rail_vertical_velocity.png", 1.0),
    ]:
        fig, ax = plt.subplots(figsize=(6.4, 3.6))
        values = (y[key] - z0) * scale if key == "car.r[3]" else y[key] * scale
        ax.plot(t, values, color="C0")
        ax.set_xlabel("time [s]")
        ax.set_ylabel(label)
        ax.set_title("Rail vehicle at 80 km/h: car body centre of mass")
        ax.axvline(2.5, color="0.6", lw=0.8, ls=":")
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(os.path.join(IMG, fname), dpi=120)
        plt.close(fig)
    i = np.searchsorted(t, 2.5)
    print(
        f"rail vehicle: car body drops {1e3 * (z0 - y['car.r[3]'][-1]):.2f} mm; "
        f"|z - z_end| after 2.5 s <= {1e3 * np.max(np.abs(y['car.r[3]'][i:] - y['car.r[3]'][-1])):.3f} mm"
    )


def slider_crank(sc, runs):
    params = lambda law, scale, e=None: {  # noqa: E731
        "impact.law": law,
        "aluminium.youngs_modulus": E_ALUMINIUM * scale,
        **({} if e is None else {"impact.restitution": e}),
    }
    outputs = ["block.r[1]", "block.v[1]", "impact.delta", "impact.stiffness"]
    h = 1e-4
    tp, piecewise = sc.sample(params(LAW_IMPULSE, 1.0), outputs, h)
    continuous = {s: sc.sample(params(LAW_HERTZ_LN, s), outputs, h)[1] for s in SCALES}
    # The piecewise analysis with the restitution the Lankarani-Nikravesh law really produces.
    e = float(sc.start["impact.restitution"])
    e_ln = lankarani_nikravesh_restitution(e)
    _, matched = sc.sample(params(LAW_IMPULSE, 1.0, e_ln), outputs, h)

    # Fig. 11 and 12, with a zoom on the impact.
    i_touch = int(np.argmax(np.abs(piecewise["block.v[1]"] - piecewise["block.v[1]"][0]) > 0))
    t_imp = tp[i_touch]
    for key, label, fname in [
        ("block.r[1]", "block displacement x [m]", "slider_crank_block_displacement.png"),
        ("block.v[1]", "block velocity [m/s]", "slider_crank_block_velocity.png"),
    ]:
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
        ax = axes[0]
        ax.plot(tp, piecewise[key], color="k", lw=2.2, label="piecewise (impulse)")
        for s, c in zip(FIGURE_SCALES, ["C0", "C1", "C3"]):
            ax.plot(tp, continuous[s][key], color=c, lw=1.2, ls="--", label=f"continuous, E x {s:g}")
        ax.set_title("Block struck by the slider-crank")
        ax = axes[1]
        if key == "block.r[1]":
            # the differences are millimetres on a 1 m scale: plot them, against the piecewise
            # run with the same e (dashed) and with the law's own restitution (solid)
            for s, c in zip(FIGURE_SCALES, ["C0", "C1", "C3"]):
                ax.plot(tp, 1e3 * (continuous[s][key] - piecewise[key]), color=c, lw=1.0, ls="--",
                        label=f"E x {s:g}, vs piecewise e = {e:g}")
                ax.plot(tp, 1e3 * (continuous[s][key] - matched[key]), color=c, lw=1.6,
                        label=f"E x {s:g}, vs piecewise e = {e_ln:.4f}")
            ax.axhline(0.0, color="k", lw=0.8)
            ax.set_ylabel("continuous - piecewise [mm]")
            ax.set_title("difference from the piecewise analysis")
        else:
            m = (tp >= t_imp - 0.004) & (tp <= t_imp + 0.012)
            ax.plot(tp[m], piecewise[key][m], color="k", lw=2.2, label="piecewise (impulse)")
            for s, c in zip(FIGURE_SCALES, ["C0", "C1", "C3"]):
                ax.plot(tp[m], continuous[s][key][m], color=c, lw=1.2, ls="--", label=f"continuous, E x {s:g}")
            ax.set_ylabel(label)
            ax.set_title("zoom on the impact")
        axes[0].set_ylabel(label)
        for ax in axes:
            ax.set_xlabel("time [s]")
            ax.grid(alpha=0.3)
        axes[1].legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(os.path.join(IMG, fname), dpi=120)
        plt.close(fig)

    # The sweep.
    timing = sc.timed([params(LAW_IMPULSE, 1.0)] + [params(LAW_HERTZ_LN, s) for s in SCALES], 1e-2, runs)
    t_pw, evals_pw, steps_pw = timing[0]
    h_rk4_pw, evals_rk4_pw = sc.fixed_step_needed(params(LAW_IMPULSE, 1.0), piecewise["block.v[1]"][-1])
    rows = []
    for s, (t_c, evals_c, steps_c) in zip(SCALES, timing[1:]):
        c = continuous[s]
        h_rk4, evals_rk4 = sc.fixed_step_needed(params(LAW_HERTZ_LN, s), c["block.v[1]"][-1])
        rows.append(
            {
                "modulus_scale": s,
                "stiffness_N_per_m1.5": c["impact.stiffness"][0],
                "contact_duration_s": sc.contact_duration(params(LAW_HERTZ_LN, s)),
                "max_penetration_m": float(np.max(c["impact.delta"])),
                "max_dx_block_m": float(np.max(np.abs(c["block.r[1]"] - piecewise["block.r[1]"]))),
                "dv_block_end_m_per_s": float(c["block.v[1]"][-1] - piecewise["block.v[1]"][-1]),
                "max_dx_block_matched_e_m": float(np.max(np.abs(c["block.r[1]"] - matched["block.r[1]"]))),
                "dv_block_end_matched_e_m_per_s": float(c["block.v[1]"][-1] - matched["block.v[1]"][-1]),
                "continuous_run_time_s": t_c,
                "continuous_rhs_evals": evals_c,
                "continuous_steps": steps_c,
                "continuous_rk4_step_s": h_rk4,
                "continuous_rk4_rhs_evals": evals_rk4,
                "piecewise_run_time_s": t_pw,
                "piecewise_rhs_evals": evals_pw,
                "piecewise_steps": steps_pw,
                "piecewise_rk4_step_s": h_rk4_pw,
                "piecewise_rk4_rhs_evals": evals_rk4_pw,
            }
        )
    path = os.path.join(ROOT, "docs", "slider_crank_sweep.csv")
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    print(f"slider-crank: restitution e = {e}, Lankarani-Nikravesh effective restitution {e_ln:.5f}")
    print(f"piecewise block velocity after impact {piecewise['block.v[1]'][-1]:.5f} m/s")
    print(
        "| E scale | K [N/m^1.5] | contact duration [ms] | max δ [mm] | max abs Δx [mm] | Δv after [m/s] "
        "| max abs Δx, matched e [mm] | Δv, matched e [m/s] | continuous: time [ms] / RHS evals "
        "| piecewise: time [ms] / RHS evals | RK4 step for 0.1 %: continuous / piecewise [s] "
        "| RK4 RHS evals: continuous / piecewise |"
    )
    print("|" + "---|" * 12)
    for r in rows:
        print(
            f"| {r['modulus_scale']:g} | {r['stiffness_N_per_m1.5']:.4g} | {1e3 * r['contact_duration_s']:.3f} "
            f"| {1e3 * r['max_penetration_m']:.3f} | {1e3 * r['max_dx_block_m']:.3f} "
            f"| {r['dv_block_end_m_per_s']:+.5f} | {1e3 * r['max_dx_block_matched_e_m']:.3f} "
            f"| {r['dv_block_end_matched_e_m_per_s']:+.5f} "
            f"| {1e3 * r['continuous_run_time_s']:.2f} / {r['continuous_rhs_evals']} "
            f"| {1e3 * r['piecewise_run_time_s']:.2f} / {r['piecewise_rhs_evals']} "
            f"| {r['continuous_rk4_step_s']:.3g} / {r['piecewise_rk4_step_s']:.3g} "
            f"| {r['continuous_rk4_rhs_evals']} / {r['piecewise_rk4_rhs_evals']} |"
        )
    print(f"wrote {path}")


def lankarani_nikravesh_restitution(e, h=2e-5):
    """Rebound ratio of x'' = -x^1.5 (1 + 3(1-e^2)/4 x'), x'(0) = 1: the restitution the
    Lankarani-Nikravesh law really produces for its parameter e (dimensionless, RK4)."""
    chi = 0.75 * (1.0 - e * e)

    def f(x, v):
        return v, -max(max(x, 0.0) ** 1.5 * (1.0 + chi * v), 0.0)

    x, v = 0.0, 1.0
    while True:
        k1 = f(x, v)
        k2 = f(x + 0.5 * h * k1[0], v + 0.5 * h * k1[1])
        k3 = f(x + 0.5 * h * k2[0], v + 0.5 * h * k2[1])
        k4 = f(x + h * k3[0], v + h * k3[1])
        xn = x + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        vn = v + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        if xn < 0:
            return -(v + (vn - v) * x / (x - xn))
        x, v = xn, vn


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=11, help="timed runs per case (median); at least 5")
    ap.add_argument("--no-export", action="store_true", help="use the FMUs already in target/fmu")
    args = ap.parse_args()
    if args.runs < 5:
        sys.exit("--runs must be at least 5")
    os.makedirs(IMG, exist_ok=True)
    rail = Fmu(export("rail_vehicle", not args.no_export))
    sc = Fmu(export("slider_crank", not args.no_export))
    rail_figures(rail)
    slider_crank(sc, args.runs)


if __name__ == "__main__":
    main()
