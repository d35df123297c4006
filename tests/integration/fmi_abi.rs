//! The FMI functions called through their C signatures, in-process (the Python tests drive
//! the exported FMU files through fmpy; these pin the same behaviour without a host).

use crate::common;

use contact_fmu::fmi::exports::*;
use contact_fmu::fmi::lifecycle::LifeState;
use contact_fmu::fmi::types::*;
use contact_fmu::guid::guid;
use contact_fmu::simulation::Simulation;
use contact_fmu::variables::{Causality, VarType};
use std::ffi::CString;
use std::path::PathBuf;
use std::ptr;
use std::sync::{PoisonError, RwLock, RwLockReadGuard, RwLockWriteGuard};

const OK: fmi2Status = fmi2Status::fmi2OK;
const ERROR: fmi2Status = fmi2Status::fmi2Error;

/// Tests run on parallel threads of one process, so an address freed by one test may come back
/// from the next allocation of another. A test that keeps a freed handle to check that it is
/// refused holds this lock exclusively (no other test allocates instances or states meanwhile);
/// every other test that makes them holds it shared.
static HANDLES: RwLock<()> = RwLock::new(());

/// For a test that makes instances or states.
fn shared() -> RwLockReadGuard<'static, ()> {
    HANDLES.read().unwrap_or_else(PoisonError::into_inner)
}

/// For a test that keeps freed handles.
fn exclusive() -> RwLockWriteGuard<'static, ()> {
    HANDLES.write().unwrap_or_else(PoisonError::into_inner)
}

/// A scene unpacked like an FMU, in a folder whose path contains a space.
struct Unpacked {
    root: PathBuf,
    text: String,
}

impl Unpacked {
    fn new(tag: &str) -> Unpacked {
        Unpacked::of("bouncing_ball", tag)
    }

    /// The bundled scene `name`, unpacked as an FMU's resources.
    fn of(name: &str, tag: &str) -> Unpacked {
        let text = std::fs::read_to_string(common::bundled(name)).unwrap();
        let root = std::env::temp_dir().join(format!("contact fmu abi {} {tag}", std::process::id()));
        std::fs::create_dir_all(root.join("resources")).unwrap();
        std::fs::write(root.join("resources/scene.toml"), &text).unwrap();
        Unpacked { root, text }
    }

    fn uri(&self) -> String {
        let path = self.root.join("resources").display().to_string();
        format!("file://{}", path.replace('%', "%25").replace(' ', "%20"))
    }

    fn instantiate_with(&self, name: &str, guid_text: &str, uri: &str) -> fmi2Component {
        let callbacks = fmi2CallbackFunctions::default();
        let name = CString::new(name).unwrap();
        let g = CString::new(guid_text).unwrap();
        let u = CString::new(uri).unwrap();
        // SAFETY: valid strings and callbacks that live for the call.
        unsafe {
            fmi2Instantiate(
                name.as_ptr(),
                FMI2_CO_SIMULATION,
                g.as_ptr(),
                u.as_ptr(),
                &callbacks,
                0,
                0,
            )
        }
    }

    fn instantiate(&self) -> Component {
        let c = self.instantiate_with("abi", &guid(&self.text), &self.uri());
        assert!(!c.is_null());
        Component(c)
    }

    fn simulation(&self) -> Simulation {
        Simulation::from_scene_str(&self.text, "scene.toml").unwrap()
    }

    /// The facade simulation and the value references of its real outputs.
    fn simulation_and_outputs(&self) -> (Simulation, Vec<u32>) {
        let sim = self.simulation();
        let outs = real_outputs(&sim);
        (sim, outs)
    }
}

fn real_outputs(sim: &Simulation) -> Vec<u32> {
    sim.variables()
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == Causality::Output && v.vtype == VarType::Real)
        .map(|(i, _)| i as u32)
        .collect()
}

impl Drop for Unpacked {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.root);
    }
}

/// An instance freed on drop.
struct Component(fmi2Component);

impl Drop for Component {
    fn drop(&mut self) {
        // SAFETY: a live instance from fmi2Instantiate, freed once.
        unsafe { fmi2FreeInstance(self.0) }
    }
}

