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

/// Asserts the message of each mistake of `kind` (see `expect`).
fn expect_kind(kind: &str) {
    let cases: Vec<_> = MISTAKES.iter().filter(|case| case.0 == kind).collect();
    assert!(!cases.is_empty(), "no mistakes of kind {kind}");
    for (_, from, to, fragments) in cases {
        let text = good();
        assert!(text.contains(from), "{from:?} is not in the scene");
        let msg = expect(&text.replace(from, to), fragments);
        eprintln!("{msg}");
    }
}

/// The mistakes, by kind: (kind, from, to, fragments): the good scene with every `from` replaced
/// by `to`, and the fragments its message must hold. One a line.
#[rustfmt::skip]
const MISTAKES: &[(&str, &str, &str, &[&str])] = &[
    ("unparsable", "mass = 0.2", "mass = 0.2.1", &["line", "toml"]),
    ("unparsable", "[[joint]]\nname = \"weld\"", "[[joint]\nname = \"weld\"", &["line", "toml"]),
    // a value of the wrong type and an unknown key are reported the same way
    ("unparsable", "mass = 1.0", "mass = \"heavy\"", &["line", "toml"]),
    ("unparsable", "mass = 1.0", "mass = 1.0\ncolour = \"red\"", &["line", "colour"]),
    // numbers beyond a fixed-length array's were dropped without a word
    ("unparsable", "[0.01, 0.02, 0.02]", "[0.01, 0.02, 0.02, 0.03]", &["line", "invalid length 4, expected an array of length 3"]),
    ("unparsable", "origin = [0.5, 0.0, -1.0]", "origin = [0.5, 0.0, -1.0, \"junk\"]", &["line", "junk"]),
    ("unparsable", "size = [1.0, 1.0]", "size = [1.0, 1.0, 1.0]", &["line", "invalid length 3, expected an array of length 2"]),
    ("unknown_body", "parent = \"ground\"", "parent = \"grund\"", &["joint \"pivot\"", "parent", "unknown body \"grund\""]),
    ("unknown_body", "child = \"tip\"", "child = \"tap\"", &["joint \"weld\"", "child", "unknown body"]),
    ("unknown_body", "sphere_body = \"tip\"", "sphere_body = \"top\"", &["contact \"tip_wall\"", "sphere_body", "unknown body"]),
    ("duplicate", "name = \"tip\"", "name = \"arm\"", &["body \"arm\"", "name", "duplicate"]),
    // names are shared between kinds (they become FMU variable prefixes)
    ("duplicate", "name = \"weld\"", "name = \"arm\"", &["joint \"arm\"", "name", "duplicate"]),
    ("mass", "mass = 1.0", "mass = -1.0", &["body \"arm\"", "mass", "> 0"]),
    ("mass", "mass = 1.0", "mass = nan", &["body \"arm\"", "mass"]),
    ("mass", "mass = 1.0", "mass = 0.0", &["body \"arm\"", "mass"]),
    ("inertia", "[0.01, 0.02, 0.02]", "[0.01, -0.02, 0.02]", &["body \"arm\"", "inertia", "positive definite"]),
    ("inertia", "[0.01, 0.02, 0.02]", "[0.0, 0.02, 0.02]", &["body \"arm\"", "inertia"]),
    ("inertia", "[0.01, 0.02, 0.02]", "[0.01, 0.02, 0.05]", &["body \"arm\"", "inertia", "triangle"]),
    // (near f64::MAX the check's tolerance overflowed to infinity and let these through)
    ("inertia", "[0.01, 0.02, 0.02]", "[1.7e308, 1e307, 1e307]", &["body \"arm\"", "inertia", "triangle"]),
    ("zero_axis", "axis = [0.0, 1.0, 0.0]", "axis = [0.0, 0.0, 0.0]", &["joint \"pivot\"", "axis", "zero"]),
    ("zero_axis", "normal = [-1.0, 0.0, 0.0]", "normal = [0.0, 0.0, 0.0]", &["contact \"tip_wall\"", "normal"]),
    ("poisson", "poisson_ratio = 0.3", "poisson_ratio = 0.5", &["material \"steel\"", "poisson_ratio", "[0, 0.5)"]),
    ("poisson", "poisson_ratio = 0.3", "poisson_ratio = 0.7", &["material \"steel\"", "poisson_ratio"]),
    ("ground_contact", "sphere_body = \"tip\"", "sphere_body = \"ground\"", &["contact \"tip_wall\"", "body", "ground"]),
    ("material", "material = \"steel\"\norigin", "material = \"stell\"\norigin", &["contact \"tip_wall\"", "material", "unknown material \"stell\""]),
    ("material", "sphere_material = \"steel\"", "sphere_material = \"rubber\"", &["contact \"tip_wall\"", "sphere_material", "unknown material"]),
    ("other", "type = \"fixed\"", "type = \"hinge\"", &["line", "toml"]),
    ("other", "parent = \"arm\"", "parent = \"tip\"", &["joint \"weld\"", "child", "itself"]),
    ("other", "name = \"bad\"", "name = \"2bad\"", &["[model]", "name"]),
    ("other", "[0.0, 0.0, -0.5]", "[0.0, 0.0, inf]", &["body \"arm\"", "position", "finite"]),
    ("other", "radius = 0.02", "radius = -0.02", &["contact \"tip_wall\"", "radius"]),
    ("other", "u_axis = [0.0, 1.0, 0.0]", "u_axis = [-1.0, 0.0, 0.0]", &["contact \"tip_wall\"", "u_axis", "perpendicular"]),
    ("other", "law = \"hertz\"", "law = \"kelvin_voigt\"", &["contact \"tip_wall\"", "stiffness"]),
    ("other", "name = \"arm\"", "name = \"ground\"", &["name", "reserved"]),
    // a key of another type of contact (it was ignored without a word)
    ("other", "radius = 0.02", "radius = 0.02\nother_radius = 0.01", &["contact \"tip_wall\"", "other_radius", "not used by a sphere_plane contact"]),
    ("other", "radius = 0.02", "radius = 0.02\nside = \"inside\"", &["contact \"tip_wall\"", "side", "not used by a sphere_plane contact"]),
    // (only a body named "ground" was refused; a material or contact so named was accepted)
    ("other", "name = \"steel\"", "name = \"ground\"", &["material \"ground\"", "name", "reserved for the fixed world"]),
    ("other", "name = \"tip_wall\"", "name = \"ground\"", &["contact \"ground\"", "name", "reserved for the fixed world"]),
    // a speed the engine takes for a blow-up (validation allowed it, the run then stopped at
    // once advising a tighter tolerance)
    ("other", "mass = 0.2", "mass = 0.2\nangular_velocity = [0.0, 2e8, 0.0]", &["body \"tip\"", "angular_velocity", "beyond 1e8"]),
    // names of the FMU's own variables (an input named "time" made a second variable "time")
    ("other", "name = \"arm\"", "name = \"time\"", &["body \"time\"", "name", "reserved"]),
    ("other", "name = \"weld\"", "name = \"solver\"", &["joint \"solver\"", "name", "reserved"]),
    ("other", "name = \"tip_wall\"", "name = \"energy\"", &["contact \"energy\"", "name", "reserved"]),
    ("other", "[model]\nname = \"bad\"\n", "[model]\nname = \"bad\"\nstop_time = -1.0\n", &["[model]", "stop_time"]),
    // a band of admitted penetrations too thin to be seen (the sphere passed through the
    // surface without an error)
    ("other", "radius = 0.02", "radius = 0.02\nmax_penetration = 1e-300", &["contact \"tip_wall\"", "max_penetration", "at least 1e-9"]),
    // (max_penetration defaults to the radius: its parameter's start would be below its min)
    ("other", "radius = 0.02", "radius = 1e-10", &["contact \"tip_wall\"", "radius", "give max_penetration"]),
    // a step budget beyond an FMI Integer (reported before as a parameter, with no file or
    // item, its value rounded through a float)
    ("other", "[model]\nname = \"bad\"\n", "[model]\nname = \"bad\"\n[solver]\nmax_steps = 9223372036854775807\n", &["[solver]", "max_steps", "9223372036854775807"]),
    ("other", "[model]\nname = \"bad\"\n", "[model]\nname = \"bad\"\n[solver]\nmax_steps = 0\n", &["[solver]", "max_steps", "[1, 2147483647]"]),
];

