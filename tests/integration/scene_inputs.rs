//! Every scene input is checked (docs/scene.md, "Rules for names and numbers"): names that an
//! FMI structured variable name and XML can carry, descriptions without control characters, a
//! model name usable as modelIdentifier and file name, every number finite and of a sane
//! magnitude, tolerances where results mean something, and a host's parameter values that a
//! contact cannot take. Each bad input gets one error naming the file, the item and the field
//! — never a hang, a panic or a broken FMU. And compilation is linear in the number of bodies.

use crate::common::{self, run_command};
use contact_fmu::compile::compile;
use contact_fmu::export::model_description_xml;
use contact_fmu::scene::{Scene, SceneError};
use contact_fmu::simulation::{SimError, Simulation};
use contact_fmu::variables::VariableTable;
use std::path::PathBuf;
use std::time::Instant;

const ORIGIN: &str = "inputs.toml";

/// A valid scene that holds every key with a number (each contact type, a spring, an input),
/// so that the sweeps below can spoil each number in turn.
const GOOD: &str = include_str!("scenes/inputs.toml");

/// The error of a scene: from parsing and validation, or else from compilation at
/// initialisation. Fails the test when the scene is accepted.
fn error_of(text: &str) -> SceneError {
    match Simulation::from_scene_str(text, ORIGIN) {
        Err(e) => e,
        Ok(mut s) => error_at_initialization(&mut s),
    }
}

/// The scene error with which the scene `text` refuses to initialise once the parameter `name`
/// is set to `value`.
fn error_with_parameter(text: &str, name: &str, value: f64) -> SceneError {
    let mut s = Simulation::from_scene_str(text, ORIGIN).unwrap();
    s.set_by_name(name, value).unwrap();
    let e = error_at_initialization(&mut s);
    eprintln!("{e}");
    e
}

/// The scene error with which `s` refuses to initialise. Fails the test when it initialises
/// or fails otherwise.
fn error_at_initialization(s: &mut Simulation) -> SceneError {
    match s.initialize(0.0) {
        Err(SimError::Scene(e)) => e,
        Err(e) => panic!("not a scene error: {e}"),
        Ok(()) => panic!("scene accepted"),
    }
}

/// Asserts that the scene is refused with an error naming the file, `item` (a fragment of
/// it) and `field`, in one line, with every fragment of `message`; returns the message.
fn expect(text: &str, item: &str, field: &str, message: &[&str]) -> String {
    let e = error_of(text);
    let msg = e.to_string();
    assert_eq!(e.origin, ORIGIN, "{msg}");
    assert!(e.item.contains(item), "item {:?} is not {item:?}: {msg}", e.item);
    assert_eq!(e.field, field, "{msg}");
    assert!(msg.starts_with(&format!("{ORIGIN}: ")), "{msg}");
    assert!(!msg.contains(['\n', '\r']), "message spans several lines: {msg:?}");
    for f in message {
        assert!(msg.contains(f), "message {msg:?} lacks {f:?}");
    }
    msg
}

/// `GOOD` with the first occurrence of `from` replaced by `to` (which must be there).
fn with(from: &str, to: &str) -> String {
    assert!(GOOD.contains(from), "{from:?} is not in the scene");
    GOOD.replacen(from, to, 1)
}

#[test]
fn the_reference_scene_is_valid_and_runs() {
    let mut s = Simulation::from_scene_str(GOOD, ORIGIN).unwrap();
    s.initialize(0.0).unwrap();
    s.step_to(0.02).unwrap();
}

// ---------------------------------------------------------------------------------------------
// names

