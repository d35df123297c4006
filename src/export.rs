//! Building an FMU (an FMI 2.0 Co-Simulation zip) from a scene file.
//!
//! The FMU holds `modelDescription.xml` (generated here from the scene's variable table),
//! `binaries/<platform>/<model name>.<ext>` (a copy of this crate's shared library, which
//! serves every scene), `resources/scene.toml` (the scene text, read by `fmi2Instantiate`)
//! and `documentation/index.html`.
//!
//! Everything is deterministic: the GUID is derived from the scene text and the crate
//! version, the description carries no generation date and the zip entries carry a fixed
//! timestamp, so the same scene always gives the same `modelDescription.xml` (which is why
//! the bundled ones can be kept under version control).

use crate::fmi::LOG_CATEGORIES;
use crate::guid::guid;
use crate::scene::{Scene, SceneError};
use crate::simulation::Simulation;
use crate::variables::{Causality, EnumType, Range, VarType, Variability, Variable, VariableTable, UNITS};
use quick_xml::events::attributes::Attribute;
use quick_xml::events::{BytesDecl, Event};
use quick_xml::name::QName;
use quick_xml::Writer;
use std::borrow::Cow;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// The crate version, written into `generationTool` (and mixed into the GUID).
pub use crate::guid::VERSION;

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

/// The file name cargo gives this crate's shared library.
pub const LIBRARY_FILE: &str = if cfg!(target_os = "windows") {
    "contact_fmu.dll"
} else if cfg!(target_os = "macos") {
    "libcontact_fmu.dylib"
} else {
    "libcontact_fmu.so"
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

/// Shortest text that reads back as exactly `x` (an `xs:double`).
pub fn format_real(x: f64) -> String {
    let plain = format!("{x}");
    let sci = format!("{x:e}");
    if sci.len() < plain.len() {
        sci
    } else {
        plain
    }
}

/// Attributes with only the escaping XML needs inside double quotes (`&`, `<`, `"`),
/// so that descriptions read naturally (`Young's modulus`, not `Young&apos;s modulus`).
fn attrs<'k, V: AsRef<str>>(pairs: impl IntoIterator<Item = (&'k str, V)>) -> Vec<Attribute<'k>> {
    pairs
        .into_iter()
        .map(|(key, value)| {
            let v = value
                .as_ref()
                .replace('&', "&amp;")
                .replace('<', "&lt;")
                .replace('"', "&quot;");
            Attribute {
                key: QName(key.as_bytes()),
                value: Cow::Owned(v.into_bytes()),
            }
        })
        .collect()
}

fn causality_name(c: Causality) -> &'static str {
    match c {
        Causality::Parameter => "parameter",
        Causality::CalculatedParameter => "calculatedParameter",
        Causality::Input => "input",
        Causality::Output => "output",
    }
}

fn variability_name(v: Variability) -> &'static str {
    match v {
        Variability::Fixed => "fixed",
        Variability::Discrete => "discrete",
        Variability::Continuous => "continuous",
    }
}

/// The `initial` attribute: exact for parameters, calculated for calculated parameters and
/// for outputs without a start value, none for inputs.
fn initial_of(v: &Variable) -> Option<&'static str> {
    match v.causality {
        Causality::Parameter => Some("exact"),
        Causality::CalculatedParameter => Some("calculated"),
        Causality::Input => None,
        Causality::Output => Some(if v.start.is_some() { "exact" } else { "calculated" }),
    }
}

/// A range in words: `> 0`, `>= 1`, `[0, 0.5)`.
fn range_text(r: &Range) -> String {
    let min = format_real(r.min);
    if r.max.is_finite() {
        let open = if r.min_exclusive { "(" } else { "[" };
        let close = if r.max_exclusive { ")" } else { "]" };
        format!("{open}{min}, {}{close}", format_real(r.max))
    } else if r.min_exclusive {
        format!("> {min}")
    } else {
        format!(">= {min}")
    }
}