/// Arm and tip joined to each other and to nothing else.
const CYCLE_JOINTS: &str =
    "[[joint]]\nname = \"j1\"\ntype = \"revolute\"\nparent = \"tip\"\nchild = \"arm\"\naxis = [0.0, 1.0, 0.0]\n\n\
     [[joint]]\nname = \"j2\"\ntype = \"fixed\"\nparent = \"arm\"\nchild = \"tip\"\n";

#[test]
fn unparsable_toml_names_the_line() {
    let text = good().replace("mass = 0.2", "mass = 0.2.1");
    let line = text.lines().position(|l| l.contains("0.2.1")).unwrap() + 1;
    expect(&text, &[&format!("line {line}"), "toml"]);
    expect_kind("unparsable");
    expect("", &["model"]);
}

#[test]
fn unknown_body_names_joint_and_field() {
    expect_kind("unknown_body");
}

#[test]
fn duplicate_name_is_reported() {
    expect_kind("duplicate");
}

#[test]
fn negative_mass_is_reported() {
    expect_kind("mass");
}

#[test]
fn inertia_that_is_not_positive_definite_is_reported() {
    expect_kind("inertia");
}

#[test]
fn zero_axis_is_reported() {
    expect_kind("zero_axis");
    expect(
        &good().replacen("axis = [0.0, 1.0, 0.0]\n", "", 1),
        &["joint \"pivot\"", "axis", "required"],
    );
}

