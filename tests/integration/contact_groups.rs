//! Contact groups (`[[shape]]`, `[[contact_group]]`, `[broad_phase]`): the same trajectory as
//! the explicit `[[contact]]` list they stand for; the broad phase never leaves out a pair
//! that touches or lies within the margin; a group pair's parameters act on every pair; the
//! outputs per body and per group pair; clear errors for bad group input.
//!
//! `cargo test --release --test integration contact_groups:: -- --nocapture` prints the measurements.

use crate::common;

use common::{compile, get, start, Rng, ORIGIN};
use contact_fmu::bench::scenes::{sphere_box_groups, BALL_MASS, BALL_RADIUS};
use contact_fmu::contact::broad::Candidate;
use contact_fmu::contact::{self, geometry};
use contact_fmu::kinematics::frame;
use contact_fmu::scene::{
    BodySpec, BroadPhaseMethod, ContactGroupSpec, Law, MaterialSpec, Scene, ShapeSpec, Side, GROUND,
};
use contact_fmu::scene_builder::{Cylinder, Plane, SceneBuilder};
use contact_fmu::simulation::{SimError, Simulation};
use nalgebra::{UnitQuaternion, Vector3};

/// The scene with its groups replaced by the explicit `[[contact]]` list they stand for.
pub(crate) fn explicit(scene: &Scene) -> Scene {
    let mut e = scene.clone();
    e.contact.extend(scene.group_contacts());
    e.shape.clear();
    e.contact_group.clear();
    e.broad_phase = Default::default();
    e
}

/// Positions and velocities of every body at `t` (after stepping in `dt`).
fn trajectory(scene: Scene, t_end: f64, dt: f64) -> (Vec<f64>, Simulation) {
    let names: Vec<String> = scene.body.iter().map(|b| b.name.clone()).collect();
    let mut s = start(scene);
    let n = (t_end / dt).round() as usize;
    let mut out = Vec::new();
    for k in 1..=n {
        s.step_to(k as f64 * dt).unwrap_or_else(|e| panic!("{e}"));
        for b in &names {
            for key in ["r", "v"] {
                for c in 1..=3 {
                    out.push(get(&mut s, &format!("{b}.{key}[{c}]")));
                }
            }
        }
    }
    (out, s)
}

#[test]
fn groups_give_the_trajectory_of_the_explicit_pair_list() {
    // 8 spheres in a box, 0.2 s: several sphere-sphere and sphere-wall impacts
    let mut groups = sphere_box_groups(8, 0.2);
    // (a) a margin that takes in every pair: the same contact elements in the same order
    groups.broad_phase.margin = Some(10.0);
    let (a, sa) = trajectory(groups.clone(), 0.2, 0.01);
    let (b, sb) = trajectory(explicit(&groups), 0.2, 0.01);
    let impacts = sb.counters().events;
    let diff = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    println!(
        "groups (margin 10 m) against the explicit list: largest difference {diff:e}, {} events, {} RHS evaluations",
        impacts,
        sa.counters().rhs_evals
    );
    assert!(impacts >= 4, "the scene should have impacts ({impacts} events)");
    assert_eq!(a, b, "not bit-identical");
    // the default margin (the sphere radius): the candidate list is made again as the
    // spheres move; the steps differ (the bound on the step is another), the trajectory
    // agrees to the integration tolerance (with one integrator for the scene, as the
    // explicit list has: tests/integration/islands.rs compares the islands with it)
    groups.broad_phase.margin = None;
    groups.solver.islands = false;
    let (c, sc) = trajectory(groups, 0.2, 0.01);
    let diff = c.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    println!(
        "groups (margin = radius) against the explicit list: largest difference {diff:e} (m, m/s), {} events, {} RHS evaluations, \
         the candidate list made {} times again",
        sc.counters().events,
        sc.counters().rhs_evals,
        sc.candidate_refreshes()
    );
    assert!(sc.candidate_refreshes() > 5);
    assert_eq!(sc.counters().events, impacts);
    assert!(diff < 1e-5, "difference {diff}");
}

