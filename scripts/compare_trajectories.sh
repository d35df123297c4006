#!/usr/bin/env bash
# Runs every bundled scene with every method (and the impulse-law variants) through two
# builds of contact-fmu and compares the CSV trajectories value by value (bit for bit after
# parsing; the number notation may differ between builds). A trajectory that differs is
# reported with its largest difference relative to the largest magnitude of the column.
#
#   scripts/compare_trajectories.sh OLD_BINARY NEW_BINARY
set -euo pipefail
old=$1; new=$2
out=$(mktemp -d)
run() {  # binary dir
    local bin=$1 dir=$2
    mkdir -p "$dir"
    for scene in fmu/*/scene.toml; do
        name=$(basename "$(dirname "$scene")")
        for method in dopri5 sdirk radau5 rk4; do
            "$bin" simulate "$scene" --quiet --set "solver.method=$method" --csv "$dir/$name.$method.csv" \
                > /dev/null 2>&1 || echo "failed: $name $method" > "$dir/$name.$method.csv"
        done
    done
    "$bin" simulate fmu/bouncing_ball/scene.toml --quiet --set ball_floor.law=impulse --csv "$dir/bb.impulse.csv" > /dev/null
    "$bin" simulate fmu/slider_crank/scene.toml --quiet --set impact.law=impulse --csv "$dir/sc.impulse.csv" > /dev/null
}
run "$old" "$out/old"
run "$new" "$out/new"
python3 - "$out" <<'PY'
import glob, os, struct, sys
out = sys.argv[1]
same = differ = values = 0
worst = 0.0
for f in sorted(glob.glob(f"{out}/old/*.csv")):
    a = open(f).read().splitlines()
    b = open(f.replace("/old/", "/new/")).read().splitlines()
    ok = len(a) == len(b) and a[:1] == b[:1]
    ra = [[float(x) for x in l.split(",")] for l in a[1:]] if a[1:2] and "failed" not in a[0] else []
    rb = [[float(x) for x in l.split(",")] for l in b[1:]] if b[1:2] and "failed" not in b[0] else []
    for xa, xb in zip(ra, rb):
        for x, y in zip(xa, xb):
            values += 1
            if struct.pack("<d", x) != struct.pack("<d", y):
                ok = False
    same += ok
    differ += not ok
    if not ok:
        # largest difference of a column relative to that column's largest magnitude
        rel = 0.0
        if ra and rb and len(ra) == len(rb):
            for c in range(len(ra[0])):
                scale = max(max(abs(r[c]) for r in ra), max(abs(r[c]) for r in rb))
                if scale > 0:
                    rel = max(rel, max(abs(p[c] - q[c]) for p, q in zip(ra, rb)) / scale)
            print(f"differs: {os.path.basename(f)} (largest difference {rel:.2e} of the column's largest value)")
        else:
            rel = float("inf")
            print(f"differs: {os.path.basename(f)} ({len(ra)} rows before, {len(rb)} after)")
        worst = max(worst, rel)
print(f"{same} trajectories bit-identical, {differ} differ ({values} values compared); largest relative difference {worst:.2e}")
PY
rm -rf "$out"
