//! The impulse laws against (14)-(16) and the paper's effective mass (17)-(19) against the exact
//! solve, resting contact, cylinders, the FMU state of a contact, loops hit by an impulse, and
//! contacts found without a largest step (the helpers are `contact.rs`'s).
//!
//! Run: `cargo test --release --test integration contact_impacts:: -- --nocapture`.

use crate::common;

use super::contact::*;
use common::{energy_balance, get, open, rel, start, vec_out};
use contact_fmu::contact::{self};
use contact_fmu::model::{ContactEvent, ContactEventKind};
use contact_fmu::scene::{
    BodySpec, ContactSpec, ImpulseMethod, InputSpec, JointSpec, Law, Method, Side, SpringDamperSpec, GROUND,
};
use contact_fmu::scene_builder::{Cylinder, Plane, SceneBuilder, Sphere};
use contact_fmu::simulation::Simulation;
use nalgebra::{UnitQuaternion, Vector3};
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------------------
// Impulse law

#[test]
fn impulse_two_free_spheres_follow_14_15() {
    let (m1, r1, v1, m2, r2, v2, e) = (1.0, 0.05, 2.0, 3.0, 0.08, -0.5, 0.6);
    let c1 = Vector3::new(-r1 - 0.005, 0.0, 0.0);
    let c2 = Vector3::new(r2 + 0.005, 0.0, 0.0);
    for (method, impulse_method) in [
        ("exact", ImpulseMethod::Exact),
        ("effective_mass", ImpulseMethod::EffectiveMass),
    ] {
        let a = BodySpec::sphere("a", m1, r1, c1).velocity([v1, 0.0, 0.0]);
        let b = BodySpec::sphere("b", m2, r2, c2).velocity([v2, 0.0, 0.0]);
        let c = steel_spheres("c", Law::Impulse, e, Sphere::of(&a, r1), Sphere::of(&b, r2));
        let mut s = start(
            header(0.0, 1e-10, 1e-14, 1e-3)
                .body(a)
                .body(b)
                .contact(c.impulse_method(impulse_method)),
        );
        s.step_to(0.01).unwrap();
        let (u1, u2) = (get(&mut s, "a.v[1]"), get(&mut s, "b.v[1]"));
        let w1 = ((m1 - e * m2) * v1 + (1.0 + e) * m2 * v2) / (m1 + m2);
        let w2 = ((m2 - e * m1) * v2 + (1.0 + e) * m1 * v1) / (m1 + m2);
        let lost = 0.5 * m1 * v1 * v1 + 0.5 * m2 * v2 * v2 - 0.5 * m1 * w1 * w1 - 0.5 * m2 * w2 * w2;
        println!("two spheres, {method}, e = {e}: v1+ {u1:.15} (14: {w1}), v2+ {u2:.15} (15: {w2})");
        assert!((u1 - w1).abs() < 1e-12 * w1.abs());
        assert!((u2 - w2).abs() < 1e-12 * w2.abs());
        assert_eq!(get(&mut s, "c.impacts"), 1.0);
        assert!((get(&mut s, "energy.dissipated") - lost).abs() < 1e-12 * lost);
        let ev = first(&events(&s), ContactEventKind::Impact);
        assert!((ev.time - 0.01 / (v1 - v2)).abs() < 1e-12);
        assert!(
            (ev.force - m1 * (v1 - w1)).abs() < 1e-12 * m1 * v1,
            "impulse {}",
            ev.force
        );
    }
}

/// A rod (mass 2 kg, length 1 m) on a revolute joint about y at the origin, hanging along −z,
/// turning at 1 rad/s, with a sphere (r = 10 mm) on its axis at distance `d` from the pivot
/// that hits a wall x = −r when the rod is vertical. No gravity: ω is constant apart from
/// the impact.
pub(super) fn rod_pendulum(d: f64, e: f64, method: ImpulseMethod) -> SceneBuilder {
    let (m, l, r, w0, a0) = (2.0, 1.0, 0.01, 1.0, -0.05_f64);
    let q = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), a0);
    let com = q * Vector3::new(0.0, 0.0, -l / 2.0);
    let omega = Vector3::new(0.0, w0, 0.0);
    let center = q * Vector3::new(0.0, 0.0, -d);
    let i = m * l * l / 12.0;
    let wall = Plane::new([-r, 0.0, -d], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0]);
    header(0.0, 1e-10, 1e-14, 1e-3)
        .body(
            BodySpec::new("rod", m, [i, i, 1e-4], com.into())
                .orientation(q)
                .velocity(omega.cross(&com))
                .angular_velocity(omega),
        )
        .joint(JointSpec::revolute("pivot", GROUND, "rod", [0.0; 3], [0.0, 1.0, 0.0]))
        .contact(
            ContactSpec::sphere_plane("wall", Law::Impulse, Sphere::new("rod", center, r), GROUND, wall)
                .restitution(e)
                .impulse_method(method),
        )
}

/// ω after / ω before for the rod pendulum.
pub(super) fn rod_ratio(d: f64, e: f64, method: ImpulseMethod) -> Result<f64, String> {
    let mut s = start(rod_pendulum(d, e, method));
    s.step_to(0.2).map_err(|e| e.to_string())?;
    assert_eq!(get(&mut s, "wall.impacts"), 1.0);
    Ok(get(&mut s, "pivot.qd") / 1.0)
}