impl Component {
    fn state(&self) -> LifeState {
        // SAFETY: a live instance.
        unsafe { instance_state(self.0) }.unwrap()
    }
    fn init(&self) {
        // SAFETY: a live instance.
        unsafe {
            assert_eq!(fmi2SetupExperiment(self.0, 0, 0.0, 0.0, 0, 0.0), OK);
            assert_eq!(fmi2EnterInitializationMode(self.0), OK);
            assert_eq!(fmi2ExitInitializationMode(self.0), OK);
        }
    }
    fn step(&self, t: f64, h: f64) -> fmi2Status {
        // SAFETY: a live instance.
        unsafe { fmi2DoStep(self.0, t, h, FMI2_TRUE) }
    }
    fn reals(&self, vrs: &[u32]) -> Vec<f64> {
        let mut out = vec![0.0; vrs.len()];
        // SAFETY: arrays of vrs.len() elements.
        let s = unsafe { fmi2GetReal(self.0, vrs.as_ptr(), vrs.len(), out.as_mut_ptr()) };
        assert_eq!(s, OK);
        out
    }
}

#[test]
fn stepping_through_fmi_equals_the_simulation_facade_bit_for_bit() {
    let _handles = shared();
    let u = Unpacked::new("facade");
    let (mut sim, outs) = u.simulation_and_outputs();
    let c = u.instantiate();
    c.init();
    sim.initialize(0.0).unwrap();
    let h = 1e-3;
    for k in 0..300 {
        let t = k as f64 * h;
        assert_eq!(c.step(t, h), OK);
        sim.step_to(t + h).unwrap();
        let direct: Vec<f64> = outs.iter().map(|&vr| sim.get(vr as usize).unwrap()).collect();
        assert_eq!(c.reals(&outs), direct, "t = {}", t + h);
    }
}

#[test]
fn wrong_guid_empty_name_or_missing_resources_give_null() {
    let _handles = shared();
    let u = Unpacked::new("null");
    assert!(u
        .instantiate_with("x", "{00000000-0000-0000-0000-000000000000}", &u.uri())
        .is_null());
    assert!(u.instantiate_with("", &guid(&u.text), &u.uri()).is_null());
    assert!(u
        .instantiate_with("x", &guid(&u.text), "file:///nonexistent/resources")
        .is_null());
    assert!(u
        .instantiate_with("x", &guid(&u.text), "http://example.org/resources")
        .is_null());
    // SAFETY: NULL arguments are part of what is checked.
    unsafe {
        assert!(fmi2Instantiate(ptr::null(), 1, ptr::null(), ptr::null(), ptr::null(), 0, 0).is_null());
    }
}

#[test]
fn null_component_and_null_arrays_are_errors_not_crashes() {
    let _handles = shared();
    let u = Unpacked::new("nulls");
    // SAFETY: NULL pointers are what is checked.
    unsafe {
        assert_eq!(fmi2DoStep(ptr::null_mut(), 0.0, 1e-3, 0), ERROR);
        assert_eq!(fmi2Terminate(ptr::null_mut()), ERROR);
        fmi2FreeInstance(ptr::null_mut());
        let c = u.instantiate();
        c.init();
        assert_eq!(fmi2GetReal(c.0, ptr::null(), 1, ptr::null_mut()), ERROR);
        assert_eq!(c.state(), LifeState::Error);
        assert_eq!(fmi2Reset(c.0), OK);
        c.init();
        assert_eq!(fmi2GetReal(c.0, ptr::null(), 0, ptr::null_mut()), OK);
        assert_eq!(fmi2FreeFMUstate(c.0, ptr::null_mut()), OK);
    }
}

#[test]
fn calls_out_of_sequence_are_errors_and_reset_recovers() {
    let _handles = shared();
    let u = Unpacked::new("sequence");
    let c = u.instantiate();
    assert_eq!(c.state(), LifeState::Instantiated);
    assert_eq!(c.step(0.0, 1e-3), ERROR);
    assert_eq!(c.state(), LifeState::Error);
    // SAFETY: a live instance.
    unsafe {
        assert_eq!(fmi2EnterInitializationMode(c.0), ERROR);
        assert_eq!(fmi2Reset(c.0), OK);
    }
    assert_eq!(c.state(), LifeState::Instantiated);
    c.init();
    assert_eq!(c.state(), LifeState::StepComplete);
    assert_eq!(c.step(0.0, 1e-3), OK);
    // A fixed parameter cannot change after initialisation; an input can.
    let sim = u.simulation();
    let mass = sim.table().index_of("ball.mass").unwrap() as u32;
    // SAFETY: one-element arrays.
    unsafe {
        assert_eq!(fmi2SetReal(c.0, &mass, 1, &1.0), ERROR);
    }
}

