//! Friction checked against closed forms (docs/friction.md): a block on an incline (sticking
//! below tan θ = μ_s with a bounded creep, sliding with a = g (sin θ − μ cos θ) above), a
//! sphere launched sliding without spin (rolling from t = 2 v0/(7 μ g) at 5/7 v0, (1/7) m v0²
//! dissipated), the energy balance with friction.
//!
//! Run: `cargo test --release --test integration friction:: -- --nocapture --test-threads 1` (the measured
//! numbers are printed; docs/friction.md quotes them).

use crate::common;

use common::{energy_balance, get, rel, start, vec_out};
use contact_fmu::model::ContactEventKind;
use contact_fmu::scene::{BodySpec, ContactSpec, Law, Method, Scene, GROUND};
use contact_fmu::scene_builder::{Plane, SceneBuilder, Sphere};
use contact_fmu::simulation::Simulation;

const G: f64 = 9.81;

/// A scene "t" with gravity `g` (world vector) and the given solver.
fn header(g: [f64; 3], method: Method, rtol: f64, atol: f64, max_step: f64) -> SceneBuilder {
    SceneBuilder::new("t")
        .gravity(g)
        .experiment(1.0, 1e-2)
        .solver(method, rtol, atol, max_step)
}

// ---------------------------------------------------------------------------------------------
// Block on an incline

/// Block mass [kg], Hertz stiffness of each foot [N/m^1.5], foot radius [m].
const BLOCK_M: f64 = 2.0;
const FOOT_K: f64 = 1e9;
const FOOT_R: f64 = 0.01;

/// A block on an incline of angle `theta` (gravity tilted by θ about y, so the incline is the
/// plane z = 0 and "down the slope" is +x), standing on four spherical feet (Hertz,
/// `FOOT_K`) with friction `friction(contact)`, sliding down at `v0`. The feet are placed
/// at the static penetration, and the centre of mass lies in the contact plane, so friction
/// has no moment about it: the four normal forces stay m g cos θ / 4 each (a block whose
/// centre of mass is higher would pitch and make the normal forces oscillate).
fn block_on_incline(
    theta: f64,
    v0: f64,
    method: Method,
    law: Law,
    friction: impl Fn(ContactSpec) -> ContactSpec,
) -> (Scene, f64) {
    let (s, c) = theta.sin_cos();
    let delta0 = if law == Law::Impulse {
        0.0 // resting contact: touching, no penetration
    } else {
        (BLOCK_M * G * c / (4.0 * FOOT_K)).powf(2.0 / 3.0)
    };
    let block = BodySpec::new("block", BLOCK_M, [0.02, 0.02, 0.03], [0.0, 0.0, 0.0]).velocity([v0, 0.0, 0.0]);
    let mut b = header([G * s, 0.0, -G * c], method, 1e-10, 1e-14, 1e-2).body(block);
    for (k, (x, y)) in [(0.1, 0.1), (0.1, -0.1), (-0.1, 0.1), (-0.1, -0.1)]
        .into_iter()
        .enumerate()
    {
        let foot = Sphere::new("block", [x, y, FOOT_R - delta0], FOOT_R);
        let floor = Plane::horizontal([0.0; 3], [100.0, 100.0]);
        b = b.contact(friction(
            ContactSpec::sphere_plane(&format!("foot{k}"), law, foot, GROUND, floor).stiffness(FOOT_K),
        ));
    }
    let mut scene = b.build();
    scene.solver.max_steps = 10_000_000;
    (scene, delta0)
}

