//! A ceramic's DC-bias law between the voltages the data visits.
//!
//! A PRBS on the duty holds the output near its two levels: the data shows Cl there and little
//! of the law's shape between them. Reported at the data's mean output ([`crate::bias_reference`]),
//! Cl is the law's value between the levels, which its curvature decides: the quadratic law's
//! concave `1 − b·x²` put a ceramic following `Cl₀/√(1 + (v/V₀)²)` (convex) 2.3 % high at a
//! 5 V point-of-load buck, with an interval of ±0.1 %. So a final model that carries
//! `cap_dc_bias` is refitted with the other shape ([`buck_model::BiasLaw`]): where the data tells the two
//! apart (a likelihood ratio beyond its 1 % point), the better one's Cl and parameters are reported; where it
//! does not, Cl's interval spans both laws' (a type-B term for the law, like the interval
//! test's for the model).
use buck_model::Params;
use estimator::identify::Candidate;
use estimator::validate::chi2_99;
use serde::Serialize;

use crate::effect::{EffectFit, held_out_likelihood_ratio, residual, rms};
use crate::problem::Problem;
use crate::select::Stack;

/// Cl under the other bias law.
#[derive(Debug, Clone, Serialize)]
pub struct BiasLawSpread {
    /// The law of the final model.
    pub law: &'static str,
    /// Cl under the final model's law \[F\].
    pub law_cl: f64,
    /// Its CI95 \[F\].
    pub law_ci95: [f64; 2],
    /// The other law, refitted.
    pub other: &'static str,
    /// Cl under the other law \[F\].
    pub other_cl: f64,
    /// Its CI95 \[F\].
    pub other_ci95: [f64; 2],
    /// `n·ln(σ²_other/σ²_final)` over the `n` held-out samples (the two laws have as many
    /// parameters): positive where the final law predicts better.
    pub likelihood_ratio: f64,
    /// The data tells the laws apart (the ratio beyond its 1 % point either way).
    pub told_apart: bool,
    /// The better law's model leaves no miss above the noise floor (`None`: no floor
    /// to judge by): its shape is taken for the ceramic's, and its Cl is reported alone where
    /// the laws are told apart.
    pub fits_to_floor: Option<bool>,
}

impl BiasLawSpread {
    /// The final model `selected` (carrying `cap_dc_bias`) refitted with the other law, when it
    /// can be, and that refit; `None` otherwise.
    pub(crate) fn of(p: &Problem, selected: &[EffectFit]) -> Option<(Self, Candidate)> {
        let Problem { data, nominal, n_est, holdout, baseline, .. } = *p;
        let last = selected.last()?;
        if !selected.iter().any(|e| e.name == "cap_dc_bias") {
            return None;
        }
        let fits: Vec<&EffectFit> = selected.iter().collect();
        let stack = Stack::of(&fits, nominal, last.cl.estimate, true).ok()?;
        let law = stack.params.cap_bias_law;
        let alt = stack.fit(data, &[Params { cap_bias_law: law.other(), ..stack.params }], n_est, holdout).ok()?;
        let cl = alt.fit.estimate("Cl")?;
        let rms_other = rms(&residual(&alt));
        let likelihood_ratio = held_out_likelihood_ratio(rms_other, last.rms_after, data.len() - n_est);
        let fits_to_floor = baseline.misses_above_floor(rms_other.min(last.rms_after)).map(|misses| !misses);
        let spread = Self {
            law: law.name(),
            law_cl: last.cl.estimate,
            law_ci95: last.cl.ci95,
            other: law.other().name(),
            other_cl: cl.value,
            other_ci95: [cl.ci95.0, cl.ci95.1],
            likelihood_ratio,
            told_apart: likelihood_ratio.abs() > chi2_99(1),
            fits_to_floor,
        };
        Some((spread, alt))
    }

    /// The data prefers the other law: its fit is the one to report, Cl and the parameters.
    pub fn prefers_other(&self) -> bool {
        self.told_apart && self.likelihood_ratio < 0.0
    }

    /// The data says which shape the ceramic has: the laws told apart, and the better one
    /// fitting to the floor (or no floor to judge by).
    pub fn resolved(&self) -> bool {
        self.told_apart && self.fits_to_floor != Some(false)
    }

    /// Cl and its CI95 to report, from the final law's `cl` and `ci95`: the other law's where
    /// the data prefers it.
    pub fn reported(&self, cl: f64, ci95: [f64; 2]) -> (f64, [f64; 2]) {
        if self.prefers_other() { (self.other_cl, self.other_ci95) } else { (cl, ci95) }
    }

    /// The reported law's interval `ci95` (a finite one), spanning both laws' where the data
    /// does not resolve the shape ([`Self::resolved`]): a type-B term, added after any
    /// widening for the model error (the shape's spread is no statistical error to inflate).
    pub fn spanned(&self, ci95: [f64; 2]) -> [f64; 2] {
        if self.resolved() {
            return ci95;
        }
        crate::effect::spanning(ci95, &[self.law_ci95, self.other_ci95])
    }
}

/// Where a biased ceramic's Cl is reported: at the converter's operating point, the output
/// voltage `vout_time_mean` averaged in time over the record as the final circuit `p` runs on
/// the data's inputs ([`estimator::simulated::operation`]). The law is anchored at the mean of
/// the samples for the fits ([`crate::bias_reference`]), but they are all taken at one phase of
/// the ripple: at a thesis-scale ripple 34 mV below the average, which put Cl under a law losing
/// 0.013 %/mV there 0.45 % high, outside its ±0.2 % interval. The voltage, and Cl's ratio there
/// to Cl at the law's reference; `None` without a bias law.
pub(crate) fn operating_point(p: &Params, vout_time_mean: f64) -> Option<(f64, f64)> {
    if p.cap_dc_bias == 0.0 {
        return None;
    }
    let ratio = p.cl_at(vout_time_mean) / p.cl;
    (ratio.is_finite() && ratio > 0.0).then_some((vout_time_mean, ratio))
}

impl std::fmt::Display for BiasLawSpread {
    /// One sentence for people.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let other = format!("the {} bias law gives {:.4} µF", self.other, self.other_cl * 1e6);
        match (self.told_apart, self.resolved(), self.likelihood_ratio < 0.0) {
            (true, true, false) => write!(f, "{other}, and the data prefers the {} (likelihood ratio {:.1})", self.law, self.likelihood_ratio),
            (true, true, true) => write!(f, "{other}, which the data prefers (likelihood ratio {:.1}): its Cl and parameters are reported", -self.likelihood_ratio),
            (true, false, false) => write!(
                f,
                "{other}; the data prefers the {} (likelihood ratio {:.1}), but its model still misses above the noise floor, so neither shape is the ceramic's and the interval spans both",
                self.law, self.likelihood_ratio
            ),
            (true, false, true) => write!(
                f,
                "{other}, which the data prefers (likelihood ratio {:.1}): its Cl and parameters are reported; its model still misses above the noise floor, so neither shape is the ceramic's and the interval spans both",
                -self.likelihood_ratio
            ),
            (false, ..) => write!(f, "{other}; the data does not tell the laws apart, so the interval spans both"),
        }
    }
}
