//! The FMI 3.0 functions called through their C signatures, in-process (tests/python/test_fmi3.py
//! drives the exported FMUs through fmpy): the calling sequence, early return, states of both
//! versions told apart, handles of the other version refused, a resource path with `%` in it.

use crate::common;

use contact_fmu::fmi::exports as fmi2;
use contact_fmu::fmi::lifecycle::LifeState;
use contact_fmu::fmi::types::{fmi2CallbackFunctions, fmi2FMUstate, fmi2Status, FMI2_CO_SIMULATION};
use contact_fmu::fmi3::exports::*;
use contact_fmu::fmi3::types::*;
use contact_fmu::fmi3::unsupported::*;
use contact_fmu::guid::guid;
use std::ffi::{CStr, CString};
use std::os::raw::c_char;
use std::path::PathBuf;
use std::ptr;
use std::sync::Mutex;

const OK: fmi3Status = fmi3Status::fmi3OK;
const ERROR: fmi3Status = fmi3Status::fmi3Error;

/// The messages logged by every instance of these tests: (status, category, text).
static LOG: Mutex<Vec<(fmi3Status, String, String)>> = Mutex::new(Vec::new());

unsafe extern "C" fn logger(
    _env: fmi3InstanceEnvironment,
    status: fmi3Status,
    category: fmi3String,
    message: fmi3String,
) {
    // SAFETY: the library passes NUL-terminated strings.
    let (c, m) = unsafe { (CStr::from_ptr(category), CStr::from_ptr(message)) };
    let entry = (
        status,
        c.to_string_lossy().into_owned(),
        m.to_string_lossy().into_owned(),
    );
    LOG.lock().unwrap_or_else(|e| e.into_inner()).push(entry);
}

fn logged(text: &str) -> bool {
    LOG.lock()
        .unwrap_or_else(|e| e.into_inner())
        .iter()
        .any(|(_, _, m)| m.contains(text))
}

/// The bouncing ball unpacked as an FMU's resources, in a folder whose path has `%` and a
/// space in it (FMI 3.0 passes a path, not a URI: nothing is percent-decoded).
struct Unpacked {
    root: PathBuf,
    text: String,
}

impl Unpacked {
    fn new(tag: &str) -> Unpacked {
        let text = std::fs::read_to_string(common::bundled("bouncing_ball")).unwrap();
        let root = std::env::temp_dir().join(format!("contact fmu3 100%20 {} {tag}", std::process::id()));
        std::fs::create_dir_all(root.join("resources")).unwrap();
        std::fs::write(root.join("resources/scene.toml"), &text).unwrap();
        Unpacked { root, text }
    }

    fn instantiate(&self, early_return: bool) -> fmi3Instance {
        self.instantiate_with(false, early_return)
    }

    /// `fmi3InstantiateCoSimulation` with `eventModeUsed` and `earlyReturnAllowed`.
    fn instantiate_with(&self, event_mode: bool, early_return: bool) -> fmi3Instance {
        let path = CString::new(format!("{}/", self.root.join("resources").display())).unwrap();
        let token = CString::new(guid(&self.text)).unwrap();
        // SAFETY: valid strings, no intermediate variables, a logger of the right signature.
        unsafe {
            fmi3InstantiateCoSimulation(
                c"abi".as_ptr(),
                token.as_ptr(),
                path.as_ptr(),
                false,
                false,
                event_mode,
                early_return,
                ptr::null(),
                0,
                ptr::null_mut(),
                Some(logger),
                None,
            )
        }
    }
}

impl Drop for Unpacked {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.root);
    }
}

/// A step's outputs: (status, early return, last successful time).
fn step(c: fmi3Instance, t: f64, h: f64) -> (fmi3Status, bool, f64) {
    let (mut event, mut terminate, mut early, mut last) = (true, true, false, f64::NAN);
    // SAFETY: every output pointer is valid.
    let s = unsafe { fmi3DoStep(c, t, h, true, &mut event, &mut terminate, &mut early, &mut last) };
    assert!(s != OK || (!event && !terminate));
    (s, early, last)
}

fn init(c: fmi3Instance, values: &[(u32, f64)]) {
    // SAFETY: `c` is a live instance; the arrays hold one element.
    unsafe {
        assert_eq!(fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0), OK);
        for &(vr, x) in values {
            assert_eq!(fmi3SetFloat64(c, &vr, 1, &x, 1), OK);
        }
        assert_eq!(fmi3ExitInitializationMode(c), OK);
    }
}

