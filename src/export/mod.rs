//! Building an FMU (an FMI 2.0 Co-Simulation zip) from a scene file.
//!
//! The FMU holds `modelDescription.xml` (generated here from the scene's variable table),
//! `binaries/<platform>/<model name>.<ext>` (a copy of this crate's shared library, which
//! serves every scene), `resources/scene.toml` (the scene text, read by `fmi2Instantiate`)
//! and `documentation/index.html`.
//!
//! Everything is deterministic: the GUID is derived from the scene text and the crate
//! version, and the one date, `generationDateAndTime` (also the zip entries' timestamp), is
//! `SOURCE_DATE_EPOCH` when that is set and a fixed date (1980-01-01) otherwise, so the same
//! scene always gives the same FMU. [`model_description_xml`] is the description without the
//! date, which is what `modelDescription/` keeps under version control.
//!
//! The library packed is the one of the cargo profile `dist` (no debug information, stripped,
//! fat LTO), built for glibc 2.17 by `scripts/build_fmu_library.sh`; see [`find_library`].

use crate::fmi::lifecycle::Version;
use crate::guid::guid;
use crate::scene::{Scene, SceneError};
use crate::simulation::{SimError, Simulation};
use crate::variables::VariableTable;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// The crate version, written into `generationTool` (and mixed into the GUID).
pub use crate::guid::VERSION;

mod description;
pub mod fmi3;
mod library;
pub use description::{
    describe, documentation_html, format_real, format_utc, generation_epoch, model_description_xml,
    model_description_xml_dated, model_structure, output_dependencies, utc_time, DEFAULT_EPOCH, MAX_EPOCH,
};
pub use library::{
    build_of, dist_library, find_library, glibc_needed, library_file, missing_message, parse_platforms, platform,
    Binary, Library, Missing, Platform, DEFAULT_PLATFORMS, DIST_PROFILE, GLIBC_FLOOR, LIBRARY_EXTENSION, PLATFORM,
    PLATFORMS,
};

/// An export that did not succeed; the message names the file.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The scene does not parse, validate or compile.
    #[error("{0}")]
    Scene(#[from] SceneError),
    /// The scene parses but the model cannot be initialised with its start values.
    #[error("{path}: {message}")]
    Model {
        /// The scene file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: io::Error,
    },
    /// The shared library was not found.
    #[error("{0}")]
    Library(String),
    /// A `--binary` argument that cannot be packed.
    #[error("{0}")]
    Binary(String),
    /// `SOURCE_DATE_EPOCH` is set but is not a number of seconds since 1970.
    #[error("SOURCE_DATE_EPOCH = {0:?} is not a whole number of seconds since 1970-01-01 (0 to {MAX_EPOCH})")]
    SourceDateEpoch(String),
}

fn io_error(path: &Path) -> impl FnOnce(io::Error) -> ExportError + '_ {
    move |source| ExportError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// What [`export_fmu`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportedFmu {
    /// The FMU file.
    pub path: PathBuf,
    /// `modelName` and `modelIdentifier`.
    pub model_name: String,
    /// The GUID in the model description.
    pub guid: String,
    /// Number of model variables.
    pub variables: usize,
}

/// Builds the FMU for the scene file `scene_path` into `out`, copying the shared library
/// `library` (see [`find_library`]) as `binaries/<platform>/<model name>.<ext>`.
///
/// The scene is parsed, validated and initialised once with its start values first, so a
/// scene that cannot run is refused with the same message `simulate` would give.
pub fn export_fmu(scene_path: &Path, out: &Path, library: &Path) -> Result<ExportedFmu, ExportError> {
    let host = Binary {
        platform: PLATFORM.to_string(),
        path: library.to_path_buf(),
    };
    export_fmu_binaries(scene_path, out, &[host], Version::Fmi2)
}

