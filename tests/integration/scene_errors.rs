//! Bad scenes: each one gets a message naming the file, the item and the field, and none
//! panics — through the library (parse, validate, compile) and through the command line.

use crate::common;
use contact_fmu::simulation::Simulation;
use std::path::PathBuf;

const ORIGIN: &str = "bad.toml";

/// A valid scene: a pendulum with a contact, each part replaceable by the cases below.
fn scene(model: &str, materials: &str, bodies: &str, joints: &str, contacts: &str) -> String {
    format!("{model}\n{materials}\n{bodies}\n{joints}\n{contacts}\n")
}

const MODEL: &str = "[model]\nname = \"bad\"\n";
const MATERIALS: &str = "[[material]]\nname = \"steel\"\nyoungs_modulus = 2.1e11\npoisson_ratio = 0.3\n";
const BODIES: &str = "[[body]]\nname = \"arm\"\nmass = 1.0\ninertia = [0.01, 0.02, 0.02]\nposition = [0.0, 0.0, -0.5]\n\n\
                      [[body]]\nname = \"tip\"\nmass = 0.2\ninertia = [0.001, 0.001, 0.001]\nposition = [0.0, 0.0, -1.0]\n";
const JOINTS: &str = "[[joint]]\nname = \"pivot\"\ntype = \"revolute\"\nparent = \"ground\"\nchild = \"arm\"\nanchor = [0.0, 0.0, 0.0]\naxis = [0.0, 1.0, 0.0]\n\n\
                      [[joint]]\nname = \"weld\"\ntype = \"fixed\"\nparent = \"arm\"\nchild = \"tip\"\n";
const CONTACTS: &str = "[[contact]]\nname = \"tip_wall\"\ntype = \"sphere_plane\"\nlaw = \"hertz\"\nsphere_body = \"tip\"\n\
                        center = [0.0, 0.0, -1.0]\nradius = 0.02\nsphere_material = \"steel\"\nbody = \"ground\"\nmaterial = \"steel\"\n\
                        origin = [0.5, 0.0, -1.0]\nnormal = [-1.0, 0.0, 0.0]\nu_axis = [0.0, 1.0, 0.0]\nsize = [1.0, 1.0]\n";

fn good() -> String {
    scene(MODEL, MATERIALS, BODIES, JOINTS, CONTACTS)
}

/// The error message of a scene: from parsing and validation, or else from compilation at
/// initialisation. Panics (failing the test) when the scene is accepted.
fn error_of(text: &str) -> String {
    match Simulation::from_scene_str(text, ORIGIN) {
        Err(e) => e.to_string(),
        Ok(mut s) => match s.initialize(0.0) {
            Err(e) => e.to_string(),
            Ok(()) => panic!("scene accepted:\n{text}"),
        },
    }
}

/// Asserts that the message names the file and contains every fragment.
fn expect(text: &str, fragments: &[&str]) -> String {
    let msg = error_of(text);
    assert!(msg.starts_with(ORIGIN), "message does not name the file: {msg}");
    for f in fragments {
        assert!(msg.contains(f), "message {msg:?} lacks {f:?}");
    }
    assert!(!msg.contains('\n'), "message spans several lines: {msg:?}");
    msg
}

#[test]
fn the_reference_scene_is_valid() {
    let mut s = Simulation::from_scene_str(&good(), ORIGIN).unwrap();
    s.initialize(0.0).unwrap();
    s.step_to(0.01).unwrap();
}

#[test]
fn unparsable_toml_names_the_line() {
    let text = good().replace("mass = 0.2", "mass = 0.2.1");
    let line = text.lines().position(|l| l.contains("0.2.1")).unwrap() + 1;
    let msg = expect(&text, &[&format!("line {line}"), "toml"]);
    eprintln!("{msg}");
    let msg = expect(
        &good().replace("[[joint]]\nname = \"weld\"", "[[joint]\nname = \"weld\""),
        &["line", "toml"],
    );
    eprintln!("{msg}");
    // a value of the wrong type and an unknown key are reported the same way
    expect(&good().replace("mass = 1.0", "mass = \"heavy\""), &["line", "toml"]);
    expect(
        &good().replace("mass = 1.0", "mass = 1.0\ncolour = \"red\""),
        &["line", "colour"],
    );
    expect("", &["model"]);
}

