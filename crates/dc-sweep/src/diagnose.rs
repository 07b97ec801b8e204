//! Which DC effects explain the gap between a measured sweep and the nominal model.
//!
//! Each candidate effect adds parameters to the DC model ([`crate::model`]); they are fitted by
//! Levenberg–Marquardt (numerical central-difference Jacobian, scaled) to the measured mean
//! output voltages. The covariance is `s²·(JᵀJ)⁻¹` with `s² = SSE/(n − p)`, the CI95 uses the
//! t quantile for `n − p` degrees of freedom. **Forward selection**: each round fits every
//! remaining candidate on top of the effects selected so far and adds the one that lowers the
//! residual most among those that are
//! - *significant*: the F test of the added parameters against the model it extends, p < 0.05
//!   (an effect without parameters, `dcm`, must lower the residual),
//! - *identified*: every CI95 finite, of positive width, and no wider (half-width) than ten
//!   times its estimate,
//! - *physical*: its parameters positive,
//! - *material*: it removes at least [`Options::min_share`] of the residual power left and
//!   lowers the residual RMS by more than [`Options::min_rms`],
//!
//! and repeats until no candidate qualifies. Where the data cannot carry a fit (fewer distinct
//! operating points than parameters + 2, or no variation at all) it says so instead of giving
//! numbers.
use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::data::Sweep;
use crate::error::SweepError;
use crate::model::{Circuit, Effects, check_circuit, solve};
use crate::stats::{f_upper_tail, t_quantile};

/// A candidate DC effect (names as in the design's effect table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Effect {
    /// Asynchronous (diode) buck with forward drop `vf` \[V\]; DCM at light load follows.
    DiodeDrop,
    /// Series resistance `r_series` \[Ω\] beyond the nominal `RL`, in the inductor path all
    /// period: switch on-resistance plus any extra series resistance (design: extra series
    /// resistance counts as `switch_resistance`).
    SwitchResistance,
    /// Dead time `td` \[s\] before each turn-on of a synchronous buck.
    DeadTime,
    /// Discontinuous conduction: an ideal freewheeling diode (no parameter).
    Dcm,
    /// The inductance `l` \[H\] off its nominal value (matters in DC only through DCM).
    ParamDrift,
}

impl Effect {
    /// Every candidate, in the order they are reported on ties.
    pub const ALL: [Effect; 5] = [Effect::DiodeDrop, Effect::SwitchResistance, Effect::DeadTime, Effect::Dcm, Effect::ParamDrift];

    /// The contract name (CLI/JSON).
    pub fn name(self) -> &'static str {
        match self {
            Effect::DiodeDrop => "diode_drop",
            Effect::SwitchResistance => "switch_resistance",
            Effect::DeadTime => "dead_time",
            Effect::Dcm => "dcm",
            Effect::ParamDrift => "param_drift",
        }
    }

    /// Names of its parameters (units in [`Effect`]'s variants).
    pub fn params(self) -> &'static [&'static str] {
        match self {
            Effect::DiodeDrop => &["vf"],
            Effect::SwitchResistance => &["r_series"],
            Effect::DeadTime => &["td"],
            Effect::Dcm => &[],
            Effect::ParamDrift => &["l"],
        }
    }

    /// Typical size of each parameter (step scale of the fit).
    fn scale(self, c: &Circuit) -> f64 {
        match self {
            Effect::DiodeDrop => 0.1,
            Effect::SwitchResistance => 0.01,
            Effect::DeadTime => 1e-8,
            Effect::Dcm => 1.0,
            Effect::ParamDrift => 0.1 * c.l,
        }
    }

    /// Start values tried for its parameter.
    fn starts(self, c: &Circuit) -> Vec<f64> {
        match self {
            Effect::DiodeDrop => vec![0.3, 0.7],
            Effect::SwitchResistance => vec![0.01, 0.1, 1.0],
            Effect::DeadTime => vec![2e-8, 1e-7],
            Effect::Dcm => vec![],
            Effect::ParamDrift => vec![0.5 * c.l, 2.0 * c.l],
        }
    }

    fn apply(self, theta: &[f64], c: &mut Circuit, e: &mut Effects) {
        match self {
            Effect::DiodeDrop => {
                e.diode = true;
                e.diode_drop = theta[0];
            }
            Effect::SwitchResistance => e.r_series = theta[0],
            Effect::DeadTime => e.dead_time = theta[0],
            Effect::Dcm => e.diode = true,
            Effect::ParamDrift => c.l = theta[0],
        }
    }
}

