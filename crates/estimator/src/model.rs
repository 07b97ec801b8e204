//! Grey-box model structures of the buck converter at one sample per switching period.
//!
//! Each structure turns circuit values and a data set into a per-sample affine predictor
//!
//! ```text
//! x[k+1] = F_j·x[k] + G_j·u[k]        y[k] = H_j·x[k] + D_j·u[k]
//! ```
//!
//! where `j` is the sample's input level (one level for the averaged and reduced models, one
//! per distinct duty for the sampled-data PWM and exact models), together with the derivatives of
//! `F, G, H, D` with respect to the free circuit parameters (log-parameterized): analytic for
//! the averaged, PWM and reduced models, central finite differences for the exact model.
//!
//! A load resistor (`Params::rload`, a known value) is in every structure: the analytic ones
//! carry `−vo/(rload·Cl)` at the output node (so `∂A/∂ln Cl` includes it), the exact and
//! simulated ones get it from the plant simulator.
use buck_model::lti::{Discrete, Lti};
use buck_model::variables::VarId;
use buck_model::{Converter, Mode, Params, State};
use nalgebra::DMatrix;

use crate::data::DataSet;
use crate::error::EstimatorError;

/// Which grey-box model to fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Structure {
    /// Averaged third-order model, duty → outputs (switch node = `d·U`).
    Averaged,
    /// Sampled-data PWM model: exact for the switched circuit sampled at period starts
    /// (switching ripple, trailing-edge modulation within the period).
    Pwm,
    /// Reduced second-order model: the measured inductor current drives `vc`, `vo`. Within a
    /// period the current is the quadratic through its two period-start samples with the
    /// measured period average, so the charge delivered per period is exact (the charge mode is
    /// an integrator: any error in it would drift). Exact for smooth currents (averaged data);
    /// on switched data it cannot see the ripple shape and is biased for small Cl, like
    /// [`Structure::Averaged`].
    Reduced,
    /// Exact period map of the plant simulator: like [`Structure::Pwm`] (one level per distinct
    /// duty, period-start samples) but each level's maps are extracted from one simulated
    /// switching period of `buck_model::Converter` in switched mode, so every non-ideal effect
    /// of [`Params`] is in them. Inputs `[vin, io, 1]`: the constant third input carries the
    /// affine offset of the period map (e.g. a diode drop).
    ///
    /// The maps are the period map linearized at the periodic orbit of each level at the data's
    /// mean `vin` and `io` (found by Newton's method on the period map, perturbations of 1e-3 in
    /// each state and input). They are exact where the period map is affine: `switch_resistance`,
    /// `load_esr`, `esl`, and `dead_time` and `diode_drop` while the inductor current keeps the
    /// sign it has at the orbit through every diode interval. DCM, `inductor_saturation` and
    /// `cap_dc_bias` make it non-affine (events that move with the state, a state-dependent
    /// `Cl`): there these maps are only a small-signal approximation around the orbit.
    /// The state is `[il, vc, vo]`, plus the branch current `ic` of `C` when [`Free::Esl`] is
    /// free (a nominal `esl > 0` needs `Esl` free). Period-start sampling only.
    Exact,
    /// The plant simulator itself, nonlinear: `buck_model::Converter` in switched mode driven
    /// period by period by the data's duty, `io` and `vin`, sampled at period starts, fitted by
    /// its simulation error (see [`crate::simulated`]). Exact where [`Structure::Exact`] is a
    /// linearization: DCM, diode and dead-time intervals that move with the state, saturation,
    /// a voltage-dependent `Cl`. Output error only, `vout` only, period-start sampling; slower
    /// (a simulation per parameter per iteration).
    Simulated,
}

impl Structure {
    /// Name used in the CLI and reports.
    pub fn name(self) -> &'static str {
        match self {
            Structure::Averaged => "averaged",
            Structure::Pwm => "pwm",
            Structure::Reduced => "reduced",
            Structure::Exact => "exact",
            Structure::Simulated => "simulated",
        }
    }

    /// Parses a CLI name.
    pub fn from_name(s: &str) -> Option<Self> {
        [Structure::Averaged, Structure::Pwm, Structure::Reduced, Structure::Exact, Structure::Simulated].into_iter().find(|m| m.name() == s)
    }
}

/// Which samples the outputs are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sampling {
    /// Instantaneous values at each period start (`vout`, `il` columns).
    PeriodStart,
    /// Exact averages over each period (`vout_avg`, `il_avg` columns).
    PeriodAverage,
}

/// A measured output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Signal {
    /// Output voltage.
    Vout,
    /// Inductor current.
    Il,
}

/// A circuit parameter that can be estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Free {
    /// Load capacitance.
    Cl,
    /// Inductance.
    L,
    /// Inductor series resistance.
    RL,
    /// Main capacitance.
    C,
    /// ESR of the main capacitance.
    Rc,
    /// `load_esr`: series resistance of `Cl` ([`Structure::Exact`] only).
    LoadEsr,
    /// `esl`: series inductance of the `C` branch ([`Structure::Exact`] only).
    Esl,
    /// `dead_time` of the half bridge ([`Structure::Exact`] only).
    DeadTime,
    /// `pulse_width_distortion`: the high side's on-time beyond the PWM's `d·T`, fitted
    /// positive (a gate drive's turn-off slower than its turn-on; a shortened pulse reads as
    /// a dead time) ([`Structure::Simulated`] only).
    PulseWidthDistortion,
    /// `diode_drop` of the freewheeling diode ([`Structure::Exact`] only; a positive value makes
    /// the buck asynchronous).
    DiodeDrop,
    /// `diode_resistance`: slope resistance of the conducting diodes ([`Structure::Exact`] and
    /// [`Structure::Simulated`] only).
    DiodeResistance,
    /// `switch_node_capacitance`, charged by il while both switches are off
    /// ([`Structure::Exact`] and [`Structure::Simulated`] only).
    SwitchNodeCapacitance,
    /// `switch_node_damping`: resistance in series with the switch node's capacitance (an RC
    /// snubber's), damping its ring ([`Structure::Exact`] and [`Structure::Simulated`] only).
    SwitchNodeDamping,
    /// `low_side_ratio`: the low-side switch's on-resistance over the high side's
    /// ([`Structure::Exact`] and [`Structure::Simulated`] only).
    LowSideRatio,
    /// `switch_resistance` of each switch ([`Structure::Exact`] only).
    SwitchResistance,
    /// `inductor_saturation`: fraction of `L` lost above `isat` ([`Structure::Exact`] and
    /// [`Structure::Simulated`] only).
    InductorSaturation,
    /// `isat`: saturation current of the inductor (with [`Free::InductorSaturation`]).
    Isat,
    /// `cap_dc_bias`: fraction of `Cl` lost at its rated voltage ([`Structure::Exact`] and
    /// [`Structure::Simulated`] only).
    CapDcBias,
    /// `sample_delay`: the outputs sampled this long after each period start
    /// ([`Structure::Simulated`] only).
    SampleDelay,
    /// `vout_skew`: `vout` read this long after `il`, signed ([`Structure::Simulated`] only).
    VoutSkew,
    /// `vout_filter`: the `vout` reading through a first-order low-pass of this time constant
    /// ([`Structure::Simulated`] only).
    VoutFilter,
    /// `il_filter`: the `il` reading through a first-order low-pass of this time constant
    /// ([`Structure::Simulated`] only).
    IlFilter,
    /// `vout_offset`: the `vout` reading's zero error, signed ([`Structure::Simulated`] only).
    VoutOffset,
    /// `vout_gain_error`: the `vout` reading's relative gain error, signed
    /// ([`Structure::Simulated`] only).
    VoutGainError,
}