#[test]
fn unknown_body_names_joint_and_field() {
    let msg = expect(
        &good().replace("parent = \"ground\"", "parent = \"grund\""),
        &["joint \"pivot\"", "parent", "unknown body \"grund\""],
    );
    eprintln!("{msg}");
    expect(
        &good().replace("child = \"tip\"", "child = \"tap\""),
        &["joint \"weld\"", "child", "unknown body"],
    );
    expect(
        &good().replace("sphere_body = \"tip\"", "sphere_body = \"top\""),
        &["contact \"tip_wall\"", "sphere_body", "unknown body"],
    );
}

#[test]
fn duplicate_name_is_reported() {
    let msg = expect(
        &good().replace("name = \"tip\"", "name = \"arm\""),
        &["body \"arm\"", "name", "duplicate"],
    );
    eprintln!("{msg}");
    // names are shared between kinds (they become FMU variable prefixes)
    expect(
        &good().replace("name = \"weld\"", "name = \"arm\""),
        &["joint \"arm\"", "name", "duplicate"],
    );
}

#[test]
fn negative_mass_is_reported() {
    let msg = expect(
        &good().replace("mass = 1.0", "mass = -1.0"),
        &["body \"arm\"", "mass", "> 0"],
    );
    eprintln!("{msg}");
    expect(&good().replace("mass = 1.0", "mass = nan"), &["body \"arm\"", "mass"]);
    expect(&good().replace("mass = 1.0", "mass = 0.0"), &["body \"arm\"", "mass"]);
}

#[test]
fn inertia_that_is_not_positive_definite_is_reported() {
    let msg = expect(
        &good().replace("[0.01, 0.02, 0.02]", "[0.01, -0.02, 0.02]"),
        &["body \"arm\"", "inertia", "positive definite"],
    );
    eprintln!("{msg}");
    expect(
        &good().replace("[0.01, 0.02, 0.02]", "[0.0, 0.02, 0.02]"),
        &["body \"arm\"", "inertia"],
    );
    let msg = expect(
        &good().replace("[0.01, 0.02, 0.02]", "[0.01, 0.02, 0.05]"),
        &["body \"arm\"", "inertia", "triangle"],
    );
    eprintln!("{msg}");
}

#[test]
fn zero_axis_is_reported() {
    let msg = expect(
        &good().replace("axis = [0.0, 1.0, 0.0]", "axis = [0.0, 0.0, 0.0]"),
        &["joint \"pivot\"", "axis", "zero"],
    );
    eprintln!("{msg}");
    expect(
        &good().replacen("axis = [0.0, 1.0, 0.0]\n", "", 1),
        &["joint \"pivot\"", "axis", "required"],
    );
    expect(
        &good().replace("normal = [-1.0, 0.0, 0.0]", "normal = [0.0, 0.0, 0.0]"),
        &["contact \"tip_wall\"", "normal"],
    );
}

#[test]
fn joint_cycle_without_path_to_ground_is_reported() {
    // arm and tip joined to each other and to nothing else
    let joints =
        "[[joint]]\nname = \"j1\"\ntype = \"revolute\"\nparent = \"tip\"\nchild = \"arm\"\naxis = [0.0, 1.0, 0.0]\n\n\
                  [[joint]]\nname = \"j2\"\ntype = \"fixed\"\nparent = \"arm\"\nchild = \"tip\"\n";
    let msg = expect(
        &scene(MODEL, MATERIALS, BODIES, joints, CONTACTS),
        &["body \"", "joint", "cycle", "no path to ground"],
    );
    eprintln!("{msg}");
    // a cycle of three
    let bodies3 = format!(
        "{BODIES}\n[[body]]\nname = \"c\"\nmass = 1.0\ninertia = [0.01, 0.01, 0.01]\nposition = [1.0, 0.0, 0.0]\n"
    );
    let joints3 = "[[joint]]\nname = \"j1\"\ntype = \"spherical\"\nparent = \"c\"\nchild = \"arm\"\n\n\
                   [[joint]]\nname = \"j2\"\ntype = \"spherical\"\nparent = \"arm\"\nchild = \"tip\"\n\n\
                   [[joint]]\nname = \"j3\"\ntype = \"spherical\"\nparent = \"tip\"\nchild = \"c\"\n";
    expect(
        &scene(MODEL, MATERIALS, &bodies3, joints3, CONTACTS),
        &["cycle", "no path to ground"],
    );
}

