//! Multibody dynamics checked against physics: conservation laws, closed-form kinematics and
//! motions, closed loops with redundant constraint rows, initial-velocity projection, and two
//! integration methods agreeing. Scenes are built inline with the scene builder.
//!
//! Run: `cargo test --release --test integration multibody:: -- --nocapture` (the measured numbers are
//! printed; docs/multibody.md quotes them).

use crate::common;

use common::{compile, energy_balance, get, open, quat_out, run, start, vec_out};
use contact_fmu::contact;
use contact_fmu::dynamics;
use contact_fmu::forward::Rhs;
use contact_fmu::integrator::OdeSystem;
use contact_fmu::kinematics;
use contact_fmu::scene::{
    BodySpec, ContactSpec, InputSpec, JointSpec, JointType, Law, MaterialSpec, Method, Scene, SpringDamperSpec, GROUND,
};
use contact_fmu::scene_builder::{Plane, SceneBuilder, Sphere};
use contact_fmu::simulation::Simulation;
use nalgebra::{Matrix3, Quaternion, Unit, UnitQuaternion, Vector3};
use std::f64::consts::PI;

const G: f64 = 9.81;

// ---------------------------------------------------------------------------------------------
// scene builders

/// A scene with `gravity`, 1 s in steps of 0.01 s by default, and this solver.
fn header(name: &str, gravity: [f64; 3], method: Method, rtol: f64, atol: f64, max_step: f64) -> SceneBuilder {
    SceneBuilder::new(name)
        .gravity(gravity)
        .experiment(1.0, 0.01)
        .solver(method, rtol, atol, max_step)
}

/// A body with its principal axes turned by `quat`.
fn body(name: &str, mass: f64, inertia: [f64; 3], pos: Vector3<f64>, quat: UnitQuaternion<f64>) -> BodySpec {
    BodySpec::new(name, mass, inertia, pos.into()).orientation(quat)
}

/// A joint at `anchor`, with an axis when given.
fn joint(
    name: &str,
    kind: JointType,
    parent: &str,
    child: &str,
    anchor: Vector3<f64>,
    axis: Option<Vector3<f64>>,
) -> JointSpec {
    let j = JointSpec::new(name, kind, parent, child).anchor(anchor);
    match axis {
        Some(a) => j.axis(a),
        None => j,
    }
}

fn at_rest() -> Vector3<f64> {
    Vector3::zeros()
}

fn ident() -> UnitQuaternion<f64> {
    UnitQuaternion::identity()
}

/// Rotation by `psi` about −y: maps x to (cos ψ, 0, sin ψ), so that angles in the x–z plane
/// are measured counter-clockwise from x towards z.
fn planar(psi: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::new(0.0, -1.0, 0.0)), psi)
}

fn xz(x: f64, z: f64) -> Vector3<f64> {
    Vector3::new(x, 0.0, z)
}

/// Slender-rod inertia (principal axis 1 along the rod).
fn rod_inertia(m: f64, l: f64) -> [f64; 3] {
    [m * l * l * 1e-3, m * l * l / 12.0, m * l * l / 12.0]
}

// ---------------------------------------------------------------------------------------------
// simulation helpers

fn warnings(s: &mut Simulation) -> Vec<String> {
    s.warnings().unwrap_or_default()
}

/// World inertia about the centre of mass of a body from its outputs.
fn world_inertia(s: &mut Simulation, body: &str, principal: [f64; 3]) -> Matrix3<f64> {
    let r = quat_out(s, body).to_rotation_matrix();
    r.matrix() * Matrix3::from_diagonal(&Vector3::from(principal)) * r.matrix().transpose()
}

// ---------------------------------------------------------------------------------------------
// double pendulum: energy

fn double_pendulum(method: Method, rtol: f64, atol: f64) -> Scene {
    // principal axes tilted so that the world inertias are full 3x3 matrices
    let tilt = UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::new(1.0, 0.4, -0.3)), 0.5);
    header("double_pendulum", [0.0, 0.0, -G], method, rtol, atol, 0.05)
        .body(body("upper", 1.0, [0.004, 0.09, 0.092], xz(0.5, 0.0), tilt))
        .body(body("lower", 0.6, [0.003, 0.05, 0.051], xz(1.3, -0.4), tilt.inverse()))
        .joint(JointSpec::revolute("shoulder", GROUND, "upper", [0.0; 3], Vector3::y()))
        .joint(JointSpec::revolute(
            "elbow",
            "upper",
            "lower",
            xz(1.0, 0.0),
            Vector3::y(),
        ))
        .build()
}

#[test]
fn double_pendulum_conserves_energy() {
    let mut s = start(double_pendulum(Method::Dopri5, 1e-10, 1e-12));
    assert!(warnings(&mut s).is_empty(), "{:?}", warnings(&mut s));
    let e0 = get(&mut s, "energy.total");
    let (mut max_drift, mut ke_max, mut turns) = (0.0_f64, 0.0_f64, 0.0_f64);
    run(&mut s, 10.0, 0.01, |s, _| {
        max_drift = max_drift.max((get(s, "energy.total") - e0).abs());
        ke_max = ke_max.max(get(s, "energy.kinetic"));
        turns = turns.max(get(s, "elbow.q").abs());
    });
    let rel = max_drift / ke_max;
    let steps = get(&mut s, "solver.steps");
    eprintln!("double pendulum 10 s rtol 1e-10: max |ΔE|/KE_max = {rel:.3e} (KE_max = {ke_max:.3} J, {steps} steps)");
    assert!(turns > 1.0, "the elbow hardly moved: {turns}");
    assert!(rel < 1e-8, "relative energy drift {rel:.3e}");
}

// ---------------------------------------------------------------------------------------------
// free body tumbling without gravity

#[test]
fn free_body_conserves_angular_momentum_and_energy() {
    let principal = [1.0, 2.0, 3.0];
    let q0 = UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::new(0.2, 1.0, 0.5)), 0.7);
    // spin mostly about the intermediate axis: the body tumbles (Dzhanibekov flips)
    let omega0 = q0 * Vector3::new(0.2, 3.0, 0.1);
    let brick = body("brick", 2.0, principal, Vector3::new(0.1, -0.2, 0.3), q0)
        .velocity([0.5, 0.0, -0.2])
        .angular_velocity(omega0);
    let mut s = start(header("tumbling", [0.0; 3], Method::Dopri5, 1e-12, 1e-14, 0.05).body(brick));
    let momentum = |s: &mut Simulation| -> (Vector3<f64>, f64) {
        let i_w = world_inertia(s, "brick", principal);
        let w = vec_out(s, "brick.w");
        (i_w * w, get(s, "energy.total"))
    };
    let (l0, e0) = momentum(&mut s);
    let (mut dl, mut de, mut flips) = (0.0_f64, 0.0_f64, 0);
    let mut last_sign = 1.0;
    run(&mut s, 10.0, 0.01, |s, _| {
        let (l, e) = momentum(s);
        dl = dl.max((l - l0).norm() / l0.norm());
        de = de.max((e - e0).abs() / e0);
        // the body's second principal axis in the world, against L: sign changes are flips
        let axis2 = quat_out(s, "brick") * Vector3::y();
        let sign = axis2.dot(&l0).signum();
        if sign != last_sign {
            flips += 1;
            last_sign = sign;
        }
    });
    let r = get(&mut s, "brick.r[1]");
    eprintln!("free body 10 s rtol 1e-12: |ΔL|/|L| = {dl:.3e}, |ΔE|/E = {de:.3e}, {flips} flips");
    assert!(flips >= 2, "the body did not tumble ({flips} flips)");
    assert!((r - (0.1 + 0.5 * 10.0)).abs() < 1e-9, "centre of mass x = {r}");
    assert!(dl < 1e-10, "angular momentum drift {dl:.3e}");
    assert!(de < 1e-10, "energy drift {de:.3e}");
}

// ---------------------------------------------------------------------------------------------
// closed loops: four-bar linkage and slider-crank, planar mechanisms from 3-D joints

/// Intersection of the circles |X − B| = b and |X − D| = c in the x–z plane, on the side of
/// positive z relative to the line B→D (the assembly branch used throughout).
fn circle_intersection(bp: Vector3<f64>, b: f64, dp: Vector3<f64>, c: f64) -> Vector3<f64> {
    let e = dp - bp;
    let dist = e.norm();
    let u = e / dist;
    let along = (b * b - c * c + dist * dist) / (2.0 * dist);
    let h = (b * b - along * along).sqrt();
    let n = Vector3::new(-u.z, 0.0, u.x); // u rotated by +90° in the x–z plane
    bp + u * along + n * h
}

/// Angle of a vector in the x–z plane.
fn angle_xz(v: Vector3<f64>) -> f64 {
    v.z.atan2(v.x)
}

/// Central-difference derivative of a vector function of the crank angle.
fn d_dtheta(f: &dyn Fn(f64) -> Vector3<f64>, th: f64) -> Vector3<f64> {
    let h = 1e-5;
    (f(th + h) - f(th - h)) / (2.0 * h)
}

/// Four-bar: ground pivots A = 0 and D = (d, 0, 0), crank a, coupler b, rocker c
/// (a Grashof crank-rocker: the crank turns fully).
const FB: (f64, f64, f64, f64) = (0.2, 0.7, 0.5, 0.6);

