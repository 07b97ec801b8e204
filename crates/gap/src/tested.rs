//! Cl's interval as the data can back it, not only as the fit's covariance has it.
//!
//! A fit's CI95 assumes its model is the data's. A circuit (SPICE or a bench) is never quite
//! the model: its parasitics move Cl by more than a white residual at the noise floor can show.
//! Of 43 third-generator captures with no effect listed, the nominal fit's own interval missed
//! the true Cl in 10 (by 0.001–4 %), 9 of them with white residuals. The interval is therefore tested: against
//! the high-pass refit ([`crate::consistency`]), widened for a residual the model error
//! colours, void where the model misses grossly, and held to the circuit model's fidelity
//! ([`CL_FIDELITY`]), and void where the model's inductor current contradicts the measured one
//! ([`CurrentMisfit`]). The diagnosis so tests its final model's Cl; `buckid identify` so tests
//! the nominal's on data from a file.
use buck_model::Params;
use estimator::data::DataSet;
use estimator::identify::Candidate;
use estimator::model::Structure;
use serde::Serialize;
use std::collections::BTreeMap;

use crate::consistency;
use crate::current::CurrentMisfit;
use crate::effect::{self, Baseline, ClCheck, ClMove};

/// Relative half-width below which Cl's CI95 is not reported: the fidelity of a circuit model
/// to a converter. The third generator's ever-present parasitics (a decoupling capacitor, the
/// hot loop, a feedback divider) move its Cl, which a white residual at the floor cannot show:
/// clean point-of-load captures were 0.0004–0.02 % off with intervals of ±0.0005–0.01 %, and
/// fresh boards of seeds 53 and 67 +0.128 % and −0.153 % (the first outside the ±0.1 % this
/// had been); and with a leverage of 2–6 on L (`cl_leverage`), Cl to 0.2 % already asks L to
/// 0.03–0.1 %.
pub const CL_FIDELITY: f64 = 2e-3;

/// [`CL_FIDELITY`] of a model that needed effects to explain the data: each effect's model
/// approximates a device (a constant drop for a diode's exponential, one ESL for the
/// capacitors' own, a saturation knee or a bias law of one shape for a part's smooth curve).
/// On the third generator's boards with one effect, 6 of 42 final intervals that pinned Cl
/// down missed it, 0.1–3.1 % off with their near bound 0.1–0.7 % from the estimate (an ESL's
/// 0.9 %, a Schottky's 1.0 %, two saturation knees' 1.0 and 3.1 %, two bias laws' 0.1 %),
/// where every board that needed no effect was covered at ±0.1 %.
pub const CL_FIDELITY_WITH_EFFECTS: f64 = 1e-2;

/// Relative accuracy to which a circuit model's L and C stand for the circuit's own: its
/// parasitics (a decoupling capacitor, the hot loop, a ceramic's ESR, a simulator's time steps)
/// move the resonance the model puts down to L and C. Where Cl is a small part of the output's
/// capacitance, a fixed share of Cl asks far more of L and C than that: a 1.83 µF beside 200 µF
/// (seed 79's clean point-of-load board) leans −103 on C and −108 on L, and its fit was 0.27 %
/// high, outside ±0.2 %, from an error of 0.0025 % in L and C. On the 30 clean third-generator
/// boards of seeds 71–79, the errors put down to L or C over Cl's leverage on them were at most
/// 0.009 %.
pub const CIRCUIT_FIDELITY: f64 = 1e-4;

/// [`CIRCUIT_FIDELITY`] of a model holding an effect whose form approximates a device's curve
/// or edge (`crate::effect::approximates_a_device`: a hard saturation knee for a core's soft
/// one, a constant drop for a diode's exponential, a dead time's held node for its gate ramps
/// and body diodes). What the approximation gets wrong, the fit puts partly into the output's
/// resonance, so into L and C. Harness seed 3636's 36 datasets put 0.19 % of L into a
/// saturation knee's Cl (3.06 µF for 3.15 beside 100 µF: leverage −16.7 on L) and 0.24 % of C
/// into a dead time's with the node's capacitance (1.65 µF for 1.58, −18 on C), both outside
/// their intervals; every final model without such an effect (a switch's resistance, a load's
/// ESR or an ESL, a drift, a late reading) put at most 0.1 % there.
pub const CIRCUIT_FIDELITY_WITH_DEVICES: f64 = 3e-3;