#[test]
fn block_slides_down_an_incline_with_the_coulomb_acceleration() {
    // tan θ > μ: a = g (sin θ − μ cos θ), constant, whatever μ_s and the stiction velocity
    // (the slip stays far above it). Measured from the velocity after 1 s (and the distance).
    for (theta, mu, mu_s) in [(0.5, 0.3, 0.3), (0.5, 0.3, 0.5), (0.3, 0.05, 0.05), (1.2, 1.5, 1.5)] {
        let v0 = 0.5;
        let (scene, _) = block_on_incline(theta, v0, Method::Dopri5, Law::Hertz, |c| {
            c.friction(mu).static_friction(mu_s).stribeck_velocity(1e-3)
        });
        let mut s = start(scene);
        let e0 = energy_balance(&mut s);
        let t = 1.0;
        s.step_to(t).unwrap();
        let a = G * (theta.sin() - mu * theta.cos());
        let v = get(&mut s, "block.v[1]");
        let x = get(&mut s, "block.r[1]");
        let a_v = (v - v0) / t;
        let a_x = 2.0 * (x - v0 * t) / (t * t);
        let drift = (energy_balance(&mut s) - e0).abs() / (0.5 * BLOCK_M * v * v);
        let f = get(&mut s, "foot0.friction_force[1]");
        println!(
            "θ = {theta}, μ = {mu}, μ_s = {mu_s}: a = {a:.9}, from v {a_v:.9} (rel {:.1e}), from x {a_x:.9} \
             (rel {:.1e}); friction on a foot {f:.6} N (μ m g cos θ / 4 = {:.6}); energy balance {drift:.1e}",
            rel(a_v, a),
            rel(a_x, a),
            mu * BLOCK_M * G * theta.cos() / 4.0
        );
        assert!(a > 0.0, "the block slides");
        assert!(rel(a_v, a) < 1e-6, "acceleration from the velocity {a_v} vs {a}");
        assert!(rel(a_x, a) < 1e-6, "acceleration from the distance {a_x} vs {a}");
        assert!(rel(-f, mu * BLOCK_M * G * theta.cos() / 4.0) < 1e-6, "Coulomb force");
        assert!(drift < 1e-6, "energy balance {drift}");
    }
}

#[test]
fn block_sticks_on_an_incline_below_the_static_coefficient() {
    // tan θ < μ_s: the block holds, creeping at most at the regularised law's speed
    // v_s tan θ / μ_s (the regularisation r(x) = x (2 − x) ≥ x gives at least the force of
    // the linear one): over 10 s at most 10 s · v_s tan θ/μ_s. The friction force carries the
    // weight's slope component, m g sin θ.
    let theta: f64 = 0.4; // tan θ = 0.423
    let (mu, mu_s) = (0.4, 0.6);
    for (v_s, method) in [(1e-4, Method::Radau5), (1e-3, Method::Dopri5)] {
        let (scene, _) = block_on_incline(theta, 0.0, method, Law::Hertz, |c| {
            c.friction(mu)
                .static_friction(mu_s)
                .stribeck_velocity(1e-2)
                .stiction_velocity(v_s)
        });
        let mut s = start(scene);
        let t0 = std::time::Instant::now();
        s.step_to(10.0).unwrap();
        let x = get(&mut s, "block.r[1]");
        let v = get(&mut s, "block.v[1]");
        let bound = 10.0 * v_s * theta.tan() / mu_s;
        let f: f64 = (0..4).map(|k| get(&mut s, &format!("foot{k}.friction_force[1]"))).sum();
        let weight = BLOCK_M * G * theta.sin();
        let steps = get(&mut s, "solver.steps");
        let rhs = get(&mut s, "solver.rhs_evals");
        println!(
            "v_s = {v_s:e} ({method:?}): creep {x:.3e} m in 10 s (bound {bound:.3e}), speed {v:.3e} m/s, friction \
             {f:.9} N vs m g sin θ = {weight:.9} (rel {:.1e}); {steps} steps, {rhs} RHS, {:.2} s",
            rel(-f, weight),
            t0.elapsed().as_secs_f64()
        );
        // the creep speed where the law's coefficient φ(v) equals tan θ (bisection, written here)
        let phi = |v: f64| {
            let x = v / v_s;
            let r = if x >= 1.0 { 1.0 } else { x * (2.0 - x) };
            (mu + (mu_s - mu) * (-(v / 1e-2) * (v / 1e-2)).exp()) * r
        };
        let (mut lo, mut hi) = (0.0, v_s);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if phi(mid) < theta.tan() {
                lo = mid
            } else {
                hi = mid
            }
        }
        println!("  creep speed of the law {lo:.6e} m/s (rel {:.1e})", rel(v, lo));
        assert!(rel(v, lo) < 1e-6, "creep speed {v} vs {lo}");
        assert!(x > 0.0 && x < bound, "creep {x} within (0, {bound})");
        assert!(v.abs() < v_s * theta.tan() / mu_s, "creep speed {v}");
        assert!(rel(-f, weight) < 1e-6, "friction holds the weight: {f} vs {weight}");
    }
}

