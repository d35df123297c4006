//! Which shared libraries an export packs: by default the `dist` library of every platform in
//! [`DEFAULT_PLATFORMS`] (linux64 and win64), each built by `scripts/build_fmu_library.sh`
//! from the same sources as the exporter itself.
//!
//! A library's sources are told by the string [`crate::guid::BUILD`] that every build carries
//! (the version and a fingerprint of the sources, see `build.rs`): a default library without
//! the exporter's own is refused as built from other sources, whatever its file time. The
//! development build (`target/release/`, with debug information and this machine's glibc) is
//! packed only when named (`CONTACT_FMU_LIBRARY` or `--binary`).

use super::ExportError;
use crate::fmi::lifecycle::Version;
use std::path::{Path, PathBuf};

/// The cargo profile of the library packed into FMUs (`[profile.dist]` in `Cargo.toml`).
pub const DIST_PROFILE: &str = "dist";

/// The newest glibc symbol version the packed Linux library may need: (2, 17), the floor of
/// the portable build (`x86_64-unknown-linux-gnu.2.17` through cargo-zigbuild).
pub const GLIBC_FLOOR: (u32, u32) = (2, 17);

/// A platform of FMI 2.0 (`binaries/<platform>/`): its shared-library extension and, for the
/// platforms built by `scripts/build_fmu_library.sh`, the Rust target it is built for and the
/// file name cargo gives the library there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Platform {
    /// The FMI 2.0 platform folder name (the name the command line takes).
    pub name: &'static str,
    /// The FMI 3.0 platform folder name (`<architecture>-<operating system>`).
    pub fmi3: &'static str,
    /// The shared-library file extension.
    pub extension: &'static str,
    /// The Rust target triple of its `dist` build (`target/<triple>/dist/`), if the build
    /// script makes one.
    pub triple: Option<&'static str>,
    /// The file cargo writes there.
    pub file: &'static str,
}

/// The platforms of FMI 2.0, in the order of their names in an FMU's listing.
pub const PLATFORMS: [Platform; 5] = [
    Platform {
        name: "darwin64",
        fmi3: "x86_64-darwin",
        extension: "dylib",
        triple: None,
        file: "libcontact_fmu.dylib",
    },
    Platform {
        name: "linux32",
        fmi3: "x86-linux",
        extension: "so",
        triple: None,
        file: "libcontact_fmu.so",
    },
    Platform {
        name: "linux64",
        fmi3: "x86_64-linux",
        extension: "so",
        triple: Some("x86_64-unknown-linux-gnu"),
        file: "libcontact_fmu.so",
    },
    Platform {
        name: "win32",
        fmi3: "x86-windows",
        extension: "dll",
        triple: None,
        file: "contact_fmu.dll",
    },
    Platform {
        name: "win64",
        fmi3: "x86_64-windows",
        extension: "dll",
        triple: Some("x86_64-pc-windows-gnu"),
        file: "contact_fmu.dll",
    },
];

/// The platforms every export carries unless told otherwise (`--platforms`).
pub const DEFAULT_PLATFORMS: [&str; 2] = ["linux64", "win64"];

/// The FMI platform folder of this build (`binaries/<PLATFORM>/`).
pub const PLATFORM: &str = if cfg!(target_os = "windows") {
    if cfg!(target_pointer_width = "64") {
        "win64"
    } else {
        "win32"
    }
} else if cfg!(target_os = "macos") {
    "darwin64"
} else if cfg!(target_pointer_width = "64") {
    "linux64"
} else {
    "linux32"
};

/// The shared-library file extension of this platform.
pub const LIBRARY_EXTENSION: &str = if cfg!(target_os = "windows") {
    "dll"
} else if cfg!(target_os = "macos") {
    "dylib"
} else {
    "so"
};

/// The platform named `name`, if FMI 2.0 has it.
pub fn platform(name: &str) -> Option<&'static Platform> {
    PLATFORMS.iter().find(|p| p.name == name)
}

/// The file name cargo gives this crate's shared library on this platform.
pub fn library_file() -> String {
    let prefix = if cfg!(target_os = "windows") { "" } else { "lib" };
    format!("{prefix}contact_fmu.{LIBRARY_EXTENSION}")
}

