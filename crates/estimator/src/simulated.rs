//! Simulation-error fit of the plant simulator itself ([`Structure::Simulated`]): the switched
//! `buck_model::Converter`, driven period by period by the data's duty, `io` and `vin` and
//! sampled at period starts, with the free parameters fitted by Levenberg–Marquardt on forward
//! differences in `ln θ`.
//!
//! This is the model for what the grey-box predictors linearize: DCM, diode and dead-time
//! intervals whose length moves with the state, inductor saturation, a voltage-dependent `Cl`.
//! Its cost is a simulation per free parameter per iteration (about 3–10 ms each for 3001
//! periods with state events), so it serves few parameters.
//!
//! The instant the data was read at (`sample_delay`), where free and the data has `il`, is
//! pinned by the inductor current: read late, `il` moves by the inductor's slope times the
//! delay (a large, clean signal), while a resistance in series with `Cl` or an inductance in the
//! capacitor branch, which move the sampled `vout` much as a late reading does, leave it alone.
//! The delay is fitted first on both channels (each weighted by its white noise estimated from
//! the data, [`crate::noise`]), then held while everything else is fitted to `vout` alone: the
//! current would otherwise weigh on `Cl` with its own precision, and a small error in how the
//! model draws it (gate ramps, a switch node's charge) would bias `Cl` by many of its too-narrow
//! standard deviations.
//!
//! The initial state is estimated with the parameters ([`Start`]: both capacitors' voltage and
//! the inductor current's departure from the DC point of the first inputs): a record
//! cut from a running experiment starts wherever the excitation left the converter, and a
//! lightly damped LC, or DCM's slow first-order mode, forgets its start only after hundreds of
//! periods. What is left of a start error that the linear part cannot take (the switching
//! intervals adjusting to it) decays within the first [`BURN_IN`] samples, which are left out
//! of the criterion.
use buck_model::variables::VarId;
use buck_model::{Converter, Mode, Params, State};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::candidate::{Candidate, Traces, Validation};
use crate::data::DataSet;
use crate::error::EstimatorError;
use crate::model::{Free, Structure};
use crate::pem::{self, Fit};
use crate::validate::{ResidualTests, fit_percent};

/// Samples at the start left out of the criterion while the start error decays.
pub const BURN_IN: usize = 50;

/// Latest sampling instant of the `sample_delay` effect, as a fraction of the period. A
/// controller that samples clear of the switching edges reads in the middle of the off-time,
/// 0.7–0.8 of the period at duties of 0.4–0.6; at the period's end the readings are a row late
/// (the `delay` candidate's −1). At half the period, the limit before, an ngspice buck read at
/// 0.6 or 0.9 of it was diagnosed as C +16 % and L −8 % (or Rc +28 %), Cl not identified.
pub const MAX_SAMPLE_DELAY: f64 = 0.95;

/// Forward-difference step in `ln θ`.
const FD_STEP: f64 = 1e-4;

/// Forward-difference steps of the initial state's unknowns ([`Start::unknowns`]): \[V\], \[A\].
const START_STEPS: [f64; Start::UNKNOWNS] = [1e-4, 1e-4];

/// Start values of Cl tried besides the given one, as multiples of the main capacitance C (half
/// a decade apart: 0.3–100 µF beside the thesis's 100 µF).
const CL_GRID: [f64; 6] = [3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0];

/// Smallest noise level a channel is credited with, as a fraction of its range: noise-free
/// (simulated) data then weights `vout` and `il` by their spans instead of by rounding error.
const NOISE_RESOLUTION: f64 = 1e-5;

/// Iteration limit of Levenberg–Marquardt.
const MAX_ITERATIONS: usize = 40;
/// Relative distance from a fraction's ceiling ([`Free::ceiling`]) within which a fit stops:
/// it has run onto the edge of the range (not converged, whatever it would creep to next), and
/// the logit would take it closer by ever smaller amounts.
const AT_CEILING: f64 = 1e-3;

/// Starts from which the sampling instant's joint fit on both channels goes (the best by the
/// criterion at the start).
const PINNED_STARTS: usize = 2;

/// Levenberg–Marquardt steps taken on Broyden's updates of the Jacobian before it is taken by
/// differences again (each difference costs a simulation per unknown).
const BROYDEN_STEPS: usize = 4;

/// Largest step in `ln θ` per iteration (a factor e).
const MAX_LOG_STEP: f64 = 1.0;

/// What the fit minimizes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Criterion {
    /// The sum of squared simulation errors: maximum likelihood under white sensor noise.
    #[default]
    OutputError,
    /// The sum of squared *differences* of successive simulation errors: the same model seen
    /// through the high-pass `1 − q⁻¹`, which weights the fast dynamics (where a small `Cl`
    /// shows) and ignores DC. Consistent for the same parameters when the model is right, so a
    /// disagreement with [`Criterion::OutputError`] beyond their uncertainty exposes model error
    /// (a Hausman test). Its covariance is the sandwich for the MA(1) noise that differencing
    /// white noise leaves.
    Differenced,
}

/// Where a simulation starts: both capacitors at `v0` and the inductor current `dil` above the
/// DC point of the first inputs (moved by what a load resistor draws at `v0` instead of there).
/// A record taken from a running experiment starts wherever its excitation left the converter:
/// a lightly damped LC (a 24 V buck with 10 µH and 220 µF rings for 80 periods per e-fold) is
/// then amperes and volts away from any DC point for hundreds of samples, and a fit that could
/// only move `v0` biased Cl and the effects to follow that start. Both are fitted with the
/// parameters. The capacitors' difference is not: it decays in the fast C–Cl mode (`Rc` times
/// their series capacitance, a fraction of a period to a few) within the samples left out.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Start {
    /// Voltage of both capacitors \[V\].
    pub v0: f64,
    /// Inductor current above the DC point's \[A\].
    pub dil: f64,
}

impl From<f64> for Start {
    /// Both capacitors at `v0`, the inductor current at the DC point.
    fn from(v0: f64) -> Self {
        Self { v0, dil: 0.0 }
    }
}

impl Start {
    /// Number of unknowns of a start.
    pub const UNKNOWNS: usize = 2;

    /// The start a simulated fit ended with (its `x0`), or the DC point at `v0` for any other.
    pub fn fitted(fit: &Fit, v0: f64) -> Self {
        if fit.x0.len() == Self::UNKNOWNS { Self::of(&fit.x0) } else { Self::from(v0) }
    }

    /// The unknowns of a fit, `[v0, dil]`.
    fn unknowns(self) -> [f64; Self::UNKNOWNS] {
        [self.v0, self.dil]
    }

    /// The start of the unknowns `u` (the last [`Start::UNKNOWNS`] of a fit's unknowns).
    fn of(u: &[f64]) -> Self {
        match u {
            [.., v0, dil] => Self { v0: *v0, dil: *dil },
            _ => Self::default(),
        }
    }
}

/// Simulated `vout` at every period start of `data` (or `p.sample_delay` after it) with circuit
/// values `p`, starting at `start` (a voltage: both capacitors at it, the DC point's current), as
/// the reading shows it (`p.vout_offset`, `p.vout_gain_error`).
pub fn simulate(p: &Params, data: &DataSet, start: impl Into<Start>) -> Result<Vec<f64>, EstimatorError> {
    simulate_outputs(p, data, start).map(|(vout, _)| vout)
}

/// [`simulate`], with the inductor current as its reading shows it (at the sampling instant, which
/// `vout`'s is `p.vout_skew` after; through the low-pass `p.il_filter`, if any,
/// [`Converter::il_read`]; its gain and zero errors).
pub fn simulate_outputs(p: &Params, data: &DataSet, start: impl Into<Start>) -> Result<(Vec<f64>, Vec<f64>), EstimatorError> {
    // What the readings make of the voltage and the current (their gain and zero errors).
    let read = |v: f64| (1.0 + p.vout_gain_error) * v + p.vout_offset;
    let read_il = |i: f64| (1.0 + p.il_gain_error) * i + p.il_offset;
    let mut out = Vec::with_capacity(data.len());
    let (_, il) = drive(p, data, start, |_, _, vout| out.push(read(vout)))?;
    let il: Vec<f64> = il.into_iter().map(read_il).collect();
    if out.iter().chain(&il).all(|v| v.is_finite()) { Ok((out, il)) } else { Err(EstimatorError::Fit("the simulation left the finite range".into())) }
}

