//! Multibody dynamics of single joints against closed forms and conservation: the spring
//! slider, the spherical pendulum, fixed and free joints, inputs driving a chain, and initial
//! velocities projected onto the joints and loops (the helpers are `multibody.rs`'s).
//!
//! Run: `cargo test --release --test integration multibody_joints:: -- --nocapture`.

use crate::common;

use common::{energy_balance, get, quat_out, run, start, vec_out};
use contact_fmu::scene::{InputSpec, JointSpec, JointType, Method, Scene, SpringDamperSpec, GROUND};
use contact_fmu::simulation::Simulation;
use nalgebra::{Matrix3, Unit, UnitQuaternion, Vector3};
use std::f64::consts::PI;

use super::multibody::*;

// ---------------------------------------------------------------------------------------------
// prismatic joint with a spring-damper: analytic motion

/// Mass on a tilted prismatic joint pulled by a spring from a ground point on the joint line;
/// gravity has a component along the line. Returns (scene, s_eq, ω) where s is the distance
/// from the attachment point.
pub(super) fn spring_slider(damping: f64, method: Method, rtol: f64) -> (Scene, f64, f64) {
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

pub(super) fn check_spring_slider(damping: f64) {
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

pub(super) fn spherical_pendulum(method: Method, rtol: f64) -> Scene {
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
pub(super) fn first_joint_quaternion_norm(s: &mut Simulation) -> f64 {
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

pub(super) fn carriage_arm(arm_drive: &str) -> Scene {
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

pub(super) fn hinged(vel: Vector3<f64>, omega: Vector3<f64>) -> (Scene, Vector3<f64>, Vector3<f64>) {
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
