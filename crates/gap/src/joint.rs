//! The joint refit: the effects a real converter carries, fitted together, then pruned.
//!
//! Forward selection judges each effect on top of those taken before it. A real converter carries
//! five or six at once (a late ADC, dead time, the switches' resistance, an inductor 12 % low and a
//! capacitor's ESR 40 % low), and a greedy path through them takes stand-ins that explain a
//! part of several (a load ESR, C drifted) and ends with a model that still misses materially,
//! the sequence full. Where it misses materially with the sequence full, or by more than
//! [`MISS_FLOORS`] noise floors, the model is refitted with, besides the effects selected, what
//! every converter of its kind carries free at once: the drifts of L, C and Rc, the switches'
//! resistance, the late reading (where il is recorded), the vout reading's gain, the load
//! capacitor's ESR, and, where something conducts while both switches are off, the switch node's
//! capacitance and a diode's slope resistance (where the data does not pin that ESR down beside
//! the rest, the refit is made without it). When that model closes a material share of the gap
//! left, it is pruned: an effect the refit added whose parameters the data does not pin down
//! first, then drifts within tolerance (back to nominal together), then one the selection found
//! that the data still does not pin down, then one at a time the effect that, given all the
//! others, closes the least of the gap they leave while it is no finding (immaterial, not
//! identified, on a bound; the immaterial ones together when jointly so). A model pruned away
//! for effects that were physical there, whose Cl the final interval leaves out, is the final
//! model's twin: the data does not prefer either, and Cl's interval spans both (a drift of C
//! that Cl took up once pruned).
//!
//! The refit starts from the selection's values, where a path of stand-ins holds it in their
//! valley. Where the path and that refit both stay far above the floor, the refit starts again
//! from each drift at an end of its tolerance ([`DRIFT_GRID`]). The converter's joint model is
//! also fitted from its nominal values ([`from_nominal`]) where the path taken still misses
//! materially or its model's inductor current contradicts the measured one.
use buck_model::Params;
use estimator::identify::Candidate;
use estimator::model::Free;
use rayon::prelude::*;

use crate::effect::{DRIFTING, EffectFit, MATERIAL_SHARE, MAX_DRIFT, SIMULATED_EFFECTS, Twin, effect_label, judge, residual, rms};
use crate::problem::Problem;
use crate::select::{DIODE_RESISTANCE_STARTS, DIODE_TOPOLOGY, Extension, STUCK_FLOORS, SWITCH_NODE_CAPACITANCE_STARTS, SWITCH_RESISTANCE_STARTS, Stack};

/// Factors on a drifting value's nominal that the joint refit of a stuck path also starts from,
/// one value at a time: the ends of the design table's ±20 % tolerance. A point-of-load buck
/// with C 17 % low and 1.64 µF of load behind 0.22 Ω took an inductor's saturation and a dead
/// time for it (L's drift alone fitted better than C's), stopped 94 floors above the noise, and
/// its refit from there stayed at C −5 % and 51 floors; from Rc at either end the refit finds
/// C −17 % at 3–7 mV, and the pruned model (the dead time, C, the switches, the node's charge)
/// has Cl 1.7 [0.38, 3.6] µF.
const DRIFT_GRID: [f64; 2] = [0.8, 1.2];

/// An effect of the joint model and the free parameters it owns.
#[derive(Debug, Clone)]
struct Group {
    name: &'static str,
    frees: Vec<Free>,
    /// Taken by the forward selection (else added by the joint model).
    selected: bool,
}

impl Group {
    /// Its name, with the value it frees where the name alone does not say ([`effect_label`]).
    fn label(&self) -> String {
        effect_label(self.name, self.frees.first().map(|f| f.name()))
    }
}

/// The final model's held-out residual, in multiples of the noise floor (RMS), above which the
/// joint refit is tried: a model error of three times the noise's power is what a sequence of
/// stand-ins leaves (a harness capture with five effects: 8×), where one that nearly closed the
/// gap leaves 1.1–1.9× (a diode's exponential knee, a 1 mΩ resistance), which the refit,
/// costing a round of fits per effect pruned, would not change.
const MISS_FLOORS: f64 = 2.0;

