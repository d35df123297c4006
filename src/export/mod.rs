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
use crate::fmi::LOG_CATEGORIES;
use crate::guid::guid;
use crate::scene::{Scene, SceneError};
use crate::simulation::Simulation;
use crate::variables::{Causality, EnumType, Range, Unit, VarType, Variable, VariableTable, UNITS};
use quick_xml::events::attributes::Attribute;
use quick_xml::events::{BytesDecl, Event};
use quick_xml::name::QName;
use quick_xml::Writer;
use std::borrow::Cow;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// The crate version, written into `generationTool` (and mixed into the GUID).
pub use crate::guid::VERSION;

pub mod fmi3;
mod library;
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

/// A variable's description as the model description gives it: the table's text, and for a
/// parameter with a range, the range in words.
pub fn describe(v: &Variable) -> String {
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
fn used_units(table: &VariableTable) -> Vec<Unit> {
    UNITS
        .iter()
        .copied()
        .filter(|u| table.vars.iter().any(|v| v.unit == Some(u.name)))
        .collect()
}

/// The enumeration types used by the table, in declaration order.
fn used_enums(table: &VariableTable) -> Vec<EnumType> {
    [EnumType::ContactLaw, EnumType::SolverMethod]
        .into_iter()
        .filter(|e| table.vars.iter().any(|v| v.vtype == VarType::Enumeration(*e)))
        .collect()
}

/// The 1-based indices of the variables an output depends on directly, for the
/// `dependencies` attribute of `ModelStructure/Outputs`: every input for an output that
/// depends on the inputs; for the other outputs read from the state, the inputs that move a
/// driven joint (none in a scene without `joint_motion` inputs); none for counters (see
/// docs/fmi.md, "Dependencies").
pub fn output_dependencies(table: &VariableTable, output: usize) -> Vec<usize> {
    let var = &table.vars[output];
    if var.depends_on_inputs {
        return table
            .vars
            .iter()
            .enumerate()
            .filter(|(_, v)| v.causality == Causality::Input)
            .map(|(i, _)| i + 1)
            .collect();
    }
    // a host that sets a driven joint's coordinate or rate moves the state at once
    if crate::outputs::needs(var.target) != crate::outputs::Needs::Nothing {
        return table.moving_inputs.iter().map(|&i| i + 1).collect();
    }
    Vec::new()
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

/// The `modelDescription.xml` of a scene (UTF-8, element order of the FMI 2.0 schema) without
/// `generationDateAndTime`: a pure function of the scene text, kept in `modelDescription/`.
pub fn model_description_xml(scene: &Scene, scene_text: &str) -> String {
    model_description_xml_dated(scene, scene_text, None)
}

/// The `modelDescription.xml` of a scene with `generationDateAndTime` set to `generated` (an
/// `xs:dateTime` such as [`format_utc`] writes), as packed into the FMU.
pub fn model_description_xml_dated(scene: &Scene, scene_text: &str, generated: Option<&str>) -> String {
    let bytes = write_model_description(scene, scene_text, generated).expect("writing XML into a Vec<u8> cannot fail");
    String::from_utf8(bytes).expect("quick-xml writes the UTF-8 it is given")
}

/// The generation time of exported FMUs when `SOURCE_DATE_EPOCH` is not set:
/// 1980-01-01T00:00:00Z, the earliest time a zip entry can carry.
pub const DEFAULT_EPOCH: u64 = 315_532_800;

/// The latest `SOURCE_DATE_EPOCH` accepted: 9999-12-31T23:59:59Z.
pub const MAX_EPOCH: u64 = 253_402_300_799;

/// The generation time of an export [s since 1970-01-01 UTC]: `SOURCE_DATE_EPOCH` (the
/// reproducible-builds convention) when it is set, [`DEFAULT_EPOCH`] otherwise, so that the
/// same scene and library always give the same FMU. A value that is not a whole number of
/// seconds is refused.
pub fn generation_epoch() -> Result<u64, ExportError> {
    match std::env::var("SOURCE_DATE_EPOCH") {
        Err(std::env::VarError::NotPresent) => Ok(DEFAULT_EPOCH),
        Ok(text) if text.is_empty() => Ok(DEFAULT_EPOCH),
        Ok(text) => match text.parse::<u64>() {
            Ok(t) if t <= MAX_EPOCH => Ok(t),
            _ => Err(ExportError::SourceDateEpoch(text)),
        },
        Err(std::env::VarError::NotUnicode(text)) => {
            Err(ExportError::SourceDateEpoch(text.to_string_lossy().into_owned()))
        }
    }
}

/// The UTC calendar time of `epoch` seconds since 1970-01-01: (year, month, day, hour,
/// minute, second).
pub fn utc_time(epoch: u64) -> (u64, u64, u64, u64, u64, u64) {
    let leap = |y: u64| (y.is_multiple_of(4) && !y.is_multiple_of(100)) || y.is_multiple_of(400);
    let mut days = epoch / 86_400;
    let secs = epoch % 86_400;
    let mut year = 1970;
    loop {
        let in_year = if leap(year) { 366 } else { 365 };
        if days < in_year {
            break;
        }
        days -= in_year;
        year += 1;
    }
    let mut month = 1;
    for length in [
        31,
        if leap(year) { 29 } else { 28 },
        31,
        30,
        31,
        30,
        31,
        31,
        30,
        31,
        30,
        31,
    ] {
        if days < length {
            break;
        }
        days -= length;
        month += 1;
    }
    (year, month, days + 1, secs / 3600, secs % 3600 / 60, secs % 60)
}

/// `epoch` as an `xs:dateTime` in UTC, e.g. `1980-01-01T00:00:00Z`.
pub fn format_utc(epoch: u64) -> String {
    let (y, mo, d, h, mi, s) = utc_time(epoch);
    format!("{y:04}-{mo:02}-{d:02}T{h:02}:{mi:02}:{s:02}Z")
}

/// The root element's attributes: `fmiVersion`, `modelName`, the identity (FMI 2.0's `guid`,
/// FMI 3.0's `instantiationToken`: the same value), the scene's metadata, the tool and date.
fn root_attributes(
    scene: &Scene,
    scene_text: &str,
    version: Version,
    generated: Option<&str>,
) -> Vec<(&'static str, String)> {
    let m = &scene.model;
    let token = match version {
        Version::Fmi2 => "guid",
        Version::Fmi3 => "instantiationToken",
    };
    let mut root = vec![
        ("fmiVersion", version.number().to_string()),
        ("modelName", m.name.clone()),
        (token, guid(scene_text)),
    ];
    for (key, value) in [
        ("description", &m.description),
        ("author", &m.author),
        ("version", &m.version),
        ("copyright", &m.copyright),
        ("license", &m.license),
    ] {
        if !value.is_empty() {
            root.push((key, value.clone()));
        }
    }
    root.push(("generationTool", format!("contact-fmu {VERSION}")));
    if let Some(date) = generated {
        root.push(("generationDateAndTime", date.to_string()));
    }
    root.push(("variableNamingConvention", "structured".to_string()));
    root
}

/// A new document with its XML declaration.
fn xml_writer() -> io::Result<Writer<Vec<u8>>> {
    let mut w = Writer::new_with_indent(Vec::new(), b' ', 2);
    w.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))?;
    Ok(w)
}

