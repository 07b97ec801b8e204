//! The exported FMI 2.0 Co-Simulation functions: pointer checks, slices, `catch_unwind`.
//!
//! Every export's safety contract is the FMI 2.0 standard's: the host passes pointers that are
//! valid for the stated lengths, a component it got from `fmi2Instantiate` and has not freed,
//! and does not call into one instance from two threads at once. Null pointers are checked
//! here anyway and rejected with `fmi2Error`.
#![allow(unsafe_code, clippy::missing_safety_doc, non_snake_case)]

use std::ffi::{CStr, CString, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::ptr;

use fmi2_sys::*;

use crate::instance::{Instance, Logger, Snapshot, Status};

impl From<Status> for fmi2Status {
    fn from(s: Status) -> Self {
        match s {
            Status::Ok => fmi2Status::fmi2OK,
            Status::Warning => fmi2Status::fmi2Warning,
            Status::Discard => fmi2Status::fmi2Discard,
            Status::Error => fmi2Status::fmi2Error,
            Status::Fatal => fmi2Status::fmi2Fatal,
        }
    }
}

/// Borrows the instance behind a component pointer.
fn instance<'a>(c: fmi2Component) -> Option<&'a mut Instance> {
    // SAFETY: a non-null component was made by `fmi2Instantiate` from `Box::into_raw`, and the
    // host neither uses it after `fmi2FreeInstance` nor from two threads at once (FMI 2.0 §2.1.5).
    unsafe { c.cast::<Instance>().as_mut() }
}

/// Runs `body` on the instance; a null component is an error, a panic makes the instance fatal.
fn call(c: fmi2Component, func: &'static str, body: impl FnOnce(&mut Instance) -> Status) -> fmi2Status {
    let Some(inst) = instance(c) else {
        return fmi2Status::fmi2Error;
    };
    match catch_unwind(AssertUnwindSafe(|| body(inst))) {
        Ok(status) => status.into(),
        Err(_) => {
            if let Some(inst) = instance(c) {
                let _ = catch_unwind(AssertUnwindSafe(|| inst.fatal(func)));
            }
            fmi2Status::fmi2Fatal
        }
    }
}

/// A slice from a host pointer and length; `None` when the pointer is null but `n > 0`.
fn slice<'a, T>(p: *const T, n: usize) -> Option<&'a [T]> {
    if n == 0 {
        return Some(&[]);
    }
    // SAFETY: non-null, and the host guarantees `n` valid elements (FMI 2.0 get/set contract).
    (!p.is_null()).then(|| unsafe { std::slice::from_raw_parts(p, n) })
}

/// A mutable slice from a host pointer and length; `None` when null but `n > 0`.
fn slice_mut<'a, T>(p: *mut T, n: usize) -> Option<&'a mut [T]> {
    if n == 0 {
        return Some(&mut []);
    }
    // SAFETY: non-null, and the host guarantees `n` valid, writable, unaliased elements.
    (!p.is_null()).then(|| unsafe { std::slice::from_raw_parts_mut(p, n) })
}

/// A C string from the host, lossily decoded; `None` when null.
fn text(s: fmi2String) -> Option<String> {
    // SAFETY: a non-null FMI string is NUL-terminated and valid for the call.
    (!s.is_null()).then(|| unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned())
}

fn null_error(inst: &mut Instance, func: &str, what: &str) -> Status {
    inst.unsupported(func, &format!("{what} is a null pointer"))
}

// ---- Inquiry -------------------------------------------------------------------------------

/// `fmi2GetTypesPlatform`.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    fmi2TypesPlatform.as_ptr().cast()
}

/// `fmi2GetVersion`.
#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    fmi2Version.as_ptr().cast()
}

/// `fmi2SetDebugLogging`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetDebugLogging(c: fmi2Component, logging_on: fmi2Boolean, n_categories: usize, categories: *const fmi2String) -> fmi2Status {
    call(c, "fmi2SetDebugLogging", |inst| {
        let Some(raw) = slice(categories, n_categories) else {
            return null_error(inst, "fmi2SetDebugLogging", "categories");
        };
        let Some(names) = raw.iter().map(|&s| text(s)).collect::<Option<Vec<String>>>() else {
            return null_error(inst, "fmi2SetDebugLogging", "a category");
        };
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        inst.set_debug_logging(logging_on != 0, &names)
    })
}

