//! Contact module checked against physics: Hertz closed forms (docs/physics.md §6), effective
//! restitution of the damped laws against an independent integration of the scalar law,
//! energy balance, Newton's cradle, and scene validation; and the scenes and closed forms that
//! `contact_impacts.rs` (impulse laws, resting contact, cylinders) and `contact_detection.rs`
//! (detection geometry against hand computations and finite differences) share.
//!
//! Run: `cargo test --release --test integration -- contact:: contact_impacts:: contact_detection:: --nocapture`
//! (measured numbers are printed; docs/contact.md quotes them).

use crate::common;

use common::{energy_balance, get, rel, rk4_step, start};
use contact_fmu::model::{ContactEvent, ContactEventKind};
use contact_fmu::scene::{BodySpec, ContactSpec, Law, Method, GROUND};
use contact_fmu::scene_builder::{Plane, SceneBuilder, Sphere};
use contact_fmu::simulation::Simulation;
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------------------
// helpers

pub(super) fn events(s: &Simulation) -> Vec<ContactEvent> {
    s.contact_events().to_vec()
}

pub(super) fn first(ev: &[ContactEvent], kind: ContactEventKind) -> ContactEvent {
    *ev.iter()
        .find(|e| e.kind == kind)
        .unwrap_or_else(|| panic!("no {kind:?} event in {ev:?}"))
}

/// Runs `scene` for 1 ms with peak events logged: its touch, peak and separation events.
pub(super) fn one_impact(scene: impl Into<contact_fmu::scene::Scene>) -> (Simulation, [ContactEvent; 3]) {
    let mut s = start(scene);
    s.set_peak_events(true);
    s.step_to(1e-3).unwrap();
    let ev = events(&s);
    let kinds = [
        ContactEventKind::Touch,
        ContactEventKind::Peak,
        ContactEventKind::Separation,
    ];
    (s, kinds.map(|k| first(&ev, k)))
}

/// A scene "t" with gravity `gravity` along −z, dopri5 at these tolerances and steel.
pub(super) fn header(gravity: f64, rtol: f64, atol: f64, max_step: f64) -> SceneBuilder {
    SceneBuilder::new("t")
        .gravity([0.0, 0.0, -gravity])
        .experiment(1.0, 1e-3)
        .solver(Method::Dopri5, rtol, atol, max_step)
        .steel()
}

/// Steel ball, R = 10 mm.
pub(super) const R: f64 = 0.01;
pub(super) const M: f64 = 0.0329;
pub(super) const E_STEEL: f64 = 210e9;
pub(super) const NU_STEEL: f64 = 0.3;

/// A steel ball above a steel floor (plane z = 0), a gap `gap` away, moving down at `v0`;
/// `floor` sets more keys of the contact.
pub(super) fn ball_on_floor(
    law: Law,
    floor: impl FnOnce(ContactSpec) -> ContactSpec,
    v0: f64,
    gravity: f64,
    gap: f64,
) -> SceneBuilder {
    let ball = BodySpec::sphere("ball", M, R, [0.0, 0.0, R + gap]).velocity([0.0, 0.0, -v0]);
    let plane = Plane::horizontal([0.0; 3], [1.0, 1.0]);
    let contact =
        ContactSpec::sphere_plane("floor", law, Sphere::of(&ball, R), GROUND, plane).materials("steel", "steel");
    header(gravity, 1e-10, 1e-14, 1e-3).body(ball).contact(floor(contact))
}

/// A contact between steel spheres.
pub(super) fn steel_spheres(name: &str, law: Law, e: f64, a: Sphere, b: Sphere) -> ContactSpec {
    ContactSpec::sphere_sphere(name, law, a, b)
        .restitution(e)
        .materials("steel", "steel")
}

/// Hertz stiffness of two steel bodies, effective radius `r_eff`, computed here from the
/// corrected (22) independently of the library.
pub(super) fn hertz_k(r_eff: f64) -> f64 {
    let h = (1.0 - NU_STEEL * NU_STEEL) / (PI * E_STEEL);
    4.0 / (3.0 * PI * (h + h)) * r_eff.sqrt()
}