#[test]
fn impulse_pendulum_wall_exact_and_effective_mass() {
    let e = 0.5;
    let l = 1.0;
    println!("rod pendulum (pivot at one end, L = 1 m), struck at distance d from the pivot, e = {e}:");
    println!("d/L     exact ω+/ω−    effective-mass ω+/ω−   (17)-(19) predicted 1 − (1+e)·3d/(2L)");
    for d in [0.5, 2.0 / 3.0, 0.8, 1.0] {
        let exact = rod_ratio(d, e, ImpulseMethod::Exact).unwrap();
        let eff = rod_ratio(d, e, ImpulseMethod::EffectiveMass).unwrap();
        // (17): m_eff = m (L/2) / d; exact effective mass I_pivot / d² = m L²/(3 d²).
        let predicted = 1.0 - (1.0 + e) * 3.0 * d / (2.0 * l);
        println!("{:.4}  {exact:.15}  {eff:.15}  {predicted:.15}", d / l);
        assert!((exact + e).abs() < 1e-12, "exact: {exact}");
        assert!((eff - predicted).abs() < 1e-12, "effective mass: {eff} vs {predicted}");
    }
    // At the centre of percussion the two agree; struck near the pivot the effective mass
    // (17) is too small to stop the approach: an error, not a silent pass-through.
    assert!((rod_ratio(2.0 / 3.0, e, ImpulseMethod::EffectiveMass).unwrap() + e).abs() < 1e-12);
    let err = rod_ratio(0.25, e, ImpulseMethod::EffectiveMass).unwrap_err();
    println!("d = L/4, effective mass: {err}");
    assert!(err.contains("approaching") && err.contains("\"wall\""), "{err}");
}

#[test]
fn impulse_bob_on_oblique_wall_rebounds_with_minus_e() {
    // A bob (point-like, 1 kg) on a 0.5 m revolute pendulum, no gravity, hitting a wall whose
    // normal is tilted 16.7° from the bob's path: the normal rate after is −e times before.
    let (l, r, w0, a0, e) = (0.5, 0.02, 2.0, -0.1_f64, 0.7);
    let q = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), a0);
    let c = q * Vector3::new(0.0, 0.0, -l);
    let omega = Vector3::new(0.0, w0, 0.0);
    let n = Vector3::new(1.0, 0.0, 0.3).normalize();
    let origin = Vector3::new(0.0, 0.0, -l) - n * r;
    let bob = BodySpec::sphere("bob", 1.0, r, c)
        .velocity(omega.cross(&c))
        .angular_velocity(omega);
    let wall = Plane::new(origin, n, [0.0, 1.0, 0.0], [1.0, 1.0]);
    let contact = ContactSpec::sphere_plane("wall", Law::Impulse, Sphere::of(&bob, r), GROUND, wall).restitution(e);
    let mut s = start(
        header(0.0, 1e-10, 1e-14, 1e-3)
            .body(bob)
            .joint(JointSpec::revolute("pivot", GROUND, "bob", [0.0; 3], [0.0, 1.0, 0.0]))
            .contact(contact),
    );
    assert!((get(&mut s, "pivot.qd") - w0).abs() < 1e-12);
    s.step_to(0.2).unwrap();
    let ev = first(&events(&s), ContactEventKind::Impact);
    // The bob's velocity right after the impact (α = 0, where the wall is met): ω is
    // constant after it (no gravity), the velocity turns with the pendulum.
    let w_after = get(&mut s, "pivot.qd");
    let c_impact = Vector3::new(0.0, 0.0, -l);
    let approach_before = -(omega.cross(&c_impact)).dot(&n);
    let approach_after = -(Vector3::new(0.0, w_after, 0.0).cross(&c_impact)).dot(&n);
    assert!((ev.delta_dot - approach_before).abs() < 1e-12);
    println!(
        "bob on oblique wall: approach {:.15} m/s, after {:.15} m/s, ratio {:.15}",
        ev.delta_dot,
        approach_after,
        approach_after / ev.delta_dot
    );
    assert!(ev.delta_dot > 0.5 * w0 * l * n.x);
    assert!((approach_after / ev.delta_dot + e).abs() < 1e-12);
}

