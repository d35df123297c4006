#!/usr/bin/env bash
# One FMI session on the shared library the FMUs ship (tests/integration/fmi_shared_library.rs: dlopen,
# instantiate, initialise, step, get/set/serialize/deserialize states, free, dlclose) under
# valgrind's memcheck. Fails (exit 1) on any invalid read or write, use of uninitialised
# memory or definitely lost block. The full log goes to target/valgrind_fmi.log; the summary
# is printed.
#
#   scripts/valgrind_fmi.sh                 the release library (cargo build --release)
#   CONTACT_FMU_LIBRARY=FILE scripts/...    another build of it (e.g. the dist library)
#   scripts/valgrind_fmi.sh --selftest      the test leaks one block on purpose: must fail
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "${1:-}" = "--selftest" ]; then export CONTACT_FMU_LEAK_SELFTEST=1; fi
command -v valgrind >/dev/null || { echo "valgrind is not installed" >&2; exit 2; }

# the shared library (cargo test builds only the rlib), then the test; its executable's path
cargo build --release --lib
exe="$(cargo test --release --test integration fmi_shared_library:: --no-run 2>&1 \
    | sed -n 's/.*Executable tests\/fmi_shared_library.rs (\(.*\))/\1/p' | tail -n 1)"
[ -x "$exe" ] || { echo "could not build tests/integration/fmi_shared_library.rs" >&2; exit 2; }

log=target/valgrind_fmi.log
status=0
valgrind --tool=memcheck --leak-check=full --show-leak-kinds=definite,indirect,possible \
    --errors-for-leak-kinds=definite,indirect --track-origins=yes --error-exitcode=1 \
    --log-file="$log" "$exe" --test-threads=1 || status=$?
valgrind --version
grep -E "ERROR SUMMARY|definitely lost|indirectly lost|possibly lost|still reachable|All heap blocks|in use at exit|total heap usage" "$log" | sed 's/^==[0-9]*== //'
if [ "$status" -ne 0 ]; then
    echo "valgrind found errors (exit $status): see $log" >&2
fi
exit "$status"