/// A random scene: bodies at random poses carrying spheres (some off their centre of mass,
/// some overlapping or touching, some just out of reach), a few rectangles and cylinder
/// patches on bodies and on the ground; groups `a` (spheres), `b` (spheres), `w` (planes and
/// cylinders) with pairs (a, a), (a, b), (b, w).
fn random_scene(rng: &mut Rng, method: BroadPhaseMethod) -> Scene {
    let nb = 2 + (rng.next() * 12.0) as usize;
    let mut b = SceneBuilder::new("random").gravity([0.0; 3]);
    let mut shapes = Vec::new();
    let mut centres: Vec<([f64; 3], f64)> = Vec::new();
    for i in 0..nb {
        let q = UnitQuaternion::from_scaled_axis(Vector3::from(rng.vector(3.0)));
        let pos = rng.vector(0.1);
        b = b.body(BodySpec::new(&format!("b{i}"), 1.0, [0.01; 3], pos).orientation(q));
        let name = format!("b{i}");
        for _ in 0..1 + (rng.next() * 3.0) as usize {
            let r = rng.range(0.002, 0.03);
            let group = if rng.next() < 0.5 { "a" } else { "b" };
            let roll = rng.next();
            let center = if roll < 0.3 || centres.is_empty() {
                // anywhere near the body
                let o = rng.vector(0.03);
                [pos[0] + o[0], pos[1] + o[1], pos[2] + o[2]]
            } else {
                // close to another sphere: overlapping, touching or a near miss
                let (c, r2) = centres[(rng.next() * centres.len() as f64) as usize];
                let gap = match (rng.next() * 4.0) as usize {
                    0 => -0.5 * r.min(r2),
                    1 => 0.0,
                    2 => rng.range(0.0, 0.02),
                    _ => rng.range(0.0, 0.05),
                };
                let dir = rng.unit();
                let d = r + r2 + gap;
                [c[0] + d * dir.x, c[1] + d * dir.y, c[2] + d * dir.z]
            };
            centres.push((center, r));
            shapes.push(ShapeSpec::sphere(group, &name, center, r));
        }
        if rng.next() < 0.3 {
            let n = rng.unit();
            let u = n.cross(&rng.unit()).normalize();
            let o = rng.vector(0.1);
            shapes.push(ShapeSpec::plane(
                "w",
                &name,
                Plane::new(o, n, u, [rng.range(0.01, 0.2), rng.range(0.01, 0.2)]),
            ));
        }
    }
    for _ in 0..(rng.next() * 3.0) as usize {
        let o = rng.vector(0.1);
        if rng.next() < 0.5 {
            let n = rng.unit();
            let u = n.cross(&rng.unit()).normalize();
            shapes.push(ShapeSpec::plane(
                "w",
                GROUND,
                Plane::new(o, n, u, [rng.range(0.01, 0.3), rng.range(0.01, 0.3)]),
            ));
        } else {
            let mut cyl = ShapeSpec::cylinder(
                "w",
                GROUND,
                Cylinder::new(o, rng.unit(), rng.range(0.02, 0.1), rng.range(0.01, 0.2)),
            );
            if rng.next() < 0.5 {
                cyl.side = Side::Inside;
                cyl.cylinder_radius = Some(0.2);
            }
            shapes.push(cyl);
        }
    }
    let mut scene = b
        .shapes(shapes)
        .contact_group(ContactGroupSpec::new("aa", "a", "a", Law::Hertz).stiffness(1e7))
        .contact_group(ContactGroupSpec::new("ab", "a", "b", Law::Hertz).stiffness(1e7))
        .contact_group(ContactGroupSpec::new("bw", "b", "w", Law::Hertz).stiffness(1e7))
        .build();
    // every group must have a shape for the pairs to be valid
    for g in ["a", "b", "w"] {
        if !scene.shape.iter().any(|s| s.group == g) {
            scene.shape.push(ShapeSpec::sphere(g, GROUND, [5.0, 5.0, 5.0], 0.01));
            if g == "w" {
                let s = scene.shape.last_mut().unwrap();
                *s = ShapeSpec::plane(
                    "w",
                    GROUND,
                    Plane::new([5.0; 3], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.1, 0.1]),
                );
            }
        }
    }
    scene.broad_phase.margin = Some(rng.range(0.001, 0.02));
    scene.broad_phase.method = method;
    scene
}

/// The pair key of an explicit contact `<pair>_<sphere>_<other>` of [`Scene::group_contacts`].
fn key_of(scene: &Scene, name: &str) -> Candidate {
    let mut parts = name.rsplitn(3, '_');
    let other: usize = parts.next().unwrap().parse().unwrap();
    let sphere: usize = parts.next().unwrap().parse().unwrap();
    let pair_name = parts.next().unwrap();
    let pair = scene.contact_group.iter().position(|g| g.name == pair_name).unwrap();
    Candidate {
        pair,
        sphere: sphere - 1,
        other: other - 1,
    }
}

