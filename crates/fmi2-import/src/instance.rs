//! A live FMU instance with safe methods over the raw `fmi2*` calls.
use std::ffi::CString;
use std::mem::ManuallyDrop;
use std::ptr;

use fmi2_sys::{fmi2Boolean, fmi2Component, fmi2FMUstate, fmi2Status, fmi2StatusKind, fmi2Type};

use crate::callbacks::{Environment, LogMessage};
use crate::fmu::{InstanceSlot, InstantiateOptions};
use crate::library::{Functions, Library};
use crate::{Fmu, ImportError, Status};

/// One instance of an FMU, created by [`Fmu::instantiate`].
///
/// Each method performs one `fmi2*` call; a status other than `fmi2OK`/`fmi2Warning` becomes
/// [`ImportError::Call`] with what the FMU logged during that call (warnings stay readable
/// through [`Instance::take_log`]). Dropping the instance frees the FMU state snapshots and the
/// component, then unloads the binary.
///
/// FMI 2.0 does not promise that an instance may move between threads, so `Instance` is
/// neither `Send` nor `Sync`:
///
/// ```compile_fail
/// fn send<T: Send>() {}
/// send::<fmi2_import::Instance>();
/// ```
pub struct Instance {
    /// Non-null component from `fmi2Instantiate`.
    component: fmi2Component,
    /// Lives at a fixed address until after `fmi2FreeInstance` (freed in `Drop`).
    env: *mut Environment,
    name: String,
    can_get_and_set_state: bool,
    /// Set after `fmi2Fatal`: FMI then forbids every further call, `fmi2FreeInstance` included.
    fatal: bool,
    /// Snapshots taken by [`Instance::get_state`] and not yet freed.
    states: Vec<fmi2FMUstate>,
    /// Unloaded in `Drop` after the component is freed (leaked after `fmi2Fatal`).
    library: ManuallyDrop<Library>,
    /// Keeps the extracted FMU (its resources) alive; dropped last.
    _slot: InstanceSlot,
}

/// A snapshot of an instance's state from [`Instance::get_state`]. Restore it with
/// [`Instance::set_state`]; release it with [`Instance::free_state`] or let the instance free
/// it when dropped.
#[derive(Debug)]
pub struct FmuState {
    ptr: fmi2FMUstate,
    /// The environment of the instance that made it: identifies the owner.
    owner: *const Environment,
}

const fn boolean(b: bool) -> fmi2Boolean {
    if b { 1 } else { 0 }
}

impl Instance {
    pub(crate) fn new(fmu: &Fmu, instance_name: &str, options: InstantiateOptions) -> Result<Self, ImportError> {
        let nul = |what, value: &str| ImportError::NulByte { what, value: value.to_owned() };
        let name = CString::new(instance_name).map_err(|_| nul("instance name", instance_name))?;
        let guid = &fmu.model_description().guid;
        let guid = CString::new(guid.as_str()).map_err(|_| nul("GUID", guid))?;
        let uri = fmu.resource_uri();
        let uri = CString::new(uri.as_str()).map_err(|_| nul("resource location", &uri))?;
        let slot = fmu.claim_instance()?;
        let library = Library::load(&fmu.binary_path(), fmu.is_pythonfmu())?;

        let env = Environment::into_raw(options.log_callback);
        // SAFETY: every string is NUL-terminated and outlives the call; the callback struct
        // lives inside `env`, which stays at its address until after `fmi2FreeInstance`
        // (or until just below, when instantiation fails).
        let component =
            unsafe { (library.functions.instantiate)(name.as_ptr(), fmi2Type::fmi2CoSimulation, guid.as_ptr(), uri.as_ptr(), (*env).functions(), boolean(false), boolean(options.debug_logging)) };
        if component.is_null() {
            // SAFETY: `env` is live; the FMU returned no instance, so it keeps no use of it.
            let log = unsafe { (*env).take() };
            // SAFETY: as above; freed exactly once.
            unsafe { Environment::free(env) };
            return Err(ImportError::Instantiate { instance: instance_name.to_owned(), log });
        }
        Ok(Self {
            component,
            env,
            name: instance_name.to_owned(),
            can_get_and_set_state: fmu.co_simulation().can_get_and_set_fmu_state == Some(true),
            fatal: false,
            states: Vec::new(),
            library: ManuallyDrop::new(library),
            _slot: slot,
        })
    }

    fn env(&self) -> &Environment {
        // SAFETY: `env` is valid from `new` until `Drop`, and only ever shared.
        unsafe { &*self.env }
    }

