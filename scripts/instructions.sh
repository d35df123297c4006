#!/usr/bin/env bash
# Deterministic cost of the engine: instructions (valgrind callgrind) of `simulate` on the
# bundled scenes, in total and inclusive in the right-hand side, for two builds of
# contact-fmu. Prints a table; the instruction counts do not depend on machine load.
#
#   scripts/instructions.sh OLD_BINARY NEW_BINARY [scene:method ...]
set -euo pipefail
old=$1; new=$2; shift 2
cases=("$@")
if [ ${#cases[@]} -eq 0 ]; then
    cases=(bouncing_ball:dopri5 two_spheres:dopri5 slider_crank:dopri5 rail_vehicle:dopri5
           rail_vehicle:sdirk rail_vehicle:radau5 rail_vehicle:rk4)
fi
out=$(mktemp -d)
printf "%-28s %16s %16s %7s %16s %16s %7s\n" case "old total" "new total" ratio "old RHS" "new RHS" ratio
for c in "${cases[@]}"; do
    scene=${c%%:*}; method=${c##*:}
    for v in old new; do
        bin=$old; [ $v = new ] && bin=$new
        valgrind --tool=callgrind --callgrind-out-file="$out/$v" "$bin" simulate "fmu/$scene/scene.toml" \
            --quiet --set "solver.method=$method" > /dev/null 2>&1
        total[$([ $v = old ] && echo 0 || echo 1)]=$(callgrind_annotate "$out/$v" | awk '/PROGRAM TOTALS/ {gsub(",","",$1); print $1}')
        rhs[$([ $v = old ] && echo 0 || echo 1)]=$(callgrind_annotate --inclusive=yes "$out/$v" \
            | grep -E 'as contact_fmu::integrator::OdeSystem>::rhs' | head -1 | awk '{gsub(",","",$1); print $1}')
    done
    printf "%-28s %16s %16s %7.4f %16s %16s %7.4f\n" "$c" "${total[0]}" "${total[1]}" \
        "$(echo "${total[1]} / ${total[0]}" | bc -l)" "${rhs[0]}" "${rhs[1]}" "$(echo "${rhs[1]} / ${rhs[0]}" | bc -l)"
done
rm -rf "$out"
