//! The `adc_quantization` candidate: readings that lie on a lattice `offset + k·lsb`.
//!
//! Quantization is not a dynamic effect, so it is not fitted with Cl: it is detected in the
//! data (the readings take few distinct values, all on one lattice), and the model it extends is
//! judged with its simulation passed through the same quantizer. The quantizer's step is exact
//! from the data; the ADC's bits are reported for the design's 16 V full scale.
use std::collections::BTreeMap;

use estimator::data::DataSet;
use estimator::identify::Candidate;
use estimator::validate::nrmse;

use crate::effect::{Baseline, ClMove, EffectFit, MIN_GAP_OVER_FLOOR, rms};

/// Fraction of the readings that must lie on the lattice.
const ON_LATTICE: f64 = 0.999;

/// A reading lies on the lattice when within this fraction of a step of a lattice point (far
/// above the rounding of a CSV file's decimals, far below a continuous value's typical miss
/// of a quarter step).
const LATTICE_TOL: f64 = 1e-3;

/// The lattice `(lsb, offset)` the readings `v` lie on, if they do: fewer distinct values than
/// readings, and (nearly) every reading an integer number of smallest steps from the lowest.
pub(crate) fn lattice(v: &[f64]) -> Option<(f64, f64)> {
    let mut distinct = v.to_vec();
    distinct.sort_by(f64::total_cmp);
    distinct.dedup();
    if distinct.len() < 2 || distinct.len() * 10 > v.len() * 9 {
        return None;
    }
    // Steps below the file's decimal precision are rounding, not the lattice.
    let tiny = 1e-9 * distinct.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let lsb = distinct.windows(2).map(|w| w[1] - w[0]).filter(|d| *d > tiny).fold(f64::INFINITY, f64::min);
    if !lsb.is_finite() || lsb <= 0.0 {
        return None;
    }
    let offset = distinct[0];
    let on = v.iter().filter(|x| {
        let steps = (*x - offset) / lsb;
        (steps - steps.round()).abs() <= LATTICE_TOL
    });
    (on.count() as f64 >= ON_LATTICE * v.len() as f64).then_some((lsb, offset))
}

/// The expected reading of an ADC with lattice `(lsb, offset)` whose input is `x` plus white
/// Gaussian noise of standard deviation `sigma`: `E[Q(x + e)]` (the plain rounding of `x` when
/// the noise is far below a step, `x` itself when it is far above).
fn expected_reading(x: f64, (lsb, offset): (f64, f64), sigma: f64) -> f64 {
    let z = (x - offset) / lsb;
    let s = sigma / lsb;
    if s < 1e-3 {
        return offset + z.round() * lsb;
    }
    let phi = |t: f64| 0.5 * libm::erfc(-t / std::f64::consts::SQRT_2);
    let reach = (6.0 * s).ceil() + 1.0;
    let centre = z.round();
    let mut k = centre - reach;
    let mut expected = 0.0;
    while k <= centre + reach {
        expected += k * (phi((k + 0.5 - z) / s) - phi((k - 0.5 - z) / s));
        k += 1.0;
    }
    offset + expected * lsb
}

/// The candidate, when `data.vout` lies on a lattice: `against`'s held-out simulation passed
/// through the quantizer, as the expected reading given the noise at the ADC's input (the
/// noise floor of the readings less the quantization's `lsb²/12`). Significant whenever the
/// lattice is found: a continuous measurement has as many distinct values as samples.
/// Quantization is measurement noise, which no model can predict, so the held-out gap it
/// explains need not shrink.
pub(crate) fn candidate(data: &DataSet, against: &Candidate, n_est: usize, baseline: &Baseline) -> Option<EffectFit> {
    let grid = lattice(&data.vout)?;
    let traces = &against.validation.traces;
    let sigma = baseline.floor.map_or(0.0, |f| (f * f - grid.0 * grid.0 / 12.0).max(0.0).sqrt());
    let quantized: Vec<f64> = traces.simulated.iter().map(|&x| expected_reading(x, grid, sigma)).collect();
    let nrmse_after = nrmse(&traces.measured, &quantized);
    let residual: Vec<f64> = traces.measured.iter().zip(&quantized).map(|(m, q)| m - q).collect();
    // Reported for the plant's default full scale (`adc_vfs`).
    let bits = (buck_model::digital::Digital::default().adc_vfs / grid.0).log2();
    let rms_after = rms(&residual);
    // Material when the quantization noise is a material part of the measurement noise (it
    // closes no gap: no model predicts noise).
    let material = baseline.floor.is_none_or(|f| grid.0.powi(2) / 12.0 >= MIN_GAP_OVER_FLOOR * f * f);
    Some(EffectFit {
        name: "adc_quantization",
        params: BTreeMap::from([("lsb".to_string(), grid.0), ("bits_at_16V_full_scale".to_string(), bits), ("input_noise_rms".to_string(), sigma)]),
        ci95: BTreeMap::new(),
        cl: ClMove::of(against, baseline.cl),
        nrmse_after,
        rms_after,
        shrink_percent: baseline.shrink_percent(nrmse_after),
        closed_percent: baseline.closed_percent(rms_after),
        delta_aic: 0.0,
        // Quantization adds no dynamics: it ranks as the model it extends.
        aic: n_est as f64 * against.fit.sigma[0].powi(2).ln(),
        lr_statistic: None,
        lr_limit: None,
        identifiable: true,
        significant: true,
        closed_of_remaining: None,
        material,
        drift_percent: None,
        of_rl_percent: None,
        within_tolerance: false,
        at_bound: false,
        cl_on_bound: false,
        takes_cl: false,
        finding: material,
        ruled_out_above: None,
        il_closed_percent: None,
        stand_in: None,
        cl_test_failed_without: None,
        alike: Vec::new(),
        residual,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_step_of_quantized_readings_and_not_of_continuous_ones() {
        let lsb = 16.0 / 1024.0;
        let continuous: Vec<f64> = (0..3000).map(|k| 5.0 + 0.3 * (k as f64 * 0.01).sin() + 1e-4 * (k as f64 * 7.3).cos()).collect();
        let quantized: Vec<f64> = continuous.iter().map(|x| (x / lsb).round() * lsb).collect();
        let (step, _) = lattice(&quantized).unwrap();
        assert!((step / lsb - 1.0).abs() < 1e-9, "{step}");
        assert!(lattice(&continuous).is_none());
    }

    /// The expected reading: plain rounding without noise; with noise of a few steps, the input
    /// itself (the dither linearizes the quantizer); symmetric half-way between two levels.
    #[test]
    fn expected_reading_goes_from_rounding_to_the_input_as_noise_grows() {
        let grid = (0.01, 0.0);
        assert!((expected_reading(0.0132, grid, 0.0) - 0.01).abs() < 1e-12);
        assert!((expected_reading(0.0132, grid, 0.02) - 0.0132).abs() < 1e-6);
        assert!((expected_reading(0.015, grid, 0.002) - 0.015).abs() < 1e-9);
        let slight = expected_reading(0.0132, grid, 0.002);
        assert!(slight > 0.01 && slight < 0.0132, "{slight}");
    }
}