/// Distance between the sphere and the other shape of a contact of the explicit scene
/// (≤ 0: touching): exact for spheres and rectangles; for cylinders the radial gap when the
/// centre lies on the patch, else only whether it touches.
fn narrow_distance(d: &contact_fmu::model::Data, i: usize) -> f64 {
    let c = &d.contacts[i];
    let fs = frame(d, c.sphere_body);
    let fo = frame(d, c.body);
    let g = geometry::detect(c, &fs, &fo);
    if contact::event_function(c, &g) > 0.0 {
        return 0.0;
    }
    match &c.shape {
        contact::Shape::Sphere { .. } => -g.delta,
        contact::Shape::Plane {
            origin,
            normal,
            u,
            v,
            half,
        } => {
            let center = fs.pos + fs.rot * c.center;
            let o = fo.pos + fo.rot * origin;
            let (n, uu, vv) = (fo.rot * normal, fo.rot * u, fo.rot * v);
            let r = center - o;
            let su = r.dot(&uu).clamp(-half[0], half[0]);
            let sv = r.dot(&vv).clamp(-half[1], half[1]);
            let closest = o + uu * su + vv * sv;
            let _ = n;
            (center - closest).norm() - c.radius
        }
        contact::Shape::Cylinder {
            point, axis, radius, ..
        } => {
            // the distance of the sphere from the surface, where its centre lies on the patch
            let center = fs.pos + fs.rot * c.center;
            let (p, k) = (fo.pos + fo.rot * point, fo.rot * axis);
            let r = center - p;
            let d = (r - k * r.dot(&k)).norm();
            if g.margin > 0.0 {
                (d - radius).abs() - c.radius
            } else {
                f64::INFINITY
            }
        }
    }
}

#[test]
fn the_broad_phase_keeps_every_pair_within_the_margin() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut cases, mut pairs, mut close, mut touching, mut listed) = (0, 0, 0, 0, 0);
    for case in 0..400 {
        let method = if case % 2 == 0 {
            BroadPhaseMethod::Sweep
        } else {
            BroadPhaseMethod::Grid
        };
        let scene = random_scene(&mut rng, method);
        let margin = scene.broad_phase.margin.unwrap();
        let (mg, dg) = compile(scene.clone());
        let found = mg.groups.find(&|b| contact::groups::pose(&dg, b));
        assert_eq!(
            found, dg.candidates,
            "case {case}: the compiled list is the broad phase's"
        );
        // a candidate's contact is named by its group pair and its two shapes (1-based)
        for (k, c) in dg.candidates.iter().enumerate() {
            let name = contact::elements::contact_name(&mg, &dg, mg.groups.n_explicit + k);
            let pair = &scene.contact_group[c.pair].name;
            assert_eq!(name, format!("{pair}[{}:{}]", c.sphere + 1, c.other + 1), "case {case}");
        }
        let reference = mg.groups.find_all_pairs(&|b| contact::groups::pose(&dg, b));
        assert_eq!(
            found, reference,
            "case {case}: {method:?} against testing all pairs of boxes"
        );
        let e = explicit(&scene);
        let (_, de) = compile(e.clone());
        for (i, c) in de.contacts.iter().enumerate() {
            let dist = narrow_distance(&de, i);
            let key = key_of(&scene, &c.name);
            pairs += 1;
            let in_list = found.binary_search(&key).is_ok();
            listed += in_list as usize;
            if dist <= margin {
                close += 1;
                touching += (dist <= 0.0) as usize;
                assert!(
                    in_list,
                    "case {case} ({method:?}): contact {} at distance {dist} (margin {margin}) is not a candidate",
                    c.name
                );
            }
        }
        cases += 1;
    }
    println!(
        "{cases} random scenes: {pairs} pairs, {touching} touching, {close} within the margin, {listed} candidates; none left out"
    );
    assert!(touching > 100 && close > touching);
}

