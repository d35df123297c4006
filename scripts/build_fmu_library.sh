#!/usr/bin/env bash
# Builds the shared library that `contact-fmu export` packs into FMUs: the cargo profile
# `dist` (the release build without debug information, stripped, fat LTO) and, on x86-64
# Linux, linked against glibc 2.17's symbol versions by cargo-zigbuild (Zig as the linker), so
# that the FMUs load on any x86-64 Linux with glibc 2.17 (2012) or newer.
#
# cargo-zigbuild and Zig come from PyPI (`cargo-zigbuild`, `ziglang`) and are installed into
# the venv .venv when missing (the venv is created when missing). Where they cannot be had or
# the portable build fails, the library is built natively (same profile, this machine's glibc)
# and `contact-fmu export` says which glibc the FMUs then need.
#
#   scripts/build_fmu_library.sh        the output: target/x86_64-unknown-linux-gnu/dist/
set -euo pipefail
cd "$(dirname "$0")/.."

triple="$(rustc -vV | sed -n 's/^host: //p')"
glibc="2.17"
venv=".venv"

if [ "$triple" != "x86_64-unknown-linux-gnu" ]; then
    # No portable build for this platform: the native one, in target/dist/.
    exec cargo build --profile dist --lib
fi

tools_ready() {
    [ -x "$venv/bin/cargo-zigbuild" ] && "$venv/bin/python" -m ziglang version >/dev/null 2>&1
}

if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv" || echo "cannot create the venv $venv" >&2
fi
if [ -x "$venv/bin/python" ] && ! tools_ready; then
    echo "== installing cargo-zigbuild and ziglang into $venv"
    "$venv/bin/python" -m pip install --quiet ziglang cargo-zigbuild || echo "pip could not install them" >&2
fi
if tools_ready; then
    # cargo finds `cargo-zigbuild` on PATH, cargo-zigbuild finds Zig as `python3 -m ziglang`.
    if PATH="$PWD/$venv/bin:$PATH" cargo zigbuild --profile dist --lib --target "$triple.$glibc"; then
        exit 0
    fi
    echo "warning: the portable build (cargo zigbuild --target $triple.$glibc) failed: building natively" >&2
else
    echo "warning: cargo-zigbuild or Zig is not available: building natively (the FMUs need this machine's glibc)" >&2
fi
cargo build --profile dist --lib --target "$triple"
