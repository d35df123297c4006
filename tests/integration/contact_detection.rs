//! Contact detection by hand and against finite differences on moving bodies: gaps, rates,
//! slip velocities, tangent rows, and the broad phase's bounding test keeping the event's sign.
//!
//! Run: `cargo test --release --test integration contact_detection:: -- --nocapture`.

use crate::common;

use super::contact::*;
use common::compile;
use contact_fmu::contact::{self, geometry, ContactElement, Shape};
use contact_fmu::kinematics;
use contact_fmu::scene::{BodySpec, ContactSpec, ContactType, ImpulseMethod, Law, Side};
use contact_fmu::scene_builder::{Cylinder, Plane, Sphere};
use contact_fmu::spatial::Frame;
use contact_fmu::spatial::Spatial;
use nalgebra::{UnitQuaternion, Vector3};
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------------------
// Detection geometry

pub(super) fn element(shape: Shape, center: Vector3<f64>, radius: f64) -> ContactElement {
    ContactElement {
        name: "c".into(),
        kind: match shape {
            Shape::Sphere { .. } => ContactType::SphereSphere,
            Shape::Plane { .. } => ContactType::SpherePlane,
            Shape::Cylinder { .. } => ContactType::SphereCylinder,
        },
        law: Law::Hertz,
        restitution: 1.0,
        sphere_body: Some(0),
        center,
        radius,
        body: Some(1),
        shape,
        stiffness: 1.0,
        stiffness_derived: false,
        exponent: 1.5,
        damping: 0.0,
        max_penetration: radius,
        min_impact_velocity: 1e-3,
        bound_radius: f64::INFINITY,
        impulse_method: ImpulseMethod::Exact,
        constraint_row: None,
        hysteresis: 0.0,
        friction: Default::default(),
    }
}

/// A body frame at `pos` with orientation `q`, centre-of-mass velocity `v` and angular
/// velocity `w` (world), no acceleration bias.
pub(super) fn frame(pos: Vector3<f64>, q: UnitQuaternion<f64>, v: Vector3<f64>, w: Vector3<f64>) -> Frame {
    Frame {
        pos,
        rot: *q.to_rotation_matrix().matrix(),
        quat: q,
        vel: Spatial::new(w, v - w.cross(&pos)),
        acc: Spatial::zero(),
    }
}

/// The frame after time `t` of motion with its constant spatial velocity (a screw motion,
/// zero spatial acceleration): orientation exp(ω t) q, centre by RK4 on ṗ = v_O + ω × p.
pub(super) fn advance(f: &Frame, t: f64) -> Frame {
    let w = f.vel.ang;
    let q = UnitQuaternion::from_scaled_axis(w * t) * f.quat;
    let n = 200;
    let h = t / n as f64;
    let mut p = f.pos;
    let rate = |p: Vector3<f64>| f.vel.lin + w.cross(&p);
    for _ in 0..n {
        let k1 = rate(p);
        let k2 = rate(p + k1 * (h / 2.0));
        let k3 = rate(p + k2 * (h / 2.0));
        let k4 = rate(p + k3 * h);
        p += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
    }
    Frame {
        pos: p,
        rot: *q.to_rotation_matrix().matrix(),
        quat: q,
        vel: f.vel,
        acc: Spatial::zero(),
    }
}