/// Three steel balls side by side dropped from different heights onto a floor (group pairs
/// ball_floor and ball_ball), impulse law.
pub(crate) fn three_balls(restitution: f64) -> Scene {
    let heights = [0.05, 0.08, 0.12];
    let mut b = SceneBuilder::new("three_balls")
        .gravity([0.0, 0.0, -9.81])
        .tolerances(1e-10, 1e-12);
    for (i, h) in heights.iter().enumerate() {
        let name = format!("ball{i}");
        b = b
            .body(BodySpec::sphere(
                &name,
                BALL_MASS,
                BALL_RADIUS,
                [0.05 * i as f64, 0.0, BALL_RADIUS + h],
            ))
            .shape(ShapeSpec::sphere(
                "balls",
                &name,
                [0.05 * i as f64, 0.0, BALL_RADIUS + h],
                BALL_RADIUS,
            ));
    }
    b.shape(ShapeSpec::plane(
        "floor",
        GROUND,
        Plane::horizontal([0.0; 3], [1.0, 1.0]),
    ))
    .contact_group(ContactGroupSpec::new("ball_floor", "balls", "floor", Law::Impulse).restitution(restitution))
    .contact_group(ContactGroupSpec::new("ball_ball", "balls", "balls", Law::Impulse).restitution(restitution))
    .build()
}

#[test]
fn a_group_pair_parameter_acts_on_every_pair() {
    let g = 9.81;
    // after each ball's first impact, before the second (ball0's at 0.202 s)
    let t_end = 0.18;
    let run = |scene: Scene, set: &[(&str, f64)]| {
        let mut s = common::open(scene);
        for (n, v) in set {
            s.set_by_name(n, *v).unwrap();
        }
        s.initialize(0.0).unwrap();
        s.step_to(t_end).unwrap();
        (0..3)
            .map(|i| get(&mut s, &format!("ball{i}.v[3]")))
            .collect::<Vec<f64>>()
    };
    let scene_e = run(three_balls(0.5), &[]);
    let param_e = run(three_balls(0.9), &[("ball_floor.restitution", 0.5)]);
    assert_eq!(param_e, scene_e, "the parameter gives the scene edited by hand");
    for (i, h) in [0.05_f64, 0.08, 0.12].iter().enumerate() {
        // v(t) = e v1 − g (t − t1) after the impact at t1 = sqrt(2h/g) with v1 = g t1
        let t1 = (2.0 * h / g).sqrt();
        let exact = 0.5 * g * t1 - g * (t_end - t1);
        println!("ball{i}: v_z = {:.12} m/s, closed form {exact:.12}", param_e[i]);
        assert!(
            (param_e[i] - exact).abs() < 1e-8,
            "ball{i}: {} against {exact}",
            param_e[i]
        );
    }
    let other = run(three_balls(0.9), &[]);
    assert!(other.iter().zip(&param_e).all(|(a, b)| a != b));
    // tunable: set between steps (before the first impact, at 0.1 s), it acts from then on
    let mut s = start(three_balls(0.9));
    s.step_to(0.05).unwrap();
    s.set_by_name("ball_floor.restitution", 0.5).unwrap();
    s.step_to(t_end).unwrap();
    for (i, v) in param_e.iter().enumerate() {
        let w = get(&mut s, &format!("ball{i}.v[3]"));
        assert!((w - v).abs() < 1e-9, "ball{i}: {w} against {v}");
    }
}

/// A group pair's `static_friction` follows its `friction` while the scene gives none and the
/// host sets friction alone (as a declared contact's does); set apart, it keeps its own value.
#[test]
fn a_group_pairs_static_friction_follows_its_friction() {
    let mut s = common::open(three_balls(0.5));
    assert_eq!(get(&mut s, "ball_floor.static_friction"), 0.0);
    s.set_by_name("ball_floor.friction", 0.3).unwrap();
    assert_eq!(get(&mut s, "ball_floor.static_friction"), 0.3);
    // the other pair's own constants stay
    assert_eq!(get(&mut s, "ball_ball.static_friction"), 0.0);
    s.set_by_name("ball_floor.static_friction", 0.5).unwrap();
    s.set_by_name("ball_floor.friction", 0.2).unwrap();
    assert_eq!(get(&mut s, "ball_floor.static_friction"), 0.5);
}