    /// The one place a raw call happens and its status becomes a `Result`.
    fn call(&mut self, function: &'static str, raw: impl FnOnce(&Functions, fmi2Component) -> fmi2Status) -> Result<(), ImportError> {
        if self.fatal {
            return Err(ImportError::Unusable { function });
        }
        let mark = self.env().mark();
        let status = raw(&self.library.functions, self.component);
        self.check(function, mark, status)
    }

    fn check(&mut self, function: &'static str, mark: u64, status: fmi2Status) -> Result<(), ImportError> {
        match Status::from(status) {
            Status::Ok | Status::Warning => Ok(()),
            status => {
                self.fatal |= status == Status::Fatal;
                Err(ImportError::Call { function, status, log: self.env().since(mark) })
            }
        }
    }

    fn same_length(function: &'static str, refs: usize, values: usize) -> Result<(), ImportError> {
        if refs == values { Ok(()) } else { Err(ImportError::LengthMismatch { function, refs, values }) }
    }

    /// The name given at instantiation.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Removes and returns every message the FMU logged so far (the newest 10 000 are kept).
    pub fn take_log(&mut self) -> Vec<LogMessage> {
        self.env().take()
    }

    /// `fmi2SetDebugLogging`; empty `categories` means all.
    pub fn set_debug_logging(&mut self, on: bool, categories: &[&str]) -> Result<(), ImportError> {
        const F: &str = "fmi2SetDebugLogging";
        let Some(set) = self.library.functions.set_debug_logging else {
            return Err(ImportError::Unsupported { function: F, reason: "the binary does not export it" });
        };
        let owned = categories.iter().map(|c| CString::new(*c).map_err(|_| ImportError::NulByte { what: "log category", value: (*c).to_owned() })).collect::<Result<Vec<_>, _>>()?;
        let ptrs: Vec<_> = owned.iter().map(|c| c.as_ptr()).collect();
        // SAFETY: `ptrs` holds `ptrs.len()` NUL-terminated strings that outlive the call.
        self.call(F, |_, c| unsafe { set(c, boolean(on), ptrs.len(), ptrs.as_ptr()) })
    }

    /// `fmi2SetupExperiment` with start time \[s\] and optional stop time \[s\]; no tolerance.
    pub fn setup_experiment(&mut self, start: f64, stop: Option<f64>) -> Result<(), ImportError> {
        let (defined, stop) = stop.map_or((false, 0.0), |s| (true, s));
        // SAFETY: a live component and plain values.
        self.call("fmi2SetupExperiment", |f, c| unsafe { (f.setup_experiment)(c, boolean(false), 0.0, start, boolean(defined), stop) })
    }

    /// `fmi2EnterInitializationMode`.
    pub fn enter_initialization_mode(&mut self) -> Result<(), ImportError> {
        // SAFETY: a live component.
        self.call("fmi2EnterInitializationMode", |f, c| unsafe { (f.enter_initialization_mode)(c) })
    }

    /// `fmi2ExitInitializationMode`.
    pub fn exit_initialization_mode(&mut self) -> Result<(), ImportError> {
        // SAFETY: a live component.
        self.call("fmi2ExitInitializationMode", |f, c| unsafe { (f.exit_initialization_mode)(c) })
    }

    /// `fmi2Terminate`.
    pub fn terminate(&mut self) -> Result<(), ImportError> {
        // SAFETY: a live component.
        self.call("fmi2Terminate", |f, c| unsafe { (f.terminate)(c) })
    }

    /// `fmi2Reset`: back to the state right after instantiation.
    pub fn reset(&mut self) -> Result<(), ImportError> {
        // SAFETY: a live component.
        self.call("fmi2Reset", |f, c| unsafe { (f.reset)(c) })
    }

    /// `fmi2SetReal`: `values[i]` goes to `refs[i]`.
    pub fn set_real(&mut self, refs: &[u32], values: &[f64]) -> Result<(), ImportError> {
        const F: &str = "fmi2SetReal";
        Self::same_length(F, refs.len(), values.len())?;
        // SAFETY: both slices hold `refs.len()` elements and outlive the call.
        self.call(F, |f, c| unsafe { (f.set_real)(c, refs.as_ptr(), refs.len(), values.as_ptr()) })
    }

    /// `fmi2GetReal`: fills `values[i]` with `refs[i]`.
    pub fn get_real(&mut self, refs: &[u32], values: &mut [f64]) -> Result<(), ImportError> {
        const F: &str = "fmi2GetReal";
        Self::same_length(F, refs.len(), values.len())?;
        // SAFETY: both slices hold `refs.len()` elements; `values` is writable.
        self.call(F, |f, c| unsafe { (f.get_real)(c, refs.as_ptr(), refs.len(), values.as_mut_ptr()) })
    }