#[test]
fn the_calling_sequence_is_fmi3s_and_values_are_typed() {
    let u = Unpacked::new("sequence");
    let c = u.instantiate(false);
    assert!(!c.is_null(), "a resource path with % and a space is taken as it is");
    // SAFETY: `c` is a live instance until it is freed; the arrays hold their lengths.
    unsafe {
        assert_eq!(step(c, 0.0, 1e-3).0, ERROR, "no step before initialisation");
        assert_eq!(instance_state(c), Some(LifeState::Error));
        assert_eq!(fmi3Reset(c), OK);
        init(c, &[]);
        assert_eq!(instance_state(c), Some(LifeState::StepComplete));
        assert_eq!(step(c, 0.0, 0.25), (OK, false, 0.25));
        // the enumeration ball_floor.law (value reference 3) is an Int64, not an Int32
        let (law, mut i64v, mut i32v) = (3u32, 0i64, 0i32);
        assert_eq!(fmi3GetInt64(c, &law, 1, &mut i64v, 1), OK);
        assert_eq!(i64v, 3);
        assert_eq!(fmi3GetInt32(c, &law, 1, &mut i32v, 1), ERROR);
        assert!(logged("is of type Enumeration (accessed as Int64), not Int32"));
        assert_eq!(fmi3Reset(c), OK);
        init(c, &[]);
        // a Boolean output read as bytes 0 or 1; Float32 variables there are none of
        let vars = contact_fmu::simulation::Simulation::from_scene_str(&u.text, "x").unwrap();
        let active = vars.table().index_of("ball_floor.active").unwrap() as u32;
        let mut b = [7u8];
        assert_eq!(fmi3GetBoolean(c, &active, 1, b.as_mut_ptr().cast(), 1), OK);
        assert_eq!(b, [0]);
        let mut f = 0f32;
        assert_eq!(fmi3GetFloat32(c, ptr::null(), 0, &mut f, 0), OK, "an empty list");
        assert_eq!(fmi3GetFloat32(c, &law, 1, &mut f, 1), ERROR);
        assert_eq!(fmi3Reset(c), OK);
        init(c, &[]);
        assert_eq!(
            fmi3EnterStepMode(c),
            ERROR,
            "Step Mode is entered by exiting initialisation"
        );
        assert_eq!(fmi3Reset(c), OK);
        init(c, &[]);
        assert_eq!(fmi3EnterEventMode(c), ERROR);
        assert!(logged("not supported: hasEventMode is false"));
        fmi3FreeInstance(c);
    }
    // event mode asked for: no instance
    let c = u.instantiate_with(true, false);
    assert!(c.is_null() && logged("this FMU has no event mode"));
}

#[test]
fn early_returns_end_at_impacts_and_continue_as_the_plain_run() {
    let u = Unpacked::new("early");
    let vars = contact_fmu::simulation::Simulation::from_scene_str(&u.text, "x").unwrap();
    let vr = |name: &str| vars.table().index_of(name).unwrap() as u32;
    let (law, e, z) = (vr("ball_floor.law"), vr("ball_floor.restitution"), vr("ball.r[3]"));
    let mut heights = Vec::new();
    let mut returns = Vec::new();
    for early in [true, false] {
        let c = u.instantiate(early);
        // SAFETY: `c` is a live instance; the arrays hold one element.
        unsafe {
            assert_eq!(fmi3EnterInitializationMode(c, false, 0.0, 0.0, true, 0.3), OK);
            assert_eq!(fmi3SetInt64(c, &law, 1, &6i64, 1), OK);
            assert_eq!(fmi3SetFloat64(c, &e, 1, &0.5, 1), OK);
            assert_eq!(fmi3ExitInitializationMode(c), OK);
        }
        let (mut t, mut here) = (0.0, Vec::new());
        for k in 1..=30 {
            let target = k as f64 * 1e-2;
            loop {
                let (s, stopped, last) = step(c, t, target - t);
                assert_eq!(s, OK);
                t = last;
                if !stopped {
                    break;
                }
                assert!(early);
                returns.push(t);
            }
            let mut x = 0.0;
            // SAFETY: as above.
            assert_eq!(unsafe { fmi3GetFloat64(c, &z, 1, &mut x, 1) }, OK);
            here.push(x.to_bits());
        }
        heights.push(here);
        // SAFETY: `c` is live.
        unsafe { fmi3FreeInstance(c) };
    }
    assert_eq!(heights[0], heights[1]);
    // e = 0.5 from 0.1 m: impacts at t1 = sqrt(2h/g), then 2 e^k v1 / g apart
    let (g, v1) = (9.81, (2.0 * 9.81 * 0.1f64).sqrt());
    let t1 = v1 / g;
    let expected = [t1, t1 + v1 / g];
    assert_eq!(returns.len(), 2, "{returns:?}");
    for (t, te) in returns.iter().zip(expected) {
        assert!((t - te).abs() < 2e-13, "{t} against {te}");
    }
}