#[test]
fn body_and_group_pair_outputs() {
    // two balls resting at their static Hertz penetrations on a floor (the second twice as
    // heavy), a third in the air
    let k = contact_fmu::bench::scenes::steel_ball_plane_stiffness();
    let w = BALL_MASS * 9.81;
    let delta0 = (w / k).powf(2.0 / 3.0);
    let delta2 = (2.0 * w / k).powf(2.0 / 3.0);
    let (z, z2) = (BALL_RADIUS - delta0, BALL_RADIUS - delta2);
    let scene = SceneBuilder::new("resting")
        .material(MaterialSpec::steel())
        .body(BodySpec::sphere("ball", BALL_MASS, BALL_RADIUS, [0.0, 0.0, z]))
        .body(BodySpec::sphere("heavy", 2.0 * BALL_MASS, BALL_RADIUS, [0.1, 0.0, z2]))
        .body(BodySpec::sphere("far", BALL_MASS, BALL_RADIUS, [0.5, 0.0, 0.3]))
        .shape(ShapeSpec::sphere("balls", "ball", [0.0, 0.0, z], BALL_RADIUS).material("steel"))
        .shape(ShapeSpec::sphere("balls", "heavy", [0.1, 0.0, z2], BALL_RADIUS).material("steel"))
        .shape(ShapeSpec::sphere("balls", "far", [0.5, 0.0, 0.3], BALL_RADIUS).material("steel"))
        .shape(ShapeSpec::plane("floor", GROUND, Plane::horizontal([0.0; 3], [2.0, 2.0])).material("steel"))
        .contact_group(ContactGroupSpec::new("ball_floor", "balls", "floor", Law::Hertz))
        .build();
    let mut s = start(scene);
    let f = common::vec_out(&mut s, "ball.contact_force");
    let t = common::vec_out(&mut s, "ball.contact_torque");
    println!("resting ball: contact force {f:?} (m g = {w}), torque {t:?}");
    assert!((f.z - w).abs() < 1e-9 * w && f.x == 0.0 && f.y == 0.0);
    assert!(t.norm() < 1e-15);
    let f2 = common::vec_out(&mut s, "heavy.contact_force");
    assert!((f2.z - 2.0 * w).abs() < 1e-9 * w);
    assert_eq!(get(&mut s, "ball_floor.active_contacts"), 2.0);
    assert!((get(&mut s, "ball_floor.largest_penetration") - delta2).abs() < 1e-15);
    assert_eq!(common::vec_out(&mut s, "far.contact_force"), Vector3::zeros());
    assert_eq!(common::vec_out(&mut s, "far.contact_torque"), Vector3::zeros());
}