fn four_bar_c(th: f64) -> Vector3<f64> {
    let (a, b, c, d) = FB;
    circle_intersection(xz(a * th.cos(), a * th.sin()), b, xz(d, 0.0), c)
}

/// Four-bar scene at crank angle `th0` turning at `rate` [rad/s]. Joint axes are given both
/// ways (+y and −y), as users do.
fn four_bar(method: Method, rtol: f64, th0: f64, rate: f64) -> Scene {
    four_bar_in(ident(), method, rtol, th0, rate)
}

/// The four-bar of [`four_bar`] with its plane turned by `frame` (gravity stays along −z).
fn four_bar_in(frame: UnitQuaternion<f64>, method: Method, rtol: f64, th0: f64, rate: f64) -> Scene {
    let (a, b, c, d) = FB;
    let pa = Vector3::zeros();
    let pb = |th: f64| xz(a * th.cos(), a * th.sin());
    let pd = xz(d, 0.0);
    let crank_com = |th: f64| pb(th) / 2.0;
    let coupler_com = |th: f64| (pb(th) + four_bar_c(th)) / 2.0;
    let rocker_com = |th: f64| (four_bar_c(th) + pd) / 2.0;
    let coupler_angle = |th: f64| angle_xz(four_bar_c(th) - pb(th));
    let rocker_angle = |th: f64| angle_xz(four_bar_c(th) - pd);
    let spin = |dpsi: f64| frame * Vector3::new(0.0, -dpsi * rate, 0.0);
    let h = 1e-5;
    let dang = |f: &dyn Fn(f64) -> f64| (f(th0 + h) - f(th0 - h)) / (2.0 * h);
    // a link: mass, length, centre of mass and angle in the x–z plane as functions of the
    // crank angle, and the rate of that angle per crank rate
    let link = |name: &str, m: f64, l: f64, com: &dyn Fn(f64) -> Vector3<f64>, angle: f64, dpsi: f64| {
        body(name, m, rod_inertia(m, l), frame * com(th0), frame * planar(angle))
            .velocity(frame * d_dtheta(com, th0) * rate)
            .angular_velocity(spin(dpsi))
    };
    let revolute = |name: &str, parent: &str, child: &str, anchor: Vector3<f64>, axis: Vector3<f64>| {
        JointSpec::revolute(name, parent, child, frame * anchor, frame * axis)
    };
    header("four_bar", [0.0, 0.0, -G], method, rtol, rtol * 1e-2, 0.05)
        .body(link("crank", 1.0, a, &crank_com, th0, 1.0))
        .body(link(
            "coupler",
            1.5,
            b,
            &coupler_com,
            coupler_angle(th0),
            dang(&coupler_angle),
        ))
        .body(link(
            "rocker",
            1.2,
            c,
            &rocker_com,
            rocker_angle(th0),
            dang(&rocker_angle),
        ))
        .joint(revolute("crank_pivot", GROUND, "crank", pa, -Vector3::y()))
        .joint(revolute("crank_pin", "crank", "coupler", pb(th0), Vector3::y()))
        .joint(revolute("rocker_pivot", GROUND, "rocker", pd, -Vector3::y()))
        .joint(revolute(
            "coupler_pin",
            "coupler",
            "rocker",
            four_bar_c(th0),
            Vector3::y(),
        ))
        .build()
}

#[test]
fn four_bar_keeps_its_loop_closed() {
    check_four_bar(ident(), 2.0 * PI);
}

#[test]
fn four_bar_in_a_tilted_plane_keeps_its_loop_closed() {
    // the dependent rows of Φ_q are no longer zero rows but combinations of the others
    let frame = UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::new(1.0, 1.0, 1.0)), 0.9);
    check_four_bar(frame, 5.0 * PI);
}

fn check_four_bar(frame: UnitQuaternion<f64>, rate: f64) {
    let th0 = 1.0;
    let mut s = start(four_bar_in(frame, Method::Dopri5, 1e-8, th0, rate));
    assert!(warnings(&mut s).is_empty(), "{:?}", warnings(&mut s));
    assert_eq!(s.data().unwrap().nc, 5);
    let e0 = get(&mut s, "energy.total");
    let psi0 = angle_xz(four_bar_c(th0) - xz(FB.3, 0.0));
    let (mut resid, mut de, mut dpsi, mut ke_max) = (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64);
    run(&mut s, 10.0, 0.01, |s, _| {
        resid = resid.max(s.constraint_residual().unwrap());
        de = de.max((get(s, "energy.total") - e0).abs());
        ke_max = ke_max.max(get(s, "energy.kinetic"));
        // the rocker angle is a closed-form function of the crank angle
        let th = th0 + get(s, "crank_pivot.q");
        let psi = psi0 + get(s, "rocker_pivot.q");
        let expect = angle_xz(four_bar_c(th) - xz(FB.3, 0.0));
        dpsi = dpsi.max((psi - expect).abs());
    });
    let turns = get(&mut s, "crank_pivot.q") / (2.0 * PI);
    let rank = s.data().unwrap().schur_rank;
    eprintln!(
        "four-bar (plane turned {:.2} rad) 10 s rtol 1e-8: max |Φ| = {resid:.3e} m, rocker angle error {dpsi:.3e} rad, |ΔE|/KE_max = {:.3e}, {turns:.1} crank turns, constraint rank {rank} of 5",
        frame.angle(),
        de / ke_max
    );
    assert!(turns.abs() > 3.0, "the crank did not turn: {turns}");
    assert_eq!(
        rank, 2,
        "a planar four-bar closed by a 3-D revolute has 2 independent rows"
    );
    assert!(resid < 1e-9, "constraint residual {resid:.3e}");
    assert!(dpsi < 1e-8, "rocker angle off the closed form by {dpsi:.3e}");
    assert!(de / ke_max < 1e-6, "energy drift {:.3e}", de / ke_max);
}

/// The crank's pivot of the planar mechanisms: at the origin, about −y.
fn crank_pivot() -> JointSpec {
    JointSpec::revolute("crank_pivot", GROUND, "crank", [0.0; 3], -Vector3::y())
}

/// Slider-crank: crank radius r about the origin, rod length l, slider on the line z = e.
const SC: (f64, f64, f64) = (0.1, 0.4, 0.03);

/// Slider position x(θ) = r cos θ + sqrt(l² − (r sin θ − e)²).
fn slider_x(th: f64) -> f64 {
    let (r, l, e) = SC;
    r * th.cos() + (l * l - (r * th.sin() - e).powi(2)).sqrt()
}

/// Slider-crank scene; `close_at_slider` puts the prismatic joint last (it closes the loop),
/// otherwise the rod–slider revolute closes it.
fn slider_crank(method: Method, rtol: f64, th0: f64, rate: f64, close_at_slider: bool) -> Scene {
    let (r, l, e) = SC;
    let pb = |th: f64| xz(r * th.cos(), r * th.sin());
    let pc = |th: f64| xz(slider_x(th), e);
    let rod_com = |th: f64| (pb(th) + pc(th)) / 2.0;
    let rod_angle = |th: f64| angle_xz(pc(th) - pb(th));
    let h = 1e-5;
    let drod = (rod_angle(th0 + h) - rod_angle(th0 - h)) / (2.0 * h);
    let slide = JointSpec::prismatic("slide", GROUND, "slider", pc(th0), Vector3::x());
    let wrist = JointSpec::revolute("wrist", "rod", "slider", pc(th0), Vector3::y());
    let last_two = if close_at_slider {
        [wrist, slide]
    } else {
        [slide, wrist]
    };
    let mut t = header("slider_crank", [0.0, 0.0, -G], method, rtol, rtol * 1e-2, 0.05)
        .body(
            body("crank", 2.0, [0.004, 0.006, 0.008], pb(th0) * 0.3, ident())
                .velocity(d_dtheta(&|th| pb(th) * 0.3, th0) * rate)
                .angular_velocity([0.0, -rate, 0.0]),
        )
        .body(
            body("rod", 1.0, rod_inertia(1.0, l), rod_com(th0), planar(rod_angle(th0)))
                .velocity(d_dtheta(&rod_com, th0) * rate)
                .angular_velocity([0.0, -drod * rate, 0.0]),
        )
        .body(body("slider", 0.5, [0.001, 0.001, 0.001], pc(th0), ident()).velocity(d_dtheta(&pc, th0) * rate))
        .joint(crank_pivot())
        .joint(JointSpec::revolute("crank_pin", "crank", "rod", pb(th0), -Vector3::y()));
    for j in last_two {
        t = t.joint(j);
    }
    t.build()
}