impl Free {
    /// Name as in the variable table.
    pub fn name(self) -> &'static str {
        match self {
            Free::Cl => "Cl",
            Free::L => "L",
            Free::RL => "RL",
            Free::C => "C",
            Free::Rc => "Rc",
            Free::LoadEsr => "load_esr",
            Free::Esl => "esl",
            Free::DeadTime => "dead_time",
            Free::PulseWidthDistortion => "pulse_width_distortion",
            Free::DiodeDrop => "diode_drop",
            Free::DiodeResistance => "diode_resistance",
            Free::SwitchNodeCapacitance => "switch_node_capacitance",
            Free::SwitchNodeDamping => "switch_node_damping",
            Free::SwitchResistance => "switch_resistance",
            Free::LowSideRatio => "low_side_ratio",
            Free::InductorSaturation => "inductor_saturation",
            Free::Isat => "isat",
            Free::CapDcBias => "cap_dc_bias",
            Free::SampleDelay => "sample_delay",
            Free::VoutSkew => "vout_skew",
            Free::VoutFilter => "vout_filter",
            Free::IlFilter => "il_filter",
            Free::VoutOffset => "vout_offset",
            Free::VoutGainError => "vout_gain_error",
        }
    }

    /// Whether the inductor current's reading pins it where the data has `il` (the simulated
    /// fit's both channels, then held): the sampling instant, and the `il` reading's filter,
    /// which `vout` does not show.
    pub fn pinned_by_il(self) -> bool {
        matches!(self, Free::SampleDelay | Free::IlFilter)
    }

    /// Whether the value `v` lies inside the parameter's range in the variable table (a
    /// parameter without one admits any value): a fit's step that would leave it is refused.
    pub fn admits(self, v: f64) -> bool {
        buck_model::variables::real_range(self.name()).is_none_or(|(min, max)| (min..=max).contains(&v))
    }

    /// The ceiling of a fraction a fit must stay below (`cap_dc_bias`, `inductor_saturation`:
    /// the top of their range in the variable table), `None` for the other parameters.
    pub fn ceiling(self) -> Option<f64> {
        match self {
            Free::CapDcBias | Free::InductorSaturation => buck_model::variables::real_range(self.name()).map(|(_, max)| max),
            _ => None,
        }
    }

    /// The unit of a signed parameter's unknown (an offset or a gain error of a reading, or the
    /// skew of its channels, which may have either sign and is fitted on a linear scale), `None`
    /// for the positive ones.
    pub fn signed_scale(self) -> Option<f64> {
        match self {
            Free::VoutOffset => Some(10e-3),
            Free::VoutGainError => Some(1e-2),
            Free::VoutSkew => Some(10e-9),
            _ => None,
        }
    }

    /// The range of the fit's unknown: the variable table's range through
    /// [`Free::to_unknown`], unbounded where it has none or the scale cannot reach it (a
    /// lower bound of zero on the log scale, a ceiling under the logit).
    pub fn unknown_range(self) -> (f64, f64) {
        let Some((min, max)) = buck_model::variables::real_range(self.name()) else { return (f64::NEG_INFINITY, f64::INFINITY) };
        let reach = |v: f64| if self.signed_scale().is_some() || v > 0.0 { self.to_unknown(v) } else { f64::NEG_INFINITY };
        let hi = if self.ceiling().is_some() { f64::INFINITY } else { reach(max) };
        (reach(min), hi)
    }

    /// A fit's unknown for the value `v`: `ln v`, or below a [`Free::ceiling`] `M` the logit
    /// `ln(v/(M − v))`, which is `ln v` less a constant far below the ceiling and never reaches
    /// it (a log-scale fit had to refuse its steps there: 30 iterations for a DC-bias law), or
    /// `v` in units of its [`Free::signed_scale`].
    pub fn to_unknown(self, v: f64) -> f64 {
        match (self.ceiling(), self.signed_scale()) {
            (_, Some(s)) => v / s,
            (Some(m), _) => (v / (m - v)).ln(),
            (None, None) => v.ln(),
        }
    }

    /// The value of the unknown `u` (the inverse of [`Free::to_unknown`]).
    pub fn from_unknown(self, u: f64) -> f64 {
        match (self.ceiling(), self.signed_scale()) {
            (_, Some(s)) => u * s,
            (Some(m), _) => m / (1.0 + (-u).exp()),
            (None, None) => u.exp(),
        }
    }

    /// `d ln |v| / du` at the unknown `u`: 1 on the log scale, `1 − v/M` below a ceiling, `1/|u|`
    /// on a signed scale (a standard deviation of `u` times it is the relative one of the value).
    pub fn relative_slope(self, u: f64) -> f64 {
        match (self.ceiling(), self.signed_scale()) {
            (_, Some(_)) => 1.0 / u.abs(),
            (Some(m), _) => 1.0 - self.from_unknown(u) / m,
            (None, None) => 1.0,
        }
    }

    /// A calibration of the vout reading (`vout_offset`, `vout_gain_error`) rather than of the
    /// circuit.
    pub fn calibrates_reading(self) -> bool {
        matches!(self, Free::VoutOffset | Free::VoutGainError)
    }

    /// Whether only [`Structure::Exact`] models this parameter.
    pub fn exact_only(self) -> bool {
        self.slot().is_none()
    }

    /// Index in the monomial exponent arrays `[L, RL, C, Rc, Cl]` (none for an effect).
    fn slot(self) -> Option<usize> {
        match self {
            Free::L => Some(0),
            Free::RL => Some(1),
            Free::C => Some(2),
            Free::Rc => Some(3),
            Free::Cl => Some(4),
            _ => None,
        }
    }

    /// Reads the value from circuit parameters.
    pub fn get(self, p: &Params) -> f64 {
        match self {
            Free::L => p.l,
            Free::RL => p.rl,
            Free::C => p.c,
            Free::Rc => p.rc,
            Free::Cl => p.cl,
            Free::LoadEsr => p.load_esr,
            Free::Esl => p.esl,
            Free::DeadTime => p.dead_time,
            Free::PulseWidthDistortion => p.pulse_width_distortion,
            Free::DiodeDrop => p.diode_drop,
            Free::DiodeResistance => p.diode_resistance,
            Free::SwitchNodeCapacitance => p.switch_node_capacitance,
            Free::SwitchNodeDamping => p.switch_node_damping,
            Free::SwitchResistance => p.switch_resistance,
            Free::LowSideRatio => p.low_side_ratio,
            Free::InductorSaturation => p.inductor_saturation,
            Free::Isat => p.isat,
            Free::CapDcBias => p.cap_dc_bias,
            Free::SampleDelay => p.sample_delay,
            Free::VoutSkew => p.vout_skew,
            Free::VoutFilter => p.vout_filter,
            Free::IlFilter => p.il_filter,
            Free::VoutOffset => p.vout_offset,
            Free::VoutGainError => p.vout_gain_error,
        }
    }

    /// Writes the value into circuit parameters.
    pub fn set(self, p: &mut Params, value: f64) {
        match self {
            Free::L => p.l = value,
            Free::RL => p.rl = value,
            Free::C => p.c = value,
            Free::Rc => p.rc = value,
            Free::Cl => p.cl = value,
            Free::LoadEsr => p.load_esr = value,
            Free::Esl => p.esl = value,
            Free::DeadTime => p.dead_time = value,
            Free::PulseWidthDistortion => p.pulse_width_distortion = value,
            Free::DiodeDrop => p.diode_drop = value,
            Free::DiodeResistance => p.diode_resistance = value,
            Free::SwitchNodeCapacitance => p.switch_node_capacitance = value,
            Free::SwitchNodeDamping => p.switch_node_damping = value,
            Free::SwitchResistance => p.switch_resistance = value,
            Free::LowSideRatio => p.low_side_ratio = value,
            Free::InductorSaturation => p.inductor_saturation = value,
            Free::Isat => p.isat = value,
            Free::CapDcBias => p.cap_dc_bias = value,
            Free::SampleDelay => p.sample_delay = value,
            Free::VoutSkew => p.vout_skew = value,
            Free::VoutFilter => p.vout_filter = value,
            Free::IlFilter => p.il_filter = value,
            Free::VoutOffset => p.vout_offset = value,
            Free::VoutGainError => p.vout_gain_error = value,
        }
    }
}

