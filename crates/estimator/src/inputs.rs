//! Inputs recorded by a measurement rather than as commanded.
//!
//! The models take `vin` and `io` as exact inputs. On a bench they are often measured (a scope
//! channel on the supply, a current probe on the load): the same levels as commanded, plus the
//! instrument's white noise. Fed to a simulation, that noise drives `vout` through the output
//! impedance, so the model's prediction carries noise the converter never saw, and an input
//! that changes at every row leaves no quiet window for the model-free noise floor
//! ([`crate::noise`]). A ground-truth check on clean ngspice boards with 2 % of white noise
//! added to `io` gave a "late reading" finding and Cl 1.33 [1.21, 1.58] µF for 1.11.
//!
//! A column is taken as measured when fewer than half of its rows repeat the row before exactly
//! (a commanded level repeats for periods on end). Its white noise is estimated from its fourth
//! differences (their median, so that the steps do not count), and the column is replaced by
//! its levels: in each segment between its own jumps beyond `STEP_SIGMAS` of its noise where
//! the duty holds (a load step), the least-squares line in the duty where its slope is
//! significant (a supply sags with the current it delivers), else the mean. Averaging only
//! between the duty's steps left a segment's mean of 15 rows, whose error, a quarter of the
//! noise, still reached vout at the duty's gain. The column is replaced only where it is such
//! levels plus white noise: the spread about them must be the noise's (`MAX_SPREAD_RATIO`); a
//! load that varies by itself (a sine, a ramp) is left as recorded.

use serde::Serialize;

use buck_model::Params;

use crate::data::DataSet;
use crate::noise::{GAIN, fourth_difference};
use crate::simulated::simulate;

/// A column's step between two rows, in multiples of its white noise's standard deviation,
/// beyond which a segment ends (the difference of two rows of white noise has `√2·σ`: a false
/// end once in 10⁹ rows).
const STEP_SIGMAS: f64 = 8.5;

/// A slope in the duty is taken where it exceeds this many of its standard errors (one
/// the noise draws exceeds 4 once in 16 000 records).
const SLOPE_SIGMAS: f64 = 4.0;

/// Most share of a column's rows that repeat the row before, for the column to be taken as
/// measured.
const MAX_REPEAT_SHARE: f64 = 0.5;

/// Most ratio of the spread about the segments' means to the white noise's variance for a
/// column to be a level plus white noise (about 1 for one; its estimate scatters by a few %).
const MAX_SPREAD_RATIO: f64 = 1.5;

/// Standard errors by which the regression of vout's residual on the response to an input's
/// noise must exceed zero for the converter to have seen the noise.
const SEEN_SIGMAS: f64 = 5.0;

/// Fewest rows for the noise to be estimated.
const MIN_ROWS: usize = 100;

/// The median of a standard normal's absolute value: `|Δ⁴x|` of white noise has its median at
/// this times `√70·σ`.
const MEDIAN_OF_ABS_NORMAL: f64 = 0.674_489_750_196_081_7;

/// An input column recorded by a measurement.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MeasuredInput {
    /// `vin` or `io`.
    pub column: &'static str,
    /// Standard deviation of its white noise (in the column's unit).
    pub noise: f64,
    /// Segments between its own steps.
    pub segments: usize,
    /// Replaced by its levels (else kept as recorded: vout shows the converter's response to
    /// the noise; see [`drive_by_levels_unless_seen`]).
    pub replaced: bool,
}

impl MeasuredInput {
    /// Its unit.
    pub fn unit(&self) -> &'static str {
        if self.column == "io" { "A" } else { "V" }
    }

    /// One sentence for people, its noise written as `noise` (a number with its unit).
    pub fn sentence(&self, noise: &str) -> String {
        format!("{} measured, with {noise} RMS of white noise: {}", self.column, self.what_was_done())
    }

    /// What was done with it, and why.
    fn what_was_done(&self) -> String {
        if self.replaced {
            format!(
                "replaced by its levels (in {} segment(s) between its own steps, the mean or, where it moves with the duty, a line in it): vout shows no response to the noise, the instrument's, which a simulation driven by it would carry into vout",
                self.segments
            )
        } else {
            "kept as recorded: vout shows the converter's response to the noise, so the converter saw it".to_string()
        }
    }
}

impl std::fmt::Display for MeasuredInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.sentence(&format!("{:.3e} {}", self.noise, self.unit())))
    }
}

/// `data` with its measured `vin` and `io` replaced by their levels (see the module's
/// documentation), and what was replaced.
pub fn average_measured(data: &DataSet) -> (DataSet, Vec<MeasuredInput>) {
    let mut out = data.clone();
    let mut measured = Vec::new();
    for (column, series) in [("vin", &mut out.vin), ("io", &mut out.io)] {
        if let Some((levels, noise, segments)) = averaged_levels(&data.duty, series) {
            *series = levels;
            measured.push(MeasuredInput { column, noise, segments, replaced: true });
        }
    }
    (out, measured)
}