/// A shared library to pack for one platform.
#[derive(Debug, Clone, PartialEq)]
pub struct Binary {
    /// The FMI platform folder, one of [`PLATFORMS`].
    pub platform: String,
    /// The library file.
    pub path: PathBuf,
}

impl Binary {
    /// Parses the CLI's `--binary PLATFORM=PATH`; an unknown platform or a missing file is
    /// refused with a message naming it.
    pub fn parse(arg: &str) -> Result<Binary, ExportError> {
        let refuse = |why: String| ExportError::Binary(format!("--binary {arg}: {why}"));
        let (name, path) = arg
            .split_once('=')
            .ok_or_else(|| refuse("expected PLATFORM=PATH, e.g. win64=contact_fmu.dll".into()))?;
        let platform =
            platform(name).ok_or_else(|| refuse(format!("unknown platform {name:?} (known: {})", known())))?;
        let path = PathBuf::from(path);
        if !path.is_file() {
            return Err(refuse(format!("{}: no such file", path.display())));
        }
        Ok(Binary {
            platform: platform.name.to_string(),
            path,
        })
    }

    /// Where the library goes in an FMI 2.0 FMU: `binaries/<platform>/<model identifier>.<ext>`.
    pub fn entry(&self, model_identifier: &str) -> String {
        self.entry_in(model_identifier, Version::Fmi2)
    }

    /// Where the library goes in an FMU of `version`: FMI 2.0's platform folder
    /// (`binaries/linux64/`) or FMI 3.0's (`binaries/x86_64-linux/`).
    pub fn entry_in(&self, model_identifier: &str, version: Version) -> String {
        let p = platform(&self.platform);
        let ext = p.map_or(LIBRARY_EXTENSION, |p| p.extension);
        let folder = match (version, p) {
            (Version::Fmi3, Some(p)) => p.fmi3,
            _ => self.platform.as_str(),
        };
        format!("binaries/{folder}/{model_identifier}.{ext}")
    }
}

/// The platform names, for messages.
fn known() -> String {
    ["win64", "win32", "linux64", "linux32", "darwin64"].join(", ")
}

/// Parses `--platforms LIST` (comma-separated platform names).
pub fn parse_platforms(list: &str) -> Result<Vec<String>, ExportError> {
    let mut out: Vec<String> = Vec::new();
    for name in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let p = platform(name).ok_or_else(|| {
            ExportError::Binary(format!(
                "--platforms {list}: unknown platform {name:?} (known: {})",
                known()
            ))
        })?;
        if !out.iter().any(|o| o == p.name) {
            out.push(p.name.to_string());
        }
    }
    if out.is_empty() {
        return Err(ExportError::Binary(format!("--platforms {list:?}: no platform named")));
    }
    Ok(out)
}

/// A library chosen to pack, and what the exporter has to tell about it.
#[derive(Debug, Clone, PartialEq)]
pub struct Library {
    /// The file to pack.
    pub path: PathBuf,
    /// Notes for the user: what the file needs (printed by the export command).
    pub notes: Vec<String>,
}

/// Why a default library cannot be packed.
#[derive(Debug, Clone, PartialEq)]
pub enum Missing {
    /// No file at any of these places.
    NotBuilt(Vec<PathBuf>),
    /// The file was built from other sources (it lacks [`crate::guid::BUILD`]).
    Stale(PathBuf),
    /// This exporter cannot know where the platform's library is built (no `dist` target).
    Unknown,
}

/// The build string [`crate::guid::BUILD`] found in a library file (`contact-fmu <version>
/// (sources <16 hex digits>)`), if it has one.
pub fn build_of(bytes: &[u8]) -> Option<String> {
    let marker = b" (sources ";
    let mut from = 0;
    while let Some(i) = find(&bytes[from..], marker) {
        let at = from + i;
        from = at + 1;
        let digits = at + marker.len();
        let Some(tail) = bytes.get(digits..digits + 17) else {
            continue;
        };
        if !(tail[..16].iter().all(u8::is_ascii_hexdigit) && tail[16] == b')') {
            continue;
        }
        // back to "contact-fmu " over the version (at most 40 bytes of it)
        let head = b"contact-fmu ";
        let window = &bytes[at.saturating_sub(40 + head.len())..at];
        if let Some(h) = rfind(window, head) {
            let start = at - window.len() + h;
            if let Ok(text) = std::str::from_utf8(&bytes[start..digits + 17]) {
                return Some(text.to_string());
            }
        }
    }
    None
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

fn rfind(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).rposition(|w| w == needle)
}