fn check_slider_crank(close_at_slider: bool) {
    let th0 = 2.0;
    let mut s = start(slider_crank(Method::Dopri5, 1e-8, th0, 3.0 * PI, close_at_slider));
    assert!(warnings(&mut s).is_empty(), "{:?}", warnings(&mut s));
    let e0 = get(&mut s, "energy.total");
    let (mut resid, mut dx, mut de, mut ke_max) = (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64);
    let mut dead_centres = 0;
    let (mut rank_min, mut rank_max) = (usize::MAX, 0);
    let mut last_sector = (th0 / PI).floor();
    run(&mut s, 10.0, 0.005, |s, _| {
        resid = resid.max(s.constraint_residual().unwrap());
        let r = s.data().unwrap().schur_rank;
        (rank_min, rank_max) = (rank_min.min(r), rank_max.max(r));
        de = de.max((get(s, "energy.total") - e0).abs());
        ke_max = ke_max.max(get(s, "energy.kinetic"));
        let th = th0 + get(s, "crank_pivot.q");
        dx = dx.max((get(s, "slider.r[1]") - slider_x(th)).abs());
        let sector = (th / PI).floor();
        if sector != last_sector {
            dead_centres += 1;
            last_sector = sector;
        }
    });
    eprintln!(
        "slider-crank (loop closed at the {}) 10 s rtol 1e-8: max |Φ| = {resid:.3e}, |x − x(θ)| = {dx:.3e} m, |ΔE|/KE_max = {:.3e}, {dead_centres} dead-centre passages, rank {rank_min}..{rank_max} of 5",
        if close_at_slider { "prismatic" } else { "wrist revolute" },
        de / ke_max
    );
    assert!(dead_centres >= 4, "the crank passed only {dead_centres} dead centres");
    assert_eq!(
        (rank_min, rank_max),
        (2, 2),
        "the constraint rank changed along the way"
    );
    assert!(resid < 1e-9, "constraint residual {resid:.3e}");
    assert!(dx < 1e-8, "slider off its closed-form position by {dx:.3e} m");
    assert!(de / ke_max < 1e-6, "energy drift {:.3e}", de / ke_max);
}

#[test]
fn slider_crank_closed_by_revolute_follows_closed_form() {
    check_slider_crank(false);
}

#[test]
fn slider_crank_closed_by_prismatic_follows_closed_form() {
    check_slider_crank(true);
}

// ---------------------------------------------------------------------------------------------
// pendulum: small-oscillation period

/// Zero crossings of a sampled signal, located on the cubic through the four samples around
/// each sign change.
fn zero_crossings(t: &[f64], y: &[f64]) -> Vec<f64> {
    let mut out = Vec::new();
    for i in 1..y.len().saturating_sub(2) {
        if (y[i] > 0.0) != (y[i + 1] > 0.0) {
            let (ts, ys) = (&t[i - 1..i + 3], &y[i - 1..i + 3]);
            let p = |x: f64| -> f64 {
                (0..4)
                    .map(|a| {
                        let mut l = ys[a];
                        for b in 0..4 {
                            if a != b {
                                l *= (x - ts[b]) / (ts[a] - ts[b]);
                            }
                        }
                        l
                    })
                    .sum()
            };
            let (mut lo, mut hi) = (t[i], t[i + 1]);
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if (p(mid) > 0.0) == (p(lo) > 0.0) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            out.push(0.5 * (lo + hi));
        }
    }
    out
}

#[test]
fn pendulum_small_oscillation_period() {
    let (m, d) = (1.3, 0.35);
    let principal = [0.02, 0.05, 0.04];
    let q0 = UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::new(0.3, -0.5, 1.0)), 0.8);
    let r = q0.to_rotation_matrix();
    let i_c = r.matrix() * Matrix3::from_diagonal(&Vector3::from(principal)) * r.matrix().transpose();
    let axis = Vector3::y();
    let i_pivot = axis.dot(&(i_c * axis)) + m * d * d;
    let omega_n = (m * G * d / i_pivot).sqrt();
    let amplitude = 1e-4;
    let w0 = axis * amplitude * omega_n;
    let com = Vector3::new(0.0, 0.0, -d);
    let mut s = start(
        header("pendulum", [0.0, 0.0, -G], Method::Dopri5, 1e-12, 1e-17, 0.05)
            .body(
                body("bob", m, principal, com, q0)
                    .velocity(w0.cross(&com))
                    .angular_velocity(w0),
            )
            .joint(JointSpec::revolute("pivot", GROUND, "bob", [0.0; 3], axis)),
    );
    assert!(warnings(&mut s).is_empty(), "{:?}", warnings(&mut s));
    let period = 2.0 * PI / omega_n;
    let dt = 1e-3;
    let (mut ts, mut qd) = (Vec::new(), Vec::new());
    run(&mut s, 10.0 * period, dt, |s, t| {
        ts.push(t);
        qd.push(get(s, "pivot.qd"));
    });
    let z = zero_crossings(&ts, &qd);
    assert!(z.len() >= 18, "{} crossings", z.len());
    let measured = 2.0 * (z[z.len() - 1] - z[0]) / (z.len() - 1) as f64;
    // finite-amplitude correction T = T0 (1 + θ0²/16 + 11 θ0⁴/3072)
    let expected = period * (1.0 + amplitude * amplitude / 16.0 + 11.0 * amplitude.powi(4) / 3072.0);
    let rel = (measured - expected).abs() / expected;
    eprintln!(
        "pendulum period: measured {measured:.12} s, 2π sqrt(I/(m g d)) = {expected:.12} s, relative error {rel:.3e}"
    );
    assert!(rel < 1e-6, "period off by {rel:.3e}");
}

// ---------------------------------------------------------------------------------------------
// prismatic joint with a spring-damper: analytic motion

/// Mass on a tilted prismatic joint pulled by a spring from a ground point on the joint line;
/// gravity has a component along the line. Returns (scene, s_eq, ω) where s is the distance
/// from the attachment point.
fn spring_slider(damping: f64, method: Method, rtol: f64) -> (Scene, f64, f64) {
    let (m, k, free) = (2.0, 50.0, 0.8);
    let a = Vector3::new(1.0, 0.4, 0.6).normalize();
    let p_ground = Vector3::new(0.2, -0.1, 0.5);
    let c0 = p_ground + a;
    let q = UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::new(1.0, 1.0, 0.0)), 0.4);
    let t = header("spring_slider", [0.0, 0.0, -G], method, rtol, rtol * 1e-3, 0.05)
        .body(body("block", m, [0.01, 0.012, 0.015], c0, q))
        .joint(JointSpec::prismatic("slide", GROUND, "block", c0, a))
        .spring_damper(
            SpringDamperSpec::new("spring", GROUND, p_ground, "block", c0, k)
                .damping(damping)
                .free_length(free),
        );
    let g_along = Vector3::new(0.0, 0.0, -G).dot(&a);
    (t.build(), free + m * g_along / k, (k / m).sqrt())
}

fn check_spring_slider(damping: f64) {
    let (scene, s_eq, w) = spring_slider(damping, Method::Dopri5, 1e-10);
    let m = 2.0;
    let zeta = damping / (2.0 * m * w);
    let wd = w * (1.0 - zeta * zeta).sqrt();
    let a0 = 1.0 - s_eq;
    let exact = |t: f64| s_eq + (-zeta * w * t).exp() * (a0 * (wd * t).cos() + zeta * w * a0 / wd * (wd * t).sin());
    let mut s = start(scene);
    let e0 = get(&mut s, "energy.total");
    let (mut err, mut balance) = (0.0_f64, 0.0_f64);
    run(&mut s, 5.0, 0.01, |s, t| {
        err = err.max((1.0 + get(s, "slide.q") - exact(t)).abs());
        balance = balance.max((energy_balance(s) - e0).abs());
    });
    let ke = 0.5 * 50.0 * a0 * a0;
    eprintln!(
        "spring slider c = {damping}: max |s − s_exact| = {err:.3e} m (amplitude {a0:.3} m), energy balance {:.3e} of the spring energy",
        balance / ke
    );
    assert!(err < 1e-8 * a0.abs().max(1.0), "position error {err:.3e}");
    assert!(balance / ke < 1e-8, "energy balance {:.3e}", balance / ke);
}

#[test]
fn prismatic_spring_undamped_matches_analytic() {
    check_spring_slider(0.0);
}

#[test]
fn prismatic_spring_damped_matches_analytic() {
    check_spring_slider(2.0);
}

// ---------------------------------------------------------------------------------------------
// spherical pendulum: energy and the vertical angular momentum about the pivot

fn spherical_pendulum(method: Method, rtol: f64) -> Scene {
    let com = Vector3::new(0.3, 0.1, -0.4);
    let w0 = Vector3::new(0.5, 2.0, 1.0);
    let q = UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::new(0.2, -1.0, 0.4)), 1.1);
    header("spherical", [0.0, 0.0, -G], method, rtol, rtol * 1e-2, 0.05)
        .body(
            body("top", 1.5, [0.03, 0.05, 0.07], com, q)
                .velocity(w0.cross(&com))
                .angular_velocity(w0),
        )
        .joint(JointSpec::spherical("ball", GROUND, "top", [0.0; 3]))
        .build()
}

/// |Q| of the quaternion of the first joint (the spherical pendulum's ball joint).
fn first_joint_quaternion_norm(s: &mut Simulation) -> f64 {
    let j = s.model().unwrap().joints[0].qpos;
    s.data().unwrap().state[j..j + 4]
        .iter()
        .map(|x| x * x)
        .sum::<f64>()
        .sqrt()
}

