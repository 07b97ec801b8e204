//! The host side of `fmi2CallbackFunctions`: the logger (through the C shim in
//! `csrc/logger.c`), the memory functions and the per-instance log the FMU writes into.
use std::collections::VecDeque;
use std::ffi::{CStr, c_char, c_uint, c_void};
use std::fmt;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::ptr;
use std::sync::{Mutex, MutexGuard, PoisonError};

use fmi2_sys::{fmi2CallbackFunctions, fmi2ComponentEnvironment, fmi2Status, fmi2String};

use crate::Status;

/// Messages kept per instance; older ones are dropped so a chatty FMU cannot exhaust memory.
const MAX_MESSAGES: usize = 10_000;

/// One message the FMU sent through the logger callback.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogMessage {
    /// The instance name the FMU passed (normally the one given at instantiation).
    pub instance_name: String,
    /// The status the FMU attached to the message.
    pub status: Status,
    /// The log category, e.g. `logStatusError`.
    pub category: String,
    /// The formatted message text.
    pub message: String,
}

impl fmt::Display for LogMessage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "[{} {}] {}", self.status, self.category, self.message)
    }
}

/// A user function that also receives every message (it may be called from any thread the FMU
/// logs from, hence `Send + Sync`).
pub type LogCallback = Box<dyn Fn(&LogMessage) + Send + Sync>;

/// The non-variadic function the C shim calls with the formatted message.
type Sink = unsafe extern "C" fn(env: *mut c_void, instance_name: *const c_char, status: c_uint, category: *const c_char, message: *const c_char);

unsafe extern "C" {
    /// `csrc/logger.c`: formats with `vsnprintf` and calls the [`Sink`] found at `env`.
    fn fmi2_import_logger(env: fmi2ComponentEnvironment, instance_name: fmi2String, status: fmi2Status, category: fmi2String, message: fmi2String, ...);
    fn calloc(count: usize, size: usize) -> *mut c_void;
    fn free(ptr: *mut c_void);
}

/// The `componentEnvironment` of one instance: lives at a fixed heap address from before
/// `fmi2Instantiate` until after `fmi2FreeInstance` (see [`Environment::into_raw`]).
#[repr(C)]
pub(crate) struct Environment {
    /// Must stay the first field: the C shim reads it through the `componentEnvironment` pointer.
    sink: Sink,
    /// Handed to `fmi2Instantiate`; FMUs may keep the pointer, so it lives here too.
    functions: fmi2CallbackFunctions,
    log: Mutex<Log>,
    callback: Option<LogCallback>,
}

#[derive(Default)]
struct Log {
    messages: VecDeque<LogMessage>,
    /// Number of messages ever received: `mark`s stay valid when old messages are dropped.
    total: u64,
}

impl Environment {
    /// Allocates an environment and leaks it to a stable address; free it with
    /// [`Environment::free`] once the FMU can no longer call back.
    pub(crate) fn into_raw(callback: Option<LogCallback>) -> *mut Environment {
        let env = Box::into_raw(Box::new(Environment {
            sink,
            functions: fmi2CallbackFunctions { logger: Some(fmi2_import_logger), allocateMemory: Some(calloc), freeMemory: Some(free), stepFinished: None, componentEnvironment: ptr::null_mut() },
            log: Mutex::new(Log::default()),
            callback,
        }));
        // SAFETY: `env` was just allocated by `Box::into_raw`, so it is valid and unaliased.
        unsafe { (*env).functions.componentEnvironment = env.cast() };
        env
    }

    /// Frees an environment made by [`Environment::into_raw`].
    ///
    /// # Safety
    /// `env` comes from [`Environment::into_raw`], is freed once, and no FMU call that could
    /// use it is running or will run (i.e. after `fmi2FreeInstance`).
    pub(crate) unsafe fn free(env: *mut Environment) {
        // SAFETY: guaranteed by the caller.
        drop(unsafe { Box::from_raw(env) });
    }

    /// The callback struct for `fmi2Instantiate`; valid as long as `self`.
    pub(crate) fn functions(&self) -> *const fmi2CallbackFunctions {
        &self.functions
    }

    fn lock(&self) -> MutexGuard<'_, Log> {
        // A panicking user callback never holds this lock, but stay usable regardless.
        self.log.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Stores first, so a panicking user callback cannot lose the message.
    fn push(&self, message: LogMessage) {
        let copy = self.callback.as_ref().map(|callback| (callback, message.clone()));
        {
            let mut log = self.lock();
            if log.messages.len() == MAX_MESSAGES {
                log.messages.pop_front();
            }
            log.messages.push_back(message);
            log.total += 1;
        }
        if let Some((callback, message)) = copy {
            callback(&message);
        }
    }

    /// A position in the log; [`Environment::since`] returns what came after it.
    pub(crate) fn mark(&self) -> u64 {
        self.lock().total
    }

    /// Copies of the messages logged after `mark` (that are still kept).
    pub(crate) fn since(&self, mark: u64) -> Vec<LogMessage> {
        let log = self.lock();
        let new = usize::try_from(log.total.saturating_sub(mark)).unwrap_or(usize::MAX);
        let skip = log.messages.len().saturating_sub(new);
        log.messages.iter().skip(skip).cloned().collect()
    }

