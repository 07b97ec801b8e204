//! Does the final model explain the measured inductor current?
//!
//! The fits follow `vout` (il pins only a late reading's instant, its probe's zero and gain
//! errors projected out). At one sample per period `vout` alone cannot tell the inductance from
//! the output's capacitance where an effect's damping stands in: a lab buck with five effects
//! was fitted with L −39 % beside Cl 16 times too large (234 µF for 14.4), their product kept,
//! so the LC resonance was right and its impedance `√(L/C)` wrong. The inductor current's
//! transients are the output's divided by that impedance: that model's `il` swung 65 % more
//! than the measured one. A probe's gain error cannot explain that; a current that needs one
//! far beyond a probe's tolerance says the model's impedance, and so its Cl, is not the
//! converter's. A gain of −1 within that tolerance is a probe the other way round (or a current
//! counted into the switch node), one of ×10, ×100 or ×1000 (or their inverses) a reading in
//! other units or a probe's attenuation set a decade off: the magnitude within its decade is
//! what tells the impedance, and the reading's slip is said.
use buck_model::Params;
use estimator::data::DataSet;
use estimator::simulated::Start;
use serde::Serialize;

/// A current probe's or shunt amplifier's gain error beyond which a model's inductor current
/// is no reading of the measured one: probes are within a few percent (the generators draw
/// ±2 %); a model the measured current needs more for is judged on the part beyond it.
pub const PROBE_GAIN_TOLERANCE: f64 = 0.10;

/// The RMS of the measured current no tolerable probe gain explains, in multiples of its noise
/// floor, beyond which the model's impedance is wrong: [`crate::GROSS_MISS_FLOORS`], as for
/// `vout`.
const MISFIT_FLOORS: f64 = crate::GROSS_MISS_FLOORS;

/// The inductor current of the circuit `p` at `data`'s samples, simulated from `start`, as the
/// circuit carries it: its il reading's zero and gain errors set aside. `None` where the
/// simulation fails.
pub(crate) fn model_il(p: &Params, data: &DataSet, start: Start) -> Option<Vec<f64>> {
    let raw = Params { il_offset: 0.0, il_gain_error: 0.0, ..*p };
    estimator::simulated::simulate_outputs(&raw, data, start).ok().map(|(_, il)| il)
}

/// How a model's inductor current misses the measured one, held out, calibrated as a probe
/// would be (its zero and gain errors fitted).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CurrentMisfit {
    /// The probe gain the measured current needs to match the model's (1: none).
    pub probe_gain: f64,
    /// The RMS of the measured current beyond what a gain within [`PROBE_GAIN_TOLERANCE`]
    /// explains \[A\].
    pub beyond_tolerance: f64,
    /// The white-noise floor of the measured current \[A\].
    pub floor: f64,
    /// The RMS of the measured current's swing the model's explains through the probe gain
    /// \[A\]: only a swing well above the floor tells how the reading slipped.
    #[serde(skip)]
    pub explained: f64,
}

impl CurrentMisfit {
    /// The misfit of the model with circuit values `p` against the measured `il` (held out from
    /// `n_est`), where the data has `il` and a noise floor for it; the model's own reading
    /// calibration set aside.
    pub(crate) fn of(data: &DataSet, p: &Params, n_est: usize) -> Option<Self> {
        let il = data.il.as_ref()?;
        let (floor, _) = estimator::noise::white_noise(data, il)?;
        let sim = model_il(p, data, Start::from(data.vout[0]))?;
        let (measured, simulated) = (il.get(n_est..)?, sim.get(n_est..)?);
        let (_, gain_error) = estimator::simulated::reading_calibration(measured, simulated);
        let probe_gain = 1.0 + gain_error;
        let spread = crate::effect::rms(&centred(simulated));
        let mut misfit = Self { probe_gain, beyond_tolerance: 0.0, floor, explained: probe_gain.abs() * spread };
        // In the measured current's units: the gain's part beyond a probe's tolerance, within
        // the decade the reading slipped by (none as a rule).
        let scale = if misfit.rescaled() { 10f64.powi(decade_of(probe_gain)) } else { 1.0 };
        misfit.beyond_tolerance = ((probe_gain.abs() / scale - 1.0).abs() - PROBE_GAIN_TOLERANCE).max(0.0) * scale * spread;
        Some(misfit)
    }

