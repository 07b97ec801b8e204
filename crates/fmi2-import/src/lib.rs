//! Load any FMI 2.0 Co-Simulation FMU and drive it through a safe [`Instance`].
//!
//! [`Fmu::open`] unzips the archive into a private temporary folder and reads
//! `modelDescription.xml` (no binary needed for that); [`Fmu::instantiate`] loads
//! `binaries/linux64/<modelIdentifier>.so`, checks it and creates an instance. Every call that
//! returns a bad status becomes an [`ImportError::Call`] naming the function, the status and what
//! the FMU logged during that call.
//!
//! ```no_run
//! use fmi2_import::Fmu;
//!
//! let fmu = Fmu::open("fmu/BuckConverter.fmu")?;
//! let (duty, _) = fmu.value_reference("duty")?;
//! let (vout, _) = fmu.value_reference("vout")?;
//! let mut inst = fmu.instantiate("buck")?;
//! inst.setup_experiment(0.0, None)?;
//! inst.enter_initialization_mode()?;
//! inst.set_real(&[duty], &[0.5])?;
//! inst.exit_initialization_mode()?;
//! inst.do_step(0.0, 1e-5)?;
//! let mut y = [0.0];
//! inst.get_real(&[vout], &mut y)?;
//! # Ok::<(), fmi2_import::ImportError>(())
//! ```
//!
//! Only this crate's FFI files (`callbacks.rs`, `library.rs`, `instance.rs`) may use `unsafe`.
#![deny(unsafe_code)]
#![deny(unsafe_op_in_unsafe_fn)]

mod archive;
#[allow(unsafe_code)]
mod callbacks;
mod fmu;
#[allow(unsafe_code)]
mod instance;
#[allow(unsafe_code)]
mod library;
mod python;
pub mod simulate;
mod value;

use std::fmt;
use std::path::PathBuf;

pub use archive::{MAX_ENTRIES, MAX_TOTAL_SIZE};
pub use callbacks::{LogCallback, LogMessage};
pub use fmi2_schema as schema;
pub use fmu::{Fmu, InstantiateOptions, MAX_MODEL_DESCRIPTION_SIZE, VarKind};
pub use instance::{FmuState, Instance};
pub use python::LIBPYTHON_ENV;
pub use value::{Value, Variable};