// ---- Life cycle ----------------------------------------------------------------------------

/// `fmi2Instantiate`: null on any problem, logged through the host's logger when there is one.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: fmi2String,
    fmu_type: fmi2Type,
    fmu_guid: fmi2String,
    _fmu_resource_location: fmi2String,
    functions: *const fmi2CallbackFunctions,
    _visible: fmi2Boolean,
    logging_on: fmi2Boolean,
) -> fmi2Component {
    catch_unwind(|| {
        // SAFETY: the host passes a valid callback struct or null; it is copied, so the host may
        // free it after this call.
        let callbacks = unsafe { functions.as_ref() }.copied();
        let name = text(instance_name).unwrap_or_default();
        let logger = host_logger(callbacks, &name);
        if instance_name.is_null() || fmu_guid.is_null() {
            logger(Status::Error, "logStatusError", "fmi2Instantiate: instanceName and fmuGUID must not be null");
            return ptr::null_mut();
        }
        if fmu_type != fmi2Type::fmi2CoSimulation {
            logger(Status::Error, "logStatusError", "fmi2Instantiate: this FMU supports Co-Simulation only");
            return ptr::null_mut();
        }
        let guid = text(fmu_guid).unwrap_or_default();
        match Instance::new(&guid, logger) {
            Ok(mut inst) => {
                if logging_on != 0 {
                    inst.set_debug_logging(true, &[]);
                }
                Box::into_raw(Box::new(inst)).cast()
            }
            Err(_) => ptr::null_mut(),
        }
    })
    .unwrap_or(ptr::null_mut())
}

/// Wraps the host's variadic logger; `"%s"` keeps `%` in messages from being read as formats.
fn host_logger(callbacks: Option<fmi2CallbackFunctions>, instance_name: &str) -> Logger {
    let name = CString::new(instance_name.replace('\0', " ")).unwrap_or_default();
    Box::new(move |status, category, message| {
        let Some(cb) = callbacks else { return };
        let Some(log) = cb.logger else { return };
        let category = CString::new(category.replace('\0', " ")).unwrap_or_default();
        let message = CString::new(message.replace('\0', " ")).unwrap_or_default();
        // SAFETY: the host's logger with valid NUL-terminated strings that outlive the call and a
        // format that consumes exactly the one string argument passed.
        unsafe {
            log(cb.componentEnvironment, name.as_ptr(), status.into(), category.as_ptr(), c"%s".as_ptr(), message.as_ptr());
        }
    })
}

/// `fmi2FreeInstance`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2FreeInstance(c: fmi2Component) {
    if c.is_null() {
        return;
    }
    // SAFETY: `c` came from `Box::into_raw` in `fmi2Instantiate` and is freed once (FMI contract).
    let mut boxed = unsafe { Box::from_raw(c.cast::<Instance>()) };
    let _ = catch_unwind(AssertUnwindSafe(move || {
        for state in boxed.states.drain() {
            // SAFETY: a live state this instance allocated with `Box::into_raw` (registered
            // then, unregistered when freed), so freed exactly once.
            drop(unsafe { Box::from_raw(state as *mut Snapshot) });
        }
        drop(boxed)
    }));
}

/// `fmi2SetupExperiment`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: fmi2Component,
    _tolerance_defined: fmi2Boolean,
    _tolerance: fmi2Real,
    start_time: fmi2Real,
    _stop_time_defined: fmi2Boolean,
    _stop_time: fmi2Real,
) -> fmi2Status {
    call(c, "fmi2SetupExperiment", |inst| inst.setup_experiment(start_time))
}

/// `fmi2EnterInitializationMode`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: fmi2Component) -> fmi2Status {
    call(c, "fmi2EnterInitializationMode", Instance::enter_initialization_mode)
}

/// `fmi2ExitInitializationMode`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: fmi2Component) -> fmi2Status {
    call(c, "fmi2ExitInitializationMode", Instance::exit_initialization_mode)
}

/// `fmi2Terminate`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2Terminate(c: fmi2Component) -> fmi2Status {
    call(c, "fmi2Terminate", Instance::terminate)
}