    /// The measured current follows the model's swing well above its noise floor: only then
    /// does the probe gain tell how the reading slipped. (A diode buck deep in DCM starts its
    /// periods at zero current: there the gain is noise, ×0.105 on a third-generator board.)
    pub(crate) fn follows(&self) -> bool {
        self.explained > MISFIT_FLOORS * self.floor
    }

    /// The measured current reads the model's at another scale, ×10, ×100 or ×1000 or their
    /// inverses within a probe's tolerance, following its swing.
    pub fn rescaled(&self) -> bool {
        self.follows() && decade_of(self.probe_gain) != 0
    }

    /// The measured current reads the model's reversed or rescaled, following its swing: a slip
    /// of the reading, not of the model.
    pub fn slipped(&self) -> bool {
        self.follows() && (self.reversed() || self.rescaled())
    }

    /// The model's impedance is not the converter's: the current left beyond a tolerable probe
    /// gain exceeds `MISFIT_FLOORS` noise floors.
    pub fn contradicts(&self) -> bool {
        self.beyond_tolerance > MISFIT_FLOORS * self.floor
    }

    /// The measured current reads the model's reversed (a negative probe gain).
    pub fn reversed(&self) -> bool {
        self.probe_gain < 0.0
    }

    /// How the measured current's reading slipped, in words.
    pub fn slip(&self) -> String {
        let mut how = Vec::new();
        if self.reversed() {
            how.push("reversed (the probe the other way round, or the current counted into the switch node; the contract's il flows from the switch node to the output)");
        }
        if self.rescaled() {
            how.push("at another scale (milliamps under a bare `il` header, or a probe's attenuation set a decade off; the contract's il is in amperes)");
        }
        format!("the measured il reads ×{:.3} the model's: {}", self.probe_gain, how.join(", and "))
    }

    /// Why Cl is not identified, in words.
    pub fn reason(&self) -> String {
        format!(
            "the model's inductor current matches the measured one only through a probe gain of ×{:.2} (a probe is within ±{:.0} %; {:.0} mA RMS beyond that, {:.0}× il's noise floor): its impedance √(L/C) is not the converter's, nor its Cl",
            self.probe_gain,
            100.0 * PROBE_GAIN_TOLERANCE,
            1e3 * self.beyond_tolerance,
            self.beyond_tolerance / self.floor
        )
    }
}

/// Cl with the current probe taken as exact, for a final model that fits L. Its impedance
/// `√(L/C)` then rests on il's swing, whose probe gain the fits set aside: the gain the measured
/// current needs, within a probe's tolerance, is the probe's or the impedance's, and the data
/// cannot tell which. Taken as the impedance's (the resonance `L·(C + Cl)` kept, as `vout`
/// pins it), the output's capacitance is that gain times the model's. A lab buck of seed 77
/// fitted L −9.8 % (its L was nominal) with C + Cl 454 µF for 409 and Cl 56.7 [31.9, 72.7] µF
/// for 6.97: its current needs ×0.888, which puts Cl near 6.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ProbeExact {
    /// The probe gain the measured current needs ([`CurrentMisfit::probe_gain`]).
    pub probe_gain: f64,
    /// Cl with the probe exact \[F\]: the output's capacitance scaled by the gain, C kept.
    pub cl: f64,
}

impl ProbeExact {
    /// Cl of the final model `p` (reported as `reported`) with the probe exact, where `misfit`
    /// follows the model's swing, tolerably (neither contradicting nor slipped).
    pub(crate) fn of(misfit: &CurrentMisfit, p: &Params, reported: f64) -> Option<Self> {
        let positive = |x: f64| x.is_finite() && x > 0.0;
        if !misfit.follows() || misfit.slipped() || misfit.contradicts() || !positive(p.cl) || !positive(reported) {
            return None;
        }
        let g = misfit.probe_gain;
        let cl = (g * (p.c + p.cl) - p.c).max(0.0) / p.cl * reported;
        Some(Self { probe_gain: g, cl })
    }