#[test]
fn spherical_pendulum_conserves_energy_and_vertical_momentum() {
    let principal = [0.03, 0.05, 0.07];
    let mut s = start(spherical_pendulum(Method::Dopri5, 1e-10));
    assert!(warnings(&mut s).is_empty(), "{:?}", warnings(&mut s));
    let lz = |s: &mut Simulation| -> f64 {
        let i_w = world_inertia(s, "top", principal);
        let (r, v, w) = (vec_out(s, "top.r"), vec_out(s, "top.v"), vec_out(s, "top.w"));
        (i_w * w + 1.5 * r.cross(&v)).z
    };
    let (e0, l0) = (get(&mut s, "energy.total"), lz(&mut s));
    let (mut de, mut dl, mut ke_max, mut z_min, mut z_max) = (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64, -1.0_f64);
    run(&mut s, 10.0, 0.01, |s, _| {
        de = de.max((get(s, "energy.total") - e0).abs());
        dl = dl.max((lz(s) - l0).abs());
        ke_max = ke_max.max(get(s, "energy.kinetic"));
        let z = get(s, "top.r[3]");
        z_min = z_min.min(z);
        z_max = z_max.max(z);
    });
    let qn = first_joint_quaternion_norm(&mut s);
    eprintln!(
        "spherical pendulum 10 s rtol 1e-10: |ΔE|/KE_max = {:.3e}, |ΔL_z|/|L_z| = {:.3e}, z in [{z_min:.3}, {z_max:.3}], | |Q| − 1 | = {:.1e}",
        de / ke_max,
        dl / l0.abs(),
        (qn - 1.0).abs()
    );
    assert!(z_max - z_min > 0.05, "no 3-D motion");
    assert!(de / ke_max < 1e-8, "energy drift {:.3e}", de / ke_max);
    assert!(dl / l0.abs() < 1e-8, "L_z drift {:.3e}", dl / l0.abs());
    assert!((qn - 1.0).abs() < 1e-8, "joint quaternion norm {qn}");
}

#[test]
fn long_run_keeps_joint_quaternions_normalised() {
    // at a loose tolerance the norm of Q drifts by about rtol per second unless rescaled
    let mut s = start(spherical_pendulum(Method::Dopri5, 1e-6));
    s.step_to(200.0).unwrap();
    let qn = first_joint_quaternion_norm(&mut s);
    eprintln!(
        "spherical pendulum 200 s rtol 1e-6: | |Q| − 1 | = {:.2e}",
        (qn - 1.0).abs()
    );
    assert!(
        (qn - 1.0).abs() <= 2.0 * contact_fmu::dynamics::QUATERNION_NORM_TOL,
        "|Q| = {qn}"
    );
}

// ---------------------------------------------------------------------------------------------
// fixed joint: a welded pair moves like one body with the combined inertia

#[test]
fn fixed_joint_behaves_as_one_rigid_body() {
    let axis = Vector3::new(0.2, 1.0, -0.1).normalize();
    let (m1, m2) = (1.0, 0.7);
    let (p1, p2) = (Vector3::new(0.4, 0.0, -0.1), Vector3::new(0.6, 0.2, -0.5));
    let (q1, q2) = (
        UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::new(1.0, 0.0, 1.0)), 0.3),
        UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::new(0.0, 1.0, 1.0)), -0.6),
    );
    let (i1, i2) = ([0.01, 0.03, 0.035], [0.02, 0.02, 0.03]);
    let world = |q: UnitQuaternion<f64>, i: [f64; 3]| {
        let r = q.to_rotation_matrix();
        r.matrix() * Matrix3::from_diagonal(&Vector3::from(i)) * r.matrix().transpose()
    };
    // combined body: mass, centre of mass and inertia by the parallel-axis theorem
    let m = m1 + m2;
    let c = (p1 * m1 + p2 * m2) / m;
    let shift = |p: Vector3<f64>, mass: f64| {
        let d = p - c;
        (Matrix3::identity() * d.dot(&d) - d * d.transpose()) * mass
    };
    let i_c = world(q1, i1) + shift(p1, m1) + world(q2, i2) + shift(p2, m2);
    let eig = i_c.symmetric_eigen();
    let mut r = eig.eigenvectors;
    if r.determinant() < 0.0 {
        r.set_column(2, &(-r.column(2)));
    }
    let qc = UnitQuaternion::from_matrix(&r);
    let ic = [eig.eigenvalues[0], eig.eigenvalues[1], eig.eigenvalues[2]];

    let pivot = Vector3::zeros();
    let welded = header("welded", [0.0, 0.0, -G], Method::Dopri5, 1e-10, 1e-12, 0.05)
        .body(body("arm", m1, i1, p1, q1))
        .body(body("weight", m2, i2, p2, q2))
        .joint(JointSpec::revolute("pivot", GROUND, "arm", pivot, axis))
        .joint(joint("weld", JointType::Fixed, "arm", "weight", p2, None));
    let single = header("single", [0.0, 0.0, -G], Method::Dopri5, 1e-10, 1e-12, 0.05)
        .body(body("arm", m, ic, c, qc))
        .joint(JointSpec::revolute("pivot", GROUND, "arm", pivot, axis));

    let (mut a, mut b) = (start(welded), start(single));
    let rel0 = q1.inverse() * q2;
    let (mut dq, mut drigid) = (0.0_f64, 0.0_f64);
    let mut sb = Vec::new();
    run(&mut b, 3.0, 0.01, |s, _| sb.push(get(s, "pivot.q")));
    let mut k = 0;
    run(&mut a, 3.0, 0.01, |s, _| {
        dq = dq.max((get(s, "pivot.q") - sb[k]).abs());
        k += 1;
        let (ra, rw) = (vec_out(s, "arm.r"), vec_out(s, "weight.r"));
        let (qa, qw) = (quat_out(s, "arm"), quat_out(s, "weight"));
        // the weight stays where it was in the arm's frame
        let local = qa.inverse() * (rw - ra);
        drigid = drigid.max((local - q1.inverse() * (p2 - p1)).norm());
        drigid = drigid.max((qa.inverse() * qw).angle_to(&rel0));
    });
    let swing = sb.iter().fold(0.0_f64, |x, y| x.max(y.abs()));
    eprintln!("fixed joint: |q_welded − q_single| = {dq:.3e} rad (swing {swing:.2} rad), rigidity error {drigid:.3e}");
    assert!(swing > 0.5);
    assert!(dq < 1e-7, "welded pair and combined body differ by {dq:.3e} rad");
    assert!(drigid < 1e-12, "the weld moved by {drigid:.3e}");
}

// ---------------------------------------------------------------------------------------------
// free joint with a parent body: the child flies as if the parent were not there

#[test]
fn free_joint_on_a_moving_parent_is_ballistic() {
    let principal = [0.02, 0.04, 0.05];
    let (r0, v0) = (Vector3::new(1.2, 0.3, -0.2), Vector3::new(0.4, -0.2, 1.5));
    let q0 = UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::new(1.0, 2.0, 0.5)), 0.9);
    let w0 = Vector3::new(1.0, -2.0, 3.0);
    let pendulum = |with_child: bool| {
        // the arm's com velocity (0,1,0) × (0.5,0,0) must be given for consistency
        let arm = body("arm", 1.0, [0.01, 0.08, 0.08], xz(0.5, 0.0), ident())
            .velocity([0.0, 0.0, -0.5])
            .angular_velocity([0.0, 1.0, 0.0]);
        let t = header("free_child", [0.0, 0.0, -G], Method::Dopri5, 1e-11, 1e-13, 0.05)
            .body(arm)
            .joint(JointSpec::revolute("pivot", GROUND, "arm", [0.0; 3], Vector3::y()));
        if with_child {
            t.body(body("drone", 0.8, principal, r0, q0).velocity(v0).angular_velocity(w0))
                .joint(joint("tether", JointType::Free, "arm", "drone", r0, None))
        } else {
            t
        }
    };
    let (mut a, mut b) = (start(pendulum(true)), start(pendulum(false)));
    assert!(warnings(&mut a).is_empty(), "{:?}", warnings(&mut a));
    let mut arm_alone = Vec::new();
    run(&mut b, 2.0, 0.01, |s, _| arm_alone.push(get(s, "pivot.q")));
    let l0 = {
        let r = q0.to_rotation_matrix();
        r.matrix() * Matrix3::from_diagonal(&Vector3::from(principal)) * r.matrix().transpose() * w0
    };
    let (mut dr, mut dl, mut darm) = (0.0_f64, 0.0_f64, 0.0_f64);
    let mut k = 0;
    run(&mut a, 2.0, 0.01, |s, t| {
        let expect = r0 + v0 * t + Vector3::new(0.0, 0.0, -G) * (0.5 * t * t);
        dr = dr.max((vec_out(s, "drone.r") - expect).norm());
        let l = world_inertia(s, "drone", principal) * vec_out(s, "drone.w");
        dl = dl.max((l - l0).norm() / l0.norm());
        darm = darm.max((get(s, "pivot.q") - arm_alone[k]).abs());
        k += 1;
    });
    eprintln!(
        "free joint on a parent: ballistic error {dr:.3e} m, |ΔL|/|L| = {dl:.3e}, arm disturbed by {darm:.3e} rad"
    );
    assert!(dr < 1e-8, "centre of mass off the parabola by {dr:.3e} m");
    assert!(dl < 1e-8, "angular momentum drift {dl:.3e}");
    assert!(darm < 1e-8, "the child disturbed the parent by {darm:.3e} rad");
}

// ---------------------------------------------------------------------------------------------
// a chain driven by inputs: force on a carriage, joint force (or torque) on an arm