#[test]
fn impulse_simultaneous_and_sequential_impacts() {
    // Ball A hits B and C at once (normals ±30° from its path), equal masses, e = 0.8:
    // P = m (1 + e) v0 cos θ / (1 + 2 cos² θ).
    let (m, r, v0, e, th) = (0.5, 0.02, 1.0, 0.8, PI / 6.0);
    let gap = 0.001;
    let ca = Vector3::zeros();
    let cb = Vector3::new(2.0 * r * th.cos() + gap, 2.0 * r * th.sin(), 0.0);
    let cc = Vector3::new(cb.x, -cb.y, 0.0);
    let a = BodySpec::sphere("a", m, r, ca).velocity([v0, 0.0, 0.0]);
    let b = BodySpec::sphere("b", m, r, cb);
    let c = BodySpec::sphere("c", m, r, cc);
    let ab = steel_spheres("ab", Law::Impulse, e, Sphere::of(&a, r), Sphere::of(&b, r));
    let ac = steel_spheres("ac", Law::Impulse, e, Sphere::of(&a, r), Sphere::of(&c, r));
    let mut s = start(header(0.0, 1e-10, 1e-14, 1e-3).bodies([a, b, c]).contacts([ab, ac]));
    s.step_to(0.05).unwrap();
    let p = m * (1.0 + e) * v0 * th.cos() / (1.0 + 2.0 * th.cos().powi(2));
    let va = get(&mut s, "a.v[1]");
    let (vbx, vby) = (get(&mut s, "b.v[1]"), get(&mut s, "b.v[2]"));
    println!(
        "simultaneous impact: a {va:.15} (expected {:.15}), b ({vbx:.15}, {vby:.15})",
        v0 - 2.0 * p * th.cos() / m
    );
    assert!((va - (v0 - 2.0 * p * th.cos() / m)).abs() < 1e-12);
    assert!((vbx - p / m * th.cos()).abs() < 1e-12 && (vby - p / m * th.sin()).abs() < 1e-12);
    assert_eq!(get(&mut s, "ab.impacts"), 1.0);
    assert_eq!(get(&mut s, "ac.impacts"), 1.0);

    // Three touching balls in a row, e = 1: the impact travels through (one round per
    // contact, at the same instant); the first two stop, the last leaves at v0.
    let c0 = Vector3::new(-gap, 0.0, 0.0);
    let mut balls = vec![BodySpec::sphere("b0", m, r, c0 - Vector3::new(2.0 * r, 0.0, 0.0)).velocity([v0, 0.0, 0.0])];
    balls.extend((0..3).map(|k| BodySpec::sphere(&format!("b{}", k + 1), m, r, [2.0 * r * k as f64, 0.0, 0.0])));
    let contacts: Vec<ContactSpec> = balls
        .windows(2)
        .map(|p| {
            let name = format!("c{}{}", &p[0].name[1..], &p[1].name[1..]);
            steel_spheres(&name, Law::Impulse, 1.0, Sphere::of(&p[0], r), Sphere::of(&p[1], r))
        })
        .collect();
    let mut s = start(header(0.0, 1e-10, 1e-14, 1e-3).bodies(balls).contacts(contacts));
    s.step_to(0.05).unwrap();
    let v: Vec<f64> = (0..4).map(|k| get(&mut s, &format!("b{k}.v[1]"))).collect();
    println!("impulse cradle of 4: final velocities {v:?}");
    assert!(v[0].abs() < 1e-12 && v[1].abs() < 1e-12 && v[2].abs() < 1e-12);
    assert!((v[3] - v0).abs() < 1e-12);
    let times: Vec<f64> = events(&s)
        .iter()
        .filter(|e| e.kind == ContactEventKind::Impact)
        .map(|e| e.time)
        .collect();
    assert_eq!(times.len(), 3);
    assert!(times.iter().all(|&x| x == times[0]));
}

// ---------------------------------------------------------------------------------------------
// Resting contact under the impulse law

#[test]
fn impulse_ball_comes_to_rest_on_the_floor() {
    // Dropped from 0.1 m, e = 0.8: bounces at v0 e^k until the approach speed falls below
    // min_impact_velocity (1 mm/s), then a plastic impact and a resting contact: no Zeno
    // lock-up, no fall-through, energy balance exact.
    let (h, e, vmin, g) = (0.1, 0.8, 1e-3, 9.81);
    let scene = ball_on_floor(Law::Impulse, |c| c.restitution(e).min_impact_velocity(vmin), 0.0, g, h)
        .input(InputSpec::force("lift", "ball", [0.0, 0.0, 1.0]).start(0.0));
    let mut s = start(scene);
    let e0 = get(&mut s, "energy.total");
    let v0 = (2.0 * g * h).sqrt();
    let t_rest = v0 / g * (1.0 + 2.0 * e / (1.0 - e)); // upper bound: the geometric series
    let mut t = 0.0;
    let mut worst: f64 = 0.0;
    while t < t_rest + 0.5 {
        t += 0.01;
        s.step_to(t).unwrap();
        let z = get(&mut s, "ball.r[3]");
        assert!(z > R - 1e-12, "fell through: z = {z} at t = {t}");
        worst = worst.max((energy_balance(&mut s) - e0).abs() / e0);
    }
    let ev = events(&s);
    let impacts: Vec<&ContactEvent> = ev.iter().filter(|x| x.kind == ContactEventKind::Impact).collect();
    let rest = first(&ev, ContactEventKind::Rest);
    // impacts at v0 e^k for k = 0..K with v0 e^K < vmin, the last one plastic
    let k_last = ((vmin / v0).ln() / e.ln()).ceil() as usize;
    println!(
        "impulse ball: {} impacts (expected {}), rest at t = {:.9} s (infinite series {:.9} s), normal force {:.9} N (m g = {:.9}), \
         energy balance {worst:.2e}, {} events, {} steps",
        impacts.len(),
        k_last + 1,
        rest.time,
        t_rest,
        rest.force,
        M * g,
        s.counters().events,
        s.counters().steps
    );
    assert_eq!(impacts.len(), k_last + 1);
    // one event per impact (the plastic last one is the rest, at the same instant), as
    // the output `solver.events` counts them
    assert_eq!(get(&mut s, "solver.events"), (k_last + 1) as f64);
    for (k, x) in impacts.iter().enumerate() {
        assert!(
            rel(x.delta_dot, v0 * e.powi(k as i32)) < 1e-6,
            "impact {k}: {}",
            x.delta_dot
        );
    }
    let t_last = v0 / g + (1..=k_last).map(|k| 2.0 * v0 * e.powi(k as i32) / g).sum::<f64>();
    assert!(rel(rest.time, t_last) < 1e-9, "rest at {} vs {t_last}", rest.time);
    assert!(rel(rest.force, M * g) < 1e-9);
    assert!(worst < 1e-12, "energy balance {worst}");
    assert_eq!(get(&mut s, "floor.active"), 1.0);
    assert!(rel(get(&mut s, "floor.force"), M * g) < 1e-9);
    assert!((get(&mut s, "ball.r[3]") - R).abs() < 1e-12);
    let lost = get(&mut s, "energy.dissipated");
    assert!(
        rel(lost, M * g * h) < 1e-9,
        "all the energy went into the impacts: {lost}"
    );

    // Lift it with twice its weight: the constraint force would pull, the contact lets go,
    // the ball rises with g upwards.
    let vr = s.table().index_of("lift").unwrap();
    s.set(vr, 2.0 * M * g).unwrap();
    let t_release = t;
    s.step_to(t + 0.1).unwrap();
    let release = first(&events(&s), ContactEventKind::Release);
    let z = get(&mut s, "ball.r[3]");
    println!(
        "released at t = {:.6} s, rose {:.9e} m in 0.1 s (g t²/2 = {:.9e})",
        release.time,
        z - R,
        0.5 * g * 0.01
    );
    assert!((release.time - t_release).abs() < 1e-12);
    assert!(rel(z - R, 0.5 * g * 0.01) < 1e-9);
    assert_eq!(get(&mut s, "floor.active"), 0.0);
}

