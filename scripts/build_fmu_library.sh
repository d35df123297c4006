#!/usr/bin/env bash
# Builds the shared libraries that `contact-fmu export` packs into every FMU, in the cargo
# profile `dist` (the release build without debug information, stripped, fat LTO):
#
#   linux64  target/x86_64-unknown-linux-gnu/dist/libcontact_fmu.so, linked by cargo-zigbuild
#            (Zig as the linker) against glibc 2.17's symbol versions, so that it loads on any
#            x86-64 Linux with glibc 2.17 (2012) or newer. cargo-zigbuild and Zig come from PyPI
#            (`cargo-zigbuild`, `ziglang`) and are installed into the venv .venv when missing.
#   win64    target/x86_64-pc-windows-gnu/dist/contact_fmu.dll, cross-compiled for 64-bit
#            Windows with the Rust target x86_64-pc-windows-gnu and the MinGW-w64 linker
#            (Debian/Ubuntu package gcc-mingw-w64-x86-64); it needs Windows 10 or later.
#
# Only the cdylib is built (`cargo rustc --crate-type cdylib`): built together with the rlib,
# the Windows DLL keeps every public function of the crate (the command line, the exporter,
# the benchmarks: 5.7 MB instead of 2.3 MB). cargo rebuilds only what changed, so a second run
# is quick. Every step says what it does;
# a missing tool stops the script with a message naming the step, the missing package and the
# command that installs it. With CONTACT_FMU_INSTALL=1 (./run_tests.sh and CI set it) the
# script installs the Rust target (rustup) and the MinGW linker (apt-get, as root) itself.
#
#   scripts/build_fmu_library.sh                 both platforms
#   scripts/build_fmu_library.sh linux64         one of them
set -euo pipefail
cd "$(dirname "$0")/.."

platforms=("$@")
[ ${#platforms[@]} -gt 0 ] || platforms=(linux64 win64)
host="$(rustc -vV | sed -n 's/^host: //p')"
glibc="2.17"
venv=".venv"
install="${CONTACT_FMU_INSTALL:-0}"

fail() {
    echo "error: scripts/build_fmu_library.sh: $*" >&2
    exit 1
}

build_linux64() {
    if [ "$host" != "x86_64-unknown-linux-gnu" ]; then
        fail "linux64: the portable Linux build is made on x86-64 Linux (this is $host)"
    fi
    tools_ready() {
        [ -x "$venv/bin/cargo-zigbuild" ] && "$venv/bin/python" -m ziglang version >/dev/null 2>&1
    }
    if [ ! -x "$venv/bin/python" ]; then
        echo "== linux64: creating the Python venv $venv (for cargo-zigbuild and Zig)"
        python3 -m venv "$venv" ||
            fail "linux64: cannot create the venv $venv (Debian/Ubuntu: apt-get install python3-venv)"
    fi
    if ! tools_ready; then
        echo "== linux64: installing cargo-zigbuild and ziglang (PyPI) into $venv"
        "$venv/bin/python" -m pip install --quiet ziglang cargo-zigbuild ||
            fail "linux64: pip could not install cargo-zigbuild and ziglang (PyPI) into $venv"
    fi
    echo "== linux64: cargo-zigbuild rustc --profile dist --lib --crate-type cdylib --target x86_64-unknown-linux-gnu.$glibc"
    # cargo-zigbuild finds Zig as `python3 -m ziglang` (the venv's python first on PATH).
    PATH="$PWD/$venv/bin:$PATH" "$venv/bin/cargo-zigbuild" rustc --profile dist --lib --crate-type cdylib \
        --target "x86_64-unknown-linux-gnu.$glibc" ||
        fail "linux64: the build failed (cargo-zigbuild rustc, see above)"
    echo "   -> target/x86_64-unknown-linux-gnu/dist/libcontact_fmu.so"
}

build_win64() {
    local target="x86_64-pc-windows-gnu" linker="x86_64-w64-mingw32-gcc"
    if command -v rustup >/dev/null 2>&1; then
        if ! rustup target list --installed | grep -qx "$target"; then
            echo "== win64: rustup target add $target"
            rustup target add "$target" ||
                fail "win64: the Rust standard library for $target is missing and rustup could not add it (rustup target add $target)"
        fi
    elif ! rustc --print sysroot >/dev/null 2>&1 || [ ! -d "$(rustc --print sysroot)/lib/rustlib/$target" ]; then
        fail "win64: the Rust standard library for $target is missing (rustup target add $target)"
    fi
    if ! command -v "$linker" >/dev/null 2>&1; then
        if [ "$install" = 1 ] && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
            echo "== win64: apt-get install gcc-mingw-w64-x86-64 (the MinGW-w64 linker)"
            DEBIAN_FRONTEND=noninteractive apt-get install -y -q gcc-mingw-w64-x86-64 >/dev/null ||
                { apt-get update -q >/dev/null && DEBIAN_FRONTEND=noninteractive apt-get install -y -q gcc-mingw-w64-x86-64 >/dev/null; } ||
                fail "win64: apt-get could not install gcc-mingw-w64-x86-64"
        else
            fail "win64: the MinGW-w64 linker $linker is missing (Debian/Ubuntu: apt-get install gcc-mingw-w64-x86-64; Fedora: dnf install mingw64-gcc; or leave win64 out: contact-fmu export --platforms linux64)"
        fi
    fi
    echo "== win64: cargo rustc --profile dist --lib --crate-type cdylib --target $target"
    cargo rustc --profile dist --lib --crate-type cdylib --target "$target" ||
        fail "win64: the build failed (cargo rustc --target $target, see above)"
    echo "   -> target/$target/dist/contact_fmu.dll"
}

for p in "${platforms[@]}"; do
    case "$p" in
    linux64) build_linux64 ;;
    win64) build_win64 ;;
    *) fail "unknown platform $p (this script builds linux64 and win64)" ;;
    esac
done