/// Thresholds of the forward selection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Least share of the residual power left that an effect must remove (default 0.2).
    pub min_share: f64,
    /// Least drop of the residual RMS an effect must bring \[V\] (default 5 mV).
    pub min_rms: f64,
    /// Significance level of the F test (default 0.05).
    pub alpha: f64,
}

impl Default for Options {
    fn default() -> Self {
        Self { min_share: 0.2, min_rms: 5e-3, alpha: 0.05 }
    }
}

/// Residual size: RMS \[V\] and NRMSE (RMS over the standard deviation of the measured vout;
/// `None` when the measurements do not vary).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Gap {
    /// NRMSE of the residual.
    pub nrmse: Option<f64>,
    /// RMS of the residual \[V\].
    pub rms: f64,
}

/// The gap at one operating point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PointGap {
    /// Duty.
    pub duty: f64,
    /// Input voltage \[V\].
    pub vin: f64,
    /// Constant-current load \[A\].
    pub io: f64,
    /// Load resistor \[Ω\], if any.
    pub rload: Option<f64>,
    /// Total load current at the measured vout \[A\].
    pub load: f64,
    /// Measured mean vout \[V\].
    pub measured: f64,
    /// The nominal model's vout \[V\].
    pub expected: f64,
    /// `measured − expected` \[V\].
    pub residual: f64,
    /// The vout of the nominal model with the selected effects \[V\].
    pub fitted: f64,
    /// `measured − fitted` \[V\].
    pub residual_after: f64,
}

/// Where the nominal model misses.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Where {
    /// The gap per operating point, in file order.
    pub by_operating_point: Vec<PointGap>,
}

/// One candidate fitted on top of the nominal model (the `effects` list) or of the effects
/// selected before it (a forward-selection step).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EffectFit {
    /// Contract name.
    pub name: &'static str,
    /// Fitted parameters, `None` when the data cannot support them (see `note`).
    pub params: Option<BTreeMap<String, f64>>,
    /// CI95 of each parameter.
    pub ci95: Option<BTreeMap<String, [f64; 2]>>,
    /// Residual RMS with the effect \[V\].
    pub rms_after: Option<f64>,
    /// Residual NRMSE with the effect.
    pub nrmse_after: Option<f64>,
    /// How much the NRMSE shrank against the nominal model [%].
    pub shrink_percent: Option<f64>,
    /// Share of the nominal model's residual power closed [%].
    pub closed_percent: Option<f64>,
    /// p-value of the F test against the model it extends (`None` without parameters).
    pub p_value: Option<f64>,
    /// Passes the F test.
    pub significant: bool,
    /// Every parameter identified (finite CI95 of positive width, no wider than ×10).
    pub identifiable: bool,
    /// Parameters positive.
    pub physical: bool,
    /// Removes a material share of the residual left.
    pub material: bool,
    /// Why there are no numbers, or what else to know.
    pub note: Option<String>,
}

impl EffectFit {
    /// An effect not (yet) fitted, with why.
    fn untested(name: &'static str, note: Option<String>) -> Self {
        Self {
            name,
            params: None,
            ci95: None,
            rms_after: None,
            nrmse_after: None,
            shrink_percent: None,
            closed_percent: None,
            p_value: None,
            significant: false,
            identifiable: false,
            physical: false,
            material: false,
            note,
        }
    }
}

/// The final model: every selected effect's parameters from the last joint fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FinalFit {
    /// Parameters per effect.
    pub params: BTreeMap<String, BTreeMap<String, f64>>,
    /// Their CI95.
    pub ci95: BTreeMap<String, BTreeMap<String, [f64; 2]>>,
    /// Residual after it.
    pub gap: Gap,
}