    /// `fmi2SetInteger` (also for enumerations).
    pub fn set_integer(&mut self, refs: &[u32], values: &[i32]) -> Result<(), ImportError> {
        const F: &str = "fmi2SetInteger";
        Self::same_length(F, refs.len(), values.len())?;
        // SAFETY: both slices hold `refs.len()` elements and outlive the call.
        self.call(F, |f, c| unsafe { (f.set_integer)(c, refs.as_ptr(), refs.len(), values.as_ptr()) })
    }

    /// `fmi2GetInteger` (also for enumerations).
    pub fn get_integer(&mut self, refs: &[u32], values: &mut [i32]) -> Result<(), ImportError> {
        const F: &str = "fmi2GetInteger";
        Self::same_length(F, refs.len(), values.len())?;
        // SAFETY: both slices hold `refs.len()` elements; `values` is writable.
        self.call(F, |f, c| unsafe { (f.get_integer)(c, refs.as_ptr(), refs.len(), values.as_mut_ptr()) })
    }

    /// `fmi2SetBoolean`.
    pub fn set_boolean(&mut self, refs: &[u32], values: &[bool]) -> Result<(), ImportError> {
        const F: &str = "fmi2SetBoolean";
        Self::same_length(F, refs.len(), values.len())?;
        let raw: Vec<fmi2Boolean> = values.iter().map(|&b| boolean(b)).collect();
        // SAFETY: both buffers hold `refs.len()` elements and outlive the call.
        self.call(F, |f, c| unsafe { (f.set_boolean)(c, refs.as_ptr(), refs.len(), raw.as_ptr()) })
    }

    /// `fmi2GetBoolean`.
    pub fn get_boolean(&mut self, refs: &[u32], values: &mut [bool]) -> Result<(), ImportError> {
        const F: &str = "fmi2GetBoolean";
        Self::same_length(F, refs.len(), values.len())?;
        let mut raw: Vec<fmi2Boolean> = vec![0; refs.len()];
        // SAFETY: both buffers hold `refs.len()` elements; `raw` is writable.
        self.call(F, |f, c| unsafe { (f.get_boolean)(c, refs.as_ptr(), refs.len(), raw.as_mut_ptr()) })?;
        for (v, r) in values.iter_mut().zip(raw) {
            *v = r != 0;
        }
        Ok(())
    }

    /// `fmi2GetString`: fills `values[i]` with a copy of `refs[i]` (a null string reads as "").
    pub fn get_string(&mut self, refs: &[u32], values: &mut [String]) -> Result<(), ImportError> {
        const F: &str = "fmi2GetString";
        Self::same_length(F, refs.len(), values.len())?;
        let Some(get) = self.library.functions.get_string else {
            return Err(ImportError::Unsupported { function: F, reason: "the binary does not export it" });
        };
        let mut raw: Vec<fmi2_sys::fmi2String> = vec![ptr::null(); refs.len()];
        // SAFETY: both buffers hold `refs.len()` elements; `raw` is writable.
        self.call(F, |_, c| unsafe { get(c, refs.as_ptr(), refs.len(), raw.as_mut_ptr()) })?;
        for (v, p) in values.iter_mut().zip(raw) {
            *v = if p.is_null() {
                String::new()
            } else {
                // SAFETY: FMI 2.0 returns NUL-terminated strings that stay valid until the next
                // call on this instance; they are copied here, before any other call.
                unsafe { std::ffi::CStr::from_ptr(p) }.to_string_lossy().into_owned()
            };
        }
        Ok(())
    }

    /// `fmi2SetString`.
    pub fn set_string(&mut self, refs: &[u32], values: &[&str]) -> Result<(), ImportError> {
        const F: &str = "fmi2SetString";
        Self::same_length(F, refs.len(), values.len())?;
        let Some(set) = self.library.functions.set_string else {
            return Err(ImportError::Unsupported { function: F, reason: "the binary does not export it" });
        };
        let owned = values.iter().map(|v| CString::new(*v).map_err(|_| ImportError::NulByte { what: "string value", value: (*v).to_owned() })).collect::<Result<Vec<_>, _>>()?;
        let ptrs: Vec<fmi2_sys::fmi2String> = owned.iter().map(|c| c.as_ptr()).collect();
        // SAFETY: `ptrs` holds `refs.len()` NUL-terminated strings that outlive the call.
        self.call(F, |_, c| unsafe { set(c, refs.as_ptr(), refs.len(), ptrs.as_ptr()) })
    }

    /// `fmi2DoStep` from communication point `t` \[s\] over `h` \[s\].
    ///
    /// `noSetFMUStatePriorToCurrentPoint` is true unless a snapshot from
    /// [`Instance::get_state`] is held, so the FMU may drop history it will not need.
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<(), ImportError> {
        let no_rollback = boolean(self.states.is_empty());
        // SAFETY: a live component and plain values.
        self.call("fmi2DoStep", |f, c| unsafe { (f.do_step)(c, t, h, no_rollback) })
    }

