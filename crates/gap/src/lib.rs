//! Sim-to-real gap diagnosis: given "real" data (SPICE, a third-party model, a measurement)
//! and the nominal simulation model, say **where** the model misses (frequency band, operating
//! point, time window, each against the noise floor), **which** unmodelled effect explains
//! the miss (every candidate effect is fitted together with Cl on the estimation part and
//! judged on the held-out part, with a likelihood-ratio test or Akaike's criterion for
//! significance), and **how far** the held-out error shrinks once it is added.
//!
//! The data is never asked which effect it holds: metadata naming an effect is ignored.
#![forbid(unsafe_code)]

mod bias_law;
mod candidates;
mod consistency;
mod current;
mod effect;
mod joint;
mod limits;
mod locate;
mod options;
mod pairs;
mod problem;
mod quantization;
mod ridge;
mod select;
mod tested;

use buck_model::Params;
use estimator::data::DataSet;
use estimator::identify::{Candidate, IdentifyOptions, identify};
use estimator::model::{Free, Structure};
use serde::Serialize;
use std::collections::BTreeMap;

pub use bias_law::BiasLawSpread;
pub use current::{CurrentMisfit, PROBE_GAIN_TOLERANCE, ProbeExact};
pub use effect::{
    Against, Alike, ClCheck, ClMove, DEEP_DCM_MISS_FLOORS, DEEP_DCM_SHARE, DeepDcmMiss, EFFECTS, EffectFit, GROSS_MISS_FLOORS, GROSS_MISS_OF_SWING, InPlaceOf, MATERIAL_OF_SWING, MATERIAL_SHARE,
    NEAR_STEP_MISS, NearStep, NotTested, RECIPROCAL_BIAS_LAW, ReadLate, closed_percent, gap_above, gap_material, model_error_inflation,
};
use options::nominal_options;
pub use options::{DiagnoseOptions, Nominal, SwitchingEvidence, nominal_for};

pub use estimator::noise::{noise_floor, noise_floor_estimate};
pub use locate::{Band, FloorSource, Group, Where};
pub use tested::{CIRCUIT_FIDELITY, CIRCUIT_FIDELITY_WITH_DEVICES, CL_FIDELITY, CL_FIDELITY_WITH_EFFECTS, TestedCl, tested_cl};

/// Whether two sequences hold the same effects, in whatever order.
fn same_model(a: &[EffectFit], b: &[EffectFit]) -> bool {
    let labels = |s: &[EffectFit]| {
        let mut labels: Vec<String> = s.iter().map(EffectFit::label).collect();
        labels.sort();
        labels
    };
    labels(a) == labels(b)
}

/// How much smaller than the joint refit's held-out residual a going-on sequence's must be to
/// be taken instead (the joint model has fewer effects, each judged given all the others).
const GOING_ON_MARGIN: f64 = 1.05;

/// Share of its periods a diode buck starts in DCM above which the regime sentence warns of the
/// switch node's ring, which the fits leave out (README, sixteenth session: a ringing node's
/// criterion has a valley per phase, narrower than ±2 % in its capacitance).
const DEEP_DCM: f64 = 0.5;

/// Why a diagnosis could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GapError {
    /// The data or the nominal fit failed.
    #[error(transparent)]
    Estimator(#[from] estimator::EstimatorError),
}

/// Held-out traces for plots: the measured output, the nominal model's and the verdict's
/// simulations.
#[derive(Debug, Clone, Default)]
pub struct Traces {
    /// Index of the first held-out sample in the data.
    pub start: usize,
    /// Measured `vout` \[V\].
    pub measured: Vec<f64>,
    /// Nominal model's free-run simulation \[V\].
    pub nominal: Vec<f64>,
    /// Simulation of the final model, every selected effect added (`None` when the verdict is
    /// `none`) \[V\].
    pub after: Option<Vec<f64>>,
}

/// The nominal model's fit, the gap before any effect is added.
#[derive(Debug, Clone, Serialize)]
pub struct Before {
    /// The nominal model's structure (`averaged`, `pwm`, or `simulated` where the PWM model
    /// could not be fitted).
    pub model: &'static str,
    /// Held-out NRMSE of the nominal model's simulation.
    pub nrmse: f64,
    /// Held-out residual RMS of the nominal model's simulation \[V\].
    pub rms: f64,
    /// Cl of the nominal fit \[F\] (when the verdict is `none` and the high-pass refit agrees and
    /// is the more precise, that one's; see [`ClCheck`]).
    pub cl: f64,
    /// Its CI95 \[F\]: the model's own, or, when the verdict is `none`, the one the interval's
    /// test reports (see [`ClCheck`]).
    pub cl_ci95: [f64; 2],
    /// The test of the interval when the verdict is `none`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cl_check: Option<ClCheck>,
    /// Why it was not made, when the verdict is `none`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cl_check_skipped: Option<String>,
    /// When the verdict is `none` but the nominal still misses above the floor: the factor the
    /// interval's log half-widths were widened by (see [`model_error_inflation`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cl_widened_by: Option<f64>,
    /// When the verdict is `none` and the nominal misses by more than
    /// [`effect::GROSS_MISS_FLOORS`] noise floors: that multiple (Cl not identified).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cl_misses_by_floors: Option<f64>,
    /// When the verdict is `none` and the nominal's inductor current contradicts the measured
    /// one (Cl not identified) or the measured one reads it reversed ([`CurrentMisfit`]): how.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cl_current_misfit: Option<CurrentMisfit>,
    /// Whatever the verdict, when the nominal misses `vout` grossly (by more than
    /// [`effect::GROSS_MISS_FLOORS`] noise floors, and materially on the swing's scale): that
    /// multiple. Its Cl, fitted to a model that cannot follow the data, then says nothing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub misses_by_floors: Option<f64>,
}