#[test]
fn communication_points_must_match_and_steps_must_be_positive() {
    let _handles = shared();
    let u = Unpacked::new("points");
    for (t, h) in [
        (0.0, 0.0),
        (0.0, -1e-3),
        (0.1, 1e-3),
        (f64::NAN, 1e-3),
        (0.0, f64::INFINITY),
    ] {
        let c = u.instantiate();
        c.init();
        assert_eq!(c.step(t, h), ERROR, "t = {t}, h = {h}");
    }
    let c = u.instantiate();
    c.init();
    assert_eq!(c.step(0.0, 0.1), OK);
    // A host's accumulated rounding (well inside 1e-9 relative) is accepted.
    assert_eq!(c.step(0.1 + 1e-17, 0.1), OK);
}

#[test]
fn stop_time_limits_the_steps() {
    let _handles = shared();
    let u = Unpacked::new("stop");
    let c = u.instantiate();
    // SAFETY: a live instance.
    unsafe {
        assert_eq!(fmi2SetupExperiment(c.0, 0, 0.0, 0.0, 1, 0.01), OK);
        assert_eq!(fmi2EnterInitializationMode(c.0), OK);
        assert_eq!(fmi2ExitInitializationMode(c.0), OK);
    }
    assert_eq!(c.step(0.0, 0.01), OK);
    assert_eq!(c.step(0.01, 0.01), ERROR);
}

#[test]
fn saved_states_restore_values_and_lifecycle_and_serialize_plainly() {
    let _handles = shared();
    let u = Unpacked::new("states");
    let outs = real_outputs(&u.simulation());
    let a = u.instantiate();
    a.init();
    let h = 1e-3;
    for k in 0..120 {
        assert_eq!(a.step(k as f64 * h, h), OK);
    }
    let mut state: fmi2FMUstate = ptr::null_mut();
    // SAFETY: live instance, state slot, buffers of the sizes passed.
    unsafe {
        assert_eq!(fmi2GetFMUstate(a.0, &mut state), OK);
        assert!(!state.is_null());
        let mut size = 0usize;
        assert_eq!(fmi2SerializedFMUstateSize(a.0, state, &mut size), OK);
        let mut bytes = vec![0 as fmi2Byte; size];
        assert_eq!(fmi2SerializeFMUstate(a.0, state, bytes.as_mut_ptr(), size - 1), ERROR);
        assert_eq!(fmi2Reset(a.0), OK);
        a.init();
        for k in 0..120 {
            assert_eq!(a.step(k as f64 * h, h), OK);
        }
        assert_eq!(fmi2SerializeFMUstate(a.0, state, bytes.as_mut_ptr(), size), OK);

        let mut expected = Vec::new();
        for k in 120..180 {
            assert_eq!(a.step(k as f64 * h, h), OK);
            expected.push(a.reals(&outs));
        }
        // Back in time on the same instance, via the state object.
        assert_eq!(fmi2SetFMUstate(a.0, state), OK);
        assert_eq!(fmi2FreeFMUstate(a.0, &mut state), OK);
        assert!(state.is_null());
        for (i, k) in (120..180).enumerate() {
            assert_eq!(a.step(k as f64 * h, h), OK);
            assert_eq!(a.reals(&outs), expected[i]);
        }
        // Into a fresh instance of the same model, via the bytes.
        let b = u.instantiate();
        let mut restored: fmi2FMUstate = ptr::null_mut();
        assert_eq!(fmi2DeSerializeFMUstate(b.0, bytes.as_ptr(), size, &mut restored), OK);
        assert_eq!(fmi2SetFMUstate(b.0, restored), OK);
        assert_eq!(fmi2FreeFMUstate(b.0, &mut restored), OK);
        assert_eq!(b.state(), LifeState::StepComplete);
        let mut last = 0.0;
        assert_eq!(fmi2GetRealStatus(b.0, 2, &mut last), OK);
        assert_eq!(
            last,
            119.0 * h + h,
            "the end of the last step, computed as the host did"
        );
        for (i, k) in (120..180).enumerate() {
            assert_eq!(b.step(k as f64 * h, h), OK);
            assert_eq!(b.reals(&outs), expected[i]);
        }
        // Damaged bytes are refused.
        bytes[0] ^= 0x55;
        let mut bad: fmi2FMUstate = ptr::null_mut();
        assert_eq!(fmi2DeSerializeFMUstate(b.0, bytes.as_ptr(), size, &mut bad), ERROR);
        assert!(bad.is_null());
        // So is a negative size passed as size_t (it was read as that many bytes: a
        // segmentation fault).
        bytes[0] ^= 0x55;
        for size in [usize::MAX, usize::MAX - 7, isize::MAX as usize + 1] {
            let b2 = u.instantiate();
            let mut none: fmi2FMUstate = ptr::null_mut();
            assert_eq!(fmi2DeSerializeFMUstate(b2.0, bytes.as_ptr(), size, &mut none), ERROR);
            assert!(none.is_null());
        }
    }
}