/// `UnitDefinitions` (the same in FMI 2.0 and 3.0): the units the table uses, with their base
/// units and display units.
fn write_units(w: &mut Writer<Vec<u8>>, table: &VariableTable) -> io::Result<()> {
    let units = used_units(table);
    if units.is_empty() {
        return Ok(());
    }
    w.create_element("UnitDefinitions").write_inner_content(|w| {
        for unit in units {
            let mut base: Vec<(&str, String)> = Vec::new();
            for (attr, e) in ["kg", "m", "s", "rad"].into_iter().zip(unit.base) {
                if e != 0 {
                    base.push((attr, e.to_string()));
                }
            }
            w.create_element("Unit")
                .with_attributes(attrs([("name", unit.name)]))
                .write_inner_content(|w| {
                    w.create_element("BaseUnit")
                        .with_attributes(attrs(base.iter().map(|(a, v)| (*a, v.as_str()))))
                        .write_empty()?;
                    for (name, factor) in unit.display {
                        let factor = format_real(*factor);
                        w.create_element("DisplayUnit")
                            .with_attributes(attrs([("name", *name), ("factor", factor.as_str())]))
                            .write_empty()?;
                    }
                    Ok(())
                })?;
        }
        Ok(())
    })?;
    Ok(())
}

/// `TypeDefinitions`: the enumerations the table uses, with their items (FMI 2.0:
/// `SimpleType/Enumeration/Item`, FMI 3.0: `EnumerationType/Item`).
fn write_type_definitions(w: &mut Writer<Vec<u8>>, table: &VariableTable, version: Version) -> io::Result<()> {
    let enums = used_enums(table);
    if enums.is_empty() {
        return Ok(());
    }
    w.create_element("TypeDefinitions").write_inner_content(|w| {
        for e in enums {
            let items = |w: &mut Writer<Vec<u8>>| -> io::Result<()> {
                for (name, value) in e.items() {
                    let value = value.to_string();
                    w.create_element("Item")
                        .with_attributes(attrs([("name", name), ("value", value.as_str())]))
                        .write_empty()?;
                }
                Ok(())
            };
            let tag = match version {
                Version::Fmi2 => "SimpleType",
                Version::Fmi3 => "EnumerationType",
            };
            w.create_element(tag)
                .with_attributes(attrs([("name", e.type_name())]))
                .write_inner_content(|w| match version {
                    Version::Fmi2 => w.create_element("Enumeration").write_inner_content(items).map(|_| ()),
                    Version::Fmi3 => items(w),
                })?;
        }
        Ok(())
    })?;
    Ok(())
}

