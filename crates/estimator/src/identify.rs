//! The whole identification: split the data, fit one or several model structures on the
//! estimation part, validate on the held-out part, pick the structure that predicts the
//! held-out data best.
use std::time::Instant;

use buck_model::Params;

use crate::data::DataSet;
use crate::error::EstimatorError;
use crate::model::{Free, Model, Sampling, Signal, Structure};
use crate::pem::{self, Fit, FitOptions, NoiseModel};
use crate::validate::{ResidualTests, fit_percent};

pub use crate::candidate::{Candidate, Traces, Validation};

/// What to identify and how.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifyOptions {
    /// Structures to try; the one with the best held-out one-step prediction wins.
    pub structures: Vec<Structure>,
    /// Output sampling.
    pub sampling: Sampling,
    /// Outputs to fit (`il` is used only where the data has it).
    pub outputs: Vec<Signal>,
    /// Free parameters.
    pub free: Vec<Free>,
    /// Disturbance model.
    pub noise: NoiseModel,
    /// Start value of `Cl` [F] (`None`: grid search).
    pub cl_guess: Option<f64>,
    /// Fraction of the samples, at the end, held out for validation.
    pub holdout: f64,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        Self {
            structures: vec![Structure::Averaged, Structure::Pwm],
            sampling: Sampling::PeriodStart,
            outputs: vec![Signal::Vout],
            free: vec![Free::Cl],
            noise: NoiseModel::OutputError,
            cl_guess: None,
            holdout: 1.0 / 3.0,
        }
    }
}

/// Result of [`identify`].
#[derive(Debug, Clone)]
pub struct Identification {
    /// Every structure tried, best first.
    pub candidates: Vec<Candidate>,
    /// Samples used for estimation.
    pub estimation_samples: usize,
    /// Samples held out for validation.
    pub validation_samples: usize,
    /// Outputs that were fitted.
    pub outputs: Vec<Signal>,
}

impl Identification {
    /// The chosen structure's result.
    pub fn best(&self) -> &Candidate {
        &self.candidates[0]
    }
}

/// Identifies `opts.free` from `data`, with `nominal` holding the known circuit values
/// (including the load resistor: take `rload` from [`DataSet::rload`] as the CLI does).
///
/// ```
/// use buck_model::{Mode, Params};
/// use estimator::experiment::{run, Experiment, ModelPlant};
/// use estimator::identify::{identify, IdentifyOptions};
///
/// let truth = Params { cl: 2.2e-6, ..Params::default() };
/// let data = run(&mut ModelPlant::new(truth, Mode::Switched), &Experiment { noise_vout: 2e-3, ..Experiment::default() }).unwrap();
/// let id = identify(&data, &Params::default(), &IdentifyOptions::default()).unwrap();
/// assert_eq!(id.best().structure.name(), "pwm"); // the ripple-exact model wins on switched data
/// let cl = id.best().fit.estimate("Cl").unwrap();
/// assert!(cl.ci95.0 < 2.2e-6 && 2.2e-6 < cl.ci95.1);
/// ```
pub fn identify(data: &DataSet, nominal: &Params, opts: &IdentifyOptions) -> Result<Identification, EstimatorError> {
    data.validate()?;
    if !(opts.holdout > 0.0 && opts.holdout < 0.9) {
        return Err(EstimatorError::Config(format!("hold-out fraction {} must be in (0, 0.9)", opts.holdout)));
    }
    if opts.structures.is_empty() {
        return Err(EstimatorError::Config("no model structure to fit".into()));
    }
    let n = data.len();
    let n_est = ((n as f64) * (1.0 - opts.holdout)).round() as usize;
    if n_est < 50 || n - n_est < 20 {
        return Err(EstimatorError::Data(format!("{n} samples are too few to estimate and validate (need ≥ 50 + 20)")));
    }
    let constant = |v: &[f64]| v[..n_est].iter().all(|x| *x == v[0]);
    if constant(&data.duty) && constant(&data.io) && constant(&data.vin) {
        return Err(EstimatorError::Data("no excitation: duty, io and vin are constant over the estimation part, so the data cannot tell Cl (step the duty, e.g. a PRBS)".into()));
    }
    let period = data.sample_period();
    let estimation = data.slice(0..n_est);
    let outputs: Vec<Signal> = opts
        .outputs
        .iter()
        .copied()
        .filter(|s| {
            *s == Signal::Vout
                || match opts.sampling {
                    Sampling::PeriodStart => data.il.is_some(),
                    Sampling::PeriodAverage => data.il_avg.is_some(),
                }
        })
        .collect();
    let mut candidates = Vec::new();
    for &structure in &opts.structures {
        if structure == Structure::Simulated {
            let mut start = *nominal;
            if let Some(cl) = opts.cl_guess {
                start.cl = cl;
            }
            candidates.push(crate::simulated::fit(data, &start, &opts.free, n_est)?);
            continue;
        }
        let outs: Vec<Signal> = if structure == Structure::Reduced { vec![Signal::Vout] } else { outputs.clone() };
        let model = Model::new(structure, opts.sampling, &outs, &opts.free, &estimation, period)?;
        let guess = opts.cl_guess.map(|cl| opts.free.iter().map(|f| if *f == Free::Cl { cl } else { f.get(nominal) }).collect());
        let start = Instant::now();
        let fit = pem::fit(&model, nominal, &FitOptions { noise: opts.noise, guess, ..FitOptions::default() })?;
        let seconds = start.elapsed().as_secs_f64();
        let whole = Model::new(structure, opts.sampling, &outs, &opts.free, data, period)?;
        let validation = validate(&whole, &fit, data, n_est);
        candidates.push(Candidate { structure, fit, validation, seconds });
    }
    candidates.sort_by(|a, b| {
        let score = |c: &Candidate| -c.validation.fit_prediction[0];
        score(a).total_cmp(&score(b))
    });
    Ok(Identification { candidates, estimation_samples: n_est, validation_samples: n - n_est, outputs })
}

/// Runs the fitted model over all samples (so the held-out part starts from the state the
/// model reached, nothing re-estimated) and scores the held-out part.
fn validate(whole: &Model, fit: &Fit, data: &DataSet, n_est: usize) -> Validation {
    let ny = whole.ny();
    let sim = pem::outputs(whole, &fit.params, &fit.x0, None);
    let pred = pem::outputs(whole, &fit.params, &fit.x0, Some(&fit.gain));
    let column = |v: &[f64], o: usize| -> Vec<f64> { v.iter().skip(n_est * ny + o).step_by(ny).copied().collect() };
    let mut fit_simulation = Vec::new();
    let mut fit_prediction = Vec::new();
    for o in 0..ny {
        let y = column(&whole.y, o);
        fit_simulation.push(fit_percent(&y, &column(&sim, o)));
        fit_prediction.push(fit_percent(&y, &column(&pred, o)));
    }
    let measured = column(&whole.y, 0);
    let predicted = column(&pred, 0);
    let residual: Vec<f64> = measured.iter().zip(&predicted).map(|(a, b)| a - b).collect();
    Validation {
        fit_simulation,
        fit_prediction,
        residuals: ResidualTests::new(&residual, &data.duty[n_est..]),
        traces: Traces { time: data.time[n_est..].to_vec(), measured, simulated: column(&sim, 0), predicted },
    }
}