/// Γ(x) for x > 0 (Lanczos, g = 7).
pub(super) fn gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return PI / ((PI * x).sin() * gamma(1.0 - x));
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    (2.0 * PI).sqrt() * t.powf(x + 0.5) * (-t).exp() * a
}

/// Closed forms of docs/physics.md §6: (δ_max, F_max, t_c).
pub(super) fn hertz_closed_form(m: f64, k: f64, v0: f64) -> (f64, f64, f64) {
    let dmax = (5.0 * m * v0 * v0 / (4.0 * k)).powf(0.4);
    let c = 4.0 * PI.sqrt() * gamma(0.4) / (5.0 * gamma(0.9));
    (dmax, k * dmax.powf(1.5), c * dmax / v0)
}

// ---------------------------------------------------------------------------------------------
// Hertz closed forms

#[test]
fn hertz_sphere_plane_matches_closed_form() {
    let v0 = 1.0;
    let (mut s, [touch, peak, sep]) = one_impact(ball_on_floor(Law::Hertz, |c| c, v0, 0.0, 1e-4));
    let (dmax, fmax, tc) = hertz_closed_form(M, hertz_k(R), v0);
    let rebound = get(&mut s, "ball.v[3]");
    println!(
        "sphere-plane Hertz: delta_max {:.9e} (closed {:.9e}, rel {:.2e}); F_max {:.9e} (closed {:.9e}, rel {:.2e}); \
         t_c {:.9e} (closed {:.9e}, rel {:.2e}); rebound {:.12} (rel {:.2e})",
        peak.delta,
        dmax,
        rel(peak.delta, dmax),
        peak.force,
        fmax,
        rel(peak.force, fmax),
        sep.time - touch.time,
        tc,
        rel(sep.time - touch.time, tc),
        rebound,
        rel(rebound, v0)
    );
    assert!((touch.time - 1e-4 / v0).abs() < 1e-12, "touch at {}", touch.time);
    assert!(rel(peak.delta, dmax) < 1e-4);
    assert!(rel(peak.force, fmax) < 1e-4);
    assert!(rel(sep.time - touch.time, tc) < 1e-4);
    assert!(rel(rebound, v0) < 1e-6, "rebound {rebound}");
    assert!(rel(-sep.delta_dot, v0) < 1e-6);
}

#[test]
fn hertz_sphere_sphere_matches_closed_form() {
    // Two free spheres (R 10 mm and 15 mm), the small one at 1 m/s: reduced mass, effective
    // radius R1 R2/(R1 + R2).
    let (r1, r2, m1, m2, v0) = (0.01, 0.015, 0.0329, 0.111, 1.0);
    let gap = 1e-4;
    let x1 = -r1 - gap / 2.0;
    let x2 = r2 + gap / 2.0;
    let small = BodySpec::sphere("small", m1, r1, [x1, 0.0, 0.0]).velocity([v0, 0.0, 0.0]);
    let large = BodySpec::sphere("large", m2, r2, [x2, 0.0, 0.0]);
    let c = ContactSpec::sphere_sphere("c", Law::Hertz, Sphere::of(&small, r1), Sphere::of(&large, r2));
    let scene = header(0.0, 1e-10, 1e-14, 1e-3)
        .body(small)
        .body(large)
        .contact(c.materials("steel", "steel"));
    let (mut s, [touch, peak, sep]) = one_impact(scene);
    let mstar = m1 * m2 / (m1 + m2);
    let (dmax, fmax, tc) = hertz_closed_form(mstar, hertz_k(r1 * r2 / (r1 + r2)), v0);
    let (u1, u2) = (get(&mut s, "small.v[1]"), get(&mut s, "large.v[1]"));
    println!(
        "sphere-sphere Hertz: delta_max rel {:.2e}, F_max rel {:.2e}, t_c rel {:.2e} (t_c = {:.6e} s); \
         relative rebound speed {:.12} (rel {:.2e}); momentum error {:.2e}",
        rel(peak.delta, dmax),
        rel(peak.force, fmax),
        rel(sep.time - touch.time, tc),
        sep.time - touch.time,
        u2 - u1,
        rel(u2 - u1, v0),
        (m1 * u1 + m2 * u2 - m1 * v0).abs() / (m1 * v0)
    );
    assert!(rel(peak.delta, dmax) < 1e-4);
    assert!(rel(peak.force, fmax) < 1e-4);
    assert!(rel(sep.time - touch.time, tc) < 1e-4);
    assert!(rel(u2 - u1, v0) < 1e-6);
    assert!((m1 * u1 + m2 * u2 - m1 * v0).abs() < 1e-10 * m1 * v0);
}

