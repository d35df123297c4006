//! What the `extern "C"` functions of both FMI versions share: looking up handles, checking
//! the calling state, catching panics, turning C arrays into slices, and the bodies of the
//! functions whose work does not depend on the version (values, FMU states, debug logging).
//!
//! Safety, for every function here: `c` and FMU-state values may be anything (they are looked
//! up in the registries before use), but one instance, and one state, is not used or freed on
//! two threads at once (FMI 2.0 and 3.0 alike); a state is freed with the instance that made
//! it (that last wrote it), so another instance uses it only while its maker lives and is not
//! being freed. Each function's `# Safety` names its other pointers.

use super::instance::{Access, Instance, InstantiateArgs};
use super::lifecycle::Version;
use super::log::{Failure, FmiResult};
use super::registry::{INSTANCES, STATES};
use super::saved::SavedState;
use super::types::fmi2Status;
use std::ffi::CStr;
use std::os::raw::{c_char, c_void};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::ptr;

/// The text of a panic payload.
pub(crate) fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".to_string()
    }
}

/// Borrows the instance behind a handle if the handle is a live instance of this library made
/// by a function of `version` (see `registry`). NULL, a freed handle, an instance of the other
/// FMI version or any other value gives `None`; only a live instance is read.
///
/// # Safety
/// While the borrow lasts, no other thread uses or frees `c`.
pub(crate) unsafe fn instance<'a>(c: *mut c_void, version: Version) -> Option<&'a mut Instance> {
    let p = c as *mut Instance;
    if !INSTANCES.contains(p) {
        return None;
    }
    // SAFETY: a live handle is a `Box<Instance>` leaked by an instantiation function and not
    // yet released; nothing else uses it meanwhile (this function's contract).
    let inst = unsafe { &mut *p };
    (inst.version == version).then_some(inst)
}

/// Leaks a new instance into the registry of live handles; the handle the host receives.
pub(crate) fn register(inst: Instance) -> *mut c_void {
    INSTANCES.register(Box::new(inst)) as *mut c_void
}

/// Creates the instance `args` describe and registers it: its handle, or NULL once `report`
/// has been given the reason (the instance's refusal, or a panic while creating it).
pub(crate) fn instantiate(args: InstantiateArgs, report: impl Fn(&str)) -> *mut c_void {
    let function = args.function;
    let message = match catch_unwind(AssertUnwindSafe(|| Instance::new(args))) {
        Ok(Ok(inst)) => return register(inst),
        Ok(Err(message)) => message,
        Err(payload) => format!("{function}: internal error (panic): {}", panic_text(payload.as_ref())),
    };
    report(&message);
    ptr::null_mut()
}

/// Frees the instance behind `c` when it is a live instance of `version`; anything else is
/// ignored.
///
/// # Safety
/// No other thread uses `c` during or after the call.
pub(crate) unsafe fn free_instance(c: *mut c_void, version: Version) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: nothing else uses `c` (this function's contract).
        if unsafe { instance(c, version) }.is_some() {
            // The states it made go with it (FreeInstance "frees all the allocated memory
            // and other resources that have been allocated by the functions of the FMU
            // interface"): the host's handles to them are stale from now on, and refused.
            // (first, while the instance still holds its address: an instance made at the
            // same address once this one is freed owns its own states)
            // SAFETY: no instance uses a state of this one while it is freed (the module's
            // contract).
            drop(unsafe { STATES.release_owned_by(c as usize) });
            // SAFETY: as above; the borrow has ended.
            drop(unsafe { INSTANCES.release(c as *mut Instance) });
        }
    }));
}