#[test]
fn poisson_ratio_of_one_half_or_more_is_reported() {
    let msg = expect(
        &good().replace("poisson_ratio = 0.3", "poisson_ratio = 0.5"),
        &["material \"steel\"", "poisson_ratio", "[0, 0.5)"],
    );
    eprintln!("{msg}");
    expect(
        &good().replace("poisson_ratio = 0.3", "poisson_ratio = 0.7"),
        &["material \"steel\"", "poisson_ratio"],
    );
}

#[test]
fn contact_between_two_ground_shapes_is_reported() {
    let msg = expect(
        &good().replace("sphere_body = \"tip\"", "sphere_body = \"ground\""),
        &["contact \"tip_wall\"", "body", "ground"],
    );
    eprintln!("{msg}");
}

#[test]
fn unknown_material_is_reported() {
    let msg = expect(
        &good().replace("material = \"steel\"\norigin", "material = \"stell\"\norigin"),
        &["contact \"tip_wall\"", "material", "unknown material \"stell\""],
    );
    eprintln!("{msg}");
    expect(
        &good().replace("sphere_material = \"steel\"", "sphere_material = \"rubber\""),
        &["contact \"tip_wall\"", "sphere_material", "unknown material"],
    );
}

#[test]
fn other_mistakes_are_reported_without_panicking() {
    let cases: Vec<(String, &[&str])> = vec![
        (good().replace("type = \"fixed\"", "type = \"hinge\""), &["line", "toml"]),
        (good().replace("parent = \"arm\"", "parent = \"tip\""), &["joint \"weld\"", "child", "itself"]),
        (good().replace("name = \"bad\"", "name = \"2bad\""), &["[model]", "name"]),
        (good().replace("[0.0, 0.0, -0.5]", "[0.0, 0.0, inf]"), &["body \"arm\"", "position", "finite"]),
        (good().replace("radius = 0.02", "radius = -0.02"), &["contact \"tip_wall\"", "radius"]),
        (good().replace("u_axis = [0.0, 1.0, 0.0]", "u_axis = [-1.0, 0.0, 0.0]"), &["contact \"tip_wall\"", "u_axis", "perpendicular"]),
        (good().replace("law = \"hertz\"", "law = \"kelvin_voigt\""), &["contact \"tip_wall\"", "stiffness"]),
        (good().replace("name = \"arm\"", "name = \"ground\""), &["name", "reserved"]),
        (
            format!("{}\n[[body]]\nname = \"x\"\nmass = 1.0\ninertia = [0.01, 0.01, 0.01]\nposition = [0.0, 0.0, 0.0]\norientation = [0.0, 0.0, 0.0, 0.0]\n", good()),
            &["body \"x\"", "orientation", "unit quaternion"],
        ),
        (
            format!("{}\n[[joint]]\nname = \"loop\"\ntype = \"free\"\nparent = \"ground\"\nchild = \"tip\"\n", good()),
            &["joint \"loop\"", "type", "free joint cannot close a loop"],
        ),
        (
            format!("{}\n[[joint]]\nname = \"loop\"\ntype = \"revolute\"\nparent = \"ground\"\nchild = \"tip\"\naxis = [0.0, 1.0, 0.0]\n\n[[input]]\nname = \"u\"\ntype = \"joint_force\"\njoint = \"loop\"\n", good()),
            &["input \"u\"", "joint", "loop"],
        ),
        (
            format!("{}\n[[input]]\nname = \"u\"\ntype = \"joint_force\"\njoint = \"weld\"\n", good()),
            &["input \"u\"", "joint", "1-DOF"],
        ),
        (
            format!("{}\n[[input]]\nname = \"u\"\ntype = \"joint_force\"\njoints = [\"pivot\", \"nothing\"]\n", good()),
            &["input \"u\"", "joints", "unknown joint \"nothing\""],
        ),
        (
            format!("{}\n[[input]]\nname = \"u\"\ntype = \"joint_force\"\njoint = \"pivot\"\njoints = [\"pivot\"]\n", good()),
            &["input \"u\"", "joints", "not both"],
        ),
        (
            format!("{}\n[[input]]\nname = \"u\"\ntype = \"joint_force\"\njoints = []\n", good()),
            &["input \"u\"", "joint", "required"],
        ),
        (
            format!("{}\n[[spring_damper]]\nname = \"s\"\nbody_a = \"arm\"\npoint_a = [0.0, 0.0, 0.0]\nbody_b = \"nobody\"\npoint_b = [0.0, 0.0, 1.0]\nstiffness = 1.0\n", good()),
            &["spring_damper \"s\"", "body_b", "unknown body"],
        ),
        (good().replace("[model]\nname = \"bad\"\n", "[model]\nname = \"bad\"\nstop_time = -1.0\n"), &["[model]", "stop_time"]),
        (format!("{}\n[solver]\nrtol = 0.0\n", good()), &["[solver]", "rtol"]),
    ];
    for (text, fragments) in cases {
        let msg = expect(&text, fragments);
        eprintln!("{msg}");
    }
}