// ---------------------------------------------------------------------------------------------
// Effective restitution of the damped laws

/// The hysteresis bracket factor of each law, written here independently of the library.
pub(super) fn damping_factor(law: Law, e: f64) -> f64 {
    match law {
        Law::HertzLn => 3.0 * (1.0 - e * e) / 4.0,
        Law::HuntCrossley => 3.0 * (1.0 - e) / 2.0,
        Law::Flores => 8.0 * (1.0 - e) / (5.0 * e),
        _ => unreachable!(),
    }
}

/// Exit speed / impact speed of `m δ̈ = −max(0, K δ^1.5 (1 + d δ̇/v0))`, δ(0) = 0, δ̇(0) = v0,
/// by classical RK4 with a fixed step (1/20000 of the Hertz contact time), the exit speed
/// interpolated linearly at δ = 0.
pub(super) fn scalar_restitution(m: f64, k: f64, d: f64, v0: f64) -> f64 {
    let (_, _, tc) = hertz_closed_form(m, k, v0);
    let h = tc / 20000.0;
    let acc = |x: f64, v: f64| -> f64 {
        let x = x.max(0.0);
        -(k * x.powf(1.5) * (1.0 + d * v / v0)).max(0.0) / m
    };
    let (mut x, mut v) = (0.0_f64, v0);
    for _ in 0..10_000_000 {
        let (xn, vn) = rk4_step(acc, x, v, h);
        if xn <= 0.0 && vn < 0.0 {
            let s = x / (x - xn);
            return -(v + s * (vn - v)) / v0;
        }
        x = xn;
        v = vn;
    }
    panic!("no separation")
}

/// Engine: the ball's exit speed over its impact speed (no gravity), and the number of steps.
pub(super) fn engine_restitution(law: Law, e: f64, clamp_events: bool) -> (f64, u64) {
    let v0 = 1.0;
    let mut s = start(ball_on_floor(law, |c| c.restitution(e), v0, 0.0, 1e-4));
    s.set_clamp_events(clamp_events).unwrap();
    s.step_to(1e-3).unwrap();
    let ev = events(&s);
    assert!(
        ev.iter().any(|e| e.kind == ContactEventKind::Separation),
        "{} e={e}: no separation",
        law.name()
    );
    (get(&mut s, "ball.v[3]") / v0, s.counters().steps)
}