#[test]
fn impulse_ball_slides_in_a_groove_as_a_pendulum() {
    // A ball placed at rest on the inside of a horizontal cylinder (a groove, axis y,
    // ρ = 0.1 m), 0.5 rad from the bottom: resting contact (the constraint row with the
    // curvature term) makes it a frictionless pendulum of length ρ − r.
    let (rho, r, th0, g) = (0.1, R, 0.5_f64, 9.81);
    let len = rho - r;
    let c = Vector3::new(len * th0.sin(), 0.0, -len * th0.cos());
    let ball = BodySpec::sphere("ball", M, r, c);
    let cylinder = Cylinder::new([0.0; 3], [0.0, 1.0, 0.0], rho, 0.2);
    let groove = ContactSpec::sphere_cylinder("groove", Law::Impulse, Sphere::of(&ball, r), GROUND, cylinder)
        .restitution(0.5)
        .side(Side::Inside)
        .theta_range([-1.5, 1.5], [0.0, 0.0, -1.0]);
    let mut s = start(header(g, 1e-10, 1e-14, 1e-3).body(ball).contact(groove));
    assert_eq!(get(&mut s, "groove.active"), 1.0, "resting from the start");
    let e0 = get(&mut s, "energy.total");
    // period of the pendulum with amplitude th0: 4 sqrt(l/g) K(sin(th0/2)), K by the AGM
    let k = (th0 / 2.0).sin();
    let (mut a, mut b) = (1.0_f64, (1.0 - k * k).sqrt());
    for _ in 0..20 {
        let an = 0.5 * (a + b);
        b = (a * b).sqrt();
        a = an;
    }
    let period = 4.0 * (len / g).sqrt() * PI / (2.0 * a);
    // times of the upward zero crossings of x ... use the first return to x = max: x changes
    // sign twice per period; measure the time of the second crossing of x = 0.
    let dt = 1e-3;
    let (mut t_prev, mut x_prev) = (0.0, c.x);
    let mut crossings = Vec::new();
    let mut worst: f64 = 0.0;
    let mut worst_delta: f64 = 0.0;
    while crossings.len() < 4 {
        let tn = t_prev + dt;
        s.step_to(tn).unwrap();
        let x = get(&mut s, "ball.r[1]");
        let z = get(&mut s, "ball.r[3]");
        worst_delta = worst_delta.max(((x * x + z * z).sqrt() - len).abs());
        worst = worst.max((get(&mut s, "energy.total") - e0).abs() / e0.abs());
        if x_prev > 0.0 && x <= 0.0 || x_prev < 0.0 && x >= 0.0 {
            crossings.push(t_prev + dt * x_prev / (x_prev - x));
        }
        t_prev = tn;
        x_prev = x;
        assert!(tn < 10.0 * period);
    }
    let measured = crossings[3] - crossings[1];
    println!(
        "groove pendulum: period {measured:.9} s (exact {period:.9} s, rel {:.2e}), |distance - (rho - r)| <= {worst_delta:.2e} m, \
         energy drift {worst:.2e}",
        rel(measured, period)
    );
    assert!(
        rel(measured, period) < 1e-5,
        "the crossing times are interpolated linearly over 1 ms"
    );
    assert!(worst_delta < 1e-9);
    assert!(worst < 1e-8);
    assert_eq!(get(&mut s, "groove.impacts"), 0.0);
}