#[test]
fn joint_cycle_without_path_to_ground_is_reported() {
    let msg = expect(
        &scene(MODEL, MATERIALS, BODIES, CYCLE_JOINTS, CONTACTS),
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
    expect_kind("poisson");
}

#[test]
fn contact_between_two_ground_shapes_is_reported() {
    expect_kind("ground_contact");
}

#[test]
fn unknown_material_is_reported() {
    expect_kind("material");
}

/// Items added to the good scene, and the fragments the message must hold.
#[rustfmt::skip]
const ADDED_ITEMS: &[(&str, &[&str])] = &[
    ("[[body]]\nname = \"x\"\nmass = 1.0\ninertia = [0.01, 0.01, 0.01]\nposition = [0.0, 0.0, 0.0]\norientation = [0.0, 0.0, 0.0, 0.0]\n", &["body \"x\"", "orientation", "unit quaternion"]),
    ("[[joint]]\nname = \"loop\"\ntype = \"free\"\nparent = \"ground\"\nchild = \"tip\"\n", &["joint \"loop\"", "type", "free joint cannot close a loop"]),
    ("[[joint]]\nname = \"loop\"\ntype = \"revolute\"\nparent = \"ground\"\nchild = \"tip\"\naxis = [0.0, 1.0, 0.0]\n\n[[input]]\nname = \"u\"\ntype = \"joint_force\"\njoint = \"loop\"\n", &["input \"u\"", "joint", "loop"]),
    ("[[input]]\nname = \"u\"\ntype = \"joint_force\"\njoint = \"weld\"\n", &["input \"u\"", "joint", "1-DOF"]),
    ("[[input]]\nname = \"u\"\ntype = \"joint_force\"\njoints = [\"pivot\", \"nothing\"]\n", &["input \"u\"", "joints", "unknown joint \"nothing\""]),
    ("[[input]]\nname = \"u\"\ntype = \"joint_force\"\njoint = \"pivot\"\njoints = [\"pivot\"]\n", &["input \"u\"", "joints", "not both"]),
    ("[[input]]\nname = \"u\"\ntype = \"joint_force\"\njoints = []\n", &["input \"u\"", "joint", "required"]),
    // a joint named twice took the force twice (and the one it replaced none)
    ("[[input]]\nname = \"u\"\ntype = \"joint_force\"\njoints = [\"pivot\", \"pivot\"]\n", &["input \"u\"", "joints", "twice"]),
    ("[[input]]\nname = \"u\"\ntype = \"force\"\nbody = \"arm\"\ndirection = [1.0, 0.0, 0.0]\njoint = \"pivot\"\n", &["input \"u\"", "joint", "not used by a force or torque input"]),
    ("[[input]]\nname = \"u\"\ntype = \"torque\"\nbody = \"arm\"\ndirection = [1.0, 0.0, 0.0]\njoints = [\"pivot\"]\n", &["input \"u\"", "joints", "not used by a force or torque input"]),
    ("[[input]]\nname = \"u\"\ntype = \"joint_force\"\njoint = \"pivot\"\nbody = \"arm\"\n", &["input \"u\"", "body", "not used by a joint_force input"]),
    ("[[input]]\nname = \"u\"\ntype = \"joint_force\"\njoint = \"pivot\"\ndirection = [1.0, 0.0, 0.0]\n", &["input \"u\"", "direction", "not used by a joint_force input"]),
    ("[[spring_damper]]\nname = \"s\"\nbody_a = \"arm\"\npoint_a = [0.0, 0.0, 0.0]\nbody_b = \"nobody\"\npoint_b = [0.0, 0.0, 1.0]\nstiffness = 1.0\n", &["spring_damper \"s\"", "body_b", "unknown body"]),
    ("[solver]\nrtol = 0.0\n", &["[solver]", "rtol"]),
    ("[solver]\nthreads = 1000\n", &["[solver]", "threads", "at most 256"]),
];

#[test]
fn other_mistakes_are_reported_without_panicking() {
    expect_kind("other");
    for (item, fragments) in ADDED_ITEMS {
        let msg = expect(&format!("{}\n{item}", good()), fragments);
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
    // the mistakes above, each through the command line
    let mut cases: Vec<(String, String, &[&str])> = vec![(
        "cycle.toml".into(),
        scene(MODEL, MATERIALS, BODIES, CYCLE_JOINTS, CONTACTS),
        &["cycle"],
    )];
    for (k, (kind, from, to, fragments)) in MISTAKES.iter().enumerate() {
        cases.push((format!("{kind}_{k}.toml"), good().replace(from, to), fragments));
    }
    for (file, text, fragments) in cases {
        let p = temp_scene(&file, &text);
        common::assert_refused_in_one_line(&file, &p, simulate(&p), fragments);
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

#[test]
fn export_names_the_file_once_for_a_mistake_found_when_the_model_is_compiled() {
    // (a joint cycle is found by the compilation, not by the checks of the scene: export
    // printed the file twice, "error: x.toml: x.toml: body ...")
    let p = temp_scene(
        "cycle_export.toml",
        &scene(MODEL, MATERIALS, BODIES, CYCLE_JOINTS, CONTACTS),
    );
    let out = std::env::temp_dir().join("contact_fmu_cycle_export.fmu");
    // (the scene file stands in for the library: the export stops before reading it)
    let (ok, err) = common::export_linux64_with(&p, &out, &p);
    common::assert_refused_in_one_line("export", &p, (ok, err.clone()), &["cycle"]);
    assert_eq!(err.matches("cycle_export.toml").count(), 1, "{err}");
}

#[test]
fn a_run_of_more_communication_points_than_a_scene_may_declare_is_refused_before_it_starts() {
    // `simulate --interval 1e-300` (or `--stop-time 1e300`) ran on for ever at t = 0: the
    // scene's own experiment is checked for at most 1e9 points, the overrides were not
    let mut sim = Simulation::from_scene_str(&good(), ORIGIN).unwrap();
    for (stop, interval) in [(1.0, 1e-300), (1e300, 1e-3), (1.0, 0.0), (1.0, f64::NAN)] {
        let mut points = 0;
        let err = contact_fmu::run::run_simulation(
            &mut sim,
            stop,
            interval,
            |_| {
                points += 1;
                if points > 1000 {
                    return Err("ran on".into());
                }
                Ok(())
            },
            |_| {},
        )
        .unwrap_err();
        assert!(
            err.contains("communication") && points == 0,
            "stop {stop}, interval {interval}: {err} after {points} points"
        );
    }
    // and the command line says so in one line
    let p = temp_scene("long_run.toml", &good());
    let (ok, err) = common::run_command(&["simulate", p.to_str().unwrap(), "--interval", "1e-300", "--quiet"]);
    assert!(!ok && err.lines().count() == 1 && err.contains("at most 1e9"), "{err}");
}