fn describe(v: &Variable) -> String {
    match (v.causality, v.range) {
        (Causality::Parameter, Some(r)) if !matches!(v.vtype, VarType::Enumeration(_)) => {
            if r.max.is_finite() {
                format!("{}; allowed range {}", v.description, range_text(&r))
            } else {
                format!("{}; must be {}", v.description, range_text(&r))
            }
        }
        _ => v.description.clone(),
    }
}

/// The `min`/`max` attributes of a range (exclusive bounds are stated in the description and
/// checked by `fmi2ExitInitializationMode`).
fn range_attributes(r: Option<Range>) -> Vec<(&'static str, String)> {
    let mut a = Vec::new();
    if let Some(r) = r {
        if r.min.is_finite() {
            a.push(("min", format_real(r.min)));
        }
        if r.max.is_finite() {
            a.push(("max", format_real(r.max)));
        }
    }
    a
}

/// The units used by the table, in [`UNITS`] order.
fn used_units(table: &VariableTable) -> Vec<(&'static str, [i32; 3])> {
    UNITS
        .iter()
        .copied()
        .filter(|(name, _)| table.vars.iter().any(|v| v.unit == Some(*name)))
        .collect()
}

/// The enumeration types used by the table, in declaration order.
fn used_enums(table: &VariableTable) -> Vec<EnumType> {
    [EnumType::ContactLaw, EnumType::SolverMethod]
        .into_iter()
        .filter(|e| table.vars.iter().any(|v| v.vtype == VarType::Enumeration(*e)))
        .collect()
}

/// The 1-based indices of `ModelStructure`: (every output, the initial unknowns).
pub fn model_structure(table: &VariableTable) -> (Vec<usize>, Vec<usize>) {
    let outputs = table
        .vars
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == Causality::Output)
        .map(|(i, _)| i + 1)
        .collect();
    let initial = table
        .vars
        .iter()
        .enumerate()
        .filter(|(_, v)| match v.causality {
            Causality::Output => matches!(initial_of(v), Some("calculated") | Some("approx")),
            Causality::CalculatedParameter => true,
            _ => false,
        })
        .map(|(i, _)| i + 1)
        .collect();
    (outputs, initial)
}

/// The `modelDescription.xml` of a scene (UTF-8, element order of the FMI 2.0 schema, no
/// generation date).
pub fn model_description_xml(scene: &Scene, scene_text: &str) -> String {
    let bytes = write_model_description(scene, scene_text).expect("writing XML into a Vec<u8> cannot fail");
    String::from_utf8(bytes).expect("quick-xml writes the UTF-8 it is given")
}