/// A matrix entry `coef · L^e0 · RL^e1 · C^e2 · Rc^e3 · Cl^e4 · G^g`, with `G = 1/rload` the
/// load conductance (a known value, never free; 0 without a load resistor, which zeroes its
/// terms and leaves the others as they were).
#[derive(Debug, Clone, Copy)]
struct Term {
    row: usize,
    col: usize,
    coef: f64,
    exps: [i32; 5],
    g: i32,
}

const fn t(row: usize, col: usize, coef: f64, exps: [i32; 5]) -> Term {
    Term { row, col, coef, exps, g: 0 }
}

/// A term proportional to the load conductance `G`.
const fn tg(row: usize, col: usize, coef: f64, exps: [i32; 5]) -> Term {
    Term { row, col, coef, exps, g: 1 }
}

/// Averaged third-order model `[il, vc, vo]`, inputs `[u_sw, io]` (see `buck_model::Params`).
const FULL_A: &[Term] = &[
    t(0, 0, -1.0, [-1, 1, 0, 0, 0]),
    t(0, 2, -1.0, [-1, 0, 0, 0, 0]),
    t(1, 1, -1.0, [0, 0, -1, -1, 0]),
    t(1, 2, 1.0, [0, 0, -1, -1, 0]),
    t(2, 0, 1.0, [0, 0, 0, 0, -1]),
    t(2, 1, 1.0, [0, 0, 0, -1, -1]),
    t(2, 2, -1.0, [0, 0, 0, -1, -1]),
    // The load resistor at the output node: −vo/(rload·Cl).
    tg(2, 2, -1.0, [0, 0, 0, 0, -1]),
];
const FULL_B: &[Term] = &[t(0, 0, 1.0, [-1, 0, 0, 0, 0]), t(2, 1, -1.0, [0, 0, 0, 0, -1])];
/// Reduced model `[vc, vo]`, inputs `[il, io]`.
#[rustfmt::skip] // a term per line, as FULL_A
const REDUCED_A: &[Term] = &[
    t(0, 0, -1.0, [0, 0, -1, -1, 0]),
    t(0, 1, 1.0, [0, 0, -1, -1, 0]),
    t(1, 0, 1.0, [0, 0, 0, -1, -1]),
    t(1, 1, -1.0, [0, 0, 0, -1, -1]),
    tg(1, 1, -1.0, [0, 0, 0, 0, -1]),
];
const REDUCED_B: &[Term] = &[t(1, 0, 1.0, [0, 0, 0, 0, -1]), t(1, 1, -1.0, [0, 0, 0, 0, -1])];

fn values(p: &Params) -> [f64; 5] {
    [p.l, p.rl, p.c, p.rc, p.cl]
}

/// Evaluates a term matrix, or its derivative with respect to `ln p[slot]` when `slot` is set.
fn build(terms: &[Term], rows: usize, cols: usize, p: &Params, slot: Option<usize>) -> DMatrix<f64> {
    let v = values(p);
    let g = p.load_conductance();
    let mut m = DMatrix::zeros(rows, cols);
    for term in terms {
        if term.g != 0 && g == 0.0 {
            continue;
        }
        let value = term.coef * term.exps.iter().zip(v).map(|(&e, x)| x.powi(e)).product::<f64>() * g.powi(term.g);
        m[(term.row, term.col)] += match slot {
            None => value,
            Some(s) => f64::from(term.exps[s]) * value,
        };
    }
    m
}