#[test]
fn states_of_the_other_version_and_instances_of_the_other_version_are_refused() {
    let u = Unpacked::new("versions");
    let c3 = u.instantiate(false);
    init(c3, &[]);
    let uri = CString::new(format!(
        "file://{}",
        u.root
            .join("resources")
            .display()
            .to_string()
            .replace('%', "%25")
            .replace(' ', "%20")
    ))
    .unwrap();
    let token = CString::new(guid(&u.text)).unwrap();
    let callbacks = fmi2CallbackFunctions::default();
    // SAFETY: valid strings and callbacks; handles are used while live.
    unsafe {
        let c2 = fmi2::fmi2Instantiate(
            c"two".as_ptr(),
            FMI2_CO_SIMULATION,
            token.as_ptr(),
            uri.as_ptr(),
            &callbacks,
            0,
            0,
        );
        assert!(!c2.is_null());
        assert_eq!(fmi2::fmi2SetupExperiment(c2, 0, 0.0, 0.0, 0, 0.0), fmi2Status::fmi2OK);
        assert_eq!(fmi2::fmi2EnterInitializationMode(c2), fmi2Status::fmi2OK);
        assert_eq!(fmi2::fmi2ExitInitializationMode(c2), fmi2Status::fmi2OK);
        // a handle of the other version is no instance of this one (and stays alive)
        assert_eq!(step(c2, 0.0, 1e-3).0, ERROR);
        fmi3FreeInstance(c2);
        assert_eq!(fmi2::fmi2DoStep(c2, 0.0, 1e-3, 1), fmi2Status::fmi2OK);
        assert_eq!(fmi2::fmi2Terminate(c3), fmi2Status::fmi2Error);
        assert_eq!(instance_state(c3), Some(LifeState::StepComplete));
        // an FMI 2.0 state handle and its bytes, into the FMI 3.0 instance
        let mut s2: fmi2FMUstate = ptr::null_mut();
        assert_eq!(fmi2::fmi2GetFMUstate(c2, &mut s2), fmi2Status::fmi2OK);
        assert_eq!(fmi3SetFMUState(c3, s2), ERROR);
        assert!(logged(
            "saved by an FMI 2.0 instance; an FMI 3.0 instance does not restore it"
        ));
        let mut size = 0usize;
        assert_eq!(fmi2::fmi2SerializedFMUstateSize(c2, s2, &mut size), fmi2Status::fmi2OK);
        let mut bytes = vec![0 as c_char; size];
        assert_eq!(
            fmi2::fmi2SerializeFMUstate(c2, s2, bytes.as_mut_ptr(), size),
            fmi2Status::fmi2OK
        );
        assert_eq!(fmi3Reset(c3), OK);
        let mut s3: fmi3FMUState = ptr::null_mut();
        assert_eq!(fmi3DeserializeFMUState(c3, bytes.as_ptr().cast(), size, &mut s3), ERROR);
        assert!(s3.is_null());
        // an FMI 3.0 state's bytes round-trip, and FMI 2.0 refuses them
        assert_eq!(fmi3Reset(c3), OK);
        init(c3, &[]);
        assert_eq!(step(c3, 0.0, 0.1).0, OK);
        assert_eq!(fmi3GetFMUState(c3, &mut s3), OK);
        let mut size3 = 0usize;
        assert_eq!(fmi3SerializedFMUStateSize(c3, s3, &mut size3), OK);
        assert_eq!(size3, size + 8, "one more host number");
        let mut b3 = vec![0u8; size3];
        assert_eq!(fmi3SerializeFMUState(c3, s3, b3.as_mut_ptr(), size3), OK);
        let mut back: fmi3FMUState = ptr::null_mut();
        assert_eq!(fmi3DeserializeFMUState(c3, b3.as_ptr(), size3, &mut back), OK);
        let mut b3_again = vec![0u8; size3];
        assert_eq!(fmi3SerializeFMUState(c3, back, b3_again.as_mut_ptr(), size3), OK);
        assert_eq!(b3, b3_again);
        let mut s2_from3: fmi2FMUstate = ptr::null_mut();
        assert_eq!(
            fmi2::fmi2DeSerializeFMUstate(c2, b3.as_ptr().cast(), size3, &mut s2_from3),
            fmi2Status::fmi2Error
        );
        assert_eq!(fmi3FreeFMUState(c3, &mut s3), OK);
        assert_eq!(fmi3FreeFMUState(c3, &mut back), OK);
        assert_eq!(fmi2::fmi2FreeFMUstate(c2, &mut s2), fmi2Status::fmi2OK);
        fmi2::fmi2FreeInstance(c2);
        fmi3FreeInstance(c3);
    }
}