impl Before {
    /// The nominal's fit `base` with its own Cl interval `base_cl`, or, when the verdict is
    /// `none`, its Cl `tested`.
    fn of(base: &Candidate, baseline: &effect::Baseline, base_cl: [f64; 2], tested: Option<TestedCl>) -> Self {
        let before = Self {
            model: base.structure.name(),
            nrmse: baseline.nrmse,
            rms: baseline.rms,
            cl: baseline.cl,
            cl_ci95: base_cl,
            cl_check: None,
            cl_check_skipped: None,
            cl_widened_by: None,
            cl_misses_by_floors: None,
            cl_current_misfit: None,
            misses_by_floors: effect::gross_miss(baseline.rms, baseline.floor, baseline.swing),
        };
        match tested.map(|t| t.cl) {
            Some(t) => Self {
                cl: t.estimate,
                cl_ci95: t.ci95,
                cl_check: t.check,
                cl_check_skipped: t.check_skipped,
                cl_widened_by: t.widened_by,
                cl_misses_by_floors: t.misses_by_floors,
                cl_current_misfit: t.current_misfit,
                ..before
            },
            None => before,
        }
    }

    /// Why the nominal fit's Cl says nothing, where it does not: a gross miss, an interval that
    /// does not pin it down (`None` where it is a value, if only the nominal's).
    pub fn cl_not_identified(&self) -> Option<String> {
        match self.misses_by_floors {
            Some(k) => Some(format!("not identified: the nominal model misses vout by {k:.1}× its noise floor")),
            None => (!estimator::validate::identified(self.cl_ci95)).then(|| "not identified".to_string()),
        }
    }

    /// The nominal's Cl as the final model's is held ([`ClMove`]), for its sentence.
    fn cl_move(&self) -> ClMove {
        ClMove {
            check: self.cl_check.clone(),
            check_skipped: self.cl_check_skipped.clone(),
            widened_by: self.cl_widened_by,
            misses_by_floors: self.cl_misses_by_floors,
            current_misfit: self.cl_current_misfit,
            ..ClMove::at(self.cl, self.cl_ci95, self.cl)
        }
    }
}

/// Result of [`diagnose`].
#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    /// The nominal model's held-out error.
    pub gap_before: Before,
    /// Where the nominal model misses.
    #[serde(rename = "where")]
    pub location: Where,
    /// Every candidate effect that was fitted, best held-out error first.
    pub effects: Vec<EffectFit>,
    /// Effects of the design table not fitted to this data, with the reason.
    pub not_tested: Vec<NotTested>,
    /// The forward selection: the findings in the order they were added, each fitted on top of
    /// the ones before it (its `closed_percent` is the share of the nominal's gap closed once it
    /// is added, `closed_of_remaining` the share of what the sequence before it left).
    pub selected: Vec<EffectFit>,
    /// Why the sequence ended.
    pub selection_ended: String,
    /// The first selected effect (the single effect that explains most), or `none`.
    pub verdict: String,
    /// No effect is selected although the nominal misses materially above the noise floor (and
    /// no drift within tolerance explains it): the gap is real and no candidate explains it, a
    /// mechanism they lack. The verdict `none` then says "no candidate", not "no gap".
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub unexplained: bool,
    /// Where the final model is a diode buck: the share of periods it starts in DCM, the
    /// diode having blocked before the period ended (`il` at zero), as it runs on the data's
    /// inputs. DCM is in the model's diode by construction, so it is reported here, not as an
    /// effect of its own.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dcm_share: Option<f64>,
    /// How the final Cl leans on the circuit values its model holds at their nominal (`L`,
    /// `C`, `Rc` unless fitted): `d ln Cl / d ln x`, the per cent Cl moves per per cent of `x`,
    /// the model's other values refitted (switched data). Cl's CI95 holds these values exact.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cl_leverage: Option<BTreeMap<String, f64>>,
    /// The final Cl's CI95 was widened to the circuit model's fidelity ([`Diagnosis::cl_fidelity`]).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub cl_at_fidelity: bool,
    /// The relative half-width the final Cl's CI95 is held to: [`CL_FIDELITY_WITH_EFFECTS`]
    /// where the final model carries effects, [`CL_FIDELITY`] for the nominal alone, or the
    /// circuit model's fidelity of L and C through Cl's leverage on them where that is wider
    /// ([`Diagnosis::cl_circuit_fidelity`]).
    pub cl_fidelity: f64,
    /// The relative accuracy of L and C that [`Diagnosis::cl_fidelity`] allows for through Cl's
    /// leverage: [`CIRCUIT_FIDELITY`], or [`CIRCUIT_FIDELITY_WITH_DEVICES`] where the final model
    /// holds an effect whose form approximates a device.
    pub cl_circuit_fidelity: f64,
    /// The nominal model used.
    pub nominal: Nominal,
    /// The inputs (`vin`, `io`) recorded by a measurement, and whether they were replaced by
    /// their levels before the fits (see [`estimator::inputs`]).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub measured_inputs: Vec<estimator::inputs::MeasuredInput>,
    /// Held-out traces for plots.
    #[serde(skip)]
    pub traces: Traces,
}

impl Diagnosis {
    /// Cl of the model the diagnosis ends with (the last selected effect's, or the nominal's
    /// when the verdict is `none`): estimate \[F\], CI95 \[F\], and a sentence on the interval's test.
    pub fn final_cl(&self) -> (f64, [f64; 2], String) {
        let cl = self.final_cl_move();
        (cl.estimate, cl.ci95, cl.sentence(self.cl_at_fidelity.then_some((self.cl_fidelity, self.cl_circuit_fidelity))))
    }