/// One sample's affine maps, flattened row-major for the predictor's inner loop.
#[derive(Debug, Clone, Default)]
pub struct Maps {
    /// `n × n`.
    pub f: Vec<f64>,
    /// `n × nu`.
    pub g: Vec<f64>,
    /// `ny × n`.
    pub h: Vec<f64>,
    /// `ny × nu`.
    pub d: Vec<f64>,
}

impl Maps {
    fn from(f: &DMatrix<f64>, g: &DMatrix<f64>, h: &DMatrix<f64>, d: &DMatrix<f64>) -> Self {
        let flat = |m: &DMatrix<f64>| m.transpose().as_slice().to_vec();
        Self { f: flat(f), g: flat(g), h: flat(h), d: flat(d) }
    }

    /// `(a − b)/step`, entry by entry (a central difference).
    fn difference(a: &Maps, b: &Maps, step: f64) -> Self {
        let diff = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(p, q)| (p - q) / step).collect();
        Self { f: diff(&a.f, &b.f), g: diff(&a.g, &b.g), h: diff(&a.h, &b.h), d: diff(&a.d, &b.d) }
    }

    /// Maps of the same shape filled with NaN (a simulation that could not run).
    fn nan(nx: usize, ny: usize, nu: usize) -> Self {
        Self { f: vec![f64::NAN; nx * nx], g: vec![f64::NAN; nx * nu], h: vec![f64::NAN; ny * nx], d: vec![f64::NAN; ny * nu] }
    }
}

/// Step in `ln θ` of the central differences that give the exact model's derivatives. The
/// maps are smooth in θ and computed to ~1e-13, so the truncation error (~step²) and the
/// rounding error (~1e-13/step) are both ≤ 1e-8 relative: far below what the fit resolves.
const FD_STEP: f64 = 1e-4;

/// Perturbation of each state [A, V] and input [V, A] when extracting the exact maps.
const EXACT_DELTA: f64 = 1e-3;

/// Newton iterations for a level's periodic orbit (one step reaches it where the map is affine,
/// a second confirms; a DCM orbit takes ~6).
const NEWTON_ITERATIONS: usize = 8;

/// Maps of one input level and their derivatives with respect to each free parameter.
#[derive(Debug, Clone, Default)]
pub struct Level {
    /// Value.
    pub maps: Maps,
    /// `∂/∂ln θ_i` for each free parameter `i`.
    pub derivs: Vec<Maps>,
}

/// A model structure bound to a data set: inputs, levels and measured outputs per sample.
#[derive(Debug, Clone)]
pub struct Model {
    /// The structure.
    pub structure: Structure,
    /// Output sampling.
    pub sampling: Sampling,
    /// Measured outputs, in order.
    pub outputs: Vec<Signal>,
    /// Free parameters, in order.
    pub free: Vec<Free>,
    /// Distinct duty levels (PWM model) or a single placeholder.
    levels: Vec<f64>,
    /// Level index of each sample.
    pub level_of: Vec<usize>,
    /// Input vector of each sample, `nu` values each.
    pub u: Vec<f64>,
    /// Measured outputs of each sample, `ny` values each.
    pub y: Vec<f64>,
    /// Switching period \[s\].
    period: f64,
    /// Mean `vin` and `io` of the data: the operating point of the exact model's orbits.
    operating: (f64, f64),
}

/// Largest number of distinct duty values the PWM model accepts (one exact map per value;
/// closed-loop data through a 10-bit DPWM has a few hundred).
pub const MAX_PWM_LEVELS: usize = 4096;

impl Model {
    /// Binds `structure` to `data`. Errors name a missing column or an unusable duty sequence.
    pub fn new(structure: Structure, sampling: Sampling, outputs: &[Signal], free: &[Free], data: &DataSet, period: f64) -> Result<Self, EstimatorError> {
        data.validate()?;
        if structure == Structure::Simulated {
            return Err(EstimatorError::Config("the simulated structure has no linear predictor: fit it with `estimator::simulated::fit`".into()));
        }
        if outputs.is_empty() {
            return Err(EstimatorError::Config("at least one output is needed".into()));
        }
        if structure == Structure::Reduced && outputs.contains(&Signal::Il) {
            return Err(EstimatorError::Config("the reduced model takes il as an input, not an output".into()));
        }
        if free.is_empty() {
            return Err(EstimatorError::Config("at least one free parameter is needed".into()));
        }
        if let Some(f) = free.iter().find(|f| matches!(f, Free::SampleDelay | Free::VoutSkew | Free::VoutFilter | Free::IlFilter)) {
            return Err(EstimatorError::Config(format!("the free parameter `{}` is modelled by the simulated structure only, not by `{}`", f.name(), structure.name())));
        }
        if structure != Structure::Exact
            && let Some(f) = free.iter().find(|f| f.exact_only())
        {
            return Err(EstimatorError::Config(format!("the free parameter `{}` is modelled by the exact structure only, not by `{}`", f.name(), structure.name())));
        }
        if structure == Structure::Exact && sampling != Sampling::PeriodStart {
            return Err(EstimatorError::Config("the exact model takes period-start samples only".into()));
        }
        let column = |s: Signal| -> Result<&Vec<f64>, EstimatorError> {
            let (col, name) = match (s, sampling) {
                (Signal::Vout, Sampling::PeriodStart) => (Some(&data.vout), "vout"),
                (Signal::Il, Sampling::PeriodStart) => (data.il.as_ref(), "il"),
                (Signal::Vout, Sampling::PeriodAverage) => (data.vout_avg.as_ref(), "vout_avg"),
                (Signal::Il, Sampling::PeriodAverage) => (data.il_avg.as_ref(), "il_avg"),
            };
            col.ok_or_else(|| EstimatorError::Data(format!("the data set has no `{name}` column")))
        };
        let cols: Vec<&Vec<f64>> = outputs.iter().map(|&s| column(s)).collect::<Result<_, _>>()?;
        let n = data.len();
        let y: Vec<f64> = (0..n).flat_map(|k| cols.iter().map(move |c| c[k])).collect();

        // The reduced model needs the next period-start sample: it uses one sample less.
        let n = if structure == Structure::Reduced { n - 1 } else { n };
        let y = y[..n * outputs.len()].to_vec();
        let (levels, level_of) = match structure {
            Structure::Pwm | Structure::Exact => {
                let mut levels: Vec<f64> = Vec::new();
                let mut level_of = Vec::with_capacity(n);
                for &d in &data.duty {
                    let j = match levels.iter().position(|&l| l == d) {
                        Some(j) => j,
                        None => {
                            levels.push(d);
                            levels.len() - 1
                        }
                    };
                    level_of.push(j);
                }
                if levels.len() > MAX_PWM_LEVELS {
                    return Err(EstimatorError::Config(format!(
                        "the PWM model needs a duty with finitely many levels (a DPWM register); this data has {} distinct duties (max {MAX_PWM_LEVELS})",
                        levels.len()
                    )));
                }
                (levels, level_of)
            }
            _ => (vec![0.0], vec![0; n]),
        };
        let u: Vec<f64> = match structure {
            Structure::Averaged => (0..n).flat_map(|k| [data.duty[k] * data.vin[k], data.io[k]]).collect(),
            Structure::Pwm => (0..n).flat_map(|k| [data.vin[k], data.io[k]]).collect(),
            Structure::Exact => (0..n).flat_map(|k| [data.vin[k], data.io[k], 1.0]).collect(),
            Structure::Simulated => unreachable!("rejected above"),
            Structure::Reduced => {
                let (Some(il), Some(avg)) = (data.il.as_ref(), data.il_avg.as_ref()) else {
                    return Err(EstimatorError::Data("the reduced model needs the measured `il` (period start) and `il_avg` (period average) columns".into()));
                };
                // [il at the period start, its period average, il at the period end, io]; the
                // last sample, which has no period end, was dropped above.
                (0..n).flat_map(|k| [il[k], avg[k], il[k + 1], data.io[k]]).collect()
            }
        };
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        let operating = (mean(&data.vin), mean(&data.io));
        Ok(Self { structure, sampling, outputs: outputs.to_vec(), free: free.to_vec(), levels, level_of, u, y, period, operating })
    }