#[test]
fn a_state_of_another_model_is_refused() {
    let _handles = shared();
    let u = Unpacked::new("other a");
    let mut v = Unpacked::new("other b");
    v.text.push_str("\n# a different scene text is a different model\n");
    std::fs::write(v.root.join("resources/scene.toml"), &v.text).unwrap();
    let a = u.instantiate();
    let b = v.instantiate();
    let mut state: fmi2FMUstate = ptr::null_mut();
    // SAFETY: live instances and a state slot.
    unsafe {
        assert_eq!(fmi2GetFMUstate(a.0, &mut state), OK);
        assert_eq!(fmi2SetFMUstate(b.0, state), ERROR);
        assert_eq!(fmi2FreeFMUstate(a.0, &mut state), OK);
    }
}

#[test]
fn types_platform_and_version() {
    // SAFETY: static NUL-terminated strings.
    unsafe {
        assert_eq!(std::ffi::CStr::from_ptr(fmi2GetTypesPlatform()).to_str(), Ok("default"));
        assert_eq!(std::ffi::CStr::from_ptr(fmi2GetVersion()).to_str(), Ok("2.0"));
    }
}

#[test]
fn enumerations_are_set_as_integers_and_checked_at_initialisation() {
    let _handles = shared();
    let u = Unpacked::new("enums");
    let sim = u.simulation();
    let method = sim.table().index_of("solver.method").unwrap() as u32;
    let c = u.instantiate();
    // SAFETY: one-element arrays on a live instance.
    unsafe {
        let mut x: fmi2Real = 0.0;
        assert_eq!(fmi2SetupExperiment(c.0, 0, 0.0, 0.0, 0, 0.0), OK);
        assert_eq!(fmi2EnterInitializationMode(c.0), OK);
        assert_eq!(
            fmi2GetReal(c.0, &method, 1, &mut x),
            ERROR,
            "an enumeration is not a Real"
        );
        assert_eq!(fmi2Reset(c.0), OK);
        assert_eq!(fmi2SetupExperiment(c.0, 0, 0.0, 0.0, 0, 0.0), OK);
        assert_eq!(fmi2EnterInitializationMode(c.0), OK);
        let mut m: fmi2Integer = 0;
        assert_eq!(fmi2GetInteger(c.0, &method, 1, &mut m), OK);
        assert_eq!(m, 5, "the default method, auto");
        assert_eq!(fmi2SetInteger(c.0, &method, 1, &7), OK);
        assert_eq!(fmi2ExitInitializationMode(c.0), ERROR, "method 7 does not exist");
    }
}

/// Handle values that are not live instances: never instantiated, misaligned, the top of the
/// address space, a pointer to memory of another kind.
fn garbage_handles(elsewhere: &mut f64) -> [*mut std::ffi::c_void; 4] {
    [
        0x10 as fmi2Component,
        0x1001 as fmi2Component,
        (usize::MAX & !0xf) as fmi2Component,
        (elsewhere as *mut f64).cast(),
    ]
}

