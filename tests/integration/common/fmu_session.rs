//! A bundled scene laid out as an unzipped FMU's `resources` folder, and one FMI session on
//! it through the C functions: instantiate, initialise with some Real parameters set, step,
//! read every Real output. The test binary's root includes it once (`crate::fmu_session`).
//! (the thread and valgrind tests share it; the functions are passed in, so that the same
//! session runs on the linked library or on the shared library loaded at run time).

// Each test binary uses a part of these.
#![allow(dead_code)]

use contact_fmu::fmi::types::*;
use contact_fmu::simulation::Simulation;
use contact_fmu::variables::{Causality, VarType};
use std::ffi::CString;
use std::path::PathBuf;

/// A scene copied into `<tmp>/<tag>/resources/scene.toml`; removed on drop.
pub struct SceneDir {
    /// The folder that plays the unzipped FMU.
    pub root: PathBuf,
    /// The scene text.
    pub text: String,
}

impl SceneDir {
    /// The bundled scene `fmu/<name>/scene.toml`, under a folder named after `tag`.
    pub fn bundled(name: &str, tag: &str) -> SceneDir {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("fmu")
            .join(name)
            .join("scene.toml");
        let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let root = std::env::temp_dir().join(format!("contact-fmu session {} {tag}", std::process::id()));
        std::fs::create_dir_all(root.join("resources")).unwrap();
        std::fs::write(root.join("resources").join("scene.toml"), &text).unwrap();
        SceneDir { root, text }
    }

    /// `fmuResourceLocation` as fmpy passes it (percent-encoded `file:///` URI).
    pub fn resource_uri(&self) -> CString {
        let dir = self.root.join("resources").display().to_string();
        CString::new(format!("file://{}", dir.replace('%', "%25").replace(' ', "%20"))).unwrap()
    }

    /// The GUID of the scene's model description.
    pub fn guid(&self) -> CString {
        CString::new(contact_fmu::guid::guid(&self.text)).unwrap()
    }

    /// A simulation of the scene (for its variable table and default experiment).
    pub fn simulation(&self) -> Simulation {
        Simulation::from_scene_str(&self.text, "scene.toml").unwrap()
    }

    /// The value references of every Real output.
    pub fn real_outputs(&self) -> Vec<fmi2ValueReference> {
        self.simulation()
            .variables()
            .iter()
            .enumerate()
            .filter(|(_, v)| v.causality == Causality::Output && v.vtype == VarType::Real)
            .map(|(vr, _)| vr as fmi2ValueReference)
            .collect()
    }

    /// The value reference of variable `name`.
    pub fn vr(&self, name: &str) -> fmi2ValueReference {
        self.simulation()
            .table()
            .index_of(name)
            .unwrap_or_else(|| panic!("no variable {name}")) as fmi2ValueReference
    }
}

impl Drop for SceneDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.root);
    }
}