    /// The first `n` samples only (e.g. to rank start values cheaply).
    pub fn prefix(&self, n: usize) -> Model {
        let n = n.min(self.len());
        Model { level_of: self.level_of[..n].to_vec(), u: self.u[..n * self.nu()].to_vec(), y: self.y[..n * self.ny()].to_vec(), ..self.clone() }
    }

    /// Number of states.
    pub fn nx(&self) -> usize {
        match self.structure {
            Structure::Reduced => 2,
            Structure::Exact if self.free.contains(&Free::Esl) => 4,
            _ => 3,
        }
    }

    /// Number of inputs.
    pub fn nu(&self) -> usize {
        match self.structure {
            Structure::Reduced => 4,
            Structure::Exact => 3,
            _ => 2,
        }
    }

    /// Number of outputs.
    pub fn ny(&self) -> usize {
        self.outputs.len()
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.level_of.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.level_of.is_empty()
    }

    /// State of the DC operating point for the first sample's inputs (a start guess).
    pub fn dc_state(&self, p: &Params) -> Vec<f64> {
        if self.structure == Structure::Exact {
            // The fixed point of the first sample's period map.
            let (n, nu) = (self.nx(), self.nu());
            let Some(level) = self.exact_maps(p).into_iter().nth(self.level_of[0]) else {
                return vec![0.0; n];
            };
            let f = DMatrix::from_row_slice(n, n, &level.f);
            let g = DMatrix::from_row_slice(n, nu, &level.g);
            let rhs = g * nalgebra::DVector::from_row_slice(&self.u[..nu]);
            let m = DMatrix::identity(n, n) - f;
            return m.lu().solve(&rhs).map_or_else(|| vec![0.0; n], |x| x.as_slice().to_vec());
        }
        let (a, b) = self.lti(p, None);
        let u = match self.structure {
            Structure::Pwm => {
                let d = self.levels[self.level_of[0]];
                nalgebra::DVector::from_row_slice(&[d * self.u[0], self.u[1]])
            }
            Structure::Averaged => nalgebra::DVector::from_row_slice(&self.u[..2]),
            Structure::Reduced => nalgebra::DVector::from_row_slice(&[self.u[1], self.u[3]]),
            Structure::Exact => unreachable!("handled above"),
            Structure::Simulated => unreachable!("never built"),
        };
        let rhs = -(b * u);
        a.lu().solve(&rhs).map_or_else(|| vec![0.0; self.nx()], |x| x.as_slice().to_vec())
    }

    fn lti(&self, p: &Params, slot: Option<usize>) -> (DMatrix<f64>, DMatrix<f64>) {
        let (ta, tb) = if self.structure == Structure::Reduced { (REDUCED_A, REDUCED_B) } else { (FULL_A, FULL_B) };
        let n = self.nx();
        (build(ta, n, n, p, slot), build(tb, n, 2, p, slot))
    }

    /// Output selection `ny × n` on the state.
    fn selection(&self) -> DMatrix<f64> {
        let n = self.nx();
        let mut c = DMatrix::zeros(self.ny(), n);
        for (i, s) in self.outputs.iter().enumerate() {
            let col = match (self.structure, s) {
                (Structure::Reduced, _) => 1,
                (_, Signal::Vout) => 2,
                (_, Signal::Il) => 0,
            };
            c[(i, col)] = 1.0;
        }
        c
    }

    /// Maps of the quadratic-hold discretization `d` of the reduced model in the inputs
    /// `[il_k, il_avg_k, il_k+1, io]`: with `Δ1 = il_k+1 − il_k` and `Δa = il_avg_k − il_k`,
    /// `il(t) = il_k + a·t + b·t²` has `a·T = 6Δa − 2Δ1` and `b·T² = 3Δ1 − 6Δa`. `value` selects
    /// the constant output selection (false for a derivative, whose selection is zero).
    fn hold_maps(&self, d: &Discrete, sel: &DMatrix<f64>, t: f64, value: bool) -> Maps {
        let to_inputs = |x: &DMatrix<f64>, b: &DMatrix<f64>| {
            let (e2, e3, e4) = (x.column(2), x.column(3), x.column(4));
            let mut g = DMatrix::zeros(5, 4);
            // il(0) = il_k, il'(0) = a, il'' = 2b.
            g.set_column(0, &(e2 - e3 * (4.0 / t) + e4 * (6.0 / (t * t))));
            g.set_column(1, &(e3 * (6.0 / t) - e4 * (12.0 / (t * t))));
            g.set_column(2, &(e4 * (6.0 / (t * t)) - e3 * (2.0 / t)));
            g.set_column(3, &b.column(0));
            g.rows(0, 2).into_owned()
        };
        let f = d.ad.view((0, 0), (2, 2)).into_owned();
        let g = to_inputs(&d.ad, &d.bd);
        let (h, dd) = match self.sampling {
            Sampling::PeriodStart if value => (sel.clone(), DMatrix::zeros(self.ny(), 4)),
            Sampling::PeriodStart => (DMatrix::zeros(self.ny(), 2), DMatrix::zeros(self.ny(), 4)),
            Sampling::PeriodAverage => (sel * d.ia.view((0, 0), (2, 2)) / t, sel * to_inputs(&d.ia, &d.ib) / t),
        };
        Maps::from(&f, &g, &h, &dd)
    }