/// Calls every function that takes a component with `c`, which is not a live instance, and
/// with arguments that would be valid for one: each must return `fmi2Error` without reading
/// `c` (a crash or a sanitizer report would be the failure).
///
/// # Safety
/// The arrays passed are valid, only `c` is not.
unsafe fn every_call_on_a_dead_handle_is_an_error(c: fmi2Component) {
    let vr: fmi2ValueReference = 0;
    let mut real: fmi2Real = 0.0;
    let mut int: fmi2Integer = 0;
    let mut boolean: fmi2Boolean = 0;
    let mut string: fmi2String = ptr::null();
    let mut state: fmi2FMUstate = ptr::null_mut();
    let mut size = 0usize;
    let mut bytes = [0 as fmi2Byte; 16];
    let order: fmi2Integer = 1;
    // SAFETY: every pointer but `c` is valid for the call; `c` must not be read.
    unsafe {
        assert_eq!(fmi2SetDebugLogging(c, FMI2_TRUE, 0, ptr::null()), ERROR);
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), ERROR);
        assert_eq!(fmi2EnterInitializationMode(c), ERROR);
        assert_eq!(fmi2ExitInitializationMode(c), ERROR);
        assert_eq!(fmi2Terminate(c), ERROR);
        assert_eq!(fmi2Reset(c), ERROR);
        assert_eq!(fmi2GetReal(c, &vr, 1, &mut real), ERROR);
        assert_eq!(fmi2GetInteger(c, &vr, 1, &mut int), ERROR);
        assert_eq!(fmi2GetBoolean(c, &vr, 1, &mut boolean), ERROR);
        assert_eq!(fmi2GetString(c, &vr, 1, &mut string), ERROR);
        assert_eq!(fmi2SetReal(c, &vr, 1, &1.0), ERROR);
        assert_eq!(fmi2SetInteger(c, &vr, 1, &1), ERROR);
        assert_eq!(fmi2SetBoolean(c, &vr, 1, &FMI2_TRUE), ERROR);
        assert_eq!(fmi2SetString(c, &vr, 1, &c"x".as_ptr()), ERROR);
        assert_eq!(fmi2GetFMUstate(c, &mut state), ERROR);
        assert!(state.is_null(), "no state is allocated for a dead instance");
        assert_eq!(fmi2SetFMUstate(c, state), ERROR);
        assert_eq!(fmi2FreeFMUstate(c, &mut state), ERROR);
        assert_eq!(fmi2SerializedFMUstateSize(c, state, &mut size), ERROR);
        assert_eq!(fmi2SerializeFMUstate(c, state, bytes.as_mut_ptr(), bytes.len()), ERROR);
        assert_eq!(
            fmi2DeSerializeFMUstate(c, bytes.as_ptr(), bytes.len(), &mut state),
            ERROR
        );
        assert!(state.is_null());
        assert_eq!(fmi2GetDirectionalDerivative(c, &vr, 1, &vr, 1, &1.0, &mut real), ERROR);
        assert_eq!(fmi2SetRealInputDerivatives(c, &vr, 1, &order, &1.0), ERROR);
        assert_eq!(fmi2GetRealOutputDerivatives(c, &vr, 1, &order, &mut real), ERROR);
        assert_eq!(fmi2DoStep(c, 0.0, 1e-3, FMI2_TRUE), ERROR);
        assert_eq!(fmi2CancelStep(c), ERROR);
        assert_eq!(fmi2GetStatus(c, 0, &mut int), ERROR);
        assert_eq!(fmi2GetRealStatus(c, 2, &mut real), ERROR);
        assert_eq!(fmi2GetIntegerStatus(c, 0, &mut int), ERROR);
        assert_eq!(fmi2GetBooleanStatus(c, 4, &mut boolean), ERROR);
        assert_eq!(fmi2GetStringStatus(c, 3, &mut string), ERROR);
        assert_eq!(instance_state(c), None);
        // Freeing it is ignored, also twice.
        fmi2FreeInstance(c);
        fmi2FreeInstance(c);
    }
    assert_eq!((real, int, boolean, size), (0.0, 0, 0, 0), "nothing was written");
    assert!(string.is_null());
}

/// With every handle test held off: the scene unpacked as `name`, and an instance of it
/// initialised and stepped once.
fn stepped_once(name: &str) -> (RwLockWriteGuard<'static, ()>, Unpacked, Component) {
    let alone = exclusive();
    let u = Unpacked::new(name);
    let c = u.instantiate();
    c.init();
    assert_eq!(c.step(0.0, 1e-3), OK);
    (alone, u, c)
}