// ---------------------------------------------------------------------------------------------
// Sphere launched sliding

/// The first Stick event (the slip speed falling below the stiction velocity: rolling).
fn first_stick(s: &Simulation) -> contact_fmu::model::ContactEvent {
    *s.contact_events()
        .iter()
        .find(|e| e.kind == ContactEventKind::Stick)
        .expect("a Stick event")
}

#[test]
fn sliding_sphere_starts_rolling_at_the_closed_form() {
    // A solid sphere (I = 2/5 m R²) launched at v0 without spin: friction μ m g decelerates
    // it and spins it up until the contact point stops slipping at t = 2 v0/(7 μ g), speed
    // 5/7 v0 (angular momentum about the contact point is conserved); (1/7) m v0² is
    // dissipated. The rolling onset is the Stick event (slip speed reaching v_s): later than
    // the rigid closed form by v_s/(7/2 μ g), i.e. relatively by v_s/v0. The contact is stiff
    // (K = 1e13) so that the lever arm R − δ differs from R by 2e-7 R.
    let (m, r, v0, mu) = (1.0, 0.05, 1.0, 0.3);
    let k = 1e13;
    let delta0 = (m * G / k).powf(2.0 / 3.0);
    for (method, v_s) in [(Method::Dopri5, 1e-6), (Method::Dopri5, 1e-7)] {
        let ball = BodySpec::sphere("ball", m, r, [0.0, 0.0, r - delta0]).velocity([v0, 0.0, 0.0]);
        let floor = Plane::horizontal([0.0; 3], [100.0, 100.0]);
        let contact = ContactSpec::sphere_plane("floor", Law::Hertz, Sphere::of(&ball, r), GROUND, floor)
            .stiffness(k)
            .friction(mu)
            .stiction_velocity(v_s);
        let mut scene = header([0.0, 0.0, -G], method, 1e-11, 1e-15, 1e-2)
            .body(ball)
            .contact(contact)
            .build();
        scene.solver.max_steps = 10_000_000;
        let mut s: Simulation = start(scene);
        let e0 = energy_balance(&mut s);
        let t_roll = 2.0 * v0 / (7.0 * mu * G);
        // The same closed forms with the lever arm h = R − δ0 of the contact point: the slip
        // speed falls at μ g (1 + m h²/I), the rolling speed is v0/(1 + I/(m h²)).
        let (h, inertia) = (r - delta0, 0.4 * m * r * r);
        let slip_rate = mu * G * (1.0 + m * h * h / inertia);
        let v_roll = v0 / (1.0 + inertia / (m * h * h));
        // while sliding: slip speed v0 − (7/2) μ g t
        let t1 = 0.5 * t_roll;
        s.step_to(t1).unwrap();
        let slip1 = get(&mut s, "floor.slip_velocity");
        let expected = v0 - slip_rate * t1;
        s.step_to(t_roll * 1.02).unwrap();
        let stick = first_stick(&s);
        let v = vec_out(&mut s, "ball.v");
        let w = vec_out(&mut s, "ball.w");
        let dissipated = get(&mut s, "energy.dissipated");
        let drift = (energy_balance(&mut s) - e0).abs();
        println!(
            "{method:?}, v_s = {v_s:e}: slip at t/2 {slip1:.12} (closed form {expected:.12}, rel {:.1e}); Stick at \
             {:.9} s (closed form {t_roll:.9}, rel {:.1e}); speed {:.12} (5/7 v0 rel {:.1e}), ω R/v {:.12}; \
             dissipated {dissipated:.12} J (m v0²/7 rel {:.1e}); energy balance {drift:.1e} J; {} steps",
            rel(slip1, expected),
            stick.time,
            rel(stick.time, t_roll),
            v.x,
            rel(v.x, 5.0 / 7.0 * v0),
            w.y * r / v.x,
            rel(dissipated, m * v0 * v0 / 7.0),
            get(&mut s, "solver.steps"),
        );
        println!(
            "  with the lever arm R − δ0: Stick at (v0 − v_s)/rate rel {:.1e}, speed v0/(1 + I/(m h²)) rel {:.1e}",
            rel(stick.time, (v0 - v_s) / slip_rate),
            rel(v.x, v_roll)
        );
        assert!(rel(slip1, expected) < 1e-9, "sliding phase");
        assert!(rel(stick.time, (v0 - v_s) / slip_rate) < 1e-9, "Stick event");
        assert!(rel(v.x, v_roll) < 1e-9, "rolling speed");
        assert!(
            rel(stick.time, t_roll) < 1e-5,
            "rolling onset {} vs {t_roll}",
            stick.time
        );
        assert!(rel(v.x, 5.0 / 7.0 * v0) < 1e-5, "rolling speed {}", v.x);
        assert!(rel(w.y * r, v.x) < 1e-5, "rolls: ω R = v");
        assert!(rel(dissipated, m * v0 * v0 / 7.0) < 1e-6, "dissipated {dissipated}");
        assert!(drift < 1e-9, "energy balance {drift}");
    }
}