/// The FMI functions a session calls, as C function pointers.
#[derive(Clone, Copy)]
pub struct Api {
    pub instantiate: unsafe extern "C" fn(
        fmi2String,
        std::os::raw::c_int,
        fmi2String,
        fmi2String,
        *const fmi2CallbackFunctions,
        fmi2Boolean,
        fmi2Boolean,
    ) -> fmi2Component,
    pub free_instance: unsafe extern "C" fn(fmi2Component),
    pub setup_experiment:
        unsafe extern "C" fn(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean, fmi2Real) -> fmi2Status,
    pub enter_initialization_mode: unsafe extern "C" fn(fmi2Component) -> fmi2Status,
    pub exit_initialization_mode: unsafe extern "C" fn(fmi2Component) -> fmi2Status,
    pub set_real: unsafe extern "C" fn(fmi2Component, *const fmi2ValueReference, usize, *const fmi2Real) -> fmi2Status,
    pub get_real: unsafe extern "C" fn(fmi2Component, *const fmi2ValueReference, usize, *mut fmi2Real) -> fmi2Status,
    pub do_step: unsafe extern "C" fn(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean) -> fmi2Status,
    pub terminate: unsafe extern "C" fn(fmi2Component) -> fmi2Status,
    pub get_fmu_state: unsafe extern "C" fn(fmi2Component, *mut fmi2FMUstate) -> fmi2Status,
    pub set_fmu_state: unsafe extern "C" fn(fmi2Component, fmi2FMUstate) -> fmi2Status,
    pub free_fmu_state: unsafe extern "C" fn(fmi2Component, *mut fmi2FMUstate) -> fmi2Status,
    pub serialized_size: unsafe extern "C" fn(fmi2Component, fmi2FMUstate, *mut usize) -> fmi2Status,
    pub serialize: unsafe extern "C" fn(fmi2Component, fmi2FMUstate, *mut fmi2Byte, usize) -> fmi2Status,
    pub deserialize: unsafe extern "C" fn(fmi2Component, *const fmi2Byte, usize, *mut fmi2FMUstate) -> fmi2Status,
}

/// The functions of the linked library.
pub fn linked_api() -> Api {
    use contact_fmu::fmi::exports::*;
    Api {
        instantiate: fmi2Instantiate,
        free_instance: fmi2FreeInstance,
        setup_experiment: fmi2SetupExperiment,
        enter_initialization_mode: fmi2EnterInitializationMode,
        exit_initialization_mode: fmi2ExitInitializationMode,
        set_real: fmi2SetReal,
        get_real: fmi2GetReal,
        do_step: fmi2DoStep,
        terminate: fmi2Terminate,
        get_fmu_state: fmi2GetFMUstate,
        set_fmu_state: fmi2SetFMUstate,
        free_fmu_state: fmi2FreeFMUstate,
        serialized_size: fmi2SerializedFMUstateSize,
        serialize: fmi2SerializeFMUstate,
        deserialize: fmi2DeSerializeFMUstate,
    }
}

/// Instantiates `dir`'s scene, sets `parameters` in initialization mode, steps `steps` times
/// by `h` and returns the bits of every Real output after every step. Every call must return
/// `fmi2OK`.
pub fn run_session(
    api: &Api,
    dir: &SceneDir,
    name: &str,
    parameters: &[(fmi2ValueReference, f64)],
    h: f64,
    steps: usize,
) -> Vec<Vec<u64>> {
    let outputs = dir.real_outputs();
    let (uri, guid) = (dir.resource_uri(), dir.guid());
    let name = CString::new(name).unwrap();
    let callbacks = fmi2CallbackFunctions::default();
    let ok = fmi2Status::fmi2OK;
    let mut trace = Vec::with_capacity(steps);
    // SAFETY: valid strings, callbacks and arrays that live for each call; the instance is
    // used on this thread only and freed once.
    unsafe {
        let c = (api.instantiate)(
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            uri.as_ptr(),
            &callbacks,
            0,
            0,
        );
        assert!(!c.is_null(), "fmi2Instantiate failed");
        assert_eq!((api.setup_experiment)(c, 0, 0.0, 0.0, 0, 0.0), ok);
        assert_eq!((api.enter_initialization_mode)(c), ok);
        for (vr, x) in parameters {
            assert_eq!((api.set_real)(c, vr, 1, x), ok);
        }
        assert_eq!((api.exit_initialization_mode)(c), ok);
        let mut values = vec![0.0; outputs.len()];
        for k in 0..steps {
            assert_eq!((api.do_step)(c, k as f64 * h, h, FMI2_TRUE), ok, "step {k}");
            assert_eq!(
                (api.get_real)(c, outputs.as_ptr(), outputs.len(), values.as_mut_ptr()),
                ok
            );
            trace.push(values.iter().map(|x| x.to_bits()).collect());
        }
        (api.free_instance)(c);
    }
    trace
}