/// How a circuit runs on a record's inputs ([`operation`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Operation {
    /// The output voltage averaged over the whole record in time (each period's exact average),
    /// the readings' errors left out \[V\]: the operating point a DC-biased ceramic sits at. The
    /// samples' mean is not: they are all taken at one phase of the ripple.
    pub vout_time_mean: f64,
    /// Share of the periods that a diode buck starts with its inductor current at zero, the
    /// diode having blocked before the period ended (DCM); 0 for a synchronous one.
    pub dcm_share: f64,
}

/// Inductor current at a period start \[A\] at or below which a diode buck's diode has blocked:
/// the blocked inductor holds exactly zero, conduction at this level is none.
const BLOCKED_IL: f64 = 1e-9;

/// How the circuit `p` runs on `data`'s inputs from `start` ([`Operation`]).
pub fn operation(p: &Params, data: &DataSet, start: impl Into<Start>) -> Result<Operation, EstimatorError> {
    let start = start.into();
    // At each sampling instant the last completed period is the one before it (none at the
    // first); the record's last period completes at its end.
    let (mut sum, mut blocked, mut first) = (0.0, 0usize, true);
    let (last, _) = drive(p, data, start, |conv, il_at_start, _| {
        if !first {
            sum += conv.outputs().vout_avg;
            blocked += usize::from(il_at_start <= BLOCKED_IL);
        }
        first = false;
    })?;
    let periods = data.len() as f64;
    let vout_time_mean = (sum + last.outputs().vout_avg) / periods;
    // A ringing node's current at a period start has either sign: where the node rings, the
    // periods whose diode blocked are counted on the circuit with its node held (the ring moves
    // each period's charge a little, not whether the diode blocks).
    let dcm_share = match p.asynchronous() {
        false => 0.0,
        true if p.rings() => operation(&Params { switch_node_ring: false, ..*p }, data, start)?.dcm_share,
        true => blocked as f64 / (periods - 1.0).max(1.0),
    };
    if vout_time_mean.is_finite() { Ok(Operation { vout_time_mean, dcm_share }) } else { Err(EstimatorError::Fit("the simulation left the finite range".into())) }
}

/// Runs the switched converter with circuit values `p` period by period on `data`'s duty, `io`
/// and `vin`, from `start` (a voltage: both capacitors at it, the DC point's current), calling
/// `at_sample` at each reading of `vout` (the period start, or `p.sample_delay` after it, moved
/// with the duty by `p.sample_duty_share`, then by `p.vout_skew`) with the inductor current at
/// the period's start and `vout` as read there (through the low-pass `p.vout_filter`, if any:
/// the converter's ADC's anti-alias filter, [`Converter::vout_read`]). Returns the converter
/// at the end of the record and the `il` readings at the sampling instants
/// ([`Converter::il_read`]).
fn drive(p: &Params, data: &DataSet, start: impl Into<Start>, mut at_sample: impl FnMut(&Converter, f64, f64)) -> Result<(Converter, Vec<f64>), EstimatorError> {
    let Start { v0, dil } = start.into();
    let plant = |e: buck_model::ModelError| EstimatorError::Plant(e.to_string());
    let period = data.sample_period();
    let mut conv = Converter::new(Params { fs: 1.0 / period, ..*p }, Mode::Switched);
    // Each input is set where it changes (a record holds each duty for periods on end, and
    // io and vin mostly constant): setting a value again changes nothing.
    let set_inputs = |conv: &mut Converter, k: usize| -> Result<(), EstimatorError> {
        let changed = |signal: &[f64]| k == 0 || signal[k].to_bits() != signal[k - 1].to_bits();
        for (id, signal) in [(VarId::Duty, &data.duty), (VarId::Io, &data.io), (VarId::Vin, &data.vin)] {
            if changed(signal) {
                conv.set(id, signal[k]).map_err(plant)?;
            }
        }
        Ok(())
    };
    // `vout` and `il` read through their filters, if any: the FMU's ADC's own.
    conv.set(VarId::AdcFilter, p.vout_filter).map_err(plant)?;
    conv.set(VarId::AdcIlFilter, p.il_filter).map_err(plant)?;
    set_inputs(&mut conv, 0)?;
    conv.initialize();
    // The DC point's current, moved by what a load resistor draws at v0 instead of there.
    let s0 = conv.state();
    let il0 = s0.il + (v0 - s0.vo) * conv.params().load_conductance();
    conv.set_state(State { il: il0 + dil, vc: v0, vo: v0, ic: 0.0 });
    // The instants of each period's readings, `[vout, il]`: fixed, or moving with its duty (an
    // ADC triggered from the PWM); vout's apart from il's by the channels' skew.
    let instants = |k: usize| {
        let il = p.sample_instant(data.duty[k], period);
        [il + p.vout_skew, il]
    };
    if let Some(late) = (0..data.len()).flat_map(instants).find(|late| !(0.0..MAX_SAMPLE_DELAY * period).contains(late)) {
        let lock = if p.sample_duty_share == 0.0 { String::new() } else { format!(" (sample_delay {:e} s plus {}·(D − ½)·T)", p.sample_delay, p.sample_duty_share) };
        let skew = if p.vout_skew == 0.0 { String::new() } else { format!(" (vout read {:e} s after il)", p.vout_skew) };
        return Err(EstimatorError::Config(format!("a sampling instant {late:e} s{lock}{skew} must lie in [0, {MAX_SAMPLE_DELAY}·T)")));
    }
    let mut il_reads = Vec::with_capacity(data.len());
    for k in 0..data.len() {
        let il_at_start = conv.state().il;
        let [at_vout, at_il] = instants(k);
        // The duty is latched at the period start; the readings come where they are taken in it
        // (at the start itself before the period's inputs are set), il's first where both come
        // at once.
        let reads = if at_vout < at_il { [(at_vout, true), (at_il, false)] } else { [(at_il, false), (at_vout, true)] };
        // (The inputs are set once, at the first step out of the period start.)
        let mut now = 0.0;
        for (at, is_vout) in reads {
            if at > now {
                if now == 0.0 {
                    set_inputs(&mut conv, k)?;
                }
                conv.step(at - now).map_err(plant)?;
                now = at;
            }
            if is_vout {
                at_sample(&conv, il_at_start, conv.vout_read());
            } else {
                il_reads.push(conv.il_read());
            }
        }
        if now == 0.0 {
            set_inputs(&mut conv, k)?;
        }
        conv.step(period - now).map_err(plant)?;
    }
    Ok((conv, il_reads))
}

/// Circuit values with the free parameters set from the unknowns `[ln θ | start]` (a logit for a
/// fraction below its ceiling: [`Free::to_unknown`]).
fn with_logs(start: &Params, free: &[Free], unknowns: &[f64]) -> Params {
    let mut p = *start;
    for (f, l) in free.iter().zip(unknowns) {
        f.set(&mut p, f.from_unknown(*l));
    }
    p
}

/// Weight of the measured `il` against `vout` (`σ_vout / σ_il`, each the white noise of its
/// channel, at least [`NOISE_RESOLUTION`] of its range), or `None` when the data has no `il` or
/// its noise cannot be told from the data.
fn il_weight(data: &DataSet) -> Option<f64> {
    let il = data.il.as_ref()?;
    let sigma = |series: &[f64]| -> Option<f64> {
        let (white, _) = crate::noise::white_noise(data, series)?;
        let (lo, hi) = series.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| (lo.min(x), hi.max(x)));
        Some(white.max(NOISE_RESOLUTION * (hi - lo)))
    };
    let weight = sigma(&data.vout)? / sigma(il)?;
    (weight.is_finite() && weight > 0.0).then_some(weight)
}