#[test]
fn detection_by_hand() {
    let id = UnitQuaternion::identity();
    let rz90 = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), PI / 2.0);
    let z = Vector3::zeros();
    // sphere-sphere: the sphere's centre sits 0.1 m along its body's y axis; the body turned
    // 90° about z puts it at (0.25, 0, 0); the other sphere (ρ = 0.2) at the origin.
    let c = element(
        Shape::Sphere { center: z, radius: 0.2 },
        Vector3::new(0.0, 0.1, 0.0),
        0.1,
    );
    let fs = frame(Vector3::new(0.35, 0.0, 0.0), rz90, z, z);
    let fo = frame(z, id, z, z);
    let g = geometry::detect(&c, &fs, &fo);
    assert!((g.delta - 0.05).abs() < 1e-15);
    assert!((g.normal - Vector3::x()).norm() < 1e-15);
    assert!((g.point - Vector3::new(0.175, 0.0, 0.0)).norm() < 1e-15);
    assert!(g.margin.is_infinite());
    assert!((contact::event_function(&c, &g) - 0.05).abs() < 1e-15);
    // sphere-plane: a 0.4 × 0.2 rectangle in its body's xy plane, the body at height 1 and
    // turned 90° about z (so its u axis is world y); sphere r = 0.1 centred 0.07 above it.
    let plane = Shape::Plane {
        origin: z,
        normal: Vector3::z(),
        u: Vector3::x(),
        v: Vector3::y(),
        half: [0.2, 0.1],
    };
    let c = element(plane, z, 0.1);
    let fo = frame(Vector3::new(0.0, 0.0, 1.0), rz90, z, z);
    let at = |x: f64, y: f64, h: f64| geometry::detect(&c, &frame(Vector3::new(x, y, 1.0 + h), id, z, z), &fo);
    let g = at(0.05, 0.15, 0.07);
    assert!((g.delta - 0.03).abs() < 1e-15);
    assert!((g.normal - Vector3::z()).norm() < 1e-15);
    assert!((g.point - Vector3::new(0.05, 0.15, 1.0)).norm() < 1e-15);
    // margins: along world y (the plane's u, half 0.2) 0.05; along world x (v, half 0.1) 0.05
    assert!((g.margin - 0.05).abs() < 1e-15);
    assert!((at(0.08, 0.0, 0.07).margin - 0.02).abs() < 1e-15);
    // off the patch, or through it past δ_max, or apart: the event function is negative
    assert!(contact::event_function(&c, &at(0.12, 0.0, 0.07)) < 0.0);
    assert!(contact::event_function(&c, &at(0.0, 0.0, -0.05)) < 0.0);
    assert!(contact::event_function(&c, &at(0.0, 0.0, 0.11)) < 0.0);
    assert!(contact::event_function(&c, &at(0.0, 0.0, 0.09)) > 0.0);
    // sphere-cylinder, outside: axis z through the origin, ρ = 1, length 0.4, θ in [0, π/2]
    // from x; sphere r = 0.1 at 45°, 1.05 from the axis, 0.1 up.
    let cyl = |inside: bool, range: [f64; 2]| Shape::Cylinder {
        point: z,
        axis: Vector3::z(),
        reference: Vector3::x(),
        radius: 1.0,
        half_length: if inside { 2.0 } else { 0.2 },
        theta_range: Some(range),
        inside,
    };
    let polar = |rho: f64, th: f64, h: f64| Vector3::new(rho * th.cos(), rho * th.sin(), h);
    let fo = frame(z, id, z, z);
    let c = element(cyl(false, [0.0, PI / 2.0]), z, 0.1);
    let g = geometry::detect(&c, &frame(polar(1.05, PI / 4.0, 0.1), id, z, z), &fo);
    assert!((g.delta - 0.05).abs() < 1e-14);
    assert!((g.normal - polar(1.0, PI / 4.0, 0.0)).norm() < 1e-15);
    assert!((g.point - polar(1.0, PI / 4.0, 0.1)).norm() < 1e-15);
    assert!((g.margin - 0.1).abs() < 1e-15, "length margin 0.2 − 0.1");
    let g = geometry::detect(&c, &frame(polar(1.05, 0.1, 0.0), id, z, z), &fo);
    assert!((g.margin - 0.1).abs() < 1e-14, "angular margin ρ θ");
    let g = geometry::detect(&c, &frame(polar(1.05, 1.8, 0.0), id, z, z), &fo);
    assert!((g.margin - (PI / 2.0 - 1.8)).abs() < 1e-14 && contact::event_function(&c, &g) < 0.0);
    let g = geometry::detect(&c, &frame(polar(1.05, 0.5, 0.25), id, z, z), &fo);
    assert!(contact::event_function(&c, &g) < 0.0, "beyond the length");
    // inside, an arc across ±π: [3π/4, 5π/4]
    let c = element(cyl(true, [0.75 * PI, 1.25 * PI]), z, 0.1);
    for (th, margin) in [
        (PI, 0.25 * PI),
        (-PI + 0.1, 0.25 * PI - 0.1),
        (PI - 0.1, 0.25 * PI - 0.1),
        (0.5 * PI, -0.25 * PI),
    ] {
        let g = geometry::detect(&c, &frame(polar(0.95, th, 0.0), id, z, z), &fo);
        assert!((g.delta - 0.05).abs() < 1e-14);
        assert!(
            (g.normal + polar(1.0, th, 0.0)).norm() < 1e-14,
            "normal points to the axis"
        );
        assert!(
            (g.margin - margin).abs() < 1e-14,
            "θ {th}: margin {} vs {margin}",
            g.margin
        );
    }
    // near the axis the sphere is apart from the concave surface
    let g = geometry::detect(&c, &frame(polar(0.5, PI, 0.0), id, z, z), &fo);
    assert!((g.delta + 0.4).abs() < 1e-14);
}