    /// `ci95` widened to hold this Cl (to 0 where the gain leaves none).
    pub(crate) fn spanned(&self, ci95: [f64; 2]) -> [f64; 2] {
        crate::effect::spanning(ci95, &[[self.cl; 2]])
    }
}

impl std::fmt::Display for ProbeExact {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the model fits L, so its impedance √(L/C) rests on il's swing, which needs a probe gain of ×{:.3}: with the probe exact, the output's capacitance is ×{:.3} and Cl {:.4} µF, and the interval spans both",
            self.probe_gain,
            self.probe_gain,
            self.cl * 1e6
        )
    }
}

impl std::fmt::Display for CurrentMisfit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "not identified: {}", self.reason())
    }
}

/// The decade `d` (±1 to ±3) a probe gain `gain` lies within a probe's tolerance of in
/// magnitude (`|gain| ≈ 10^d`), else 0.
fn decade_of(gain: f64) -> i32 {
    let d = gain.abs().log10().round();
    let rescaled = d != 0.0 && d.abs() <= 3.0 && (gain.abs() / 10f64.powf(d) - 1.0).abs() <= PROBE_GAIN_TOLERANCE;
    if rescaled { d as i32 } else { 0 }
}

/// `x` less its mean.
fn centred(x: &[f64]) -> Vec<f64> {
    let mean = x.iter().sum::<f64>() / x.len().max(1) as f64;
    x.iter().map(|v| v - mean).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use buck_model::Mode;
    use estimator::experiment::{Experiment, ModelPlant, run};

    /// The true circuit's current needs no probe gain, and one read 5 % high needs ×1.05, within
    /// a probe's tolerance. A model with L −39 % and Cl raised so that the LC resonance stays
    /// (L·(C + Cl) kept), as a lab buck's selection once ended, follows vout's resonance with
    /// 0.61 of the impedance: its current swings half as much again (×0.66 calibrates it, the
    /// capacitors' ESR shaping the transients too), which no probe explains.
    #[test]
    fn a_model_with_the_wrong_impedance_contradicts_the_current() {
        let truth = Params { cl: 10e-6, ..Params::default() };
        let exp = Experiment { samples: 1500, io: 2.0, noise_vout: 2e-3, noise_il: 10e-3, ..Experiment::default() };
        let mut data = run(&mut ModelPlant::new(truth, Mode::Switched), &exp).unwrap();
        let n_est = 1000;
        let right = CurrentMisfit::of(&data, &truth, n_est).expect("a current and its floor");
        assert!((right.probe_gain - 1.0).abs() < 0.01 && !right.contradicts(), "{right:?}");
        let ratio: f64 = 0.61;
        let wrong = Params { l: ratio * truth.l, cl: (truth.c + truth.cl) / ratio - truth.c, ..truth };
        let misfit = CurrentMisfit::of(&data, &wrong, n_est).unwrap();
        assert!(misfit.probe_gain < 0.75 && misfit.contradicts(), "{misfit:?}");
        assert!(misfit.to_string().starts_with("not identified"), "{misfit}");
        for il in data.il.as_mut().unwrap() {
            *il *= 1.05;
        }
        let high = CurrentMisfit::of(&data, &truth, n_est).unwrap();
        assert!((high.probe_gain - 1.05).abs() < 0.01 && !high.contradicts() && !high.reversed(), "{high:?}");
        // The probe the other way round: the same impedance, said reversed.
        for il in data.il.as_mut().unwrap() {
            *il = -*il;
        }
        let reversed = CurrentMisfit::of(&data, &truth, n_est).unwrap();
        assert!((reversed.probe_gain + 1.05).abs() < 0.01 && !reversed.contradicts() && reversed.reversed() && !reversed.rescaled(), "{reversed:?}");
        let misfit = CurrentMisfit::of(&data, &wrong, n_est).unwrap();
        assert!(misfit.contradicts() && misfit.reversed(), "{misfit:?}");
        // In milliamps: the same impedance, said rescaled; the wrong one still contradicts.
        for il in data.il.as_mut().unwrap() {
            *il *= -1000.0;
        }
        let milliamps = CurrentMisfit::of(&data, &truth, n_est).unwrap();
        assert!((milliamps.probe_gain / 1050.0 - 1.0).abs() < 0.01 && !milliamps.contradicts() && milliamps.rescaled() && !milliamps.reversed(), "{milliamps:?}");
        assert!(milliamps.slip().contains("another scale"), "{}", milliamps.slip());
        let misfit = CurrentMisfit::of(&data, &wrong, n_est).unwrap();
        assert!(misfit.contradicts() && !misfit.rescaled(), "{misfit:?}");
    }

    /// A model whose impedance is 8 % low, the resonance kept (L ×0.92 and C + Cl ÷0.92: Cl
    /// 19.6 µF for 10), needs a probe gain near ×0.92, within a probe's tolerance: taken as the
    /// impedance's, it gives back the converter's Cl. A model with the right impedance and a
    /// probe 5 % high is put 5 % of C + Cl off the other way: the data cannot tell which.
    #[test]
    fn with_the_probe_exact_a_model_with_the_wrong_impedance_gives_back_cl() {
        let truth = Params { cl: 10e-6, ..Params::default() };
        let exp = Experiment { samples: 1500, io: 2.0, noise_vout: 2e-3, noise_il: 10e-3, ..Experiment::default() };
        let mut data = run(&mut ModelPlant::new(truth, Mode::Switched), &exp).unwrap();
        let ratio: f64 = 0.92;
        let wrong = Params { l: ratio * truth.l, cl: (truth.c + truth.cl) / ratio - truth.c, ..truth };
        let misfit = CurrentMisfit::of(&data, &wrong, 1000).unwrap();
        assert!((misfit.probe_gain - ratio).abs() < 0.01 && !misfit.contradicts(), "{misfit:?}");
        let exact = ProbeExact::of(&misfit, &wrong, wrong.cl).expect("a tolerable gain");
        assert!((exact.cl / truth.cl - 1.0).abs() < 0.05, "Cl {:e} with the probe exact, for {:e}", exact.cl, truth.cl);
        assert_eq!(exact.spanned([19e-6, 20e-6]), [exact.cl, 20e-6]);
        for il in data.il.as_mut().unwrap() {
            *il *= 1.05;
        }
        let high = ProbeExact::of(&CurrentMisfit::of(&data, &truth, 1000).unwrap(), &truth, truth.cl).unwrap();
        assert!((high.cl - (truth.cl + 0.05 * (truth.c + truth.cl))).abs() < 0.01 * (truth.c + truth.cl), "{high:?}");
        // A reading that slipped (reversed) or a gain past the tolerance says nothing of it.
        for il in data.il.as_mut().unwrap() {
            *il = -*il;
        }
        assert_eq!(ProbeExact::of(&CurrentMisfit::of(&data, &truth, 1000).unwrap(), &truth, truth.cl), None);
        // Nor a Cl that is not there to scale.
        assert_eq!(ProbeExact::of(&misfit, &wrong, f64::NAN), None);
        let far = Params { l: 0.61 * truth.l, cl: (truth.c + truth.cl) / 0.61 - truth.c, ..truth };
        assert_eq!(ProbeExact::of(&CurrentMisfit::of(&data, &far, 1000).unwrap(), &far, far.cl), None);
    }

    /// A gain near a decade within a probe's tolerance is a rescaled reading; one between
    /// decades, or near zero (the model's current unrelated to the measured one), is not.
    #[test]
    fn only_a_gain_near_a_decade_is_a_rescaled_reading() {
        assert_eq!([1000.0, 0.0105, -98.0, 1.05, 0.6, 3.2, 0.00036, 1e5].map(decade_of), [3, -2, 2, 0, 0, 0, 0, 0]);
    }
}
