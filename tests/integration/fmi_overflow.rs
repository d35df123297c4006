//! Parameter values inside their ranges that overflow double precision (a mass of 1.8e308,
//! found by scripts/fuzz_fmi.py: the kinetic or potential energy became NaN or infinite
//! while fmi2ExitInitializationMode returned fmi2OK) are refused: exiting initialization
//! mode is an error naming the output, no fmi2GetReal returns fmi2OK with a value that is not
//! finite, and fmi2Reset recovers the instance. A finite input that overflows an output (a
//! traction of 1.8e308 on contacts resting under the impulse law) makes the read of that
//! output an error too.

use crate::fmu_session;

use contact_fmu::fmi::exports::*;
use contact_fmu::fmi::lifecycle::LifeState;
use contact_fmu::fmi::types::*;
use fmu_session::SceneDir;
use std::ffi::CString;

const OK: fmi2Status = fmi2Status::fmi2OK;
const ERROR: fmi2Status = fmi2Status::fmi2Error;

fn instantiate(dir: &SceneDir) -> fmi2Component {
    let (uri, guid) = (dir.resource_uri(), dir.guid());
    let name = CString::new("overflow").unwrap();
    let callbacks = fmi2CallbackFunctions::default();
    // SAFETY: valid strings and callbacks for the call.
    let c = unsafe {
        fmi2Instantiate(
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            uri.as_ptr(),
            &callbacks,
            0,
            0,
        )
    };
    assert!(!c.is_null());
    c
}

/// Reads one Real: the status and the value.
fn read(c: fmi2Component, vr: u32) -> (fmi2Status, f64) {
    let mut x = f64::NAN;
    // SAFETY: one value reference, one out value, a live instance.
    let s = unsafe { fmi2GetReal(c, &vr, 1, &mut x) };
    (s, x)
}

#[test]
fn an_overflowing_parameter_is_an_error_at_exit_initialization_and_reset_recovers() {
    for (scene, parameter, output) in [
        ("bouncing_ball", "ball.mass", "energy.potential"),
        ("rail_vehicle", "car.mass", "energy.kinetic"),
        ("two_spheres", "steel.youngs_modulus", "impact.stiffness"),
    ] {
        let dir = SceneDir::bundled(scene, &format!("overflow {scene}"));
        let (p, out) = (dir.vr(parameter), dir.vr(output));
        let c = instantiate(&dir);
        // SAFETY: a live instance and one-element arrays.
        unsafe {
            assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), OK);
            assert_eq!(fmi2EnterInitializationMode(c), OK);
            assert_eq!(fmi2SetReal(c, &p, 1, &f64::MAX), OK, "{scene}: inside the range (> 0)");
            assert_eq!(fmi2ExitInitializationMode(c), ERROR, "{scene}: {parameter} = f64::MAX");
            assert_eq!(instance_state(c), Some(LifeState::Error));
            let (status, x) = read(c, out);
            assert!(status == ERROR || x.is_finite(), "{scene}: {output} = {x} with fmi2OK");
            assert_eq!(read(c, p), (OK, f64::MAX), "{scene}: a parameter reads back as set");
            assert_eq!(fmi2DoStep(c, 0.0, 1e-3, 1), ERROR);

            assert_eq!(fmi2Reset(c), OK);
            assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), OK);
            assert_eq!(fmi2EnterInitializationMode(c), OK);
            assert_eq!(
                fmi2ExitInitializationMode(c),
                OK,
                "{scene}: start values after the reset"
            );
            let (status, x) = read(c, out);
            assert!(status == OK && x.is_finite(), "{scene}: {output} = {x}");
            assert_eq!(fmi2DoStep(c, 0.0, 1e-5, 1), OK);
            fmi2FreeInstance(c);
        }
    }
}

#[test]
fn outputs_read_in_initialization_mode_are_finite_or_an_error() {
    let dir = SceneDir::bundled("bouncing_ball", "overflow init");
    let (mass, potential) = (dir.vr("ball.mass"), dir.vr("energy.potential"));
    let c = instantiate(&dir);
    // SAFETY: a live instance and one-element arrays.
    unsafe {
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), OK);
        assert_eq!(fmi2EnterInitializationMode(c), OK);
        let (status, before) = read(c, potential);
        assert!(status == OK && before.is_finite());
        assert_eq!(fmi2SetReal(c, &mass, 1, &f64::MAX), OK);
        let (status, x) = read(c, potential);
        assert_eq!(status, ERROR, "energy.potential = {x}");
        fmi2FreeInstance(c);
    }
}

#[test]
fn an_input_that_overflows_an_output_makes_its_read_an_error() {
    // a contact resting under the impulse law carries the traction in its force (the rigid
    // vehicle on eight rigid contacts is statically indeterminate: which four carry its weight
    // depends on the history, so the test takes one that does)
    let dir = SceneDir::bundled("rail_vehicle", "overflow input");
    let sim = dir.simulation();
    let laws: Vec<u32> = sim
        .variables()
        .iter()
        .enumerate()
        .filter(|(_, v)| v.name.ends_with(".law"))
        .map(|(vr, _)| vr as u32)
        .collect();
    let traction = dir.vr("traction");
    let forces: Vec<fmi2ValueReference> = ["fl1", "fl2", "fr1", "fr2", "rl1", "rl2", "rr1", "rr2"]
        .iter()
        .map(|w| dir.vr(&format!("contact_{w}.force")))
        .collect();
    let impulse = 6;
    let c = instantiate(&dir);
    // SAFETY: a live instance and one-element arrays.
    unsafe {
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), OK);
        assert_eq!(fmi2EnterInitializationMode(c), OK);
        for law in &laws {
            assert_eq!(fmi2SetInteger(c, law, 1, &impulse), OK);
        }
        assert_eq!(fmi2ExitInitializationMode(c), OK);
        for k in 0..50 {
            assert_eq!(fmi2DoStep(c, k as f64 * 0.01, 0.01, 1), OK);
        }
        let mut saved: fmi2FMUstate = std::ptr::null_mut();
        assert_eq!(fmi2GetFMUstate(c, &mut saved), OK);
        assert_eq!(fmi2SetReal(c, &traction, 1, &1e3), OK);
        let loaded: Vec<(fmi2ValueReference, f64)> = forces
            .iter()
            .map(|&f| (f, read(c, f)))
            .map(|(f, (status, x))| {
                assert!(status == OK && x.is_finite(), "a moderate traction: {x}");
                (f, x)
            })
            .collect();
        // the weight, 2.6 t, on the resting contacts
        let &(force, _) = loaded
            .iter()
            .find(|(_, x)| *x > 1e3)
            .expect("a contact carries the vehicle");
        assert_eq!(fmi2SetReal(c, &traction, 1, &f64::MAX), OK, "finite, so accepted");
        let (status, x) = read(c, force);
        assert_eq!(status, ERROR, "the loaded contact's force = {x}");
        assert_eq!(fmi2SetFMUstate(c, saved), OK, "a saved state recovers");
        let (status, x) = read(c, force);
        assert!(status == OK && x.is_finite(), "{x}");
        assert_eq!(fmi2FreeFMUstate(c, &mut saved), OK);
        fmi2FreeInstance(c);
    }
}