/// `data` with its measured inputs replaced by their levels ([`average_measured`]) unless the
/// converter saw their noise, and the model `fit` fits to the data chosen, whose circuit values
/// are `params`: the data chosen, its fit and the measured inputs (`replaced` as chosen).
///
/// An instrument's noise drives a simulation with what the converter never saw; a supply's or a
/// load's own noise it did see, and its levels would miss it. Which it was, the data says: the
/// model fitted on the levels is run on the inputs as recorded too, and its residual regressed
/// on the difference, the response to the noise (both differenced once). A converter that saw
/// it shows that response (coefficient near 1); an instrument's noise leaves the residual blind
/// to it (near 0). The noise is taken as seen where the coefficient exceeds ½ at
/// `SEEN_SIGMAS` standard errors (the model's own miss of vout is no function of a white
/// noise, whatever the effects it lacks). Comparing the held-out errors of the two fits instead
/// chose the recorded noise on 6 of 36 third-generator boards with noise added, where the
/// nominal missed by tens of per cent and the two errors differed in the fifth digit.
pub fn drive_by_levels_unless_seen<T, E>(data: &DataSet, fit: impl Fn(&DataSet) -> Result<T, E>, params: impl Fn(&T) -> Params) -> Result<(DataSet, T, Vec<MeasuredInput>), E> {
    let (levels, mut measured) = average_measured(data);
    if measured.is_empty() {
        return fit(data).map(|f| (data.clone(), f, measured));
    }
    if let Ok(by_levels) = fit(&levels)
        && !noise_seen(data, &levels, &params(&by_levels))
    {
        return Ok((levels, by_levels, measured));
    }
    measured.iter_mut().for_each(|m| m.replaced = false);
    fit(data).map(|f| (data.clone(), f, measured))
}

/// Whether vout shows the response of the converter `p` to the difference between the inputs
/// as `recorded` and their `levels` (see [`drive_by_levels_unless_seen`]).
fn noise_seen(recorded: &DataSet, levels: &DataSet, p: &Params) -> bool {
    let v0 = recorded.vout[0];
    let (Ok(by_levels), Ok(by_recorded)) = (simulate(p, levels, v0), simulate(p, recorded, v0)) else { return false };
    // First differences: the response to white noise is fast, the model's own miss slow, and a
    // nonlinear model (a diode's DCM) rectifies the noise into a shift of its mean that a miss
    // of the level would match.
    let difference = |x: Vec<f64>| -> Vec<f64> { x.windows(2).map(|w| w[1] - w[0]).collect() };
    let response = difference(by_recorded.iter().zip(&by_levels).map(|(r, l)| r - l).collect());
    let residual = difference(recorded.vout.iter().zip(&by_levels).map(|(v, l)| v - l).collect());
    let ss: f64 = response.iter().map(|r| r * r).sum();
    if !(ss > 0.0 && ss.is_finite()) {
        return false;
    }
    let beta = residual.iter().zip(&response).map(|(e, r)| e * r).sum::<f64>() / ss;
    let sigma = (residual.iter().zip(&response).map(|(e, r)| (e - beta * r).powi(2)).sum::<f64>() / residual.len() as f64).sqrt();
    beta > 0.5 && beta * ss.sqrt() > SEEN_SIGMAS * sigma
}

/// `series` as levels (see [`levels`]), its white noise and the number of segments, where it
/// is measured and such levels plus white noise.
fn averaged_levels(duty: &[f64], series: &[f64]) -> Option<(Vec<f64>, f64, usize)> {
    let n = series.len();
    if n < MIN_ROWS || duty.len() != n {
        return None;
    }
    let repeats = series.windows(2).filter(|w| w[0] == w[1]).count();
    if repeats as f64 >= MAX_REPEAT_SHARE * (n - 1) as f64 {
        return None;
    }
    let mut differences: Vec<f64> = series.windows(5).map(|y| fourth_difference(y).abs()).collect();
    let middle = differences.len() / 2;
    let (_, median, _) = differences.select_nth_unstable_by(middle, f64::total_cmp);
    let noise = *median / (MEDIAN_OF_ABS_NORMAL * GAIN.sqrt());
    if !(noise.is_finite() && noise > 0.0) {
        return None;
    }
    // Segment starts: the first row and each jump of the column beyond its noise that the duty
    // does not explain (a load step).
    let mut starts = vec![0];
    starts.extend((1..n).filter(|&k| duty[k] == duty[k - 1] && (series[k] - series[k - 1]).abs() > STEP_SIGMAS * noise));
    let mut fitted = Vec::with_capacity(n);
    let mut spread = 0.0;
    let mut taken = 0;
    for (j, &start) in starts.iter().enumerate() {
        let end = starts.get(j + 1).copied().unwrap_or(n);
        let (level, dof) = levels(&duty[start..end], &series[start..end], noise);
        spread += level.iter().zip(&series[start..end]).map(|(l, x)| (x - l).powi(2)).sum::<f64>();
        taken += dof;
        fitted.extend(level);
    }
    // The spread about the levels, corrected for the degrees of freedom they take.
    let spread = spread / (n - taken).max(1) as f64;
    (spread <= MAX_SPREAD_RATIO * noise * noise).then_some((fitted, noise, starts.len()))
}