/// The relative half-width Cl's CI95 is held to: `base` ([`CL_FIDELITY`] or
/// [`CL_FIDELITY_WITH_EFFECTS`]), or `circuit` ([`CIRCUIT_FIDELITY`] or
/// [`CIRCUIT_FIDELITY_WITH_DEVICES`]) of L and C through Cl's `leverage` on them
/// (`d ln Cl / d ln x`, [`crate::Diagnosis::cl_leverage`]) where that is wider: `ln Cl` within
/// `±leverage·circuit`, so `exp(leverage·circuit) − 1` (a 0.3 % through a leverage of 175 is
/// a factor of 1.69, where a linear share would hold Cl to 1.52).
pub(crate) fn fidelity(base: f64, circuit: f64, leverage: Option<&BTreeMap<String, f64>>) -> f64 {
    let lean = leverage.into_iter().flatten().filter(|(name, _)| matches!(name.as_str(), "L" | "C")).map(|(_, k)| k.abs()).fold(0.0, f64::max);
    base.max((circuit * lean).exp_m1())
}

/// Says the relative half-width `fidelity` ([`fidelity`]) an interval was held to, and where it
/// comes from Cl's leverage (`circuit` of L and C), so.
pub(crate) fn held_to(fidelity: f64, circuit: f64) -> String {
    let through_leverage = fidelity != CL_FIDELITY && fidelity != CL_FIDELITY_WITH_EFFECTS;
    let why = if through_leverage { format!(" ({:.2} % of L and C, through Cl's leverage on them)", 100.0 * circuit) } else { String::new() };
    format!("held to ±{:.1} %, the circuit model's fidelity{why}", 100.0 * fidelity)
}

/// `ci95` around `cl` widened to at least ±`fidelity` (`cl/(1 + f)` to `cl·(1 + f)`), and
/// whether it was; an interval that identifies nothing stays as it is.
pub(crate) fn at_fidelity_of(cl: f64, [lo, hi]: [f64; 2], fidelity: f64) -> ([f64; 2], bool) {
    if !(cl > 0.0 && lo > 0.0 && hi.is_finite()) {
        return ([lo, hi], false);
    }
    let floor = [cl / (1.0 + fidelity), cl * (1.0 + fidelity)];
    ([lo.min(floor[0]), hi.max(floor[1])], lo > floor[0] || hi < floor[1])
}

/// Cl of the nominal model alone, its interval tested.
#[derive(Debug, Clone, Serialize)]
pub struct TestedCl {
    /// Estimate and tested CI95 (the high-pass refit's estimate where the two fits agree and it
    /// is the more precise; `moved_percent` from the fit's own), and the test's parts.
    #[serde(flatten)]
    pub cl: ClMove,
    /// The fit's own CI95, which assumes the model is right \[F\].
    pub model_ci95: [f64; 2],
    /// The interval was widened to ±`fidelity`.
    pub at_fidelity: bool,
    /// The relative half-width the interval is held to (`fidelity`).
    pub fidelity: f64,
}

impl TestedCl {
    /// The nominal's Cl `cl` with its own interval `ci95`, judged with the test `tested` (or why
    /// it was not made) and the nominal's held-out `residual`, and held to `fidelity`.
    pub(crate) fn judged(baseline: &Baseline, cl: f64, ci95: [f64; 2], tested: (Option<ClCheck>, Option<String>), residual: &[f64], fidelity: f64) -> Self {
        let mut judged = ClMove::at(cl, ci95, cl);
        (judged.check, judged.check_skipped) = tested;
        if let Some(check) = judged.check.as_mut() {
            check.model_misses = baseline.misses_above_floor(effect::rms(residual)).unwrap_or(false);
            (judged.estimate, judged.ci95) = check.reported();
            judged.moved_from(cl);
        }
        (judged.ci95, judged.widened_by, judged.misses_by_floors) = baseline.judged_by_miss(judged.estimate, judged.ci95, residual);
        let at_fidelity;
        (judged.ci95, at_fidelity) = at_fidelity_of(judged.estimate, judged.ci95, fidelity);
        Self { cl: judged, model_ci95: ci95, at_fidelity, fidelity }
    }

    /// Not identified where the nominal's inductor current at this Cl contradicts the measured
    /// one ([`CurrentMisfit`]: the nominal's impedance is not the converter's).
    pub(crate) fn against_current(mut self, data: &DataSet, nominal: &Params, n_est: usize) -> Self {
        self.cl.held_to_current(CurrentMisfit::of(data, &Params { cl: self.cl.estimate, ..*nominal }, n_est), None);
        self.at_fidelity &= !self.cl.voided_by_current();
        self
    }

    /// A sentence on the interval's test, for people.
    pub fn sentence(&self) -> String {
        self.cl.sentence(self.at_fidelity.then_some((self.fidelity, CIRCUIT_FIDELITY)))
    }
}