#[test]
fn effective_restitution_of_damped_laws() {
    let k = hertz_k(R);
    let mut table = Vec::new();
    println!(
        "law           e     engine e_eff   scalar e_eff   |engine-scalar|  steps (clamp events on/off, error off)"
    );
    for law in [Law::HertzLn, Law::HuntCrossley, Law::Flores] {
        for e in [0.3, 0.5, 0.7, 0.9] {
            let (eng, steps) = engine_restitution(law, e, true);
            let (eng_off, steps_off) = engine_restitution(law, e, false);
            let sc = scalar_restitution(M, k, damping_factor(law, e), 1.0);
            let law = law.name();
            println!(
                "{law:13} {e:.1}   {eng:.9}    {sc:.9}    {:.2e}         {steps} / {steps_off} ({:.2e})",
                (eng - sc).abs(),
                (eng_off - sc).abs()
            );
            assert!((eng - sc).abs() < 1e-6 * sc, "{law} e={e}: engine {eng} vs scalar {sc}");
            table.push((law, e, eng));
        }
    }
    let eff = |law: &str, e: f64| table.iter().find(|r| r.0 == law && r.1 == e).unwrap().2;
    for e in [0.3, 0.5, 0.7, 0.9] {
        let (ln, hc, fl) = (eff("hertz_ln", e), eff("hunt_crossley", e), eff("flores", e));
        // Lankarani-Nikravesh and Hunt-Crossley dissipate too little: they over-estimate e,
        // Lankarani-Nikravesh most, and the more so the lower e.
        assert!(ln > hc && hc > e, "e={e}: LN {ln}, HC {hc}");
        // Flores is the closest of the three at every e ...
        assert!((fl - e).abs() < (hc - e).abs(), "e={e}: Flores {fl}, HC {hc}");
        // ... within 5 % for e ≥ 0.7; below, it under-estimates (measured: docs/contact.md).
        if e >= 0.7 {
            assert!((fl - e).abs() < 0.05 * e, "flores e={e}: {fl}");
        } else {
            assert!(fl < e, "flores e={e}: {fl}");
        }
    }
    assert!(
        eff("hertz_ln", 0.3) > 0.3 + 0.3,
        "LN at e = 0.3: {}",
        eff("hertz_ln", 0.3)
    );
}

#[test]
fn kelvin_voigt_cut_at_zero_force() {
    // Linear spring-damper, damping ratio 0.2: the law would pull near separation; the force
    // is cut at zero. Engine against the scalar integration, with and without the location of
    // the cut.
    let (k, zeta, v0) = (1e6, 0.2, 1.0);
    let c = 2.0 * zeta * (k * M).sqrt();
    let run = |clamp: bool| {
        let mut s = start(ball_on_floor(
            Law::KelvinVoigt,
            |f| f.stiffness(k).damping(c),
            v0,
            0.0,
            1e-4,
        ));
        s.set_clamp_events(clamp).unwrap();
        s.step_to(2e-3).unwrap();
        let ev = events(&s);
        (get(&mut s, "ball.v[3]"), s.counters(), ev)
    };
    // scalar: m x'' = -max(0, k x + c x'), fine RK4 step, exit when x returns to 0
    let h = 1e-9;
    let acc = |x: f64, v: f64| -((k * x + c * v).max(0.0)) / M;
    let (mut x, mut v) = (0.0_f64, v0);
    let exit = loop {
        let (xn, vn) = rk4_step(acc, x, v, h);
        if xn <= 0.0 && vn < 0.0 {
            break -vn;
        }
        x = xn;
        v = vn;
    };
    let (on, con, ev) = run(true);
    let (off, coff, _) = run(false);
    println!(
        "Kelvin-Voigt zeta = 0.2: exit speed scalar {exit:.10}, engine with cut events {on:.10} (err {:.2e}, {} steps, \
         {} rhs), without {off:.10} (err {:.2e}, {} steps, {} rhs); e of the unclamped oscillator {:.6}",
        (on - exit).abs(),
        con.steps,
        con.rhs_evals,
        (off - exit).abs(),
        coff.steps,
        coff.rhs_evals,
        (-zeta * PI / (1.0 - zeta * zeta).sqrt()).exp()
    );
    let clamp = first(&ev, ContactEventKind::Clamp);
    assert!(clamp.delta > 0.0, "the cut comes before delta = 0");
    assert!(clamp.time < first(&ev, ContactEventKind::Separation).time);
    assert!((on - exit).abs() < 1e-7 * exit);
    assert!((off - exit).abs() < 1e-6 * exit);
}

// ---------------------------------------------------------------------------------------------
// Energy balance

/// Sets more keys of the floor contact.
type FloorKeys = fn(ContactSpec) -> ContactSpec;