// ---------------------------------------------------------------------------------------------
// Cylinders

/// The steel ball `ball` at `c` against a steel cylinder of radius `rho` about the y axis.
pub(super) fn cylinder_contact(law: Law, e: f64, c: Vector3<f64>, rho: f64, side: Side) -> ContactSpec {
    let cylinder = Cylinder::new([0.0; 3], [0.0, 1.0, 0.0], rho, 0.2);
    ContactSpec::sphere_cylinder("cyl", law, Sphere::new("ball", c, R), GROUND, cylinder)
        .restitution(e)
        .materials("steel", "steel")
        .side(side)
}

#[test]
fn ball_settles_at_the_bottom_of_a_groove() {
    // Released 0.3 rad up the side of a groove (ρ = 0.1 m), Hunt-Crossley e = 0.5, and a
    // horizontal viscous damper (c = 0.5 N s/m, along x) for the frictionless sliding: it
    // ends at the bottom, pressed in by the static Hertz penetration (m g / K)^(2/3) with the
    // stiffness of the sphere in the concave cylinder.
    let (rho, th0, g) = (0.1, 0.3_f64, 9.81);
    let len = rho - R;
    let c = Vector3::new(len * th0.sin(), 0.0, -len * th0.cos() + 1e-3);
    let drag = SpringDamperSpec::new("drag", GROUND, [-100.0, 0.0, c.z], "ball", c, 0.0).damping(0.5);
    let mut scene: contact_fmu::scene::Scene = header(g, 1e-8, 1e-12, 1e-3)
        .body(BodySpec::sphere("ball", M, R, c))
        .contact(cylinder_contact(Law::HuntCrossley, 0.5, c, rho, Side::Inside))
        .spring_damper(drag)
        .into();
    scene.solver.max_steps = 100_000; // 4 s in one step
    let mut s = start(scene);
    s.step_to(4.0).unwrap();
    let (x, z) = (get(&mut s, "ball.r[1]"), get(&mut s, "ball.r[3]"));
    // concave: circumferential relative radius 1/(1/R − 1/ρ), axial R; K from their geometric mean
    let r_eff = (R * 1.0 / (1.0 / R - 1.0 / rho)).sqrt();
    let delta_static = (M * g / hertz_k(r_eff)).powf(2.0 / 3.0);
    let speed = (get(&mut s, "ball.v[1]").powi(2) + get(&mut s, "ball.v[3]").powi(2)).sqrt();
    let touches = events(&s).iter().filter(|e| e.kind == ContactEventKind::Touch).count();
    println!(
        "groove: after 4 s x = {x:.3e} m, z + (rho - r) = {:.6e} m (static penetration {delta_static:.6e} m), \
         speed {speed:.2e} m/s, {touches} touches, contact force {:.9} N (m g = {:.9})",
        z + len,
        get(&mut s, "cyl.force"),
        M * g
    );
    assert!(x.abs() < 1e-6, "x = {x}");
    assert!((z + len + delta_static).abs() < 1e-3 * delta_static, "z = {z}");
    assert!(rel(get(&mut s, "cyl.force"), M * g) < 1e-3);
    assert_eq!(get(&mut s, "cyl.active"), 1.0);
}

