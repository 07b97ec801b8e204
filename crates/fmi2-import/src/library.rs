//! Loading an FMU binary and resolving its `fmi2*` functions into typed pointers; loading
//! libpython for pythonfmu FMUs.
use std::ffi::{CStr, c_char};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};

use fmi2_sys::*;
use libloading::os::unix::{Library as UnixLibrary, RTLD_GLOBAL, RTLD_LOCAL, RTLD_NOW};

use crate::{ImportError, python};

/// `Option<fn>` → `fn`: the function type inside an `fmi2…TYPE` alias.
pub(crate) trait FnPtr {
    type Inner;
}

impl<T> FnPtr for Option<T> {
    type Inner = T;
}

macro_rules! functions {
    (
        required { $($field:ident: $ty:ident = $symbol:literal,)* }
        optional { $($ofield:ident: $oty:ident = $osymbol:literal,)* }
    ) => {
        /// The FMU's functions; valid only while the [`Library`] they came from is loaded.
        pub(crate) struct Functions {
            $(pub(crate) $field: <$ty as FnPtr>::Inner,)*
            $(pub(crate) $ofield: $oty,)*
        }

        impl Functions {
            fn resolve(lib: &libloading::Library, path: &Path) -> Result<Self, ImportError> {
                Ok(Self {
                    $($field: {
                        // SAFETY: an FMI 2.0 binary exports this symbol with the signature of
                        // the official header's typedef; a null address reads as `None`.
                        let f: $ty = unsafe { lib.get::<$ty>($symbol) }.ok().and_then(|s| *s);
                        f.ok_or_else(|| ImportError::MissingSymbol { path: path.to_path_buf(), symbol: $symbol })?
                    },)*
                    $($ofield: {
                        // SAFETY: as above; absence is allowed.
                        unsafe { lib.get::<$oty>($osymbol) }.ok().and_then(|s| *s)
                    },)*
                })
            }
        }
    };
}

functions! {
    required {
        get_types_platform: fmi2GetTypesPlatformTYPE = "fmi2GetTypesPlatform",
        get_version: fmi2GetVersionTYPE = "fmi2GetVersion",
        instantiate: fmi2InstantiateTYPE = "fmi2Instantiate",
        free_instance: fmi2FreeInstanceTYPE = "fmi2FreeInstance",
        setup_experiment: fmi2SetupExperimentTYPE = "fmi2SetupExperiment",
        enter_initialization_mode: fmi2EnterInitializationModeTYPE = "fmi2EnterInitializationMode",
        exit_initialization_mode: fmi2ExitInitializationModeTYPE = "fmi2ExitInitializationMode",
        terminate: fmi2TerminateTYPE = "fmi2Terminate",
        reset: fmi2ResetTYPE = "fmi2Reset",
        get_real: fmi2GetRealTYPE = "fmi2GetReal",
        get_integer: fmi2GetIntegerTYPE = "fmi2GetInteger",
        get_boolean: fmi2GetBooleanTYPE = "fmi2GetBoolean",
        set_real: fmi2SetRealTYPE = "fmi2SetReal",
        set_integer: fmi2SetIntegerTYPE = "fmi2SetInteger",
        set_boolean: fmi2SetBooleanTYPE = "fmi2SetBoolean",
        do_step: fmi2DoStepTYPE = "fmi2DoStep",
    }
    optional {
        set_debug_logging: fmi2SetDebugLoggingTYPE = "fmi2SetDebugLogging",
        get_fmu_state: fmi2GetFMUstateTYPE = "fmi2GetFMUstate",
        set_fmu_state: fmi2SetFMUstateTYPE = "fmi2SetFMUstate",
        free_fmu_state: fmi2FreeFMUstateTYPE = "fmi2FreeFMUstate",
        // Required by the standard, but the importer needs them only for String variables.
        get_string: fmi2GetStringTYPE = "fmi2GetString",
        set_string: fmi2SetStringTYPE = "fmi2SetString",
        get_real_status: fmi2GetRealStatusTYPE = "fmi2GetRealStatus",
        get_boolean_status: fmi2GetBooleanStatusTYPE = "fmi2GetBooleanStatus",
    }
}

/// A loaded FMU binary with its resolved functions.
pub(crate) struct Library {
    /// Copies of addresses inside `_lib`; declared first so nothing can outlive the unload.
    pub(crate) functions: Functions,
    _lib: libloading::Library,
}