/// `LogCategories` and `DefaultExperiment` (the same in FMI 2.0 and 3.0 but for the version
/// named in the categories' descriptions).
fn write_categories_and_experiment(w: &mut Writer<Vec<u8>>, scene: &Scene, version: Version) -> io::Result<()> {
    w.create_element("LogCategories").write_inner_content(|w| {
        for (name, description) in LOG_CATEGORIES {
            let name = name.to_str().unwrap_or_default();
            let description = description.replace("fmi2", version.prefix());
            w.create_element("Category")
                .with_attributes(attrs([("name", name), ("description", description.as_str())]))
                .write_empty()?;
        }
        Ok(())
    })?;
    let stop = format_real(scene.model.stop_time);
    let tolerance = format_real(scene.solver.rtol);
    let step = format_real(scene.model.interval);
    w.create_element("DefaultExperiment")
        .with_attributes(attrs([
            ("startTime", "0"),
            ("stopTime", stop.as_str()),
            ("tolerance", tolerance.as_str()),
            ("stepSize", step.as_str()),
        ]))
        .write_empty()?;
    Ok(())
}

fn write_model_description(scene: &Scene, scene_text: &str, generated: Option<&str>) -> io::Result<Vec<u8>> {
    let table = VariableTable::from_scene(scene);
    let m = &scene.model;
    let mut w = xml_writer()?;
    w.create_element("fmiModelDescription")
        .with_attributes(attrs(root_attributes(scene, scene_text, Version::Fmi2, generated)))
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
            write_units(w, &table)?;
            write_type_definitions(w, &table, Version::Fmi2)?;
            write_categories_and_experiment(w, scene, Version::Fmi2)?;
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
                        for &i in list {
                            let index = i.to_string();
                            let mut a = vec![("index", index)];
                            // Outputs state their direct dependencies (often none); initial
                            // unknowns keep FMI's default (they may depend on every parameter).
                            if tag == "Outputs" {
                                let deps: Vec<String> = output_dependencies(&table, i - 1)
                                    .iter()
                                    .map(|d| d.to_string())
                                    .collect();
                                a.push(("dependencies", deps.join(" ")));
                            }
                            w.create_element("Unknown")
                                .with_attributes(attrs(a.iter().map(|(k, v)| (*k, v.as_str()))))
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
    attributes.push(("causality", v.causality.name()));
    attributes.push(("variability", v.variability.name()));
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
                    if let Some(d) = v.display_unit {
                        a.push(("displayUnit", d.to_string()));
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
                    if v.causality == Causality::Parameter {
                        a.extend(range_attributes(v.range));
                    }
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
pub fn documentation_html(scene: &Scene, version: Version) -> String {
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
        "<p>FMI {} Co-Simulation FMU generated by contact-fmu {VERSION}. Default experiment: stop time {} s, communication step {} s, relative tolerance {}. The scene is in <code>resources/scene.toml</code>.</p>\n",
        version.number(),
        format_real(m.stop_time),
        format_real(m.interval),
        format_real(scene.solver.rtol)
    ));
    h.push_str(&format!(
        "<p>Version {}; author: {}; {}; license: {}.</p>\n",
        escape_html(&m.version),
        escape_html(&m.author),
        escape_html(&m.copyright),
        escape_html(&m.license)
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
            v.causality.name(),
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
    trial.initialize(0.0).map_err(|e| ExportError::Model {
        path: scene_path.to_path_buf(),
        message: e.to_string(),
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