/// Names that a structured FMI variable name (and fmpy's check of it) or XML cannot carry,
/// in TOML basic-string syntax, with what the message says about them.
const BAD_NAMES: &[(&str, &str)] = &[
    ("ar\\tm", "tab (U+0009)"),
    ("ar\tm", "tab (U+0009)"), // a literal tab, which TOML allows in strings
    ("ar\\u0001m", "control character U+0001"),
    ("ar\\u0000m", "control character U+0000"),
    ("ar\\u001Fm", "control character U+001F"),
    ("ar\\nm", "line feed (U+000A)"),
    ("ar\\u007Fm", "control character U+007F"),
    ("ar\\uFFFEm", "U+FFFE"),
    ("ar\\uFFFFm", "U+FFFF"),
    ("ar%m", "'%' (U+0025)"),
    ("ar m", "space (U+0020)"),
    ("ar-m", "'-' (U+002D)"),
    ("arm.x", "'.' (U+002E)"),
    ("arm[1]", "'[' (U+005B)"),
    ("ar'm", "'\\'' (U+0027)"),
    ("ar\\\"m", "'\"' (U+0022)"),
    ("ar&m", "'&' (U+0026)"),
    ("ar<m", "'<' (U+003C)"),
    ("ärm", "'ä' (U+00E4)"),
    ("2arm", "starts with a digit"),
    ("", "must not be empty"),
];

#[test]
fn a_name_that_fmi_or_xml_cannot_carry_is_refused_for_every_kind_of_item() {
    // (the line that names the item, its kind in messages)
    let items = [
        ("name = \"steel\"", "material"),
        ("name = \"arm\"", "body"),
        ("name = \"pivot\"", "joint"),
        ("name = \"spring\"", "spring_damper"),
        ("name = \"tip_wall\"", "contact"),
        ("name = \"push\"", "input"),
    ];
    for (line, kind) in items {
        for (bad, says) in BAD_NAMES {
            let text = with(line, &format!("name = \"{bad}\""));
            let msg = expect(&text, kind, "name", &[says, "letter or '_'"]);
            if *bad == "ar\\tm" {
                eprintln!("{msg}");
            }
        }
    }
}

#[test]
fn tab_control_character_and_percent_in_a_body_or_contact_name() {
    // the cases a fuzzer found
    for (line, kind) in [("name = \"tip\"", "body \"ti"), ("name = \"tip_wall\"", "contact \"ti")] {
        let tip = line.trim_start_matches("name = \"").trim_end_matches('"');
        for (bad, escaped, says) in [
            ("\\t", "\\t", "tab (U+0009)"),
            ("\\u0007", "\\u{7}", "U+0007"),
            ("%", "%", "'%'"),
        ] {
            let msg = expect(
                &with(line, &format!("name = \"{tip}{bad}x\"")),
                kind,
                "name",
                &[says, &format!("\"{tip}{escaped}x\"")],
            );
            eprintln!("{msg}");
        }
    }
}

#[test]
fn names_made_of_letters_digits_and_underscores_are_accepted() {
    let text = GOOD
        .replace("\"arm\"", "\"_Arm_2\"")
        .replace("\"pivot\"", "\"pivot_0\"")
        .replace("\"tip_wall\"", "\"TIP_WALL_1\"");
    let mut s = Simulation::from_scene_str(&text, ORIGIN).unwrap();
    s.initialize(0.0).unwrap();
    assert!(s.table().index_of("_Arm_2.r[1]").is_some());
    assert!(s.table().index_of("TIP_WALL_1.law").is_some());
}

#[test]
fn control_characters_in_the_description_are_refused() {
    for (bad, says) in [
        ("\\u0001", "U+0001"),
        ("\\t", "tab (U+0009)"),
        ("\\n", "line feed (U+000A)"),
        ("\\r", "carriage return (U+000D)"),
        ("\\u007F", "U+007F"),
        ("\\u0085", "U+0085"),
        ("\\uFFFE", "U+FFFE"),
        ("\\uFFFF", "U+FFFF"),
    ] {
        let text = with(
            "description = \"a pendulum",
            &format!("description = \"a{bad} pendulum"),
        );
        let msg = expect(&text, "[model]", "description", &[says, "character 2 is"]);
        eprintln!("{msg}");
    }
    // a multi-line string holds line feeds
    let text = with(
        "description = \"a pendulum that can hit a wall, a rail and a ball\"",
        "description = \"\"\"two\nlines\"\"\"",
    );
    expect(&text, "[model]", "description", &["line feed"]);
    // any other text is fine, including XML's special characters and non-ASCII letters
    let text = with(
        "description = \"a pendulum",
        "description = \"<Pendel> & \\\"Kugel\\\" — 'ü' % a pendulum",
    );
    let scene = Scene::from_str(&text, ORIGIN).unwrap();
    let xml = model_description_xml(&scene, &text);
    assert!(xml.contains("description=\"&lt;Pendel> &amp; &quot;Kugel&quot; — 'ü' % a pendulum"));
}