fn write_model_description(scene: &Scene, scene_text: &str) -> io::Result<Vec<u8>> {
    let table = VariableTable::from_scene(scene);
    let m = &scene.model;
    let mut w = Writer::new_with_indent(Vec::new(), b' ', 2);
    w.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))?;
    let guid = guid(scene_text);
    let tool = format!("contact-fmu {VERSION}");
    let mut root = vec![
        ("fmiVersion", "2.0"),
        ("modelName", m.name.as_str()),
        ("guid", guid.as_str()),
    ];
    if !m.description.is_empty() {
        root.push(("description", m.description.as_str()));
    }
    root.push(("generationTool", tool.as_str()));
    root.push(("variableNamingConvention", "structured"));
    w.create_element("fmiModelDescription")
        .with_attributes(attrs(root))
        .write_inner_content(|w| {
            w.create_element("CoSimulation")
                .with_attributes(attrs([
                    ("modelIdentifier", m.name.as_str()),
                    ("canHandleVariableCommunicationStepSize", "true"),
                    ("canInterpolateInputs", "false"),
                    ("maxOutputDerivativeOrder", "0"),
                    ("canRunAsynchronuously", "false"),
                    ("canBeInstantiatedOnlyOncePerProcess", "false"),
                    ("canNotUseMemoryManagementFunctions", "true"),
                    ("canGetAndSetFMUstate", "true"),
                    ("canSerializeFMUstate", "true"),
                    ("providesDirectionalDerivative", "false"),
                ]))
                .write_empty()?;
            let units = used_units(&table);
            if !units.is_empty() {
                w.create_element("UnitDefinitions").write_inner_content(|w| {
                    for (name, [kg, metre, s]) in units {
                        let mut base: Vec<(&str, String)> = Vec::new();
                        for (attr, e) in [("kg", kg), ("m", metre), ("s", s)] {
                            if e != 0 {
                                base.push((attr, e.to_string()));
                            }
                        }
                        // Angular units: radian is FMI's base unit "rad" (dimensionless in UNITS).
                        if name.starts_with("rad") {
                            base.push(("rad", "1".into()));
                        }
                        w.create_element("Unit")
                            .with_attributes(attrs([("name", name)]))
                            .write_inner_content(|w| {
                                w.create_element("BaseUnit")
                                    .with_attributes(attrs(base.iter().map(|(a, v)| (*a, v.as_str()))))
                                    .write_empty()?;
                                Ok(())
                            })?;
                    }
                    Ok(())
                })?;
            }
            let enums = used_enums(&table);
            if !enums.is_empty() {
                w.create_element("TypeDefinitions").write_inner_content(|w| {
                    for e in enums {
                        w.create_element("SimpleType")
                            .with_attributes(attrs([("name", e.type_name())]))
                            .write_inner_content(|w| {
                                w.create_element("Enumeration").write_inner_content(|w| {
                                    for (name, value) in e.items() {
                                        let value = value.to_string();
                                        w.create_element("Item")
                                            .with_attributes(attrs([("name", name), ("value", value.as_str())]))
                                            .write_empty()?;
                                    }
                                    Ok(())
                                })?;
                                Ok(())
                            })?;
                    }
                    Ok(())
                })?;
            }
            w.create_element("LogCategories").write_inner_content(|w| {
                for (name, description) in LOG_CATEGORIES {
                    let name = name.to_str().unwrap_or_default();
                    w.create_element("Category")
                        .with_attributes(attrs([("name", name), ("description", description)]))
                        .write_empty()?;
                }
                Ok(())
            })?;
            let stop = format_real(m.stop_time);
            let tolerance = format_real(scene.solver.rtol);
            let step = format_real(m.interval);
            w.create_element("DefaultExperiment")
                .with_attributes(attrs([
                    ("startTime", "0"),
                    ("stopTime", stop.as_str()),
                    ("tolerance", tolerance.as_str()),
                    ("stepSize", step.as_str()),
                ]))
                .write_empty()?;
            w.create_element("ModelVariables").write_inner_content(|w| {
                for (vr, v) in table.vars.iter().enumerate() {
                    write_variable(w, vr, v)?;
                }
                Ok(())
            })?;
            let (outputs, initial) = model_structure(&table);
            w.create_element("ModelStructure").write_inner_content(|w| {
                for (tag, list) in [("Outputs", &outputs), ("InitialUnknowns", &initial)] {
                    if list.is_empty() {
                        continue;
                    }
                    w.create_element(tag).write_inner_content(|w| {
                        for i in list {
                            let i = i.to_string();
                            w.create_element("Unknown")
                                .with_attributes(attrs([("index", i.as_str())]))
                                .write_empty()?;
                        }
                        Ok(())
                    })?;
                }
                Ok(())
            })?;
            Ok(())
        })?;
    let mut out = w.into_inner();
    out.push(b'\n');
    Ok(out)
}