pub(super) fn energy_drift(law: Law, floor: FloorKeys, stop: f64) -> (f64, usize) {
    let mut s = start(ball_on_floor(law, floor, 0.0, 9.81, 0.05));
    let e0 = energy_balance(&mut s);
    let mut worst: f64 = 0.0;
    let n = 200;
    for k in 1..=n {
        s.step_to(stop * k as f64 / n as f64).unwrap();
        let e = energy_balance(&mut s);
        worst = worst.max((e - e0).abs() / e0.abs());
    }
    let bounces = events(&s).iter().filter(|e| e.kind == ContactEventKind::Touch).count();
    let diss = get(&mut s, "energy.dissipated");
    assert!(diss > 0.1 * e0, "{}: little dissipated ({diss} of {e0})", law.name());
    (worst, bounces)
}

#[test]
fn damped_impacts_balance_energy() {
    let cases: [(Law, FloorKeys); 3] = [
        (Law::HertzLn, |c| c.restitution(0.5)),
        (Law::Flores, |c| c.restitution(0.5)),
        (Law::KelvinVoigt, |c| c.stiffness(1e6).damping(40.0)),
    ];
    for (law, floor) in cases {
        let (worst, bounces) = energy_drift(law, floor, 0.4);
        let law = law.name();
        println!("{law}: {bounces} bounces, max |total + dissipated - initial| / initial = {worst:.2e}");
        assert!(worst < 1e-7, "{law}: energy drift {worst}");
    }
}

// ---------------------------------------------------------------------------------------------
// Newton's cradle

#[test]
fn newtons_cradle_of_five_hertz_balls() {
    // Five touching free steel balls (R 10 mm), the first hits at 1 m/s; pure Hertz (e = 1).
    let v0 = 1.0;
    let gap = 1e-4;
    let balls: Vec<BodySpec> = (0..5)
        .map(|k| {
            let (x, v) = if k == 0 { (-gap, v0) } else { (2.0 * R * k as f64, 0.0) };
            BodySpec::sphere(&format!("b{k}"), M, R, [x, 0.0, 0.0]).velocity([v, 0.0, 0.0])
        })
        .collect();
    let contacts: Vec<ContactSpec> = (0..4)
        .map(|k| {
            steel_spheres(
                &format!("c{k}"),
                Law::Hertz,
                1.0,
                Sphere::of(&balls[k], R),
                Sphere::of(&balls[k + 1], R),
            )
        })
        .collect();
    let mut s = start(header(0.0, 1e-10, 1e-14, 1e-3).bodies(balls).contacts(contacts));
    let e0 = get(&mut s, "energy.total");
    s.step_to(0.01).unwrap();
    let v: Vec<f64> = (0..5).map(|k| get(&mut s, &format!("b{k}.v[1]"))).collect();
    let p: f64 = v.iter().map(|x| M * x).sum();
    let ke: f64 = v.iter().map(|x| 0.5 * M * x * x).sum();
    let active: f64 = (0..4).map(|k| get(&mut s, &format!("c{k}.active"))).sum();
    println!(
        "Hertz cradle of 5: final velocities {:?} m/s; momentum error {:.2e}, energy error {:.2e}",
        v.iter().map(|x| format!("{x:.6}")).collect::<Vec<_>>(),
        (p - M * v0).abs() / (M * v0),
        (ke - e0).abs() / e0
    );
    assert_eq!(active, 0.0, "all contacts open at the end");
    assert!((p - M * v0).abs() < 1e-10 * M * v0);
    assert!((ke - e0).abs() < 1e-8 * e0);
    // the velocities are ordered (no ball overtakes the next) and the last carries most
    for k in 0..4 {
        assert!(v[k] <= v[k + 1] + 1e-12, "{v:?}");
    }
    assert!(v[4] > 0.8 * v0 && v[4] < v0);
}

// ---------------------------------------------------------------------------------------------
// Errors the user sees

