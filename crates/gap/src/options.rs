//! What a diagnosis compares the data with and how: the nominal model and the settings.
use buck_model::Params;
use estimator::data::DataSet;
use estimator::identify::{IdentifyOptions, identify};
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

/// How a data set's switching shows, for choosing its nominal model ([`nominal_for`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwitchingEvidence {
    /// The averaged model's held-out residual RMS (Cl and the series resistance free), in
    /// noise floors (`NaN` where the model or the floor could not be had).
    pub averaged_floors: f64,
    /// How much of the ripple the switched circuit adds to the averaged model's fit the data
    /// holds: the least-squares coefficient of that difference in the averaged model's held-out
    /// residual (1: switched data, 0: averaged; `NaN` where a model could not be run).
    pub ripple_share: f64,
    /// The model the data calls for.
    pub nominal: Nominal,
}

/// The averaged model's residual, in noise floors, within which it describes the data.
const AVERAGED_FITS_FLOORS: f64 = 2.0;

/// The nominal model the data calls for when the user names none. Samples of a switching
/// converter call for the switched model: only it holds the ripple the sampling catches and the
/// effects of the switching (a dead time, a diode, the node's charge). The averaged one is taken
/// only where the data is averaged (a model run in averaged mode, a third-party LTI model): its
/// fit (Cl and the series resistance free) leaves the held-out residual within two noise floors,
/// and the ripple the switched circuit adds to it (the switched circuit run with the averaged
/// fit's values, less that fit) is not in the residual (its least-squares share not above one
/// half by more than its 99 % point). A diode buck in DCM, a 5 V converter's dead time or a
/// 1 MHz point-of-load's missed by volts, which hide the ripple's millivolts, are switched.
pub fn nominal_for(data: &DataSet, nominal: &Params, holdout: f64) -> SwitchingEvidence {
    // Measured inputs by their levels: whether the data shows its switching is no question of
    // their noise.
    let data = &estimator::inputs::average_measured(data).0;
    let switched = |averaged_floors: f64, ripple_share: f64| SwitchingEvidence { averaged_floors, ripple_share, nominal: Nominal::Switched };
    let opts = IdentifyOptions { structures: vec![Structure::Averaged], free: vec![Free::Cl, Free::RL], holdout, ..IdentifyOptions::default() };
    let (Ok(id), Some((floor, _))) = (identify(data, nominal, &opts), estimator::noise::noise_floor_estimate(data)) else { return switched(f64::NAN, f64::NAN) };
    let avg = id.best();
    let r = crate::effect::residual(avg);
    let averaged_floors = crate::effect::rms(&r) / floor;
    let Ok(run) = estimator::simulated::simulate(&avg.fit.params, data, data.vout[0]) else { return switched(averaged_floors, f64::NAN) };
    let g: Vec<f64> = run[data.len() - r.len()..].iter().zip(&avg.validation.traces.simulated).map(|(s, a)| s - a).collect();
    let gg: f64 = g.iter().map(|x| x * x).sum();
    let ripple_share = g.iter().zip(&r).map(|(a, b)| a * b).sum::<f64>() / gg;
    let sd = floor / gg.sqrt();
    // Not finite (no ripple to seek: a switched run equal to the averaged one) holds nothing.
    let holds = ripple_share.is_finite() && ripple_share - 0.5 > estimator::validate::Z_99 * sd;
    if averaged_floors <= AVERAGED_FITS_FLOORS && !holds { SwitchingEvidence { averaged_floors, ripple_share, nominal: Nominal::Averaged } } else { switched(averaged_floors, ripple_share) }
}

/// The nominal model with Cl free.
pub(crate) fn nominal_options(opts: &DiagnoseOptions) -> IdentifyOptions {
    let structure = match opts.nominal {
        Nominal::Averaged => Structure::Averaged,
        Nominal::Switched => Structure::Pwm,
    };
    IdentifyOptions { structures: vec![structure], free: vec![Free::Cl], holdout: opts.holdout, ..IdentifyOptions::default() }
}
