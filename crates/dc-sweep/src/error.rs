//! The one error type of the crate.

/// What went wrong reading a sweep or solving its model.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SweepError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The sweep file breaks the contract (the message names the line and column).
    #[error("{0}")]
    Data(String),
    /// An operating point or circuit value the DC model cannot solve (the message says which).
    #[error("{0}")]
    Model(String),
}

pub(crate) fn data_err(msg: impl Into<String>) -> SweepError {
    SweepError::Data(msg.into())
}

pub(crate) fn model_err(msg: impl Into<String>) -> SweepError {
    SweepError::Model(msg.into())
}