#[test]
fn a_model_name_of_255_characters_is_refused_and_one_of_200_accepted() {
    let long = "m".repeat(255);
    let msg = expect(
        &with("name = \"inputs\"", &format!("name = \"{long}\"")),
        "[model]",
        "name",
        &["255 characters", "at most 200 are allowed"],
    );
    eprintln!("{msg}");
    assert!(msg.len() < 400, "the message repeats the whole name: {msg}");
    let name = format!("m{}", "0".repeat(199));
    let scene = Scene::from_str(&with("name = \"inputs\"", &format!("name = \"{name}\"")), ORIGIN).unwrap();
    assert_eq!(scene.model.name, name);
}

#[test]
fn a_model_name_that_is_no_c_identifier_or_file_name_is_refused() {
    for (bad, says) in [
        ("in-puts", "'-'"),
        ("in puts", "space"),
        ("in\\tputs", "tab"),
        ("in%puts", "'%'"),
        ("in.puts", "'.'"),
        ("in/puts", "'/'"),
        ("in\\\\puts", "'\\\\'"),
        ("2inputs", "starts with a digit"),
        ("", "must not be empty"),
        ("nul", "device name"),
        ("CON", "device name"),
        ("Com1", "device name"),
    ] {
        let text = with("name = \"inputs\"", &format!("name = \"{bad}\""));
        let msg = expect(&text, "[model]", "name", &[says, "C identifier"]);
        eprintln!("{msg}");
    }
}

#[test]
fn a_long_name_is_shortened_in_messages() {
    // a valid but very long body name, with an error in a later field
    let name = "b".repeat(10_000);
    let text = with("name = \"arm\"\nmass = 1.0", &format!("name = \"{name}\"\nmass = -1.0"));
    let msg = expect(
        &text,
        "body \"bbbb",
        "mass",
        &["must be > 0 (got -1)", "(10000 characters)"],
    );
    assert!(msg.len() < 300, "{msg}");
}

// ---------------------------------------------------------------------------------------------
// numbers

/// Every number of `GOOD` as (line index, key, byte range of the number in the line).
fn numbers() -> Vec<(usize, String, std::ops::Range<usize>)> {
    let mut out = Vec::new();
    for (i, line) in GOOD.lines().enumerate() {
        let Some((key, value)) = line.split_once(" = ") else {
            continue;
        };
        if value.starts_with('"') {
            continue;
        }
        let offset = key.len() + 3;
        let b = value.as_bytes();
        let mut k = 0;
        while k < b.len() {
            let starts = b[k].is_ascii_digit() || (b[k] == b'-' && b.get(k + 1).is_some_and(u8::is_ascii_digit));
            if starts {
                let end = (k + 1..b.len())
                    .find(|&e| !(b[e].is_ascii_alphanumeric() || matches!(b[e], b'.' | b'-' | b'+')))
                    .unwrap_or(b.len());
                out.push((i, key.trim().to_string(), offset + k..offset + end));
                k = end;
            } else {
                k += 1;
            }
        }
    }
    out
}

/// `GOOD` with one number replaced.
fn spoil(line: usize, range: &std::ops::Range<usize>, by: &str) -> String {
    let mut lines: Vec<String> = GOOD.lines().map(str::to_string).collect();
    lines[line].replace_range(range.clone(), by);
    lines.join("\n")
}

