#!/usr/bin/env bash
# The project's test command: build, Rust tests, the main job (which builds the libraries the
# FMUs ship with, for linux64 and win64, and exports the bundled FMUs), then test the exported
# .fmu files through real FMI hosts (fmpy in a Python venv, libcosim through libcosimpy, the
# project's own C host for both platforms, the win64 one under wine, and the FMU Compliance
# Checker where present: FMU_CHECK, see docs/fmi.md).
#
#   ./run_tests.sh            everything
#   ./run_tests.sh -k guid    extra arguments go to pytest
set -euo pipefail
cd "$(dirname "$0")"

echo "== cargo fmt --check, cargo clippy -D warnings, cargo doc -D warnings"
if cargo fmt --version >/dev/null 2>&1; then cargo fmt --check; else echo "(rustfmt not installed: skipped)"; fi
if cargo clippy --version >/dev/null 2>&1; then
    cargo clippy --release --all-targets --quiet -- -D warnings
else
    echo "(clippy not installed: skipped)"
fi
# the API docs without a broken link (units in doc comments are written \[s\])
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --quiet

echo "== tools for the win64 library and its tests: the Rust target, MinGW-w64, wine"
# The FMUs carry a win64 library beside the linux64 one (scripts/build_fmu_library.sh), and
# tests/python/test_windows.py runs it under wine. Installed here where missing (rustup; apt-get
# as root); where that is impossible the script says what is missing and stops.
if ! rustup target list --installed 2>/dev/null | grep -qx x86_64-pc-windows-gnu; then
    rustup target add x86_64-pc-windows-gnu
fi
missing=()
command -v x86_64-w64-mingw32-gcc >/dev/null 2>&1 || missing+=(gcc-mingw-w64-x86-64)
[ -x /usr/lib/wine/wine64 ] || command -v wine64 >/dev/null 2>&1 || missing+=(wine64)
if [ ${#missing[@]} -gt 0 ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
        echo "   apt-get install ${missing[*]}"
        export DEBIAN_FRONTEND=noninteractive
        apt-get install -y -q "${missing[@]}" >/dev/null 2>&1 ||
            { apt-get update -q >/dev/null && apt-get install -y -q "${missing[@]}" >/dev/null; }
    else
        echo "error: missing Debian/Ubuntu packages: ${missing[*]} (apt-get install ${missing[*]}, as root)" >&2
        exit 1
    fi
fi
# with the tools present, the Windows tests must run (not skip)
export CONTACT_FMU_WINDOWS_TESTS=required

# (the shared-library test dlopens target/release/libcontact_fmu.so)
echo "== cargo build --release"
cargo build --release

echo "== cargo test --release"
cargo test --release

echo "== the main job (cargo run --release): builds the FMU libraries (linux64, win64) when they"
echo "   are not built from these sources, exports target/fmu/<name>.fmu, runs each default experiment"
cargo run --release

echo "== Python venv (.venv)"
if [ ! -x .venv/bin/python ]; then
    python3 -m venv .venv
fi
# fmpy, pytest, numpy, matplotlib: the FMU tests; pythonfmu (builds the driver FMU), libcosimpy
# (libcosim, the second co-simulation engine) and dask[distributed] (parameter sweeps): the
# co-simulation and sweep tests (docs/cosimulation.md, docs/sweeps.md).
if ! .venv/bin/python -c "import fmpy, pytest, numpy, matplotlib, pythonfmu, libcosimpy, dask, distributed" 2>/dev/null; then
    .venv/bin/python -m pip install --quiet --upgrade pip
    .venv/bin/python -m pip install --quiet fmpy pytest numpy matplotlib pythonfmu libcosimpy "dask[distributed]"
fi

echo "== pytest tests/python"
# The FMUs were just built and exported: the fixtures need not rebuild them.
CONTACT_FMU_SKIP_BUILD=1 .venv/bin/python -m pytest tests/python -q "$@"