fn carriage_arm(arm_drive: &str) -> Scene {
    let motor = match arm_drive {
        "joint_force" => InputSpec::joint_force("motor", "hinge"),
        _ => InputSpec::torque("motor", "arm", [0.0, 0.0, 1.0]),
    };
    header("carriage_arm", [0.0, 0.0, -G], Method::Dopri5, 1e-11, 1e-13, 0.05)
        .body(body("carriage", 3.0, [0.05, 0.06, 0.07], Vector3::zeros(), ident()))
        .body(body(
            "arm",
            1.0,
            [0.002, 0.01, 0.011],
            Vector3::new(0.3, 0.0, 0.1),
            ident(),
        ))
        .joint(JointSpec::prismatic("rail", GROUND, "carriage", [0.0; 3], Vector3::x()))
        .joint(JointSpec::revolute(
            "hinge",
            "carriage",
            "arm",
            [0.0, 0.0, 0.1],
            Vector3::z(),
        ))
        .input(InputSpec::force("push", "carriage", [1.0, 0.0, 0.0]).start(2.0))
        .input(motor.start(0.5))
        .build()
}

#[test]
fn inputs_drive_a_chain_by_momentum_and_work() {
    let mut s = start(carriage_arm("joint_force"));
    let (mut dp, mut dw) = (0.0_f64, 0.0_f64);
    // momentum along the rail: dP/dt = F (the rail's reactions are normal to x);
    // kinetic energy = work of the inputs: F Δx + τ Δθ (gravity does no work on this chain)
    let (mut impulse, mut work, mut t_prev, mut x_prev, mut th_prev, mut f) = (0.0, 0.0, 0.0, 0.0, 0.0, 2.0);
    let tau = 0.5;
    let mut arm = Vec::new();
    run(&mut s, 3.0, 0.01, |s, t| {
        let x = get(s, "carriage.r[1]");
        let th = get(s, "hinge.q");
        impulse += f * (t - t_prev);
        work += f * (x - x_prev) + tau * (th - th_prev);
        let p = 3.0 * get(s, "carriage.v[1]") + 1.0 * get(s, "arm.v[1]");
        dp = dp.max((p - impulse).abs());
        dw = dw.max((get(s, "energy.kinetic") - work).abs());
        arm.push((th, get(s, "arm.r[2]")));
        (t_prev, x_prev, th_prev) = (t, x, th);
        if t >= 1.0 - 1e-12 && f == 2.0 {
            f = -1.0;
            s.set_by_name("push", f).unwrap();
        }
    });
    let turn = get(&mut s, "hinge.q");
    eprintln!("inputs: |P_x − ∫F dt| = {dp:.3e} N s, |KE − work| = {dw:.3e} J, arm turned {turn:.2} rad");
    assert!(turn > 1.0, "the arm did not turn ({turn})");
    assert!(dp < 1e-9, "momentum balance {dp:.3e}");
    assert!(dw < 1e-8, "work balance {dw:.3e}");

    // a body torque about the hinge axis moves the chain exactly like the joint force
    let mut s2 = start(carriage_arm("torque"));
    let mut k = 0;
    let mut diff = 0.0_f64;
    run(&mut s2, 3.0, 0.01, |s, t| {
        diff = diff
            .max((get(s, "hinge.q") - arm[k].0).abs())
            .max((get(s, "arm.r[2]") - arm[k].1).abs());
        k += 1;
        if t >= 1.0 - 1e-12 && k == 101 {
            s.set_by_name("push", -1.0).unwrap();
        }
    });
    eprintln!("torque input vs joint force: max difference {diff:.3e}");
    assert!(diff < 1e-9, "torque and joint force differ by {diff:.3e}");
}

// ---------------------------------------------------------------------------------------------
// initial velocities from body velocities (paper (35)-(37))

fn hinged(vel: Vector3<f64>, omega: Vector3<f64>) -> (Scene, Vector3<f64>, Vector3<f64>) {
    let axis = Vector3::new(0.3, 0.9, -0.2).normalize();
    let (pivot, com) = (Vector3::new(0.1, 0.2, 0.3), Vector3::new(0.5, 0.1, -0.1));
    let t = header("hinged", [0.0, 0.0, -G], Method::Dopri5, 1e-10, 1e-12, 0.05)
        .body(
            body("door", 2.0, [0.1, 0.2, 0.25], com, ident())
                .velocity(vel)
                .angular_velocity(omega),
        )
        .joint(JointSpec::revolute("hinge", GROUND, "door", pivot, axis));
    (t.build(), axis, com - pivot)
}

#[test]
fn initial_velocity_consistent_with_joint_gives_joint_rate() {
    let (_, axis, arm) = hinged(at_rest(), at_rest());
    let rate = 1.7;
    let (scene, ..) = hinged((axis * rate).cross(&arm), axis * rate);
    let mut s = start(scene);
    assert!(warnings(&mut s).is_empty(), "{:?}", warnings(&mut s));
    let qd = get(&mut s, "hinge.qd");
    let v = vec_out(&mut s, "door.v");
    assert!((qd - rate).abs() < 1e-12, "joint rate {qd}");
    assert!((v - (axis * rate).cross(&arm)).norm() < 1e-12);
}

#[test]
fn initial_velocity_inconsistent_with_joint_warns_and_projects() {
    let (_, axis, arm) = hinged(at_rest(), at_rest());
    // angular velocity about the hinge but no translation: least squares over
    // [v; ω] = [a × r; a] q̇ gives q̇ = ω (a·a) / (|a × r|² + 1)
    let rate = 1.7;
    let (scene, ..) = hinged(at_rest(), axis * rate);
    let mut s = start(scene);
    let w = warnings(&mut s);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].contains("inconsistent"), "{w:?}");
    let expect = rate / (axis.cross(&arm).norm_squared() + 1.0);
    let qd = get(&mut s, "hinge.qd");
    eprintln!(
        "inconsistent initial velocity: warning {:?}; q̇ = {qd} (least squares {expect})",
        w[0]
    );
    assert!((qd - expect).abs() < 1e-12, "joint rate {qd}, expected {expect}");
    // a velocity along the hinge axis cannot be followed at all: warned, rate unchanged
    let (scene, ..) = hinged((axis * rate).cross(&arm) + axis * 0.3, axis * rate);
    let mut s = start(scene);
    assert_eq!(warnings(&mut s).len(), 1);
    assert!((get(&mut s, "hinge.qd") - rate).abs() < 1e-12);
}

#[test]
fn initial_velocity_projected_onto_loop_constraints() {
    // only the crank of a four-bar is given its velocity: the tree's least squares leaves the
    // loop violated, the projection (28) fixes it and says so
    let mut scene = four_bar(Method::Dopri5, 1e-8, 1.0, 2.0 * PI);
    let rocker = scene.body.iter_mut().find(|b| b.name == "rocker").unwrap();
    (rocker.velocity, rocker.angular_velocity) = ([0.0; 3], [0.0; 3]);
    let mut s = start(scene);
    let w = warnings(&mut s);
    assert!(w.iter().any(|w| w.contains("loop constraints")), "{w:?}");
    s.constraint_residual().unwrap();
    let rate = s.data().unwrap().phi_dot.iter().fold(0.0_f64, |a, b| a.max(b.abs()));
    assert!(rate < 1e-12, "constraint rate after projection {rate:.3e}");
    assert!(
        get(&mut s, "rocker_pivot.qd").abs() > 0.1,
        "the rocker was left at rest"
    );
}

// ---------------------------------------------------------------------------------------------
// explicit and implicit methods agree

/// Runs `text` to `t_end` with the method chosen through the `solver.method` parameter;
/// returns the listed outputs at every 0.05 s.
fn trajectory(scene: &Scene, method: &str, rtol: f64, t_end: f64, outputs: &[&str]) -> (Vec<Vec<f64>>, f64) {
    let mut s = open(scene.clone());
    let vr = s.table().index_of("solver.method").unwrap();
    let value = match s.variables()[vr].vtype {
        contact_fmu::variables::VarType::Enumeration(e) => e.items().iter().find(|(n, _)| *n == method).unwrap().1,
        _ => unreachable!(),
    };
    s.set(vr, value as f64).unwrap();
    s.set_by_name("solver.rtol", rtol).unwrap();
    s.set_by_name("solver.atol", rtol * 1e-2).unwrap();
    s.initialize(0.0).unwrap();
    let mut out = Vec::new();
    run(&mut s, t_end, 0.05, |s, _| {
        out.push(outputs.iter().map(|n| get(s, n)).collect())
    });
    let steps = get(&mut s, "solver.steps");
    (out, steps)
}