/// The keys of coordinates, lengths and directions (bounded by 1e12 in magnitude).
const BOUNDED_KEYS: &[&str] = &[
    "gravity",
    "position",
    "velocity",
    "angular_velocity",
    "anchor",
    "axis",
    "point_a",
    "point_b",
    "free_length",
    "center",
    "radius",
    "origin",
    "normal",
    "u_axis",
    "size",
    "max_penetration",
    "axis_point",
    "cylinder_radius",
    "length",
    "theta_range",
    "ref_axis",
    "other_center",
    "other_radius",
    "direction",
];

/// The other keys with numbers.
const OTHER_NUMBER_KEYS: &[&str] = &[
    "stop_time",
    "interval",
    "rtol",
    "atol",
    "max_step",
    "youngs_modulus",
    "poisson_ratio",
    "mass",
    "inertia",
    "orientation",
    "stiffness",
    "damping",
    "restitution",
    "exponent",
    "min_impact_velocity",
    "start",
];

#[test]
fn nan_or_infinity_in_any_number_is_refused_naming_its_field() {
    let numbers = numbers();
    assert!(numbers.len() > 90, "only {} numbers found", numbers.len());
    let mut keys: Vec<&str> = numbers.iter().map(|(_, k, _)| k.as_str()).collect();
    keys.dedup();
    for key in BOUNDED_KEYS.iter().chain(OTHER_NUMBER_KEYS) {
        assert!(keys.contains(key), "the sweep misses {key}");
    }
    for (line, key, range) in &numbers {
        for by in ["nan", "inf", "-inf"] {
            let text = spoil(*line, range, by);
            let e = Scene::from_str(&text, ORIGIN).expect_err(&format!("{key} = {by} accepted"));
            let msg = e.to_string();
            assert_eq!(e.field, *key, "{msg}");
            assert_eq!(e.origin, ORIGIN, "{msg}");
            assert!(!e.item.is_empty() && !msg.contains('\n'), "{msg}");
        }
    }
}

#[test]
fn absurdly_large_coordinates_lengths_and_directions_are_refused() {
    let mut seen = std::collections::HashSet::new();
    for (line, key, range) in numbers() {
        if !BOUNDED_KEYS.contains(&key.as_str()) {
            continue;
        }
        seen.insert(key.clone());
        for by in ["1e300", "-1e300", "1.000001e12"] {
            let text = spoil(line, &range, by);
            let e = Scene::from_str(&text, ORIGIN).expect_err(&format!("{key} = {by} accepted"));
            assert_eq!(e.field, key, "{e}");
        }
        // the bound itself is accepted (for speeds the tighter one the engine takes for a
        // blow-up, 1e8: 1e12 is refused there by that rule)
        let bound = if ["velocity", "angular_velocity"].contains(&key.as_str()) {
            let e = Scene::from_str(&spoil(line, &range, "1e12"), ORIGIN).expect_err(&format!("{key} = 1e12 accepted"));
            assert!(e.field == key && e.to_string().contains("beyond 1e8"), "{e}");
            "1e8"
        } else {
            "1e12"
        };
        Scene::from_str(&spoil(line, &range, bound), ORIGIN)
            .map(drop)
            .or_else(|e| {
                // only geometry that needs other relations (perpendicular axes, min < max) may
                // refuse the bound itself
                if ["normal", "u_axis", "ref_axis", "axis", "theta_range", "direction"].contains(&key.as_str()) {
                    Ok(())
                } else {
                    Err(e)
                }
            })
            .unwrap_or_else(|e| panic!("{key} = {bound} refused: {e}"));
    }
    assert_eq!(seen.len(), BOUNDED_KEYS.len());
}

/// Asserts that each value of `values` written at `{}` in `to` (which replaces `from`) is refused
/// naming `item` and `field`, with `says` in the message.
fn expect_each_refused(cases: &[(&str, &str, &str, &str, &str)], values: &[&str]) {
    for (from, to, item, field, says) in cases {
        for by in values {
            let msg = expect(&with(from, &to.replace("{}", by)), item, field, &[says]);
            eprintln!("{msg}");
        }
    }
}