/// Runs one FMI call on `found`, the instance [`instance`] looked up: checks the calling
/// state, catches panics and turns failures into a logged status (`fmi2Status`, or FMI 3.0's
/// of the same value). Without an instance the call returns an error and logs nothing (there
/// is no logger to log to).
pub(crate) fn call<S: From<fmi2Status>>(
    found: Option<&mut Instance>,
    func: &'static str,
    mask: u32,
    body: impl FnOnce(&mut Instance) -> FmiResult,
) -> S {
    let outer = catch_unwind(AssertUnwindSafe(|| {
        let Some(inst) = found else {
            return fmi2Status::fmi2Error;
        };
        if inst.state.bit() & mask == 0 {
            let message = format!(
                "illegal call sequence: {func} is not allowed in the {} state",
                inst.state_name()
            );
            return inst.fail(func, Failure::error(message));
        }
        match catch_unwind(AssertUnwindSafe(|| body(&mut *inst))) {
            Ok(Ok(())) => fmi2Status::fmi2OK,
            Ok(Err(failure)) => inst.fail(func, failure),
            Err(payload) => {
                inst.poisoned = true;
                let message = format!("internal error (panic): {}", panic_text(payload.as_ref()));
                inst.fail(func, Failure::error(message))
            }
        }
    }));
    S::from(outer.unwrap_or(fmi2Status::fmi2Fatal))
}

/// Whether a C array of `n` elements of `T` at a pointer that `is_null` is one to read
/// (false: no elements), or the failure: NULL with a length that is not 0, or a count beyond
/// what memory holds (its bytes above `isize::MAX`: a host's mistake, such as a negative size
/// passed as `size_t`), refused before a slice is made of it.
fn array_to_read<T>(is_null: bool, n: usize, what: &str) -> FmiResult<bool> {
    if n == 0 {
        Ok(false)
    } else if is_null {
        Err(Failure::error(format!("{what} is NULL but {n} values were requested")))
    } else if n > isize::MAX as usize / std::mem::size_of::<T>().max(1) {
        Err(Failure::error(format!(
            "{what}: {n} values are more than memory can hold (a negative size passed as size_t?)"
        )))
    } else {
        Ok(true)
    }
}

/// A slice from a C array, or a failure ([`array_to_read`]).
///
/// # Safety
/// When not NULL, `p` points to `n` valid elements that nothing writes during `'a`.
pub(crate) unsafe fn slice<'a, T>(p: *const T, n: usize, what: &str) -> FmiResult<&'a [T]> {
    if !array_to_read::<T>(p.is_null(), n, what)? {
        return Ok(&[]);
    }
    // SAFETY: `p` is not NULL and points to `n` valid elements (this function's contract).
    Ok(unsafe { std::slice::from_raw_parts(p, n) })
}

/// A mutable slice from a C array (see [`fn@slice`]).
///
/// # Safety
/// When not NULL, `p` points to `n` valid, writable elements that nothing else accesses
/// during `'a`.
pub(crate) unsafe fn slice_mut<'a, T>(p: *mut T, n: usize, what: &str) -> FmiResult<&'a mut [T]> {
    if !array_to_read::<T>(p.is_null(), n, what)? {
        return Ok(&mut []);
    }
    // SAFETY: `p` is not NULL and points to `n` writable elements (this function's contract).
    Ok(unsafe { std::slice::from_raw_parts_mut(p, n) })
}

/// A string argument, or `None` for NULL.
///
/// # Safety
/// When not NULL, `s` is a NUL-terminated string.
pub(crate) unsafe fn string_arg(s: *const c_char) -> Option<String> {
    if s.is_null() {
        None
    } else {
        // SAFETY: `s` is not NULL and NUL-terminated (this function's contract).
        Some(unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned())
    }
}

/// Borrows a saved state if the handle is a live state of this library (see `registry`);
/// anything else is refused without being read.
///
/// # Safety
/// While the borrow lasts, no other thread frees or overwrites `s`.
pub(crate) unsafe fn saved_state<'a>(s: *mut c_void) -> FmiResult<&'a SavedState> {
    let p = s as *const SavedState;
    if p.is_null() {
        return Err(Failure::error("the FMU state is NULL"));
    }
    if !STATES.contains(p) {
        return Err(Failure::error(
            "the FMU state was not made by this FMU or has been freed",
        ));
    }
    // SAFETY: a live handle is a `Box<SavedState>` leaked by `store_state` and not yet
    // released by a free; nothing writes it meanwhile (this function's contract).
    Ok(unsafe { &*p })
}