    /// Maps of every level at circuit parameters `p`, with derivatives for the free ones when
    /// `with_derivatives`.
    pub fn levels(&self, p: &Params, with_derivatives: bool) -> Vec<Level> {
        if self.structure == Structure::Exact {
            return self.exact_levels(p, with_derivatives);
        }
        let (a, b) = self.lti(p, None);
        let lti = Lti { a, b };
        let derivs: Vec<Lti> = self
            .free
            .iter()
            .filter(|_| with_derivatives)
            .map(|f| match f.slot() {
                Some(slot) => {
                    let (a, b) = self.lti(p, Some(slot));
                    Lti { a, b }
                }
                // Not in the averaged circuit (refused by `Model::new`): no dependence.
                None => Lti { a: DMatrix::zeros(self.nx(), self.nx()), b: DMatrix::zeros(self.nx(), 2) },
            })
            .collect();
        let sel = self.selection();
        let t = self.period;
        // Discretizations of one piece and their derivatives.
        let piece = |tau: f64| -> (Discrete, Vec<Discrete>) {
            let mut base = None;
            let ds = derivs
                .iter()
                .map(|d| {
                    let (b, dd) = lti.discretize_with_derivative(d, tau);
                    base.get_or_insert(b);
                    dd
                })
                .collect();
            (base.unwrap_or_else(|| lti.discretize(tau)), ds)
        };
        let out = |h_state: &DMatrix<f64>, d_state: &DMatrix<f64>| -> (DMatrix<f64>, DMatrix<f64>) {
            match self.sampling {
                Sampling::PeriodStart => (sel.clone(), DMatrix::zeros(self.ny(), 2)),
                Sampling::PeriodAverage => (&sel * h_state, &sel * d_state),
            }
        };
        let zero_out = || (DMatrix::zeros(self.ny(), self.nx()), DMatrix::zeros(self.ny(), 2));
        match self.structure {
            Structure::Averaged => {
                let (p0, dp) = piece(t);
                let (h, d) = out(&(&p0.ia / t), &(&p0.ib / t));
                let maps = Maps::from(&p0.ad, &p0.bd, &h, &d);
                let derivs = dp
                    .iter()
                    .map(|q| {
                        let (dh, dd) = match self.sampling {
                            Sampling::PeriodStart => zero_out(),
                            Sampling::PeriodAverage => out(&(&q.ia / t), &(&q.ib / t)),
                        };
                        Maps::from(&q.ad, &q.bd, &dh, &dd)
                    })
                    .collect();
                vec![Level { maps, derivs }]
            }
            Structure::Reduced => {
                // Quadratic hold: the current, its slope and its (constant) second derivative
                // are held states of a 5-state generator [vc, vo, il, il', il''] with io as input.
                let hold = |l: &Lti, chain: f64| {
                    let mut a = DMatrix::zeros(5, 5);
                    a.view_mut((0, 0), (2, 2)).copy_from(&l.a);
                    a.view_mut((0, 2), (2, 1)).copy_from(&l.b.column(0));
                    a[(2, 3)] = chain;
                    a[(3, 4)] = chain;
                    let mut b = DMatrix::zeros(5, 1);
                    b.view_mut((0, 0), (2, 1)).copy_from(&l.b.column(1));
                    Lti { a, b }
                };
                let aug = hold(&lti, 1.0);
                let mut base = None;
                let derivs = derivs
                    .iter()
                    .map(|dl| {
                        let (b, d) = aug.discretize_with_derivative(&hold(dl, 0.0), t);
                        base.get_or_insert(b);
                        self.hold_maps(&d, &sel, t, false)
                    })
                    .collect();
                let base = base.unwrap_or_else(|| aug.discretize(t));
                vec![Level { maps: self.hold_maps(&base, &sel, t, true), derivs }]
            }
            Structure::Pwm => {
                // Off-time input is [0, io]: the switch node is grounded.
                let s = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, 0.0, 1.0]);
                self.levels
                    .iter()
                    .map(|&duty| {
                        let (p1, d1) = piece(duty * t);
                        let (p2, d2) = piece((1.0 - duty) * t);
                        let f = &p2.ad * &p1.ad;
                        let g = &p2.ad * &p1.bd + &p2.bd * &s;
                        let hs = (&p1.ia + &p2.ia * &p1.ad) / t;
                        let ds = (&p1.ib + &p2.ia * &p1.bd + &p2.ib * &s) / t;
                        let (h, d) = out(&hs, &ds);
                        let maps = Maps::from(&f, &g, &h, &d);
                        let derivs = d1
                            .iter()
                            .zip(&d2)
                            .map(|(q1, q2)| {
                                let df = &q2.ad * &p1.ad + &p2.ad * &q1.ad;
                                let dg = &q2.ad * &p1.bd + &p2.ad * &q1.bd + &q2.bd * &s;
                                let (dh, dd) = match self.sampling {
                                    Sampling::PeriodStart => zero_out(),
                                    Sampling::PeriodAverage => {
                                        let dhs = (&q1.ia + &q2.ia * &p1.ad + &p2.ia * &q1.ad) / t;
                                        let dds = (&q1.ib + &q2.ia * &p1.bd + &p2.ia * &q1.bd + &q2.ib * &s) / t;
                                        out(&dhs, &dds)
                                    }
                                };
                                Maps::from(&df, &dg, &dh, &dd)
                            })
                            .collect();
                        Level { maps, derivs }
                    })
                    .collect()
            }
            Structure::Exact => unreachable!("handled above"),
            Structure::Simulated => unreachable!("never built"),
        }
    }

    /// [`Model::levels`] of the exact model: derivatives by central differences in `ln θ`.
    fn exact_levels(&self, p: &Params, with_derivatives: bool) -> Vec<Level> {
        let base = self.exact_maps(p);
        let mut derivs: Vec<Vec<Maps>> = vec![Vec::new(); base.len()];
        if with_derivatives {
            for f in &self.free {
                let v = f.get(p);
                let (mut hi, mut lo) = (*p, *p);
                f.set(&mut hi, v * FD_STEP.exp());
                f.set(&mut lo, v * (-FD_STEP).exp());
                let (mh, ml) = (self.exact_maps(&hi), self.exact_maps(&lo));
                for (j, d) in derivs.iter_mut().enumerate() {
                    d.push(Maps::difference(&mh[j], &ml[j], 2.0 * FD_STEP));
                }
            }
        }
        base.into_iter().zip(derivs).map(|(maps, derivs)| Level { maps, derivs }).collect()
    }

    /// The exact model's maps of every level at circuit values `p`, extracted from the plant
    /// simulator (see [`Structure::Exact`]). A level whose simulation fails gets NaN maps.
    fn exact_maps(&self, p: &Params) -> Vec<Maps> {
        let mut q = *p;
        q.fs = 1.0 / self.period;
        // One converter for all simulations: its cache of piece transitions is reused.
        let mut conv = Converter::new(q, Mode::Switched);
        self.levels.iter().map(|&duty| self.exact_level(&mut conv, duty).unwrap_or_else(|| Maps::nan(self.nx(), self.ny(), self.nu()))).collect()
    }

    /// One level's maps: the period map linearized at its periodic orbit.
    fn exact_level(&self, conv: &mut Converter, duty: f64) -> Option<Maps> {
        use nalgebra::DVector;
        let (n, ny, t) = (self.nx(), self.ny(), self.period);
        let (vin, io) = self.operating;
        conv.set(VarId::Duty, duty).ok()?;
        let put = |conv: &mut Converter, x: &DVector<f64>, vin: f64, io: f64| -> Option<()> {
            conv.set(VarId::Vin, vin).ok()?;
            conv.set(VarId::Io, io).ok()?;
            conv.set_state(State { il: x[0], vc: x[1], vo: x[2], ic: if n > 3 { x[3] } else { 0.0 } });
            Some(())
        };
        // State after one period from `x` with inputs `vin`, `io`.
        let period = |conv: &mut Converter, x: &DVector<f64>, vin: f64, io: f64| -> Option<DVector<f64>> {
            put(conv, x, vin, io)?;
            conv.step(t).ok()?;
            let s = conv.state();
            let v = DVector::from_row_slice(&[s.il, s.vc, s.vo, s.ic][..n]);
            v.iter().all(|x| x.is_finite()).then_some(v)
        };
        // Measured outputs in state `x` with load current `io`.
        let output = |conv: &mut Converter, x: &DVector<f64>, io: f64| -> Option<DVector<f64>> {
            put(conv, x, vin, io)?;
            let (vout, il) = (conv.outputs().vout, conv.state().il);
            Some(DVector::from_iterator(ny, self.outputs.iter().map(|s| if *s == Signal::Vout { vout } else { il })))
        };
        // State Jacobian at `x` and the map's value there.
        let jacobian = |conv: &mut Converter, x: &DVector<f64>| -> Option<(DMatrix<f64>, DVector<f64>)> {
            let x1 = period(conv, x, vin, io)?;
            let mut f = DMatrix::zeros(n, n);
            for i in 0..n {
                let mut xi = x.clone();
                xi[i] += EXACT_DELTA;
                f.set_column(i, &((period(conv, &xi, vin, io)? - &x1) / EXACT_DELTA));
            }
            Some((f, x1))
        };
        // Newton's method for the periodic orbit, from the averaged DC point.
        let dc = conv.params().steady_state(duty, vin, io);
        let mut x = DVector::from_iterator(n, dc.into_iter().chain([0.0]).take(n));
        let (mut f, mut x1) = jacobian(conv, &x)?;
        for _ in 0..NEWTON_ITERATIONS {
            let step = (DMatrix::identity(n, n) - &f).lu().solve(&(&x1 - &x))?;
            x += &step;
            (f, x1) = jacobian(conv, &x)?;
            if step.amax() <= 1e-9 * (1.0 + x.amax()) {
                break;
            }
        }
        // Input columns and the affine offset.
        let mut g = DMatrix::zeros(n, 3);
        g.set_column(0, &((period(conv, &x, vin + EXACT_DELTA, io)? - &x1) / EXACT_DELTA));
        g.set_column(1, &((period(conv, &x, vin, io + EXACT_DELTA)? - &x1) / EXACT_DELTA));
        let offset = &x1 - &f * &x - g.column(0) * vin - g.column(1) * io;
        g.set_column(2, &offset);
        // Output map: vout is affine in the state and io, il is a state.
        let y0 = output(conv, &x, io)?;
        let mut h = DMatrix::zeros(ny, n);
        for i in 0..n {
            let mut xi = x.clone();
            xi[i] += EXACT_DELTA;
            h.set_column(i, &((output(conv, &xi, io)? - &y0) / EXACT_DELTA));
        }
        let mut d = DMatrix::zeros(ny, 3);
        d.set_column(1, &((output(conv, &x, io + EXACT_DELTA)? - &y0) / EXACT_DELTA));
        let offset = &y0 - &h * &x - d.column(1) * io;
        d.set_column(2, &offset);
        Some(Maps::from(&f, &g, &h, &d))
    }
}

