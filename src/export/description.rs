//! The model description (`modelDescription.xml`, FMI 2.0; the FMI 3.0 one is
//! [`super::fmi3`], which shares the helpers here) and the documentation page, written from
//! the scene's variable table: metadata, units, types, variables with their ranges, the model
//! structure (outputs and their dependencies), the default experiment; the generation date.

use super::ExportError;
use crate::fmi::lifecycle::Version;
use crate::fmi::LOG_CATEGORIES;
use crate::guid::{guid, VERSION};
use crate::scene::Scene;
use crate::variables::{Causality, EnumType, Range, Unit, VarType, Variable, VariableTable, UNITS};
use quick_xml::events::attributes::Attribute;
use quick_xml::events::{BytesDecl, Event};
use quick_xml::name::QName;
use quick_xml::Writer;
use std::borrow::Cow;
use std::io;

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
pub(super) fn attrs<'k, V: AsRef<str>>(pairs: impl IntoIterator<Item = (&'k str, V)>) -> Vec<Attribute<'k>> {
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

/// Writes the empty element `<tag …/>` with the attributes `pairs` (escaped by [`attrs`]).
pub(super) fn empty<'k, V: AsRef<str>>(
    w: &mut Writer<Vec<u8>>,
    tag: &str,
    pairs: impl IntoIterator<Item = (&'k str, V)>,
) -> io::Result<()> {
    w.create_element(tag).with_attributes(attrs(pairs)).write_empty()?;
    Ok(())
}

/// Writes the element `<tag>` holding what `each` writes of every item in turn; nothing at all
/// when there are no items.
pub(super) fn write_list<T>(
    w: &mut Writer<Vec<u8>>,
    tag: &str,
    items: &[T],
    each: impl Fn(&mut Writer<Vec<u8>>, &T) -> io::Result<()>,
) -> io::Result<()> {
    if items.is_empty() {
        return Ok(());
    }
    w.create_element(tag).write_inner_content(|w| {
        for item in items {
            each(w, item)?;
        }
        Ok(())
    })?;
    Ok(())
}

/// The `initial` attribute: exact for parameters, calculated for calculated parameters and
/// for outputs without a start value, none for inputs.
pub(super) fn initial_of(v: &Variable) -> Option<&'static str> {
    match v.causality {
        Causality::Parameter => Some("exact"),
        Causality::CalculatedParameter => Some("calculated"),
        Causality::Input => None,
        Causality::Output => Some(if v.start.is_some() { "exact" } else { "calculated" }),
    }
}

