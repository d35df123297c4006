//! One small FMI session on the shared library itself (`libcontact_fmu.so`, the file an FMU
//! ships), loaded at run time with `dlopen` as a host loads it: instantiate, initialise, step,
//! save, serialize and restore states, terminate, free, unload. `scripts/valgrind_fmi.sh`
//! runs this test under `valgrind --leak-check=full --error-exitcode=1`; without valgrind it
//! checks that the session's results are those of the linked library.
//!
//! The library is `CONTACT_FMU_LIBRARY` when set, otherwise the one cargo built beside this
//! test (`target/<profile>/libcontact_fmu.so`, which `cargo build` makes and `cargo test`
//! alone does not update: `./run_tests.sh` and `scripts/valgrind_fmi.sh` build it first).

#![cfg(target_os = "linux")]

use crate::fmu_session;

use contact_fmu::fmi::types::*;
use fmu_session::{linked_api, run_session, Api, SceneDir};
use std::ffi::{c_void, CStr, CString};
use std::path::PathBuf;
use std::ptr;

fn library_path() -> PathBuf {
    if let Some(p) = std::env::var_os("CONTACT_FMU_LIBRARY") {
        return PathBuf::from(p);
    }
    // this test is target/<profile>/deps/<name>-<hash>
    let exe = std::env::current_exe().unwrap();
    exe.parent().and_then(|d| d.parent()).unwrap().join("libcontact_fmu.so")
}

/// The shared library, loaded with `dlopen` and closed on drop.
struct Loaded(*mut c_void);

impl Loaded {
    fn open() -> Loaded {
        let path = library_path();
        let c = CString::new(path.display().to_string()).unwrap();
        // SAFETY: a NUL-terminated path; RTLD_NOW resolves every symbol at once.
        let h = unsafe { libc::dlopen(c.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL) };
        if h.is_null() {
            // SAFETY: dlerror returns NULL or a NUL-terminated message.
            let e = unsafe { libc::dlerror() };
            let why = if e.is_null() {
                String::new()
            } else {
                // SAFETY: not NULL, NUL-terminated (see above).
                unsafe { CStr::from_ptr(e) }.to_string_lossy().into_owned()
            };
            panic!("dlopen {}: {why} (build it: cargo build --release)", path.display());
        }
        Loaded(h)
    }

    fn symbol(&self, name: &CStr) -> *mut c_void {
        // SAFETY: a live handle and a NUL-terminated name.
        let p = unsafe { libc::dlsym(self.0, name.as_ptr()) };
        assert!(!p.is_null(), "{name:?} is not exported");
        p
    }

    fn api(&self) -> Api {
        macro_rules! load {
            ($name:literal) => {
                // SAFETY: the symbol is the library's `extern "C"` function of this name, whose
                // signature is the field's (both follow fmi2FunctionTypes.h).
                unsafe { function(self.symbol($name)) }
            };
        }
        Api {
            instantiate: load!(c"fmi2Instantiate"),
            free_instance: load!(c"fmi2FreeInstance"),
            setup_experiment: load!(c"fmi2SetupExperiment"),
            enter_initialization_mode: load!(c"fmi2EnterInitializationMode"),
            exit_initialization_mode: load!(c"fmi2ExitInitializationMode"),
            set_real: load!(c"fmi2SetReal"),
            get_real: load!(c"fmi2GetReal"),
            do_step: load!(c"fmi2DoStep"),
            terminate: load!(c"fmi2Terminate"),
            get_fmu_state: load!(c"fmi2GetFMUstate"),
            set_fmu_state: load!(c"fmi2SetFMUstate"),
            free_fmu_state: load!(c"fmi2FreeFMUstate"),
            serialized_size: load!(c"fmi2SerializedFMUstateSize"),
            serialize: load!(c"fmi2SerializeFMUstate"),
            deserialize: load!(c"fmi2DeSerializeFMUstate"),
        }
    }
}

/// A function pointer of type `F` from a symbol's address.
///
/// # Safety
/// `F` is the `extern "C" fn` type of the function at `p`.
unsafe fn function<F: Copy>(p: *mut c_void) -> F {
    assert_eq!(std::mem::size_of::<F>(), std::mem::size_of::<*mut c_void>());
    // SAFETY: a function pointer has the size of an address (checked) and `p` is the address
    // of a function of type `F` (this function's contract).
    unsafe { std::mem::transmute_copy::<*mut c_void, F>(&p) }
}

