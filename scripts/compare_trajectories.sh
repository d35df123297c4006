#!/usr/bin/env bash
# Runs every bundled scene with every method (and the impulse-law variants) through two
# builds of contact-fmu and compares the CSV trajectories value by value (bit for bit after
# parsing; the number notation may differ between builds). Columns are matched by name, so
# outputs that the new build adds are listed and not compared.
#
#   scripts/compare_trajectories.sh [--zero-friction] OLD_BINARY NEW_BINARY
#
# --zero-friction: the new binary runs every contact that has a `friction` key in its scene
# with <contact>.friction = <contact>.static_friction = 0 (to compare a build with friction against one from before it).
# OLD_SCENES=DIR: the old binary reads the bundled scenes from DIR/<name>/scene.toml (the
# checkout it was built from, when the scene files gained keys it does not know); default fmu.
set -euo pipefail
zero=0
if [ "${1:-}" = "--zero-friction" ]; then zero=1; shift; fi
old=$1; new=$2
out=$(mktemp -d)
frictionless() {  # scene: --set arguments that switch its friction off
    awk '/^\[\[contact\]\]/ {name=""} /^name *=/ {gsub(/[" ]/, "", $3); name=$3}
         /^friction *=/ {print "--set " name ".friction=0 --set " name ".static_friction=0"}' "$1"
}
run() {  # binary dir zero scenes
    local bin=$1 dir=$2 zero=$3 scenes=$4
    mkdir -p "$dir"
    for scene in "$scenes"/*/scene.toml; do
        name=$(basename "$(dirname "$scene")")
        extra=""
        if [ "$zero" = 1 ]; then extra=$(frictionless "$scene"); fi
        for method in dopri5 sdirk radau5 rk4; do
            # shellcheck disable=SC2086
            "$bin" simulate "$scene" --quiet --set "solver.method=$method" $extra --csv "$dir/$name.$method.csv" \
                > /dev/null 2>&1 || echo "failed: $name $method" > "$dir/$name.$method.csv"
        done
    done
    "$bin" simulate "$scenes"/bouncing_ball/scene.toml --quiet --set ball_floor.law=impulse --csv "$dir/bb.impulse.csv" > /dev/null
    "$bin" simulate "$scenes"/slider_crank/scene.toml --quiet --set impact.law=impulse --csv "$dir/sc.impulse.csv" > /dev/null
}
run "$old" "$out/old" 0 "${OLD_SCENES:-fmu}"
run "$new" "$out/new" "$zero" fmu
python3 - "$out" <<'PY'
import glob, os, struct, sys
out = sys.argv[1]
same = differ = values = 0
added = set()
for f in sorted(glob.glob(f"{out}/old/*.csv")):
    a = open(f).read().splitlines()
    b = open(f.replace("/old/", "/new/")).read().splitlines()
    ok = len(a) == len(b) and len(a) > 0 and len(b) > 0
    if ok:
        # columns are compared by name: a newer build may add output columns
        ha, hb = a[0].split(","), b[0].split(",")
        added |= set(hb) - set(ha)
        ok = set(ha) <= set(hb)
        cols = [(i, hb.index(n)) for i, n in enumerate(ha)] if ok else []
        for la, lb in zip(a[1:], b[1:]):
            xa, xb = la.split(","), lb.split(",")
            for i, j in cols:
                values += 1
                if struct.pack("<d", float(xa[i])) != struct.pack("<d", float(xb[j])):
                    ok = False
    same += ok
    differ += not ok
    if not ok:
        print("differs:", os.path.basename(f))
print(f"{same} trajectories bit-identical, {differ} differ ({values} values compared)")
if added:
    print(f"{len(added)} columns only in the new build (not compared), e.g. {sorted(added)[:4]}")
PY
rm -rf "$out"