/// Tests the interval of Cl fitted by `base` (a fit of the nominal `nominal` alone, Cl its only
/// free value, on `data` with its first `n_est` samples for estimation). The high-pass refit
/// needs switched data: a base of the averaged model is judged without it.
pub fn tested_cl(data: &DataSet, nominal: &Params, base: &Candidate, n_est: usize) -> TestedCl {
    let baseline = Baseline::of(data, base, n_est, 0.0);
    let ci95 = base.fit.estimate("Cl").map_or([f64::NAN; 2], |e| [e.ci95.0, e.ci95.1]);
    let switched = matches!(base.structure, Structure::Pwm | Structure::Simulated);
    let tested = if switched {
        match consistency::check(data, nominal, &[], baseline.cl, ci95, n_est) {
            Ok(check) => (Some(check), None),
            Err(reason) => (None, Some(reason)),
        }
    } else {
        (None, Some(format!("the {} model was fitted, and the switched simulator that tests the interval stands in for the switched (PWM) model only", base.structure.name())))
    };
    let leverage = if switched { crate::leverage(data, nominal, &[], None, baseline.cl, true, n_est) } else { None };
    let judged = TestedCl::judged(&baseline, baseline.cl, ci95, tested, &effect::residual(base), fidelity(CL_FIDELITY, CIRCUIT_FIDELITY, leverage.as_ref()));
    if switched { judged.against_current(data, nominal, n_est) } else { judged }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An interval narrower than the model's fidelity is widened to it around the estimate; a
    /// wider one, or one that identifies nothing, stays as it is.
    #[test]
    fn cls_interval_is_held_to_the_models_fidelity() {
        let (lo, hi) = (10e-6 / (1.0 + CL_FIDELITY), 10e-6 * (1.0 + CL_FIDELITY));
        let (ci, widened) = at_fidelity_of(10e-6, [9.9995e-6, 10.0003e-6], CL_FIDELITY);
        assert!(widened && (ci[0] - lo).abs() < 1e-15 && (ci[1] - hi).abs() < 1e-15, "{ci:?}");
        // One side already wider: kept.
        let (ci, widened) = at_fidelity_of(10e-6, [9.9e-6, 10.0003e-6], CL_FIDELITY);
        assert!(widened && ci[0] == 9.9e-6 && (ci[1] - hi).abs() < 1e-15, "{ci:?}");
        assert_eq!(at_fidelity_of(10e-6, [9e-6, 11e-6], CL_FIDELITY), ([9e-6, 11e-6], false));
        assert_eq!(at_fidelity_of(10e-6, [0.0, f64::INFINITY], CL_FIDELITY), ([0.0, f64::INFINITY], false));
    }

    /// The interval is held to the base fidelity, or to L's and C's through Cl's leverage on
    /// them where that is wider (Rc's does not count), and says which.
    #[test]
    fn cls_fidelity_grows_with_its_leverage_on_l_and_c() {
        let lever = |pairs: &[(&str, f64)]| pairs.iter().map(|(k, v)| ((*k).to_string(), *v)).collect::<BTreeMap<_, _>>();
        assert_eq!(fidelity(CL_FIDELITY, CIRCUIT_FIDELITY, None), CL_FIDELITY);
        assert_eq!(fidelity(CL_FIDELITY, CIRCUIT_FIDELITY, Some(&lever(&[("C", -3.0), ("L", -5.0)]))), CL_FIDELITY);
        let leaning = fidelity(CL_FIDELITY, CIRCUIT_FIDELITY, Some(&lever(&[("C", -102.6), ("L", -108.1), ("Rc", 4.1)])));
        assert!((leaning - (108.1 * CIRCUIT_FIDELITY).exp_m1()).abs() < 1e-12, "{leaning}");
        assert_eq!(fidelity(CL_FIDELITY_WITH_EFFECTS, CIRCUIT_FIDELITY, Some(&lever(&[("Rc", 500.0), ("C", -60.0)]))), CL_FIDELITY_WITH_EFFECTS);
        assert!(held_to(leaning, CIRCUIT_FIDELITY).contains("±1.1 %") && held_to(leaning, CIRCUIT_FIDELITY).contains("0.01 % of L and C"), "{}", held_to(leaning, CIRCUIT_FIDELITY));
        assert!(!held_to(CL_FIDELITY, CIRCUIT_FIDELITY).contains("leverage"));
        // A model whose effect approximates a device: a leverage of 16.7 on L (harness 3636's
        // saturation knee) holds Cl to ±5.1 %, and says so.
        let device = fidelity(CL_FIDELITY_WITH_EFFECTS, CIRCUIT_FIDELITY_WITH_DEVICES, Some(&lever(&[("C", 10.9), ("L", -16.7)])));
        assert!((device - (16.7 * CIRCUIT_FIDELITY_WITH_DEVICES).exp_m1()).abs() < 1e-12, "{device}");
        assert!(held_to(device, CIRCUIT_FIDELITY_WITH_DEVICES).contains("±5.1 %") && held_to(device, CIRCUIT_FIDELITY_WITH_DEVICES).contains("0.30 % of L and C"));
    }
}