// ---------------------------------------------------------------------------------------------
// Impacts with friction (impulse law)

/// The rigid-body impact of a solid sphere (mass `m`, radius `r`) on a fixed plane with
/// normal +z, restitution `e` and Coulomb friction `mu` (for a sphere the normal impulse
/// passes through the centre, so Newton's, Poisson's and Stronge's restitution coincide and
/// the tangential problem decouples): normal impulse P_n = (1 + e) m v_n⁻; the slip of the
/// contact point u = v_t + ω × (−r n) is stopped by P_t = −(2/7) m u if that lies inside the
/// cone (stick), else P_t = −μ P_n u/|u| (slip). Returns (v⁺, ω⁺, sticks).
fn sphere_impact(
    m: f64,
    r: f64,
    e: f64,
    mu: f64,
    v: nalgebra::Vector3<f64>,
    w: nalgebra::Vector3<f64>,
) -> (nalgebra::Vector3<f64>, nalgebra::Vector3<f64>, bool) {
    let n = nalgebra::Vector3::z();
    let pn = -(1.0 + e) * m * v.z;
    let arm = -n * r;
    let slip = v + w.cross(&arm);
    let u = slip - n * slip.dot(&n);
    let stick = -u * (2.0 / 7.0 * m);
    let sticks = stick.norm() <= mu * pn;
    let pt = if sticks { stick } else { -u.normalize() * (mu * pn) };
    let p = n * pn + pt;
    let inertia = 0.4 * m * r * r;
    (v + p / m, w + arm.cross(&p) / inertia, sticks)
}

#[test]
fn oblique_impact_of_a_sphere_matches_the_rigid_body_closed_form() {
    let (m, r) = (0.2, 0.02);
    let cases = [
        // (e, μ, v⁻, ω⁻)
        (0.8, 0.3, [0.3, 0.0, -2.0], [0.0, 0.0, 0.0]), // stick (slip stopped)
        (0.8, 0.1, [2.0, 0.0, -1.0], [0.0, 0.0, 0.0]), // slip
        (0.5, 0.1, [3.0, -2.0, -1.5], [10.0, 40.0, 3.0]), // slip, 3-D, spin about every axis
        (0.0, 0.5, [0.5, 0.2, -1.0], [-20.0, 5.0, 0.0]), // plastic, stick
        (1.0, 0.25, [0.2, 0.1, -3.0], [0.0, -10.0, 50.0]), // elastic, stick with spin about n
    ];
    let mut kinds = [0, 0];
    for (e, mu, v0, w0) in cases {
        let gap = 1e-4;
        let ball = BodySpec::sphere("ball", m, r, [0.0, 0.0, r + gap])
            .velocity(v0)
            .angular_velocity(w0);
        let floor = Plane::horizontal([0.0; 3], [100.0, 100.0]);
        let contact = ContactSpec::sphere_plane("floor", Law::Impulse, Sphere::of(&ball, r), GROUND, floor)
            .restitution(e)
            .friction(mu);
        let scene = header([0.0; 3], Method::Dopri5, 1e-12, 1e-15, 1e-3)
            .body(ball)
            .contact(contact);
        let mut s = start(scene);
        let ke0 = get(&mut s, "energy.kinetic");
        s.step_to(2.0 * gap / -v0[2]).unwrap();
        let (v, w) = (vec_out(&mut s, "ball.v"), vec_out(&mut s, "ball.w"));
        let (v_cf, w_cf, sticks) = sphere_impact(m, r, e, mu, v0.into(), w0.into());
        let lost = ke0 - (0.5 * m * v_cf.norm_squared() + 0.5 * 0.4 * m * r * r * w_cf.norm_squared());
        let dissipated = get(&mut s, "energy.dissipated");
        println!(
            "e = {e}, μ = {mu} ({}): v⁺ {:.9?} (closed form {:.9?}), ω⁺ {:.6?} ({:.6?}); dissipated {dissipated:.9} J \
             (closed form {lost:.9})",
            if sticks { "stick" } else { "slip" },
            v.as_slice(),
            v_cf.as_slice(),
            w.as_slice(),
            w_cf.as_slice()
        );
        kinds[sticks as usize] += 1;
        assert!((v - v_cf).norm() < 1e-12 * v_cf.norm().max(1.0), "v⁺ {v} vs {v_cf}");
        assert!((w - w_cf).norm() < 1e-12 * w_cf.norm().max(1.0) / r, "ω⁺ {w} vs {w_cf}");
        assert!(
            (dissipated - lost).abs() < 1e-12 * ke0,
            "dissipated {dissipated} vs {lost}"
        );
        assert_eq!(get(&mut s, "floor.impacts"), 1.0);
    }
    assert!(kinds[0] >= 2 && kinds[1] >= 2, "both stick and slip cases: {kinds:?}");
}