impl Library {
    /// Loads `path` (after libpython when `python` is set) and checks version and platform.
    ///
    /// `RTLD_NOW` makes an unresolvable dependency an error here instead of an abort in the
    /// middle of a call; `RTLD_LOCAL` keeps two FMUs' identically named `fmi2*` apart.
    pub(crate) fn load(path: &Path, python: bool) -> Result<Self, ImportError> {
        if !path.is_file() {
            return Err(ImportError::MissingBinary { path: path.to_path_buf() });
        }
        if python {
            libpython()?;
        }
        // SAFETY: loading runs the binary's initialisers, which an FMU keeps side-effect free
        // apart from its own globals; this is the trust every FMU importer extends.
        let lib = unsafe { UnixLibrary::open(Some(path), RTLD_NOW | RTLD_LOCAL) }.map_err(|source| ImportError::Load { path: path.to_path_buf(), source })?;
        let lib = libloading::Library::from(lib);
        let functions = Functions::resolve(&lib, path)?;
        let incompatible = |function, found: String, expected| ImportError::Incompatible { path: path.to_path_buf(), function, found, expected };
        // SAFETY: `fmi2GetVersion` takes no arguments and returns a static string (or null).
        let version = unsafe { returned_str((functions.get_version)()) };
        if version != "2.0" {
            return Err(incompatible("fmi2GetVersion", version, "2.0"));
        }
        // SAFETY: as for `fmi2GetVersion`.
        let platform = unsafe { returned_str((functions.get_types_platform)()) };
        if platform != "default" {
            return Err(incompatible("fmi2GetTypesPlatform", platform, "default"));
        }
        Ok(Self { functions, _lib: lib })
    }
}

/// Copies a string the FMU returned.
///
/// # Safety
/// `s` is null or NUL-terminated and valid for the duration of the call.
unsafe fn returned_str(s: *const c_char) -> String {
    if s.is_null() {
        return "(null)".to_owned();
    }
    // SAFETY: non-null and NUL-terminated by the caller's contract.
    unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned()
}

/// The libpython loaded for pythonfmu FMUs, with its path. It is never unloaded: an
/// initialised interpreter cannot safely leave the process, and all pythonfmu instances share it.
static LIBPYTHON: Mutex<Option<(PathBuf, &'static UnixLibrary)>> = Mutex::new(None);

/// Loads libpython with `RTLD_GLOBAL` once per process, trying [`python::libpython_candidates`];
/// returns the path it was loaded from.
pub(crate) fn libpython() -> Result<PathBuf, ImportError> {
    let mut slot = LIBPYTHON.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some((path, _)) = slot.as_ref() {
        return Ok(path.clone());
    }
    let mut tried = Vec::new();
    for candidate in python::libpython_candidates() {
        // SAFETY: libpython's initialisers only set up its own globals; the interpreter is
        // started later by the pythonfmu binary.
        match unsafe { UnixLibrary::open(Some(&candidate), RTLD_NOW | RTLD_GLOBAL) } {
            Ok(lib) => {
                *slot = Some((candidate.clone(), Box::leak(Box::new(lib))));
                return Ok(candidate);
            }
            Err(e) => tried.push(format!("{} ({e})", candidate.display())),
        }
    }
    Err(ImportError::LibPython { tried: tried.join("; ") })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn missing_binary_names_the_path() {
        let err = Library::load(Path::new("/nonexistent/binaries/linux64/M.so"), false).err().unwrap();
        assert!(err.to_string().contains("/nonexistent/binaries/linux64/M.so"), "{err}");
    }

    #[test]
    fn a_non_fmu_library_names_the_first_missing_function() {
        // libm is on every glibc system; it exports no fmi2 function.
        let Some(libm) = ["/lib/x86_64-linux-gnu/libm.so.6", "/usr/lib/x86_64-linux-gnu/libm.so.6", "/lib64/libm.so.6"].into_iter().map(Path::new).find(|p| p.is_file()) else {
            return;
        };
        let err = Library::load(libm, false).err().unwrap();
        assert!(matches!(err, ImportError::MissingSymbol { symbol: "fmi2GetTypesPlatform", .. }), "{err}");
    }

    #[test]
    fn libpython_loads_or_explains() {
        match libpython() {
            Ok(path) => assert!(path.to_string_lossy().contains("libpython"), "{}", path.display()),
            Err(e) => assert!(e.to_string().contains(crate::LIBPYTHON_ENV), "{e}"),
        }
    }
}