#[test]
fn ball_bounces_off_a_convex_cylinder_along_its_normal() {
    // Falling (no gravity) onto a cylinder ρ = 0.05 m, axis y, offset b in x: the normal at
    // contact is n = (b, 0, sqrt(a² − b²))/a with a = ρ + r; e = 1 gives v' = v − 2 (v·n) n.
    let (rho, b, v0) = (0.05, 0.02, 1.0);
    let a = rho + R;
    let n = Vector3::new(b, 0.0, (a * a - b * b).sqrt()) / a;
    let c = n * a + Vector3::new(0.0, 0.0, 0.002);
    let v = Vector3::new(0.0, 0.0, -v0);
    let expect = v - 2.0 * v.dot(&n) * n;
    for law in [Law::Impulse, Law::Hertz] {
        let mut s = start(
            header(0.0, 1e-10, 1e-14, 1e-3)
                .body(BodySpec::sphere("ball", M, R, c).velocity(v))
                .contact(cylinder_contact(law, 1.0, c, rho, Side::Outside)),
        );
        s.step_to(0.01).unwrap();
        let out = vec_out(&mut s, "ball.v");
        let law = law.name();
        let angle = (out.normalize().cross(&expect.normalize())).norm().asin();
        println!(
            "convex cylinder, {law}: exit velocity {:?} (mirror {:?}), angle off {angle:.3e} rad, speed rel {:.2e}",
            out.as_slice(),
            expect.as_slice(),
            rel(out.norm(), v0)
        );
        if law == "impulse" {
            assert!((out - expect).norm() < 1e-12);
        } else {
            // Hertz: a central force about the axis, finite penetration: the deflection
            // differs from the hard mirror by O(δ_max/a); speed is conserved.
            let (dmax, _, _) = hertz_closed_form(M, hertz_k((R / (1.0 / R + 1.0 / rho)).sqrt()), v.dot(&n).abs());
            assert!(angle < 4.0 * dmax / a, "angle {angle} vs delta_max/a {}", dmax / a);
            assert!(rel(out.norm(), v0) < 1e-6);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// FMU state

#[test]
fn snapshot_restores_contact_memory_bit_for_bit() {
    // In the middle of a hertz_ln contact (δ̇⁻ remembered) and while an impulse contact rests:
    // save, go on, restore, go on again: the same numbers, bit for bit.
    for (law, v0, gap, t_save) in [(Law::HertzLn, 1.0, 1e-4, 1e-4 + 3e-5), (Law::Impulse, 0.0, 0.01, 0.2)] {
        let scene = ball_on_floor(law, |c| c.restitution(0.5), v0, 9.81, gap).build();
        let mut s = start(scene.clone());
        s.step_to(t_save).unwrap();
        assert_eq!(get(&mut s, "floor.active"), 1.0, "in contact when saved");
        let snap = s.snapshot(Vec::new());
        let bytes = snap.to_bytes(0);
        let run = |s: &mut Simulation| -> Vec<f64> {
            let mut out = Vec::new();
            for k in 1..=50 {
                s.step_to(t_save + 1e-3 * k as f64).unwrap();
                for name in ["ball.r[3]", "ball.v[3]", "floor.force", "energy.dissipated"] {
                    out.push(get(s, name));
                }
            }
            out
        };
        let a = run(&mut s);
        let mut fresh = open(scene);
        fresh
            .restore(&contact_fmu::checkpoint::Snapshot::from_bytes(&bytes, 0).unwrap())
            .unwrap();
        let b = run(&mut fresh);
        assert!(
            a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
            "restored run differs"
        );
    }
}

#[test]
fn resting_ball_slides_off_the_edge_and_falls() {
    // Resting on a 0.2 m square (impulse law) and sliding at 0.5 m/s without friction: the
    // contact lets go when the centre leaves the patch (x = 0.1 m at t = 0.2 s), then the
    // ball falls freely.
    let (g, vx): (f64, f64) = (9.81, 0.5);
    let mut scene = ball_on_floor(Law::Impulse, |c| c.restitution(0.5), 0.0, g, 0.0).build();
    scene.contact[0].size = Some([0.2, 0.2]);
    scene.body[0].velocity = [vx, 0.0, 0.0];
    let mut s = start(scene);
    assert_eq!(get(&mut s, "floor.active"), 1.0, "rests from the start");
    s.step_to(0.3).unwrap();
    let release = first(&events(&s), ContactEventKind::Release);
    let z = get(&mut s, "ball.r[3]");
    let fall = 0.5 * g * (0.3 - 0.1 / vx).powi(2);
    println!(
        "slides off the edge: released at t = {:.12} s (0.2), fell {:.9e} m ({fall:.9e})",
        release.time,
        R - z
    );
    assert!((release.time - 0.1 / vx).abs() < 1e-12);
    assert!(rel(R - z, fall) < 1e-9);
    assert_eq!(get(&mut s, "floor.impacts"), 0.0);
}

#[test]
fn impulse_on_a_closed_loop_keeps_it_closed() {
    // Parallelogram four-bar (cranks 0.3 m, pivots 0.4 m apart, axes y; one revolute closes
    // the loop), no gravity, turning at 1 rad/s: its coupler translates on a circle and ω is
    // constant. A sphere on the coupler strikes a wall: the impulse, applied through G (loops
    // closed), must give both cranks −e ω and leave the coupler without rotation.
    let (l, a, w0, a0, e, r) = (0.3, 0.4, 1.0, -0.05_f64, 0.6, 0.02);
    let u = Vector3::new(-a0.sin(), 0.0, -a0.cos());
    let (pa, pb) = (Vector3::zeros(), Vector3::new(a, 0.0, 0.0));
    let omega = Vector3::new(0.0, w0, 0.0);
    let joint = |name: &str, parent: &str, child: &str, anchor: Vector3<f64>| {
        JointSpec::revolute(name, parent, child, anchor, [0.0, 1.0, 0.0])
    };
    let c1 = pa + u * (l / 2.0);
    let c2 = pb + u * (l / 2.0);
    let cc = (pa + pb) / 2.0 + u * l;
    let vc = omega.cross(&(u * l));
    let sphere = pa + u * l - Vector3::new(0.05, 0.0, 0.0);
    let wall = Plane::new([-0.05 - r, 0.0, -l], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0]);
    let mut s = start(
        header(0.0, 1e-11, 1e-14, 1e-3)
            .body(
                BodySpec::new("crank1", 1.0, [0.01, 0.01, 0.002], c1.into())
                    .velocity(omega.cross(&(c1 - pa)))
                    .angular_velocity(omega),
            )
            .body(
                BodySpec::new("crank2", 1.5, [0.02, 0.02, 0.002], c2.into())
                    .velocity(omega.cross(&(c2 - pb)))
                    .angular_velocity(omega),
            )
            .body(BodySpec::new("coupler", 2.0, [0.001, 0.03, 0.03], cc.into()).velocity(vc))
            .joint(joint("j1", GROUND, "crank1", pa))
            .joint(joint("j2", GROUND, "crank2", pb))
            .joint(joint("j3", "crank1", "coupler", pa + u * l))
            .joint(joint("j4", "crank2", "coupler", pb + u * l))
            .contact(
                ContactSpec::sphere_plane("wall", Law::Impulse, Sphere::new("coupler", sphere, r), GROUND, wall)
                    .restitution(e),
            ),
    );
    assert!((get(&mut s, "j1.qd") - w0).abs() < 1e-12 && (get(&mut s, "j2.qd") - w0).abs() < 1e-12);
    s.step_to(0.1).unwrap();
    let ev = first(&events(&s), ContactEventKind::Impact);
    let (w1, w2) = (get(&mut s, "j1.qd"), get(&mut s, "j2.qd"));
    let wc = get(&mut s, "coupler.w[2]");
    println!(
        "four-bar impact at t = {:.9} s: crank rates after {w1:.12}, {w2:.12} (−e ω = {:.3}), coupler ω_y {wc:.2e}, \
         loop residual {:.2e}",
        ev.time,
        -e * w0,
        s.constraint_residual().unwrap()
    );
    assert!((ev.time + a0 / w0).abs() < 1e-9, "impact when the cranks are vertical");
    assert!((w1 + e * w0).abs() < 1e-9 && (w2 + e * w0).abs() < 1e-9);
    assert!(wc.abs() < 1e-9);
}

#[test]
fn a_sphere_passing_behind_a_plate_is_not_a_contact() {
    // A ball rising from below through a one-sided floor plate (normal up, no gravity): it
    // enters the admissible zone through δ = δ_max from behind; that is no touch (no force, no
    // error), and the ball goes on at its speed.
    for law in [Law::Hertz, Law::Impulse] {
        let mut s = start(ball_on_floor(law, |c| c, -1.0, 0.0, -0.05));
        let law = law.name();
        s.step_to(0.1).unwrap();
        let v = get(&mut s, "ball.v[3]");
        println!(
            "{law}: ball through the back of a plate: v = {v}, events {:?}",
            events(&s)
        );
        assert!((v - 1.0).abs() < 1e-15);
        assert!(events(&s).is_empty());
        assert!(get(&mut s, "ball.r[3]") > 0.05);
    }
}

#[test]
fn impulse_complementarity_solver() {
    // Coupled contacts where one needs no impulse: w = W P + q ≥ 0, P ≥ 0, Pᵀ w = 0.
    let w = [2.0, 1.9, 1.9, 2.0];
    let q = [-1.0, -0.1];
    let p = contact::impulse::solve_lcp(&w, &q, 2).unwrap();
    assert!((p[0] - 0.5).abs() < 1e-15 && p[1] == 0.0, "{p:?}");
    // and a random positive definite 6 × 6 case: check the conditions
    let mut seed: u64 = 7;
    let mut rnd = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    for _ in 0..200 {
        let n = 6;
        let a: Vec<f64> = (0..n * n).map(|_| rnd()).collect();
        let mut w = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                w[i * n + j] =
                    (0..n).map(|k| a[i * n + k] * a[j * n + k]).sum::<f64>() + if i == j { 0.1 } else { 0.0 };
            }
        }
        let q: Vec<f64> = (0..n).map(|_| rnd()).collect();
        let p = contact::impulse::solve_lcp(&w, &q, n).unwrap();
        for i in 0..n {
            let wi = q[i] + (0..n).map(|j| w[i * n + j] * p[j]).sum::<f64>();
            assert!(
                p[i] >= 0.0 && wi >= -1e-12 && (p[i] * wi).abs() < 1e-12,
                "row {i}: p {} w {wi}",
                p[i]
            );
        }
    }
}

