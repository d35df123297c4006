//! A group pair and the `[[contact]]`s it stands for, compiled and checked alike: a declared
//! contact is the pair of its two one-shape groups (the same contact elements, bit for bit,
//! with sizes from the scene or set as parameters), a law a host sets is refused with one
//! check for both, and a Kelvin-Voigt law with damping warns for both.
//!
//! `cargo test --release --test integration contact_groups_as_contacts:: -- --nocapture` prints
//! what was compared.

use crate::common;
use crate::contact_groups::{explicit, three_balls};

use common::{compile, ORIGIN};
use contact_fmu::compile::Parameters;
use contact_fmu::contact;
use contact_fmu::scene::{BodySpec, ContactGroupSpec, ContactType, Law, MaterialSpec, Scene, ShapeSpec, Side, GROUND};
use contact_fmu::scene_builder::{Cylinder, Plane, SceneBuilder};
use contact_fmu::simulation::SimError;
use nalgebra::{UnitQuaternion, Vector3};

/// A declared `[[contact]]` is compiled as the pair of its two one-shape groups: for every
/// kind of shape, on rotated bodies and on the ground, off-centre spheres, materials (the
/// stiffness derived) and friction, cylinder patches inside and outside with an angular range,
/// the element of each contact of the explicit list is the element of its group pair's
/// candidate, field by field to the bit (its name apart); and the sizes a host sets as
/// parameters make the element the same keys in the scene make.
#[test]
fn a_declared_contact_is_the_element_of_its_two_one_shape_groups() {
    let q = |axis: [f64; 3], angle: f64| UnitQuaternion::from_scaled_axis(Vector3::from(axis).normalize() * angle);
    let bodies = [
        BodySpec::new("a", 0.3, [1e-4, 2e-4, 3e-4], [0.01, 0.02, 0.03]).orientation(q([1.0, 2.0, 3.0], 0.7)),
        BodySpec::new("b", 0.5, [2e-4; 3], [0.05, -0.01, 0.02]).orientation(q([-1.0, 0.5, 0.2], 1.9)),
        BodySpec::new("c", 0.2, [1e-4; 3], [-0.04, 0.03, 0.01]),
    ];
    let shapes = vec![
        ShapeSpec::sphere("s", "a", [0.015, 0.02, 0.03], 0.01).material("steel"),
        ShapeSpec::sphere("s", "b", [0.05, -0.01, 0.02], 0.012).material("rubber"),
        ShapeSpec {
            center: None, // at its body's centre of mass
            ..ShapeSpec::sphere("t", "c", [0.0; 3], 0.008)
        },
        ShapeSpec::plane(
            "w",
            "b",
            Plane::new([0.06, 0.0, 0.0], [0.3, 1.0, 0.2], [1.0, -0.3, 0.0], [0.04, 0.07]),
        )
        .material("steel"),
        ShapeSpec::plane("w", GROUND, Plane::horizontal([0.0, 0.0, -0.05], [0.3, 0.2])).material("rubber"),
        ShapeSpec {
            side: Side::Inside,
            theta_range: Some([-0.5, 2.0]),
            ref_axis: Some([1.0, 0.0, 0.0]),
            ..ShapeSpec::cylinder("w", GROUND, Cylinder::new([0.0, 0.0, 0.01], [0.0, 0.3, 1.0], 0.2, 0.15))
                .material("rubber")
        },
        ShapeSpec::cylinder("w", "c", Cylinder::new([-0.03, 0.0, 0.0], [1.0, 0.0, 0.2], 0.02, 0.05)).material("steel"),
    ];
    let mut scene = SceneBuilder::new("declared_as_groups")
        .gravity([0.0; 3])
        .material(MaterialSpec::steel())
        .material(MaterialSpec::new("rubber", 5e7, 0.45))
        .bodies(bodies)
        .shapes(shapes)
        .contact_group(
            ContactGroupSpec::new("ss", "s", "s", Law::HertzLn)
                .restitution(0.6)
                .friction(0.3),
        )
        .contact_group(
            ContactGroupSpec::new("st", "s", "t", Law::Hertz)
                .stiffness(3e7)
                .exponent(1.4),
        )
        .contact_group(
            ContactGroupSpec::new("sw", "s", "w", Law::Flores)
                .restitution(0.4)
                .friction(0.2)
                .static_friction(0.35)
                .stribeck_velocity(0.01),
        )
        .contact_group(
            ContactGroupSpec::new("tw", "t", "w", Law::KelvinVoigt)
                .stiffness(1e6)
                .damping(50.0),
        )
        .build();
    scene.broad_phase.margin = Some(10.0);
    let (mg, dg) = compile(scene.clone());
    let e = explicit(&scene);
    let (_, de) = compile(e.clone());
    assert_eq!(de.contacts.len(), e.contact.len());
    assert_eq!(
        dg.contacts.len(),
        de.contacts.len(),
        "every pair is a candidate at a margin of 10 m"
    );
    assert_eq!(de.contacts.len(), 13, "1 + 2 + 7 + 3 pairs not on one body");
    let unnamed = |c: &contact_fmu::model::contact::ContactElement| {
        format!(
            "{:?}",
            contact_fmu::model::contact::ContactElement {
                name: String::new(),
                ..c.clone()
            }
        )
    };
    let mut kinds = std::collections::HashSet::new();
    for (i, (g, d)) in dg.contacts.iter().zip(&de.contacts).enumerate() {
        let name = contact::elements::contact_name(&mg, &dg, i);
        assert_eq!(unnamed(g), unnamed(d), "{name} against {}", d.name);
        kinds.insert(format!("{:?} {:?} {}", d.kind, d.law, d.stiffness_derived));
    }
    println!(
        "{} contacts, the same elements as their group pairs' candidates: {kinds:?}",
        de.contacts.len()
    );
    assert_eq!(kinds.len(), 6, "{kinds:?}");
    // the sizes a host sets (parameters) reach the element as the scene's keys do: the
    // explicit scene compiled with the parameter values of one whose sizes were edited
    let mut edited = e.clone();
    for c in &mut edited.contact {
        c.radius *= 1.25;
        match c.kind {
            ContactType::SphereSphere => c.other_radius = c.other_radius.map(|r| 0.8 * r),
            ContactType::SpherePlane => c.size = c.size.map(|[u, v]| [1.1 * u, 0.9 * v]),
            ContactType::SphereCylinder => {
                c.cylinder_radius = c.cylinder_radius.map(|r| 1.05 * r);
                c.length = c.length.map(|l| 1.2 * l);
            }
        }
    }
    let (_, d_keys) = compile(edited.clone());
    let (_, d_set) = contact_fmu::compile::compile_with(&e, &Parameters::of_scene(&edited), ORIGIN)
        .unwrap_or_else(|err| panic!("{err}"));
    for (k, s) in d_keys.contacts.iter().zip(&d_set.contacts) {
        assert_eq!(format!("{k:?}"), format!("{s:?}"), "{}: the sizes set", k.name);
    }
    for (k, d) in d_keys.contacts.iter().zip(&de.contacts) {
        assert_ne!(format!("{k:?}"), format!("{d:?}"), "{}: the sizes were edited", k.name);
    }
}