/// The diagnosis of a sweep (the JSON shape of the time-series diagnosis).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Diagnosis {
    /// False when the data cannot support any fit (`message` says why).
    pub supported: bool,
    /// Why not, in plain words.
    pub message: Option<String>,
    /// Operating points, and how many of them differ.
    pub points: usize,
    /// Distinct operating points (duty, vin, io, rload).
    pub distinct_points: usize,
    /// The nominal model's residual.
    pub gap_before: Gap,
    /// Where it misses.
    #[serde(rename = "where")]
    pub location: Where,
    /// Each candidate alone on the nominal model, best first.
    pub effects: Vec<EffectFit>,
    /// The forward-selection sequence.
    pub selected: Vec<EffectFit>,
    /// The forward selection within each topology; `selected` is the better by AIC.
    pub branches: Vec<Branch>,
    /// The joint fit of the selected effects.
    #[serde(rename = "final")]
    pub final_fit: Option<FinalFit>,
    /// The first selected effect, or `"none"`.
    pub verdict: String,
}

/// The forward selection within one topology.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Branch {
    /// `synchronous` (dead time allowed) or `asynchronous` (diode, DCM allowed).
    pub topology: &'static str,
    /// The effects it selected, in order.
    pub selected: Vec<&'static str>,
    /// Residual RMS of its final model \[V\].
    pub rms: f64,
    /// Akaike's criterion `n·ln(SSE/n) + 2·p` of its final model.
    pub aic: f64,
}

/// A fitted model: a set of effects and their stacked parameters.
#[derive(Debug, Clone)]
struct Fit {
    set: Vec<Effect>,
    theta: Vec<f64>,
    sse: f64,
    ci95: Option<Vec<[f64; 2]>>,
}

struct Problem<'a> {
    nominal: Circuit,
    sweep: &'a Sweep,
    n: usize,
    distinct: usize,
    std: f64,
}