/// Everything that can go wrong while opening, loading or driving an FMU.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImportError {
    /// A file or folder could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file is not a readable zip archive.
    #[error("{path} is not a valid FMU (zip) archive: {source}")]
    Zip {
        /// The archive.
        path: PathBuf,
        /// The zip error.
        source: zip::result::ZipError,
    },
    /// An archive entry would land outside the extraction folder (`../x`, `/etc/x`).
    #[error("FMU archive entry {entry:?} escapes the extraction folder; refusing to extract")]
    UnsafeEntry {
        /// The entry name as stored in the archive.
        entry: String,
    },
    /// The archive exceeds [`MAX_ENTRIES`] or [`MAX_TOTAL_SIZE`], or its description
    /// [`MAX_MODEL_DESCRIPTION_SIZE`].
    #[error("FMU archive {path} is too large to extract: {reason}")]
    TooLarge {
        /// The archive.
        path: PathBuf,
        /// Which limit was hit.
        reason: String,
    },
    /// The `modelIdentifier` cannot name a binary inside the FMU (empty, `..`, a `/`).
    #[error("{path}: modelIdentifier {identifier:?} is not a plain file name; refusing to load a binary from it")]
    BadModelIdentifier {
        /// The model description.
        path: PathBuf,
        /// The declared identifier.
        identifier: String,
    },
    /// The FMU has no `modelDescription.xml` at its root.
    #[error("{path} does not exist: the FMU has no modelDescription.xml at its root")]
    MissingModelDescription {
        /// Where it was expected.
        path: PathBuf,
    },
    /// `modelDescription.xml` is malformed.
    #[error("{path}: {source}")]
    ModelDescription {
        /// The file.
        path: PathBuf,
        /// The parse error.
        source: fmi2_schema::SchemaError,
    },
    /// `fmiVersion` is not `2.0`.
    #[error("{path}: fmiVersion is {found:?}; only FMI 2.0 is supported")]
    UnsupportedFmiVersion {
        /// The model description.
        path: PathBuf,
        /// The declared version.
        found: String,
    },
    /// The model description declares no `CoSimulation` element.
    #[error("{path}: no CoSimulation element; only Co-Simulation FMUs can be imported")]
    NotCoSimulation {
        /// The model description.
        path: PathBuf,
    },
    /// The FMU has no binary for this platform.
    #[error("FMU binary {path} does not exist (the FMU has no binary for this platform)")]
    MissingBinary {
        /// Where it was expected.
        path: PathBuf,
    },
    /// The dynamic loader rejected the binary.
    #[error("cannot load FMU binary {path}: {source}")]
    Load {
        /// The binary.
        path: PathBuf,
        /// The loader's error (`dlerror`).
        source: libloading::Error,
    },
    /// A required `fmi2*` function is not exported.
    #[error("FMU binary {path} does not export the required function {symbol}")]
    MissingSymbol {
        /// The binary.
        path: PathBuf,
        /// The function name.
        symbol: &'static str,
    },
    /// `fmi2GetVersion` or `fmi2GetTypesPlatform` returned something unexpected.
    #[error("FMU binary {path}: {function} returned {found:?}, expected {expected:?}")]
    Incompatible {
        /// The binary.
        path: PathBuf,
        /// `fmi2GetVersion` or `fmi2GetTypesPlatform`.
        function: &'static str,
        /// What the binary returned.
        found: String,
        /// What this importer supports.
        expected: &'static str,
    },
    /// A pythonfmu FMU needs libpython, which could not be loaded.
    #[error(
        "this is a pythonfmu FMU and needs libpython loaded first, but none could be loaded \
         (set {} to its path); tried: {tried}",
        LIBPYTHON_ENV
    )]
    LibPython {
        /// Every candidate with the loader's error.
        tried: String,
    },
    /// A string passed to the FMU contains a NUL byte.
    #[error("{what} {value:?} contains a NUL byte")]
    NulByte {
        /// What the string is.
        what: &'static str,
        /// The string.
        value: String,
    },
    /// The FMU can be instantiated only once per process and an instance is alive.
    #[error("the FMU declares canBeInstantiatedOnlyOncePerProcess and an instance of it is alive")]
    OnlyOncePerProcess,
    /// `fmi2Instantiate` returned null.
    #[error("fmi2Instantiate({instance:?}) returned null{}", log_suffix(log))]
    Instantiate {
        /// The instance name.
        instance: String,
        /// What the FMU logged while instantiating.
        log: Vec<LogMessage>,
    },
    /// An `fmi2*` call returned a status other than `fmi2OK`/`fmi2Warning`.
    #[error("{function} returned {status}{}", log_suffix(log))]
    Call {
        /// The FMI function.
        function: &'static str,
        /// The status it returned.
        status: Status,
        /// What the FMU logged during that call.
        log: Vec<LogMessage>,
    },
    /// Value references and values differ in length.
    #[error("{function}: {refs} value references but {values} values")]
    LengthMismatch {
        /// The FMI function.
        function: &'static str,
        /// Number of value references.
        refs: usize,
        /// Number of values.
        values: usize,
    },
    /// An optional FMI function is not available or not allowed.
    #[error("{function} is not available: {reason}")]
    Unsupported {
        /// The FMI function.
        function: &'static str,
        /// Why.
        reason: &'static str,
    },
    /// An earlier call returned `fmi2Fatal`; FMI forbids any further call.
    #[error("cannot call {function}: an earlier call returned fmi2Fatal and the instance is unusable")]
    Unusable {
        /// The refused FMI function.
        function: &'static str,
    },
    /// An [`FmuState`] was used with an instance that did not create it.
    #[error("{function}: this FMU state belongs to another instance")]
    ForeignState {
        /// The FMI function.
        function: &'static str,
    },
    /// A value does not fit its variable (type, range, NaN).
    #[error("variable `{name}`: {reason}")]
    BadValue {
        /// The variable.
        name: String,
        /// What is wrong with the value.
        reason: String,
    },
    /// Setting a variable failed.
    #[error("setting `{name}`: {source}")]
    Setting {
        /// The variable.
        name: String,
        /// The call's error.
        source: Box<ImportError>,
    },
    /// The simulation's time settings or input table cannot be run.
    #[error("{0}")]
    Simulation(String),
    /// No variable has this name.
    #[error("the FMU has no variable {name:?}; its variables are: {available}")]
    UnknownVariable {
        /// The name asked for.
        name: String,
        /// The FMU's variable names, comma-separated.
        available: String,
    },
}

