use thiserror::Error;

/// Why a value or a call was rejected by the model.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum ModelError {
    /// A variable was given a value outside its declared range (or NaN).
    #[error("{name} = {value} is out of range: must be {range}")]
    OutOfRange {
        /// Variable name as in the variable table.
        name: &'static str,
        /// The rejected value.
        value: f64,
        /// Human-readable allowed range.
        range: String,
    },
    /// No variable has this value reference (or it has another type).
    #[error("no {kind} variable has value reference {vr}")]
    UnknownReference {
        /// The value reference asked for.
        vr: u32,
        /// The FMI base type that was asked for.
        kind: &'static str,
    },
    /// The variable exists but may not be set now (e.g. a fixed parameter after initialization,
    /// or an output).
    #[error("{name} cannot be set {when}")]
    NotSettable {
        /// Variable name.
        name: &'static str,
        /// When or why not.
        when: &'static str,
    },
    /// A step of non-positive or non-finite length was asked for.
    #[error("step size {0} must be positive and finite")]
    BadStep(f64),
    /// A saved state could not be decoded.
    #[error("cannot restore state: {0}")]
    BadState(String),
}