#[test]
fn nan_and_infinite_plane_origin_and_size() {
    #[rustfmt::skip]
    let cases = [
        ("origin = [0.5, 0.0, -1.0]", "origin = [0.5, {}, -1.0]", "contact \"tip_wall\"", "origin", "must be finite"),
        ("size = [1.0, 1.0]", "size = [1.0, {}]", "contact \"tip_wall\"", "size", "finite"),
    ];
    expect_each_refused(&cases, &["nan", "inf", "-inf"]);
}

#[test]
fn non_finite_spring_point_is_refused_before_the_run() {
    #[rustfmt::skip]
    let cases = [
        ("point_b = [0.0, 0.0, -1.0]", "point_b = [0.0, {}, -1.0]", "spring_damper \"spring\"", "point_b", "must be finite"),
    ];
    expect_each_refused(&cases, &["nan", "inf"]);
}

#[test]
fn joint_axis_of_1e300_is_refused_instead_of_spinning() {
    let msg = expect(
        &with("axis = [0.0, 1.0, 0.0]", "axis = [0.0, 1e300, 0.0]"),
        "joint \"pivot\"",
        "axis",
        &["1e300", "at most 1e12"],
    );
    eprintln!("{msg}");
    // a tiny axis is a zero axis, not a NaN direction
    expect(
        &with("axis = [0.0, 1.0, 0.0]", "axis = [0.0, 1e-300, 0.0]"),
        "joint \"pivot\"",
        "axis",
        &["zero vector"],
    );
    // an axis on a fixed joint (used when it closes a loop) is checked too
    expect(
        &with("type = \"fixed\"", "type = \"fixed\"\naxis = [nan, 0.0, 1.0]"),
        "joint \"weld\"",
        "axis",
        &["finite"],
    );
}

#[test]
fn tolerances_where_results_mean_nothing_are_refused_in_the_scene() {
    for (from, to, field, says) in [
        ("rtol = 1e-8", "rtol = 0.5", "rtol", "[1e-14, 0.01] (got 0.5)"),
        ("rtol = 1e-8", "rtol = 0.011", "rtol", "(got 0.011)"),
        ("rtol = 1e-8", "rtol = 1e-15", "rtol", "(got 1e-15)"),
        ("rtol = 1e-8", "rtol = 0.0", "rtol", "(got 0)"),
        ("atol = 1e-10", "atol = 0.1", "atol", "[1e-20, 0.01] (got 0.1)"),
        ("atol = 1e-10", "atol = 1e-300", "atol", "[1e-20, 0.01]"),
        ("atol = 1e-10", "atol = -1.0", "atol", "[1e-20, 0.01]"),
        ("max_step = 1e-3", "max_step = 1e-10", "max_step", ">= 1e-9 s"),
        ("max_step = 1e-3", "max_step = 1e-300", "max_step", ">= 1e-9 s"),
        ("max_step = 1e-3", "max_step = -1.0", "max_step", ">= 1e-9 s"),
    ] {
        let msg = expect(&with(from, to), "[solver]", field, &[says]);
        eprintln!("{msg}");
    }
    // the bounds themselves are accepted
    for (from, to) in [
        ("rtol = 1e-8", "rtol = 1e-2"),
        ("rtol = 1e-8", "rtol = 1e-14"),
        ("atol = 1e-10", "atol = 1e-2"),
        ("atol = 1e-10", "atol = 1e-20"),
        ("max_step = 1e-3", "max_step = 1e-9"),
        // 0: no largest step (the default)
        ("max_step = 1e-3", "max_step = 0.0"),
    ] {
        Scene::from_str(&with(from, to), ORIGIN).unwrap_or_else(|e| panic!("{to}: {e}"));
    }
    // a default experiment with more than 1e9 communication points never ends
    expect(
        &with("interval = 0.01", "interval = 1e-12"),
        "[model]",
        "interval",
        &["communication points"],
    );
}