/// The mean of `measured − simulated`: a reading's zero error as least squares sees it.
fn reading_offset(measured: &[f64], simulated: &[f64]) -> f64 {
    let n = measured.len().min(simulated.len()).max(1) as f64;
    measured.iter().zip(simulated).map(|(y, s)| y - s).sum::<f64>() / n
}

/// The zero and gain errors `(offset, gain_error)` that fit `measured` best as
/// `(1 + gain_error)·simulated + offset` (least squares; the offset alone where the simulated
/// reading does not vary).
pub fn reading_calibration(measured: &[f64], simulated: &[f64]) -> (f64, f64) {
    let n = measured.len().min(simulated.len()).max(1) as f64;
    let (my, ms) = (measured.iter().sum::<f64>() / n, simulated.iter().sum::<f64>() / n);
    let (sxx, sxy) = measured.iter().zip(simulated).fold((0.0, 0.0), |(xx, xy), (y, s)| (xx + (s - ms).powi(2), xy + (s - ms) * (y - my)));
    if sxx > 0.0 {
        let gain = sxy / sxx;
        (my - gain * ms, gain - 1.0)
    } else {
        (my - ms, 0.0)
    }
}

/// A reading's `(offset, gain_error)` fitted to its measurement.
type Calibration = fn(&[f64], &[f64]) -> (f64, f64);

/// The circuit values `p` with the readings taken as exact but for `vout`'s gain (a model's own
/// parameter where it has one).
fn without_offsets(p: Params) -> Params {
    Params { vout_offset: 0.0, il_offset: 0.0, il_gain_error: 0.0, ..p }
}

/// Residuals over the criterion samples `BURN_IN..n_est` at the unknowns `[ln θ | start]`: those of
/// `vout`, then, with an `il_weight`, those of `il` times the weight; each channel differenced
/// for [`Criterion::Differenced`] (`None` if the simulation fails). With an `il_weight` (the late
/// reading pinned on both channels) the readings' calibration is first projected out as a
/// nuisance: vout's zero error ([`reading_offset`]), il's zero and gain errors
/// ([`reading_calibration`]).
fn residuals(start: &Params, free: &[Free], unknowns: &[f64], estimation: &DataSet, criterion: Criterion, il_weight: Option<f64>) -> Option<DVector<f64>> {
    // A trial step outside a parameter's declared range (e.g. a Cl loss above 90 %) is refused.
    if !free.iter().zip(unknowns).all(|(f, l)| f.admits(f.from_unknown(*l))) {
        return None;
    }
    let from = Start::of(unknowns);
    let p = with_logs(start, free, unknowns);
    let pinned = il_weight.is_some();
    let (vout, il) = simulate_outputs(&if pinned { without_offsets(p) } else { p }, estimation, from).ok()?;
    // Each channel's calibration where pinned: vout's offset; il's offset and gain (a current
    // probe's gain scales il's transients, amperes after each duty step, which pulled the
    // instant from 92 to 42 ns at 1 %).
    let vout_calibration: Calibration = |m, s| (reading_offset(m, s), 0.0);
    let errors = |measured: &[f64], simulated: &[f64], weight: f64, calibration: Calibration| -> Vec<f64> {
        let (measured, simulated) = (&measured[BURN_IN..], &simulated[BURN_IN..]);
        let (offset, gain) = if pinned { calibration(measured, simulated) } else { (0.0, 0.0) };
        let e = measured.iter().zip(simulated).map(|(y, s)| weight * (y - (1.0 + gain) * s - offset));
        match criterion {
            Criterion::OutputError => e.collect(),
            Criterion::Differenced => e.collect::<Vec<f64>>().windows(2).map(|w| w[1] - w[0]).collect(),
        }
    };
    let mut r = errors(&estimation.vout, &vout, 1.0, vout_calibration);
    if let (Some(w), Some(measured)) = (il_weight, estimation.il.as_ref()) {
        r.extend(errors(measured, &il, w, reading_calibration));
    }
    Some(DVector::from_vec(r))
}

/// Jacobian of the simulated output (`−∂r/∂[ln θ | start]`) by forward differences from `r0`, one
/// simulation per column, the columns in parallel (a lone slow fit, a bias law or a saturation
/// knee, then uses both cores).
fn jacobian(start: &Params, free: &[Free], unknowns: &[f64], estimation: &DataSet, criterion: Criterion, il_weight: Option<f64>, r0: &DVector<f64>) -> Option<DMatrix<f64>> {
    let columns: Option<Vec<DVector<f64>>> = (0..unknowns.len())
        .into_par_iter()
        .map(|i| {
            let h = if i < free.len() { FD_STEP } else { START_STEPS[i - free.len()] };
            // Forward, or backward at the upper end of a parameter's range.
            let at = |step: f64| {
                let mut u = unknowns.to_vec();
                u[i] += step;
                residuals(start, free, &u, estimation, criterion, il_weight).map(|r| (r, step))
            };
            let (ri, step) = at(h).or_else(|| at(-h))?;
            Some((r0 - ri) / step)
        })
        .collect();
    Some(DMatrix::from_columns(&columns?))
}

/// Fits `free` (all positive; `start` holds their start values and every known value) to the
/// first `n_est` samples of `data` and validates on the rest, as [`crate::identify::identify`]
/// does for the grey-box structures. The criterion is the output error.
pub fn fit(data: &DataSet, start: &Params, free: &[Free], n_est: usize) -> Result<Candidate, EstimatorError> {
    fit_with(data, start, free, n_est, Criterion::OutputError)
}

/// [`fit`] with the given criterion.
pub fn fit_with(data: &DataSet, start: &Params, free: &[Free], n_est: usize, criterion: Criterion) -> Result<Candidate, EstimatorError> {
    fit_from(data, std::slice::from_ref(start), free, n_est, criterion)
}

/// [`fit_with`] from the best of several starts (by the criterion, each with a coarse Cl
/// grid): for parameters whose criterion has local minima over their range (a diode drop far
/// from its start leaves Cl and the drop in a wrong valley). The known values come from the
/// first start.
pub fn fit_from(data: &DataSet, starts: &[Params], free: &[Free], n_est: usize, criterion: Criterion) -> Result<Candidate, EstimatorError> {
    fit_from_starts(data, starts, free, n_est, criterion, true)
}

/// [`fit_from`] from exactly the given starts, without the Cl grid: for a model extended from
/// one already fitted, whose Cl is a good start (a grid point per start costs a simulation).
pub fn fit_from_exactly(data: &DataSet, starts: &[Params], free: &[Free], n_est: usize, criterion: Criterion) -> Result<Candidate, EstimatorError> {
    fit_from_starts(data, starts, free, n_est, criterion, false)
}