#[test]
fn explicit_and_implicit_methods_agree() {
    let rtol = 1e-8;
    let cases: Vec<(&str, Scene, f64, Vec<&str>)> = vec![
        (
            "double pendulum",
            double_pendulum(Method::Dopri5, rtol, rtol),
            2.0,
            vec!["shoulder.q", "elbow.q"],
        ),
        (
            "four-bar",
            four_bar(Method::Dopri5, rtol, 1.0, 2.0 * PI),
            2.0,
            vec!["crank_pivot.q", "rocker_pivot.q"],
        ),
        (
            "slider-crank",
            slider_crank(Method::Dopri5, rtol, 2.0, 3.0 * PI, true),
            2.0,
            vec!["crank_pivot.q", "slider.r[1]"],
        ),
        (
            "spherical pendulum",
            spherical_pendulum(Method::Dopri5, rtol),
            2.0,
            vec!["top.r[1]", "top.r[2]", "top.r[3]"],
        ),
        (
            "damped spring",
            spring_slider(2.0, Method::Dopri5, rtol).0,
            2.0,
            vec!["slide.q"],
        ),
    ];
    // every adaptive implicit method offered by the solver.method enumeration
    let probe = open(cases[0].1.clone());
    let vr = probe.table().index_of("solver.method").unwrap();
    let implicit: Vec<&str> = match probe.variables()[vr].vtype {
        contact_fmu::variables::VarType::Enumeration(e) => e
            .items()
            .into_iter()
            .map(|(n, _)| n)
            .filter(|n| !["dopri5", "rk4"].contains(n))
            .collect(),
        _ => unreachable!(),
    };
    assert!(implicit.contains(&"sdirk"), "{implicit:?}");
    for (name, scene, t_end, outputs) in &cases {
        let (a, na) = trajectory(scene, "dopri5", rtol, *t_end, outputs);
        let scale = a.iter().flatten().fold(0.0_f64, |m, x| m.max(x.abs()));
        for method in &implicit {
            let (b, nb) = trajectory(scene, method, rtol, *t_end, outputs);
            let diff = a
                .iter()
                .flatten()
                .zip(b.iter().flatten())
                .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()));
            eprintln!("{name}: dopri5 ({na} steps) vs {method} ({nb} steps) over {t_end} s at rtol {rtol:e}: max difference {diff:.3e} of {scale:.3}");
            // both methods keep the local error near rtol; over a few hundred steps the global
            // difference stays within a couple of orders of magnitude of rtol
            assert!(
                diff < 100.0 * rtol * scale,
                "{name}: dopri5 and {method} differ by {diff:.3e} (scale {scale})"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// loop-constraint rows: values, rates and bias terms against finite differences

/// A non-planar chain (revolute, prismatic, spherical and revolute tree joints with skew axes)
/// closed back to the ground and onto itself by a revolute, a prismatic, a spherical and a
/// fixed loop joint, each tested on its own.
fn loop_zoo(closing: &str) -> Scene {
    let q = |x: f64, y: f64, z: f64, a: f64| {
        UnitQuaternion::from_axis_angle(&Unit::new_normalize(Vector3::new(x, y, z)), a)
    };
    // name, mass, principal moments, centre of mass, orientation (axis, angle)
    let links = [
        ("a", 1.0, [0.01, 0.02, 0.025], [0.3, 0.1, 0.0], (1.0, 0.2, 0.0, 0.3)),
        ("b", 1.2, [0.02, 0.02, 0.03], [0.6, 0.3, 0.2], (0.0, 1.0, 0.3, -0.4)),
        ("c", 0.8, [0.01, 0.015, 0.02], [0.8, 0.1, 0.5], (0.5, 0.5, 1.0, 0.7)),
        ("d", 0.5, [0.005, 0.006, 0.007], [1.0, -0.2, 0.6], (1.0, -1.0, 0.2, 1.2)),
    ];
    let t = header("zoo", [0.0, 0.0, -G], Method::Dopri5, 1e-8, 1e-10, 0.05)
        .bodies(links.map(|(name, m, inertia, com, (x, y, z, a))| body(name, m, inertia, com.into(), q(x, y, z, a))))
        .joint(JointSpec::revolute("j1", GROUND, "a", [0.0; 3], [0.1, 0.2, 1.0]))
        .joint(JointSpec::prismatic("j2", "a", "b", [0.5, 0.2, 0.1], [1.0, 0.3, -0.2]))
        .joint(JointSpec::spherical("j3", "b", "c", [0.7, 0.2, 0.4]))
        .joint(JointSpec::revolute("j4", "c", "d", [0.9, 0.0, 0.55], [-0.3, 1.0, 0.4]));
    let (kind, parent, anchor, axis) = match closing {
        "prismatic" => (
            JointType::Prismatic,
            "a",
            Vector3::new(1.1, -0.1, 0.7),
            Some(Vector3::new(0.2, -0.5, 1.0)),
        ),
        "spherical" => (JointType::Spherical, GROUND, Vector3::new(1.1, -0.1, 0.7), None),
        "fixed" => (JointType::Fixed, "b", Vector3::new(1.0, -0.3, 0.6), None),
        _ => (
            JointType::Revolute,
            GROUND,
            Vector3::new(1.1, -0.1, 0.7),
            Some(Vector3::new(0.4, 0.1, 1.0)),
        ),
    };
    if closing == "none" {
        t.build()
    } else {
        t.joint(joint("close", kind, parent, "d", anchor, axis)).build()
    }
}

/// Advances joint positions by the velocity-space increment `dv` (quaternions through the
/// exponential map in the child frame).
fn displaced(m: &contact_fmu::model::Model, qpos: &[f64], dv: &[f64]) -> Vec<f64> {
    let mut q = qpos.to_vec();
    for j in &m.joints {
        let (a, v) = (j.qpos, j.qvel);
        match j.nv() {
            1 => q[a] += dv[v],
            3 => {
                let r = UnitQuaternion::from_quaternion(Quaternion::new(q[a], q[a + 1], q[a + 2], q[a + 3]))
                    * UnitQuaternion::from_scaled_axis(Vector3::new(dv[v], dv[v + 1], dv[v + 2]));
                q[a..a + 4].copy_from_slice(&[r.w, r.i, r.j, r.k]);
            }
            _ => {}
        }
    }
    q
}

#[test]
fn loop_constraint_rows_match_finite_differences() {
    for closing in ["revolute", "prismatic", "spherical", "fixed"] {
        let (mut m, mut d) = compile(loop_zoo(closing));
        m.baumgarte = 0.0;
        let (nq, nv, nc) = (m.nq, m.nv, d.nc);
        assert!(nc > 0);
        // a state away from the initial one, with velocities and accelerations
        let mut state = d.state.clone();
        let offset: Vec<f64> = (0..nv).map(|k| 0.3 * ((k as f64 + 1.0) * 1.7).sin()).collect();
        let q1 = displaced(&m, &state[..nq], &offset);
        state[..nq].copy_from_slice(&q1);
        let qd: Vec<f64> = (0..nv).map(|k| 1.5 * ((k as f64 + 2.0) * 0.9).cos()).collect();
        let qdd: Vec<f64> = (0..nv).map(|k| 2.0 * ((k as f64 + 0.5) * 2.3).sin()).collect();
        state[nq..nq + nv].copy_from_slice(&qd);
        d.eval_state.copy_from_slice(&state);
        kinematics::kinematics(&m, &mut d);
        dynamics::constraints(&m, &mut d, contact::resting_rows);
        let (phi_q, rate, gamma) = (d.phi_q.clone(), d.phi_dot.clone(), d.gamma.clone());
        // Φ along q(t) = q ⊕ (t q̇ + t²/2 q̈)
        let mut phi_at = |t: f64| -> Vec<f64> {
            let dv: Vec<f64> = (0..nv).map(|k| t * qd[k] + 0.5 * t * t * qdd[k]).collect();
            let mut st = state.clone();
            st[..nq].copy_from_slice(&displaced(&m, &q1, &dv));
            d.eval_state.copy_from_slice(&st);
            kinematics::kinematics(&m, &mut d);
            dynamics::constraints(&m, &mut d, contact::resting_rows);
            d.phi.clone()
        };
        let h = 1e-4;
        let (pp, p0, pm) = (phi_at(h), phi_at(0.0), phi_at(-h));
        let (mut e1, mut e2) = (0.0_f64, 0.0_f64);
        for r in 0..nc {
            let fd1 = (pp[r] - pm[r]) / (2.0 * h);
            let fd2 = (pp[r] - 2.0 * p0[r] + pm[r]) / (h * h);
            // Φ̈ = Φ_q q̈ − γ with γ = −(Φ_q q̇)_q q̇ (no stabilisation)
            let exact2: f64 = (0..nv).map(|k| phi_q[r * nv + k] * qdd[k]).sum::<f64>() - gamma[r];
            e1 = e1.max((fd1 - rate[r]).abs());
            e2 = e2.max((fd2 - exact2).abs());
        }
        eprintln!("{closing} loop ({nc} rows): |Φ̇ − Φ_q q̇| = {e1:.2e}, |Φ̈ − (Φ_q q̈ − γ)| = {e2:.2e}");
        assert!(e1 < 1e-7, "{closing}: rate rows off by {e1:.3e}");
        assert!(e2 < 1e-5, "{closing}: bias terms off by {e2:.3e}");
    }
}

// ---------------------------------------------------------------------------------------------
// no allocation on the right-hand-side path

use crate::alloc_counter;

#[test]
fn right_hand_side_and_projection_do_not_allocate() {
    // a slider-crank whose slider presses on a stop through an active Hertz contact
    let mut stopped = slider_crank(Method::Dopri5, 1e-8, 2.0, 3.0, true);
    stopped.material.push(MaterialSpec::steel());
    let stop = Plane::new([0.2095, 0.0, 0.03], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.1, 0.1]);
    stopped.contact.push(
        ContactSpec::sphere_plane(
            "stop",
            Law::HertzLn,
            Sphere::new("slider", [0.2, 0.0, 0.03], 0.01),
            GROUND,
            stop,
        )
        .restitution(0.8)
        .materials("steel", "steel"),
    );
    for scene in [
        loop_zoo("prismatic"),
        slider_crank(Method::Dopri5, 1e-8, 2.0, 3.0, false),
        spherical_pendulum(Method::Dopri5, 1e-8),
        stopped,
    ] {
        let (m, mut d) = compile(scene);
        for mem in d.contact_memory.iter_mut() {
            mem.active = true;
            mem.impact_velocity = 0.1;
        }
        let mut state = d.state.clone();
        let mut dy = vec![0.0; m.nstate()];
        Rhs {
            model: &m,
            data: &mut d,
        }
        .rhs(0.0, &state, &mut dy);
        let mut moved = false;
        let n = alloc_counter::count(|| {
            for k in 0..10 {
                state[m.nq - 1] += 1e-7 * k as f64;
                Rhs {
                    model: &m,
                    data: &mut d,
                }
                .rhs(0.0, &state, &mut dy);
            }
            d.state.copy_from_slice(&state);
            moved = dynamics::project_state(&m, &mut d, dynamics::PROJECTION_TOL, contact::resting_rows);
        });
        assert!(dy.iter().all(|x| x.is_finite()));
        for (i, out) in d.contact_out.iter().enumerate() {
            assert!(out.force > 0.0, "contact {i} of {} carries no force", m.name);
        }
        assert_eq!(n, 0, "{} allocations on the right-hand-side path ({})", n, m.name);
        if d.nc > 0 {
            assert!(moved, "the perturbed state of {} was not projected", m.name);
            // the projected state satisfies Φ = 0 and Φ_q q̇ = 0
            let st = d.state.clone();
            d.eval_state.copy_from_slice(&st);
            kinematics::kinematics(&m, &mut d);
            dynamics::constraints(&m, &mut d, contact::resting_rows);
            let worst = |v: &[f64]| v.iter().fold(0.0_f64, |a, b| a.max(b.abs()));
            let (p, v) = (worst(&d.phi), worst(&d.phi_dot));
            eprintln!("{}: after projection |Φ| = {p:.1e}, |Φ_q q̇| = {v:.1e}", m.name);
            assert!(p < 1e-13 && v < 1e-12, "{}: |Φ| = {p:.3e}, |Φ_q q̇| = {v:.3e}", m.name);
        }
    }
}

#[test]
fn restored_state_continues_bit_for_bit_with_projection() {
    // a loose tolerance, so that the loop is projected after most steps
    let scene = slider_crank(Method::Dopri5, 1e-6, 2.0, 3.0 * PI, true);
    let outputs = ["crank_pivot.q", "slider.r[1]", "rod.q[2]", "energy.total"];
    let continue_for = |s: &mut Simulation, n: usize| -> Vec<u64> {
        let t0 = s.time();
        let mut out = Vec::new();
        for k in 1..=n {
            s.step_to(t0 + 0.01 * k as f64).unwrap();
            out.extend(outputs.map(|name| get(s, name).to_bits()));
        }
        out
    };
    let mut a = start(scene.clone());
    continue_for(&mut a, 50);
    let snap = a.snapshot(Vec::new());
    let tail_a = continue_for(&mut a, 50);
    // into a fresh simulation, and back into the original one
    let mut b = open(scene);
    b.restore(&snap).unwrap();
    let tail_b = continue_for(&mut b, 50);
    a.restore(&snap).unwrap();
    let tail_a2 = continue_for(&mut a, 50);
    assert!(tail_a == tail_b, "a restored copy diverged from the original");
    assert!(tail_a == tail_a2, "restoring into the same instance diverged");
}

// ---------------------------------------------------------------------------------------------
// every joint type in one chain: energy balance with and without a closed loop

#[test]
fn mixed_chain_conserves_energy_with_and_without_loops() {
    for (closing, damping) in [
        ("none", 0.0),
        ("none", 0.5),
        ("spherical", 0.0),
        ("revolute", 0.3),
        ("prismatic", 0.0),
    ] {
        let mut scene = loop_zoo(closing);
        (scene.solver.rtol, scene.solver.atol) = (1e-10, 1e-12);
        // a spring-damper between two moving bodies, stretched at the start
        scene.spring_damper.push(
            SpringDamperSpec::new("link", "b", [0.6, 0.3, 0.2], "d", [1.0, -0.2, 0.6], 40.0)
                .damping(damping)
                .free_length(0.4),
        );
        let mut s = start(scene);
        let e0 = get(&mut s, "energy.total");
        let (mut balance, mut ke_max, mut resid) = (0.0_f64, 0.0_f64, 0.0_f64);
        run(&mut s, 5.0, 0.01, |s, _| {
            balance = balance.max((energy_balance(s) - e0).abs());
            ke_max = ke_max.max(get(s, "energy.kinetic"));
            resid = resid.max(s.constraint_residual().unwrap());
        });
        let dissipated = get(&mut s, "energy.dissipated");
        eprintln!(
            "mixed chain, loop {closing}, damping {damping}: |E + E_diss − E0|/KE_max = {:.3e} (dissipated {dissipated:.3} J, KE_max {ke_max:.3} J), max |Φ| = {resid:.1e}",
            balance / ke_max
        );
        assert!(
            balance / ke_max < 1e-8,
            "{closing}: energy balance {:.3e}",
            balance / ke_max
        );
        assert!(
            damping == 0.0 || dissipated > 1e-3,
            "{closing}: the damper dissipated nothing"
        );
        assert!(resid < 1e-9, "{closing}: residual {resid:.3e}");
    }
}

/// A parallelogram four-bar passes its change points (all links collinear, where the loop
/// Jacobian loses rank) twice per turn; it must stay on the parallelogram branch, where the
/// rocker angle equals the crank angle.
#[test]
fn parallelogram_passes_its_change_points_on_its_branch() {
    let (a, d) = (0.3, 0.6);
    let th0 = 1.0_f64;
    let rate = 2.0 * PI;
    let b = xz(a * th0.cos(), a * th0.sin());
    let bd = xz(-a * th0.sin(), a * th0.cos()) * rate;
    let c = b + xz(d, 0.0);
    let spin = Vector3::new(0.0, -rate, 0.0);
    let mut s = start(
        header("parallelogram", [0.0, 0.0, 0.0], Method::Dopri5, 1e-8, 1e-10, 0.05)
            .body(
                body("crank", 1.0, rod_inertia(1.0, a), b / 2.0, planar(th0))
                    .velocity(bd / 2.0)
                    .angular_velocity(spin),
            )
            .body(body("coupler", 1.0, rod_inertia(1.0, d), (b + c) / 2.0, ident()).velocity(bd))
            .body(
                body("rocker", 1.0, rod_inertia(1.0, a), (c + xz(d, 0.0)) / 2.0, planar(th0))
                    .velocity(bd / 2.0)
                    .angular_velocity(spin),
            )
            .joint(crank_pivot())
            .joint(JointSpec::revolute("crank_pin", "crank", "coupler", b, Vector3::y()))
            .joint(JointSpec::revolute(
                "rocker_pivot",
                GROUND,
                "rocker",
                xz(d, 0.0),
                -Vector3::y(),
            ))
            .joint(JointSpec::revolute("coupler_pin", "coupler", "rocker", c, Vector3::y())),
    );
    let (mut dq, mut resid, mut rmin, mut rmax) = (0.0_f64, 0.0_f64, 9, 0);
    let mut fail = None;
    for k in 1..=500 {
        if let Err(e) = s.step_to(0.01 * k as f64) {
            fail = Some(e.to_string());
            break;
        }
        resid = resid.max(s.constraint_residual().unwrap());
        let r = s.data().unwrap().schur_rank;
        (rmin, rmax) = (rmin.min(r), rmax.max(r));
        dq = dq.max((get(&mut s, "rocker_pivot.q") - get(&mut s, "crank_pivot.q")).abs());
    }
    let turns = get(&mut s, "crank_pivot.q") / (2.0 * PI);
    eprintln!("parallelogram 5 s: {turns:.2} turns ({} change points), |q_rocker − q_crank| = {dq:.3e}, max |Φ| = {resid:.2e}, rank {rmin}..{rmax}", (2.0 * turns).floor());
    assert!(fail.is_none(), "{fail:?}");
    assert!(
        (turns - 5.0).abs() < 1e-6,
        "no gravity, no friction: 5 turns expected, got {turns}"
    );
    assert!(dq < 1e-8, "left the parallelogram branch: {dq:.3e}");
    assert!(resid < 1e-9, "residual {resid:.3e}");
}

// ---------------------------------------------------------------------------------------------
// the lean path of free bodies

/// The right-hand side at `y` by the engine's path (`lean`, what the integrators call) and by
/// the full evaluation (`general`: every body's kinematics and dynamics, the outputs' path).
fn lean_and_general(
    m: &contact_fmu::model::Model,
    d: &mut contact_fmu::model::Data,
    y: &[f64],
    lean: &mut [f64],
    general: &mut [f64],
) {
    Rhs { model: m, data: d }.rhs(0.0, y, lean);
    d.eval_state.copy_from_slice(y);
    assert!(contact_fmu::forward::evaluate(m, d));
    contact_fmu::forward::state_derivative(m, d, general);
}

#[test]
fn lean_right_hand_side_matches_the_general_path() {
    // A slider-crank (a loop: the general path) beside two free spheres, spinning, turned and
    // far from the origin, in contact with each other; a spring ties one to the crank, an input
    // force and torque act on the other.
    let mut scene = slider_crank(Method::Dopri5, 1e-8, 2.0, 3.0, false);
    scene.material.push(MaterialSpec::steel());
    let turned = UnitQuaternion::from_euler_angles(0.3, -0.7, 1.1);
    let a = body(
        "a",
        0.0329,
        [1.316e-6, 1.5e-6, 1.7e-6],
        Vector3::new(1.0, -2.0, 0.5),
        turned,
    )
    .velocity([0.3, -0.2, 0.1])
    .angular_velocity([4.0, -7.0, 11.0]);
    let b = body(
        "b",
        0.111,
        [9.99e-6, 9.99e-6, 1.2e-5],
        Vector3::new(1.0199, -2.0, 0.5),
        UnitQuaternion::identity(),
    )
    .velocity([-0.5, 0.0, 0.2])
    .angular_velocity([-3.0, 2.0, 5.0]);
    scene.contact.push(
        ContactSpec::sphere_sphere("ab", Law::HertzLn, Sphere::of(&a, 0.01), Sphere::of(&b, 0.01))
            .restitution(0.8)
            .materials("steel", "steel"),
    );
    scene
        .spring_damper
        .push(SpringDamperSpec::new("tie", "crank", [0.0, 0.0, 0.0], "a", [1.0, -2.0, 0.51], 50.0).damping(0.3));
    scene.input.push(InputSpec::force("push", "b", [0.0, 1.0, 0.0]));
    scene.input.push(InputSpec::torque("twist", "b", [1.0, 1.0, 0.0]));
    scene.body.push(a);
    scene.body.push(b);
    let (m, mut d) = compile(scene);
    assert_eq!(m.plan.free.len(), 2);
    assert!(!m.plan.general.joints.is_empty());
    d.inputs.iter_mut().enumerate().for_each(|(i, u)| *u = 0.7 + i as f64);
    for mem in d.contact_memory.iter_mut() {
        mem.active = true;
        mem.impact_velocity = 0.5;
    }
    let state = d.state.clone();
    let (mut lean, mut general) = (vec![0.0; m.nstate()], vec![0.0; m.nstate()]);
    for k in 0..5 {
        let mut y = state.clone();
        y[m.nq..m.nq + m.nv]
            .iter_mut()
            .enumerate()
            .for_each(|(i, v)| *v += 0.1 * (k * i) as f64 % 0.7);
        lean_and_general(&m, &mut d, &y, &mut lean, &mut general);
        assert!(d.contact_out.iter().any(|o| o.force > 0.0));
        let scale = general.iter().fold(0.0_f64, |a, x| a.max(x.abs()));
        let worst = lean
            .iter()
            .zip(&general)
            .fold(0.0_f64, |a, (x, g)| a.max((x - g).abs()));
        println!(
            "state {k}: largest |lean − general| = {:.2e} of the largest rate {scale:.3e}",
            worst / scale
        );
        for (i, (x, g)) in lean.iter().zip(&general).enumerate() {
            assert!(
                (x - g).abs() <= 1e-10 * scale,
                "state {k}, component {i}: lean {x:e}, general {g:e}"
            );
        }
    }
}

/// A wheel that carries a contact group's shape is a rotor only if no pair the broad phase
/// may list later breaks the rule (the plan is made once, at compilation): a sphere off the
/// axle, or any shape of a group that other spheres touch, makes its axle general even when
/// nothing is near at the start; a sphere on the axle, in a group that only touches, keeps it
/// a rotor.
#[test]
fn a_wheel_with_group_shapes_is_a_rotor_only_if_no_later_pair_breaks_the_rule() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/rail_vehicle/scene.toml");
    let base = std::fs::read_to_string(path).unwrap();
    let rotor = |shapes: &str| {
        // a floor far below the track: no pair is within reach at the start
        let text = format!(
            "{base}\n{shapes}\n[[shape]]\ngroup = \"floor\"\ntype = \"plane\"\nbody = \"ground\"\n\
             origin = [0.0, 0.0, -50.0]\nnormal = [0.0, 0.0, 1.0]\nu_axis = [1.0, 0.0, 0.0]\nsize = [1.0, 1.0]\n\n\
             [[contact_group]]\nname = \"bits_floor\"\ngroups = [\"bits\", \"floor\"]\nlaw = \"hertz\"\n\
             stiffness = 1e9\n"
        );
        let scene = contact_fmu::scene::Scene::from_str(&text, "wheel with shapes").unwrap();
        let (m, d) = contact_fmu::compile::compile(&scene, "wheel with shapes").unwrap();
        assert!(d.candidates.is_empty(), "no pair at the start: {:?}", d.candidates);
        let ji = m.joints.iter().position(|j| j.name == "axle_fl1").unwrap();
        m.plan.rotors[ji].is_some()
    };
    let sphere = |body: &str, center: [f64; 3], group: &str| {
        format!(
            "[[shape]]\ngroup = \"{group}\"\ntype = \"sphere\"\nbody = \"{body}\"\nradius = 0.05\n\
             center = [{}, {}, {}]\n",
            center[0], center[1], center[2]
        )
    };
    // the wheel's centre is (10, 0.75, 0.459974), its axle along y
    let on_axle = [10.0, 0.9, 0.459974];
    assert!(rotor(&sphere("wheel_fl1", on_axle, "bits")), "a sphere on the axle");
    assert!(
        !rotor(&sphere("wheel_fl1", [10.0, 0.75, 0.1], "bits")),
        "a sphere off the axle"
    );
    let touched = sphere("wheel_fl1", on_axle, "floor") + &sphere("bogie_fl", [10.0, 0.75, 0.8], "bits");
    assert!(!rotor(&touched), "a shape that spheres touch");
}