#[test]
fn freed_and_garbage_component_handles_are_errors_not_crashes() {
    let (_alone, u, c) = stepped_once("stale component");
    // (a state of another instance: the states an instance made are freed with it)
    let other = u.instantiate();
    other.init();
    let mut state: fmi2FMUstate = ptr::null_mut();
    // SAFETY: a live instance and a state slot.
    unsafe { assert_eq!(fmi2GetFMUstate(other.0, &mut state), OK) };
    let freed = c.0;
    drop(c); // fmi2FreeInstance
    let mut elsewhere = 1.5;
    // SAFETY: only the component handles are invalid.
    unsafe {
        every_call_on_a_dead_handle_is_an_error(freed);
        for g in garbage_handles(&mut elsewhere) {
            every_call_on_a_dead_handle_is_an_error(g);
        }
        // A live FMU state is not a component either.
        every_call_on_a_dead_handle_is_an_error(state);
    }
    assert_eq!(elsewhere, 1.5);
    // The state is still live and is freed through its instance.
    // SAFETY: a live instance and a live state.
    unsafe {
        assert_eq!(fmi2FreeFMUstate(other.0, &mut state), OK);
    }
    assert!(state.is_null());
}

#[test]
fn freed_and_garbage_fmu_states_are_errors_not_crashes() {
    let (_alone, _u, c) = stepped_once("stale state");
    let mut state: fmi2FMUstate = ptr::null_mut();
    let mut size = 0usize;
    let mut elsewhere = 1.5;
    // SAFETY: a live instance; every pointer but the FMU state handles is valid.
    unsafe {
        assert_eq!(fmi2GetFMUstate(c.0, &mut state), OK);
        assert_eq!(fmi2SerializedFMUstateSize(c.0, state, &mut size), OK);
        let mut bytes = vec![0 as fmi2Byte; size];
        assert_eq!(fmi2SerializeFMUstate(c.0, state, bytes.as_mut_ptr(), size), OK);
        let freed = state;
        assert_eq!(fmi2FreeFMUstate(c.0, &mut state), OK);
        assert!(state.is_null());

        let mut dead = vec![freed, c.0];
        dead.extend(garbage_handles(&mut elsewhere));
        for s in dead {
            assert_eq!(fmi2SetFMUstate(c.0, s), ERROR);
            assert_eq!(c.state(), LifeState::Error);
            let mut n = 0usize;
            assert_eq!(fmi2SerializedFMUstateSize(c.0, s, &mut n), ERROR);
            assert_eq!(n, 0);
            assert_eq!(fmi2SerializeFMUstate(c.0, s, bytes.as_mut_ptr(), size), ERROR);
            // Neither freed again nor overwritten, and the slot keeps its value.
            let mut slot = s;
            assert_eq!(fmi2FreeFMUstate(c.0, &mut slot), ERROR);
            assert_eq!(slot, s);
            assert_eq!(fmi2GetFMUstate(c.0, &mut slot), ERROR);
            assert_eq!(fmi2DeSerializeFMUstate(c.0, bytes.as_ptr(), size, &mut slot), ERROR);
            assert_eq!(slot, s);
        }
        assert_eq!(elsewhere, 1.5);

        // The instance itself is unharmed: reset, and the bytes of the freed state restore.
        assert_eq!(fmi2Reset(c.0), OK);
        let mut restored: fmi2FMUstate = ptr::null_mut();
        assert_eq!(fmi2DeSerializeFMUstate(c.0, bytes.as_ptr(), size, &mut restored), OK);
        assert_eq!(fmi2SetFMUstate(c.0, restored), OK);
        assert_eq!(fmi2FreeFMUstate(c.0, &mut restored), OK);
    }
    assert_eq!(c.state(), LifeState::StepComplete);
    assert_eq!(c.step(1e-3, 1e-3), OK);
}

#[test]
fn eight_instances_step_in_parallel_on_eight_threads() {
    let _handles = shared();
    let u = Unpacked::new("threads");
    let (mut sim, outs) = u.simulation_and_outputs();
    let h = 1e-3;
    sim.initialize(0.0).unwrap();
    for k in 0..200 {
        sim.step_to(k as f64 * h + h).unwrap();
    }
    let expected: Vec<f64> = outs.iter().map(|&vr| sim.get(vr as usize).unwrap()).collect();
    let start = std::sync::Barrier::new(8);
    std::thread::scope(|s| {
        let threads: Vec<_> = (0..8)
            .map(|_| {
                s.spawn(|| {
                    let c = u.instantiate();
                    c.init();
                    start.wait();
                    for k in 0..200 {
                        assert_eq!(c.step(k as f64 * h, h), OK);
                    }
                    c.reals(&outs)
                })
            })
            .collect();
        for t in threads {
            assert_eq!(t.join().unwrap(), expected);
        }
    });
}