fn fit_from_starts(data: &DataSet, starts: &[Params], free: &[Free], n_est: usize, criterion: Criterion, cl_grid: bool) -> Result<Candidate, EstimatorError> {
    let Some(start) = starts.first() else {
        return Err(EstimatorError::Config("at least one start is needed".into()));
    };
    data.validate()?;
    if free.is_empty() {
        return Err(EstimatorError::Config("at least one free parameter is needed".into()));
    }
    if n_est < BURN_IN + 50 || n_est >= data.len() {
        return Err(EstimatorError::Data(format!("the simulated model needs ≥ {} estimation samples and some held out ({n_est} of {})", BURN_IN + 50, data.len())));
    }
    // The unknowns `[ln θ | start]` of each start, with the start's other values (a start may
    // hold what is not free differently: a reading's lock to the PWM); the initial voltage
    // starts at the first measured sample, the rest at the DC point.
    let mut tries: Vec<(&Params, Vec<f64>)> = starts.iter().map(|s| (s, free.iter().map(|f| f.to_unknown(f.get(s))).chain(Start::from(data.vout[0]).unknowns()).collect())).collect();
    if tries.iter().flat_map(|(_, u)| u).any(|l| !l.is_finite()) {
        return Err(EstimatorError::Config("start values of free parameters must be positive".into()));
    }
    let clock = std::time::Instant::now();
    let estimation = data.slice(0..n_est);
    // Cl starts from the best of its start value and a coarse grid: a start taken from a model
    // that cannot describe the data (e.g. a linear model on DCM data) may be far off, and where
    // the model misses, the differenced criterion can have its best valley far from the
    // output error's.
    if let (Some(ci), true) = (free.iter().position(|f| *f == Free::Cl), cl_grid) {
        tries = tries
            .into_iter()
            .flat_map(|(s, t)| {
                std::iter::once(t[ci]).chain(CL_GRID.iter().map(|k| (k * start.c).ln())).map(move |l| {
                    let mut u = t.clone();
                    u[ci] = l;
                    (s, u)
                })
            })
            .collect();
    }
    // What il pins (the sampling instant, il's filter: `Free::pinned_by_il`), where free beside
    // other values and the data has il: pinned on both channels first, then held (see the
    // module doc). vout's own instant (`Free::VoutSkew`) is vout's: fitted with the rest.
    let pinned_at: Vec<usize> = (0..free.len()).filter(|&k| free[k].pinned_by_il()).collect();
    let pinned = Some(pinned_at).filter(|at| !at.is_empty() && free.len() > at.len()).zip(il_weight(&estimation));
    // The best start by the criterion of the first fit it goes into: both channels where the
    // instant is pinned (vout alone can prefer a start whose instant il rules out, from which a
    // fit on the log scale slides toward zero and stays).
    let weight = pinned.as_ref().filter(|_| criterion == Criterion::OutputError).map(|(_, w)| *w);
    let cost_at = |(s, u): &(&Params, Vec<f64>)| residuals(s, free, u, &estimation, criterion, weight).map_or(f64::INFINITY, |r| r.norm_squared());
    if tries.len() > 1 {
        let mut ranked: Vec<(f64, (&Params, Vec<f64>))> = tries.into_par_iter().map(|t| (cost_at(&t), t)).collect();
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
        tries = ranked.into_iter().map(|(_, t)| t).collect();
    }
    let (start, logs) = tries.first().cloned().unwrap_or((start, Vec::new()));
    let (start, free_rest, logs, delay) = match pinned {
        Some((at, weight)) => {
            // The high-pass refit tests the rest of a model whose instant the output-error fit
            // has pinned: it keeps that instant (held exactly, so without a variance of its own).
            let (held, logs, var, iterations): (_, _, Vec<f64>, _) = if criterion == Criterion::Differenced {
                (with_logs(start, free, &logs), logs, vec![0.0; at.len()], 0)
            } else {
                // Pinned by what the instant changes, not by the readings' calibration: vout's
                // zero error and il's zero and gain errors are projected out (see `residuals`).
                // Read late, il moves by the inductor's slope times the delay, which a current
                // probe's offset would otherwise stand in for (the slope's change with the duty
                // tells them apart); vout's level moves with a probe's offset or any unmodelled
                // drop, which would pull the instant. The model's own vout offset, if any, is
                // that projection here; its own vout gain is fitted with the rest.
                // From the best [`PINNED_STARTS`] starts: the instant's criterion has a valley per
                // ripple feature a delay can line up with, and the start ranked best, its other
                // values fitted without the delay, can sit in a wrong one.
                let joint_at: Vec<usize> = (0..free.len()).filter(|&k| free[k] != Free::VoutOffset).collect();
                let joint_free: Vec<Free> = joint_at.iter().map(|&k| free[k]).collect();
                let joint_logs = |u: &Vec<f64>| -> Vec<f64> { joint_at.iter().map(|&k| u[k]).chain(u[free.len()..].iter().copied()).collect() };
                let (joint, (start, mut logs)) = tries
                    .par_iter()
                    .take(PINNED_STARTS)
                    .filter_map(|(s, u)| minimize(s, &joint_free, joint_logs(u), &estimation, criterion, Some(weight)).ok().map(|m| (m, (*s, u.clone()))))
                    .min_by(|a, b| a.0.cost.total_cmp(&b.0.cost))
                    .ok_or_else(|| EstimatorError::Fit("the simulation fails at every start of the sampling instant".into()))?;
                let (_, cov) = noise_and_covariance(&joint, criterion)?;
                for (k, l) in joint_at.iter().zip(&joint.logs) {
                    logs[*k] = *l;
                }
                logs[free.len()..].copy_from_slice(&joint.logs[joint_free.len()..]);
                // The instant is held, with the il reading's calibration that goes with it.
                let mut held = with_logs(start, free, &logs);
                let (_, il) = simulate_outputs(&without_offsets(held), &estimation, Start::of(&logs))?;
                let measured = estimation.il.as_deref().unwrap_or_default();
                (held.il_offset, held.il_gain_error) = reading_calibration(&measured[BURN_IN.min(measured.len())..], &il[BURN_IN..]);
                let var = at.iter().map(|i| joint_at.iter().position(|k| k == i).map_or(0.0, |j| cov[(j, j)])).collect();
                (held, logs, var, joint.iterations)
            };
            let rest: Vec<Free> = free.iter().copied().filter(|f| !f.pinned_by_il()).collect();
            let rest_logs: Vec<f64> = logs.iter().enumerate().filter(|(k, _)| !at.contains(k)).map(|(_, l)| *l).collect();
            let held_logs: Vec<f64> = at.iter().map(|&i| logs[i]).collect();
            (held, rest, rest_logs, Some((at, held_logs, var, iterations)))
        }
        None => (*start, free.to_vec(), logs, None),
    };
    let m = minimize(&start, &free_rest, logs, &estimation, criterion, None)?;
    let (s2, rest_covariance) = noise_and_covariance(&m, criterion)?;
    // The estimates and covariance in the order of `free` (then the start); the held values with
    // their variances from the joint fit, uncorrelated with the rest but vout's skew.
    let (covariance, logs) = match &delay {
        Some((at, held_logs, var, _)) => {
            let (mut covariance, mut logs) = (rest_covariance, m.logs.clone());
            for (k, &i) in at.iter().enumerate() {
                covariance = covariance.insert_column(i, 0.0).insert_row(i, 0.0);
                covariance[(i, i)] = var[k];
                logs.insert(i, held_logs[k]);
            }
            // vout shows the instants only through their sum (its own instant): the skew fitted
            // with il's held takes that one's error one for one, `d skew = −d delay`.
            let index = |f: Free| free.iter().position(|g| *g == f);
            if let (Some(s), Some(d)) = (index(Free::VoutSkew), index(Free::SampleDelay)) {
                let slope = -Free::SampleDelay.from_unknown(logs[d]) / Free::VoutSkew.signed_scale().unwrap_or(1.0);
                let var_d = covariance[(d, d)];
                covariance[(s, s)] += slope * slope * var_d;
                covariance[(s, d)] = slope * var_d;
                covariance[(d, s)] = slope * var_d;
            }
            (covariance, logs)
        }
        None => (rest_covariance, m.logs.clone()),
    };
    let (cost, iterations, converged, np) = (m.cost, m.iterations + delay.as_ref().map_or(0, |d| d.3), m.converged, logs.len());
    let start = &start;
    let seconds = clock.elapsed().as_secs_f64();
    let params = with_logs(start, free, &logs);
    let estimates = pem::log_estimates(free, &logs, &covariance);
    let from = Start::of(&logs);
    let sim = simulate(&params, data, from)?;
    let measured = data.vout[n_est..].to_vec();
    let simulated = sim[n_est..].to_vec();
    let residual: Vec<f64> = measured.iter().zip(&simulated).map(|(y, s)| y - s).collect();
    let fit_sim = fit_percent(&measured, &simulated);
    let validation = Validation {
        fit_simulation: vec![fit_sim],
        // Output error: the one-step prediction is the simulation.
        fit_prediction: vec![fit_sim],
        residuals: ResidualTests::new(&residual, &data.duty[n_est..]),
        traces: Traces { time: data.time[n_est..].to_vec(), measured, simulated: simulated.clone(), predicted: simulated },
    };
    let fit = Fit { params, estimates, x0: from.unknowns().to_vec(), gain: Vec::new(), sigma: vec![s2.sqrt()], cost: cost / s2.max(1e-300), iterations, converged, n_params: np, covariance };
    Ok(Candidate { structure: Structure::Simulated, fit, validation, seconds })
}