/// The load capacitor's ESR the joint refit starts from \[Ω\] (a ceramic's or a polymer's is a
/// few mΩ; vout is linear in it).
const LOAD_ESR_START: f64 = 1e-3;

/// An effect of the joint model judged against the model refitted without it.
struct Without {
    /// Its index in the groups.
    k: usize,
    /// Its fit as a step on top of all the others (`None`: its parameters not identified).
    fit: Option<EffectFit>,
    /// The model without it, and that model's fit.
    less: Stack,
    against: Candidate,
}

impl Without {
    /// How much of the gap the others leave it closes (least first; not identified, or no
    /// material gap left without it: below all).
    fn strength(&self) -> f64 {
        self.fit.as_ref().and_then(|f| f.closed_of_remaining).unwrap_or(f64::NEG_INFINITY)
    }

    fn finding(&self) -> bool {
        self.fit.as_ref().is_some_and(|f| f.finding)
    }
}

/// The first start value of a simulated effect's parameter `f` on top of `base`, as its
/// candidate has it ([`SIMULATED_EFFECTS`]).
fn candidate_start(name: &str, f: Free, base: &Params) -> Option<f64> {
    SIMULATED_EFFECTS.iter().find(|e| e.name == name)?.starts(base, 0.0).first().map(|p| f.get(p))
}

/// The model without `g`: its parameters free no more, at their nominal values (a late
/// reading's calibration of il and its lock to the PWM with it).
fn without(stack: &Stack, g: &Group, nominal: &Params) -> Stack {
    let mut s = stack.clone();
    s.free.retain(|f| !g.frees.contains(f));
    for f in &g.frees {
        f.set(&mut s.params, f.get(nominal));
    }
    if g.frees.contains(&Free::SampleDelay) {
        (s.params.il_offset, s.params.il_gain_error, s.params.sample_duty_share) = (nominal.il_offset, nominal.il_gain_error, nominal.sample_duty_share);
    }
    // The effects that free no value change the structure: a duty applied late, an ideal diode.
    match g.name {
        "delay" => s.delay = 0,
        "dcm" => s.params.dcm = nominal.dcm,
        "switch_node_ring" => s.params.switch_node_ring = nominal.switch_node_ring,
        _ => {}
    }
    // Without dead time or a diode nothing conducts while both switches are off: the switch
    // node's capacitance (and its ring's damping) and a diode's slope resistance go with them.
    // Without the switches' resistance, the low side's ratio to it goes too (it scales nothing:
    // the fit without the switches was singular, and the joint model, whose pruning needs every
    // effect judged without it, was dropped after 4 s of refits).
    let mut dependent = Vec::new();
    if !(s.params.dead_time > 0.0 || s.params.asynchronous() || s.params.dcm) {
        dependent.extend([Free::SwitchNodeCapacitance, Free::SwitchNodeDamping, Free::DiodeResistance]);
    }
    if !s.free.contains(&Free::SwitchResistance) && s.params.switch_resistance == nominal.switch_resistance {
        dependent.push(Free::LowSideRatio);
    }
    for f in dependent {
        s.free.retain(|&x| x != f);
        f.set(&mut s.params, f.get(nominal));
    }
    s
}

/// The model `stack` without the groups `gone` ([`without`]), refitted: the model at its fitted
/// values, and its fit.
fn refitted_without<'a>(p: &Problem, stack: &Stack, gone: impl IntoIterator<Item = &'a Group>) -> Option<(Stack, Candidate)> {
    let Problem { data, nominal, n_est, holdout, .. } = *p;
    let less = gone.into_iter().fold(stack.clone(), |s, g| without(&s, g, nominal));
    let fit = less.fit(data, &[less.params], n_est, holdout).ok()?;
    Some((Stack { params: fit.fit.params, ..less }, fit))
}

