//! Contact module checked against physics: detection geometry against hand computations and
//! finite differences, Hertz closed forms (PHYSICS.md §6), effective restitution of the
//! damped laws against an independent integration of the scalar law, energy balance,
//! impulse laws against (14)-(16), the paper's effective mass (17)-(19) against the exact
//! solve, resting contact, cylinders, Newton's cradle, and scene validation.
//!
//! Run: `cargo test --release --test contact -- --nocapture` (measured numbers are printed;
//! docs/contact.md quotes them).

use contact_fmu::contact::{self, geometry, ContactElement, Shape};
use contact_fmu::dynamics::{self, Frame};
use contact_fmu::engine::{ContactEvent, ContactEventKind};
use contact_fmu::scene::{ContactType, ImpulseMethod, Law, Scene};
use contact_fmu::simulation::Simulation;
use contact_fmu::spatial::Spatial;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------------------
// helpers

fn sim(text: &str) -> Simulation {
    let mut s = Simulation::from_scene_str(text, "test.toml").unwrap_or_else(|e| panic!("{e}"));
    s.initialize(0.0).unwrap_or_else(|e| panic!("{e}"));
    s
}

fn get(s: &mut Simulation, name: &str) -> f64 {
    let vr = s.table().index_of(name).unwrap_or_else(|| panic!("no variable {name}"));
    s.get(vr).unwrap()
}

fn events(s: &Simulation) -> Vec<ContactEvent> {
    s.engine().unwrap().contact_events().to_vec()
}