/// Where Levenberg–Marquardt ended: the unknowns `[ln θ | start]`, the residuals and their
/// Jacobian there, the criterion, and how it got there.
struct Minimum {
    logs: Vec<f64>,
    r: DVector<f64>,
    j: DMatrix<f64>,
    cost: f64,
    iterations: usize,
    converged: bool,
    /// Simulations it took (trial steps, and one per unknown for each Jacobian by differences).
    #[cfg_attr(not(test), expect(dead_code, reason = "the tests' measure of a minimum's cost"))]
    simulations: usize,
    /// Trial steps it refused.
    #[cfg_attr(not(test), expect(dead_code, reason = "the tests' measure of a minimum's path"))]
    refusals: usize,
}

/// Minimizes the criterion over `[ln θ | start]` of `free` from `logs` (Levenberg–Marquardt on
/// forward differences, steps capped at [`MAX_LOG_STEP`]).
fn minimize(start: &Params, free: &[Free], mut logs: Vec<f64>, estimation: &DataSet, criterion: Criterion, il_weight: Option<f64>) -> Result<Minimum, EstimatorError> {
    let not_simulable = || EstimatorError::Fit("the simulation fails at the start values".into());
    let simulations = std::cell::Cell::new(1);
    let mut refusals = 0;
    let by_differences = |logs: &[f64], r: &DVector<f64>| {
        simulations.set(simulations.get() + logs.len());
        jacobian(start, free, logs, estimation, criterion, il_weight, r).ok_or_else(not_simulable)
    };
    let mut r = residuals(start, free, &logs, estimation, criterion, il_weight).ok_or_else(not_simulable)?;
    let mut cost = r.norm_squared();
    let mut j = by_differences(&logs, &r)?;
    let np = logs.len();
    let dof = (r.len() - np) as f64;
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let mut converged = false;
    // Accepted steps since `j` was last taken by differences (in between, Broyden's updates).
    let mut stale = 0;
    while iterations < MAX_ITERATIONS && !converged {
        iterations += 1;
        let jtj = j.transpose() * &j;
        let jtr = j.transpose() * &r;
        // A step is worth a simulation only when its linearized decrease is material (a
        // hundredth of σ², as for convergence): once damping has shrunk it below that, there is
        // nothing left to gain along this Jacobian. (Tried up to λ = 1e10, a minimum cost
        // twenty rejected simulations, a third of all a diagnosis ran.)
        let worth_trying = (cost / dof) * 1e-2;
        // The next step worth a simulation from damping `lambda` on (raised where a step is not
        // worth one), given the step last refused at this Jacobian; `None` when none is.
        let plan = |lambda: &mut f64, refused: Option<&DVector<f64>>| -> Option<DVector<f64>> {
            while *lambda < 1e10 {
                let mut a = jtj.clone();
                for i in 0..np {
                    a[(i, i)] += *lambda * jtj[(i, i)].max(1e-30);
                }
                let Some(step) = step_within_range(&a, &jtr, &logs, free) else {
                    *lambda *= 10.0;
                    continue;
                };
                let largest = step.rows(0, free.len()).amax();
                let step = &step * (MAX_LOG_STEP / largest.max(MAX_LOG_STEP));
                if 2.0 * step.dot(&jtr) - step.dot(&(&jtj * &step)) <= worth_trying {
                    return None;
                }
                // More damping that barely changes the step last refused (λ far below the
                // curvature of every direction) is not worth its simulation either.
                if refused.is_some_and(|last| (&step - last).norm() <= 0.1 * last.norm()) {
                    *lambda *= 10.0;
                    continue;
                }
                return Some(step);
            }
            None
        };
        let trial_of = |step: &DVector<f64>| -> Vec<f64> { logs.iter().zip(step.iter()).map(|(l, s)| l + s).collect() };
        let mut accepted = None;
        let mut next = plan(&mut lambda, None);
        // The residuals of `next`, where a core that would have idled has simulated them ahead.
        let mut ahead: Option<Option<DVector<f64>>> = None;
        while let Some(step) = next {
            let trial = trial_of(&step);
            // Should this step be refused, the one after it: planned now and simulated on the
            // other core if it is free (one that finds this step accepted skips it), so that a
            // chain of refusals costs one simulation's time per two. Every result is the serial
            // one: the step after is planned as the serial loop would plan it.
            let mut lambda_after = lambda * 10.0;
            let after = plan(&mut lambda_after, Some(&step));
            let done = AtomicBool::new(false);
            let (rt, rt_after) = rayon::join(
                || {
                    let rt = ahead.take().unwrap_or_else(|| residuals(start, free, &trial, estimation, criterion, il_weight));
                    done.store(rt.as_ref().is_some_and(|rt| rt.norm_squared() < cost), Ordering::Relaxed);
                    rt
                },
                || after.as_ref().filter(|_| !done.load(Ordering::Relaxed)).map(|a| residuals(start, free, &trial_of(a), estimation, criterion, il_weight)),
            );
            simulations.set(simulations.get() + 1);
            match rt {
                Some(rt) if rt.norm_squared() < cost => {
                    let gain = cost - rt.norm_squared();
                    // Converged when the decrease is far below one unit of the criterion's
                    // noise (σ²: a hundredth, a likelihood-ratio statistic's worth of 0.01) or
                    // every step is far inside its own standard deviation. (A millionth cost
                    // iterations that move nothing a test or an interval can see.)
                    let s2 = cost / dof;
                    let small = (0..np).all(|i| step[i].abs() <= 1e-3 * (s2 / jtj[(i, i)].max(1e-300)).sqrt());
                    converged = gain <= 1e-2 * s2 || small;
                    logs = trial;
                    let dr = &rt - &r;
                    r = rt;
                    cost = r.norm_squared();
                    lambda = (lambda / 10.0).max(1e-9);
                    accepted = Some((step, dr));
                    if free.iter().zip(&logs).any(|(f, u)| f.ceiling().is_some_and(|m| f.from_unknown(*u) >= m * (1.0 - AT_CEILING))) {
                        let j = by_differences(&logs, &r)?;
                        return Ok(Minimum { logs, r, j, cost, iterations, converged: false, simulations: simulations.get(), refusals });
                    }
                    break;
                }
                _ => {
                    refusals += 1;
                    lambda = lambda_after;
                    next = after;
                    ahead = rt_after;
                }
            }
        }
        match accepted {
            // No descent along an updated Jacobian: take it afresh by differences and go on.
            None if stale > 0 => {
                j = by_differences(&logs, &r)?;
                (stale, lambda) = (0, 1e-3);
            }
            None => {
                converged = true; // no descent left: a minimum to working precision
                break;
            }
            // A minimum, and every [`BROYDEN_STEPS`]-th step: the Jacobian by differences there
            // (the covariance is the minimum's own).
            Some(_) if converged || stale + 1 >= BROYDEN_STEPS => {
                j = by_differences(&logs, &r)?;
                stale = 0;
            }
            // Broyden's rank-one update, so that `j` maps the step to the residuals' change: one
            // simulation an iteration instead of one per unknown.
            Some((step, dr)) => {
                let predicted = &dr + &j * &step;
                j -= &predicted * step.transpose() / step.norm_squared();
                stale += 1;
            }
        }
    }
    if stale > 0 {
        // Out of iterations on an updated Jacobian: the covariance needs the minimum's own.
        j = by_differences(&logs, &r)?;
    }
    Ok(Minimum { logs, r, j, cost, iterations, converged, simulations: simulations.get(), refusals })
}