#[test]
fn resting_ball_leaves_an_accelerating_platform() {
    // A ball resting (impulse law) on a plate on a vertical spring. Together they oscillate,
    // x = −A cos ωt about the static equilibrium, ω² = K/(M + m); the plate's force on the ball
    // m (g + ẍ) turns tensile at cos ωt = −g/(A ω²): the contact lets go there.
    let (g, k, mp, a) = (9.81, 1000.0, 1.0, 0.02_f64);
    let w = (k / (mp + M)).sqrt();
    let l0 = 1.0 + (mp + M) * g / k; // compressed by the weight at z = 0
    let ball = BodySpec::sphere("ball", M, R, [0.0, 0.0, -a + R]);
    let floor = ContactSpec::sphere_plane(
        "floor",
        Law::Impulse,
        Sphere::of(&ball, R),
        "plate",
        Plane::horizontal([0.0, 0.0, -a], [1.0, 1.0]),
    );
    let mut s = start(
        header(g, 1e-11, 1e-14, 1e-3)
            .body(BodySpec::sphere("plate", mp, 0.1, [0.0, 0.0, -a]))
            .body(ball)
            .joint(JointSpec::prismatic(
                "slide",
                GROUND,
                "plate",
                [0.0, 0.0, -a],
                [0.0, 0.0, 1.0],
            ))
            .spring_damper(
                SpringDamperSpec::new("spring", GROUND, [0.0, 0.0, -1.0], "plate", [0.0, 0.0, -a], k).free_length(l0),
            )
            .contact(floor.restitution(0.5)),
    );
    assert_eq!(get(&mut s, "floor.active"), 1.0);
    assert!(rel(get(&mut s, "floor.force"), M * (g + a * w * w)) < 1e-9);
    s.step_to(0.1).unwrap();
    let release = first(&events(&s), ContactEventKind::Release);
    let t_rel = (-g / (a * w * w)).acos() / w;
    println!(
        "platform: ball released at t = {:.12} s (cos ωt = −g/(Aω²): {t_rel:.12} s)",
        release.time
    );
    assert!((release.time - t_rel).abs() < 1e-9 * t_rel);
    // the plate kept the common motion up to there
    let plate_z = -a * (w * release.time).cos();
    assert!(plate_z > 0.0);
}