#[test]
fn impacts_with_friction_never_create_energy() {
    // 10⁴ random impacts with friction on bodies whose sphere is off the centre of mass (so
    // that the normal and tangential impulses couple, W_nt ≠ 0) and with anisotropic inertia,
    // free or hinged to the ground: random orientation, offset, velocities, e in [0, 1] and
    // μ in [0, 1.5]. The kinetic energy after every impact round is at most the one before
    // (to rounding) for the exact method; for both methods, friction removes energy: the
    // kinetic energy after the impact is at most the one after the same impact without it.
    use contact_fmu::contact::impulse::resolve_with;
    use contact_fmu::model::work::ImpulseWork;
    use contact_fmu::scene::{ImpulseMethod, JointSpec};
    let mut seed: u64 = 2024;
    let mut rnd = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut impacts, mut worst, mut sticks) = (0, f64::NEG_INFINITY, 0);
    for scene_no in 0..400 {
        let r = 0.05;
        let offset = [rnd() * 0.2 - 0.1, rnd() * 0.2 - 0.1, rnd() * 0.1];
        let q = nalgebra::UnitQuaternion::from_euler_angles(rnd() * 6.0, rnd() * 6.0, rnd() * 6.0);
        let (i1, i2) = (0.01 + 0.05 * rnd(), 0.01 + 0.05 * rnd());
        let lo = (i1 - i2).abs();
        let inertia = [i1, i2, lo + (i1 + i2 - lo) * (0.1 + 0.8 * rnd())];
        let centre = [0.0, 0.0, r];
        let pos = [-offset[0], -offset[1], r - offset[2]];
        let body = BodySpec::new("b", 1.0 + rnd(), inertia, pos).orientation(q);
        let floor = Plane::horizontal([0.0; 3], [100.0, 100.0]);
        let method = if scene_no % 4 == 3 {
            ImpulseMethod::EffectiveMass
        } else {
            ImpulseMethod::Exact
        };
        let contact = ContactSpec::sphere_plane("c", Law::Impulse, Sphere::new("b", centre, r), GROUND, floor)
            .impulse_method(method);
        let mut b = header([0.0; 3], Method::Dopri5, 1e-8, 1e-10, 1e-3)
            .body(body)
            .contact(contact);
        if scene_no % 2 == 1 {
            let axis = [rnd() - 0.5, rnd() - 0.5, rnd() - 0.5];
            let anchor = [pos[0] + 0.3, pos[1] - 0.2, pos[2] + 0.4];
            b = b.joint(JointSpec::revolute("hinge", GROUND, "b", anchor, axis));
        }
        let (m, mut d) = common::compile(b);
        let mut work = ImpulseWork::new(m.nv, m.fixed_rows(), 1);
        let state0 = d.state.clone();
        for _ in 0..70 {
            d.contacts[0].friction.mu = 1.5 * rnd();
            d.state.copy_from_slice(&state0);
            for v in d.state[m.nq..m.nq + m.nv].iter_mut() {
                *v = 4.0 * rnd() - 2.0;
            }
            let velocities = d.state[m.nq..m.nq + m.nv].to_vec();
            d.eval_state.copy_from_slice(&d.state);
            contact_fmu::forward::evaluate(&m, &mut d);
            let g = contact_fmu::contact::gap(&d, 0);
            if g.delta_dot <= 1e-6 {
                continue; // not approaching
            }
            let ke = contact_fmu::dynamics::kinetic_energy(&m, &d);
            let e = rnd();
            // the same impact without friction, for comparison
            let mu = d.contacts[0].friction.mu;
            d.contacts[0].friction.mu = 0.0;
            let frictionless = resolve_with(&m, &mut d, &mut work, &[0], &[e]);
            d.contacts[0].friction.mu = mu;
            d.state.copy_from_slice(&state0);
            d.state[m.nq..m.nq + m.nv].copy_from_slice(&velocities);
            d.eval_state.copy_from_slice(&d.state);
            contact_fmu::forward::evaluate(&m, &mut d);
            let (Ok(lost0), Ok(lost)) = (frictionless, resolve_with(&m, &mut d, &mut work, &[0], &[e])) else {
                continue; // the effective-mass method may refuse (a documented failure)
            };
            // (no drives here: what the impacts dissipate is the kinetic energy they remove)
            let (lost0, lost) = (lost0.dissipated, lost.dissipated);
            impacts += 1;
            worst = worst.max((lost0 - lost) / ke);
            let pt = work.friction_impulse(0);
            let pn = work.impulses()[0];
            if pt[0].hypot(pt[1]) < mu * pn * (1.0 - 1e-9) {
                sticks += 1;
            }
            assert!(pt[0].hypot(pt[1]) <= mu * pn * (1.0 + 1e-12), "inside the cone");
            assert!(
                lost >= lost0 - 1e-12 * ke,
                "impact {impacts} (scene {scene_no}): friction added energy"
            );
            if method == ImpulseMethod::Exact {
                assert!(
                    lost >= -1e-12 * ke,
                    "impact {impacts} (scene {scene_no}) created {:.3e} J",
                    -lost
                );
            }
        }
    }
    println!(
        "{impacts} random impacts with friction ({sticks} stick): largest energy friction added, relative to the \
         kinetic energy, {worst:.1e}"
    );
    assert!(impacts >= 10_000, "enough impacts tested: {impacts}");
    assert!(sticks > 100 && impacts - sticks > 100, "both regimes");
}