/// The target directories a `dist` library may be in: those above the running executable
/// (`target/<profile>/contact-fmu`, a test's `target/<profile>/deps/...`).
fn target_dirs() -> Vec<PathBuf> {
    let Ok(exe) = std::env::current_exe() else {
        return Vec::new();
    };
    exe.parent()
        .map(|dir| dir.ancestors().skip(1).take(3).map(Path::to_path_buf).collect())
        .unwrap_or_default()
}

/// Where `scripts/build_fmu_library.sh` puts the `dist` library of `platform`, for each
/// target directory above the running executable (`target/<triple>/dist/<file>`; for this
/// platform also `target/dist/<file>`, a native build).
pub fn dist_candidates(platform: &Platform) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for target in target_dirs() {
        if let Some(triple) = platform.triple {
            out.push(target.join(triple).join(DIST_PROFILE).join(platform.file));
        }
        if platform.name == PLATFORM {
            out.push(target.join(DIST_PROFILE).join(platform.file));
        }
    }
    out
}

/// The `dist` library of `platform` built from this exporter's sources, or why there is none.
pub fn dist_library(platform: &Platform) -> Result<PathBuf, Missing> {
    let candidates = dist_candidates(platform);
    if candidates.is_empty() {
        return Err(Missing::Unknown);
    }
    let mut stale = None;
    for path in &candidates {
        let Ok(bytes) = std::fs::read(path) else { continue };
        if build_of(&bytes).as_deref() == Some(crate::guid::BUILD) {
            return Ok(path.clone());
        }
        stale.get_or_insert_with(|| path.clone());
    }
    Err(match stale {
        Some(path) => Missing::Stale(path),
        None => Missing::NotBuilt(candidates),
    })
}