impl Problem<'_> {
    fn predict(&self, set: &[Effect], theta: &[f64]) -> Option<Vec<f64>> {
        let (mut c, mut e) = (self.nominal, Effects::default());
        let mut k = 0;
        for eff in set {
            let p = eff.params().len();
            eff.apply(&theta[k..k + p], &mut c, &mut e);
            k += p;
        }
        check_circuit(&c).ok()?;
        self.sweep.points.iter().map(|op| solve(&c, &e, op).ok().map(|s| s.vout)).collect()
    }

    fn residual(&self, set: &[Effect], theta: &[f64]) -> Option<DVector<f64>> {
        let y = self.predict(set, theta)?;
        let r = DVector::from_iterator(self.n, self.sweep.vout.iter().zip(&y).map(|(m, p)| m - p));
        r.iter().all(|v| v.is_finite()).then_some(r)
    }

    fn scales(&self, set: &[Effect]) -> Vec<f64> {
        set.iter().flat_map(|e| std::iter::repeat_n(e.scale(&self.nominal), e.params().len())).collect()
    }

    /// Jacobian of the model output (not the residual) by central differences.
    fn jacobian(&self, set: &[Effect], theta: &[f64]) -> Option<DMatrix<f64>> {
        let scales = self.scales(set);
        let mut j = DMatrix::zeros(self.n, theta.len());
        for k in 0..theta.len() {
            let h = 1e-5 * theta[k].abs().max(scales[k]);
            let mut plus = theta.to_vec();
            let mut minus = theta.to_vec();
            plus[k] += h;
            minus[k] -= h;
            let (rp, rm) = (self.residual(set, &plus)?, self.residual(set, &minus)?);
            j.set_column(k, &((rm - rp) / (2.0 * h)));
        }
        Some(j)
    }

    fn rms(&self, sse: f64) -> f64 {
        (sse / self.n as f64).sqrt()
    }

    fn gap(&self, sse: f64) -> Gap {
        let rms = self.rms(sse);
        Gap { rms, nrmse: (self.std > 0.0).then(|| rms / self.std) }
    }

    /// Levenberg–Marquardt from `theta0`; `None` when the model cannot be evaluated there.
    fn levenberg_marquardt(&self, set: &[Effect], theta0: &[f64]) -> Option<Fit> {
        let mut theta = theta0.to_vec();
        let mut r = self.residual(set, &theta)?;
        let mut sse = r.norm_squared();
        let scales = self.scales(set);
        let mut lambda = 1e-3;
        for _ in 0..200 {
            if theta.is_empty() {
                break;
            }
            let j = self.jacobian(set, &theta)?;
            let js = DMatrix::from_fn(self.n, theta.len(), |i, k| j[(i, k)] * scales[k]);
            let jtj = js.transpose() * &js;
            let jtr = js.transpose() * &r;
            let mut improved = false;
            while lambda < 1e12 {
                let mut a = jtj.clone();
                for k in 0..theta.len() {
                    a[(k, k)] += lambda * (jtj[(k, k)].max(1e-12));
                }
                let Some(step) = a.cholesky().map(|ch| ch.solve(&jtr)) else {
                    lambda *= 10.0;
                    continue;
                };
                let trial: Vec<f64> = theta.iter().zip(step.iter()).zip(&scales).map(|((t, s), sc)| t + s * sc).collect();
                match self.residual(set, &trial) {
                    Some(rt) if rt.norm_squared() < sse => {
                        let gain = sse - rt.norm_squared();
                        theta = trial;
                        r = rt;
                        sse = r.norm_squared();
                        lambda = (lambda / 3.0).max(1e-12);
                        improved = gain > 1e-14 * sse.max(1e-300);
                        break;
                    }
                    _ => lambda *= 4.0,
                }
            }
            if !improved {
                break;
            }
        }
        let ci95 = self.ci95(set, &theta, sse);
        Some(Fit { set: set.to_vec(), theta, sse, ci95 })
    }

    /// CI95 from `s²·(JᵀJ)⁻¹` and the t quantile; `None` when JᵀJ is singular or dof < 1.
    fn ci95(&self, set: &[Effect], theta: &[f64], sse: f64) -> Option<Vec<[f64; 2]>> {
        let p = theta.len();
        if p == 0 {
            return Some(Vec::new());
        }
        let dof = self.n.checked_sub(p).filter(|d| *d >= 1)? as f64;
        let scales = self.scales(set);
        let j = self.jacobian(set, theta)?;
        let js = DMatrix::from_fn(self.n, p, |i, k| j[(i, k)] * scales[k]);
        let svd = js.clone().svd(false, false);
        let (smax, smin) = (svd.singular_values.max(), svd.singular_values.min());
        if !(smin > 1e-9 * smax && smax > 0.0) {
            return None;
        }
        let inv = (js.transpose() * js).try_inverse()?;
        let s2 = sse / dof;
        let t = t_quantile(0.95, dof);
        Some(
            (0..p)
                .map(|k| {
                    let half = t * (s2 * inv[(k, k)]).sqrt() * scales[k];
                    [theta[k] - half, theta[k] + half]
                })
                .collect(),
        )
    }

    /// Best of several starts for `base` extended by `extra`.
    fn fit_extended(&self, base: &Fit, extra: Effect) -> Option<Fit> {
        let mut set = base.set.clone();
        set.push(extra);
        let starts = extra.starts(&self.nominal);
        let starts: Vec<Vec<f64>> = if starts.is_empty() { vec![base.theta.clone()] } else { starts.iter().map(|s| base.theta.iter().copied().chain([*s]).collect()).collect() };
        starts.iter().filter_map(|t0| self.levenberg_marquardt(&set, t0)).min_by(|a, b| a.sse.total_cmp(&b.sse))
    }

    /// The candidate `extra` tested on top of `base`; the fit when it can be made.
    fn test(&self, base: &Fit, extra: Effect, nominal_sse: f64, opts: &Options) -> (EffectFit, Option<Fit>) {
        let p_total = base.theta.len() + extra.params().len();
        let mut out = EffectFit::untested(extra.name(), None);
        if self.distinct < p_total + 2 {
            out.note = Some(format!("the data cannot support it: {} parameter(s) need at least {} distinct operating points, the sweep has {}", p_total, p_total + 2, self.distinct));
            return (out, None);
        }
        let Some(fit) = self.fit_extended(base, extra) else {
            out.note = Some("the DC model has no steady state for this effect at some operating point".into());
            return (out, None);
        };
        let own = base.theta.len()..fit.theta.len();
        let names = extra.params();
        let identified = |ci: &[f64; 2], v: f64| {
            let half = 0.5 * (ci[1] - ci[0]);
            half.is_finite() && half > 0.0 && half <= 10.0 * v.abs()
        };
        out.identifiable = match &fit.ci95 {
            Some(ci) => ci.iter().zip(&fit.theta).all(|(c, v)| identified(c, *v)),
            None => false,
        };
        let gap = self.gap(fit.sse);
        let nominal = self.gap(nominal_sse);
        out.rms_after = Some(gap.rms);
        out.nrmse_after = gap.nrmse;
        out.shrink_percent = match (nominal.nrmse, gap.nrmse) {
            (Some(a), Some(b)) if a > 0.0 => Some(100.0 * (1.0 - b / a)),
            _ => None,
        };
        out.closed_percent = (nominal_sse > 0.0).then(|| 100.0 * (nominal_sse - fit.sse) / nominal_sse);
        let added = names.len();
        let dof = (self.n - fit.theta.len()) as f64;
        if added > 0 {
            let f = ((base.sse - fit.sse) / added as f64) / (fit.sse / dof);
            let p = if fit.sse <= 0.0 { 0.0 } else { f_upper_tail(f.max(0.0), added as f64, dof) };
            out.p_value = Some(p);
            out.significant = p < opts.alpha;
        } else {
            out.significant = fit.sse < base.sse * (1.0 - 1e-9);
        }
        out.physical = fit.theta.iter().all(|v| *v > 0.0);
        let rms_base = self.rms(base.sse);
        out.material = base.sse > 0.0 && (base.sse - fit.sse) >= opts.min_share * base.sse && rms_base - gap.rms > opts.min_rms;
        if out.identifiable {
            out.params = Some(names.iter().zip(&fit.theta[own.clone()]).map(|(n, v)| (n.to_string(), *v)).collect());
            out.ci95 = fit.ci95.as_ref().map(|ci| names.iter().zip(&ci[own]).map(|(n, c)| (n.to_string(), *c)).collect());
        } else {
            out.note = Some(match &fit.ci95 {
                None => "not identifiable from this sweep: the data does not constrain its parameters (singular Jacobian); no numbers given".into(),
                Some(_) => "not identifiable from this sweep: a CI95 is wider than ten times its estimate; no numbers given".into(),
            });
            out.significant = false;
        }
        (out, Some(fit))
    }
}