impl Drop for Loaded {
    fn drop(&mut self) {
        // SAFETY: the handle from dlopen, closed once; no function of it is used afterwards.
        unsafe { libc::dlclose(self.0) };
    }
}

const STEPS: usize = 60;

/// Steps, saves a state, steps on, restores it (directly and through its serialized bytes)
/// and checks that the run after each restore repeats the first bit for bit.
fn states_session(api: &Api, dir: &SceneDir) {
    let ok = fmi2Status::fmi2OK;
    let outputs = dir.real_outputs();
    let h = dir.simulation().scene().model.interval;
    let (uri, guid) = (dir.resource_uri(), dir.guid());
    let callbacks = fmi2CallbackFunctions::default();
    // SAFETY: valid strings, callbacks, arrays and state slots for each call; one thread.
    unsafe {
        let c = (api.instantiate)(
            c"states".as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            uri.as_ptr(),
            &callbacks,
            0,
            0,
        );
        assert!(!c.is_null());
        assert_eq!((api.setup_experiment)(c, 1, 1e-6, 0.0, 0, 0.0), ok);
        assert_eq!((api.enter_initialization_mode)(c), ok);
        assert_eq!((api.exit_initialization_mode)(c), ok);
        let t0 = 10.0 * h;
        for k in 0..10 {
            assert_eq!((api.do_step)(c, k as f64 * h, h, FMI2_TRUE), ok);
        }
        let mut saved: fmi2FMUstate = ptr::null_mut();
        assert_eq!((api.get_fmu_state)(c, &mut saved), ok);
        let run = || {
            let mut v = vec![0.0; outputs.len()];
            for k in 0..10 {
                assert_eq!((api.do_step)(c, t0 + k as f64 * h, h, FMI2_TRUE), ok);
            }
            assert_eq!((api.get_real)(c, outputs.as_ptr(), outputs.len(), v.as_mut_ptr()), ok);
            v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>()
        };
        let first = run();
        assert_eq!((api.set_fmu_state)(c, saved), ok);
        assert_eq!(run(), first, "after fmi2SetFMUstate");
        let mut size = 0usize;
        assert_eq!((api.serialized_size)(c, saved, &mut size), ok);
        let mut bytes = vec![0 as fmi2Byte; size];
        assert_eq!((api.serialize)(c, saved, bytes.as_mut_ptr(), size), ok);
        let mut back: fmi2FMUstate = ptr::null_mut();
        assert_eq!((api.deserialize)(c, bytes.as_ptr(), size, &mut back), ok);
        // overwrite the first state with the present one, then restore the deserialized copy
        assert_eq!((api.get_fmu_state)(c, &mut saved), ok);
        assert_eq!((api.set_fmu_state)(c, back), ok);
        assert_eq!(run(), first, "after fmi2DeSerializeFMUstate");
        // a damaged copy is refused and allocates nothing
        bytes[size / 2] ^= 1;
        let mut refused: fmi2FMUstate = ptr::null_mut();
        assert_eq!(
            (api.deserialize)(c, bytes.as_ptr(), size, &mut refused),
            fmi2Status::fmi2Error
        );
        assert!(refused.is_null());
        assert_eq!((api.free_fmu_state)(c, &mut saved), ok);
        assert_eq!((api.free_fmu_state)(c, &mut back), ok);
        (api.free_instance)(c);
    }
}

#[test]
fn a_session_on_the_shared_library_equals_the_linked_one_and_frees_everything() {
    let dir = SceneDir::bundled("bouncing_ball", "shared library");
    let rtol = dir.vr("solver.rtol");
    let h = dir.simulation().scene().model.interval;
    let loaded = Loaded::open();
    let api = loaded.api();
    let from_so = run_session(&api, &dir, "so", &[(rtol, 1e-7)], h, STEPS);
    states_session(&api, &dir);
    drop(loaded);
    let linked = run_session(&linked_api(), &dir, "linked", &[(rtol, 1e-7)], h, STEPS);
    assert_eq!(from_so, linked);
    states_session(&linked_api(), &dir);
    if std::env::var_os("CONTACT_FMU_LEAK_SELFTEST").is_some() {
        // scripts/valgrind_fmi.sh --selftest: a block nobody frees, which valgrind must report
        std::hint::black_box(Box::into_raw(Box::new([7u8; 1000])));
    }
}
