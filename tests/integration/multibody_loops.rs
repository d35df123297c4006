//! Closed loops and the right-hand side's paths: loop-constraint rows against finite
//! differences, no allocation, restored states, mixed chains, branch points, and the lean and
//! rotor paths against the general evaluation (the helpers are `multibody.rs`'s).
//!
//! Run: `cargo test --release --test integration multibody_loops:: -- --nocapture`.

use crate::common;

use common::{compile, energy_balance, get, open, run, start};
use contact_fmu::contact;
use contact_fmu::dynamics;
use contact_fmu::forward::Rhs;
use contact_fmu::integrator::OdeSystem;
use contact_fmu::kinematics;
use contact_fmu::scene::{
    ContactSpec, InputSpec, JointSpec, JointType, Law, MaterialSpec, Method, Scene, SpringDamperSpec, GROUND,
};
use contact_fmu::scene_builder::{Plane, Sphere};
use contact_fmu::simulation::Simulation;
use nalgebra::{Quaternion, Unit, UnitQuaternion, Vector3};
use std::f64::consts::PI;

use super::multibody::*;
use super::multibody_joints::spherical_pendulum;

// ---------------------------------------------------------------------------------------------
// loop-constraint rows: values, rates and bias terms against finite differences

/// A non-planar chain (revolute, prismatic, spherical and revolute tree joints with skew axes)
/// closed back to the ground and onto itself by a revolute, a prismatic, a spherical and a
/// fixed loop joint, each tested on its own.
pub(super) fn loop_zoo(closing: &str) -> Scene {
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
pub(super) fn displaced(m: &contact_fmu::model::Model, qpos: &[f64], dv: &[f64]) -> Vec<f64> {
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
pub(super) fn lean_and_general(
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