#[test]
fn tolerances_where_results_mean_nothing_are_refused_as_fmu_parameters() {
    for (name, value, range) in [
        ("solver.rtol", 0.5, "[1e-14, 0.01]"),
        ("solver.rtol", 1e-15, "[1e-14, 0.01]"),
        ("solver.atol", 1.0, "[1e-20, 0.01]"),
        ("solver.max_step", 1e-12, "0 (none) or finite and >= 1e-9 s"),
    ] {
        let mut s = Simulation::from_scene_str(GOOD, ORIGIN).unwrap();
        s.set_by_name(name, value).unwrap();
        let msg = s.initialize(0.0).unwrap_err().to_string();
        eprintln!("{msg}");
        assert!(msg.contains(name) && msg.contains(range), "{msg}");
    }
    // and the ranges are in the model description (min/max attributes)
    let table = VariableTable::from_scene(&Scene::from_str(GOOD, ORIGIN).unwrap());
    let range = |n: &str| table.vars[table.index_of(n).unwrap()].range.unwrap();
    assert_eq!((range("solver.rtol").min, range("solver.rtol").max), (1e-14, 1e-2));
    assert_eq!((range("solver.atol").min, range("solver.atol").max), (1e-20, 1e-2));
    // 0 means none; between 0 and 1e-9 the compilation refuses it (above)
    assert_eq!(range("solver.max_step").min, 0.0);
    let xml = model_description_xml(&Scene::from_str(GOOD, ORIGIN).unwrap(), GOOD);
    assert!(
        xml.contains("<Real min=\"1e-14\" max=\"0.01\" start=\"1e-8\"/>"),
        "{xml}"
    );
}

// ---------------------------------------------------------------------------------------------
// parameters a contact cannot take

#[test]
fn kelvin_voigt_chosen_by_parameter_without_a_stiffness_names_the_parameter_and_the_way_out() {
    // tip_wall has no stiffness key: its stiffness is a calculated parameter (Hertz)
    let s = Simulation::from_scene_str(GOOD, ORIGIN).unwrap();
    let stiffness = s.table().index_of("tip_wall.stiffness").unwrap();
    assert_eq!(
        s.variables()[stiffness].causality,
        contact_fmu::variables::Causality::CalculatedParameter
    );
    let e = error_with_parameter(GOOD, "tip_wall.law", 1.0);
    let msg = e.to_string();
    assert_eq!(
        (e.origin.as_str(), e.item.as_str(), e.field.as_str()),
        (ORIGIN, "contact \"tip_wall\"", "law")
    );
    for f in [
        "parameter \"tip_wall.law\" = 1 (kelvin_voigt)",
        "\"tip_wall.stiffness\" is a calculated parameter",
        "hertz = 2",
        "impulse = 6",
        "add stiffness",
        "export the FMU again",
    ] {
        assert!(msg.contains(f), "{msg:?} lacks {f:?}");
    }
    assert!(!msg.contains("kelvin_voigt = 1"), "kelvin_voigt is no way out: {msg}");
    // the message is the same through the command line
    let path = temp_scene("kelvin_voigt.toml", GOOD);
    let (ok, err) = run_command(&[
        "simulate",
        path.to_str().unwrap(),
        "--quiet",
        "--set",
        "tip_wall.law=kelvin_voigt",
    ]);
    assert!(!ok);
    assert!(err.contains("parameter \"tip_wall.law\" = 1 (kelvin_voigt)"), "{err}");
    // another law resets nothing: the instance initialises with it
    let mut s = Simulation::from_scene_str(GOOD, ORIGIN).unwrap();
    s.set_by_name("tip_wall.law", 2.0).unwrap();
    s.initialize(0.0).unwrap();
}