fn write_variable(w: &mut Writer<Vec<u8>>, vr: usize, v: &Variable) -> io::Result<()> {
    let vr_text = vr.to_string();
    let description = describe(v);
    let mut attributes = vec![("name", v.name.as_str()), ("valueReference", vr_text.as_str())];
    if !description.is_empty() {
        attributes.push(("description", description.as_str()));
    }
    attributes.push(("causality", causality_name(v.causality)));
    attributes.push(("variability", variability_name(v.variability)));
    if let Some(initial) = initial_of(v) {
        attributes.push(("initial", initial));
    }
    let start_allowed = initial_of(v) != Some("calculated");
    let start = if start_allowed { v.start } else { None };
    w.create_element("ScalarVariable")
        .with_attributes(attrs(attributes))
        .write_inner_content(|w| {
            let mut a: Vec<(&str, String)> = Vec::new();
            let tag = match v.vtype {
                VarType::Real => {
                    if let Some(u) = v.unit {
                        a.push(("unit", u.to_string()));
                    }
                    if v.causality == Causality::Parameter {
                        a.extend(range_attributes(v.range));
                    }
                    if let Some(s) = start {
                        a.push(("start", format_real(s)));
                    }
                    "Real"
                }
                VarType::Integer => {
                    if let Some(s) = start {
                        a.push(("start", format!("{}", s.round() as i64)));
                    }
                    "Integer"
                }
                VarType::Boolean => {
                    if let Some(s) = start {
                        a.push(("start", (if s != 0.0 { "true" } else { "false" }).to_string()));
                    }
                    "Boolean"
                }
                VarType::Enumeration(e) => {
                    a.push(("declaredType", e.type_name().to_string()));
                    if let Some(s) = start {
                        a.push(("start", format!("{}", s.round() as i64)));
                    }
                    "Enumeration"
                }
            };
            w.create_element(tag)
                .with_attributes(attrs(a.iter().map(|(k, v)| (*k, v.as_str()))))
                .write_empty()?;
            Ok(())
        })?;
    Ok(())
}

fn escape_html(s: &str) -> String {
    quick_xml::escape::partial_escape(s).into_owned()
}

/// `documentation/index.html`: the model's variables as a table.
pub fn documentation_html(scene: &Scene) -> String {
    let table = VariableTable::from_scene(scene);
    let m = &scene.model;
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    h.push_str(&format!("<title>{}</title>\n", escape_html(&m.name)));
    h.push_str("<style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 8px;text-align:left}</style>\n");
    h.push_str("</head>\n<body>\n");
    h.push_str(&format!("<h1>{}</h1>\n", escape_html(&m.name)));
    if !m.description.is_empty() {
        h.push_str(&format!("<p>{}</p>\n", escape_html(&m.description)));
    }
    h.push_str(&format!(
        "<p>FMI 2.0 Co-Simulation FMU generated by contact-fmu {VERSION}. Default experiment: stop time {} s, communication step {} s, relative tolerance {}. The scene is in <code>resources/scene.toml</code>.</p>\n",
        format_real(m.stop_time),
        format_real(m.interval),
        format_real(scene.solver.rtol)
    ));
    h.push_str("<table>\n<tr><th>value reference</th><th>name</th><th>causality</th><th>type</th><th>unit</th><th>start</th><th>description</th></tr>\n");
    for (vr, v) in table.vars.iter().enumerate() {
        let vtype = match v.vtype {
            VarType::Real => "Real".to_string(),
            VarType::Integer => "Integer".to_string(),
            VarType::Boolean => "Boolean".to_string(),
            VarType::Enumeration(e) => {
                let items: Vec<String> = e.items().iter().map(|(n, i)| format!("{i}={n}")).collect();
                format!("{} ({})", e.type_name(), items.join(", "))
            }
        };
        let start = match (v.start, v.vtype) {
            (Some(s), VarType::Real) => format_real(s),
            (Some(s), VarType::Boolean) => (s != 0.0).to_string(),
            (Some(s), _) => format!("{}", s.round() as i64),
            (None, _) => String::new(),
        };
        h.push_str(&format!(
            "<tr><td>{vr}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            escape_html(&v.name),
            causality_name(v.causality),
            escape_html(&vtype),
            escape_html(v.unit.unwrap_or("")),
            escape_html(&start),
            escape_html(&describe(v)),
        ));
    }
    h.push_str("</table>\n</body>\n</html>\n");
    h
}