// ---------------------------------------------------------------------------------------------
// No contact stepped over without a largest step

/// A glancing blow in weightless free flight, with no `max_step`: the steel sphere passes
/// its neighbour at 10 m/s with an overlap of 1 mm (a tenth of a radius) at closest approach,
/// which dopri5 alone, seeing exact straight-line motion, would cross in one step. The time
/// to contact bounds the steps, the touch is located, and the outcome equals a run held to
/// 1 µs steps; momentum and (elastic Hertz) kinetic energy are conserved.
#[test]
fn glancing_blow_is_found_without_a_largest_step() {
    let run = |max_step: f64| {
        let a = BodySpec::sphere("a", M, R, [-1.0, 1.9 * R, 0.0]).velocity([10.0, 0.0, 0.0]);
        let b = BodySpec::sphere("b", M, R, [0.0, 0.0, 0.0]);
        let c = ContactSpec::sphere_sphere("c", Law::Hertz, Sphere::of(&a, R), Sphere::of(&b, R));
        let scene = header(0.0, 1e-10, 1e-14, max_step)
            .experiment(0.2, 0.2)
            .body(a)
            .body(b)
            .contact(c.materials("steel", "steel"));
        let mut s = start(scene);
        for k in 1..=200 {
            s.step_to(k as f64 * 1e-3).unwrap();
        }
        let touches = events(&s).iter().filter(|e| e.kind == ContactEventKind::Touch).count();
        let v = ["a.v[1]", "a.v[2]", "b.v[1]", "b.v[2]"].map(|n| get(&mut s, n));
        (touches, v, s.counters().steps)
    };
    let (touches, v, steps) = run(0.0);
    let (ref_touches, v_ref, ref_steps) = run(1e-6);
    println!(
        "glancing blow: {touches} touch, {steps} steps (held to 1 µs: {ref_steps}); velocities {v:?}, held {v_ref:?}"
    );
    assert_eq!((touches, ref_touches), (1, 1));
    assert!(
        v[3] < -0.1,
        "the struck sphere moves off along the line of centres: {v:?}"
    );
    for k in 0..4 {
        assert!(
            (v[k] - v_ref[k]).abs() < 1e-7 * 10.0,
            "component {k}: {} vs {}",
            v[k],
            v_ref[k]
        );
    }
    assert!(
        (v[0] + v[2] - 10.0).abs() < 1e-9 && (v[1] + v[3]).abs() < 1e-9,
        "momentum {v:?}"
    );
    let ke = v.iter().map(|x| x * x).sum::<f64>();
    assert!((ke - 100.0).abs() < 1e-7 * 100.0, "kinetic energy ratio {}", ke / 100.0);
    assert!(steps < 1_000, "free flight takes few steps: {steps}");
}

/// A ball dropped from 0.5 m on the floor with the `impulse` law (e = 0.8) and no `max_step`:
/// every impact at its closed-form time `t_k = t_1 + 2 v_1 e (1 − e^(k−1)) / ((1 − e) g)`,
/// no flight through the floor after an apex, in a few dozen steps.
#[test]
fn bouncing_ball_impacts_at_closed_form_times_without_a_largest_step() {
    let (h, e, g) = (0.5, 0.8, 9.81);
    let scene = ball_on_floor(Law::Impulse, |c| c.restitution(e), 0.0, g, h)
        .solver(Method::Dopri5, 1e-10, 1e-14, 0.0)
        .experiment(2.0, 0.01);
    let mut s = start(scene);
    s.step_to(2.0).unwrap();
    let impacts: Vec<f64> = events(&s)
        .iter()
        .filter(|ev| ev.kind == ContactEventKind::Impact)
        .map(|ev| ev.time)
        .collect();
    let (t1, v1) = ((2.0 * h / g).sqrt(), (2.0 * g * h).sqrt());
    let steps = s.counters().steps;
    println!("impulse bouncing ball: {} impacts in 2 s, {steps} steps", impacts.len());
    assert!(impacts.len() >= 5, "{impacts:?}");
    for (k, t) in impacts.iter().take(5).enumerate() {
        let expected = t1 + 2.0 * v1 * e * (1.0 - e.powi(k as i32)) / ((1.0 - e) * g);
        assert!(
            rel(*t, expected) < 1e-9,
            "impact {}: {t} s, closed form {expected} s",
            k + 1
        );
    }
    assert!(get(&mut s, "ball.r[3]") > 0.0, "the ball is above the floor");
    assert!(steps < 500, "{steps} steps");
}
