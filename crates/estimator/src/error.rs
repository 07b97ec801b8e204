use thiserror::Error;

/// Why an experiment, a data set or a fit failed.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum EstimatorError {
    /// The data file or data set is unusable; the message names the line or column.
    #[error("{0}")]
    Data(String),
    /// An experiment or fit setting is out of range.
    #[error("invalid setting: {0}")]
    Config(String),
    /// The plant refused an input or a step.
    #[error("plant: {0}")]
    Plant(String),
    /// The optimisation could not produce an estimate.
    #[error("fit failed: {0}")]
    Fit(String),
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
}

pub(crate) fn data_err(msg: impl Into<String>) -> EstimatorError {
    EstimatorError::Data(msg.into())
}
