#!/usr/bin/env python3
"""How the spheres of a scene touch one another over a run: the clusters of touching spheres
against the one island the candidate pairs make.

Usage: touching_clusters.py SCENE.toml RUN.csv [WINDOW_S]

RUN.csv is a CSV written by `contact-fmu simulate SCENE.toml --csv RUN.csv` (a fine
`--interval`, e.g. 1e-5, shows the short collisions). For every sample it joins the spheres
that overlap (centre distance below the sum of the radii; spheres centred on their bodies'
centres of mass) into clusters, and per window of WINDOW_S seconds (default 0.05) it prints
the steps and contact events taken (from `solver.steps` and `solver.events`), the touching
sphere pairs and the largest cluster (mean, and the 90th percentile over the samples). The
walls and the floor are left out: they join nothing, as the ground is in no island.

An island is every body its candidate pairs (pairs within the broad phase's margin) connect,
and it advances with one step for all its bodies; a cluster is what the contact forces couple
at that instant. Where the largest cluster is much smaller than the island, steps local to a
collision (a multirate method) would save the difference.
"""
import csv
import math
import sys
import tomllib


def sphere_radii(scene_path):
    """Body name -> radius of the spheres centred on their bodies' centres of mass."""
    with open(scene_path, "rb") as f:
        scene = tomllib.load(f)
    radii = {}
    for shape in scene.get("shape", []):
        if shape.get("type") != "sphere" or shape.get("body", "ground") == "ground":
            continue
        if any(abs(c) > 0.0 for c in shape.get("center", [0.0, 0.0, 0.0])):
            continue
        radii[shape["body"]] = float(shape["radius"])
    return radii


def clusters(points, radii):
    """(touching pairs, size of the largest cluster) of spheres at `points`."""
    n = len(points)
    parent = list(range(n))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    pairs = 0
    for i in range(n):
        for j in range(i + 1, n):
            if math.dist(points[i], points[j]) < radii[i] + radii[j]:
                pairs += 1
                parent[root(i)] = root(j)
    sizes = {}
    for i in range(n):
        sizes[root(i)] = sizes.get(root(i), 0) + 1
    return pairs, max(sizes.values(), default=0)


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    scene_path, csv_path = sys.argv[1], sys.argv[2]
    window = float(sys.argv[3]) if len(sys.argv) > 3 else 0.05
    by_body = sphere_radii(scene_path)
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"{csv_path}: no rows")
    bodies = [b for b in by_body if f"{b}.r[1]" in rows[0]]
    if not bodies:
        sys.exit(f"{csv_path}: no column <body>.r[1] of a sphere of {scene_path}")
    for needed in ("solver.steps", "solver.events"):
        if needed not in rows[0]:
            sys.exit(f"{csv_path}: no column {needed} (written by this version's `simulate --csv`)")
    radii = [by_body[b] for b in bodies]
    print(f"{len(bodies)} spheres, {len(rows)} samples, windows of {window} s")
    print(f"{'window [s]':>15} {'steps':>8} {'events':>7} {'events/s':>9} {'pairs':>6} "
          f"{'largest cluster':>15} {'90 %':>5}")
    t0 = float(rows[0]["time"])
    start = 0
    while start < len(rows) - 1:
        end = start
        while end + 1 < len(rows) and float(rows[end + 1]["time"]) <= t0 + window * (1 + 1e-9):
            end += 1
        if end == start:
            end = start + 1
        samples = rows[start:end + 1]
        stats = []
        for r in samples:
            points = [tuple(float(r[f"{b}.r[{k}]"]) for k in (1, 2, 3)) for b in bodies]
            stats.append(clusters(points, radii))
        largest = sorted(s[1] for s in stats)
        a, b = rows[start], rows[end]
        span = float(b["time"]) - float(a["time"])
        steps = int(float(b["solver.steps"]) - float(a["solver.steps"]))
        events = int(float(b["solver.events"]) - float(a["solver.events"]))
        print(f"{float(a['time']):7.3f}-{float(b['time']):<7.3f} {steps:8d} {events:7d} "
              f"{events / span:9.0f} {sum(s[0] for s in stats) / len(stats):6.1f} "
              f"{sum(largest) / len(largest):15.1f} {largest[int(0.9 * (len(largest) - 1))]:5d}")
        t0 = float(b["time"])
        start = end


if __name__ == "__main__":
    main()
