#!/usr/bin/env python3
"""Work-precision plots: one PNG per scene (docs/img/wp_<scene>.png) from
docs/work_precision.csv (written by `contact-fmu bench work-precision`), the scaling
plot (docs/img/scaling.png) from docs/scaling.csv and the pile's windows
(docs/img/pile.png) from docs/pile.csv (`contact-fmu bench pile`) when present.

    .venv/bin/python scripts/bench_plot.py
"""
import csv
import math
import os
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOCS = os.path.join(ROOT, "docs")
IMG = os.path.join(DOCS, "img")


def work_precision():
    path = os.path.join(DOCS, "work_precision.csv")
    data = defaultdict(lambda: defaultdict(list))
    kind = {}
    with open(path) as f:
        for r in csv.DictReader(f):
            err = float(r["error"])
            # CPU time of the thread (immune to other load); wall time when CPU is missing.
            sec = float(r["cpu_seconds"]) if math.isfinite(float(r["cpu_seconds"])) else float(r["seconds"])
            if r["status"] != "ok" or not (math.isfinite(err) and err > 0 and sec > 0):
                continue
            data[r["scene"]][r["method"]].append((sec, err, float(r["tolerance"])))
            kind[r["scene"]] = r["error_kind"]
    for scene, methods in data.items():
        fig, ax = plt.subplots(figsize=(6.4, 4.6))
        for method, pts in sorted(methods.items()):
            pts.sort(key=lambda p: p[2], reverse=True)
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=method)
            for s, e, t in pts[:: max(1, len(pts) // 4)]:
                ax.annotate(f"{t:.0e}", (s, e), fontsize=7, textcoords="offset points", xytext=(3, 3))
        ax.set_xlabel("CPU time [s] (median of 5)")
        ax.set_ylabel("error" + (" (closed form)" if "closed" in kind[scene] else " (vs reference)"))
        ax.set_title(f"{scene}: work-precision")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        out = os.path.join(IMG, f"wp_{scene}.png")
        fig.savefig(out, dpi=110)
        plt.close(fig)
        print("wrote", out)
    summary(data)


def summary(data):
    """Markdown table: the fastest method (CPU time) reaching each error level."""
    methods = sorted({m for ms in data.values() for m in ms})
    print("\n| scene | error ≤ | fastest (setting) | " + " | ".join(f"{m} [ms]" for m in methods) + " |")
    print("| --- | --- | --- |" + " --- |" * len(methods))
    for scene in sorted(data):
        for target in [1e-2, 1e-4, 1e-6, 1e-8]:
            best = {}
            for m in methods:
                ok = [p for p in data[scene].get(m, []) if p[1] <= target]
                best[m] = min(ok) if ok else None
            cands = [(p[0], m, p[2]) for m, p in best.items() if p]
            win = min(cands) if cands else None
            cells = [f"{best[m][0] * 1e3:.2f}" if best[m] else "—" for m in methods]
            w = f"**{win[1]}** ({'h' if win[1] == 'rk4' else 'rtol'} {win[2]:.0e})" if win else "none"
            print(f"| {scene} | {target:.0e} | {w} | " + " | ".join(cells) + " |")


def rows_of(name):
    """The rows of docs/<name> (None when it is not there)."""
    path = os.path.join(DOCS, name)
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return list(csv.DictReader(f))


def scaling():
    rows = rows_of("scaling.csv")
    if rows is None:
        return
    n = [int(r["n"]) for r in rows]
    t = [float(r["seconds_per_simulated_second"]) for r in rows]
    rhs = [float(r["rhs_seconds"]) for r in rows]
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    ax.loglog(n, t, "o-", label="run time per simulated second [s]")
    ax.loglog(n, [x * 1e3 for x in rhs], "s-", label="one RHS evaluation [ms]")
    ax.loglog(n, [t[0] * (x / n[0]) ** 2 for x in n], ":", color="gray", label="∝ N²")
    ax.loglog(n, [rhs[0] * 1e3 * (x / n[0]) for x in n], "--", color="gray", label="∝ N")
    ax.set_xlabel("free spheres N")
    ax.set_title("spheres in a box")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    out = os.path.join(IMG, "scaling.png")
    fig.savefig(out, dpi=110)
    plt.close(fig)
    print("wrote", out)


def pile(name="pile"):
    rows = rows_of(name + ".csv")
    if rows is None:
        return
    mid = [0.5 * (float(r["start"]) + float(r["end"])) for r in rows]
    width = [0.9 * (float(r["end"]) - float(r["start"])) for r in rows]
    fig, (top, middle, bottom) = plt.subplots(3, 1, figsize=(6.4, 8.4), sharex=True)
    top.bar(mid, [float(r["real_time_factor"]) for r in rows], width=width, color="tab:blue")
    top.axhline(1.0, color="gray", ls="--", label="real time")
    top.set_ylabel("simulated s per CPU s")
    top.set_title("pile_of_balls by windows")
    top.legend()
    length = [float(r["end"]) - float(r["start"]) for r in rows]
    middle.plot(mid, [float(r["largest_island"]) for r in rows], "s-", label="largest island [bodies]")
    middle.plot(mid, [float(r["largest_cluster"]) for r in rows], "o-", label="largest touching cluster (mean)")
    right = middle.twinx()
    right.plot(mid, [int(r["events"]) / x for r, x in zip(rows, length)], "^:", color="tab:red",
               label="contact events per simulated s")
    right.set_ylabel("events per simulated s", color="tab:red")
    middle.set_ylabel("spheres")
    lines = middle.get_legend_handles_labels()
    more = right.get_legend_handles_labels()
    middle.legend(lines[0] + more[0], lines[1] + more[1], loc="center right", fontsize=8)
    middle.grid(True, alpha=0.3)
    if "kinetic_energy_end" in rows[0]:
        # (what is not positive, a zero change or a rise of the potential energy, is left out of
        # the logarithmic axis)
        def positive(key, sign=1.0):
            pts = [(x, sign * float(r[key])) for x, r in zip(mid, rows)]
            return [x for x, v in pts if v > 0], [v for x, v in pts if v > 0]
        bottom.semilogy(*positive("kinetic_energy_end"), "o-", label="kinetic energy at the end")
        bottom.semilogy(*positive("potential_energy_change", -1.0), "v-",
                        label="potential energy lost in the window")
        bottom.semilogy(mid, [max(abs(float(r["energy_balance_change"])), 1e-16) for r in rows], "x:",
                        color="tab:gray", label="|change of the energy balance| (error)")
        bottom.set_ylabel("J")
        bottom.legend(fontsize=8)
        bottom.grid(True, alpha=0.3)
    bottom.set_xlabel("time [s]")
    fig.tight_layout()
    out = os.path.join(IMG, name + ".png")
    fig.savefig(out, dpi=110)
    plt.close(fig)
    print("wrote", out)


if __name__ == "__main__":
    os.makedirs(IMG, exist_ok=True)
    work_precision()
    scaling()
    pile()
    pile("pile_to_rest")