/// A communication step far too long for the integrator (the fuzzed hosts' `fmi2DoStep(0,
/// 1e300)`, `(0, 1e9)`, `(0, 1e3)` without a stop time) stops after `solver.max_steps`
/// integrator steps with `fmi2Discard` at a valid last successful time; the instance then
/// goes on from a saved state as before. A step of no finite length is an error.
#[test]
fn overlong_communication_steps_are_discarded_after_max_steps() {
    let _handles = shared();
    for (name, _) in common::bundled_scenes() {
        let u = Unpacked::of(&name, &format!("long {name}"));
        let sim = u.simulation();
        let vr = |n: &str| sim.table().index_of(n).unwrap() as u32;
        let max_steps = sim.scene().solver.max_steps as f64;
        let a = u.instantiate();
        a.init();
        let mut saved: fmi2FMUstate = ptr::null_mut();
        // SAFETY: a live instance and a state slot.
        unsafe { assert_eq!(fmi2GetFMUstate(a.0, &mut saved), OK) };
        for h in [f64::MAX, 1e300, 1e9, 1e3] {
            let started = std::time::Instant::now();
            let status = a.step(0.0, h);
            let seconds = started.elapsed().as_secs_f64();
            let mut last = f64::NAN;
            // SAFETY: a live instance and an out value.
            unsafe { assert_eq!(fmi2GetRealStatus(a.0, 2, &mut last), OK) };
            let mut steps: fmi2Integer = -1;
            // SAFETY: one value reference, one out value.
            unsafe { assert_eq!(fmi2GetInteger(a.0, &vr("solver.steps"), 1, &mut steps), OK) };
            let steps = f64::from(steps);
            println!(
                "{name}: fmi2DoStep(0, {h:e}) -> {status:?} after {steps} steps at t = {last:e} in {seconds:.3} s"
            );
            // Discard after max_steps steps, or OK with the time reached within them (the
            // budget is asserted below): the weightless two spheres fly apart with no largest
            // step, so any finite time is reached in a few hundred steps (1e300 s in 384), and
            // the step toward f64::MAX fails once a step would end beyond the largest number;
            // the bouncing ball, once at rest, is integrated by the implicit method of `auto`
            // with steps that grow geometrically (1e9 s in about 3,200 steps); the rail vehicle,
            // cruising on its own, reaches 1e3 s in 4,721 of its 5,000 steps.
            match status {
                fmi2Status::fmi2Discard => assert_eq!(a.state(), LifeState::StepFailed),
                fmi2Status::fmi2Error if name == "two_spheres" && h == f64::MAX => {
                    assert_eq!(a.state(), LifeState::Error)
                }
                fmi2Status::fmi2OK if h < f64::MAX => {
                    assert_eq!(a.state(), LifeState::StepComplete);
                    assert_eq!(last, h, "{name}: reached");
                }
                other => panic!("{name}, h = {h:e}: {other:?}"),
            }
            assert!(
                last.is_finite() && (0.0..=h).contains(&last),
                "{name}: last successful time {last}"
            );
            // solver.max_steps bounds the steps of each island (a scene of one piece: all its
            // steps); there are at most as many islands as bodies
            let islands = if sim.scene().shape.is_empty() {
                1.0
            } else {
                sim.scene().body.len() as f64
            };
            assert!(
                steps <= max_steps * islands,
                "{name}: {steps} steps, solver.max_steps = {max_steps} for at most {islands} islands"
            );
            assert!(
                a.reals(&real_outputs(&sim)).iter().all(|x| x.is_finite()),
                "{name}: NaN output"
            );
            // SAFETY: the state saved above, on its own instance.
            unsafe { assert_eq!(fmi2SetFMUstate(a.0, saved), OK) };
            assert_eq!(a.state(), LifeState::StepComplete);
            assert_eq!(a.step(0.0, 1e-3), OK, "{name}: steps normally after the restore");
            // SAFETY: as above.
            unsafe { assert_eq!(fmi2SetFMUstate(a.0, saved), OK) };
        }
        assert_eq!(a.step(0.0, f64::INFINITY), ERROR, "{name}: a step to no finite time");
        assert_eq!(a.state(), LifeState::Error);
        // SAFETY: the state saved above, freed once.
        unsafe { assert_eq!(fmi2FreeFMUstate(a.0, &mut saved), OK) };
    }
}

