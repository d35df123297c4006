#!/usr/bin/env bash
# The project's test command: build, Rust tests, build the library the FMUs ship with, export
# the bundled FMUs, then test the exported .fmu files through real FMI hosts (fmpy in a Python
# venv, libcosim through libcosimpy, and the FMU Compliance Checker where present: FMU_CHECK, see
# docs/fmi.md).
#
#   ./run_tests.sh            everything
#   ./run_tests.sh -k guid    extra arguments go to pytest
set -euo pipefail
cd "$(dirname "$0")"

echo "== cargo fmt --check, cargo clippy -D warnings"
if cargo fmt --version >/dev/null 2>&1; then cargo fmt --check; else echo "(rustfmt not installed: skipped)"; fi
if cargo clippy --version >/dev/null 2>&1; then
    cargo clippy --release --all-targets --quiet -- -D warnings
else
    echo "(clippy not installed: skipped)"
fi

# (the shared-library test dlopens target/release/libcontact_fmu.so)
echo "== cargo build --release"
cargo build --release

echo "== cargo test --release"
cargo test --release

# `cargo build` rebuilds the library after `cargo test` has built it (the test build leaves it
# different), so it is built again here, before the FMU library: `export` below then finds it
# up to date, and the `dist` library is the newest
echo "== cargo build --release, after the tests"
cargo build --release

echo "== the FMU library: cargo profile dist (stripped, LTO), glibc 2.17 through cargo-zigbuild"
scripts/build_fmu_library.sh

echo "== export the bundled FMUs"
mkdir -p target/fmu
for scene in fmu/*/scene.toml; do
    name="$(basename "$(dirname "$scene")")"
    cargo run --release --quiet -- export "$scene" -o "target/fmu/$name.fmu"
done

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