#[test]
fn flores_chosen_by_parameter_with_zero_restitution_names_the_parameter() {
    let e = error_with_parameter(&with("restitution = 0.8", "restitution = 0.0"), "tip_wall.law", 5.0);
    assert_eq!(e.field, "law");
    assert!(e.message.contains("\"tip_wall.law\" = 5 (flores)") && e.message.contains("restitution"));
    // and the other way round: the scene's law is flores, the host sets e = 0
    let e = error_with_parameter(
        &with("law = \"hertz_ln\"", "law = \"flores\""),
        "tip_wall.restitution",
        0.0,
    );
    assert_eq!(e.field, "restitution");
    assert!(e.message.contains("\"tip_wall.restitution\" = 0"));
}

// ---------------------------------------------------------------------------------------------
// the command line

fn temp_scene(name: &str, text: &str) -> PathBuf {
    common::temp_scene("scene_inputs", name, text)
}

#[test]
fn command_line_gives_one_line_and_a_failure_status_for_each_case() {
    let long = format!("name = \"{}\"", "m".repeat(255));
    // (file, line in GOOD, what replaces it, fragments of the message)
    #[rustfmt::skip]
    let cases: [(&str, &str, &str, &[&str]); 10] = [
        ("tab.toml", "name = \"tip\"", "name = \"ti\\tp\"", &["body \"ti\\tp\": name:", "tab"]),
        ("bell.toml", "name = \"tip_wall\"", "name = \"tip\\u0007wall\"", &["contact \"tip\\u{7}wall\": name:"]),
        ("percent.toml", "name = \"tip_wall\"", "name = \"tip%wall\"", &["contact \"tip%wall\": name:", "'%'"]),
        ("description.toml", "description = \"a", "description = \"\\u0001a", &["[model]: description:", "character 1 is the control character U+0001"]),
        ("long.toml", "name = \"inputs\"", &long, &["[model]: name:", "255 characters"]),
        ("origin.toml", "origin = [0.5, 0.0, -1.0]", "origin = [nan, 0.0, -1.0]", &["contact \"tip_wall\": origin:"]),
        ("size.toml", "size = [1.0, 1.0]", "size = [inf, 1.0]", &["contact \"tip_wall\": size:"]),
        ("spring.toml", "point_a = [0.0, 0.0, -2.0]", "point_a = [0.0, nan, -2.0]", &["spring_damper \"spring\": point_a:"]),
        ("axis.toml", "axis = [0.0, 1.0, 0.0]", "axis = [0.0, 1e300, 0.0]", &["joint \"pivot\": axis:", "at most 1e12"]),
        ("rtol.toml", "rtol = 1e-8", "rtol = 0.5", &["[solver]: rtol:", "(got 0.5)"]),
    ];
    for (file, from, to, fragments) in cases {
        let p = temp_scene(file, &with(from, to));
        for command in ["simulate", "export"] {
            let out = p.with_extension("fmu");
            let args: Vec<&str> = match command {
                "simulate" => vec!["simulate", p.to_str().unwrap(), "--quiet"],
                _ => vec!["export", p.to_str().unwrap(), "-o", out.to_str().unwrap()],
            };
            common::assert_refused_in_one_line(&format!("{command} {file}"), &p, run_command(&args), fragments);
            assert!(!out.exists(), "{file}: a refused scene left an FMU behind");
        }
    }
    // --set with a range error: the parameter is named
    let p = temp_scene("good.toml", GOOD);
    let (ok, err) = run_command(&["simulate", p.to_str().unwrap(), "--quiet", "--set", "solver.rtol=0.5"]);
    assert!(
        !ok && err.contains("solver.rtol") && err.contains("[1e-14, 0.01]"),
        "{err}"
    );
}

