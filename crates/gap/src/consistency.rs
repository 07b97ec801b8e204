//! Whether Cl's interval can be trusted: a Hausman test between two criteria.
//!
//! Cl's CI95 from a fit is conditional on the model: when an effect is still missing or only
//! approximated (a Schottky diode fitted as a constant drop, MOSFET body diodes fitted as ideal
//! dead time), Cl is biased by many of its standard deviations, and the interval says nothing
//! about it. The residual cannot show that bias: at the optimum the model error that Cl absorbed
//! has been fitted away.
//!
//! What the data can show is whether two estimators that agree when the model is right agree
//! here. The final model is refitted with the plant simulator through the high-pass criterion
//! ([`Criterion::Differenced`], which weights the fast dynamics where a small Cl shows and
//! ignores DC) with the same parameters free. Under a right model both are consistent and the
//! output-error fit is efficient, so `(ln Cl₁ − ln Cl₂)² / (var₂ − var₁)` is χ²₁ (Hausman).
//! When it exceeds the 99 % point the model error moves Cl by about the distance `d` between
//! the two estimates, and no weighting is free of it: the reported CI95 becomes the hull of both
//! intervals widened by `d` on each side (a type-B term in the metrologist's sense). Wider,
//! and honest about what the model can tell.
//!
//! Output-error is the efficient criterion only near its own optimum: a fit that settled where
//! Cl barely shows in the sampled output (a late reading with a small Cl) can leave it
//! unidentified while the high-pass refit pins it down. Of two fits that agree, the more
//! precise is reported.
use buck_model::Params;
use estimator::data::DataSet;
use estimator::simulated::{Criterion, fit_with};
use estimator::validate::{Z_975, chi2_99};

use crate::effect::{ClCheck, EffectFit, log_width};
use crate::select::Stack;

/// Standard deviation of `ln Cl` from a CI95 of the log-normal approximation.
fn log_sd(ci95: [f64; 2]) -> f64 {
    log_width(ci95) / (2.0 * Z_975)
}

/// Tests Cl's interval `model_ci95` around `cl` of the final model (the nominal with `effects`)
/// on switched data.
pub(crate) fn check(data: &DataSet, nominal: &Params, effects: &[&EffectFit], cl: f64, model_ci95: [f64; 2], n_est: usize) -> Result<ClCheck, String> {
    let model = Stack::of(effects, nominal, cl, true)?;
    // The reading's calibration shows in its DC, which the high-pass view ignores: held at the
    // output-error fit's values.
    let free: Vec<_> = model.free.iter().copied().filter(|f| !f.calibrates_reading()).collect();
    let cand = fit_with(&model.data(data), &model.params, &free, n_est, Criterion::Differenced).map_err(|e| e.to_string())?;
    let hp = cand.fit.estimate("Cl").ok_or("the high-pass fit has no Cl")?;
    let high_pass_ci95 = [hp.ci95.0, hp.ci95.1];
    let (sd_model, sd_hp) = (log_sd(model_ci95), hp.rel_std);
    // Hausman: the efficient estimator's variance comes off the other's; a difference at or
    // below zero (the two nearly equally efficient, up to the finite-difference Jacobian) is
    // replaced by the sum, which can only make the test milder.
    let var = match sd_hp.powi(2) - sd_model.powi(2) {
        v if v > 0.0 => v,
        _ => sd_hp.powi(2) + sd_model.powi(2),
    };
    let hausman = (cl.ln() - hp.value.ln()).powi(2) / var;
    Ok(ClCheck::new(cl, model_ci95, hp.value, high_pass_ci95, hausman, chi2_99(1)))
}