/// `g` judged on top of the model without it (fitted as `against`) in the model `with` (fitted
/// as `cand`): `None` when its parameters are not identified there.
fn judged(p: &Problem, g: &Group, with: &Stack, cand: &Candidate, against: &Candidate) -> Option<EffectFit> {
    let Problem { data, nominal, n_est, baseline, .. } = *p;
    let x = Extension::within(with, g.name, &g.frees, against.fit.params);
    let t = x.assess(cand.clone(), data, nominal).ok()?;
    let (mut fit, _) = judge(g.name, t, against, n_est, baseline);
    fit.judge_by_il(&g.frees, &with.data(data), &against.fit.params, &cand.fit.params, n_est, baseline.tolerance);
    Some(fit.into_step())
}

/// Effects pruned from the model `cand` although physical there: their values identified, a
/// circuit value's drift within [`MAX_DRIFT`] of `nominal`. That model, which the data does not
/// reject, is a model of the converter.
fn physical<'a>(gone: impl IntoIterator<Item = &'a Group>, cand: &Candidate, nominal: &Params) -> bool {
    gone.into_iter().flat_map(|g| &g.frees).all(|f| {
        let drift = DRIFTING.contains(f).then(|| f.get(&cand.fit.params) / f.get(nominal) - 1.0);
        cand.fit.estimate(f.name()).is_some_and(|e| estimator::validate::identified([e.ci95.0, e.ci95.1])) && drift.is_none_or(|d| d.abs() <= MAX_DRIFT)
    })
}

/// The joint model of `groups`, fitted as `cand`, as a twin of the one pruned from it.
fn twin_of(groups: &[Group], cand: &Candidate) -> Twin {
    let (cl, ci95) = cand.fit.estimate("Cl").map_or((f64::NAN, [0.0, f64::INFINITY]), |e| (e.value, [e.ci95.0, e.ci95.1]));
    Twin { selected: groups.iter().map(Group::label).collect(), rms_after: rms(&residual(cand)), cl, ci95 }
}

/// The joint refit after the selection `selected` (see the module's documentation), when its
/// final model still misses materially on switched data: `selected` becomes the pruned joint
/// model's effects (those selected before, in their order, then those it added, the most
/// material first), each with its step's fit. Returns what changed.
pub(crate) fn refit(p: &Problem, selected: &mut Vec<EffectFit>) -> Option<String> {
    let Problem { baseline, .. } = *p;
    let last = selected.last()?;
    // A full sequence that still misses materially ran out of steps, not of effects.
    let full = selected.len() >= crate::select::MAX_EFFECTS;
    if baseline.misses_materially(last.rms_after) != Some(true) || (!full && baseline.floor.is_none_or(|f| last.rms_after < MISS_FLOORS * f)) {
        return None;
    }
    // A load capacitor's ESR beside a late reading and the switches' resistance was a
    // stand-in's to take (a point-of-load buck's 4.4 mΩ gave a vout gain error and C +7 %,
    // and Cl 85 µF for 96). Where the data does not pin it down, or the refit with it keeps
    // nothing, the refit is made again from the selection's values without it: one that merely
    // dropped it started where the ESR had pulled the rest, and pruned a late reading il shows;
    // and a model with it that closed no material share landed where the one without it
    // closed 58 % (a diode buck's).
    let free_load_esr = !selected.iter().any(|e| e.name == "load_esr");
    if free_load_esr && let Some(done) = refit_with(p, selected, true) {
        return Some(done);
    }
    refit_with(p, selected, false)
}

/// The selected effects `fits` as groups of a joint model (Cl at `cl`), each owning what it frees
/// on top of those before it; the first `skip` (the switched model's ripple) left out.
fn groups_of(fits: &[&EffectFit], skip: usize, nominal: &Params, cl: f64, switched: bool) -> Option<Vec<Group>> {
    let mut groups = Vec::new();
    let mut before = Stack::nominal(nominal, cl, switched).free;
    for k in 0..fits.len() {
        let after = Stack::of(&fits[..=k], nominal, cl, switched).ok()?.free;
        if k >= skip {
            groups.push(Group { name: fits[k].name, frees: after.iter().filter(|f| !before.contains(f)).copied().collect(), selected: true });
        }
        before = after;
    }
    Some(groups)
}