    /// Removes and returns every kept message.
    pub(crate) fn take(&self) -> Vec<LogMessage> {
        self.lock().messages.drain(..).collect()
    }
}

/// Copies a C string that may be null or not UTF-8.
///
/// # Safety
/// `s` is null or points to a NUL-terminated string valid for the duration of the call.
unsafe fn lossy(s: *const c_char) -> String {
    if s.is_null() {
        return String::new();
    }
    // SAFETY: non-null and NUL-terminated by the caller's contract.
    unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned()
}

/// Receives one formatted message from the C shim; never unwinds into C.
unsafe extern "C" fn sink(env: *mut c_void, instance_name: *const c_char, status: c_uint, category: *const c_char, message: *const c_char) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: the C shim passes the `componentEnvironment` we gave the FMU, which is a live
        // `Environment` until after `fmi2FreeInstance`; it is only ever shared (`&`), and its
        // mutable parts are behind a `Mutex`.
        let Some(env) = (unsafe { env.cast::<Environment>().as_ref() }) else { return };
        // SAFETY: the FMU passes NUL-terminated strings (or null) valid during the logger call;
        // `message` is the shim's formatted buffer, valid until the sink returns.
        let (instance_name, category, message) = unsafe { (lossy(instance_name), lossy(category), lossy(message)) };
        env.push(LogMessage { instance_name, status: fmi2Status(status).into(), category, message });
    }));
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicUsize, Ordering};

    use super::*;

    /// Calls the shim as an FMU would; returns what the log received.
    fn log_through_shim(env: *mut Environment, format: &CStr, arg: &CStr, number: i32) {
        // SAFETY: `env` is live; `logger` is the shim; the format consumes one string and one int.
        unsafe {
            let functions = &*(*env).functions();
            let logger = functions.logger.unwrap();
            logger(functions.componentEnvironment, c"inst".as_ptr(), fmi2Status::fmi2Error, c"logStatusError".as_ptr(), format.as_ptr(), arg.as_ptr(), number);
        }
    }

    #[test]
    fn shim_formats_variadic_arguments() {
        let env = Environment::into_raw(None);
        log_through_shim(env, c"%s = %d is out of range", c"duty", 3);
        // SAFETY: `env` is live until freed below and nothing else uses it.
        let got = unsafe { (*env).take() };
        // SAFETY: freed once, no FMU holds it.
        unsafe { Environment::free(env) };
        assert_eq!(got, vec![LogMessage { instance_name: "inst".into(), status: Status::Error, category: "logStatusError".into(), message: "duty = 3 is out of range".into() }]);
    }

    #[test]
    fn shim_handles_messages_longer_than_its_stack_buffer() {
        let long = "x".repeat(5000);
        let arg = std::ffi::CString::new(long.clone()).unwrap();
        let env = Environment::into_raw(None);
        log_through_shim(env, c"<%s|%d>", &arg, 7);
        // SAFETY: as above.
        let got = unsafe { (*env).take() };
        // SAFETY: as above.
        unsafe { Environment::free(env) };
        assert_eq!(got[0].message, format!("<{long}|7>"));
    }

    #[test]
    fn marks_select_the_messages_of_one_call_and_callback_sees_all() {
        let seen = Arc::new(AtomicUsize::new(0));
        let counter = Arc::clone(&seen);
        let env = Environment::into_raw(Some(Box::new(move |_: &LogMessage| {
            counter.fetch_add(1, Ordering::SeqCst);
        })));
        log_through_shim(env, c"first %s %d", c"a", 1);
        // SAFETY: as above.
        let mark = unsafe { (*env).mark() };
        log_through_shim(env, c"second %s %d", c"b", 2);
        // SAFETY: as above.
        let (since, all) = unsafe { ((*env).since(mark), (*env).take()) };
        // SAFETY: as above.
        unsafe { Environment::free(env) };
        assert_eq!(since.len(), 1);
        assert_eq!(since[0].message, "second b 2");
        assert_eq!(all.len(), 2);
        assert_eq!(seen.load(Ordering::SeqCst), 2);
    }

    #[test]
    fn a_panicking_callback_does_not_unwind_into_c() {
        let env = Environment::into_raw(Some(Box::new(|_: &LogMessage| panic!("user callback bug"))));
        log_through_shim(env, c"%s %d", c"still", 1);
        // SAFETY: as above.
        let got = unsafe { (*env).take() };
        // SAFETY: as above.
        unsafe { Environment::free(env) };
        assert_eq!(got[0].message, "still 1");
    }

    #[test]
    fn null_environment_and_null_message_are_harmless() {
        // SAFETY: the shim accepts a null environment and drops the message.
        unsafe {
            fmi2_import_logger(ptr::null_mut(), ptr::null(), fmi2Status::fmi2OK, ptr::null(), ptr::null());
        }
        let env = Environment::into_raw(None);
        // SAFETY: a null format is passed through as an empty message.
        unsafe {
            fmi2_import_logger(env.cast(), ptr::null(), fmi2Status::fmi2Warning, ptr::null(), ptr::null());
        }
        // SAFETY: as above.
        let got = unsafe { (*env).take() };
        // SAFETY: as above.
        unsafe { Environment::free(env) };
        assert_eq!(got[0].message, "");
        assert_eq!(got[0].status, Status::Warning);
    }
}