// ---------------------------------------------------------------------------------------------
// The rail vehicle brakes through its wheels

/// Total mass of the bundled rail vehicle [kg], wheel spin inertia [kg m²], wheel radius [m],
/// number of wheels, wheel-rail μ (fmu/rail_vehicle/scene.toml).
const TRAIN_M: f64 = 32000.0 + 4.0 * 1400.0 + 8.0 * 750.0;
const WHEEL_J: f64 = 55.0;
const WHEEL_R: f64 = 0.46;
const WHEELS: f64 = 8.0;
const RAIL_MU: f64 = 0.3;

/// The bundled rail vehicle at 80 km/h, settled for 3 s, then braked by `torque` on every axle
/// (`axle_torque` = −torque); the deceleration measured over [3.5 s, t_end] from the car
/// body's speed, the mean wheel-rail penetration, the energy balance (total + dissipated
/// energy against the work of the brake torques, relative to the initial energy) and the
/// number of wheels sliding at the end. At rtol 1e-8, atol 1e-10: the energy balance is checked
/// to 1e-8, which the scene's own tolerances (rtol 4e-6, chosen for 1e-6 of the range of
/// motion, docs/benchmarks.md §17) do not resolve while all eight wheels slide (6e-6 there).
fn brake(torque: f64, t_end: f64) -> (f64, f64, f64, usize) {
    let mut s = Simulation::from_file(&common::bundled("rail_vehicle")).unwrap();
    s.set_by_name("solver.rtol", 1e-8).unwrap();
    s.set_by_name("solver.atol", 1e-10).unwrap();
    s.initialize(0.0).unwrap();
    let e0 = energy_balance(&mut s);
    // in communication steps of the scene's interval (10 ms)
    let advance = |s: &mut Simulation, t: f64| {
        while s.time() < t - 1e-9 {
            s.step_to((s.time() + 1e-2).min(t)).unwrap();
        }
    };
    advance(&mut s, 3.0);
    let contacts = ["fl1", "fl2", "fr1", "fr2", "rl1", "rl2", "rr1", "rr2"];
    let turned = |s: &mut Simulation| contacts.iter().map(|c| get(s, &format!("axle_{c}.q"))).sum::<f64>();
    let (e3, turned3) = (energy_balance(&mut s), turned(&mut s));
    let input_work3 = get(&mut s, "energy.input_work");
    s.set_by_name("axle_torque", -torque).unwrap();
    advance(&mut s, 3.5);
    let v1 = get(&mut s, "car.v[1]");
    advance(&mut s, t_end);
    let v2 = get(&mut s, "car.v[1]");
    let delta = contacts
        .iter()
        .map(|c| get(&mut s, &format!("contact_{c}.delta")))
        .sum::<f64>()
        / WHEELS;
    let sliding = contacts
        .iter()
        .filter(|c| get(&mut s, &format!("contact_{c}.slip_velocity")) > 0.02)
        .count();
    // the brakes' work −T Σ Δθ is what total + dissipated energy changes by
    let work = -torque * (turned(&mut s) - turned3);
    let drift = (energy_balance(&mut s) - e3 - work).abs() / e0.abs();
    // energy.input_work, integrated with the state, is the same work
    let input_work = get(&mut s, "energy.input_work") - input_work3;
    assert!(
        (input_work - work).abs() <= 1e-6 * work.abs(),
        "input work {input_work} J against the brakes' -T Σ Δθ = {work} J"
    );
    ((v1 - v2) / (t_end - 3.5), delta, drift, sliding)
}