/// Two bodies that translate and rotate (constant twists), a sphere (r = 0.1, offset
/// `center` in the first body) and the four shapes on the second body placed near contact
/// with it: (sphere frame, other frame, centre, named shapes).
pub(super) fn moving_pair() -> (Frame, Frame, Vector3<f64>, Vec<(&'static str, Shape)>) {
    let q1 = UnitQuaternion::from_euler_angles(0.3, -0.2, 0.5);
    let q2 = UnitQuaternion::from_euler_angles(-0.4, 0.1, 0.2);
    let fs = frame(
        Vector3::new(0.1, 0.2, 0.3),
        q1,
        Vector3::new(0.3, -0.7, 0.2),
        Vector3::new(1.5, -2.0, 0.7),
    );
    let fo = frame(
        Vector3::new(0.05, 0.1, -0.2),
        q2,
        Vector3::new(-0.2, 0.4, 0.1),
        Vector3::new(-0.8, 1.1, 2.3),
    );
    let center = Vector3::new(0.02, -0.03, 0.01);
    let cw = fs.pos + fs.rot * center;
    let local = |p: Vector3<f64>| fo.rot.transpose() * (p - fo.pos);
    let ldir = |d: Vector3<f64>| fo.rot.transpose() * d;
    let shapes = vec![
        (
            "sphere",
            Shape::Sphere {
                center: local(cw - Vector3::new(0.0, 0.0, 0.27)),
                radius: 0.2,
            },
        ),
        (
            "plane",
            Shape::Plane {
                origin: local(cw - Vector3::new(0.01, 0.02, 0.08)),
                normal: ldir(Vector3::z()),
                u: ldir(Vector3::x()),
                v: ldir(Vector3::y()),
                half: [0.5, 0.5],
            },
        ),
        (
            "cylinder outside",
            Shape::Cylinder {
                point: local(cw - Vector3::new(0.0, 0.0, 0.58)),
                axis: ldir(Vector3::new(1.0, 0.2, 0.0).normalize()),
                reference: ldir(Vector3::z()),
                radius: 0.5,
                half_length: 1.0,
                theta_range: None,
                inside: false,
            },
        ),
        (
            "cylinder inside",
            Shape::Cylinder {
                point: local(cw + Vector3::new(0.0, 0.0, 0.42)),
                axis: ldir(Vector3::new(1.0, -0.3, 0.1).normalize()),
                reference: ldir(Vector3::z()),
                radius: 0.5,
                half_length: 1.0,
                theta_range: None,
                inside: true,
            },
        ),
    ];
    (fs, fo, center, shapes)
}

#[test]
fn detection_rates_on_moving_bodies_match_finite_differences() {
    // Both bodies translate and rotate (constant twists). δ̇ from detection and the
    // velocity-product part of the separation's second derivative (resting rows) against
    // central differences of δ along the motion.
    let (fs, fo, center, shapes) = moving_pair();
    let h = 1e-3;
    for (name, shape) in shapes {
        let c = element(shape, center, 0.1);
        let delta = |t: f64| geometry::detect(&c, &advance(&fs, t), &advance(&fo, t)).delta;
        let g = geometry::detect(&c, &fs, &fo);
        // central differences with one Richardson step (error O(h⁴))
        let d0 = delta(0.0);
        let first_d = |h: f64| (delta(h) - delta(-h)) / (2.0 * h);
        let second_d = |h: f64| (delta(h) - 2.0 * d0 + delta(-h)) / (h * h);
        let rate_fd = (4.0 * first_d(h / 2.0) - first_d(h)) / 3.0;
        let acc_fd = (4.0 * second_d(h / 2.0) - second_d(h)) / 3.0;
        let bias = geometry::separation_acceleration_bias(&c, &fs, &fo, &g);
        println!(
            "{name}: δ = {d0:.6}, δ̇ {:.12} (fd {rate_fd:.12}), s̈₀ {bias:.9} (fd {:.9})",
            g.delta_dot, -acc_fd
        );
        assert!(g.delta.abs() < 0.1, "{name}: set up near contact ({})", g.delta);
        assert!((g.delta_dot - rate_fd).abs() < 1e-9 * rate_fd.abs().max(1.0), "{name}");
        assert!(
            (bias + acc_fd).abs() < 1e-6 * acc_fd.abs().max(1.0),
            "{name}: {bias} vs {}",
            -acc_fd
        );
    }
}

#[test]
fn slip_velocity_matches_finite_differences_of_the_material_points() {
    // Both bodies translate and rotate; the slip velocity at the contact point (friction) is
    // checked against central differences of the positions of the two material points that
    // coincide with the contact point at t = 0, projected on the tangent plane. The rotation
    // of both bodies enters (ω × r of each): a sphere spinning about the normal slips along
    // nothing, one rolling at ω = v/R slips not at all; here everything moves.
    let (fs, fo, center, shapes) = moving_pair();
    for (_, shape) in shapes {
        let c = element(shape, center, 0.1);
        let g = geometry::detect(&c, &fs, &fo);
        let slip = contact::friction::slip_velocity(&fs, &fo, &g);
        // the material points at g.point, followed along the two screw motions
        let ps = fs.rot.transpose() * (g.point - fs.pos);
        let po = fo.rot.transpose() * (g.point - fo.pos);
        let rel = |t: f64| {
            let (a, b) = (advance(&fs, t), advance(&fo, t));
            (a.pos + a.rot * ps) - (b.pos + b.rot * po)
        };
        let h = 1e-4;
        let u = (rel(h) - rel(-h)) / (2.0 * h);
        let fd = u - g.normal * u.dot(&g.normal);
        let (t1, t2) = contact::friction::tangents(&g.normal);
        println!("{:?}: slip {:.12?}, fd {:.12?}", c.kind, slip.as_slice(), fd.as_slice());
        assert!(slip.dot(&g.normal).abs() < 1e-14, "{:?}: slip is tangential", c.kind);
        assert!((slip - fd).norm() < 1e-7 * fd.norm(), "{:?}: {slip} vs {fd}", c.kind);
        assert!((t1.dot(&g.normal)).abs() < 1e-15 && (t2.dot(&g.normal)).abs() < 1e-15);
        assert!(
            (t1.cross(&t2) - g.normal).norm() < 1e-15,
            "right-handed triad (n, t1, t2)"
        );
        assert!(fd.norm() > 0.1, "the test moves the contact point tangentially");
    }
}

#[test]
fn tangent_jacobian_rows_give_the_slip_of_a_spinning_ball() {
    // A free ball touching the floor, moving and spinning: the Jacobian rows of the two
    // tangent directions times q̇ equal the slip components, and the slip is the hand
    // computation v + ω × (−R n) of the contact point (the rotation enters as radius × ω).
    let v = Vector3::new(0.7, -0.3, 0.0);
    let w = Vector3::new(2.0, 5.0, -3.0);
    let scene = ball_on_floor(Law::Hertz, |c| c.friction(0.3), 0.0, 9.81, 0.0);
    let mut scene = scene.build();
    scene.body[0].velocity = v.into();
    scene.body[0].angular_velocity = w.into();
    let (m, mut d) = compile(scene);
    d.eval_state.copy_from_slice(&d.state);
    kinematics::kinematics(&m, &mut d);
    let g = contact::gap(&d, 0);
    let fs = kinematics::frame(&d, d.contacts[0].sphere_body);
    let slip = contact::friction::slip_velocity(&fs, &kinematics::frame(&d, None), &g);
    let by_hand = v + w.cross(&Vector3::new(0.0, 0.0, -R));
    let by_hand = by_hand - Vector3::z() * by_hand.z;
    assert!((slip - by_hand).norm() < 1e-14, "{slip} vs {by_hand}");
    let (t1, t2) = contact::friction::tangents(&g.normal);
    for t in [t1, t2] {
        let mut row = vec![0.0; m.nv];
        contact::friction::add_tangent_row(&m, &d.dof_s, &d.contacts[0], &g, &t, &mut row);
        let rate: f64 = row.iter().zip(&d.state[m.nq..m.nq + m.nv]).map(|(a, b)| a * b).sum();
        assert!((rate - slip.dot(&t)).abs() < 1e-14, "{rate} vs {}", slip.dot(&t));
    }
}

#[test]
fn broad_phase_keeps_the_event_sign() {
    // A free ball (r = 0.05) against a sphere, a plane and a cylinder on a second free body;
    // over many random poses the broad-phase event value has the exact one's sign, and it
    // does skip the far cases.
    let ball = || Sphere::new("ball", [0.0; 3], 0.05);
    let at = [0.0, 0.0, -1.0];
    let contacts = [
        ContactSpec::sphere_sphere("s", Law::Hertz, ball(), Sphere::new("other", at, 0.3)).max_penetration(0.2),
        ContactSpec::sphere_plane("p", Law::Hertz, ball(), "other", Plane::horizontal(at, [0.6, 0.4]))
            .max_penetration(0.3),
        ContactSpec::sphere_cylinder(
            "c",
            Law::Hertz,
            ball(),
            "other",
            Cylinder::new(at, [0.0, 1.0, 0.0], 0.3, 0.5),
        )
        .side(Side::Inside),
    ];
    let (m, mut d) = compile(
        header(0.0, 1e-8, 1e-12, 1e-3)
            .body(BodySpec::sphere("ball", 1.0, 0.05, [0.0; 3]))
            .body(BodySpec::sphere("other", 1.0, 0.05, at))
            .contacts(contacts.map(|c| c.stiffness(1e6))),
    );
    let mut seed: u64 = 12345;
    let mut rnd = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let (mut skipped, mut positive) = ([0; 3], [0; 3]);
    for _ in 0..20000 {
        let mut state = d.state.clone();
        let scale = 1.2;
        for b in 0..2 {
            let j = &m.joints[m.bodies[b].joint];
            let q = UnitQuaternion::from_euler_angles(3.0 * rnd(), 3.0 * rnd(), 3.0 * rnd()).into_inner();
            let p = [
                scale * rnd(),
                scale * rnd(),
                scale * rnd() - if b == 1 { 1.0 } else { 0.0 },
            ];
            state[j.qpos..j.qpos + 7].copy_from_slice(&[p[0], p[1], p[2], q.w, q.i, q.j, q.k]);
        }
        d.eval_state.copy_from_slice(&state);
        kinematics::kinematics(&m, &mut d);
        for i in 0..3 {
            let exact = contact::event_function(&d.contacts[i], &contact::gap(&d, i));
            let fast = contact::gap_event(&d, i);
            assert_eq!(
                exact > 0.0,
                fast > 0.0,
                "contact {i}: exact {exact}, broad phase {fast}"
            );
            if contact::broad_phase(&d.contacts[i], &d).is_some() {
                skipped[i] += 1;
            }
            if exact > 0.0 {
                positive[i] += 1;
            }
        }
    }
    println!("broad phase over 20000 random poses: skipped {skipped:?}, in contact {positive:?}");
    assert!(skipped.iter().all(|&n| n > 1000) && positive.iter().all(|&n| n > 10));
}