impl Problem<'_> {
    /// Forward selection from `start` among the candidates not `excluded`: the steps and the
    /// final fit.
    fn forward(&self, start: &Fit, excluded: &[Effect], sse0: f64, opts: &Options) -> (Vec<EffectFit>, Fit) {
        let (mut steps, mut current) = (Vec::new(), start.clone());
        loop {
            let remaining = Effect::ALL.iter().copied().filter(|e| !current.set.contains(e) && !excluded.contains(e));
            let mut round: Vec<(EffectFit, Fit)> =
                remaining.map(|e| self.test(&current, e, sse0, opts)).filter_map(|(f, fit)| fit.filter(|_| f.significant && f.identifiable && f.physical && f.material).map(|fit| (f, fit))).collect();
            round.sort_by(|a, b| a.1.sse.total_cmp(&b.1.sse));
            let Some((best, fit)) = round.into_iter().next() else { break };
            steps.push(best);
            current = fit;
        }
        (steps, current)
    }
}

fn key(op: &crate::model::OperatingPoint) -> String {
    format!("{:.9e}/{:.9e}/{:.9e}/{:?}", op.duty, op.vin, op.io, op.rload.map(|r| format!("{r:.9e}")))
}

/// Diagnoses a sweep against the nominal circuit `nominal` (ideal synchronous buck with `RL`,
/// and `rds_on` when given).
pub fn diagnose(sweep: &Sweep, nominal: &Circuit, opts: &Options) -> Result<Diagnosis, SweepError> {
    check_circuit(nominal)?;
    if sweep.vout.len() != sweep.points.len() || sweep.is_empty() {
        return Err(crate::error::data_err("the sweep has no operating points (or vout and the points differ in number)"));
    }
    let n = sweep.len();
    let distinct = sweep.points.iter().map(key).collect::<std::collections::BTreeSet<_>>().len();
    let mean = sweep.vout.iter().sum::<f64>() / n as f64;
    let std = (sweep.vout.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
    let problem = Problem { nominal: *nominal, sweep, n, distinct, std };
    let nominal_fit = Fit { set: Vec::new(), theta: Vec::new(), sse: 0.0, ci95: Some(Vec::new()) };
    let expected = problem.predict(&[], &[]).ok_or_else(|| crate::error::model_err("the nominal model has no steady state at some operating point"))?;
    let r0: Vec<f64> = sweep.vout.iter().zip(&expected).map(|(m, e)| m - e).collect();
    let sse0 = r0.iter().map(|v| v * v).sum::<f64>();
    let nominal_fit = Fit { sse: sse0, ..nominal_fit };

    let effects;
    let mut branches = Vec::new();
    let (mut selected, mut current) = (Vec::new(), nominal_fit.clone());
    let min_params = 1;
    let message = (distinct < min_params + 2).then(|| {
        format!(
            "the data cannot support a diagnosis: {n} operating point(s), {distinct} distinct; an effect with one parameter needs at least {} distinct operating points varying in duty or load",
            min_params + 2
        )
    });
    if message.is_none() {
        let mut alone: Vec<(EffectFit, Option<Fit>)> = Effect::ALL.iter().map(|e| problem.test(&nominal_fit, *e, sse0, opts)).collect();
        alone.sort_by(|a, b| a.0.rms_after.unwrap_or(f64::INFINITY).total_cmp(&b.0.rms_after.unwrap_or(f64::INFINITY)));
        effects = alone.iter().map(|a| a.0.clone()).collect();
        // A buck is synchronous (dead time possible) or asynchronous (diode, DCM), not both:
        // select within each topology and keep the better final model by AIC (the two are not
        // nested, so no F test can compare them).
        let mut best: Option<(f64, Vec<EffectFit>, Fit)> = None;
        for excluded in [[Effect::DiodeDrop, Effect::Dcm], [Effect::DeadTime, Effect::DeadTime]] {
            let (steps, fit) = problem.forward(&nominal_fit, &excluded, sse0, opts);
            let aic = n as f64 * (fit.sse.max(1e-300) / n as f64).ln() + 2.0 * fit.theta.len() as f64;
            branches.push(Branch {
                topology: if excluded[0] == Effect::DiodeDrop { "synchronous" } else { "asynchronous" },
                selected: steps.iter().map(|s| s.name).collect(),
                rms: problem.rms(fit.sse),
                aic,
            });
            if best.as_ref().is_none_or(|b| aic < b.0 - 1e-9) {
                best = Some((aic, steps, fit));
            }
        }
        if let Some((_, steps, fit)) = best {
            selected = steps;
            current = fit;
        }
    } else {
        effects = Effect::ALL.iter().map(|e| EffectFit::untested(e.name(), message.clone())).collect();
    }
    let fitted = problem.predict(&current.set, &current.theta).unwrap_or_else(|| expected.clone());
    let by_operating_point = sweep
        .points
        .iter()
        .enumerate()
        .map(|(i, op)| PointGap {
            duty: op.duty,
            vin: op.vin,
            io: op.io,
            rload: op.rload,
            load: op.load_current(sweep.vout[i]),
            measured: sweep.vout[i],
            expected: expected[i],
            residual: r0[i],
            fitted: fitted[i],
            residual_after: sweep.vout[i] - fitted[i],
        })
        .collect();
    let final_fit = (!current.set.is_empty()).then(|| {
        let mut params = BTreeMap::new();
        let mut ci95 = BTreeMap::new();
        let mut k = 0;
        for e in &current.set {
            let mut p = BTreeMap::new();
            let mut c = BTreeMap::new();
            for name in e.params() {
                p.insert(name.to_string(), current.theta[k]);
                if let Some(ci) = &current.ci95 {
                    c.insert(name.to_string(), ci[k]);
                }
                k += 1;
            }
            params.insert(e.name().to_string(), p);
            ci95.insert(e.name().to_string(), c);
        }
        FinalFit { params, ci95, gap: problem.gap(current.sse) }
    });
    let verdict = selected.first().map_or("none", |s| s.name).to_string();
    Ok(Diagnosis {
        supported: message.is_none(),
        message,
        points: n,
        distinct_points: distinct,
        gap_before: problem.gap(sse0),
        location: Where { by_operating_point },
        effects,
        selected,
        branches,
        final_fit,
        verdict,
    })
}
