//! What a diagnosis compares the data with and how: the nominal model and the settings.
use estimator::identify::IdentifyOptions;
use estimator::model::{Free, Structure};
use serde::Serialize;

/// The simulation model the data is compared with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Nominal {
    /// The averaged circuit (no switching ripple): `switching_ripple` is a candidate.
    #[default]
    Averaged,
    /// The ideal switched circuit sampled at period starts (the sampled-data PWM model): the
    /// ripple is part of the model, so `switching_ripple` is not a candidate.
    Switched,
}

/// Settings of a diagnosis.
#[derive(Debug, Clone, PartialEq)]
pub struct DiagnoseOptions {
    /// Fraction of the samples, at the end, held out for judging.
    pub holdout: f64,
    /// The nominal simulation model.
    pub nominal: Nominal,
    /// Relative tolerance of the nominal circuit values: a `param_drift` within it is
    /// consistent with the nominal, not a finding.
    pub tolerance: f64,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        Self { holdout: 1.0 / 3.0, nominal: Nominal::Averaged, tolerance: 0.01 }
    }
}

/// The nominal model with Cl free.
pub(crate) fn nominal_options(opts: &DiagnoseOptions) -> IdentifyOptions {
    let structure = match opts.nominal {
        Nominal::Averaged => Structure::Averaged,
        Nominal::Switched => Structure::Pwm,
    };
    IdentifyOptions { structures: vec![structure], free: vec![Free::Cl], holdout: opts.holdout, ..IdentifyOptions::default() }
}