/// The rail vehicle's wheels are rotors (a revolute joint, the centre of mass and the spheres
/// on the axis, the inertia symmetric about it): the right-hand side skips their rotation by
/// the wheel angle and takes their world inertia from the axis. It gives the accelerations of
/// the full evaluation, which rotates each wheel by its angle, to rounding: over states with
/// the wheels turned by large angles, the car body pitched and rolled, every contact active.
/// A wheel whose inertia is not symmetric about its axle is no rotor.
#[test]
fn rotor_right_hand_side_matches_the_full_evaluation() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fmu/rail_vehicle/scene.toml");
    let scene = contact_fmu::scene::Scene::from_file(&path).unwrap();
    let (m, mut d) = contact_fmu::compile::compile(&scene, "rail").unwrap();
    let rotors: Vec<&str> = m
        .joints
        .iter()
        .zip(&m.plan.rotors)
        .filter(|(_, r)| r.is_some())
        .map(|(j, _)| j.name.as_str())
        .collect();
    assert_eq!(rotors.len(), 8, "{rotors:?}");
    assert!(rotors.iter().all(|n| n.starts_with("axle_")), "{rotors:?}");
    for mem in d.contact_memory.iter_mut() {
        mem.active = true;
        mem.impact_velocity = 0.05;
    }
    let state = d.state.clone();
    let n = m.nstate();
    let (mut lean, mut full) = (vec![0.0; n], vec![0.0; n]);
    for k in 0..6 {
        let mut y = state.clone();
        for (i, j) in m.joints.iter().enumerate() {
            if m.plan.rotors[i].is_some() {
                // wheel angles up to hundreds of radians, as after seconds of rolling
                y[j.qpos] = 37.0 * (k * (i + 1)) as f64 % 311.0 + 0.3;
            }
        }
        // pitch and roll the car body a little (its quaternion), and let it bounce
        let car = m.joints.iter().find(|j| j.parent.is_none()).unwrap();
        let (a, b) = (0.004 * k as f64, -0.003 * k as f64);
        let q = nalgebra::UnitQuaternion::from_euler_angles(a, b, 0.0);
        y[car.qpos + 3..car.qpos + 7].copy_from_slice(&[q.w, q.i, q.j, q.k]);
        y[m.nq + car.qvel + 2] = 0.05 * k as f64;
        lean_and_general(&m, &mut d, &y, &mut lean, &mut full);
        // each part against its own scale: position rates, accelerations, dissipated power
        for (part, range) in [("q̇", 0..m.nq), ("q̈", m.nq..m.nq + m.nv), ("power", m.nq + m.nv..n)] {
            let scale = full[range.clone()].iter().fold(0.0_f64, |a, x| a.max(x.abs()));
            let worst = lean[range.clone()]
                .iter()
                .zip(&full[range])
                .fold(0.0_f64, |a, (x, g)| a.max((x - g).abs()));
            println!(
                "state {k}: {part}: largest |rotor − full| = {:.2e} of {scale:.3e}",
                worst / scale
            );
            assert!(worst <= 1e-12 * scale, "state {k}, {part}: {worst:e} of {scale:e}");
        }
    }
    // a wheel with three different moments is no rotor
    let mut lopsided = scene.clone();
    lopsided
        .body
        .iter_mut()
        .find(|b| b.name == "wheel_fl1")
        .unwrap()
        .inertia = [35.0, 55.0, 36.0];
    let (m, _) = contact_fmu::compile::compile(&lopsided, "rail").unwrap();
    let is_rotor = |name: &str| {
        m.joints
            .iter()
            .zip(&m.plan.rotors)
            .any(|(j, r)| j.name == name && r.is_some())
    };
    assert!(!is_rotor("axle_fl1") && is_rotor("axle_fl2"));
    // and its row of the mass matrix is assembled, not taken as constant (constant_rows.rs)
    let constant = |name: &str| {
        m.joints
            .iter()
            .zip(&m.plan.constant_row)
            .any(|(j, &c)| j.name == name && c)
    };
    assert!(!constant("axle_fl1") && constant("axle_fl2"));
}