/// The message for a default library that cannot be packed.
pub fn missing_message(platform: &str, why: &Missing) -> String {
    let remedy = format!(
        "build it with scripts/build_fmu_library.sh (or `cargo run --release`, which builds it), name a library with --binary {platform}=FILE{}, or leave {platform} out with --platforms",
        if platform == PLATFORM {
            " or CONTACT_FMU_LIBRARY=FILE"
        } else {
            ""
        }
    );
    match why {
        Missing::NotBuilt(places) => format!(
            "no {platform} library (looked for {}): {remedy}",
            places
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
        Missing::Stale(path) => format!(
            "{} was built from other sources than this exporter ({}): {remedy}",
            path.display(),
            crate::guid::BUILD
        ),
        Missing::Unknown => format!("this exporter does not know where a {platform} library is built: {remedy}"),
    }
}

/// The library `export` packs for `platform_name` when no `--binary` names one:
/// `CONTACT_FMU_LIBRARY` for this platform when set, else the platform's `dist` library built
/// from the exporter's sources ([`dist_library`]). A Linux library is checked for the glibc it
/// needs (a note when newer than [`GLIBC_FLOOR`]); a named library built from other sources
/// gets a note too.
pub fn find_library(platform_name: &str) -> Result<Library, ExportError> {
    let platform = platform(platform_name)
        .ok_or_else(|| ExportError::Library(format!("unknown platform {platform_name:?} (known: {})", known())))?;
    let mut notes = Vec::new();
    let named = std::env::var_os("CONTACT_FMU_LIBRARY").filter(|p| !p.is_empty() && platform.name == PLATFORM);
    let path = match named {
        Some(p) => {
            let p = PathBuf::from(p);
            let Ok(bytes) = std::fs::read(&p) else {
                return Err(ExportError::Library(format!(
                    "CONTACT_FMU_LIBRARY = {}: no such file",
                    p.display()
                )));
            };
            match build_of(&bytes) {
                Some(b) if b == crate::guid::BUILD => {}
                Some(b) => notes.push(format!(
                    "{} is {b}, not {} (this exporter)",
                    p.display(),
                    crate::guid::BUILD
                )),
                None => notes.push(format!("{} is not a contact-fmu library of any version", p.display())),
            }
            p
        }
        None => dist_library(platform).map_err(|why| ExportError::Library(missing_message(platform.name, &why)))?,
    };
    if platform.extension == "so" {
        match std::fs::read(&path).ok().and_then(|bytes| glibc_needed(&bytes)) {
            Some((major, minor)) if (major, minor) > GLIBC_FLOOR => notes.push(format!(
                "{} needs glibc {major}.{minor}: the FMU will not load where glibc is older (the portable build needs at most {}.{}; scripts/build_fmu_library.sh makes it)",
                path.display(),
                GLIBC_FLOOR.0,
                GLIBC_FLOOR.1
            )),
            _ => {}
        }
    }
    Ok(Library { path, notes })
}

/// The newest `GLIBC_x.y` version an ELF64 little-endian shared library requires (from its
/// `.gnu.version_r` section, which the dynamic loader checks); `None` for anything else or a
/// library that requires no glibc version.
pub fn glibc_needed(elf: &[u8]) -> Option<(u32, u32)> {
    let u16_at = |o: usize| Some(u16::from_le_bytes(elf.get(o..o + 2)?.try_into().ok()?));
    let u32_at = |o: usize| Some(u32::from_le_bytes(elf.get(o..o + 4)?.try_into().ok()?));
    let u64_at = |o: usize| Some(u64::from_le_bytes(elf.get(o..o + 8)?.try_into().ok()?));
    // ELF magic, 64-bit class, little-endian data.
    if elf.get(..6)? != b"\x7fELF\x02\x01" {
        return None;
    }
    let shoff = usize::try_from(u64_at(0x28)?).ok()?;
    let shentsize = usize::from(u16_at(0x3a)?);
    let shnum = usize::from(u16_at(0x3c)?);
    let section = |i: usize| -> Option<(u32, usize, usize, usize, usize)> {
        let h = shoff.checked_add(i.checked_mul(shentsize)?)?;
        Some((
            u32_at(h + 4)?,                         // sh_type
            usize::try_from(u64_at(h + 24)?).ok()?, // sh_offset
            usize::try_from(u64_at(h + 32)?).ok()?, // sh_size
            usize::try_from(u32_at(h + 40)?).ok()?, // sh_link
            usize::try_from(u32_at(h + 44)?).ok()?, // sh_info
        ))
    };
    const SHT_GNU_VERNEED: u32 = 0x6fff_fffe;
    let mut newest: Option<(u32, u32)> = None;
    for i in 0..shnum {
        let (kind, offset, _, link, count) = section(i)?;
        if kind != SHT_GNU_VERNEED {
            continue;
        }
        let (_, strings, string_size, _, _) = section(link)?;
        let name = |o: usize| -> Option<&[u8]> {
            let bytes = elf.get(strings..strings.checked_add(string_size)?)?.get(o..)?;
            Some(&bytes[..bytes.iter().position(|&b| b == 0)?])
        };
        // Verneed entries (one per library), each with its Vernaux entries (one per version).
        let mut need = offset;
        for _ in 0..count {
            let aux_count = u16_at(need + 2)?;
            let mut aux = need.checked_add(usize::try_from(u32_at(need + 8)?).ok()?)?;
            for _ in 0..aux_count {
                let version = name(usize::try_from(u32_at(aux + 8)?).ok()?)?;
                if let Some(v) = version.strip_prefix(b"GLIBC_") {
                    let text = std::str::from_utf8(v).ok()?;
                    let mut parts = text.split('.').map(|p| p.parse::<u32>());
                    if let (Some(Ok(major)), Some(Ok(minor))) = (parts.next(), parts.next()) {
                        newest = newest.max(Some((major, minor)));
                    }
                }
                aux = aux.checked_add(usize::try_from(u32_at(aux + 12)?).ok()?)?;
            }
            need = need.checked_add(usize::try_from(u32_at(need + 12)?).ok()?)?;
        }
    }
    newest
}