#[test]
fn bad_contact_definitions_are_clear_errors() {
    let base = ball_on_floor(Law::HertzLn, |c| c.restitution(0.8), 0.0, 9.81, 0.1).build();
    // the scene file with one key of the contact changed
    let bad = |edit: fn(&mut ContactSpec)| {
        let mut scene = base.clone();
        edit(&mut scene.contact[0]);
        scene.to_toml()
    };
    let text = base.to_toml();
    let cases: Vec<(String, &str, &str)> = vec![
        (
            bad(|c| c.sphere_body = "bal".into()),
            "sphere_body",
            "unknown body \"bal\"",
        ),
        (bad(|c| c.body = "floor2".into()), "body", "unknown body \"floor2\""),
        (
            bad(|c| c.sphere_body = GROUND.into()),
            "body",
            "both shapes are on the ground",
        ),
        (bad(|c| c.radius = 0.0), "radius", "must be > 0"),
        (bad(|c| c.radius = -0.01), "radius", "must be > 0"),
        (bad(|c| c.restitution = 1.2), "restitution", "[0, 1]"),
        (bad(|c| c.restitution = -0.1), "restitution", "[0, 1]"),
        (
            bad(|c| c.law = Law::KelvinVoigt),
            "stiffness",
            "required for the kelvin_voigt law",
        ),
        (
            bad(|c| c.sphere_material = None),
            "stiffness",
            "give stiffness, or both sphere_material and material",
        ),
        (
            bad(|c| c.material = Some("rubber".into())),
            "material",
            "unknown material",
        ),
        (bad(|c| c.max_penetration = Some(0.0)), "max_penetration", "> 0"),
        (bad(|c| c.friction = Some(-0.1)), "friction", ">= 0"),
        (bad(|c| c.static_friction = Some(-1.0)), "static_friction", ">= 0"),
        (
            bad(|c| c.viscous_friction = Some(f64::NAN)),
            "viscous_friction",
            "finite",
        ),
        (bad(|c| c.stiction_velocity = Some(0.0)), "stiction_velocity", "> 0"),
        (bad(|c| c.stribeck_velocity = Some(-1e-3)), "stribeck_velocity", "> 0"),
        // names the scene format does not know: errors in the text itself
        (
            text.replace("law = \"hertz_ln\"", "law = \"hertz_lm\""),
            "toml",
            "unknown variant",
        ),
        (
            text.replace("impulse_method = \"exact\"", "impulse_method = \"approximate\""),
            "toml",
            "unknown variant",
        ),
    ];
    for (text, field, msg) in cases {
        let err = match Simulation::from_scene_str(&text, "bad.toml") {
            Ok(_) => panic!("accepted a bad scene (field {field})"),
            Err(e) => e,
        };
        let shown = err.to_string();
        println!("{shown}");
        assert!(shown.starts_with("bad.toml: "), "{shown}");
        assert_eq!(err.field, field, "{shown}");
        assert!(shown.contains(msg), "{shown}");
        if field != "toml" {
            assert!(err.item.contains("contact \"floor\""), "{shown}");
        }
    }
}

#[test]
fn penetration_beyond_max_is_a_failed_step() {
    // A soft linear contact and a fast ball: δ reaches max_penetration (2 mm): the step
    // fails with a message naming the contact, the state stays at the last good time.
    let floor = |c: ContactSpec| c.stiffness(1e3).damping(0.0).max_penetration(0.002);
    let mut s = start(ball_on_floor(Law::KelvinVoigt, floor, 5.0, 0.0, 1e-3));
    let err = s.step_to(0.01).unwrap_err().to_string();
    println!("{err}");
    assert!(
        err.contains("contact \"floor\"") && err.contains("max_penetration"),
        "{err}"
    );
    let t = s.time();
    // δ = 2 mm is reached at t = 1e-3/5 + the time to compress 2 mm (x = v sin(ωt)/ω, ω² = K/m)
    let w = (1e3 / M).sqrt();
    let t_max = 1e-3 / 5.0 + (0.002 * w / 5.0).asin() / w;
    assert!((t - t_max).abs() < 1e-9, "failed at {t}, expected {t_max}");
    assert!((get(&mut s, "floor.delta") - 0.002).abs() < 1e-9);
}
