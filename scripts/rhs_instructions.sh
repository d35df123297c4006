#!/usr/bin/env bash
# Instructions (valgrind callgrind) of one right-hand-side evaluation of bundled scenes, for
# two builds of contact-fmu: `contact-fmu bench rhs --calls N` run with N calls and with none,
# the difference divided by N. Both contact modes: "free" (the scene's initial state, no
# contact touching) and "contact" (every contact active). Deterministic: the counts do not
# depend on the load of the machine.
#
#   scripts/rhs_instructions.sh OLD_BINARY NEW_BINARY [scene ...]
set -euo pipefail
old=$1; new=$2; shift 2
scenes=("$@")
[ ${#scenes[@]} -eq 0 ] && scenes=(two_spheres bouncing_ball slider_crank rail_vehicle)
calls=${RHS_CALLS:-2000}
out=$(mktemp -d)
count() {  # binary scene mode calls
    valgrind --tool=callgrind --callgrind-out-file="$out/cg" "$1" bench rhs --only "$2" --mode "$3" \
        --calls "$4" --repeats 1 --csv "$out/rhs.csv" > /dev/null 2>&1
    callgrind_annotate "$out/cg" 2>/dev/null | awk '/PROGRAM TOTALS/ {gsub(",","",$1); print $1}'
}
printf "%-16s %-8s %12s %12s %8s\n" scene mode "old [instr]" "new [instr]" ratio
for s in "${scenes[@]}"; do
    for mode in free contact; do
        per=()
        for bin in "$old" "$new"; do
            a=$(count "$bin" "$s" "$mode" 0); b=$(count "$bin" "$s" "$mode" "$calls")
            per+=("$(( (b - a) / calls ))")
        done
        printf "%-16s %-8s %12s %12s %8.3f\n" "$s" "$mode" "${per[0]}" "${per[1]}" "$(echo "${per[1]} / ${per[0]}" | bc -l)"
    done
done
rm -rf "$out"