fn first(ev: &[ContactEvent], kind: ContactEventKind) -> ContactEvent {
    *ev.iter()
        .find(|e| e.kind == kind)
        .unwrap_or_else(|| panic!("no {kind:?} event in {ev:?}"))
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

fn v3(v: Vector3<f64>) -> String {
    format!("[{:?}, {:?}, {:?}]", v.x, v.y, v.z)
}

fn header(gravity: f64, rtol: f64, atol: f64, max_step: f64) -> String {
    format!(
        "[model]\nname = \"t\"\ngravity = [0.0, 0.0, {:?}]\nstop_time = 1.0\ninterval = 1e-3\n\n\
         [solver]\nmethod = \"dopri5\"\nrtol = {rtol:?}\natol = {atol:?}\nmax_step = {max_step:?}\n\n\
         [[material]]\nname = \"steel\"\nyoungs_modulus = 210e9\npoisson_ratio = 0.3\n\n",
        -gravity
    )
}

fn ball(name: &str, mass: f64, radius: f64, pos: Vector3<f64>, vel: Vector3<f64>) -> String {
    let i = 0.4 * mass * radius * radius;
    format!(
        "[[body]]\nname = \"{name}\"\nmass = {mass:?}\ninertia = [{i:?}, {i:?}, {i:?}]\nposition = {}\nvelocity = {}\n\n",
        v3(pos),
        v3(vel)
    )
}

/// Steel ball, R = 10 mm.
const R: f64 = 0.01;
const M: f64 = 0.0329;
const E_STEEL: f64 = 210e9;
const NU_STEEL: f64 = 0.3;

/// A steel ball above a steel floor (plane z = 0), a gap `gap` away, moving down at `v0`.
fn ball_on_floor(law: &str, extra: &str, v0: f64, gravity: f64, gap: f64) -> String {
    let mut t = header(gravity, 1e-10, 1e-14, 1e-3);
    t += &ball(
        "ball",
        M,
        R,
        Vector3::new(0.0, 0.0, R + gap),
        Vector3::new(0.0, 0.0, -v0),
    );
    t += &format!(
        "[[contact]]\nname = \"floor\"\ntype = \"sphere_plane\"\nlaw = \"{law}\"\nsphere_body = \"ball\"\n\
         center = [0.0, 0.0, {:?}]\nradius = {R:?}\nsphere_material = \"steel\"\nbody = \"ground\"\n\
         material = \"steel\"\norigin = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nu_axis = [1.0, 0.0, 0.0]\n\
         size = [1.0, 1.0]\n{extra}\n",
        R + gap
    );
    t
}

/// Hertz stiffness of two steel bodies, effective radius `r_eff`, computed here from the
/// corrected (22) independently of the library.
fn hertz_k(r_eff: f64) -> f64 {
    let h = (1.0 - NU_STEEL * NU_STEEL) / (PI * E_STEEL);
    4.0 / (3.0 * PI * (h + h)) * r_eff.sqrt()
}

/// Γ(x) for x > 0 (Lanczos, g = 7).
fn gamma(x: f64) -> f64 {
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

/// Closed forms of PHYSICS.md §6: (δ_max, F_max, t_c).
fn hertz_closed_form(m: f64, k: f64, v0: f64) -> (f64, f64, f64) {
    let dmax = (5.0 * m * v0 * v0 / (4.0 * k)).powf(0.4);
    let c = 4.0 * PI.sqrt() * gamma(0.4) / (5.0 * gamma(0.9));
    (dmax, k * dmax.powf(1.5), c * dmax / v0)
}

// ---------------------------------------------------------------------------------------------
// Hertz closed forms

#[test]
fn hertz_sphere_plane_matches_closed_form() {
    let v0 = 1.0;
    let mut s = sim(&ball_on_floor("hertz", "", v0, 0.0, 1e-4));
    s.step_to(1e-3).unwrap();
    let ev = events(&s);
    let touch = first(&ev, ContactEventKind::Touch);
    let peak = first(&ev, ContactEventKind::Peak);
    let sep = first(&ev, ContactEventKind::Separation);
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
    let mut t = header(0.0, 1e-10, 1e-14, 1e-3);
    t += &ball("small", m1, r1, Vector3::new(x1, 0.0, 0.0), Vector3::new(v0, 0.0, 0.0));
    t += &ball("large", m2, r2, Vector3::new(x2, 0.0, 0.0), Vector3::zeros());
    t += &format!(
        "[[contact]]\nname = \"c\"\ntype = \"sphere_sphere\"\nlaw = \"hertz\"\nsphere_body = \"small\"\n\
         center = [{x1:?}, 0.0, 0.0]\nradius = {r1:?}\nsphere_material = \"steel\"\nbody = \"large\"\n\
         material = \"steel\"\nother_center = [{x2:?}, 0.0, 0.0]\nother_radius = {r2:?}\n"
    );
    let mut s = sim(&t);
    s.step_to(1e-3).unwrap();
    let ev = events(&s);
    let touch = first(&ev, ContactEventKind::Touch);
    let peak = first(&ev, ContactEventKind::Peak);
    let sep = first(&ev, ContactEventKind::Separation);
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
fn damping_factor(law: &str, e: f64) -> f64 {
    match law {
        "hertz_ln" => 3.0 * (1.0 - e * e) / 4.0,
        "hunt_crossley" => 3.0 * (1.0 - e) / 2.0,
        "flores" => 8.0 * (1.0 - e) / (5.0 * e),
        _ => unreachable!(),
    }
}

/// Exit speed / impact speed of `m δ̈ = −max(0, K δ^1.5 (1 + d δ̇/v0))`, δ(0) = 0, δ̇(0) = v0,
/// by classical RK4 with a fixed step (1/20000 of the Hertz contact time), the exit speed
/// interpolated linearly at δ = 0.
fn scalar_restitution(m: f64, k: f64, d: f64, v0: f64) -> f64 {
    let (_, _, tc) = hertz_closed_form(m, k, v0);
    let h = tc / 20000.0;
    let acc = |x: f64, v: f64| -> f64 {
        let x = x.max(0.0);
        -(k * x.powf(1.5) * (1.0 + d * v / v0)).max(0.0) / m
    };
    let (mut x, mut v) = (0.0_f64, v0);
    for _ in 0..10_000_000 {
        let (k1x, k1v) = (v, acc(x, v));
        let (k2x, k2v) = (v + 0.5 * h * k1v, acc(x + 0.5 * h * k1x, v + 0.5 * h * k1v));
        let (k3x, k3v) = (v + 0.5 * h * k2v, acc(x + 0.5 * h * k2x, v + 0.5 * h * k2v));
        let (k4x, k4v) = (v + h * k3v, acc(x + h * k3x, v + h * k3v));
        let xn = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
        let vn = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
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
fn engine_restitution(law: &str, e: f64, clamp_events: bool) -> (f64, u64) {
    let v0 = 1.0;
    let mut s = Simulation::from_scene_str(
        &ball_on_floor(law, &format!("restitution = {e:?}"), v0, 0.0, 1e-4),
        "t.toml",
    )
    .unwrap();
    s.initialize(0.0).unwrap();
    s.engine_mut().unwrap().set_clamp_events(clamp_events);
    s.step_to(1e-3).unwrap();
    let ev = events(&s);
    assert!(
        ev.iter().any(|e| e.kind == ContactEventKind::Separation),
        "{law} e={e}: no separation"
    );
    (get(&mut s, "ball.v[3]") / v0, s.engine().unwrap().counters().steps)
}

#[test]
fn effective_restitution_of_damped_laws() {
    let k = hertz_k(R);
    let mut table = Vec::new();
    println!(
        "law           e     engine e_eff   scalar e_eff   |engine-scalar|  steps (clamp events on/off, error off)"
    );
    for law in ["hertz_ln", "hunt_crossley", "flores"] {
        for e in [0.3, 0.5, 0.7, 0.9] {
            let (eng, steps) = engine_restitution(law, e, true);
            let (eng_off, steps_off) = engine_restitution(law, e, false);
            let sc = scalar_restitution(M, k, damping_factor(law, e), 1.0);
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
    let extra = format!("stiffness = {k:?}\ndamping = {c:?}\n");
    let run = |clamp: bool| {
        let mut s =
            Simulation::from_scene_str(&ball_on_floor("kelvin_voigt", &extra, v0, 0.0, 1e-4), "t.toml").unwrap();
        s.initialize(0.0).unwrap();
        s.engine_mut().unwrap().set_clamp_events(clamp);
        s.step_to(2e-3).unwrap();
        let ev = events(&s);
        (get(&mut s, "ball.v[3]"), s.engine().unwrap().counters(), ev)
    };
    // scalar: m x'' = -max(0, k x + c x'), fine RK4 step, exit when x returns to 0
    let h = 1e-9;
    let acc = |x: f64, v: f64| -((k * x + c * v).max(0.0)) / M;
    let (mut x, mut v) = (0.0_f64, v0);
    let exit = loop {
        let (k1x, k1v) = (v, acc(x, v));
        let (k2x, k2v) = (v + 0.5 * h * k1v, acc(x + 0.5 * h * k1x, v + 0.5 * h * k1v));
        let (k3x, k3v) = (v + 0.5 * h * k2v, acc(x + 0.5 * h * k2x, v + 0.5 * h * k2v));
        let (k4x, k4v) = (v + h * k3v, acc(x + h * k3x, v + h * k3v));
        let xn = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
        let vn = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
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