#[test]
fn a_model_name_of_200_characters_exports_a_complete_fmu() {
    let name = format!("m{}", "_".repeat(199));
    let text = with("name = \"inputs\"", &format!("name = \"{name}\""));
    let p = temp_scene("long_name.toml", &text);
    let out = p.with_file_name(format!("{name}.fmu"));
    // a stand-in library (this test is about the names, not the library)
    let library = p.with_file_name("stand-in.so");
    std::fs::write(&library, "not a real library").unwrap();
    let (ok, err) = common::export_linux64_with(&p, &out, &library);
    assert!(ok, "{err}");
    let mut zip = zip::ZipArchive::new(std::fs::File::open(&out).unwrap()).unwrap();
    let entries: Vec<String> = zip.file_names().map(str::to_string).collect();
    assert!(
        entries
            .iter()
            .any(|e| e.starts_with("binaries/") && e.contains(&format!("/{name}."))),
        "{entries:?}"
    );
    let mut xml = String::new();
    std::io::Read::read_to_string(&mut zip.by_name("modelDescription.xml").unwrap(), &mut xml).unwrap();
    assert!(xml.contains(&format!("modelIdentifier=\"{name}\"")));
    std::fs::remove_file(&out).unwrap();
}

// ---------------------------------------------------------------------------------------------
// compilation is linear in the number of bodies

/// A chain of `n` links joined by revolute joints, written the way a user would (links in
/// order, joints naming parent and child).
fn chain(n: usize) -> String {
    use std::fmt::Write;
    let mut s = String::from("[model]\nname = \"chain\"\nstop_time = 0.001\ninterval = 0.001\n\n");
    for i in 0..n {
        let x = 0.1 * (i + 1) as f64;
        write!(
            s,
            "[[body]]\nname = \"link{i}\"\nmass = 1.0\ninertia = [0.001, 0.01, 0.01]\nposition = [{x:?}, 0.0, 0.0]\n\n"
        )
        .unwrap();
    }
    for i in 0..n {
        let parent = if i == 0 {
            "ground".to_string()
        } else {
            format!("link{}", i - 1)
        };
        let x = 0.1 * i as f64 + 0.05;
        write!(
            s,
            "[[joint]]\nname = \"hinge{i}\"\ntype = \"revolute\"\nparent = \"{parent}\"\nchild = \"link{i}\"\n\
             anchor = [{x:?}, 0.0, 0.0]\naxis = [0.0, 1.0, 0.0]\n\n"
        )
        .unwrap();
    }
    s
}

#[test]
fn a_chain_of_20000_links_compiles() {
    let n = 20_000;
    let text = chain(n);
    let t0 = Instant::now();
    let scene = Scene::from_str(&text, "chain.toml").unwrap();
    let t1 = Instant::now();
    let (model, data) = compile(&scene, "chain.toml").unwrap();
    let t2 = Instant::now();
    assert_eq!((model.bodies.len(), model.nv, model.trees.len()), (n, n, 1));
    // the last link hangs from the one before it
    let last = &model.joints[model.bodies[n - 1].joint];
    assert_eq!(last.parent, Some(n - 2));
    assert!(data.state.iter().all(|x| x.is_finite()));
    drop((model, data));
    let t3 = Instant::now();
    let xml = model_description_xml(&scene, &text);
    let t4 = Instant::now();
    assert!(xml.contains(&format!("link{}.r[3]", n - 1)));
    // timing for the record, not asserted (docs/scene.md): seconds, not minutes
    println!(
        "chain of {n} links: parse + validate {:.3} s, compile {:.3} s, model description {:.3} s",
        (t1 - t0).as_secs_f64(),
        (t2 - t1).as_secs_f64(),
        (t4 - t3).as_secs_f64()
    );
    // and it starts: the initial state is evaluated
    let mut s = Simulation::new(scene, "chain.toml");
    s.initialize(0.0).unwrap();
    println!(
        "chain of {n} links: initialised after {:.3} s in all",
        t0.elapsed().as_secs_f64()
    );
}

#[test]
fn a_joint_cycle_in_a_long_chain_is_found_in_linear_time() {
    // the first link hangs from the last: no link reaches the ground
    let n = 5_000;
    let text = chain(n).replacen("parent = \"ground\"", &format!("parent = \"link{}\"", n - 1), 1);
    let e = error_of(&text);
    assert_eq!((e.item.as_str(), e.field.as_str()), ("body \"link0\"", "joint"), "{e}");
    assert!(
        e.message.contains("cycle") && e.message.contains("no path to ground"),
        "{e}"
    );
}