#[test]
fn braking_rail_vehicle_decelerates_by_the_torque_or_by_mu_g() {
    // Rolling wheels (3 kN m per wheel, within adhesion): a = 8 T/R_e / (M + 8 J/R_e²), R_e
    // the rolling radius R − δ. Sliding wheels (20 kN m, beyond adhesion): a = μ g.
    let torque = 3000.0;
    let (a, delta, drift, sliding) = brake(torque, 6.0);
    let r_e = WHEEL_R - delta;
    let a_cf = WHEELS * torque / r_e / (TRAIN_M + WHEELS * WHEEL_J / (r_e * r_e));
    println!(
        "rolling, {torque} N m per wheel: deceleration {a:.6} m/s² (closed form {a_cf:.6}, rel {:.1e}); \
         energy balance {drift:.1e}; {sliding} wheels sliding",
        rel(a, a_cf)
    );
    assert_eq!(sliding, 0, "the wheels roll");
    assert!(rel(a, a_cf) < 1e-4, "rolling deceleration {a} vs {a_cf}");
    assert!(drift < 1e-8, "energy balance {drift}");
    let (a, _, drift, sliding) = brake(20000.0, 6.0);
    println!(
        "sliding, 20 kN m per wheel: deceleration {a:.6} m/s² (μ g = {:.6}, rel {:.1e}); energy balance {drift:.1e}",
        RAIL_MU * G,
        rel(a, RAIL_MU * G)
    );
    assert_eq!(sliding, 8, "every wheel slides");
    assert!(rel(a, RAIL_MU * G) < 1e-4, "sliding deceleration {a} vs μ g");
    assert!(drift < 1e-8, "energy balance {drift}");
}

