//! The candidate effects: each is the nominal model plus that effect, fitted together with Cl
//! on the estimation part and judged on the held-out part.
use std::collections::BTreeMap;

use buck_model::Params;
use estimator::data::DataSet;
use estimator::identify::{Candidate, IdentifyOptions, identify};
use estimator::model::{Free, Structure};
use estimator::simulated::Criterion;
use rayon::prelude::*;

use crate::effect::{Baseline, DELAYS, DRIFTING, EffectFit, NotTested, SIMULATED_EFFECTS, Trial, delayed, held_out_nrmse, judge, residual, rms, variance};
use crate::options::{DiagnoseOptions, Nominal, nominal_options};

fn run(data: &DataSet, nominal: &Params, opts: IdentifyOptions) -> Result<Candidate, String> {
    identify(data, nominal, &opts).map(|id| id.best().clone()).map_err(|e| e.to_string())
}

/// What [`fit_all`] found.
pub(crate) struct Fitted {
    /// Every candidate that was fitted.
    pub effects: Vec<EffectFit>,
    /// The others, with the reason.
    pub not_tested: Vec<NotTested>,
    /// The data is switched (the ripple significant, or in the nominal model): the plant
    /// simulator can fit it.
    pub switched: bool,
}

/// Fits every modelled candidate; those whose fit fails (e.g. not identifiable) are returned as
/// not tested, with the reason.
///
/// Two stages: `switching_ripple` (the PWM model instead of the averaged one) is judged against
/// the nominal model first. When it is significant the ripple may be in the data whatever else
/// is, so every other candidate is fitted on the averaged and on the PWM model, and the better
/// held-out fit is judged against the model it extends.
///
/// The circuit effects `diode_drop`, `dcm`, `dead_time`, `pulse_width_distortion`,
/// `inductor_saturation`, `cap_dc_bias`, `load_esr` and `esl` are fitted on switched data only,
/// with the plant simulator itself (`estimator::simulated`: nonlinear, exact through DCM and
/// every state event) and `[Cl, effect]` free, judged against the simulator with Cl alone.
/// `adc_quantization` is detected in the readings (see `quantization`).
pub(crate) fn fit_all(data: &DataSet, nominal: &Params, opts: &DiagnoseOptions, base: &Candidate, baseline: &Baseline, n_est: usize) -> Fitted {
    let nominal_opts = nominal_options(opts);
    let judge = |name, t: Trial, against: &Candidate| judge(name, t, against, n_est, baseline);

    // With a switched nominal the ripple is already in the model: no `switching_ripple`
    // candidate, and everything is judged against the nominal.
    let mut not_tested = Vec::new();
    let ripple = match (opts.nominal == Nominal::Averaged).then(|| run(data, nominal, IdentifyOptions { structures: vec![Structure::Pwm], ..nominal_opts.clone() })) {
        Some(Err(e)) => {
            not_tested.push(NotTested { name: "switching_ripple", reason: format!("the PWM model's fit failed: {e}") });
            None
        }
        fit => fit.and_then(Result::ok),
    }
    .map(|cand| judge("switching_ripple", Trial { cand, params: BTreeMap::new(), ci95: BTreeMap::new(), extra: 0, not_nested: false, drift: None }, base));
    // Every other candidate is one effect on the nominal model. Effects on top of the ripple
    // (averaged nominal, switched data) are the forward selection's second step (`select`).
    let pwm_base = ripple.as_ref().filter(|r| r.0.significant).map(|r| &r.1);
    let switched_base = pwm_base.unwrap_or(base);
    let switched = pwm_base.is_some() || opts.nominal == Nominal::Switched;
    let grey_box = || {
        let mut best: Vec<(&'static str, Trial)> = Vec::new();
        let mut failed: Vec<NotTested> = Vec::new();
        for (name, trial) in effect_trials(data, nominal, &nominal_opts, base.fit.estimate("Cl").map(|e| e.value)) {
            match trial {
                Ok(t) => best.push((name, t)),
                Err(reason) => failed.push(NotTested { name, reason }),
            }
        }
        (best, failed)
    };
    // The nonlinear effects with the plant simulator itself, when the nominal is switched, in
    // parallel with the grey-box candidates.
    let simulated = || -> (Vec<EffectFit>, Vec<NotTested>) {
        let untested = |reason: &str| SIMULATED_EFFECTS.iter().map(|e| NotTested { name: e.name, reason: reason.to_string() }).collect();
        if opts.nominal != Nominal::Switched {
            let reason = if switched {
                "switched-circuit effect: fitted on top of switching_ripple (see `selected`), not on the averaged nominal"
            } else {
                "switched-circuit effect: needs switched data (the ripple in the data or in the nominal model)"
            };
            return (Vec::new(), untested(reason));
        }
        // Judged against the simulator with Cl alone (the same criterion window and initial
        // state treatment), and placed on the others' AIC scale through the model it extends.
        let cl = switched_base.fit.estimate("Cl").map_or(nominal.cl, |e| e.value);
        let start = Params { cl, ..*nominal };
        let sigma = baseline.floor.unwrap_or_else(|| switched_base.fit.sigma[0]);
        let (reference, (trials, limits)) = rayon::join(
            || estimator::simulated::fit(data, &start, &[Free::Cl], n_est),
            || rayon::join(|| simulated_trials(data, &start, n_est), || crate::limits::upper_limits(data, &start, sigma, n_est)),
        );
        // Where the simulator with Cl alone cannot fit the data (e.g. DCM data, which no
        // diode-free circuit follows), the effects are judged against the model they extend,
        // by Akaike's criterion (not nested in it).
        let (reference, not_nested) = match &reference {
            Ok(r) => (r, false),
            Err(_) => (switched_base, true),
        };
        let offset = n_est as f64 * (variance(switched_base).ln() - variance(reference).ln());
        let mut fits = Vec::new();
        let mut failed = Vec::new();
        for (name, trial) in trials {
            match trial {
                Ok(mut trial) => {
                    trial.not_nested |= not_nested;
                    let late = (name == "sample_delay").then_some(trial.cand.fit.params);
                    let mut fit = judge(name, trial, reference).0;
                    fit.rebase(baseline, rms(&residual(reference)), rms(&residual(switched_base)));
                    fit.aic += offset;
                    if let Some(late) = late.filter(|_| !not_nested) {
                        fit.judge_in_il(data, &reference.fit.params, &late, n_est, baseline.tolerance);
                    }
                    fit.ruled_out_above = limits.get(name).copied().filter(|_| !fit.significant);
                    fits.push(fit);
                }
                Err(e) => failed.push(NotTested { name, reason: format!("its fit failed: {e}") }),
            }
        }
        (fits, failed)
    };
    let ((best, grey_box_failed), (mut extra, simulated_failed)) = rayon::join(grey_box, simulated);
    not_tested.extend(grey_box_failed);
    not_tested.extend(simulated_failed);
    if let Some(fit) = crate::quantization::candidate(data, switched_base, n_est, baseline) {
        extra.push(fit);
    }
    let mut out: Vec<EffectFit> = best.into_iter().map(|(name, trial)| judge(name, trial, base).0).collect();
    out.extend(ripple.map(|r| r.0));
    out.extend(extra);
    Fitted { effects: out, not_tested, switched }
}

/// Fits each nonlinear effect with `[Cl, its parameters]` free on the plant simulator, from the
/// circuit values `start` (Cl from the model it extends).
/// An effect whose fit fails is returned with the reason.
fn simulated_trials(data: &DataSet, start: &Params, n_est: usize) -> Vec<(&'static str, Result<Trial, String>)> {
    let io = crate::select::io_mean(data);
    SIMULATED_EFFECTS
        .par_iter()
        .map(|effect| {
            let starts = effect.starts(start, io);
            let free: Vec<Free> = std::iter::once(Free::Cl).chain(effect.extra.iter().map(|&(f, _)| f)).collect();
            let trial = estimator::simulated::fit_from(data, &starts, &free, n_est, Criterion::OutputError).map_err(|e| e.to_string()).and_then(|cand| {
                let (params, ci95) = effect.report(&cand, data)?;
                Ok(Trial { cand, params, ci95, extra: effect.extra.len(), not_nested: effect.dcm, drift: None })
            });
            (effect.name, trial)
        })
        .collect()
}

/// The fit with the lowest held-out error of several tries, or why none fitted.
fn best_of<K>(tries: impl Iterator<Item = (K, Result<Candidate, String>)>) -> Result<(K, Candidate), String> {
    let mut best: Option<(K, Candidate)> = None;
    let mut errors = Vec::new();
    for (k, fit) in tries {
        match fit {
            Ok(c) if best.as_ref().is_none_or(|b| held_out_nrmse(&c) < held_out_nrmse(&b.1)) => best = Some((k, c)),
            Ok(_) => {}
            Err(e) => errors.push(e),
        }
    }
    best.ok_or_else(|| format!("its fit failed: {}", errors.join("; ")))
}

/// `opts`' fit from its grid and from the nominal's fit (`cl`: the nominal's Cl, every other
/// free value at its nominal), whichever leaves the less estimation error. The grid is ranked on
/// the first samples only, and where a value trades against Cl its best point can lie in the
/// wrong valley: a third-generator lab buck whose 280 µF electrolytic is 16 % high had C's
/// drift fitted from the grid to 350 µF with Cl at its 1 nF bound, worse held out than the
/// nominal, and Cl took up the drift behind a 338 mΩ load ESR, 49.6 [49.1, 50.1] µF for 5.65.
fn run_also_from(data: &DataSet, nominal: &Params, opts: IdentifyOptions, cl: Option<f64>) -> Result<Candidate, String> {
    let grid = run(data, nominal, opts.clone());
    let Some(cl) = cl else { return grid };
    less_estimation_error(grid, run(data, nominal, IdentifyOptions { cl_guess: Some(cl), ..opts }))
}

/// Of two fits of one model from different starts, the one that leaves the less estimation
/// error (`vout`'s residual); the one that succeeded where the other failed (`a` on a tie).
pub(crate) fn less_estimation_error(a: Result<Candidate, String>, b: Result<Candidate, String>) -> Result<Candidate, String> {
    let error = |c: &Candidate| c.fit.sigma.first().copied().unwrap_or(f64::INFINITY);
    match (a, b) {
        (Ok(a), Ok(b)) => Ok(if error(&b) < error(&a) { b } else { a }),
        (a, b) => a.or(b),
    }
}

/// The candidates other than the structure: each one's fit on top of `base_opts` (from the
/// nominal's fit, Cl `base_cl`, too), or why it could not be made.
fn effect_trials(data: &DataSet, nominal: &Params, base_opts: &IdentifyOptions, base_cl: Option<f64>) -> Vec<(&'static str, Result<Trial, String>)> {
    // param_drift: one "known" value freed (the best of L, C, Rc).
    let drift = best_of(DRIFTING.into_iter().map(|f| (f, run_also_from(data, nominal, IdentifyOptions { free: vec![Free::Cl, f], ..base_opts.clone() }, base_cl)))).and_then(|(f, cand)| {
        let e = cand.fit.estimate(f.name()).copied().ok_or_else(|| format!("no estimate of {}", f.name()))?;
        let params = BTreeMap::from([(f.name().to_string(), e.value), (format!("{}_nominal", f.name()), f.get(nominal))]);
        let ci95 = BTreeMap::from([(f.name().to_string(), [e.ci95.0, e.ci95.1])]);
        Ok(Trial { cand, params, ci95, extra: 1, not_nested: false, drift: Some(e.value / f.get(nominal) - 1.0) })
    });
    // switch_resistance: extra series resistance on top of RL (a fitted RL below the nominal is
    // not this effect: resistance is only ever added).
    let resistance = run_also_from(data, nominal, IdentifyOptions { free: vec![Free::Cl, Free::RL], ..base_opts.clone() }, base_cl).map_err(|e| format!("its fit failed: {e}")).and_then(|cand| {
        let e = cand.fit.estimate("RL").copied().ok_or("no estimate of RL")?;
        if e.value <= nominal.rl {
            return Err(format!("the fitted series resistance {:.2} mΩ is not above the nominal RL {:.2} mΩ: none is added", e.value * 1e3, nominal.rl * 1e3));
        }
        let params = BTreeMap::from([("switch_resistance".to_string(), e.value - nominal.rl)]);
        let ci95 = BTreeMap::from([("switch_resistance".to_string(), [e.ci95.0 - nominal.rl, e.ci95.1 - nominal.rl])]);
        Ok(Trial { cand, params, ci95, extra: 1, not_nested: false, drift: None })
    });
    // delay: the duty drives the switch 1 or 2 periods late, or the readings were taken a
    // period late (a file whose outputs are each period's last, not its first).
    let delay = best_of(DELAYS.into_iter().map(|n| (n, run(&delayed(data, n), nominal, base_opts.clone())))).map(|(n, cand)| {
        let params = BTreeMap::from([("delay".to_string(), n as f64)]);
        Trial { cand, params, ci95: BTreeMap::new(), extra: 1, not_nested: true, drift: None }
    });
    vec![("param_drift", drift), ("switch_resistance", resistance), ("delay", delay)]
}