// ---------------------------------------------------------------------------------------------
// command line

fn temp_scene(name: &str, text: &str) -> PathBuf {
    common::temp_scene("scene_errors", name, text)
}

/// Runs `contact-fmu simulate <path>`; returns (success, stderr).
fn simulate(path: &std::path::Path) -> (bool, String) {
    common::run_command(&["simulate", path.to_str().unwrap(), "--stop-time", "0.01", "--quiet"])
}

#[test]
fn command_line_reports_bad_scenes_in_one_line() {
    let cycle = scene(
        MODEL,
        MATERIALS,
        BODIES,
        "[[joint]]\nname = \"j1\"\ntype = \"revolute\"\nparent = \"tip\"\nchild = \"arm\"\naxis = [0.0, 1.0, 0.0]\n\n\
         [[joint]]\nname = \"j2\"\ntype = \"fixed\"\nparent = \"arm\"\nchild = \"tip\"\n",
        CONTACTS,
    );
    let cases: Vec<(&str, String, &[&str])> = vec![
        (
            "unparsable.toml",
            good().replace("mass = 0.2", "mass = 0.2.1"),
            &["line", "toml"],
        ),
        (
            "header.toml",
            good().replace("[[joint]]\nname = \"weld\"", "[[joint]\nname = \"weld\""),
            &["line", "toml"],
        ),
        (
            "unknown_body.toml",
            good().replace("parent = \"ground\"", "parent = \"grund\""),
            &["joint \"pivot\"", "parent"],
        ),
        (
            "duplicate.toml",
            good().replace("name = \"tip\"", "name = \"arm\""),
            &["duplicate"],
        ),
        (
            "negative_mass.toml",
            good().replace("mass = 1.0", "mass = -1.0"),
            &["body \"arm\"", "mass"],
        ),
        (
            "inertia.toml",
            good().replace("[0.01, 0.02, 0.02]", "[0.01, -0.02, 0.02]"),
            &["inertia"],
        ),
        (
            "zero_axis.toml",
            good().replace("axis = [0.0, 1.0, 0.0]", "axis = [0.0, 0.0, 0.0]"),
            &["axis"],
        ),
        ("cycle.toml", cycle, &["cycle"]),
        (
            "poisson.toml",
            good().replace("poisson_ratio = 0.3", "poisson_ratio = 0.5"),
            &["poisson_ratio"],
        ),
        (
            "ground_contact.toml",
            good().replace("sphere_body = \"tip\"", "sphere_body = \"ground\""),
            &["contact \"tip_wall\""],
        ),
        (
            "material.toml",
            good().replace("sphere_material = \"steel\"", "sphere_material = \"rubber\""),
            &["sphere_material"],
        ),
    ];
    for (file, text, fragments) in cases {
        let p = temp_scene(file, &text);
        let (ok, err) = simulate(&p);
        let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
        eprintln!("{file}: {}", err.trim());
        assert!(!ok, "{file}: exit status 0");
        assert_eq!(lines.len(), 1, "{file}: expected one line, got {err:?}");
        assert!(!err.contains("panicked") && !err.contains("backtrace"), "{file}: {err}");
        assert!(
            err.contains(p.to_str().unwrap()),
            "{file}: the message does not name the file: {err}"
        );
        for f in fragments {
            assert!(err.contains(f), "{file}: {err:?} lacks {f:?}");
        }
    }
    // a file that does not exist
    let missing = std::env::temp_dir().join("contact_fmu_no_such_scene.toml");
    let (ok, err) = simulate(&missing);
    assert!(
        !ok && err.lines().count() == 1 && err.contains("contact_fmu_no_such_scene.toml"),
        "{err}"
    );
    // and the good scene runs
    let (ok, err) = simulate(&temp_scene("good.toml", &good()));
    assert!(ok, "{err}");
}
