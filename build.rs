//! The fingerprint of the sources the library is built from, compiled in as the environment
//! variable `CONTACT_FMU_SOURCES` (`guid::BUILD`). The exporter packs a library into an FMU
//! only when the library carries the fingerprint of the exporter's own sources, so a library
//! built from other sources is never packed by mistake (file times cannot tell: a fresh clone
//! or a rebuild of another profile changes them). FNV-1a over the paths and bytes of every file
//! under `src/` (but `main.rs`, the command line) and of `Cargo.toml` and `Cargo.lock`.

use std::fs;
use std::path::{Path, PathBuf};

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            files(&path, out);
        } else {
            out.push(path);
        }
    }
}

fn main() {
    println!("cargo:rerun-if-changed=src");
    println!("cargo:rerun-if-changed=Cargo.toml");
    println!("cargo:rerun-if-changed=Cargo.lock");
    let mut paths = Vec::new();
    files(Path::new("src"), &mut paths);
    paths.retain(|p| p != Path::new("src/main.rs"));
    paths.sort();
    paths.push(PathBuf::from("Cargo.toml"));
    paths.push(PathBuf::from("Cargo.lock"));
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    let mut feed = |bytes: &[u8]| {
        for &b in bytes {
            hash ^= u64::from(b);
            hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    for path in &paths {
        // the path with '/' on every platform, then the bytes
        feed(path.to_string_lossy().replace('\\', "/").as_bytes());
        feed(&[0]);
        feed(&fs::read(path).unwrap_or_default());
        feed(&[0]);
    }
    println!("cargo:rustc-env=CONTACT_FMU_SOURCES={hash:016x}");
}