/// Frequency response duty → vout of the averaged continuous model at `vin` volts:
/// `G(j2πf) = c·(j2πf·I − A)⁻¹·b·vin` for each frequency \[Hz\].
pub fn frequency_response(p: &Params, vin: f64, freqs: &[f64]) -> Vec<nalgebra::Complex<f64>> {
    use nalgebra::Complex;
    let a = build(FULL_A, 3, 3, p, None).map(|x| Complex::new(x, 0.0));
    let b = build(FULL_B, 3, 2, p, None).column(0).map(|x| Complex::new(x * vin, 0.0));
    freqs
        .iter()
        .map(|f| {
            let s = Complex::new(0.0, 2.0 * std::f64::consts::PI * f);
            let m = DMatrix::<Complex<f64>>::identity(3, 3) * s - &a;
            m.lu().solve(&b).map_or(Complex::new(f64::NAN, 0.0), |x| x[2])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fraction's unknown is its logit below the ceiling (0.9 for `cap_dc_bias`): it round
    /// trips, is `ln v` less `ln 0.9` far below the ceiling, never reaches the ceiling however
    /// far a step goes, and its relative slope is `d ln v/du` (central difference); the other
    /// parameters stay on the log scale.
    #[test]
    fn a_fraction_is_fitted_as_a_logit_below_its_ceiling() {
        let f = Free::CapDcBias;
        assert_eq!(f.ceiling(), Some(0.9));
        for v in [1e-6, 0.1, 0.45, 0.8, 0.8999] {
            let u = f.to_unknown(v);
            assert!((f.from_unknown(u) / v - 1.0).abs() < 1e-12, "{v}");
            let h = 1e-6;
            let slope = (f.from_unknown(u + h).ln() - f.from_unknown(u - h).ln()) / (2.0 * h);
            assert!((f.relative_slope(u) - slope).abs() < 1e-6, "{v}: {slope}");
        }
        assert!((f.to_unknown(1e-6) - (1e-6f64.ln() - 0.9f64.ln())).abs() < 1e-5);
        assert!((1..=30).all(|u| f.from_unknown(f64::from(u)) < 0.9));
        assert_eq!(Free::Cl.ceiling(), None);
        assert_eq!(Free::Cl.to_unknown(2e-6), 2e-6f64.ln());
        assert_eq!(Free::Cl.relative_slope(-13.0), 1.0);
    }

    /// A reading's calibration, and its channels' skew, may have either sign: its unknown is the
    /// value in units of its scale (round trips through zero and below it), its relative slope
    /// `|d ln |v|/du|`; a circuit value stays on the log scale.
    #[test]
    fn a_reading_calibration_is_fitted_on_a_signed_linear_scale() {
        for f in [Free::VoutOffset, Free::VoutGainError, Free::VoutSkew] {
            assert!(f.calibrates_reading() == (f != Free::VoutSkew) && f.ceiling().is_none());
            let scale = f.signed_scale().unwrap();
            for v in [-5.0, -0.01, 0.0, 0.2, 30.0].map(|k| k * scale) {
                assert!((f.from_unknown(f.to_unknown(v)) - v).abs() < 1e-15 * scale, "{f:?} {v}");
            }
            let u = f.to_unknown(-2.0 * scale);
            let h = 1e-6;
            let slope = (f.from_unknown(u + h).abs().ln() - f.from_unknown(u - h).abs().ln()) / (2.0 * h);
            assert!((f.relative_slope(u) - slope.abs()).abs() < 1e-6 * slope.abs(), "{f:?}: {slope}");
        }
        assert!(!Free::Cl.calibrates_reading() && !Free::SampleDelay.calibrates_reading());
    }

    /// At low frequency the averaged gain duty → vout is vin (the DC gain of the buck).
    #[test]
    fn frequency_response_has_the_buck_dc_gain() {
        let g = frequency_response(&Params::default(), 12.0, &[1.0, 1e6]);
        assert!((g[0].norm() - 12.0).abs() < 0.01, "{}", g[0]);
        assert!(g[1].norm() < 0.2, "an LC filter attenuates at 1 MHz: {}", g[1]);
    }

    /// The exact model's maps, extracted from the plant simulator, equal the analytic PWM maps
    /// of the ideal circuit (an independent reference), with a zero offset column.
    #[test]
    fn exact_maps_of_the_ideal_circuit_are_the_pwm_maps() {
        // With a load resistor too: the PWM model's analytic ∂/∂ln Cl and ∂/∂ln L then carry the
        // −vo/(rload·Cl) term, the exact model's finite differences the simulator's.
        for rload in [0.0, 5.0] {
            exact_maps_are_the_pwm_maps(Params { cl: 4.7e-6, rload, ..Params::default() });
        }
    }

    fn exact_maps_are_the_pwm_maps(truth: Params) {
        use crate::experiment::{Experiment, ModelPlant, run};
        let data = run(&mut ModelPlant::new(truth, Mode::Switched), &Experiment { samples: 200, ..Experiment::default() }).unwrap();
        let outs = [Signal::Vout, Signal::Il];
        let pwm = Model::new(Structure::Pwm, Sampling::PeriodStart, &outs, &[Free::Cl, Free::L], &data, truth.period()).unwrap();
        let exact = Model::new(Structure::Exact, Sampling::PeriodStart, &outs, &[Free::Cl, Free::L], &data, truth.period()).unwrap();
        let (a, b) = (pwm.levels(&truth, true), exact.levels(&truth, true));
        assert_eq!(a.len(), 2);
        assert_eq!(b.len(), 2);
        let close = |x: &[f64], y: &[f64], tol: f64, what: &str| {
            let scale = x.iter().fold(0.0_f64, |m, v| m.max(v.abs())).max(1e-300);
            for (p, q) in x.iter().zip(y) {
                assert!((p - q).abs() <= tol * scale, "{what}: pwm {x:?} vs exact {y:?}");
            }
        };
        // Exact inputs are [vin, io, 1]: compare the first two columns, the third is zero.
        let cols = |m: &[f64], rows: usize, keep: usize| -> Vec<f64> { (0..rows).flat_map(|r| m[r * 3..r * 3 + keep].to_vec()).collect() };
        let third = |m: &[f64], rows: usize| -> Vec<f64> { (0..rows).map(|r| m[r * 3 + 2]).collect() };
        for (pa, pb) in a.iter().zip(&b) {
            close(&pa.maps.f, &pb.maps.f, 1e-9, "F");
            close(&pa.maps.g, &cols(&pb.maps.g, 3, 2), 1e-9, "G");
            close(&pa.maps.h, &pb.maps.h, 1e-9, "H");
            close(&pa.maps.d, &cols(&pb.maps.d, 2, 2), 1e-9, "D");
            assert!(third(&pb.maps.g, 3).iter().all(|v| v.abs() < 1e-9), "offset {:?}", pb.maps.g);
            assert!(third(&pb.maps.d, 2).iter().all(|v| v.abs() < 1e-9), "offset {:?}", pb.maps.d);
            // The finite-difference derivatives agree with the analytic ones.
            for (da, db) in pa.derivs.iter().zip(&pb.derivs) {
                close(&da.f, &db.f, 1e-6, "dF");
                close(&da.g, &cols(&db.g, 3, 2), 1e-6, "dG");
            }
        }
    }

    /// The effect parameters are refused by the analytic structures.
    #[test]
    fn effect_parameters_need_the_exact_structure() {
        use crate::experiment::{Experiment, ModelPlant, run};
        let data = run(&mut ModelPlant::new(Params::default(), Mode::Switched), &Experiment { samples: 100, ..Experiment::default() }).unwrap();
        let err = Model::new(Structure::Pwm, Sampling::PeriodStart, &[Signal::Vout], &[Free::Cl, Free::LoadEsr], &data, 1.0 / 330e3);
        assert!(matches!(err, Err(EstimatorError::Config(_))));
        assert!(Model::new(Structure::Exact, Sampling::PeriodStart, &[Signal::Vout], &[Free::Cl, Free::LoadEsr], &data, 1.0 / 330e3).is_ok());
    }
}