/// Writes `scene` as a file with one edit and returns its parse error.
fn parse_error(scene: &Scene, edit: impl Fn(&mut Scene)) -> String {
    let mut s = scene.clone();
    edit(&mut s);
    match Scene::from_str(&s.to_toml(), ORIGIN) {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_group_input_is_a_clear_error() {
    let base = three_balls(0.8);
    base.validate(ORIGIN).unwrap();
    let cases: Vec<(String, &str)> = vec![
        (
            parse_error(&base, |s| s.contact_group[0].groups[1] = "flor".into()),
            "test.toml: contact_group \"ball_floor\": groups: unknown group \"flor\" (no [[shape]] names it; groups: \"balls\", \"floor\")",
        ),
        (
            parse_error(&base, |s| s.shape[1].body = "bal1".into()),
            "test.toml: shape 2 (group \"balls\", body \"bal1\"): body: unknown body \"bal1\"",
        ),
        (
            parse_error(&base, |s| s.shape[0].material = Some("stel".into())),
            "test.toml: shape 1 (group \"balls\", body \"ball0\"): material: unknown material \"stel\"",
        ),
        (
            parse_error(&base, |s| s.contact_group[0].groups = ["floor".into(), "balls".into()]),
            "test.toml: contact_group \"ball_floor\": groups: the first group, \"floor\", holds the spheres of the pair but has other shapes",
        ),
        (
            parse_error(&base, |s| {
                let mut g = s.contact_group[1].clone();
                g.name = "again".into();
                s.contact_group.push(g);
            }),
            "test.toml: contact_group \"again\": groups: groups \"balls\" and \"balls\" already touch through contact_group \"ball_ball\"",
        ),
        (
            parse_error(&base, |s| s.shape[0].radius = None),
            "test.toml: shape 1 (group \"balls\", body \"ball0\"): radius: required for a sphere shape",
        ),
        (
            parse_error(&base, |s| s.contact_group[0].restitution = 1.5),
            "test.toml: contact_group \"ball_floor\": restitution: must be in [0, 1] (got 1.5)",
        ),
        (
            parse_error(&base, |s| s.contact_group[0].law = Law::Hertz),
            "test.toml: contact_group \"ball_floor\": stiffness: give stiffness, or a material on every shape of both groups to derive it",
        ),
        (
            parse_error(&base, |s| s.contact_group[0].name = "ball0".into()),
            "test.toml: contact_group \"ball0\": name: duplicate name \"ball0\"",
        ),
        (
            parse_error(&base, |s| s.broad_phase.margin = Some(-1.0)),
            "test.toml: [broad_phase]: margin: must be > 0 (got -1)",
        ),
        (
            parse_error(&base, |s| s.contact_group[0].name = "ground".into()),
            "test.toml: contact_group \"ground\": name: \"ground\" is reserved for the fixed world",
        ),
        (
            // keys of another type of shape (they were ignored without a word)
            parse_error(&base, |s| s.shape[3].radius = Some(0.3)),
            "test.toml: shape 4 (group \"floor\", body \"ground\"): radius: not used by a plane shape",
        ),
        (
            parse_error(&base, |s| s.shape[0].normal = Some([0.0, 0.0, 1.0])),
            "test.toml: shape 1 (group \"balls\", body \"ball0\"): normal: not used by a sphere shape",
        ),
        (
            parse_error(&base, |s| s.shape[3].size = None),
            "test.toml: shape 4 (group \"floor\", body \"ground\"): size: required for a plane shape",
        ),
        (
            // an inside cylinder no larger than a sphere of the pair: refused as the
            // `[[contact]]` of the same two shapes is (its stiffness would not be finite)
            parse_error(&base, |s| {
                let groove = Cylinder::new([0.0, 0.0, 0.05], [0.0, 1.0, 0.0], 0.01, 0.5);
                s.shape.push(ShapeSpec {
                    side: Side::Inside,
                    ..ShapeSpec::cylinder("groove", GROUND, groove)
                });
                s.contact_group.push(ContactGroupSpec::new("ball_groove", "balls", "groove", Law::Impulse));
            }),
            "test.toml: contact_group \"ball_groove\": groups: shape 5 (group \"groove\", body \"ground\") is an \
             inside cylinder of cylinder_radius 0.01 m, no larger than the sphere of shape 1 (group \"balls\", body \
             \"ball0\") (radius 0.01 m): an inside cylinder must exceed the sphere radius",
        ),
    ];
    for (got, want) in cases {
        assert_eq!(got, want);
    }
    // an inside cylinder smaller than a sphere on its own body (the ground): that pair never
    // exists (shapes on one body never touch), and the groove is accepted
    let mut grooved = base.clone();
    grooved.shape.push(ShapeSpec {
        side: Side::Inside,
        ..ShapeSpec::cylinder(
            "groove",
            GROUND,
            Cylinder::new([0.0, 0.0, 0.05], [0.0, 1.0, 0.0], 0.05, 0.5),
        )
    });
    grooved
        .shape
        .push(ShapeSpec::sphere("balls", GROUND, [1.0, 0.0, -0.2], 0.1));
    grooved
        .contact_group
        .push(ContactGroupSpec::new("ball_groove", "balls", "groove", Law::Impulse));
    grooved.validate(ORIGIN).unwrap();
    // an unknown key in a shape
    let text = base.to_toml().replacen("radius = 0.01", "radius = 0.01\nradios = 1", 1);
    let e = Scene::from_str(&text, ORIGIN).unwrap_err().to_string();
    assert!(e.contains("unknown field `radios`"), "{e}");
}

/// Every output of a simulation at its current state.
fn all_outputs(s: &mut Simulation) -> Vec<f64> {
    s.output_indices().into_iter().map(|vr| s.get(vr).unwrap()).collect()
}

#[test]
fn a_saved_state_of_a_scene_with_groups_continues_bit_for_bit() {
    use contact_fmu::checkpoint::Snapshot;
    let scene = sphere_box_groups(27, 0.2);
    let h = 0.005;
    let mut a = start(scene.clone());
    for k in 1..=12 {
        a.step_to(k as f64 * h).unwrap();
    }
    let refreshed = a.candidate_refreshes();
    let bytes = a.snapshot(Vec::new()).to_bytes(0);
    // a fresh simulation compiles its candidates at the initial state: the restore brings
    // the snapshot's list, reference poses and contact memory
    let mut b = common::open(scene);
    b.restore(&Snapshot::from_bytes(&bytes, 0).unwrap()).unwrap();
    assert_eq!(all_outputs(&mut a), all_outputs(&mut b));
    let mut trace = Vec::new();
    for k in 13..=40 {
        let t = k as f64 * h;
        a.step_to(t).unwrap();
        b.step_to(t).unwrap();
        let out = all_outputs(&mut a);
        assert_eq!(out, all_outputs(&mut b), "t = {t}");
        trace.push(out);
    }
    println!(
        "27 spheres: saved after {refreshed} refreshes of the candidate list, {} more to the end; restored run bit-identical",
        a.candidate_refreshes() - refreshed
    );
    assert!(refreshed > 0 && a.candidate_refreshes() > refreshed);
    // rewind the original
    a.restore(&Snapshot::from_bytes(&bytes, 0).unwrap()).unwrap();
    for (k, out) in (13..=40).zip(&trace) {
        a.step_to(k as f64 * h).unwrap();
        assert_eq!(&all_outputs(&mut a), out);
    }
}

/// A saved state that is refused (a damaged contact memory) leaves the simulation as it was,
/// though its candidate list differs from the present one (the list of the snapshot is made
/// to check it, then the present one is put back): the run goes on bit for bit as one that
/// never tried (one system, no islands to repair the list).
#[test]
fn a_refused_restore_leaves_the_contact_list_and_the_run_as_they_were() {
    use contact_fmu::checkpoint::Snapshot;
    let mut scene = sphere_box_groups(27, 0.2);
    scene.solver.islands = false;
    let h = 0.005;
    let (mut a, mut b) = (start(scene.clone()), start(scene));
    for k in 1..=4 {
        a.step_to(k as f64 * h).unwrap();
        b.step_to(k as f64 * h).unwrap();
    }
    let early = a.snapshot(Vec::new());
    let early_pairs = a.data().unwrap().candidates.clone();
    let mut k = 4;
    while a.data().unwrap().candidates == early_pairs {
        k += 1;
        assert!(k < 40, "the candidate list never changed");
        a.step_to(k as f64 * h).unwrap();
        b.step_to(k as f64 * h).unwrap();
    }
    // the first contact's active flag, after time, coordinates, inputs and the group section
    let (nstate, inputs, bodies) = {
        let m = a.model().unwrap();
        (m.nstate(), m.input_values(), m.bodies.len())
    };
    let mut damaged: Snapshot = early.clone();
    damaged.state[1 + nstate + inputs + 1 + 3 * early_pairs.len() + 7 * bodies] = 0.5;
    let err = a.restore(&damaged).unwrap_err().to_string();
    assert!(err.contains("active flag"), "{err}");
    assert_ne!(a.data().unwrap().candidates, early_pairs, "the present list is back");
    assert_eq!(all_outputs(&mut a), all_outputs(&mut b));
    for k in k + 1..=k + 10 {
        let t = k as f64 * h;
        a.step_to(t).unwrap();
        b.step_to(t).unwrap();
        assert_eq!(all_outputs(&mut a), all_outputs(&mut b), "t = {t}");
    }
}

#[test]
fn shapes_without_a_group_pair_touch_nothing() {
    // a ball falling through a floor whose group no [[contact_group]] names
    let mut scene = three_balls(0.5);
    scene.contact_group.clear();
    let mut s = start(scene);
    s.step_to(0.2).unwrap();
    let z = get(&mut s, "ball0.r[3]");
    assert!(z < 0.0, "the ball fell through: z = {z}");
    assert_eq!(s.contacts().unwrap().len(), 0);
}

#[test]
fn a_fast_sphere_from_far_away_is_caught() {
    // weightless: a steel ball at 10 m/s toward a resting one 0.3 m away, off-centre by half a
    // radius; pure Hertz (e = 1). Neither is a candidate of the other at the start (margin:
    // the radius); the collision must still happen, and equal masses then exchange the normal
    // velocity: compare with the same scene with every pair a candidate from the start.
    let scene = |margin: f64| {
        let mut s = SceneBuilder::new("fast")
            .gravity([0.0; 3])
            .tolerances(1e-10, 1e-12)
            .material(MaterialSpec::steel())
            .body(BodySpec::sphere("a", BALL_MASS, BALL_RADIUS, [0.0, 0.0, 0.0]).velocity([10.0, 0.0, 0.0]))
            .body(BodySpec::sphere("b", BALL_MASS, BALL_RADIUS, [0.3, 0.005, 0.0]))
            .shape(ShapeSpec::sphere("balls", "a", [0.0, 0.0, 0.0], BALL_RADIUS).material("steel"))
            .shape(ShapeSpec::sphere("balls", "b", [0.3, 0.005, 0.0], BALL_RADIUS).material("steel"))
            .contact_group(ContactGroupSpec::new("ball_ball", "balls", "balls", Law::Hertz))
            .build();
        s.broad_phase.margin = margin.into();
        s
    };
    let run = |scene: Scene| {
        let mut s = start(scene);
        let candidates = s.contacts().unwrap().len();
        s.step_to(0.05).unwrap();
        (
            common::vec_out(&mut s, "a.v"),
            common::vec_out(&mut s, "b.v"),
            s.candidate_refreshes(),
            candidates,
        )
    };
    let (va, vb, refreshes, at_start) = run(scene(BALL_RADIUS));
    let (wa, wb, _, all) = run(scene(1.0));
    println!(
        "fast sphere: {refreshes} refreshes, b leaves at {vb:?} (all pairs from the start: {wb:?}), difference {:e}",
        (vb - wb).norm().max((va - wa).norm())
    );
    assert_eq!((at_start, all), (0, 1));
    assert!(vb.norm() > 1.0, "the collision was missed: b at {vb:?}");
    assert!((vb - wb).norm() < 1e-6 && (va - wa).norm() < 1e-6);
    assert!((va + vb - Vector3::new(10.0, 0.0, 0.0)).norm() < 1e-9, "momentum");
}

#[test]
fn body_outputs_add_the_friction_force_and_its_torque() {
    // the sliding ball of the friction benchmarks (an explicit [[contact]] "floor" with
    // μ = 0.3), in a scene that also has a contact group, so that the body outputs exist
    let mut scene = contact_fmu::bench::scenes::sliding_ball(1.0, 0.3, 1e-4, 0.1, 1e-3);
    let p = scene.body[0].position;
    scene.shape.push(ShapeSpec::sphere("balls", "ball", p, BALL_RADIUS));
    scene
        .contact_group
        .push(ContactGroupSpec::new("ball_ball", "balls", "balls", Law::Hertz).stiffness(1e7));
    let mut s = start(scene);
    s.step_to(0.01).unwrap();
    let normal = get(&mut s, "floor.force");
    let friction = common::vec_out(&mut s, "floor.friction_force");
    let total = common::vec_out(&mut s, "ball.contact_force");
    let torque = common::vec_out(&mut s, "ball.contact_torque");
    // the contact point lies h = R − δ below the centre
    let h = BALL_RADIUS - get(&mut s, "floor.delta");
    let expect = Vector3::new(friction.x, friction.y, friction.z + normal);
    let expect_torque = Vector3::new(0.0, 0.0, -h).cross(&expect);
    println!("sliding ball: contact force {total:?}, torque {torque:?}");
    assert!(friction.x < -0.09, "sliding: friction {friction:?}");
    assert!((total - expect).norm() < 1e-12 * expect.norm());
    assert!((torque - expect_torque).norm() < 1e-12 * expect_torque.norm());
    assert_eq!(get(&mut s, "ball_ball.active_contacts"), 0.0);
}

/// A broad-phase margin far too small for the bodies' speeds (2e-15 m: the candidate pairs are
/// found again after every step, each step bounded to the time to move a part of the margin)
/// stops a communication step at `solver.max_steps` steps with a message that names the
/// margin, as one integrator and as islands, instead of running on without end (one
/// integrator's budget once applied to each advance between two searches, not to the step).
#[test]
fn a_margin_far_too_small_stops_at_the_step_budget() {
    for islands in [false, true] {
        let mut scene = Scene::from_file(&common::bundled("pile_of_balls")).unwrap();
        scene.broad_phase.margin = Some(2e-15);
        scene.solver.islands = islands;
        scene.solver.max_steps = 500;
        let mut s = start(scene);
        let before = s.counters().steps;
        match s.step_to(1e-3) {
            Err(SimError::StepLimit { message, time }) => {
                assert!(time < 1e-3, "islands = {islands}: stopped at {time}");
                assert!(
                    message.contains("solver.max_steps = 500"),
                    "islands = {islands}: {message}"
                );
                if !islands {
                    assert!(message.contains("broad_phase.margin = 2e-15 m"), "{message}");
                }
            }
            other => panic!("islands = {islands}: {other:?}"),
        }
        // one integrator: at most the budget; islands: at most the budget per island
        let steps = s.counters().steps - before;
        let bound = if islands { 500 * 27 } else { 500 };
        assert!(steps <= bound, "islands = {islands}: {steps} steps");
    }
}
