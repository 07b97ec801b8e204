//! The white sensor noise on a measured channel (`vout`, `il`), estimated from the data alone,
//! with no model: the floor a model's gap is judged against (so that it is judged against
//! something the model did not produce), and the weight of each channel in a fit of both.
//!
//! Between input steps the converter's outputs are smooth at one sample per period (its poles
//! are far below the sampling rate), so a fourth difference of a channel there is almost pure
//! noise: `Δ⁴e` of white noise has variance `C(8,4)·σ² = 70·σ²`. Only differences whose
//! window, and the `SETTLE` samples before it, see one constant input are used: a step in
//! the duty kinks the output (the inductor current's slope jumps, and the ESR passes it on),
//! and the fast charge-sharing mode between C and Cl dies out within a few periods; a duty
//! applied up to two periods late (`delay`) moves the kink by as much.

use crate::data::DataSet;

/// Order of the difference.
const ORDER: usize = 4;

/// `C(2·ORDER, ORDER)`: the variance gain of the difference on white noise.
pub(crate) const GAIN: f64 = 70.0;

/// The fourth difference `Δ⁴y` of the five samples `y`.
pub(crate) fn fourth_difference(y: &[f64]) -> f64 {
    y[4] - 4.0 * y[3] + 6.0 * y[2] - 4.0 * y[1] + y[0]
}

/// Samples after an input step that are left out (the kink, a delay of up to two periods and
/// the fast mode).
const SETTLE: usize = 4;

/// Fewest usable differences for an estimate.
const MIN_DIFFERENCES: usize = 100;

/// Standard deviation of the white noise on `data.vout` \[V\], or `None` when the inputs step
/// too often to leave `MIN_DIFFERENCES` quiet windows.
pub fn noise_floor(data: &DataSet) -> Option<f64> {
    noise_floor_estimate(data).map(|(sigma, _)| sigma)
}

/// [`noise_floor`] and the number of fourth differences it was estimated from (its
/// uncertainty).
pub fn noise_floor_estimate(data: &DataSet) -> Option<(f64, usize)> {
    white_noise(data, &data.vout)
}

/// Standard deviation of the white noise on `series` (a channel of `data`, sample for sample)
/// and the number of fourth differences it was estimated from, or `None` when the inputs step
/// too often to leave `MIN_DIFFERENCES` quiet windows.
pub fn white_noise(data: &DataSet, series: &[f64]) -> Option<(f64, usize)> {
    let n = data.len().min(series.len());
    let span = ORDER + SETTLE;
    let steady = |k: usize| data.duty[k] == data.duty[k - 1] && data.io[k] == data.io[k - 1] && data.vin[k] == data.vin[k - 1];
    // quiet[k]: the inputs did not change over samples k − span ..= k.
    let mut run = 0;
    let mut sum = 0.0;
    let mut count = 0usize;
    for k in 1..n {
        run = if steady(k) { run + 1 } else { 0 };
        if run >= span {
            let y = &series[k - ORDER..=k];
            let d = fourth_difference(y);
            sum += d * d;
            count += 1;
        }
    }
    (count >= MIN_DIFFERENCES).then(|| ((sum / count as f64 / GAIN).sqrt(), count))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// A smooth step response under a square-wave input plus white noise of known σ: the
    /// estimate is within 10 % of σ, while the raw fourth differences (steps included) are not.
    #[test]
    fn finds_the_white_noise_under_a_stepped_smooth_response() {
        let sigma = 2e-3;
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let noise = Normal::new(0.0, sigma).unwrap_or_else(|e| panic!("{e}"));
        let n = 3000;
        let duty: Vec<f64> = (0..n).map(|k| if (k / 8) % 3 == 0 { 0.6 } else { 0.4 }).collect();
        // A lightly damped second-order response to the duty (poles near 8 kHz at 330 kHz).
        let (mut x, mut v) = (0.0f64, 0.0f64);
        let w = 2.0 * std::f64::consts::PI / 38.0;
        let mut vout = Vec::with_capacity(n);
        for &d in &duty {
            let a = w * w * (12.0 * d - x) - 0.05 * w * v;
            v += a;
            x += v;
            vout.push(x + 0.3 * v + noise.sample(&mut rng));
        }
        let data = DataSet { time: (0..n).map(|k| k as f64 / 330e3).collect(), duty, vin: vec![12.0; n], io: vec![1.0; n], vout, ..DataSet::default() };
        let est = noise_floor(&data).unwrap_or(f64::NAN);
        assert!((est / sigma - 1.0).abs() < 0.1, "estimate {est}, true {sigma}");
        let raw: f64 = data.vout.windows(5).map(|y| fourth_difference(y).powi(2)).sum::<f64>();
        let raw = (raw / (n - 4) as f64 / GAIN).sqrt();
        assert!(raw > 1.5 * sigma, "steps kink the raw differences: {raw}");
    }

    #[test]
    fn no_estimate_when_the_input_steps_every_sample() {
        let n = 1000;
        let data = DataSet {
            time: (0..n).map(|k| k as f64).collect(),
            duty: (0..n).map(|k| if k % 2 == 0 { 0.4 } else { 0.6 }).collect(),
            vin: vec![12.0; n],
            io: vec![1.0; n],
            vout: vec![5.0; n],
            ..DataSet::default()
        };
        assert_eq!(noise_floor(&data), None);
    }
}