/// Stores a state into `*slot`: allocates when `*slot` is NULL, otherwise overwrites it if it
/// is a live state (anything else is refused without being read).
///
/// # Safety
/// `slot` is NULL or valid for reading and writing; no other thread uses `*slot` meanwhile.
pub(crate) unsafe fn store_state(slot: *mut *mut c_void, state: SavedState, owner: &Instance) -> FmiResult {
    // (the instance's address is its handle: its states are freed with it)
    let owner = owner as *const Instance as usize;
    if slot.is_null() {
        return Err(Failure::error("the FMUstate pointer is NULL"));
    }
    // SAFETY: `slot` is not NULL and readable (this function's contract).
    let existing = unsafe { *slot } as *mut SavedState;
    if existing.is_null() {
        let p = STATES.register_owned(Box::new(state), owner) as *mut c_void;
        // SAFETY: `slot` is not NULL and writable (this function's contract).
        unsafe { *slot = p };
    } else if STATES.contains(existing) {
        // SAFETY: a live `Box<SavedState>` (see `saved_state`) that nothing else uses.
        unsafe { *existing = state };
        STATES.set_owner(existing, owner);
    } else {
        return Err(Failure::error(
            "*FMUstate is neither NULL nor a live FMU state of this FMU",
        ));
    }
    Ok(())
}

/// The number of values a typed get or set transfers: `n_values` must equal the number of
/// value references (this model has scalar variables only).
fn scalars(nvr: usize, n_values: usize) -> FmiResult<usize> {
    if n_values != nvr {
        return Err(Failure::error(format!(
            "nValues = {n_values} differs from nValueReferences = {nvr} (every variable of this model is a scalar)"
        )));
    }
    Ok(nvr)
}

/// Reads `nvr` variables of one type into `value` (`n_values` elements), converting each.
///
/// # Safety
/// `vr` holds `nvr` elements and `value` `n_values` writable ones (each may be NULL only when
/// its length is 0).
pub(crate) unsafe fn get_values<T>(
    inst: &mut Instance,
    access: Access,
    vr: *const u32,
    nvr: usize,
    value: *mut T,
    n_values: usize,
    convert: impl Fn(f64) -> T,
) -> FmiResult {
    let n = scalars(nvr, n_values)?;
    // SAFETY: `vr` and `value` hold `n` elements (this function's contract).
    let (vrs, out) = unsafe { (slice(vr, n, "vr")?, slice_mut(value, n, "value")?) };
    inst.get_values(access, vrs, |k, x| out[k] = convert(x))
}

/// Sets `nvr` variables of one type from `value` (`n_values` elements), converting each.
///
/// # Safety
/// `vr` holds `nvr` elements and `value` `n_values` (each may be NULL only when its length is
/// 0).
pub(crate) unsafe fn set_values<T: Copy>(
    inst: &mut Instance,
    access: Access,
    vr: *const u32,
    nvr: usize,
    value: *const T,
    n_values: usize,
    convert: impl Fn(T) -> f64,
) -> FmiResult {
    let n = scalars(nvr, n_values)?;
    // SAFETY: `vr` and `value` hold `n` elements (this function's contract).
    let (vrs, vals) = unsafe { (slice(vr, n, "vr")?, slice(value, n, "value")?) };
    inst.set_values(access, vrs, |k| convert(vals[k]))
}

/// A get or set of `type_name` variables, of which this model has none (String; in FMI 3.0
/// also the integer and binary types it does not use): an empty list succeeds, any value
/// reference is refused.
///
/// # Safety
/// `vr` holds `nvr` elements.
pub(crate) unsafe fn none_of(type_name: &str, vr: *const u32, nvr: usize) -> FmiResult {
    // SAFETY: `vr` holds `nvr` elements (this function's contract).
    let vrs = unsafe { slice(vr, nvr, "vr") }?;
    match vrs.first() {
        Some(v) => Err(Failure::error(format!(
            "value reference {v} is not a {type_name} variable: this model has none"
        ))),
        None => Ok(()),
    }
}