/// A law chosen by parameter for a group pair that the pair cannot take is refused with the
/// message a declared contact gets (one check for both): the parameter and its value, why no
/// stiffness can be set (the group pair's scene gives none, so the FMU has no such parameter),
/// the laws that would do, and the way out.
#[test]
fn a_law_a_group_pair_cannot_take_is_refused_as_a_contacts_is() {
    let refused = |scene: Scene, name: &str, value: f64| {
        let mut s = common::open(scene);
        s.set_by_name(name, value).unwrap_or_else(|e| panic!("{e}"));
        match s.initialize(0.0) {
            Err(SimError::Scene(e)) => e,
            other => panic!("{name} = {value}: {other:?}"),
        }
    };
    // hertz without a stiffness or materials (the scene's law is the impulse law)
    let e = refused(three_balls(0.5), "ball_floor.law", 2.0);
    println!("{e}");
    assert_eq!(
        (e.item.as_str(), e.field.as_str()),
        ("contact_group \"ball_floor\"", "law")
    );
    for f in [
        "parameter \"ball_floor.law\" = 2 (hertz)",
        "needs a contact stiffness",
        "this FMU has no \"ball_floor.stiffness\" parameter",
        "impulse = 6",
        "add stiffness to contact_group \"ball_floor\"",
    ] {
        assert!(e.message.contains(f), "{:?} lacks {f:?}", e.message);
    }
    assert!(!e.message.contains("hertz = 2"), "hertz is no way out: {}", e.message);
    // flores with the scene's restitution 0
    let e = refused(three_balls(0.0), "ball_ball.law", 5.0);
    println!("{e}");
    assert_eq!(
        (e.item.as_str(), e.field.as_str()),
        ("contact_group \"ball_ball\"", "law")
    );
    assert!(
        e.message
            .contains("parameter \"ball_ball.law\" = 5 (flores) needs a restitution e > 0"),
        "{}",
        e.message
    );
}

/// A Kelvin-Voigt law with damping warns that it would pull before separation for a group
/// pair as for the `[[contact]]`s it stands for (the group pair's warning was missing), once
/// per pair, naming it.
#[test]
fn a_kelvin_voigt_law_with_damping_warns_for_a_group_pair_as_for_its_contacts() {
    let mut scene = three_balls(0.8);
    let pair = &mut scene.contact_group[0];
    (pair.law, pair.stiffness, pair.damping) = (Law::KelvinVoigt, Some(1e5), Some(10.0));
    let name = pair.name.clone();
    let mut groups = common::start(scene.clone());
    let warned = groups.warnings().unwrap();
    println!("{warned:?}");
    assert_eq!(warned.len(), 1, "{warned:?}");
    assert!(
        warned[0].starts_with(&format!("contact_group {name:?}: kelvin_voigt jumps")),
        "{warned:?}"
    );
    let mut declared = common::start(explicit(&scene));
    let warned_declared = declared.warnings().unwrap();
    let contacts = explicit(&scene)
        .contact
        .iter()
        .filter(|c| c.law == Law::KelvinVoigt)
        .count();
    assert!(contacts > 1);
    assert_eq!(warned_declared.len(), contacts, "{warned_declared:?}");
    // the same words after the item
    let tail = |w: &str| w.split_once(": ").map(|(_, t)| t.to_string()).unwrap();
    assert!(warned_declared.iter().all(|w| tail(w) == tail(&warned[0])));
}
