//! Two effects at once where neither alone is a finding: each circuit effect fitted with a
//! drift of L, C or Rc beside it.
//!
//! Forward selection adds one effect at a time, and each must first be a finding alone. Some
//! show only with a drift beside them. In DCM a diode buck's output level is set by the
//! inductance (each period's current triangle, and the charge it delivers, scales with 1/L):
//! a third-generator thesis buck in DCM 60 % of the time, its inductor 19 % low, was missed by
//! its DCM model more than by the nominal synchronous one, while L's drift on the synchronous
//! model cannot reach DCM's level. Every candidate was worse than the nominal or on a bound:
//! verdict `none` on a model 55 floors off, Cl 1 F. Together, DCM and L's drift leave 3 % of the
//! swing (Cl 40.6 µF for 38.9).
//!
//! So where no single effect is a finding while the nominal misses grossly (see
//! [`crate::effect::gross_miss`]; a small material gap left unexplained is not worth a few
//! dozen fits, and a clean capture's is the parasitics every converter has), every pair of a
//! simulated circuit effect (not the vout reading's calibration or filter, whose pairs with a
//! drift are stand-ins twice over) and one drift is fitted from the grid over Cl. The best, a
//! finding as a pair, starts the forward selection as two steps: the effect as it fitted alone,
//! then the drift judged on top of it.
use buck_model::Params;
use estimator::identify::Candidate;
use estimator::model::Free;
use estimator::simulated::{Criterion, fit_from};
use rayon::prelude::*;

use crate::effect::{DRIFTING, EffectFit, SIMULATED_EFFECTS, SimulatedEffect, Trial, gross_miss, judge, reads_vout, residual, rms};
use crate::problem::Problem;
use crate::select::{Extension, Stack, at_final_values, io_mean};

/// The first two steps of the selection where no single effect is a finding (`effects`, the
/// candidates judged against the nominal fit `base`) while the nominal misses grossly: the
/// best pair of a circuit effect and a drift, where it is a finding as a pair, and the sentence
/// that says so. `None` otherwise.
pub(crate) fn first_steps(p: &Problem, effects: &[EffectFit], base: &Candidate) -> Option<(Vec<EffectFit>, String)> {
    let Problem { data, nominal, n_est, holdout, baseline, .. } = *p;
    gross_miss(baseline.rms, baseline.floor, baseline.swing)?;
    let io = io_mean(data);
    let start = Params { cl: baseline.cl, ..*nominal };
    let alone = |e: &SimulatedEffect| effects.iter().find(|f| f.name == e.name);
    let pairs: Vec<(&SimulatedEffect, Free)> = SIMULATED_EFFECTS.iter().filter(|e| !reads_vout(e.name) && alone(e).is_some()).flat_map(|e| DRIFTING.map(|f| (e, f))).collect();
    let fitted: Vec<(&SimulatedEffect, Free, Candidate)> = pairs
        .into_par_iter()
        .filter_map(|(e, f)| {
            let free: Vec<Free> = std::iter::once(Free::Cl).chain(e.extra.iter().map(|&(x, _)| x)).chain([f]).collect();
            fit_from(data, &e.starts(&start, io), &free, n_est, Criterion::OutputError).ok().map(|c| (e, f, c))
        })
        .collect();
    let (effect, drift, cand) = fitted.into_iter().min_by(|a, b| rms(&residual(&a.2)).total_cmp(&rms(&residual(&b.2))))?;
    // The pair judged against the nominal as one candidate (a different model class: by
    // Akaike's criterion).
    let value = cand.fit.estimate(drift.name())?;
    let (mut params, mut ci95) = effect.report(&cand, data).ok()?;
    params.insert(drift.name().to_string(), value.value);
    ci95.insert(drift.name().to_string(), [value.ci95.0, value.ci95.1]);
    let relative = value.value / drift.get(nominal) - 1.0;
    let trial = Trial { cand: cand.clone(), params, ci95, extra: effect.extra.len() + 1, not_nested: true, drift: Some(relative) };
    let (pair, _) = judge(effect.name, trial, base, n_est, baseline);
    if !pair.finding {
        return None;
    }
    // The effect as it fitted alone, at the pair's values; then the drift on top of it.
    let mut first = alone(effect)?.clone();
    at_final_values(std::slice::from_mut(&mut first), &cand, nominal);
    let without = Stack::of(&[&first], nominal, first.cl.estimate, true).ok()?;
    let against = without.fit(data, &[without.params], n_est, holdout).ok()?;
    let mut with = without.clone();
    with.free.push(drift);
    with.params = cand.fit.params;
    let t = Extension::within(&with, "param_drift", &[drift], against.fit.params).assess(cand, data, nominal).ok()?;
    let (mut second, _) = judge("param_drift", t, &against, n_est, baseline);
    second.rebase(baseline, rms(&residual(&against)), baseline.rms);
    let closed = pair.closed_percent?;
    let note = format!("no single effect is a finding; {} with a drift of {} ({:+.1} %) closes {closed:.1} % of the gap over the floor together", effect.name, drift.name(), 100.0 * relative);
    Some((vec![first, second.into_step()], note))
}