    /// How Cl of the model the diagnosis ends with moved ([`Diagnosis::final_cl`]).
    fn final_cl_move(&self) -> std::borrow::Cow<'_, ClMove> {
        self.selected.last().map_or_else(|| std::borrow::Cow::Owned(self.gap_before.cl_move()), |e| std::borrow::Cow::Borrowed(&e.cl))
    }

    /// The verdict in words: the first selected effect, `none`, or, where the gap is
    /// [`Diagnosis::unexplained`], `none` said as no candidate's.
    pub fn verdict_text(&self) -> String {
        if self.unexplained {
            return format!("{} of the candidates: the nominal misses materially and none explains it (a mechanism they lack)", self.verdict);
        }
        self.verdict.clone()
    }

    /// A sentence on Cl's leverage on the values its model holds ([`Diagnosis::cl_leverage`]);
    /// none where the final Cl is not identified (no interval holds them, and an unidentified
    /// Cl's leverage is a slope on a flat valley: ±0.0 % per per cent).
    pub fn leverage(&self) -> Option<String> {
        if !estimator::validate::identified(self.final_cl_move().ci95) {
            return None;
        }
        let lever = self.cl_leverage.as_ref().filter(|l| !l.is_empty())?;
        let each: Vec<String> = lever.iter().map(|(name, k)| format!("{k:+.1} % per 1 % of {name}")).collect();
        Some(format!("Cl moves {} (its interval holds them at their nominal values)", each.join(", ")))
    }

    /// A sentence on how the final model runs where it is a diode buck: the share of periods
    /// it starts in DCM ([`Diagnosis::dcm_share`]), and, in deep DCM, what it leaves out.
    pub fn regime(&self) -> Option<String> {
        self.dcm_share.map(|share| match share {
            0.0 => "the final model, a diode buck, conducts continuously (CCM) in every period".to_string(),
            s => {
                let ring = self.selected.iter().find(|e| e.name == "switch_node_ring");
                let blocked = match ring {
                    Some(e) if e.params.contains_key(Free::SwitchNodeDamping.name()) => "the diode blocked, its switch node ringing with L, damped",
                    Some(_) => "the diode blocked, its switch node ringing with L",
                    None => "the diode blocked, il at zero",
                };
                let share = format!("the final model, a diode buck, starts {:.1} % of its periods in DCM ({blocked})", 100.0 * s);
                if s < DEEP_DCM || ring.is_some() {
                    return share;
                }
                format!("{share}; in deep DCM a real switch node rings with L once the diode blocks, and the ring's current at the next turn-on moves each period's charge: not in this model (`switch_node_ring`), so Cl, L and the drop may take its place")
            }
        })
    }
}

/// The nominal circuit with the `cap_dc_bias` candidate's law anchored to the data (unless the
/// nominal carries a bias law of its own): its rated voltage at the highest `vout`, and Cl
/// the capacitance at the mean `vout`. The data shows Cl and its slope over the voltages it
/// visits, nothing else: anchored so, the fitted Cl is the capacitance the converter runs
/// with, whatever law the part follows, and the law's bound (90 % lost at the rated
/// voltage) spans any slope a real ceramic has over that range. A part's own rating would
/// leave a 6 V operating point on the flat start of a 16 V law, the bias fit on its bound.
fn bias_reference(nominal: &Params, data: &DataSet) -> Params {
    let top = data.vout.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mean = data.vout.iter().sum::<f64>() / data.len().max(1) as f64;
    if nominal.cap_dc_bias > 0.0 || !(top > 0.0 && mean > 0.0) {
        return *nominal;
    }
    Params { cap_rated_voltage: top, cl_reference_voltage: mean.min(top), ..*nominal }
}

/// Cl's leverage on the values the final model (the nominal with `selected`, at `circuit`
/// where the bias law's other shape is preferred) holds at their nominal: `L`, `C`, `Rc`
/// unless fitted ([`estimator::simulated::cl_leverage`]). `None` for an averaged model.
fn leverage(data: &DataSet, nominal: &Params, selected: &[EffectFit], circuit: Option<Params>, cl: f64, switched_nominal: bool, n_est: usize) -> Option<BTreeMap<String, f64>> {
    let cl = selected.last().map_or(cl, |e| e.cl.estimate);
    let stack = select::Stack::of(&selected.iter().collect::<Vec<_>>(), nominal, cl, switched_nominal).ok()?;
    if !stack.switched {
        return None;
    }
    let held: Vec<Free> = effect::DRIFTING.into_iter().filter(|f| !stack.free.contains(f)).collect();
    let values = estimator::simulated::cl_leverage(&stack.data(data), &circuit.unwrap_or(stack.params), &stack.free, n_est, &held).ok()?;
    Some(held.iter().map(|f| f.name().to_string()).zip(values).collect())
}