/// Effects that decide how the converter switches (its kind), kept from a selection in the
/// joint model from the nominal values.
const KIND: [&str; 4] = ["diode_drop", "dcm", "dead_time", "delay"];

/// The converter's joint model from its nominal values: the effects of its kind that `selected`
/// holds (a diode, DCM, dead time, a delay), with what every converter of that kind carries
/// (the drifts of L, C and Rc, the switches' resistance and, in a synchronous one, the low
/// side's own, the late reading where il is recorded, and where something conducts while both
/// switches are off the node's capacitance and a diode's slope resistance), every value where a
/// fit of it alone would start and Cl from its grid, then pruned as the joint refit is. A greedy
/// path can take stand-ins first and then stay in their valley, its joint refit too: harness
/// 3434/36 (L +11 %, a 35 mΩ high side over a 14 mΩ low side, read 142 ns late) was selected as
/// a 1 Ω load ESR, a filter and a gain error, 1.5 floors above the noise with Cl not
/// identified; this model is L, the switches and the instant as drawn, at the floor. Neither
/// the vout reading's calibration nor a load ESR is in it: alone with the drifts, they are the
/// stand-ins. `None` where its fit fails or its pruning leaves no physical model.
///
/// It must close a material share of the gap `gap_left` (held-out RMS): before its pruning,
/// which costs a round of refits per effect, and after. Where it leaves no more than that but
/// closes no material share of it, it is as good a model, and a twin of the path's.
pub(crate) fn from_nominal(p: &Problem, selected: &[EffectFit], gap_left: f64) -> Option<FromNominal> {
    let Problem { data, nominal, n_est, baseline, .. } = *p;
    let kind: Vec<&EffectFit> = selected.iter().filter(|e| KIND.contains(&e.name)).collect();
    let mut stack = Stack::of(&kind, nominal, baseline.cl, true).ok()?;
    let mut groups = groups_of(&kind, 0, nominal, baseline.cl, true)?;
    let has = |n: &str| kind.iter().any(|e| e.name == n);
    let diode = DIODE_TOPOLOGY.iter().any(|n| has(n));
    let mut adds: Vec<(&'static str, Free)> = DRIFTING.into_iter().map(|f| ("param_drift", f)).collect();
    adds.push(("switch_resistance", Free::SwitchResistance));
    if !diode {
        adds.push(("unequal_switches", Free::LowSideRatio));
    }
    if data.il.is_some() {
        adds.push(("sample_delay", Free::SampleDelay));
    }
    if diode || has("dead_time") {
        adds.push(("switch_node_capacitance", Free::SwitchNodeCapacitance));
    }
    if diode {
        adds.push(("diode_resistance", Free::DiodeResistance));
    }
    for (name, f) in adds {
        stack.free.push(f);
        groups.push(Group { name, frees: vec![f], selected: false });
    }
    stack.params = nominal_start(&stack, &groups, nominal);
    let cand = stack.fit_over_cl(data, n_est).ok()?;
    let left = rms(&residual(&cand));
    if baseline.closed_of_material_gap(gap_left, left).is_none_or(|c| c < MATERIAL_SHARE) {
        // A twin as the pruning's are: a model of the converter, and one that pins Cl down.
        let cl_identified = cand.fit.estimate("Cl").is_some_and(|e| estimator::validate::identified([e.ci95.0, e.ci95.1]));
        return (left <= gap_left && cl_identified && physical(&groups, &cand, nominal)).then(|| FromNominal::AsGood(twin_of(&groups, &cand)));
    }
    settle(p, stack, cand, groups, Vec::new(), gap_left).map(|(out, _)| FromNominal::Closes(out))
}

/// What the converter's joint model from its nominal values comes to ([`from_nominal`]).
pub(crate) enum FromNominal {
    /// Pruned, it closes a material share of the gap left: its effects, each with its step's fit.
    Closes(Vec<EffectFit>),
    /// Unpruned, it leaves no more than the gap but closes no material share of it: as good a
    /// model, whose Cl the data does not tell from the path's (a pol buck with C +13 % and an
    /// ESL ended at the floor with Rc +24 % and a gain error, Cl 11.0 [10.7, 11.2] µF for 2.03;
    /// this model, with C at +12 %, at 2.38 [1.80, 3.15] µF, 1.532 mV held out against 1.534).
    AsGood(Twin),
}

/// The joint model `stack` of `groups` with every value they free where a fit of it alone would
/// start: the drifts at their nominal values, each effect at its candidate's first start
/// ([`candidate_start`]).
fn nominal_start(stack: &Stack, groups: &[Group], nominal: &Params) -> Params {
    let mut p = stack.params;
    for g in groups {
        for &f in &g.frees {
            let start = match f {
                Free::L | Free::C | Free::Rc | Free::LowSideRatio => Some(f.get(nominal)),
                Free::SwitchResistance => Some(SWITCH_RESISTANCE_STARTS[0]),
                Free::DiodeResistance => Some(DIODE_RESISTANCE_STARTS[0]),
                Free::SwitchNodeCapacitance => Some(SWITCH_NODE_CAPACITANCE_STARTS[0]),
                _ => candidate_start(g.name, f, nominal),
            };
            if let Some(v) = start {
                f.set(&mut p, v);
            }
        }
    }
    p
}

/// [`refit`] past its precondition, freeing the load capacitor's ESR too where `load_esr`
/// (`None` where it is not identified then).
fn refit_with(p: &Problem, selected: &mut Vec<EffectFit>, load_esr: bool) -> Option<String> {
    let Problem { data, nominal, switched_nominal, n_est, holdout, baseline, .. } = *p;
    let last = selected.last()?;
    let fits: Vec<&EffectFit> = selected.iter().collect();
    let mut stack = Stack::of(&fits, nominal, last.cl.estimate, switched_nominal).ok()?;
    if !stack.switched {
        return None;
    }
    // The selected effects' own parameters: what each adds to the model of those before it.
    // The ripple (against an averaged nominal) is the switched model itself, which the refit
    // needs: it stays first, out of the pruning.
    let ripple: Vec<EffectFit> = selected.iter().take_while(|e| e.name == "switching_ripple").cloned().collect();
    let mut groups = groups_of(&fits, ripple.len(), nominal, last.cl.estimate, switched_nominal)?;
    let has = |n: &str| fits.iter().any(|e| e.name == n);
    let diode = DIODE_TOPOLOGY.iter().any(|n| has(n));
    let mut adds: Vec<(&'static str, Free, f64)> = DRIFTING.into_iter().map(|f| ("param_drift", f, f.get(&stack.params))).collect();
    if !stack.free.contains(&Free::RL) {
        adds.push(("switch_resistance", Free::SwitchResistance, SWITCH_RESISTANCE_STARTS[0].max(stack.params.switch_resistance)));
    }
    if data.il.is_some() {
        adds.push(("sample_delay", Free::SampleDelay, candidate_start("sample_delay", Free::SampleDelay, &stack.params)?));
    }
    if diode || has("dead_time") {
        adds.push(("switch_node_capacitance", Free::SwitchNodeCapacitance, SWITCH_NODE_CAPACITANCE_STARTS[0].max(stack.params.switch_node_capacitance)));
    }
    // A divider's or a probe's gain error (its zero error is a resistance's drop at a constant
    // load: left to the forward selection, which names the circuit first).
    adds.push(("sensor_gain", Free::VoutGainError, candidate_start("sensor_gain", Free::VoutGainError, &stack.params)?));
    if load_esr {
        adds.push(("load_esr", Free::LoadEsr, LOAD_ESR_START));
    }
    if diode {
        adds.push(("diode_resistance", Free::DiodeResistance, DIODE_RESISTANCE_STARTS[0].max(stack.params.diode_resistance)));
    }
    for (name, f, start) in adds {
        if !stack.free.contains(&f) {
            f.set(&mut stack.params, start);
            stack.free.push(f);
            groups.push(Group { name, frees: vec![f], selected: false });
        }
    }
    let cand = stack.fit(data, &[stack.params], n_est, holdout);
    // A path stuck far above the floor (`select::STUCK_FLOORS`) whose refit from its values is
    // stuck too: its stand-ins' valley held the refit. It starts again from each drift at an end
    // of its tolerance, the rest as selected, and the fit that leaves least is kept.
    let stuck = |rms_left: f64| baseline.floor.is_some_and(|f| rms_left > STUCK_FLOORS * f);
    let left = |c: Candidate| (rms(&residual(&c)), c);
    let cand = match cand.map(left) {
        Ok((rms_left, cand)) if stuck(last.rms_after) && stuck(rms_left) => {
            let moved = |f: Free, k: f64| {
                let mut start = stack.params;
                f.set(&mut start, k * f.get(nominal));
                start
            };
            let starts: Vec<Params> = DRIFTING.into_iter().flat_map(|f| DRIFT_GRID.map(|k| moved(f, k))).collect();
            let fits: Vec<(f64, Candidate)> = starts.par_iter().filter_map(|start| stack.fit(data, std::slice::from_ref(start), n_est, holdout).ok().map(left)).collect();
            // The first of equals: the refit from the selection's values before the grid's.
            std::iter::once((rms_left, cand)).chain(fits).min_by(|a, b| a.0.total_cmp(&b.0)).map(|(_, c)| c)?
        }
        cand => cand.ok()?.1,
    };
    if load_esr && cand.fit.estimates.iter().any(|e| e.name == Free::LoadEsr.name() && !estimator::validate::identified([e.ci95.0, e.ci95.1])) {
        return None;
    }
    let share = baseline.closed_of_material_gap(last.rms_after, rms(&residual(&cand)))?;
    if share < MATERIAL_SHARE {
        return None;
    }
    let (out, dropped) = settle(p, stack, cand, groups, ripple, last.rms_after)?;
    *selected = out;
    let names = |gs: &[Group]| gs.iter().map(|g| g.label()).collect::<Vec<_>>().join(", ");
    Some(format!(
        "the joint refit (every effect such a converter carries, fitted together) closes {share:.1} % of the gap left; pruned of {}",
        if dropped.is_empty() { "nothing".to_string() } else { names(&dropped) }
    ))
}

/// The joint model `stack` (its effects `groups`, the switched model's `ripple` before them),
/// fitted as `cand`, pruned (see the module's documentation) to the effects that are findings
/// given all the others; `None` where it leaves no physical model, or one that no longer
/// closes a material share of the gap `gap_left` (held-out RMS) it was fitted to close. The
/// pruned model's effects in sequence, each with its step's fit, and the effects pruned.
fn settle(p: &Problem, mut stack: Stack, mut cand: Candidate, mut groups: Vec<Group>, ripple: Vec<EffectFit>, gap_left: f64) -> Option<(Vec<EffectFit>, Vec<Group>)> {
    let Problem { nominal, baseline, .. } = *p;
    // With every drift free at once, values the data barely tells apart (L against a saturating
    // core, C against Cl) can wander far past any tolerance: such a fit ended on a bound, no
    // physical model to prune. Pruning it back brought nothing on any set it was tried on, for
    // seconds of refits (a lab buck's L −50 %, C +107 % and Rc −60 %).
    if DRIFTING.into_iter().any(|f| (f.get(&cand.fit.params) / f.get(nominal) - 1.0).abs() > MAX_DRIFT) {
        return None;
    }
    stack.params = cand.fit.params;
    // Pruned one at a time: each effect refitted without, the least material non-finding
    // dropped (one whose parameters are not identified before any other).
    let mut dropped = Vec::new();
    // The models pruned for effects that were no finding but physical ([`physical`]): the data
    // does not prefer the model without them.
    let mut pruned: Vec<Twin> = Vec::new();
    let findings = loop {
        // With every effect the refit added pruned again, what is left is the selection's own
        // model, or less of it: nothing it could change (the backward step has judged those).
        if groups.iter().all(|g| g.selected) {
            return None;
        }
        // Pruning only takes away: once what is left closes no material share of the gap the
        // selection left, the refit has failed (the final check below), and the rounds of refits
        // still to come would only confirm it.
        if baseline.closed_of_material_gap(gap_left, rms(&residual(&cand))).is_none_or(|c| c < MATERIAL_SHARE) {
            return None;
        }
        // A parameter the data does not pin down beside the others: its effect goes first, one the
        // refit added before one the selection found (a diode's drop lost beside the slope
        // resistance and node capacitance added to it is the diode's, not theirs to take). One the
        // selection found goes only after the drifts within tolerance, which are the nominal's
        // anyway: harness 3232/35's 36 mΩ load ESR beside 1.2 µF, lost beside L, C and Rc all
        // free, was pruned for them (then back at nominal), and Cl with it.
        let lost: Vec<usize> = cand
            .fit
            .estimates
            .iter()
            .filter(|e| e.name != "Cl" && !estimator::validate::identified([e.ci95.0, e.ci95.1]))
            .filter_map(|e| groups.iter().position(|g| g.frees.iter().any(|f| f.name() == e.name)))
            .collect();
        // Drifts within the tolerance of their nominal values are consistent with them: back to
        // nominal together, without a round of refits.
        let tolerated: Vec<usize> =
            (0..groups.len()).filter(|&k| groups[k].name == "param_drift" && groups[k].frees.iter().all(|f| (f.get(&stack.params) / f.get(nominal) - 1.0).abs() <= baseline.tolerance)).collect();
        let added_lost = lost.iter().copied().find(|&k| !groups[k].selected);
        if let Some(k) = added_lost.or(lost.first().copied().filter(|_| tolerated.is_empty())) {
            (stack, cand) = refitted_without(p, &stack, [&groups[k]])?;
            dropped.push(groups.remove(k));
            continue;
        }
        if !tolerated.is_empty() {
            (stack, cand) = refitted_without(p, &stack, tolerated.iter().map(|&k| &groups[k]))?;
            dropped.extend(tolerated.iter().rev().map(|&k| groups.remove(k)));
            continue;
        }
        let trials: Vec<Without> = groups
            .par_iter()
            .enumerate()
            .filter_map(|(k, g)| {
                let (less, against) = refitted_without(p, &stack, [g])?;
                let fit = judged(p, g, &stack, &cand, &against);
                Some(Without { k, fit, less, against })
            })
            .collect();
        let Some(weakest) = trials.iter().filter(|t| !t.finding()).min_by(|a, b| a.strength().total_cmp(&b.strength())).map(|t| t.k) else {
            break trials;
        };
        // The immaterial ones all at once (a round of refits saved per effect), when together
        // they close no material share of the gap the model leaves without them.
        let immaterial: Vec<usize> = trials.iter().filter(|t| t.fit.as_ref().is_none_or(|f| !f.finding && !f.material)).map(|t| t.k).collect();
        if immaterial.len() > 1
            && let Some((less, against)) = refitted_without(p, &stack, immaterial.iter().map(|&k| &groups[k]))
            && baseline.closed_of_material_gap(rms(&residual(&against)), rms(&residual(&cand))).is_none_or(|c| c < MATERIAL_SHARE)
        {
            if physical(immaterial.iter().map(|&k| &groups[k]), &cand, nominal) {
                pruned.push(twin_of(&groups, &cand));
            }
            dropped.extend(immaterial.iter().rev().map(|&k| groups.remove(k)));
            (stack, cand) = (less, against);
            continue;
        }
        let Without { less, against, .. } = trials.into_iter().find(|t| t.k == weakest)?;
        if physical([&groups[weakest]], &cand, nominal) {
            pruned.push(twin_of(&groups, &cand));
        }
        dropped.push(groups.remove(weakest));
        (stack, cand) = (less, against);
    };
    // The pruned model must still do what the refit was for: close a material share of the gap
    // the selection left (pruning a found effect can bring the rest down with it).
    if findings.len() != groups.len() || groups.is_empty() || baseline.closed_of_material_gap(gap_left, rms(&residual(&cand))).is_none_or(|c| c < MATERIAL_SHARE) {
        return None;
    }
    // In sequence: the selected effects kept, in their order, then those added, the most
    // material first; each step's figures from the model of the effects up to it.
    let mut order: Vec<(Group, EffectFit)> = groups.into_iter().zip(findings.into_iter().filter_map(|t| t.fit)).collect();
    // (A stable sort: the selected keep their order.)
    order.sort_by(|a, b| {
        let rank = |g: &(Group, EffectFit)| if g.0.selected { (false, 0.0) } else { (true, -g.1.closed_of_remaining.unwrap_or(0.0)) };
        rank(a).partial_cmp(&rank(b)).unwrap_or(std::cmp::Ordering::Equal)
    });
    let steps: Vec<Option<Candidate>> = (0..order.len())
        .into_par_iter()
        .map(|j| {
            if j + 1 == order.len() {
                return Some(cand.clone());
            }
            refitted_without(p, &stack, order[j + 1..].iter().map(|(g, _)| g)).map(|(_, fit)| fit)
        })
        .collect();
    let mut out: Vec<EffectFit> = ripple;
    for ((_, mut fit), step) in order.into_iter().zip(steps) {
        fit.step_from(&step?, baseline);
        // What it closes of the gap left by the steps before it (as a forward step reports; it
        // was judged given all the others).
        fit.closed_of_remaining = baseline.closed_of_material_gap(out.last().map_or(baseline.rms, |e| e.rms_after), fit.rms_after);
        out.push(fit);
    }
    // A pruned model whose Cl the pruned one's interval leaves out: the pruning's twin (the
    // farthest from it, in ln Cl).
    if let Some(last) = out.last_mut() {
        let [lo, hi] = last.cl.ci95;
        let far = |t: &Twin| {
            if t.cl < lo {
                (lo / t.cl).ln()
            } else if t.cl > hi {
                (t.cl / hi).ln()
            } else {
                0.0
            }
        };
        last.cl.twins = pruned.into_iter().filter(|t| far(t) > 0.0).max_by(|a, b| far(a).total_cmp(&far(b))).into_iter().collect();
    }
    Some((out, dropped))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effect::Baseline;
    use buck_model::Mode;
    use estimator::experiment::{Experiment, ModelPlant, run};

    /// Unequal switches scale the switches' resistance: taken out with it, the model without
    /// the switches is the nominal with Cl free and fits; left free, the low side's ratio
    /// scaled nothing and the fit was singular (the joint model, whose pruning judges every
    /// effect without it, was then dropped).
    #[test]
    fn the_model_without_the_switches_drops_their_ratio() {
        let truth = Params { cl: 10e-6, switch_resistance: 0.01, low_side_ratio: 1.5, ..Params::default() };
        let exp = Experiment { samples: 1200, noise_vout: 2e-3, io: 2.0, ..Experiment::default() };
        let data = run(&mut ModelPlant::new(truth, Mode::Switched), &exp).unwrap();
        let stack = Stack { params: truth, free: vec![Free::Cl, Free::SwitchResistance, Free::LowSideRatio], delay: 0, effects: vec!["switch_resistance", "unequal_switches"], switched: true };
        let switches = Group { name: "switch_resistance", frees: vec![Free::SwitchResistance], selected: true };
        let nominal = Params::default();
        let (n_est, holdout) = (800, 1.0 / 3.0);
        let base = Stack::nominal(&nominal, truth.cl, true).fit(&data, &[Params { cl: truth.cl, ..nominal }], n_est, holdout).expect("the nominal fits");
        let baseline = Baseline::of(&data, &base, n_est, 0.01);
        let problem = Problem { data: &data, nominal: &nominal, switched_nominal: true, switched_data: true, n_est, holdout, baseline: &baseline };
        let (less, fit) = refitted_without(&problem, &stack, [&switches]).expect("the model without the switches fits");
        assert_eq!(less.free, vec![Free::Cl]);
        assert_eq!(less.params.low_side_ratio, nominal.low_side_ratio);
        assert!(fit.fit.estimate("Cl").is_some());
    }
}