/// `fmi2Reset`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2Reset(c: fmi2Component) -> fmi2Status {
    call(c, "fmi2Reset", Instance::reset)
}

// ---- Values --------------------------------------------------------------------------------

/// Shared body of the getters: read as `f64`, convert to the host's type.
fn get_values<T>(c: fmi2Component, func: &'static str, kind: &'static str, vr: *const fmi2ValueReference, nvr: usize, value: *mut T, convert: fn(f64) -> T) -> fmi2Status {
    call(c, func, |inst| {
        let (Some(vrs), Some(out)) = (slice(vr, nvr), slice_mut(value, nvr)) else {
            return null_error(inst, func, "vr or value");
        };
        let mut tmp = vec![0.0; nvr];
        let status = inst.get(func, kind, vrs, &mut tmp);
        if status == Status::Ok {
            for (o, v) in out.iter_mut().zip(tmp) {
                *o = convert(v);
            }
        }
        status
    })
}

/// Shared body of the setters: convert from the host's type to `f64`, then set.
fn set_values<T: Copy>(c: fmi2Component, func: &'static str, kind: &'static str, vr: *const fmi2ValueReference, nvr: usize, value: *const T, convert: fn(T) -> f64) -> fmi2Status {
    call(c, func, |inst| {
        let (Some(vrs), Some(vals)) = (slice(vr, nvr), slice(value, nvr)) else {
            return null_error(inst, func, "vr or value");
        };
        let vals: Vec<f64> = vals.iter().map(|&v| convert(v)).collect();
        inst.set(func, kind, vrs, &vals)
    })
}

/// `fmi2GetReal`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetReal(c: fmi2Component, vr: *const fmi2ValueReference, nvr: usize, value: *mut fmi2Real) -> fmi2Status {
    get_values(c, "fmi2GetReal", "Real", vr, nvr, value, |v| v)
}

/// `fmi2GetInteger` (the `mode` enumeration).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetInteger(c: fmi2Component, vr: *const fmi2ValueReference, nvr: usize, value: *mut fmi2Integer) -> fmi2Status {
    get_values(c, "fmi2GetInteger", "Integer", vr, nvr, value, |v| v as fmi2Integer)
}

/// `fmi2GetBoolean`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetBoolean(c: fmi2Component, vr: *const fmi2ValueReference, nvr: usize, value: *mut fmi2Boolean) -> fmi2Status {
    get_values(c, "fmi2GetBoolean", "Boolean", vr, nvr, value, |v| fmi2Boolean::from(v != 0.0))
}

/// `fmi2GetString`: this FMU has no String variables.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetString(c: fmi2Component, vr: *const fmi2ValueReference, nvr: usize, value: *mut fmi2String) -> fmi2Status {
    get_values(c, "fmi2GetString", "String", vr, nvr, value, |_| ptr::null())
}

/// `fmi2SetReal`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetReal(c: fmi2Component, vr: *const fmi2ValueReference, nvr: usize, value: *const fmi2Real) -> fmi2Status {
    set_values(c, "fmi2SetReal", "Real", vr, nvr, value, |v| v)
}

/// `fmi2SetInteger` (the `mode` enumeration).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetInteger(c: fmi2Component, vr: *const fmi2ValueReference, nvr: usize, value: *const fmi2Integer) -> fmi2Status {
    set_values(c, "fmi2SetInteger", "Integer", vr, nvr, value, f64::from)
}

/// `fmi2SetBoolean`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetBoolean(c: fmi2Component, vr: *const fmi2ValueReference, nvr: usize, value: *const fmi2Boolean) -> fmi2Status {
    set_values(c, "fmi2SetBoolean", "Boolean", vr, nvr, value, |v| f64::from(u8::from(v != 0)))
}

/// `fmi2SetString`: this FMU has no String variables.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetString(c: fmi2Component, vr: *const fmi2ValueReference, nvr: usize, value: *const fmi2String) -> fmi2Status {
    set_values(c, "fmi2SetString", "String", vr, nvr, value, |_| f64::NAN)
}

// ---- FMU state -----------------------------------------------------------------------------