/// A segment's levels, for white noise of standard deviation `noise`: the least-squares line in
/// the duty (a supply's sag with the current it delivers) where its slope is significant, else
/// the mean; and the degrees of freedom taken. A slope the noise alone drew would move the
/// input with the duty, the excitation itself: a constant 4.9 A load with 97 mA of noise got
/// 3.5 mA of it, and Cl's interval test failed (Hausman 27).
fn levels(duty: &[f64], x: &[f64], noise: f64) -> (Vec<f64>, usize) {
    let m = x.len() as f64;
    let (dm, xm) = (duty.iter().sum::<f64>() / m, x.iter().sum::<f64>() / m);
    let sdd: f64 = duty.iter().map(|d| (d - dm).powi(2)).sum();
    let slope = if sdd > 0.0 { duty.iter().zip(x).map(|(d, v)| (d - dm) * (v - xm)).sum::<f64>() / sdd } else { 0.0 };
    if sdd <= 0.0 || slope.abs() < SLOPE_SIGMAS * noise / sdd.sqrt() {
        return (vec![xm; x.len()], 1);
    }
    (duty.iter().map(|d| xm + slope * (d - dm)).collect(), 2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    fn prbs_duty(n: usize) -> Vec<f64> {
        (0..n).map(|k| if (k / 8) % 3 == 0 { 0.6 } else { 0.4 }).collect()
    }

    fn with_noise(levels: &[f64], sigma: f64, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let noise = Normal::new(0.0, sigma).unwrap_or_else(|e| panic!("{e}"));
        levels.iter().map(|x| x + noise.sample(&mut rng)).collect()
    }

    fn data(duty: Vec<f64>, vin: Vec<f64>, io: Vec<f64>) -> DataSet {
        let n = duty.len();
        DataSet { time: (0..n).map(|k| k as f64 / 330e3).collect(), duty, vin, io, vout: vec![5.0; n], ..DataSet::default() }
    }

    /// A load stepping 1 A → 3 A, measured with 20 mA of white noise: the noise is estimated
    /// within 10 %, the step kept where it is, and what is left of the noise is the levels'
    /// (about σ/√750 here), a twentieth of it or less.
    #[test]
    fn a_measured_load_step_is_averaged_and_kept() {
        let n = 3000;
        let truth: Vec<f64> = (0..n).map(|k| if k < 1500 { 1.0 } else { 3.0 }).collect();
        let io = with_noise(&truth, 0.02, 1);
        let (out, averaged) = average_measured(&data(prbs_duty(n), vec![12.0; n], io));
        assert_eq!(averaged.len(), 1, "{averaged:?}");
        assert_eq!(averaged[0].column, "io");
        assert!((averaged[0].noise / 0.02 - 1.0).abs() < 0.1, "{}", averaged[0].noise);
        let left = (out.io.iter().zip(&truth).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / n as f64).sqrt();
        assert!(left < 0.02 / 20.0, "{left}");
        assert_eq!(averaged[0].segments, 2);
        assert!(out.io[1499] < 1.1 && out.io[1500] > 2.9, "{} {}", out.io[1499], out.io[1500]);
        assert_eq!(out.vin, vec![12.0; n], "a commanded vin is left as it is");
    }

    /// A supply that sags with the duty (an input source's resistance), measured with 10 mV of
    /// noise: the sag survives, level for level within 2 mV.
    #[test]
    fn a_sag_with_the_duty_survives() {
        let n = 2000;
        let duty = prbs_duty(n);
        let truth: Vec<f64> = duty.iter().map(|d| 12.0 - 0.2 * d).collect();
        let vin = with_noise(&truth, 0.01, 2);
        let (out, averaged) = average_measured(&data(duty, vin, vec![1.0; n]));
        assert_eq!(averaged.iter().map(|a| a.column).collect::<Vec<_>>(), ["vin"]);
        let worst = out.vin.iter().zip(&truth).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst < 0.002, "{worst}");
    }

    /// A load that varies by itself (a slow sine of 0.5 A) with little noise is no level plus
    /// white noise: left as recorded. So is a commanded one, and a record too short to tell.
    #[test]
    fn a_varying_load_a_commanded_one_and_a_short_record_are_left_alone() {
        let n = 3000;
        let sine: Vec<f64> = (0..n).map(|k| 2.0 + 0.5 * (k as f64 / 150.0).sin()).collect();
        let io = with_noise(&sine, 1e-4, 3);
        assert!(average_measured(&data(prbs_duty(n), vec![12.0; n], io)).1.is_empty());
        let stepped: Vec<f64> = (0..n).map(|k| if (k / 100) % 2 == 0 { 1.0 } else { 2.0 }).collect();
        assert!(average_measured(&data(prbs_duty(n), vec![12.0; n], stepped)).1.is_empty());
        let short = with_noise(&[1.0; 50], 0.02, 4);
        assert!(average_measured(&data(prbs_duty(50), vec![12.0; 50], short)).1.is_empty());
    }
}