/// Builds the FMU for the scene file `scene_path` into `out`, copying the shared library
/// `library` (see [`find_library`]) as `binaries/<platform>/<model name>.<ext>`.
///
/// The scene is parsed, validated and initialised once with its start values first, so a
/// scene that cannot run is refused with the same message `simulate` would give.
pub fn export_fmu(scene_path: &Path, out: &Path, library: &Path) -> Result<ExportedFmu, ExportError> {
    let text = std::fs::read_to_string(scene_path).map_err(io_error(scene_path))?;
    let origin = scene_path.display().to_string();
    let scene = Scene::from_str(&text, &origin)?;
    let mut trial = Simulation::new(scene.clone(), &origin);
    trial.initialize(0.0).map_err(|e| ExportError::Model {
        path: scene_path.to_path_buf(),
        message: e.to_string(),
    })?;
    let binary = std::fs::read(library).map_err(io_error(library))?;
    let xml = model_description_xml(&scene, &text);
    let html = documentation_html(&scene);
    let name = &scene.model.name;
    let entries: Vec<(String, &[u8], u32)> = vec![
        ("modelDescription.xml".into(), xml.as_bytes(), 0o644),
        (
            format!("binaries/{PLATFORM}/{name}.{LIBRARY_EXTENSION}"),
            &binary,
            0o755,
        ),
        ("resources/scene.toml".into(), text.as_bytes(), 0o644),
        ("documentation/index.html".into(), html.as_bytes(), 0o644),
    ];
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io_error(dir))?;
    }
    // Write next to the target and rename, so a failed export never leaves half an FMU.
    let tmp = out.with_extension("fmu.partial");
    write_zip(&tmp, &entries).map_err(io_error(&tmp))?;
    std::fs::rename(&tmp, out).map_err(io_error(out))?;
    Ok(ExportedFmu {
        path: out.to_path_buf(),
        model_name: name.clone(),
        guid: guid(&text),
        variables: VariableTable::from_scene(&scene).vars.len(),
    })
}

fn write_zip(path: &Path, entries: &[(String, &[u8], u32)]) -> io::Result<()> {
    use zip::write::SimpleFileOptions;
    use zip::{CompressionMethod, DateTime, ZipWriter};
    let file = std::fs::File::create(path)?;
    let mut zip = ZipWriter::new(io::BufWriter::new(file));
    let options = SimpleFileOptions::default()
        .compression_method(CompressionMethod::Deflated)
        .last_modified_time(DateTime::default());
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

/// Locates this crate's shared library next to the running executable: in the executable's
/// own folder (`target/release/contact-fmu` → `target/release/libcontact_fmu.so`), its
/// `deps/` (where cargo rebuilds it) or its parent (test binaries live in
/// `target/<profile>/deps/`); the newest of those found.
pub fn find_library() -> Result<PathBuf, ExportError> {
    let exe = std::env::current_exe()
        .map_err(|e| ExportError::Library(format!("cannot locate the running executable: {e}")))?;
    let dir = exe.parent().map(Path::to_path_buf).unwrap_or_default();
    let candidates = [
        dir.join(LIBRARY_FILE),
        dir.join("deps").join(LIBRARY_FILE),
        dir.join("..").join(LIBRARY_FILE),
    ];
    // `cargo run` and `cargo test` rebuild the library in `deps/` without copying it up to
    // `target/<profile>/`, so the copy next to the executable can be stale: take the newest.
    let newest = candidates
        .iter()
        .filter_map(|c| Some((std::fs::metadata(c).ok().filter(|m| m.is_file())?.modified().ok()?, c)))
        .max_by_key(|(modified, _)| *modified);
    if let Some((_, path)) = newest {
        return Ok(path.clone());
    }
    Err(ExportError::Library(format!(
        "cannot find the FMU library {LIBRARY_FILE} (looked in {}); build it with `cargo build --release`",
        candidates
            .iter()
            .map(|c| c.display().to_string())
            .collect::<Vec<_>>()
            .join(" and ")
    )))
}

/// The CLI's `export` command: the library from [`find_library`], and when no output is
/// given, `target/fmu/<model name>.fmu` (where the main job puts the bundled FMUs).
pub fn export_command(scene_path: &Path, out: Option<&Path>) -> Result<ExportedFmu, ExportError> {
    let library = find_library()?;
    let out = match out {
        Some(o) => o.to_path_buf(),
        None => {
            let scene = Scene::from_file(scene_path)?;
            Path::new("target")
                .join("fmu")
                .join(format!("{}.fmu", scene.model.name))
        }
    };
    export_fmu(scene_path, &out, &library)
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
}