/// Diagnoses the gap between `data` and the nominal averaged model with circuit values `nominal`.
///
/// A switched nominal is the sampled-data PWM model, linear in the state; where that cannot be
/// fitted (e.g. deep DCM, far from any linear model) the plant simulator itself with Cl free
/// stands in for it.
pub fn diagnose(data: &DataSet, nominal: &Params, opts: &DiagnoseOptions) -> Result<Diagnosis, GapError> {
    // A law the nominal brings is read at its own reference; one the diagnosis fits, at the
    // converter's operating point.
    let own_bias_law = nominal.cap_dc_bias > 0.0;
    let nominal = &bias_reference(nominal, data);
    let fit_nominal = |data: &DataSet| -> Result<Candidate, GapError> {
        let id = match identify(data, nominal, &nominal_options(opts)) {
            Err(_) if opts.nominal == Nominal::Switched => identify(data, nominal, &IdentifyOptions { structures: vec![Structure::Simulated], ..nominal_options(opts) })?,
            fit => fit?,
        };
        Ok(id.best().clone())
    };
    // A measured vin or io drives every model with its levels, unless vout shows the
    // converter's response to its noise.
    let (data, base, measured_inputs) = estimator::inputs::drive_by_levels_unless_seen(data, fit_nominal, |c| c.fit.params)?;
    let data = &data;
    let residual = effect::residual(&base);
    let n_est = ((data.len() as f64) * (1.0 - opts.holdout)).round() as usize;
    let baseline = effect::Baseline::of(data, &base, n_est, opts.tolerance);
    let candidates::Fitted { mut effects, not_tested, switched } = candidates::fit_all(data, nominal, opts, &base, &baseline, n_est);
    let problem = problem::Problem { data, nominal, switched_nominal: opts.nominal == Nominal::Switched, switched_data: switched, n_est, holdout: opts.holdout, baseline: &baseline };
    let p = &problem;
    effects.sort_by(|a, b| a.nrmse_after.total_cmp(&b.nrmse_after));
    // The first step: the finding (significant, material, outside tolerance) with the lowest
    // Akaike criterion; of two nested effects (dcm inside diode_drop) the richer one wins only
    // by more than its parameter's worth. Then forward selection on top of it.
    // A drift within tolerance that explains best leaves nothing to name.
    // A late reading the inductor current shows by itself comes first: it is how the data was
    // taken, and every circuit effect is then tested on top of it. Against the averaged nominal,
    // the ripple of switched data likewise: it is how the converter runs, and only the switched
    // model holds the effects of the switching (dead time, a diode, the node's charge); taken
    // after an averaged stand-in (a series resistance for a dead time), it left them out (a
    // harness capture with five effects got a resistance and a drift), where it is a finding
    // (merely significant, it also came first on an averaged plant's data, where a PWM model
    // fitted an inductance's drift 7.5 % better by chance).
    let late_in_il = effects.iter().find(|e| e.late_in_il());
    let ripple = effects.iter().find(|e| e.name == "switching_ripple" && e.finding);
    let first = late_in_il.or(ripple).or_else(|| select::best_material(effects.iter(), |e| e));
    // Forward selection from a first step, then the backward step and the joint refit; a full
    // sequence that the joint refit does not settle also goes on, one effect at a time (the
    // joint refit frees no ESL or bias law).
    // What a sequence leaves held out (RMS; nothing selected: no model to leave anything).
    let left = |s: &[EffectFit]| s.last().map_or(f64::INFINITY, |e| e.rms_after);
    let path = |first: &[EffectFit]| {
        let forward = |from: &[EffectFit], max| select::forward(p, from, &effects, max);
        let (mut selected, mut ended) = forward(first, select::MAX_EFFECTS);
        let full = selected.len() >= select::MAX_EFFECTS;
        if let Some(dropped) = select::backward(p, &mut selected) {
            ended = format!("{ended}; then {dropped}");
        }
        let greedy = selected.clone();
        let joint = joint::refit(p, &mut selected);
        // A joint model that leaves nothing material is kept; else the joint model is kept unless
        // going on leaves clearly less.
        let settled = joint.is_some() && baseline.misses_materially(left(&selected)) == Some(false);
        let (more, more_ended) = if full && !settled { forward(&greedy, select::MAX_EFFECTS_GOING_ON) } else { (Vec::new(), String::new()) };
        // Going on adds effects, or swaps one out (a late reading il shows replacing its
        // stand-in keeps the count: a harness buck's load ESR stood in for the instant at the
        // floor, Cl 7 % off).
        let went_on = !more.is_empty() && !same_model(&more, &greedy);
        let going_on = went_on && (joint.is_none() || left(&more) * GOING_ON_MARGIN < left(&selected));
        match joint {
            _ if going_on => (selected, ended) = (more, format!("{ended}; it went on: {more_ended}")),
            Some(joint) => ended = format!("{ended}; then {joint}"),
            None => {}
        }
        (selected, ended)
    };
    let (mut selected, mut selection_ended) = match first {
        Some(first) if first.finding => path(std::slice::from_ref(first)),
        Some(drift) => (Vec::new(), format!("the data is consistent with the nominal: best explained by a drift within tolerance ({})", drift.drift_label())),
        // Two effects that only together are a finding (see `pairs`).
        None if let Some((steps, note)) = (switched && p.switched_nominal).then(|| pairs::first_steps(p, &effects, &base)).flatten() => {
            let (selected, ended) = path(&steps);
            (selected, format!("{note}: {ended}"))
        }
        // Nothing in vout, il read through a filter (see `select::il_filter_first`).
        None if let Some(step) = (switched && p.switched_nominal).then(|| select::il_filter_first(p, base.fit.params.cl)).flatten() => path(std::slice::from_ref(&step)),
        None => {
            // The candidate closing most of a material share that ended on a bound, if any.
            let on_bound = effects.iter().filter(|e| e.at_bound && e.material).filter_map(|e| Some((e.name, e.closed_percent?))).max_by(|a, b| a.1.total_cmp(&b.1));
            (Vec::new(), baseline.nothing_found(on_bound))
        }
    };
    // The other topology, where the path from the first step still misses materially and the
    // other topology's best first step came close (on vout alone: is a finding), or the instant
    // within the period where the first step read a row late (see `select::rival`).
    let rms_left = selected.last().map(|e| e.rms_after);
    // The material share of the gap a path left (`left`, held-out RMS) that another path closes.
    let closes_of_left = |other: &[EffectFit], left: f64| other.last().and_then(|e| baseline.closed_of_material_gap(left, e.rms_after)).filter(|c| *c >= effect::MATERIAL_SHARE);
    let first = first.filter(|_| late_in_il.is_none() && ripple.is_none());
    // A late reading il shows, taken first, is a first step too: the circuit's findings are its
    // alternatives where its path stops materially above the floor (its il calibration, the
    // probe's gain and zero, can stand in for what an inductance's drift does to il).
    let late_first = late_in_il.filter(|_| first.is_none());
    let first_step = first.or(late_first);
    // Whether the path from `from` is the late reading's.
    let from_late = |from: &str| late_first.is_some_and(|l| l.name == from);
    let mut tried: Vec<&str> = first_step.map(|f| vec![f.name]).unwrap_or_default();
    // The first step of the path taken.
    let mut from = first_step.map_or("", |f| f.name);
    if let (Some(first), Some(rms_left)) = (first, rms_left)
        && baseline.misses_materially(rms_left) == Some(true)
        && let Some((rival, kind)) = select::rival(&effects, first, data.il.is_some())
    {
        tried.push(rival.name);
        let (other, other_ended) = path(std::slice::from_ref(rival));
        let closes = closes_of_left(&other, rms_left);
        let note = match closes {
            Some(c) => format!("; the path from {} ({kind}) closes {c:.1} % of the gap this one left ({:.2} mV held out): taken instead", rival.name, rms_left * 1e3),
            None => format!("; the path from {} ({kind}) closes no material share of the gap this one left", rival.name),
        };
        if closes.is_some() {
            (selected, selection_ended) = (other, format!("{other_ended} (from {}, after the path from {}: {selection_ended})", rival.name, first.name));
            from = rival.name;
        }
        selection_ended += &note;
    }
    // A path stuck far above the floor (see `select::STUCK_FLOORS`), or stopped materially above
    // it with a model whose inductor current contradicts the measured one (its impedance is not
    // the converter's, see `CurrentMisfit`: a stand-in took the first step) or from a late
    // reading: the paths from the next findings of the first step, one at a time while the best
    // so far is still stuck.
    let contradicts_il = |s: &[EffectFit]| -> Option<CurrentMisfit> {
        let last = s.last().filter(|_| switched)?;
        let stack = select::Stack::of(&s.iter().collect::<Vec<_>>(), nominal, last.cl.estimate, true).ok()?;
        CurrentMisfit::of(&stack.data(data), &stack.params, n_est).filter(CurrentMisfit::contradicts)
    };
    let stuck = |s: &[EffectFit], floor: f64, late: bool| -> Option<(f64, String)> {
        let rms = s.last()?.rms_after;
        if rms > select::STUCK_FLOORS * floor {
            return Some((rms, String::new()));
        }
        if baseline.misses_materially(rms) != Some(true) {
            return None;
        }
        if late {
            return Some((rms, String::new()));
        }
        let misfit = contradicts_il(s)?;
        Some((rms, format!(", its model's inductor current matching the measured one only through a probe gain of ×{:.2}", misfit.probe_gain)))
    };
    if let (Some(_), Some(floor)) = (first_step, baseline.floor) {
        // The path taken's own judgement, made once per path (its il check is a simulation).
        let mut stuck_at = None;
        for other_first in select::alternatives(&effects, &tried) {
            let Some((rms_left, why)) = stuck_at.get_or_insert_with(|| stuck(&selected, floor, from_late(from))).clone() else { break };
            if selected.len() >= select::MAX_EFFECTS {
                break;
            }
            let (other, other_ended) = path(std::slice::from_ref(other_first));
            let closes = closes_of_left(&other, rms_left);
            selection_ended = match closes {
                Some(c) => {
                    let before = format!("the path from {from} stopped {:.1} floors above the noise{why}: {selection_ended}", rms_left / floor);
                    (selected, from, stuck_at) = (other, other_first.name, None);
                    format!("{other_ended} (from {}, closing {c:.1} % of the gap left where {before})", other_first.name)
                }
                None => format!("{selection_ended}; the path from {} closes no material share of the gap left", other_first.name),
            };
        }
    }
    // A step, and a path, that leave nothing material above the floor.
    let at_floor = |e: &&EffectFit| baseline.misses_materially(e.rms_after) == Some(false);
    let ends_at_floor = |s: &[EffectFit]| s.last().is_some_and(|e| at_floor(&e));
    // A path that ends materially above the floor, or with a model whose inductor current
    // contradicts the measured one: the converter's joint model from its nominal values (see
    // `joint::from_nominal`), where it closes a material share of the gap the path left (or, the
    // path at the floor, matches the measured current where the path's does not).
    let mut nominal_twin = None;
    if switched
        && p.switched_nominal
        && let Some(left) = selected.last().map(|e| e.rms_after)
    {
        let misses = baseline.misses_materially(left) == Some(true);
        if misses || contradicts_il(&selected).is_some() {
            // Above the floor it must close a material share of the gap left, with no more
            // effects unless it ends at the floor (each of its effects a finding given the
            // others: an adequate model before a simpler one that is not); the path at the
            // floor, it must be there too.
            let gap_left = if misses { left } else { baseline.rms };
            let better = |other: &Vec<EffectFit>| {
                contradicts_il(other).is_none() && if misses { (other.len() <= selected.len() || ends_at_floor(other)) && closes_of_left(other, left).is_some() } else { ends_at_floor(other) }
            };
            // Of the kind its first steps took: an effect of the kind (a dead time) taken while
            // going on past a sequence's length may stand in for what an earlier step took (a
            // harness buck with L 16 % low went on from an inductor's saturation, Rc, the
            // switches and C to the late reading, a 1.8 ns dead time and a filter, 1.15 floors
            // up with Cl 5.7 [5.1, 6.8] µF for 7.35; the joint model from the nominal values,
            // kept synchronous without dead time, holds the switches, L −15.9 % and the late
            // reading at the floor, Cl 7.36 [7.28, 7.45] µF).
            let first_steps = &selected[..selected.len().min(select::MAX_EFFECTS)];
            match joint::from_nominal(p, first_steps, gap_left) {
                Some(joint::FromNominal::Closes(other)) if better(&other) => {
                    let why = if misses { format!("{:.2} mV held out", left * 1e3) } else { "its model's inductor current contradicting the measured one".to_string() };
                    selection_ended = format!(
                        "the converter's joint model from its nominal values (every effect such a converter carries, fitted together, then pruned), taken instead of the path, which ended with {why} ({selection_ended})"
                    );
                    // No first step led there: no path from one is its twin.
                    (selected, from) = (other, "");
                }
                // As good as the path, no better: Cl's interval spans its too, where it puts Cl
                // elsewhere (below).
                Some(joint::FromNominal::AsGood(twin)) if misses => nominal_twin = Some(twin),
                _ => {}
            }
        }
    }
    // A path at the floor: the path from a first step nearly as good that puts Cl elsewhere
    // (see `select::twin`). Where it ends at the floor too, Cl's interval spans both; where it
    // also leaves less held out with no more effects, it is taken instead.
    // (A circuit's first step: a late reading il shows has none.)
    let taken = effects.iter().find(|e| e.name == from).filter(|_| !from_late(from));
    // (Not one whose inductor current contradicts the measured one: the data tells it apart.)
    let twin_of = |s: &[EffectFit]| {
        let end = s.last().filter(at_floor).filter(|e| estimator::validate::identified(e.cl.ci95)).filter(|_| contradicts_il(s).is_none())?;
        Some(effect::Twin { selected: s.iter().map(EffectFit::label).collect(), rms_after: end.rms_after, cl: end.cl.estimate, ci95: end.cl.ci95 })
    };
    let twin_first = selected.last().filter(at_floor).zip(taken).and_then(|(last, taken)| select::twin(&effects, taken, last.cl.ci95, &tried));
    let twin = twin_first.and_then(|other_first| {
        let (other, other_ended) = path(std::slice::from_ref(other_first));
        let twin = twin_of(&other)?;
        let this = selected.last()?;
        // The same effects by another path are the same model.
        if same_model(&other, &selected) {
            return None;
        }
        if other.len() <= selected.len() && twin.rms_after < this.rms_after {
            let before = format!(
                "the path from {from} ended at the floor too, with {} effects and {:.3} mV held out against {:.3}: {selection_ended}",
                selected.len(),
                this.rms_after * 1e3,
                twin.rms_after * 1e3
            );
            let replaced = twin_of(&selected);
            (selected, selection_ended) = (other, format!("{other_ended} (from {}, where {before})", other_first.name));
            return replaced;
        }
        Some(twin)
    });
    // A path read late on both channels beside other effects, against vout read apart from il
    // on top of the effects selected before the late reading (see `select::read_apart`): vout
    // read at another instant looks like the stand-ins the path took beside the late reading (an
    // ESL, a gain error, a load ESR). As good as the path, Cl's interval spans its (below).
    // Better already, a finding with vout's instant apart from il's is taken as it is; else such
    // a finding leads a forward path of its own, taken instead where it closes a material share
    // of the gap the path taken left (with no more values fitted, unless it ends at the floor),
    // or is as good (neither closes a material share of what the other leaves) and leaves less
    // with no more values fitted; else, at the floor, it is the final model's twin.
    let apart = select::read_apart(p, &selected, &base);
    let (mut twin, mut nominal_twin, mut read_apart) = (twin, nominal_twin, None);
    let better_already = |a: &select::Apart| a.alike && a.read.in_place_of().is_some_and(|them| them.better);
    let fitted = |s: &[EffectFit]| s.iter().map(|e| e.ci95.len()).sum::<usize>();
    match apart {
        Some(a) if a.alike && !(better_already(&a) && a.fit().finding && a.skewed()) => read_apart = Some(a.read),
        // (Counted in the values fitted: vout's own instant is one more than the late reading.
        // A path at the floor is taken over only by one as good with no more values fitted, which
        // a path from more values than it has cannot be: not run.)
        Some(a) if a.fit().finding && a.skewed() && !(ends_at_floor(&selected) && fitted(&a.steps) > fitted(&selected)) => {
            let (other, other_ended) = if better_already(&a) {
                (a.steps.clone(), None)
            } else {
                // (Forward only: a full path's backward step and joint refit cost 2-5 s more on
                // the bench's several-effect boards, where vout's instant changed nothing.)
                let (other, ended) = select::forward(p, &a.steps, &effects, select::MAX_EFFECTS);
                (other, Some(ended))
            };
            let (left, other_left) = (left(&selected), left(&other));
            let no_more = fitted(&other) <= fitted(&selected);
            let better = closes_of_left(&other, left).is_some() && (no_more || ends_at_floor(&other));
            let as_good = closes_of_left(&selected, other_left).is_none() && no_more && other_left < left;
            // (A path that dropped vout's instant again is another path, not vout read apart.)
            let skewed = other.iter().any(|e| e.params.contains_key(Free::VoutSkew.name()));
            if skewed && contradicts_il(&other).is_none() && (better || as_good) {
                let from = match other_ended {
                    None => format!("vout read {:.1} ns after il ({}) in place of {}", a.read.value * 1e9, a.fit().name, a.replaced()),
                    Some(ended) => format!("the path from vout read apart from il ({} on top of {}): {ended}", a.fit().name, a.before()),
                };
                selection_ended = format!("{from}; taken instead of the path, which ended with {:.3} mV held out against its {:.3} ({selection_ended})", left * 1e3, other_left * 1e3);
                let replaced = twin_of(&selected);
                (selected, twin, nominal_twin) = (other, replaced, None);
            } else if twin.is_none() && !same_model(&other, &selected) {
                twin = twin_of(&other);
            }
        }
        _ => {}
    }
    // A model the joint refit pruned to this one that puts Cl elsewhere (see `joint::refit`):
    // its interval is spanned too, where no path's twin is.
    let pruned_twin = selected.last_mut().and_then(|e| std::mem::take(&mut e.cl.twins).pop());
    // Cl's interval of the final model, tested against the high-pass fit (switched data only:
    // the test refits with the switched plant simulator): the test, or why it was not made.
    let check = |fits: &[&EffectFit], cl: f64, ci95: [f64; 2]| {
        if switched { consistency::check(data, nominal, fits, cl, ci95, n_est) } else { Err("averaged data: the switched simulator that tests the interval cannot fit it".to_string()) }
    };
    let test = |fits: &[&EffectFit], cl: f64, ci95: [f64; 2]| match check(fits, cl, ci95) {
        Ok(check) => (Some(check), None),
        Err(reason) => (None, Some(reason)),
    };
    let final_test = |selected: &[EffectFit]| match selected.last() {
        Some(last) => test(&selected.iter().collect::<Vec<_>>(), last.cl.estimate, last.cl.ci95),
        None => test(&[], baseline.cl, base.fit.estimate("Cl").map_or([f64::NAN; 2], |e| [e.ci95.0, e.ci95.1])),
    };
    let mut tested = final_test(&selected);
    if let Some(failed) = tested.0.as_ref().filter(|c| !c.consistent)
        && let Some(added) = select::for_cl(p, &mut selected, failed.hausman, |f, cl, ci| check(f, cl, ci).ok())
    {
        selection_ended = format!("{selection_ended}; then {added}");
        tested = final_test(&selected);
    }
    let verdict = selected.first().map_or_else(|| "none".to_string(), |e| e.name.to_string());
    let unexplained = selected.is_empty() && first.is_none() && baseline.misses_materially(baseline.rms) == Some(true);
    let base_cl = base.fit.estimate("Cl").map_or([f64::NAN; 2], |e| [e.ci95.0, e.ci95.1]);
    // A ceramic's bias law between the levels the data visits is not in the data: Cl under the
    // other law's shape too.
    let (mut preferred_circuit, mut preferred_residual) = (None, None);
    let spread = BiasLawSpread::of(p, &selected).map(|(spread, alt)| {
        if spread.prefers_other() {
            select::at_final_values(&mut selected, &alt, nominal);
            preferred_circuit = Some(alt.fit.params);
            preferred_residual = Some(effect::residual(&alt));
        }
        spread
    });
    // The final model read later than the period start, where the data says so: after the law's
    // swap, so that the instant is tested on the model whose Cl is reported.
    let reported_ci95 = selected.last().map(|l| spread.as_ref().map_or(l.cl.ci95, |s| s.reported(l.cl.estimate, l.cl.ci95).1));
    let read_late = reported_ci95.and_then(|ci95| select::read_late(p, &selected, ci95));
    // Or, read late on both channels, vout read apart from il alike to the effects beside it.
    let read_late = read_late.or(read_apart);
    // The final model with Cl's capacitance moved into C, as good (see `ridge`).
    let ridge_twin = reported_ci95.and_then(|ci95| ridge::twin(p, &selected, ci95));
    // The final circuit with its law's shape (the other law's fit, where the data prefers it),
    // run on the data's inputs where that tells something: a ceramic's operating point (a law
    // the nominal brings keeps its own reference), a diode buck's share of DCM periods.
    let final_stack = selected.last().and_then(|last| select::Stack::of(&selected.iter().collect::<Vec<_>>(), nominal, last.cl.estimate, true).ok());
    let final_circuit = selected.last().and(preferred_circuit.or_else(|| final_stack.as_ref().map(|s| s.params)));
    let biased = |p: &Params| p.cap_dc_bias > 0.0 && !own_bias_law;
    let operation = final_circuit.filter(|p| biased(p) || p.asynchronous()).and_then(|p| estimator::simulated::operation(&p, data, data.vout[0]).ok().map(|o| (p, o)));
    let operating = operation.filter(|(p, _)| biased(p)).and_then(|(p, o)| bias_law::operating_point(&p, o.vout_time_mean));
    let dcm_share = operation.filter(|(p, _)| p.asynchronous()).map(|(_, o)| o.dcm_share);
    let cl_leverage = if switched { leverage(data, nominal, &selected, preferred_circuit, baseline.cl, opts.nominal == Nominal::Switched, n_est) } else { None };
    let cl_circuit_fidelity = if selected.iter().any(|e| effect::approximates_a_device(e.name)) { CIRCUIT_FIDELITY_WITH_DEVICES } else { CIRCUIT_FIDELITY };
    let cl_fidelity = tested::fidelity(if selected.is_empty() { CL_FIDELITY } else { CL_FIDELITY_WITH_EFFECTS }, cl_circuit_fidelity, cl_leverage.as_ref());
    let (nominal_cl, cl_at_fidelity) = if let Some((last, earlier)) = selected.split_last_mut() {
        // The model's miss is judged by what the reported fit leaves (the other law's, where
        // the data prefers it).
        let left = preferred_residual.as_deref().unwrap_or(&last.residual);
        if let Some(check) = tested.0.as_mut() {
            check.model_misses = baseline.misses_above_floor(effect::rms(left)).unwrap_or(false);
            last.cl.take_reported(check, baseline.cl);
        }
        (last.cl.check, last.cl.check_skipped) = tested;
        if let Some(spread) = spread {
            (last.cl.estimate, last.cl.ci95) = spread.reported(last.cl.estimate, last.cl.ci95);
            // The other law's own interval knows nothing of the test the final law's failed.
            if let Some(check) = last.cl.check.as_ref().filter(|_| spread.prefers_other()) {
                last.cl.ci95 = check.disagreement_spanned(last.cl.estimate, last.cl.ci95);
            }
            last.cl.moved_from(baseline.cl);
            last.cl.bias_law = Some(spread);
        }
        if let Some((v, ratio)) = operating {
            last.cl.read_at(v, ratio, baseline.cl);
        }
        (last.cl.ci95, last.cl.widened_by, last.cl.misses_by_floors) = baseline.judged_by_miss(last.cl.estimate, last.cl.ci95, left);
        // In deep DCM a charge the model misses is what Cl hides (unless the miss is gross,
        // which voids it already).
        if let (Some(share), Some(floor), None) = (dcm_share, baseline.floor, last.cl.misses_by_floors) {
            last.cl.deep_dcm_miss = effect::DeepDcmMiss::of(share, effect::rms(left) / floor);
            if last.cl.deep_dcm_miss.is_some() {
                last.cl.ci95 = [0.0, f64::INFINITY];
            }
        }
        if let Some(law) = last.cl.bias_law.as_ref() {
            last.cl.ci95 = law.spanned(last.cl.ci95);
        }
        if let Some(twin) = twin.or(pruned_twin) {
            last.cl.ci95 = twin.spanned(last.cl.ci95);
            last.cl.twins.push(twin);
        }
        // The joint model from the nominal values, as good as the path, then the other end of
        // the C–Cl ridge, each where it puts Cl outside the interval even so (spanned after any
        // other twin, and said beside it).
        for twin in [nominal_twin, ridge_twin].into_iter().flatten() {
            if !(last.cl.ci95[0]..=last.cl.ci95[1]).contains(&twin.cl) {
                last.cl.ci95 = twin.spanned(last.cl.ci95);
                last.cl.twins.push(twin);
            }
        }
        let [lo, hi] = last.cl.ci95;
        if let Some(late) = read_late.filter(|late| estimator::validate::identified([lo, hi]) && !(lo..=hi).contains(&late.cl)) {
            last.cl.ci95 = late.spanned(last.cl.ci95);
            last.cl.read_late = Some(late);
        }
        // A model whose inductor current the measured one matches only through an implausible
        // probe gain has the wrong impedance: its Cl is not the converter's.
        // (Switched data, as the model sees it: the duty delayed where it is late.)
        let misfit = final_stack.as_ref().filter(|_| switched).zip(final_circuit).and_then(|(s, p)| CurrentMisfit::of(&s.data(data), &p, n_est));
        let fits_l = final_stack.as_ref().filter(|s| s.free.contains(&Free::L)).and(final_circuit);
        last.cl.held_to_current(misfit, fits_l.as_ref());
        let at_fidelity;
        (last.cl.ci95, at_fidelity) = tested::at_fidelity_of(last.cl.estimate, last.cl.ci95, cl_fidelity);
        // A final model that still misses lacks an effect the size of its last steps: Cl of
        // the models along its path that miss about as much, where it lies outside even so.
        if let (Some(floor), Some(_)) = (baseline.floor, last.cl.widened_by) {
            last.cl.near_steps = effect::NearStep::of(earlier, effect::rms(left), floor, last.cl.ci95);
            for step in &last.cl.near_steps {
                last.cl.ci95 = step.spanned(last.cl.ci95);
            }
        }
        (None, at_fidelity)
    } else {
        let judged = TestedCl::judged(&baseline, baseline.cl, base_cl, tested, &residual, cl_fidelity);
        let judged = if switched { judged.against_current(data, nominal, n_est) } else { judged };
        let at_fidelity = judged.at_fidelity;
        (Some(judged), at_fidelity)
    };
    // The verdict's entry in the table carries the same test when it is the final model.
    if let [only] = selected.as_slice()
        && let Some(e) = effects.iter_mut().find(|e| e.name == only.name)
    {
        e.cl = only.cl.clone();
    }
    // The noise floor from the data alone; where the inputs step too often for that, what the
    // final model leaves (else the nominal residual).
    let floor = match baseline.floor {
        Some(sigma) => locate::Floor::White(sigma),
        None => locate::Floor::Residual(selected.last().map_or(&residual, |e| &e.residual)),
    };
    let location = locate::locate(data, n_est, &residual, floor);
    // Values beyond the devices they name, said where they stand (single fits and the final model).
    for e in effects.iter_mut().chain(selected.iter_mut()) {
        e.stand_in = e.beyond_the_device();
    }
    let measured = base.validation.traces.measured.clone();
    let after = selected.last().map(|e| measured.iter().zip(&e.residual).map(|(m, r)| m - r).collect());
    let traces = Traces { start: n_est, nominal: base.validation.traces.simulated.clone(), measured, after };
    Ok(Diagnosis {
        gap_before: Before::of(&base, &baseline, base_cl, nominal_cl),
        location,
        effects,
        not_tested,
        selected,
        selection_ended,
        verdict,
        unexplained,
        dcm_share,
        cl_leverage,
        cl_at_fidelity,
        cl_fidelity,
        cl_circuit_fidelity,
        nominal: opts.nominal,
        measured_inputs,
        traces,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A nominal Cl voided by its current (the verdict `none`) says so in its sentence, as a
    /// final model's does: the misfit is carried through [`Before`].
    #[test]
    fn the_nominals_current_misfit_reaches_its_sentence() {
        let misfit = CurrentMisfit { probe_gain: 0.6, beyond_tolerance: 1.7, floor: 0.02, explained: 2.0 };
        let before = Before {
            model: "pwm",
            nrmse: 0.1,
            rms: 0.01,
            cl: 10e-6,
            cl_ci95: [0.0, f64::INFINITY],
            cl_check: None,
            cl_check_skipped: None,
            cl_widened_by: None,
            cl_misses_by_floors: None,
            cl_current_misfit: Some(misfit),
            misses_by_floors: None,
        };
        assert!(before.cl_move().sentence(None).contains("probe gain of ×0.60"), "{}", before.cl_move().sentence(None));
    }
}