/// A range in words: `> 0`, `>= 1`, `[0, 0.5)`.
pub(super) fn range_text(r: &Range) -> String {
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
pub(super) fn range_attributes(r: Option<Range>) -> Vec<(&'static str, String)> {
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
pub(super) fn used_units(table: &VariableTable) -> Vec<Unit> {
    UNITS
        .iter()
        .copied()
        .filter(|u| table.vars.iter().any(|v| v.unit == Some(u.name)))
        .collect()
}

/// The enumeration types used by the table, in declaration order.
pub(super) fn used_enums(table: &VariableTable) -> Vec<EnumType> {
    [EnumType::ContactLaw, EnumType::SolverMethod]
        .into_iter()
        .filter(|e| table.vars.iter().any(|v| v.vtype == VarType::Enumeration(*e)))
        .collect()
}

/// The 1-based indices of the variables an output depends on directly, for the
/// `dependencies` attribute of `ModelStructure/Outputs`: every input for an output that
/// depends on the inputs; for the other outputs, the inputs that move a driven joint and the
/// bodies joined to it, where the output reads them ([`VariableTable::moved_by`]; none in a
/// scene without `joint_motion` inputs) (see docs/fmi.md, "Dependencies").
pub fn output_dependencies(table: &VariableTable, output: usize) -> Vec<usize> {
    let var = &table.vars[output];
    if var.depends_on_inputs {
        return indices_where(table, |v| v.causality == Causality::Input);
    }
    // a host that sets a driven joint's coordinate or rate moves it at once, and what is
    // joined to it
    table.moved_by[output].iter().map(|&i| i + 1).collect()
}

/// The 1-based indices of `ModelStructure`: (every output, the initial unknowns).
pub fn model_structure(table: &VariableTable) -> (Vec<usize>, Vec<usize>) {
    let outputs = indices_where(table, |v| v.causality == Causality::Output);
    let initial = indices_where(table, |v| match v.causality {
        Causality::Output => matches!(initial_of(v), Some("calculated") | Some("approx")),
        Causality::CalculatedParameter => true,
        _ => false,
    });
    (outputs, initial)
}

/// The 1-based indices of the variables `keep` selects, in table order.
fn indices_where(table: &VariableTable, keep: impl Fn(&Variable) -> bool) -> Vec<usize> {
    table
        .vars
        .iter()
        .enumerate()
        .filter(|(_, v)| keep(v))
        .map(|(i, _)| i + 1)
        .collect()
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
pub(super) fn root_attributes(
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
pub(super) fn xml_writer() -> io::Result<Writer<Vec<u8>>> {
    let mut w = Writer::new_with_indent(Vec::new(), b' ', 2);
    w.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))?;
    Ok(w)
}

/// `UnitDefinitions` (the same in FMI 2.0 and 3.0): the units the table uses, with their base
/// units and display units.
pub(super) fn write_units(w: &mut Writer<Vec<u8>>, table: &VariableTable) -> io::Result<()> {
    write_list(w, "UnitDefinitions", &used_units(table), |w, unit| {
        let mut base: Vec<(&str, String)> = Vec::new();
        for (attr, e) in ["kg", "m", "s", "rad"].into_iter().zip(unit.base) {
            if e != 0 {
                base.push((attr, e.to_string()));
            }
        }
        w.create_element("Unit")
            .with_attributes(attrs([("name", unit.name)]))
            .write_inner_content(|w| {
                empty(w, "BaseUnit", base.iter().map(|(a, v)| (*a, v.as_str())))?;
                for (name, factor) in unit.display {
                    let factor = format_real(*factor);
                    empty(w, "DisplayUnit", [("name", *name), ("factor", factor.as_str())])?;
                }
                Ok(())
            })?;
        Ok(())
    })
}

/// `TypeDefinitions`: the enumerations the table uses, with their items (FMI 2.0:
/// `SimpleType/Enumeration/Item`, FMI 3.0: `EnumerationType/Item`).
pub(super) fn write_type_definitions(
    w: &mut Writer<Vec<u8>>,
    table: &VariableTable,
    version: Version,
) -> io::Result<()> {
    write_list(w, "TypeDefinitions", &used_enums(table), |w, e| {
        let items = |w: &mut Writer<Vec<u8>>| -> io::Result<()> {
            for (name, value) in e.items() {
                let value = value.to_string();
                empty(w, "Item", [("name", name), ("value", value.as_str())])?;
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
            })
            .map(|_| ())
    })
}

/// `LogCategories` and `DefaultExperiment` (the same in FMI 2.0 and 3.0 but for the version
/// named in the categories' descriptions).
pub(super) fn write_categories_and_experiment(
    w: &mut Writer<Vec<u8>>,
    scene: &Scene,
    version: Version,
) -> io::Result<()> {
    write_list(w, "LogCategories", &LOG_CATEGORIES, |w, (name, description)| {
        let name = name.to_str().unwrap_or_default();
        let description = description.replace("fmi2", version.prefix());
        empty(w, "Category", [("name", name), ("description", description.as_str())])
    })?;
    let stop = format_real(scene.model.stop_time);
    let tolerance = format_real(scene.solver.rtol);
    let step = format_real(scene.model.interval);
    empty(
        w,
        "DefaultExperiment",
        [
            ("startTime", "0"),
            ("stopTime", stop.as_str()),
            ("tolerance", tolerance.as_str()),
            ("stepSize", step.as_str()),
        ],
    )?;
    Ok(())
}

/// Writes a part of a model description that covers the whole variable table.
pub(super) type TableWriter = fn(&mut Writer<Vec<u8>>, &VariableTable) -> io::Result<()>;

/// What the model description of one FMI version writes in its own way.
pub(super) struct Layout {
    /// The FMI version.
    pub version: Version,
    /// `CoSimulation`'s attributes after `modelIdentifier`.
    pub capabilities: &'static [(&'static str, &'static str)],
    /// What `ModelVariables` holds before the table's variables (FMI 3.0: `time`).
    pub independent: Option<TableWriter>,
    /// One variable of the table, with its value reference.
    pub variable: fn(&mut Writer<Vec<u8>>, usize, &Variable) -> io::Result<()>,
    /// `ModelStructure`.
    pub structure: TableWriter,
}

/// A `modelDescription.xml` of either FMI version: the root element, `CoSimulation`, the
/// units, type definitions, log categories and default experiment, `ModelVariables` and
/// `ModelStructure`, each as `layout` writes it.
pub(super) fn write_document(
    scene: &Scene,
    scene_text: &str,
    generated: Option<&str>,
    layout: &Layout,
) -> io::Result<Vec<u8>> {
    let table = VariableTable::from_scene(scene);
    let version = layout.version;
    let mut w = xml_writer()?;
    w.create_element("fmiModelDescription")
        .with_attributes(attrs(root_attributes(scene, scene_text, version, generated)))
        .write_inner_content(|w| {
            let model_identifier = ("modelIdentifier", scene.model.name.as_str());
            empty(
                w,
                "CoSimulation",
                std::iter::once(model_identifier).chain(layout.capabilities.iter().copied()),
            )?;
            write_units(w, &table)?;
            write_type_definitions(w, &table, version)?;
            write_categories_and_experiment(w, scene, version)?;
            w.create_element("ModelVariables").write_inner_content(|w| {
                if let Some(independent) = layout.independent {
                    independent(w, &table)?;
                }
                for (vr, v) in table.vars.iter().enumerate() {
                    (layout.variable)(w, vr, v)?;
                }
                Ok(())
            })?;
            (layout.structure)(w, &table)
        })?;
    let mut out = w.into_inner();
    out.push(b'\n');
    Ok(out)
}

/// FMI 2.0's way.
const FMI2: Layout = Layout {
    version: Version::Fmi2,
    capabilities: &[
        ("canHandleVariableCommunicationStepSize", "true"),
        ("canInterpolateInputs", "false"),
        ("maxOutputDerivativeOrder", "0"),
        ("canRunAsynchronuously", "false"),
        ("canBeInstantiatedOnlyOncePerProcess", "false"),
        ("canNotUseMemoryManagementFunctions", "true"),
        ("canGetAndSetFMUstate", "true"),
        ("canSerializeFMUstate", "true"),
        ("providesDirectionalDerivative", "false"),
    ],
    independent: None,
    variable: write_variable,
    structure: write_structure,
};

pub(super) fn write_model_description(scene: &Scene, scene_text: &str, generated: Option<&str>) -> io::Result<Vec<u8>> {
    write_document(scene, scene_text, generated, &FMI2)
}

/// FMI 2.0's `ModelStructure`: the outputs, then the initial unknowns, by 1-based index.
fn write_structure(w: &mut Writer<Vec<u8>>, table: &VariableTable) -> io::Result<()> {
    let (outputs, initial) = model_structure(table);
    w.create_element("ModelStructure").write_inner_content(|w| {
        for (tag, list) in [("Outputs", &outputs), ("InitialUnknowns", &initial)] {
            write_list(w, tag, list, |w, &i| {
                let index = i.to_string();
                let mut a = vec![("index", index)];
                // Outputs state their direct dependencies (often none); initial
                // unknowns keep FMI's default (they may depend on every parameter).
                if tag == "Outputs" {
                    let deps: Vec<String> = output_dependencies(table, i - 1)
                        .iter()
                        .map(|d| d.to_string())
                        .collect();
                    a.push(("dependencies", deps.join(" ")));
                }
                empty(w, "Unknown", a.iter().map(|(k, v)| (*k, v.as_str())))
            })?;
        }
        Ok(())
    })?;
    Ok(())
}

/// The attributes both FMI versions give a variable: those of the variable (name, value
/// reference, description, causality, variability, initial) and those of its type (unit,
/// display unit, a parameter's range, start). FMI 2.0 writes the second on the type's element
/// inside the `ScalarVariable`, FMI 3.0 both on its one element. An enumeration's
/// `declaredType`, which stands in a different place in each version, is left to the caller.
pub(super) fn variable_attributes(vr: usize, v: &Variable) -> [Vec<(&'static str, String)>; 2] {
    let mut own = vec![("name", v.name.clone()), ("valueReference", vr.to_string())];
    let description = describe(v);
    if !description.is_empty() {
        own.push(("description", description));
    }
    own.push(("causality", v.causality.name().to_string()));
    own.push(("variability", v.variability.name().to_string()));
    if let Some(initial) = initial_of(v) {
        own.push(("initial", initial.to_string()));
    }
    let start = if initial_of(v) == Some("calculated") {
        None
    } else {
        v.start
    };
    let parameter = v.causality == Causality::Parameter;
    let mut typed = Vec::new();
    match v.vtype {
        VarType::Real => {
            typed.extend(v.unit.map(|u| ("unit", u.to_string())));
            typed.extend(v.display_unit.map(|d| ("displayUnit", d.to_string())));
            if parameter {
                typed.extend(range_attributes(v.range));
            }
            typed.extend(start.map(|s| ("start", format_real(s))));
        }
        VarType::Integer => {
            if parameter {
                typed.extend(range_attributes(v.range));
            }
            typed.extend(start.map(|s| ("start", format!("{}", s.round() as i64))));
        }
        VarType::Boolean => typed.extend(start.map(|s| ("start", (s != 0.0).to_string()))),
        VarType::Enumeration(_) => typed.extend(start.map(|s| ("start", format!("{}", s.round() as i64)))),
    }
    [own, typed]
}

/// One `ScalarVariable` and its type's element.
fn write_variable(w: &mut Writer<Vec<u8>>, vr: usize, v: &Variable) -> io::Result<()> {
    let [own, mut typed] = variable_attributes(vr, v);
    if let VarType::Enumeration(e) = v.vtype {
        typed.insert(0, ("declaredType", e.type_name().to_string()));
    }
    let tag = Version::Fmi2.type_element(v.vtype);
    w.create_element("ScalarVariable")
        .with_attributes(attrs(own))
        .write_inner_content(|w| empty(w, tag, typed))?;
    Ok(())
}

pub(super) fn escape_html(s: &str) -> String {
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