/// `SetDebugLogging`: the categories named (none: all).
///
/// # Safety
/// `categories` holds `n` strings, each NULL or NUL-terminated.
pub(crate) unsafe fn set_debug_logging(
    inst: &mut Instance,
    logging_on: bool,
    n: usize,
    categories: *const *const c_char,
) -> FmiResult {
    // SAFETY: `categories` holds `n` strings (this function's contract).
    let names = unsafe { slice(categories, n, "categories") }?;
    let mut list = Vec::with_capacity(names.len());
    for &name in names {
        // SAFETY: each category is NULL or NUL-terminated (this function's contract).
        let name = unsafe { string_arg(name) };
        list.push(name.ok_or_else(|| Failure::error("a log category is NULL"))?);
    }
    inst.set_debug_logging(logging_on, &list)
}

/// `SetFMUState`: restores a live state (of this instance's FMI version and model).
///
/// # Safety
/// The host does not free `state` during the call.
pub(crate) unsafe fn set_state(inst: &mut Instance, state: *mut c_void) -> FmiResult {
    // SAFETY: the host does not free `state` during the call (this function's contract).
    let saved = unsafe { saved_state(state) }?;
    inst.restore(saved)
}

/// `FreeFMUState`: frees `*state` (NULL is ignored) and sets it to NULL.
///
/// # Safety
/// `state` is NULL or valid for reading and writing one handle; no other thread uses it.
pub(crate) unsafe fn free_state(state: *mut *mut c_void) -> FmiResult {
    if state.is_null() {
        return Ok(());
    }
    // SAFETY: `state` is not NULL and points to a readable handle (this function's contract).
    let p = unsafe { *state } as *mut SavedState;
    if p.is_null() {
        return Ok(());
    }
    // SAFETY: no other thread uses the state (this function's contract).
    let Some(boxed) = (unsafe { STATES.release(p) }) else {
        return Err(Failure::error(
            "the FMU state was not made by this FMU or has been freed",
        ));
    };
    drop(boxed);
    // SAFETY: `state` is not NULL and writable (this function's contract).
    unsafe { *state = ptr::null_mut() };
    Ok(())
}

/// `SerializedFMUStateSize`.
///
/// # Safety
/// `size` is NULL or writable; the host does not free `state` during the call.
pub(crate) unsafe fn serialized_size(state: *mut c_void, size: *mut usize) -> FmiResult {
    // SAFETY: the host does not free `state` during the call (this function's contract).
    let saved = unsafe { saved_state(state) }?;
    // SAFETY: `size` is NULL or writable (this function's contract).
    let out = unsafe { slice_mut(size, 1, "size") }?;
    out[0] = saved.to_bytes().len();
    Ok(())
}

/// `SerializeFMUState`: writes exactly the serialized size's bytes.
///
/// # Safety
/// `serialized` holds `size` writable bytes; the host does not free `state` during the call.
pub(crate) unsafe fn serialize(state: *mut c_void, serialized: *mut u8, size: usize) -> FmiResult {
    // SAFETY: the host does not free `state` during the call (this function's contract).
    let bytes = unsafe { saved_state(state) }?.to_bytes();
    if size < bytes.len() {
        return Err(Failure::error(format!(
            "the buffer holds {size} bytes, the state needs {} (ask for the serialized size first)",
            bytes.len()
        )));
    }
    // SAFETY: `serialized` holds `size` >= `bytes.len()` bytes (this function's contract).
    let out = unsafe { slice_mut(serialized, bytes.len(), "serializedState") }?;
    out.copy_from_slice(&bytes);
    Ok(())
}

/// `DeserializeFMUState`: checks the bytes (format, model, FMI version), then allocates a
/// state (or overwrites `*state` when it is not NULL).
///
/// # Safety
/// `serialized` holds `size` bytes; `state` is NULL or valid for reading and writing one
/// handle (whose value is looked up before use).
pub(crate) unsafe fn deserialize(
    inst: &mut Instance,
    serialized: *const u8,
    size: usize,
    state: *mut *mut c_void,
) -> FmiResult {
    // SAFETY: `serialized` holds `size` bytes (this function's contract).
    let bytes = unsafe { slice(serialized, size, "serializedState") }?;
    let saved = SavedState::from_bytes(bytes, inst.model_hash()).map_err(Failure::error)?;
    inst.check_version(&saved)?;
    // SAFETY: `state` points to NULL or to a live state (this function's contract).
    unsafe { store_state(state, saved, inst) }
}