/// `fmi2GetFMUstate`: allocates a new state, or overwrites the one `*state` points to.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetFMUstate(c: fmi2Component, state: *mut fmi2FMUstate) -> fmi2Status {
    call(c, "fmi2GetFMUstate", |inst| {
        let Some(slot) = slice_mut(state, 1) else {
            return null_error(inst, "fmi2GetFMUstate", "FMUstate");
        };
        let snap = match inst.snapshot() {
            Ok(s) => s,
            Err(status) => return status,
        };
        if slot[0].is_null() {
            let new = Box::into_raw(Box::new(snap));
            inst.states.insert(new as usize);
            slot[0] = new.cast();
        } else if inst.states.contains(&(slot[0] as usize)) {
            // SAFETY: a live state of this instance (registered), not aliased during the call.
            unsafe { *slot[0].cast::<Snapshot>() = snap };
        } else {
            return not_a_state(inst, "fmi2GetFMUstate");
        }
        Status::Ok
    })
}

/// `fmi2SetFMUstate`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetFMUstate(c: fmi2Component, state: fmi2FMUstate) -> fmi2Status {
    call(c, "fmi2SetFMUstate", |inst| {
        if state.is_null() {
            return null_error(inst, "fmi2SetFMUstate", "FMUstate");
        }
        match snapshot_of(inst, state) {
            Some(snap) => inst.restore(&snap),
            None => not_a_state(inst, "fmi2SetFMUstate"),
        }
    })
}

/// `fmi2FreeFMUstate`: frees `*state` and sets it to null.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: fmi2Component, state: *mut fmi2FMUstate) -> fmi2Status {
    call(c, "fmi2FreeFMUstate", |inst| {
        if let Some([slot]) = slice_mut(state, 1)
            && !slot.is_null()
        {
            if !inst.states.remove(&(*slot as usize)) {
                return not_a_state(inst, "fmi2FreeFMUstate");
            }
            // SAFETY: allocated by this instance with `Box::into_raw` and just unregistered, so
            // freed once.
            drop(unsafe { Box::from_raw(slot.cast::<Snapshot>()) });
            *slot = ptr::null_mut();
        }
        Status::Ok
    })
}

/// A copy of the state behind `state` when it is a live state of `inst`.
fn snapshot_of(inst: &Instance, state: fmi2FMUstate) -> Option<Snapshot> {
    if !inst.states.contains(&(state as usize)) {
        return None;
    }
    // SAFETY: registered: allocated by this instance and not freed.
    unsafe { state.cast::<Snapshot>().as_ref() }.cloned()
}

fn not_a_state(inst: &mut Instance, func: &str) -> Status {
    inst.unsupported(func, "FMUstate is not a live state of this instance (freed already, or another instance's)")
}

/// `fmi2SerializedFMUstateSize`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(c: fmi2Component, state: fmi2FMUstate, size: *mut usize) -> fmi2Status {
    const FUNC: &str = "fmi2SerializedFMUstateSize";
    call(c, FUNC, |inst| {
        let (Some(snap), Some([size])) = (snapshot_of(inst, state), slice_mut(size, 1)) else {
            return null_error(inst, FUNC, "FMUstate (a live state of this instance) or size");
        };
        match inst.serialize(FUNC, &snap) {
            Ok(bytes) => {
                *size = bytes.len();
                Status::Ok
            }
            Err(s) => s,
        }
    })
}

/// `fmi2SerializeFMUstate`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SerializeFMUstate(c: fmi2Component, state: fmi2FMUstate, bytes: *mut fmi2Byte, size: usize) -> fmi2Status {
    const FUNC: &str = "fmi2SerializeFMUstate";
    call(c, FUNC, |inst| {
        let (Some(snap), Some(out)) = (snapshot_of(inst, state), slice_mut(bytes.cast::<u8>(), size)) else {
            return null_error(inst, FUNC, "FMUstate (a live state of this instance) or serializedState");
        };
        match inst.serialize(FUNC, &snap) {
            Ok(data) if data.len() == size => {
                out.copy_from_slice(&data);
                Status::Ok
            }
            Ok(data) => inst.unsupported(FUNC, &format!("size is {size}, the state needs {} bytes", data.len())),
            Err(s) => s,
        }
    })
}