#[test]
fn resting_impulse_contacts_have_friction_too() {
    // The impulse law's resting contact (a constraint row whose multiplier is the normal
    // force) with the same friction law: the friction force follows the multiplier. The
    // sliding sphere rolls at t = 2 v0/(7 μ g) with 5/7 v0 — here the lever arm is exactly R
    // (no penetration), so the closed forms hold without correction; and the block on the
    // incline (four resting feet, redundant rows) slides at g (sin θ − μ cos θ) and sticks
    // with the law's creep.
    let (m, r, v0, mu, v_s) = (1.0, 0.05, 1.0, 0.3, 1e-7);
    let ball = BodySpec::sphere("ball", m, r, [0.0, 0.0, r]).velocity([v0, 0.0, 0.0]);
    let floor = Plane::horizontal([0.0; 3], [100.0, 100.0]);
    let contact = ContactSpec::sphere_plane("floor", Law::Impulse, Sphere::of(&ball, r), GROUND, floor)
        .friction(mu)
        .stiction_velocity(v_s);
    let mut scene = header([0.0, 0.0, -G], Method::Dopri5, 1e-11, 1e-15, 1e-2)
        .body(ball)
        .contact(contact)
        .build();
    scene.solver.max_steps = 10_000_000;
    let mut s = start(scene);
    assert_eq!(get(&mut s, "floor.active"), 1.0, "the ball rests on the floor");
    let e0 = energy_balance(&mut s);
    let t_roll = 2.0 * v0 / (7.0 * mu * G);
    s.step_to(0.5 * t_roll).unwrap();
    let slip1 = get(&mut s, "floor.slip_velocity");
    let f = vec_out(&mut s, "floor.friction_force");
    s.step_to(t_roll * 1.02).unwrap();
    let stick = first_stick(&s);
    let v = vec_out(&mut s, "ball.v");
    let dissipated = get(&mut s, "energy.dissipated");
    let drift = (energy_balance(&mut s) - e0).abs();
    println!(
        "impulse law, resting: slip at t/2 {slip1:.12} (closed form {:.12}), friction {:.9} N (μ m g {:.9}); Stick at \
         {:.9} s ((v0 − v_s)/(7/2 μ g) rel {:.1e}, rigid closed form rel {:.1e}); speed rel {:.1e}; dissipated rel \
         {:.1e}; energy balance {drift:.1e} J",
        0.5 * v0,
        -f.x,
        mu * m * G,
        stick.time,
        rel(stick.time, (v0 - v_s) / (3.5 * mu * G)),
        rel(stick.time, t_roll),
        rel(v.x, 5.0 / 7.0 * v0),
        rel(dissipated, m * v0 * v0 / 7.0),
    );
    assert!(rel(slip1, 0.5 * v0) < 1e-10, "sliding phase");
    assert!(
        rel(-f.x, mu * m * G) < 1e-12 && f.y.abs() < 1e-12 && f.z.abs() < 1e-12,
        "Coulomb force {f}"
    );
    assert!(rel(stick.time, (v0 - v_s) / (3.5 * mu * G)) < 1e-9, "Stick event");
    assert!(rel(stick.time, t_roll) < 1e-5, "rolling onset");
    assert!(rel(v.x, 5.0 / 7.0 * v0) < 1e-9, "rolling speed {}", v.x);
    assert!(rel(dissipated, m * v0 * v0 / 7.0) < 1e-9, "dissipated {dissipated}");
    assert!(drift < 1e-9, "energy balance {drift}");

    // the block on four resting feet (four rows for three constrained motions: redundant)
    let (theta, mu_k, v0) = (0.5_f64, 0.3, 0.5);
    let (scene, _) = block_on_incline(theta, v0, Method::Dopri5, Law::Impulse, |c| c.friction(mu_k));
    let mut s = start(scene);
    let e0 = energy_balance(&mut s);
    s.step_to(1.0).unwrap();
    let a = G * (theta.sin() - mu_k * theta.cos());
    let a_v = get(&mut s, "block.v[1]") - v0;
    let total: f64 = (0..4).map(|k| get(&mut s, &format!("foot{k}.friction_force[1]"))).sum();
    let drift = (energy_balance(&mut s) - e0).abs();
    println!(
        "impulse law, block on four resting feet: a {a_v:.12} (closed form {a:.12}, rel {:.1e}); friction {total:.9} N \
         (μ m g cos θ {:.9}); energy balance {drift:.1e} J",
        rel(a_v, a),
        mu_k * BLOCK_M * G * theta.cos()
    );
    assert!(rel(a_v, a) < 1e-6, "slide acceleration {a_v} vs {a}");
    assert!(
        rel(-total, mu_k * BLOCK_M * G * theta.cos()) < 1e-9,
        "Coulomb force {total}"
    );
    assert!(drift < 1e-9, "energy balance {drift}");
}
