//! How large an effect could be and still hide in the data: one-sided 95 % upper limits of the
//! effects whose magnitude enters smoothly from zero.
//!
//! Around zero the output is linear in the magnitude `θ`: `y ≈ y₀ + s_θ·θ + s_Cl·δ ln Cl`, with
//! sensitivities from finite differences of the plant simulator. The least-squares `θ` of the
//! nominal residual on `[s_Cl, s_θ]` (Cl's share projected out) and its standard deviation
//! `σ·√[(AᵀA)⁻¹]_θθ` give the limit `max(θ̂, 0) + 1.645·sd`. (A CI95 from the nonlinear fit in
//! `ln θ` cannot serve: around an estimate near zero it collapses onto it.)
use std::collections::BTreeMap;

use buck_model::Params;
use estimator::data::DataSet;
use estimator::model::Free;
use estimator::simulated::{BURN_IN, simulate};
use estimator::validate::Z_95;
use nalgebra::{DMatrix, DVector};

/// The effects linear at zero, with the magnitude of the finite-difference probe (small against
/// the design table's range, large against rounding).
const LINEAR_AT_ZERO: [(&str, Free, f64); 7] = [
    ("dead_time", Free::DeadTime, 2e-9),
    ("pulse_width_distortion", Free::PulseWidthDistortion, 2e-9),
    ("load_esr", Free::LoadEsr, 2e-3),
    ("esl", Free::Esl, 0.1e-9),
    ("cap_dc_bias", Free::CapDcBias, 0.02),
    ("sample_delay", Free::SampleDelay, 2e-9),
    ("sensor_filter", Free::VoutFilter, 2e-9),
];

/// Upper limits by effect name, on the first `n_est` samples of `data`, for the circuit
/// `nominal` (Cl as fitted) with sensor noise `sigma` \[V\]; effects whose simulation fails are
/// left out.
pub(crate) fn upper_limits(data: &DataSet, nominal: &Params, sigma: f64, n_est: usize) -> BTreeMap<&'static str, f64> {
    let estimation = data.slice(0..n_est);
    let v0 = data.vout[0];
    let window = |y: Vec<f64>| DVector::from_vec(y[BURN_IN.min(y.len())..].to_vec());
    let run = |p: &Params| simulate(p, &estimation, v0).ok().map(window);
    let mut limits = BTreeMap::new();
    let Some(base) = run(nominal) else { return limits };
    let Some(s_cl) = run(&Params { cl: nominal.cl * 1.001, ..*nominal }).map(|y| (y - &base) / 1.001f64.ln()) else { return limits };
    let residual = window(estimation.vout.clone()) - &base;
    for (name, free, probe) in LINEAR_AT_ZERO {
        let mut p = *nominal;
        free.set(&mut p, probe);
        let Some(s) = run(&p).map(|y| (y - &base) / probe) else { continue };
        let a = DMatrix::from_columns(&[s_cl.clone(), s]);
        let Some(inv) = (a.transpose() * &a).try_inverse() else { continue };
        let theta = (&inv * a.transpose() * &residual)[1];
        let sd = sigma * inv[(1, 1)].max(0.0).sqrt();
        if sd.is_finite() {
            limits.insert(name, theta.max(0.0) + Z_95 * sd);
        }
    }
    limits
}