/// How Cl, fitted with `free` to the first `n_est` samples of `data` at the values `p`, leans
/// on each of the circuit values `held` that the model keeps at their nominal: `d ln Cl / d ln
/// x` with every free value (and the start) refitted, linearized at `p`
/// (`−(JᵀJ)⁻¹Jᵀ·∂ŷ/∂ln x`, least squares through the SVD, which a start the data forgets
/// leaves rank-deficient). The fit's CI95 holds `held` exact: a Cl of 8 µF beside a 270 µF
/// capacitor moves by 40 % per 1 % of C, which no interval on Cl alone shows. A late reading
/// that il pins stays where the fit put it (vout alone would move it).
pub fn cl_leverage(data: &DataSet, p: &Params, free: &[Free], n_est: usize, held: &[Free]) -> Result<Vec<f64>, EstimatorError> {
    let not_simulable = || EstimatorError::Fit("the simulation fails at the fitted values".into());
    let estimation = data.slice(0..n_est.min(data.len()));
    let pinned = free.len() > 1 && il_weight(&estimation).is_some();
    let moving: Vec<Free> = free.iter().copied().filter(|f| !(pinned && f.pinned_by_il())).collect();
    let ci = moving.iter().position(|f| *f == Free::Cl).ok_or_else(|| EstimatorError::Config("Cl is not free".into()))?;
    let logs: Vec<f64> = moving.iter().map(|f| f.to_unknown(f.get(p))).chain(Start::from(data.vout[0]).unknowns()).collect();
    let r0 = residuals(p, &moving, &logs, &estimation, Criterion::OutputError, None).ok_or_else(not_simulable)?;
    let j = jacobian(p, &moving, &logs, &estimation, Criterion::OutputError, None, &r0).ok_or_else(not_simulable)?;
    let svd = j.svd(true, true);
    let eps = 1e-9 * svd.singular_values.max();
    held.par_iter()
        .map(|f| {
            let mut q = *p;
            f.set(&mut q, f.get(p) * FD_STEP.exp());
            let column = (&r0 - residuals(&q, &moving, &logs, &estimation, Criterion::OutputError, None).ok_or_else(not_simulable)?) / FD_STEP;
            let x = svd.solve(&column, eps).map_err(|e| EstimatorError::Fit(format!("Cl's leverage: {e}")))?;
            Ok(-x[ci])
        })
        .collect()
}

/// Distance in the unknowns kept from a bound of a parameter's range ([`Free::unknown_range`]).
const INSIDE_RANGE: f64 = 1e-9;

/// The damped Gauss–Newton step `a·step = jtr`, projected onto the parameters' ranges: an
/// unknown at a bound that the step would take past it is held there (its row out of the
/// system, the others solved without it), and one that would cross a bound from inside stops
/// just short of it. A fit so runs along the edge of a range instead of refusing every step
/// that leaves it: with Cl at its 1 nF floor, a drift of C that had to take over the lost
/// capacitance was refused every step and stayed at its nominal. `None` where the system is
/// singular.
fn step_within_range(a: &DMatrix<f64>, jtr: &DVector<f64>, logs: &[f64], free: &[Free]) -> Option<DVector<f64>> {
    let ranges: Vec<(f64, f64)> = free.iter().map(|f| f.unknown_range()).collect();
    let mut held = vec![false; free.len()];
    loop {
        let (mut a, mut b) = (a.clone(), jtr.clone());
        for (i, _) in held.iter().enumerate().filter(|(_, h)| **h) {
            a.row_mut(i).fill(0.0);
            a.column_mut(i).fill(0.0);
            (a[(i, i)], b[i]) = (1.0, 0.0);
        }
        let mut step = a.cholesky()?.solve(&b);
        let mut more = false;
        for (i, &(lo, hi)) in ranges.iter().enumerate() {
            if held[i] {
                continue;
            }
            let (u, to) = (logs[i], logs[i] + step[i]);
            if (to < lo && u <= lo + INSIDE_RANGE) || (to > hi && u >= hi - INSIDE_RANGE) {
                (held[i], more) = (true, true);
            } else {
                step[i] = to.clamp(lo + INSIDE_RANGE, hi - INSIDE_RANGE) - u;
            }
        }
        if !more {
            return Some(step);
        }
    }
}

/// The sensor-noise variance (in vout's units) and the covariance of the unknowns at a minimum.
fn noise_and_covariance(m: &Minimum, criterion: Criterion) -> Result<(f64, DMatrix<f64>), EstimatorError> {
    let ms = m.cost / (m.r.len() - m.logs.len()) as f64;
    match criterion {
        Criterion::OutputError => Ok((ms, with_start_current_held(&m.j, |j| pem::covariance(j.transpose() * j, ms))?)),
        Criterion::Differenced => Ok((ms / 2.0, with_start_current_held(&m.j, |j| differenced_covariance(j, ms))?)),
    }
}

/// The covariance `cov(j)` of the unknowns whose Jacobian is `j`, or, where that is singular,
/// that of the others with the start's inductor current (the last unknown) held: a converter in
/// DCM forgets its start current at its first blocked interval, within the samples left out, so
/// the data says nothing of it and its column vanishes.
fn with_start_current_held(j: &DMatrix<f64>, cov: impl Fn(&DMatrix<f64>) -> Result<DMatrix<f64>, EstimatorError>) -> Result<DMatrix<f64>, EstimatorError> {
    cov(j).or_else(|singular| {
        let n = j.ncols();
        let held = cov(&j.columns(0, n - 1).into_owned()).map_err(|_| singular)?;
        Ok(held.insert_column(n - 1, 0.0).insert_row(n - 1, 0.0))
    })
}