    /// After `fmi2DoStep` returned `fmi2Discard`: whether the FMU asks to end the simulation
    /// (`fmi2GetBooleanStatus(fmi2Terminated)`) and, if so, the time it reached
    /// (`fmi2GetRealStatus(fmi2LastSuccessfulTime)`) \[s\].
    pub fn terminated_at(&mut self) -> Result<Option<f64>, ImportError> {
        let functions = &self.library.functions;
        let (Some(get_bool), Some(get_real)) = (functions.get_boolean_status, functions.get_real_status) else {
            return Err(ImportError::Unsupported { function: "fmi2GetBooleanStatus", reason: "the binary does not export it" });
        };
        let mut terminated: fmi2Boolean = 0;
        // SAFETY: a live component; `terminated` is writable.
        self.call("fmi2GetBooleanStatus", |_, c| unsafe { get_bool(c, fmi2StatusKind::fmi2Terminated, &mut terminated) })?;
        if terminated == 0 {
            return Ok(None);
        }
        let mut time = f64::NAN;
        // SAFETY: a live component; `time` is writable.
        self.call("fmi2GetRealStatus", |_, c| unsafe { get_real(c, fmi2StatusKind::fmi2LastSuccessfulTime, &mut time) })?;
        Ok(Some(time))
    }

    fn state_function<T>(&self, function: &'static str, f: Option<T>) -> Result<T, ImportError> {
        if !self.can_get_and_set_state {
            return Err(ImportError::Unsupported { function, reason: "the model description does not declare canGetAndSetFMUstate=\"true\"" });
        }
        f.ok_or(ImportError::Unsupported { function, reason: "the binary does not export it" })
    }

    fn owned_state(&self, function: &'static str, state: &FmuState) -> Result<(), ImportError> {
        if ptr::eq(state.owner, self.env) && self.states.contains(&state.ptr) { Ok(()) } else { Err(ImportError::ForeignState { function }) }
    }

    /// `fmi2GetFMUstate`: a snapshot of the whole instance state.
    pub fn get_state(&mut self) -> Result<FmuState, ImportError> {
        const F: &str = "fmi2GetFMUstate";
        let get = self.state_function(F, self.library.functions.get_fmu_state)?;
        let mut state: fmi2FMUstate = ptr::null_mut();
        // SAFETY: a null `state` asks the FMU to allocate a new snapshot and write its pointer.
        self.call(F, |_, c| unsafe { get(c, &mut state) })?;
        if state.is_null() {
            return Err(ImportError::Unsupported { function: F, reason: "the FMU reported success but returned no state" });
        }
        self.states.push(state);
        Ok(FmuState { ptr: state, owner: self.env })
    }

    /// `fmi2SetFMUstate`: restores a snapshot taken from this instance.
    pub fn set_state(&mut self, state: &FmuState) -> Result<(), ImportError> {
        const F: &str = "fmi2SetFMUstate";
        let set = self.state_function(F, self.library.functions.set_fmu_state)?;
        self.owned_state(F, state)?;
        // SAFETY: the snapshot was made by this instance and is not freed (checked above).
        self.call(F, |_, c| unsafe { set(c, state.ptr) })
    }

    /// `fmi2FreeFMUstate`: releases a snapshot taken from this instance.
    pub fn free_state(&mut self, state: FmuState) -> Result<(), ImportError> {
        const F: &str = "fmi2FreeFMUstate";
        let free = self.state_function(F, self.library.functions.free_fmu_state)?;
        self.owned_state(F, &state)?;
        self.states.retain(|&s| s != state.ptr);
        let mut raw = state.ptr;
        // SAFETY: the snapshot was made by this instance and is freed once (removed above).
        self.call(F, |_, c| unsafe { free(c, &mut raw) })
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        if self.fatal {
            // FMI forbids every call after fmi2Fatal: leak the component and keep its code
            // mapped, since the FMU may still reference the environment or its own code.
            return;
        }
        let functions = &self.library.functions;
        if let Some(free) = functions.free_fmu_state {
            for mut state in self.states.drain(..) {
                // SAFETY: each snapshot was made by this live component and is freed once.
                unsafe { free(self.component, &mut state) };
            }
        }
        // SAFETY: the component is live and freed exactly once; nothing uses it afterwards.
        unsafe { (functions.free_instance)(self.component) };
        // SAFETY: after fmi2FreeInstance the FMU no longer calls back; freed exactly once.
        unsafe { Environment::free(self.env) };
        // SAFETY: the component is gone, so no FMU code runs any more; dropped exactly once.
        unsafe { ManuallyDrop::drop(&mut self.library) };
    }
}