/// Builds the FMU of FMI `version` like [`export_fmu`], packing one library per platform:
/// each of `binaries` as `binaries/<platform>/<model name>.<dll|so|dylib>` (the platform
/// folder of that version; in the order of the platform names, so the FMU does not depend on
/// the order given). Two libraries for one platform are refused.
pub fn export_fmu_binaries(
    scene_path: &Path,
    out: &Path,
    binaries: &[Binary],
    version: Version,
) -> Result<ExportedFmu, ExportError> {
    let binaries = one_per_platform(binaries)?;
    let text = std::fs::read_to_string(scene_path).map_err(io_error(scene_path))?;
    let origin = scene_path.display().to_string();
    let scene = Scene::from_str(&text, &origin)?;
    let mut trial = Simulation::new(scene.clone(), &origin);
    trial.initialize(0.0).map_err(|e| match e {
        // (a scene error names the file itself)
        SimError::Scene(e) => ExportError::Scene(e),
        e => ExportError::Model {
            path: scene_path.to_path_buf(),
            message: e.to_string(),
        },
    })?;
    let libraries = binaries
        .iter()
        .map(|b| std::fs::read(&b.path).map_err(io_error(&b.path)))
        .collect::<Result<Vec<_>, _>>()?;
    let epoch = generation_epoch()?;
    let date = format_utc(epoch);
    let xml = match version {
        Version::Fmi2 => model_description_xml_dated(&scene, &text, Some(&date)),
        Version::Fmi3 => fmi3::model_description_xml_dated(&scene, &text, Some(&date)),
    };
    let html = documentation_html(&scene, version);
    let name = &scene.model.name;
    let mut entries: Vec<(String, &[u8], u32)> = vec![("modelDescription.xml".into(), xml.as_bytes(), 0o644)];
    for (b, bytes) in binaries.iter().zip(&libraries) {
        entries.push((b.entry_in(name, version), bytes, 0o755));
    }
    entries.push(("resources/scene.toml".into(), text.as_bytes(), 0o644));
    entries.push(("documentation/index.html".into(), html.as_bytes(), 0o644));
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io_error(dir))?;
    }
    // Write next to the target and rename, so a failed export never leaves half an FMU.
    let tmp = out.with_extension("fmu.partial");
    write_zip(&tmp, &entries, epoch).map_err(io_error(&tmp))?;
    std::fs::rename(&tmp, out).map_err(io_error(out))?;
    Ok(ExportedFmu {
        path: out.to_path_buf(),
        model_name: name.clone(),
        guid: guid(&text),
        variables: VariableTable::from_scene(&scene).vars.len(),
    })
}

/// `binaries` in the order of their platform names; two for one platform are refused.
fn one_per_platform(binaries: &[Binary]) -> Result<Vec<Binary>, ExportError> {
    let mut binaries = binaries.to_vec();
    binaries.sort_by(|a, b| a.platform.cmp(&b.platform));
    if let Some(w) = binaries.windows(2).find(|w| w[0].platform == w[1].platform) {
        return Err(ExportError::Binary(format!(
            "two libraries for the platform {}: {} and {}",
            w[0].platform,
            w[0].path.display(),
            w[1].path.display()
        )));
    }
    Ok(binaries)
}

/// Writes the zip; every entry carries the time `epoch` (zip times are local times without a
/// zone: the UTC time is written; before 1980 or after 2107, which zip cannot hold,
/// 1980-01-01).
fn write_zip(path: &Path, entries: &[(String, &[u8], u32)], epoch: u64) -> io::Result<()> {
    use zip::write::SimpleFileOptions;
    use zip::{CompressionMethod, DateTime, ZipWriter};
    let (y, mo, d, h, mi, s) = utc_time(epoch);
    let time = u16::try_from(y)
        .ok()
        .and_then(|y| DateTime::from_date_and_time(y, mo as u8, d as u8, h as u8, mi as u8, s as u8).ok())
        .unwrap_or_default();
    let file = std::fs::File::create(path)?;
    let mut zip = ZipWriter::new(io::BufWriter::new(file));
    let options = SimpleFileOptions::default()
        .compression_method(CompressionMethod::Deflated)
        .last_modified_time(time);
    let mut dirs: Vec<String> = Vec::new();
    for (name, _, _) in entries {
        let mut prefix = String::new();
        for part in name
            .split('/')
            .collect::<Vec<_>>()
            .split_last()
            .map(|(_, d)| d)
            .unwrap_or(&[])
        {
            prefix.push_str(part);
            prefix.push('/');
            if !dirs.contains(&prefix) {
                dirs.push(prefix.clone());
            }
        }
    }
    for d in &dirs {
        zip.add_directory(d.as_str(), options.unix_permissions(0o755))
            .map_err(io::Error::other)?;
    }
    for (name, data, mode) in entries {
        zip.start_file(name.as_str(), options.unix_permissions(*mode))
            .map_err(io::Error::other)?;
        zip.write_all(data)?;
    }
    let mut inner = zip.finish().map_err(io::Error::other)?;
    inner.flush()?;
    Ok(())
}