/// `fmi2DeSerializeFMUstate`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(c: fmi2Component, bytes: *const fmi2Byte, size: usize, state: *mut fmi2FMUstate) -> fmi2Status {
    const FUNC: &str = "fmi2DeSerializeFMUstate";
    call(c, FUNC, |inst| {
        let (Some(data), Some([slot])) = (slice(bytes.cast::<u8>(), size), slice_mut(state, 1)) else {
            return null_error(inst, FUNC, "serializedState or FMUstate");
        };
        match inst.deserialize(data) {
            Ok(snap) => {
                let new = Box::into_raw(Box::new(snap));
                inst.states.insert(new as usize);
                *slot = new.cast();
                Status::Ok
            }
            Err(s) => s,
        }
    })
}

// ---- Capabilities this FMU declares absent -------------------------------------------------

/// `fmi2GetDirectionalDerivative`: not provided (`providesDirectionalDerivative="false"`).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: fmi2Component,
    _v_unknown_ref: *const fmi2ValueReference,
    _n_unknown: usize,
    _v_known_ref: *const fmi2ValueReference,
    _n_known: usize,
    _dv_known: *const fmi2Real,
    _dv_unknown: *mut fmi2Real,
) -> fmi2Status {
    const FUNC: &str = "fmi2GetDirectionalDerivative";
    call(c, FUNC, |inst| inst.unsupported(FUNC, "directional derivatives are not provided"))
}

/// `fmi2SetRealInputDerivatives`: not used (`canInterpolateInputs="false"`).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(c: fmi2Component, _vr: *const fmi2ValueReference, _nvr: usize, _order: *const fmi2Integer, _value: *const fmi2Real) -> fmi2Status {
    const FUNC: &str = "fmi2SetRealInputDerivatives";
    call(c, FUNC, |inst| inst.unsupported(FUNC, "inputs are held constant over a step (canInterpolateInputs=false)"))
}

/// `fmi2GetRealOutputDerivatives`: not provided (`maxOutputDerivativeOrder="0"`).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(c: fmi2Component, _vr: *const fmi2ValueReference, _nvr: usize, _order: *const fmi2Integer, _value: *mut fmi2Real) -> fmi2Status {
    const FUNC: &str = "fmi2GetRealOutputDerivatives";
    call(c, FUNC, |inst| inst.unsupported(FUNC, "output derivatives are not provided (maxOutputDerivativeOrder=0)"))
}

// ---- Stepping ------------------------------------------------------------------------------

/// `fmi2DoStep`: always synchronous.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2DoStep(c: fmi2Component, current_communication_point: fmi2Real, communication_step_size: fmi2Real, _no_set_fmu_state_prior_to_current_point: fmi2Boolean) -> fmi2Status {
    call(c, "fmi2DoStep", |inst| inst.do_step(current_communication_point, communication_step_size))
}

/// `fmi2CancelStep`: steps never pend, so there is nothing to cancel.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2CancelStep(c: fmi2Component) -> fmi2Status {
    const FUNC: &str = "fmi2CancelStep";
    call(c, FUNC, |inst| inst.unsupported(FUNC, "fmi2DoStep never returns fmi2Pending"))
}

/// `fmi2GetStatus`: nothing to report for a synchronous FMU.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetStatus(c: fmi2Component, _s: fmi2StatusKind, _value: *mut fmi2Status) -> fmi2Status {
    call(c, "fmi2GetStatus", |_| Status::Discard)
}

/// `fmi2GetRealStatus`: `fmi2LastSuccessfulTime` is the FMU time.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetRealStatus(c: fmi2Component, s: fmi2StatusKind, value: *mut fmi2Real) -> fmi2Status {
    call(c, "fmi2GetRealStatus", |inst| {
        let Some([out]) = slice_mut(value, 1) else {
            return null_error(inst, "fmi2GetRealStatus", "value");
        };
        if s != fmi2StatusKind::fmi2LastSuccessfulTime {
            return Status::Discard;
        }
        match inst.last_successful_time() {
            Ok(t) => {
                *out = t;
                Status::Ok
            }
            Err(status) => status,
        }
    })
}

/// `fmi2GetIntegerStatus`: nothing to report.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetIntegerStatus(c: fmi2Component, _s: fmi2StatusKind, _value: *mut fmi2Integer) -> fmi2Status {
    call(c, "fmi2GetIntegerStatus", |_| Status::Discard)
}

