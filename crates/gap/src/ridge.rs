//! The ridge between the output capacitor and the load's: a load capacitance small beside the
//! output capacitor (a ceramic's microfarad beside a bulk's hundreds) changes the output's
//! impedance as nearly the same capacitance added to C would. Only the output capacitor's ESR
//! tells the two apart, and where the data barely shows it, a fit that ends at one end of the
//! ridge says nothing of the other: our plant as a lab buck with 1.3 µF beside 330 µF, C 11 %
//! above its nominal, ended on a load ESR and the switches with Cl 37.8 µF, C's drift taken up
//! by Cl; with C +11.0 % and Cl 1.27 µF it fits as well (3.880 mV held out against 3.933).
//!
//! The ridge has two ends: a fit may also put the load's capacitance into C's drift. A diode
//! buck from the third generator with 2.77 µF of load beside 88 µF (and a 118 µF bulk) ended on
//! eight effects with C +2.25 % and Cl 0.020 [0.010, 0.089] µF; with that drift moved into Cl,
//! C at its nominal and Cl 2.31 µF, it fits as well (1.667 mV held out against 1.81). (That
//! path started from a dead time; the board is now read from its diode, see
//! `select::RIVAL_CLOSED`, and no dataset held here reaches the other end's probes.)
//!
//! The probe refits the final model with C free, started from Cl's capacitance moved into C,
//! and, where the final model has C drifted up beyond the tolerance, from that drift moved into
//! Cl. Where it lands as good held out, with C moved beyond the tolerance and Cl elsewhere, it is
//! the final model's twin: Cl's interval spans both.
use buck_model::Params;
use estimator::model::Free;
use estimator::validate::chi2_99;
use rayon::prelude::*;

use crate::effect::{EffectFit, MAX_DRIFT, Twin, gross_miss, held_out_likelihood_ratio, residual, rms};
use crate::problem::Problem;
use crate::select::Stack;

/// Shares of Cl's capacitance the probes start C with (the rest stays Cl's), and of C's drift up
/// the probes from the other end start Cl with, one probe each: a valley along the ridge may lie
/// short of its far end. Our plant with 20 µF beside C 11 % high, fitted at Cl 56 µF, stopped at
/// C +13 % from 95 % (4.17 mV held out against 3.88), and was as good at C +7.8 % from half.
const MOVED_INTO_C: [f64; 2] = [0.5, 0.95];

/// Whether a model leaving `rms` held out (over `n` samples) is as good as one leaving `against`:
/// the likelihood ratio of the other on the held-out data ([`held_out_likelihood_ratio`]) within
/// its 99 % point for one parameter. Its held-out residual a hair above the final model's, a
/// probe is as good (our plant's 20 µF beside C 11 % high: 3.8792 mV against 3.8790); 3 % more
/// power over 900 samples (a point-of-load buck's probe, C +14.6 % where C is at its nominal) is
/// not.
fn as_good(rms: f64, against: f64, n: usize) -> bool {
    held_out_likelihood_ratio(rms, against, n) <= chi2_99(1)
}

/// The final model `selected` refitted with C free from Cl's capacitance moved into C, and from
/// C's drift up moved into Cl (from each of [`MOVED_INTO_C`]), where C moved beyond the
/// tolerance (within [`MAX_DRIFT`] of its nominal), Cl lies outside the final interval `ci95`
/// and the fit is as good ([`as_good`]): a twin of the final model (of several, the one that
/// leaves least). Switched data and model only.
pub(crate) fn twin(p: &Problem, selected: &[EffectFit], ci95: [f64; 2]) -> Option<Twin> {
    let Problem { data, nominal, switched_nominal, switched_data, n_est, holdout, baseline } = *p;
    let last = selected.last()?;
    // (A final model that misses grossly has no Cl to span: `Baseline::judged_by_miss`.)
    if !switched_data || !estimator::validate::identified(ci95) || gross_miss(last.rms_after, baseline.floor, baseline.swing).is_some() {
        return None;
    }
    let fits: Vec<&EffectFit> = selected.iter().collect();
    let mut stack = Stack::of(&fits, nominal, last.cl.estimate, switched_nominal).ok()?;
    if !stack.switched {
        return None;
    }
    if !stack.free.contains(&Free::C) {
        stack.free.push(Free::C);
    }
    // The final model's effects, C's drift (where it has one) left to be named with its new value.
    let kept: Vec<String> = selected.iter().map(EffectFit::label).filter(|l| l != "param_drift (C)").collect();
    // Cl's capacitance moved into C; and where the final model has C drifted up beyond the
    // tolerance, that drift moved into Cl (a load small beside C, its capacitance taken up by C's
    // drift, sits at the ridge's other end).
    let excess = stack.params.c - nominal.c;
    let moved = |share: f64, amount: f64| Params { c: stack.params.c + share * amount, cl: last.cl.estimate - share * amount, ..stack.params };
    let mut starts: Vec<Params> = MOVED_INTO_C.iter().map(|&share| moved(share, last.cl.estimate)).collect();
    if excess > baseline.tolerance * nominal.c {
        starts.extend(MOVED_INTO_C.iter().map(|&share| moved(share, -excess)));
    }
    let probe = |start: &Params| {
        let probe = stack.fit(data, std::slice::from_ref(start), n_est, holdout).ok()?;
        let rms_after = rms(&residual(&probe));
        let c = probe.fit.params.c;
        let c_moved = (c / stack.params.c - 1.0).abs() > baseline.tolerance && (c / nominal.c - 1.0).abs() <= MAX_DRIFT;
        let (cl, ci95_probe) = probe.fit.estimate("Cl").map_or((f64::NAN, [0.0, f64::INFINITY]), |e| (e.value, [e.ci95.0, e.ci95.1]));
        let outside = !(ci95[0]..=ci95[1]).contains(&cl);
        (as_good(rms_after, last.rms_after, baseline.held_out) && c_moved && outside).then(|| {
            let drift = format!("param_drift (C) {:+.1} %", 100.0 * (c / nominal.c - 1.0));
            Twin { selected: kept.iter().cloned().chain([drift]).collect(), rms_after, cl, ci95: ci95_probe }
        })
    };
    starts.par_iter().filter_map(probe).collect::<Vec<_>>().into_iter().min_by(|a, b| a.rms_after.total_cmp(&b.rms_after))
}