/// Covariance of the unknowns for the differenced criterion, from the Jacobian `j` of the
/// differenced residuals and their mean square `ms` (`≈ 2σ²`, σ² the sensor-noise variance).
/// Differenced white noise of variance `σ²` has the covariance `Σ = σ²·tridiag(−1, 2, −1)`, so
/// the covariance is the sandwich `(JᵀJ)⁻¹·JᵀΣJ·(JᵀJ)⁻¹`.
fn differenced_covariance(j: &DMatrix<f64>, ms: f64) -> Result<DMatrix<f64>, EstimatorError> {
    let s2 = ms / 2.0;
    let jtj = j.transpose() * j;
    let n = j.nrows();
    let lag = j.rows(0, n - 1).transpose() * j.rows(1, n - 1);
    let meat = (&jtj * 2.0 - &lag - lag.transpose()) * s2;
    let bread = pem::covariance(jtj, 1.0)?;
    Ok(&bread * meat * &bread)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::{Experiment, ModelPlant, run};

    /// A reading's calibration by least squares: a scaled and shifted copy of a varying signal
    /// gives its gain and offset back exactly; a constant one, the offset alone; an empty one,
    /// nothing (no NaN).
    #[test]
    fn a_reading_calibration_is_recovered_by_least_squares() {
        let simulated: Vec<f64> = (0..500).map(|k| (k as f64 * 0.07).sin() + 2.0).collect();
        let measured: Vec<f64> = simulated.iter().map(|s| 1.03 * s - 0.05).collect();
        let (offset, gain) = reading_calibration(&measured, &simulated);
        assert!((offset + 0.05).abs() < 1e-12 && (gain - 0.03).abs() < 1e-12, "{offset} {gain}");
        assert!((reading_offset(&measured, &simulated) - (0.03 * 2.0 - 0.05)).abs() < 0.01);
        let flat = vec![3.0; 10];
        let (offset, gain) = reading_calibration(&[3.2; 10], &flat);
        assert!((offset - 0.2).abs() < 1e-12 && gain == 0.0, "{offset} {gain}");
        assert_eq!(reading_calibration(&[], &[]), (0.0, 0.0));
    }

    /// Each channel read at its own instant: with `vout_skew`, `vout` is what a reading at the
    /// sampling instant plus the skew gives, `il` what one at the instant gives, whichever comes
    /// first; a skew that takes `vout`'s instant out of the period is a clear error naming it.
    #[test]
    fn each_channel_is_read_at_its_own_instant() {
        let exp = Experiment { samples: 300, io: 1.5, ..Experiment::default() };
        let data = run(&mut ModelPlant::new(Params::default(), Mode::Switched), &exp).unwrap();
        let t = data.sample_period();
        let read = |sample_delay: f64, vout_skew: f64| simulate_outputs(&Params { sample_delay, vout_skew, ..Params::default() }, &data, data.vout[0]);
        let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9);
        for skew in [0.1 * t, -0.1 * t] {
            let (vout, il) = read(0.2 * t, skew).unwrap();
            let (vout_there, il_there) = read(0.2 * t + skew, 0.0).unwrap();
            let (_, il_here) = read(0.2 * t, 0.0).unwrap();
            assert!(close(&vout, &vout_there) && close(&il, &il_here), "skew {skew:e}");
            // The skew matters: il a tenth of the period apart moves by the ripple's slope.
            assert!(!close(&il, &il_there), "skew {skew:e}");
        }
        let err = read(0.1 * t, -0.2 * t).unwrap_err().to_string();
        assert!(err.contains("vout read") && err.contains("must lie in"), "{err}");
    }

    /// vout and il read at different instants (vout 40 ns after each period start, il 70 ns: a
    /// current probe 30 ns behind the voltage probe), fitted on both channels: both instants
    /// and Cl come back inside their CI95. (The skew's interval carries il's instant's error,
    /// which it takes one for one.)
    #[test]
    fn channels_read_at_different_instants_are_fitted_apart() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let truth = Params { cl: 4.7e-6, sample_delay: 70e-9, vout_skew: -30e-9, ..Params::default() };
        let exp = Experiment { samples: 800, io: 1.5, ..Experiment::default() };
        let mut data = run(&mut ModelPlant::new(truth, Mode::Switched), &exp).unwrap();
        let (vout, il) = simulate_outputs(&truth, &data, data.vout[0]).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let (nv, ni) = (Normal::new(0.0, 2e-3).unwrap(), Normal::new(0.0, 10e-3).unwrap());
        data.vout = vout.iter().map(|v| v + nv.sample(&mut rng)).collect();
        data.il = Some(il.iter().map(|i| i + ni.sample(&mut rng)).collect());
        let start = Params { cl: 3e-6, sample_delay: 50e-9, ..Params::default() };
        let c = fit(&data, &start, &[Free::Cl, Free::SampleDelay, Free::VoutSkew], 600).unwrap();
        for (name, value) in [("Cl", 4.7e-6), ("sample_delay", 70e-9), ("vout_skew", -30e-9)] {
            let e = c.fit.estimate(name).unwrap();
            assert!(e.ci95.0 < value && value < e.ci95.1, "{name}: {value:e} not in {:?}", e.ci95);
        }
    }

    /// On data from the switched plant with a diode (DCM every period at 1 A), the simulated
    /// model recovers `Cl` and the diode drop inside their CI95, where the period map is not
    /// affine.
    #[test]
    fn recovers_cl_and_diode_drop_through_dcm() {
        let truth = Params { cl: 4.7e-6, diode_drop: 0.45, ..Params::default() };
        let exp = Experiment { samples: 800, noise_vout: 2e-3, io: 0.5, ..Experiment::default() };
        let data = run(&mut ModelPlant::new(truth, Mode::Switched), &exp).unwrap();
        let start = Params { cl: 3e-6, diode_drop: 0.3, ..Params::default() };
        let c = fit(&data, &start, &[Free::Cl, Free::DiodeDrop], 600).unwrap();
        for (name, value) in [("Cl", 4.7e-6), ("diode_drop", 0.45)] {
            let e = c.fit.estimate(name).unwrap();
            assert!(e.ci95.0 < value && value < e.ci95.1, "{name}: {} not in {:?}", value, e.ci95);
            assert!(e.rel_std < 0.05, "{name}: relative σ {}", e.rel_std);
        }
        assert!((c.fit.sigma[0] / 2e-3 - 1.0).abs() < 0.1, "residual σ {}", c.fit.sigma[0]);
    }

    /// A fit whose Cl belongs on the floor of its range (no load capacitor) while C lies 14 %
    /// below its nominal: every step wants less capacitance of both, and Cl has none to give.
    /// Held on its floor, Cl lets C take the step, and C's interval holds the truth. (Refusing
    /// every step that left the range, the fit stayed at C's nominal.)
    #[test]
    fn a_fit_runs_along_the_floor_of_cls_range() {
        let floor = buck_model::variables::real_range("Cl").unwrap().0;
        let truth = Params { cl: floor, c: 86e-6, ..Params::default() };
        let exp = Experiment { samples: 800, noise_vout: 2e-3, io: 1.5, ..Experiment::default() };
        let data = run(&mut ModelPlant::new(truth, Mode::Switched), &exp).unwrap();
        let start = Params { cl: floor, ..Params::default() };
        let c = fit_from_exactly(&data, &[start], &[Free::Cl, Free::C], 600, Criterion::OutputError).unwrap();
        let e = c.fit.estimate("C").unwrap();
        assert!(e.ci95.0 < 86e-6 && 86e-6 < e.ci95.1, "C: {e:?}");
        assert!(c.fit.estimate("Cl").unwrap().value < 1.01 * floor);
    }

    /// Cl's leverage on a value the model holds, against refitting with that value 1 % off:
    /// the linearized `d ln Cl / d ln C` and the refits' change agree within a tenth, and C
    /// trades against Cl (more of one, less of the other).
    #[test]
    fn cls_leverage_is_what_a_refit_with_c_off_gives() {
        let truth = Params { cl: 10e-6, ..Params::default() };
        let exp = Experiment { samples: 800, noise_vout: 2e-3, io: 1.5, ..Experiment::default() };
        let data = run(&mut ModelPlant::new(truth, Mode::Switched), &exp).unwrap();
        let free = [Free::Cl];
        let at = fit(&data, &truth, &free, 600).unwrap();
        let lever = cl_leverage(&data, &at.fit.params, &free, 600, &[Free::C, Free::L]).unwrap();
        let cl_with = |c: f64| fit(&data, &Params { c, ..at.fit.params }, &free, 600).unwrap().fit.estimate("Cl").unwrap().value;
        let refit = (cl_with(truth.c * 1.01) / cl_with(truth.c)).ln() / 1.01_f64.ln();
        assert!(lever[0] < 0.0 && refit < 0.0, "{lever:?} {refit}");
        assert!((lever[0] / refit - 1.0).abs() < 0.1, "linearized {} against the refits' {refit}", lever[0]);
    }

    /// The projected step: an unknown at its floor that the step would take below it is held
    /// and the rest solved without it; one inside its range stops just short of a bound.
    #[test]
    fn a_step_is_projected_onto_the_ranges() {
        let free = [Free::Cl, Free::C];
        let floor = Free::Cl.unknown_range().0;
        let a = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 2.0]);
        let jtr = DVector::from_vec(vec![-3.0, -1.0]);
        // Unconstrained: (−5/3, 1/3); Cl held at its floor: C alone, −1/2.
        let c = 100e-6_f64.ln();
        let held = step_within_range(&a, &jtr, &[floor, c], &free).unwrap();
        assert_eq!(held[0], 0.0);
        assert!((held[1] + 0.5).abs() < 1e-12, "{held}");
        let cut = step_within_range(&a, &jtr, &[floor + 1.0, c], &free).unwrap();
        assert!((cut[0] + 1.0 - INSIDE_RANGE).abs() < 1e-12 && (cut[1] - 1.0 / 3.0).abs() < 1e-12, "{cut}");
    }

    /// With the right model the differenced criterion agrees with the output error: both
    /// intervals hold the true Cl, the sensor σ comes out of the MA(1) residual, and the
    /// output error (maximum likelihood here) is the more precise.
    #[test]
    fn differenced_criterion_agrees_with_output_error_on_a_right_model() {
        let truth = Params { cl: 4.7e-6, ..Params::default() };
        let exp = Experiment { samples: 800, noise_vout: 2e-3, io: 1.5, ..Experiment::default() };
        let data = run(&mut ModelPlant::new(truth, Mode::Switched), &exp).unwrap();
        let oe = fit(&data, &Params { cl: 3e-6, ..Params::default() }, &[Free::Cl], 600).unwrap();
        let start = Params { cl: oe.fit.estimate("Cl").unwrap().value, ..Params::default() };
        let hp = fit_with(&data, &start, &[Free::Cl], 600, Criterion::Differenced).unwrap();
        let (a, b) = (oe.fit.estimate("Cl").unwrap(), hp.fit.estimate("Cl").unwrap());
        for e in [a, b] {
            assert!(e.ci95.0 < 4.7e-6 && 4.7e-6 < e.ci95.1, "{e:?}");
        }
        assert!(b.rel_std >= a.rel_std, "high-pass σ {} below the output error's {}", b.rel_std, a.rel_std);
        assert!((hp.fit.sigma[0] / 2e-3 - 1.0).abs() < 0.1, "sensor σ from the differenced residual {}", hp.fit.sigma[0]);
    }

    /// Started at its minimum, a fit ends after the Jacobian there and the few steps the noise
    /// leaves worth taking: it does not try ever more damped steps that the linearization
    /// already says gain nothing (that climb of λ from 1e-9 to 1e10 took twenty simulations).
    #[test]
    fn a_fit_at_its_minimum_stops_without_trying_worthless_steps() {
        let truth = Params { cl: 4.7e-6, ..Params::default() };
        let exp = Experiment { samples: 800, noise_vout: 2e-3, io: 1.5, ..Experiment::default() };
        let data = run(&mut ModelPlant::new(truth, Mode::Switched), &exp).unwrap();
        let estimation = data.slice(0..600);
        let free = [Free::Cl];
        let first = fit(&data, &truth, &free, 600).unwrap();
        let logs: Vec<f64> = free.iter().map(|f| f.to_unknown(f.get(&first.fit.params))).chain(first.fit.x0.iter().copied()).collect();
        let m = minimize(&first.fit.params, &free, logs, &estimation, Criterion::OutputError, None).unwrap();
        assert!(m.converged, "not converged after {} iterations", m.iterations);
        // The residuals, the Jacobian by differences (3 unknowns) and at most one step.
        assert!(m.simulations <= 1 + 3 + 1, "{} simulations at the minimum", m.simulations);
    }

    /// The trial step simulated ahead on a free core changes nothing: a fit from far off (Cl
    /// 10× low, the diode drop 3× high: damping refused and raised along the way) ends bit for
    /// bit where it ends on one thread, after the same simulations.
    #[test]
    fn trials_simulated_ahead_leave_the_fit_as_on_one_thread() {
        let truth = Params { cl: 4.7e-6, diode_drop: 0.45, ..Params::default() };
        let exp = Experiment { samples: 800, noise_vout: 2e-3, io: 0.5, ..Experiment::default() };
        let data = run(&mut ModelPlant::new(truth, Mode::Switched), &exp).unwrap();
        let estimation = data.slice(0..600);
        let free = [Free::Cl, Free::DiodeDrop];
        let start = Params { cl: 0.47e-6, diode_drop: 1.35, ..Params::default() };
        let logs: Vec<f64> = free.iter().map(|f| f.to_unknown(f.get(&start))).chain(Start::from(data.vout[0]).unknowns()).collect();
        let on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| minimize(&start, &free, logs.clone(), &estimation, Criterion::OutputError, None).unwrap())
        };
        let (one, two) = (on(1), on(2));
        assert!(one.refusals >= 2, "{} refused steps: none to simulate ahead", one.refusals);
        assert_eq!((one.iterations, one.simulations, one.refusals, one.converged), (two.iterations, two.simulations, two.refusals, two.converged));
        assert!(one.logs.iter().zip(&two.logs).all(|(a, b)| a.to_bits() == b.to_bits()), "{:?} vs {:?}", one.logs, two.logs);
        assert_eq!(one.cost.to_bits(), two.cost.to_bits());
    }

    /// The time-averaged output is the plant's own period averages over the record (a biased
    /// ceramic, PRBS duty), and at a constant duty the volt-second balance `d·U − RL·io`; the
    /// samples, all taken where the ripple puts them, sit tens of millivolts away from it.
    #[test]
    fn time_averaged_output_is_the_plants_own_average() {
        let truth = Params { cl: 10e-6, cap_dc_bias: 0.5, ..Params::default() };
        let data = run(&mut ModelPlant::new(truth, Mode::Switched), &Experiment { samples: 1500, io: 1.5, ..Experiment::default() }).unwrap();
        let plant: Vec<f64> = data.vout_avg.clone().unwrap();
        let plant_mean = plant.iter().sum::<f64>() / plant.len() as f64;
        let ours = operation(&truth, &data, data.vout[0]).unwrap();
        assert!((ours.vout_time_mean - plant_mean).abs() < 1e-3, "{ours:?} against the plant's {plant_mean} V");
        assert_eq!(ours.dcm_share, 0.0, "a synchronous buck has no DCM");
        let steady = DataSet { duty: vec![0.5; data.len()], ..data };
        let balance = 0.5 * 12.0 - truth.rl * 1.5;
        let ours = operation(&truth, &steady, balance).unwrap().vout_time_mean;
        // (Up to the start's transient: il starts at the DC point, not on the ripple's orbit.)
        assert!((ours - balance).abs() < 2e-3, "{ours} V against d·U − RL·io = {balance} V");
        let sampled = simulate(&truth, &steady, balance).unwrap();
        let samples = sampled.iter().sum::<f64>() / sampled.len() as f64;
        assert!((samples - balance).abs() > 0.01, "the samples' mean {samples} V is the average too");
    }

    /// A diode buck (12 V, 3.3 µH, 330 kHz, a 0.5 V drop) at a constant duty of 0.4 runs in
    /// DCM when the load current is below half the ripple, `(U − Vo)·D·T/(2L)` ≈ 1.4 A at
    /// 4.5 V out: every period at 0.5 A, none at 4 A. Under PRBS between 0.4 and 0.6 at 2.3 A,
    /// in CCM at either duty, only some: a step down passes through DCM while the output falls
    /// (the diode cannot sink current).
    #[test]
    fn a_diode_buck_is_in_dcm_below_half_the_ripple() {
        let diode = Params { cl: 10e-6, diode_drop: 0.5, ..Params::default() };
        let share = |io: f64, duty: Option<f64>| {
            let data = run(&mut ModelPlant::new(diode, Mode::Switched), &Experiment { samples: 600, io, ..Experiment::default() }).unwrap();
            let data = match duty {
                Some(d) => DataSet { duty: vec![d; data.len()], ..data },
                None => data,
            };
            operation(&diode, &data, data.vout[0]).unwrap().dcm_share
        };
        assert!(share(0.5, Some(0.4)) > 0.99);
        assert_eq!(share(4.0, Some(0.4)), 0.0);
        let mixed = share(2.3, None);
        assert!(mixed > 0.01 && mixed < 0.99, "{mixed}");
    }

    #[test]
    fn too_few_samples_is_a_clear_error() {
        let data = run(&mut ModelPlant::new(Params::default(), Mode::Switched), &Experiment { samples: 100, ..Experiment::default() }).unwrap();
        let err = fit(&data, &Params::default(), &[Free::Cl], 90).unwrap_err();
        assert!(err.to_string().contains("estimation samples"), "{err}");
    }
}