fn log_suffix(log: &[LogMessage]) -> String {
    if log.is_empty() {
        " (the FMU logged nothing)".to_owned()
    } else {
        let lines: Vec<String> = log.iter().map(ToString::to_string).collect();
        format!("; the FMU logged: {}", lines.join(" | "))
    }
}

/// An `fmi2Status` as returned by the FMU.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Status {
    /// `fmi2OK`.
    Ok,
    /// `fmi2Warning`: the call succeeded, but something is questionable (see the log).
    Warning,
    /// `fmi2Discard`: e.g. `fmi2DoStep` did not complete the step.
    Discard,
    /// `fmi2Error`: the call failed; reset or free the instance before simulating on.
    Error,
    /// `fmi2Fatal`: every instance of the FMU is corrupted.
    Fatal,
    /// `fmi2Pending`: an asynchronous step is running.
    Pending,
    /// A value outside the FMI enumeration.
    Other(u32),
}

impl From<fmi2_sys::fmi2Status> for Status {
    fn from(s: fmi2_sys::fmi2Status) -> Self {
        match s.0 {
            0 => Self::Ok,
            1 => Self::Warning,
            2 => Self::Discard,
            3 => Self::Error,
            4 => Self::Fatal,
            5 => Self::Pending,
            other => Self::Other(other),
        }
    }
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Ok => f.write_str("fmi2OK"),
            Self::Warning => f.write_str("fmi2Warning"),
            Self::Discard => f.write_str("fmi2Discard"),
            Self::Error => f.write_str("fmi2Error"),
            Self::Fatal => f.write_str("fmi2Fatal"),
            Self::Pending => f.write_str("fmi2Pending"),
            Self::Other(n) => write!(f, "an invalid fmi2Status ({n})"),
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use fmi2_sys::fmi2Status;

    #[test]
    fn status_round_trips_and_names_fmi_spelling() {
        assert_eq!(Status::from(fmi2Status::fmi2OK), Status::Ok);
        assert_eq!(Status::from(fmi2Status::fmi2Fatal), Status::Fatal);
        assert_eq!(Status::from(fmi2Status(42)), Status::Other(42));
        assert_eq!(Status::Error.to_string(), "fmi2Error");
        assert_eq!(Status::Other(42).to_string(), "an invalid fmi2Status (42)");
    }

    #[test]
    fn call_error_lists_the_log() {
        let msg = LogMessage { instance_name: "a".into(), status: Status::Error, category: "logStatusError".into(), message: "duty = 1.5 is out of range".into() };
        let e = ImportError::Call { function: "fmi2SetReal", status: Status::Error, log: vec![msg] };
        let text = e.to_string();
        assert!(text.starts_with("fmi2SetReal returned fmi2Error; the FMU logged:"), "{text}");
        assert!(text.contains("duty = 1.5"), "{text}");
        let e = ImportError::Call { function: "fmi2DoStep", status: Status::Discard, log: vec![] };
        assert_eq!(e.to_string(), "fmi2DoStep returned fmi2Discard (the FMU logged nothing)");
    }
}