/// `fmi2GetBooleanStatus`: `fmi2Terminated` is always false.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetBooleanStatus(c: fmi2Component, s: fmi2StatusKind, value: *mut fmi2Boolean) -> fmi2Status {
    call(c, "fmi2GetBooleanStatus", |inst| {
        let Some([out]) = slice_mut(value, 1) else {
            return null_error(inst, "fmi2GetBooleanStatus", "value");
        };
        if s != fmi2StatusKind::fmi2Terminated {
            return Status::Discard;
        }
        match inst.wants_to_terminate() {
            Ok(t) => {
                *out = fmi2Boolean::from(t);
                Status::Ok
            }
            Err(status) => status,
        }
    })
}

/// `fmi2GetStringStatus`: nothing to report.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetStringStatus(c: fmi2Component, _s: fmi2StatusKind, _value: *mut fmi2String) -> fmi2Status {
    call(c, "fmi2GetStringStatus", |_| Status::Discard)
}

/// Compile-time proof that every export has exactly the signature of the standard's typedef.
const _: () = {
    let _: fmi2GetTypesPlatformTYPE = Some(fmi2GetTypesPlatform);
    let _: fmi2GetVersionTYPE = Some(fmi2GetVersion);
    let _: fmi2SetDebugLoggingTYPE = Some(fmi2SetDebugLogging);
    let _: fmi2InstantiateTYPE = Some(fmi2Instantiate);
    let _: fmi2FreeInstanceTYPE = Some(fmi2FreeInstance);
    let _: fmi2SetupExperimentTYPE = Some(fmi2SetupExperiment);
    let _: fmi2EnterInitializationModeTYPE = Some(fmi2EnterInitializationMode);
    let _: fmi2ExitInitializationModeTYPE = Some(fmi2ExitInitializationMode);
    let _: fmi2TerminateTYPE = Some(fmi2Terminate);
    let _: fmi2ResetTYPE = Some(fmi2Reset);
    let _: fmi2GetRealTYPE = Some(fmi2GetReal);
    let _: fmi2GetIntegerTYPE = Some(fmi2GetInteger);
    let _: fmi2GetBooleanTYPE = Some(fmi2GetBoolean);
    let _: fmi2GetStringTYPE = Some(fmi2GetString);
    let _: fmi2SetRealTYPE = Some(fmi2SetReal);
    let _: fmi2SetIntegerTYPE = Some(fmi2SetInteger);
    let _: fmi2SetBooleanTYPE = Some(fmi2SetBoolean);
    let _: fmi2SetStringTYPE = Some(fmi2SetString);
    let _: fmi2GetFMUstateTYPE = Some(fmi2GetFMUstate);
    let _: fmi2SetFMUstateTYPE = Some(fmi2SetFMUstate);
    let _: fmi2FreeFMUstateTYPE = Some(fmi2FreeFMUstate);
    let _: fmi2SerializedFMUstateSizeTYPE = Some(fmi2SerializedFMUstateSize);
    let _: fmi2SerializeFMUstateTYPE = Some(fmi2SerializeFMUstate);
    let _: fmi2DeSerializeFMUstateTYPE = Some(fmi2DeSerializeFMUstate);
    let _: fmi2GetDirectionalDerivativeTYPE = Some(fmi2GetDirectionalDerivative);
    let _: fmi2SetRealInputDerivativesTYPE = Some(fmi2SetRealInputDerivatives);
    let _: fmi2GetRealOutputDerivativesTYPE = Some(fmi2GetRealOutputDerivatives);
    let _: fmi2DoStepTYPE = Some(fmi2DoStep);
    let _: fmi2CancelStepTYPE = Some(fmi2CancelStep);
    let _: fmi2GetStatusTYPE = Some(fmi2GetStatus);
    let _: fmi2GetRealStatusTYPE = Some(fmi2GetRealStatus);
    let _: fmi2GetIntegerStatusTYPE = Some(fmi2GetIntegerStatus);
    let _: fmi2GetBooleanStatusTYPE = Some(fmi2GetBooleanStatus);
    let _: fmi2GetStringStatusTYPE = Some(fmi2GetStringStatus);
};