#[test]
fn a_status_no_query_can_answer_is_discarded_and_the_instance_goes_on() {
    // FMI 2.0 (co-simulation): "If a status is required which cannot be retrieved by the
    // slave it returns fmi2Discard" — they returned fmi2Error and ended the run
    let _handles = shared();
    let u = Unpacked::new("status kinds");
    let c = u.instantiate();
    c.init();
    assert_eq!(c.step(0.0, 1e-3), OK);
    let discard = fmi2Status::fmi2Discard;
    let (mut int, mut real, mut boolean) = (7, 7.0, 7);
    let mut string: fmi2String = ptr::null();
    // SAFETY: `c` is live and every output pointer is valid.
    unsafe {
        for kind in [0, 1, 2, 3, -1, 99, i32::MAX] {
            assert_eq!(fmi2GetStatus(c.0, kind, &mut int), discard, "kind {kind}");
            assert_eq!(fmi2GetIntegerStatus(c.0, kind, &mut int), discard, "kind {kind}");
            assert_eq!(fmi2GetStringStatus(c.0, kind, &mut string), discard, "kind {kind}");
            if kind != 2 {
                assert_eq!(fmi2GetRealStatus(c.0, kind, &mut real), discard, "kind {kind}");
            }
            if kind != 3 {
                assert_eq!(fmi2GetBooleanStatus(c.0, kind, &mut boolean), discard, "kind {kind}");
            }
            assert_eq!(c.state(), LifeState::StepComplete, "kind {kind}");
        }
        assert_eq!((int, real, boolean), (7, 7.0, 7), "nothing was written");
        assert!(string.is_null());
        // the answerable ones answer, and the run goes on
        assert_eq!(fmi2GetRealStatus(c.0, 2, &mut real), OK);
        assert_eq!(real, 1e-3);
        assert_eq!(fmi2GetBooleanStatus(c.0, 3, &mut boolean), OK);
        assert_eq!(boolean, FMI2_FALSE);
    }
    assert_eq!(c.step(1e-3, 1e-3), OK);
}

#[test]
fn the_states_an_instance_made_are_freed_with_it() {
    // FreeInstance "frees all the allocated memory and other resources that have been
    // allocated by the functions of the FMU interface": states the host had not freed leaked
    // (and could be freed only through another live instance)
    let _handles = shared();
    let u = Unpacked::new("states freed with it");
    let (a, b) = (u.instantiate(), u.instantiate());
    a.init();
    b.init();
    assert_eq!(a.step(0.0, 1e-3), OK);
    let mut states: Vec<fmi2FMUstate> = vec![ptr::null_mut(); 3];
    let mut of_b: fmi2FMUstate = ptr::null_mut();
    let mut kept_by_b: fmi2FMUstate = ptr::null_mut();
    // SAFETY: the instances are live and every slot is valid.
    unsafe {
        for s in &mut states {
            assert_eq!(fmi2GetFMUstate(a.0, s), OK);
        }
        assert_eq!(fmi2GetFMUstate(b.0, &mut of_b), OK);
        assert_eq!(fmi2GetFMUstate(b.0, &mut kept_by_b), OK);
        // while `a` lives, its states restore into `b` too
        assert_eq!(fmi2SetFMUstate(b.0, states[0]), OK);
        // a state of `b` written over by `a` is `a`'s from then on
        assert_eq!(fmi2GetFMUstate(a.0, &mut of_b), OK);
        // a live state is freed through another instance, and its maker goes on
        let mut freed_by_b: fmi2FMUstate = ptr::null_mut();
        assert_eq!(fmi2GetFMUstate(a.0, &mut freed_by_b), OK);
        assert_eq!(fmi2FreeFMUstate(b.0, &mut freed_by_b), OK);
        assert!(freed_by_b.is_null());
        assert_eq!(a.step(1e-3, 1e-3), OK);
        drop(a);
        // `b`'s own state lives on, and restores (before any stale handle puts `b` in the
        // error state)
        assert_eq!(fmi2SetFMUstate(b.0, kept_by_b), OK);
        assert_eq!(fmi2FreeFMUstate(b.0, &mut kept_by_b), OK);
        assert!(kept_by_b.is_null());
        for s in states.iter_mut().chain([&mut of_b]) {
            let stale = *s;
            assert_eq!(
                fmi2FreeFMUstate(b.0, s),
                ERROR,
                "a state of the freed instance is stale"
            );
            assert_eq!(*s, stale, "the host's handle is left as it was");
        }
    }
}
