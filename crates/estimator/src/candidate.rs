//! One fitted structure and its held-out validation: what [`crate::identify`] compares and
//! the fits of every structure (grey-box, [`crate::simulated`]) return.
use crate::model::Structure;
use crate::pem::Fit;
use crate::validate::ResidualTests;

/// Held-out validation of one fitted structure.
#[derive(Debug, Clone)]
pub struct Validation {
    /// Fit [%] of the free-run simulation, per output.
    pub fit_simulation: Vec<f64>,
    /// Fit [%] of the one-step prediction, per output.
    pub fit_prediction: Vec<f64>,
    /// Residual tests of the one-step prediction error of the first output.
    pub residuals: ResidualTests,
    /// Measured, simulated and predicted first output over the held-out samples.
    pub traces: Traces,
}

/// Signals for plots, over the held-out samples.
#[derive(Debug, Clone, Default)]
pub struct Traces {
    /// Sample times \[s\].
    pub time: Vec<f64>,
    /// Measured first output.
    pub measured: Vec<f64>,
    /// Simulated first output.
    pub simulated: Vec<f64>,
    /// One-step predicted first output.
    pub predicted: Vec<f64>,
}

/// One structure's result.
#[derive(Debug, Clone)]
pub struct Candidate {
    /// The structure.
    pub structure: Structure,
    /// Its fit on the estimation data.
    pub fit: Fit,
    /// Its validation on the held-out data.
    pub validation: Validation,
    /// Wall time of the fit alone \[s\].
    pub seconds: f64,
}