/// The CLI's `export` command: an FMU of FMI `version`, packing the libraries of `binaries`
/// (`PLATFORM=PATH`, see [`Binary::parse`]) and, for every platform of `platforms` (default
/// [`DEFAULT_PLATFORMS`]: linux64 and win64) that no `--binary` names, the library from
/// [`find_library`] (its notes go to standard error); when no output is given,
/// `target/fmu/<model name>.fmu` (FMI 2.0) or `target/fmu3/<model name>.fmu` (FMI 3.0), where
/// the main job puts the bundled FMUs.
pub fn export_command(
    scene_path: &Path,
    out: Option<&Path>,
    binaries: &[String],
    platforms: Option<&str>,
    version: Version,
) -> Result<ExportedFmu, ExportError> {
    // a scene that does not parse or validate gets its one message before anything else
    let scene = Scene::from_file(scene_path)?;
    let mut binaries = binaries
        .iter()
        .map(|b| Binary::parse(b))
        .collect::<Result<Vec<_>, _>>()?;
    one_per_platform(&binaries)?;
    let platforms = match platforms {
        Some(list) => parse_platforms(list)?,
        None => DEFAULT_PLATFORMS.iter().map(|p| p.to_string()).collect(),
    };
    for platform in &platforms {
        if binaries.iter().any(|b| &b.platform == platform) {
            continue;
        }
        let library = find_library(platform)?;
        for note in &library.notes {
            eprintln!("note: {note}");
        }
        binaries.push(Binary {
            platform: platform.clone(),
            path: library.path,
        });
    }
    let out = match out {
        Some(o) => o.to_path_buf(),
        None => Path::new("target")
            .join(fmu_folder(version))
            .join(format!("{}.fmu", scene.model.name)),
    };
    export_fmu_binaries(scene_path, &out, &binaries, version)
}

/// The folder of `target/` that the FMUs of `version` go to: `fmu`, `fmu3`.
pub fn fmu_folder(version: Version) -> &'static str {
    match version {
        Version::Fmi2 => "fmu",
        Version::Fmi3 => "fmu3",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reals_are_written_exactly_and_briefly() {
        for x in [0.0, 1.0, 0.5, 1e-8, 210e9, 0.33, 1.0 / 3.0, -2.5e-300, 9.81] {
            let s = format_real(x);
            assert_eq!(s.parse::<f64>().unwrap().to_bits(), x.to_bits(), "{s}");
        }
        assert_eq!(format_real(1e-8), "1e-8");
        assert_eq!(format_real(2.0), "2");
        assert_eq!(format_real(0.33), "0.33");
    }

    #[test]
    fn generation_times_are_utc_calendar_times() {
        assert_eq!(format_utc(0), "1970-01-01T00:00:00Z");
        assert_eq!(format_utc(DEFAULT_EPOCH), "1980-01-01T00:00:00Z");
        assert_eq!(format_utc(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(format_utc(1_700_000_000), "2023-11-14T22:13:20Z");
        assert_eq!(format_utc(4_107_542_399), "2100-02-28T23:59:59Z");
        assert_eq!(format_utc(MAX_EPOCH), "9999-12-31T23:59:59Z");
    }

    #[test]
    fn glibc_versions_are_read_from_elf_files_only() {
        assert_eq!(glibc_needed(b"not an ELF file"), None);
        assert_eq!(glibc_needed(b"\x7fELF\x02\x01"), None);
        if cfg!(all(target_os = "linux", target_env = "gnu")) {
            // This test binary links glibc dynamically.
            let me = std::fs::read(std::env::current_exe().unwrap()).unwrap();
            let (major, minor) = glibc_needed(&me).expect("a glibc version");
            assert!(major == 2 && minor >= 2, "{major}.{minor}");
        }
    }
}
