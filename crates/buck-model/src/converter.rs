//! The converter as a simulator: inputs, state, exact stepping over any step length.
use nalgebra::{Vector2, Vector4};
use serde::{Deserialize, Serialize};

use crate::digital::{Control, Digital, FILTER_PIECES};
use crate::flow::{Ladder, Point, Transition, Watch, pad};
use crate::lti::Lti;
use crate::variables::{self, Type, VarId};
use crate::{Mode, ModelError, Params};

/// Inputs, held constant over a communication step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Inputs {
    /// Duty cycle command, 0..1.
    pub duty: f64,
    /// Load current \[A\].
    pub io: f64,
    /// Input voltage \[V\].
    pub vin: f64,
    /// Output voltage reference of the controller \[V\] (closed loop).
    pub vref: f64,
    /// Added to the controller's duty (closed loop).
    pub dither: f64,
}

impl Default for Inputs {
    fn default() -> Self {
        Self { duty: 0.5, io: 1.0, vin: 12.0, vref: 5.0, dither: 0.0 }
    }
}

/// Circuit state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct State {
    /// Inductor current \[A\].
    pub il: f64,
    /// Voltage of C behind its ESR \[V\].
    pub vc: f64,
    /// Voltage across Cl \[V\] (the output voltage unless `load_esr > 0`).
    pub vo: f64,
    /// Current into the C branch \[A\]; a state only when `esl > 0`, else ignored.
    pub ic: f64,
}

/// Everything the converter reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outputs {
    /// Instantaneous output (node) voltage \[V\].
    pub vout: f64,
    /// Instantaneous inductor current \[A\].
    pub il: f64,
    /// Instantaneous voltage of C behind its ESR \[V\].
    pub vc: f64,
    /// Exact average of `vout` over the last completed switching period \[V\].
    pub vout_avg: f64,
    /// Exact average of `il` over the last completed switching period \[A\].
    pub il_avg: f64,
    /// Duty that drove the switch in the last latched period.
    pub duty_applied: f64,
    /// The ADC's latest reading of `vout` (at the period start, or `adc_delay + adc_vout_skew`
    /// into the period) \[V\].
    pub vout_adc: f64,
    /// The ADC's latest reading of `il` (at the period start, or `adc_delay` into the period) \[A\].
    pub il_adc: f64,
}

/// Relative tolerance (of the period) within which a step end snaps onto a switching event, so
/// that a host stepping by `T` in floating point does not create femtosecond slivers or latch
/// the next period's duty a rounding error too early. A step that ends away from any event
/// is simulated exactly, however short.
const SNAP: f64 = 1e-9;
/// Pieces with cached transition matrices (PRBS between two duty levels needs four, dead time
/// and diode conduction a few more). Pieces beyond them go on the circuit's ladder.
const CACHE_SLOTS: usize = 16;
/// Circuits with cached [`Ladder`]s (diode conduction and the blocked inductor, or two
/// saturation regions, each of one or two series resistances; under `cap_dc_bias` they are
/// rebuilt every period).
const LADDER_SLOTS: usize = 8;
/// Relative tolerance (of the period) of the instants of state events (`il = 0`, `|il| = isat`).
const ROOT_TOL: f64 = 1e-15;
/// Window of a diode buck's off-time, as a fraction of the period, that holds the switch
/// node's slew (see [`Converter::slew_at_edge`]): 95 ns at 330 kHz, a full swing of 12 V for
/// 1 nF at 0.13 A. A slower slew is taken as complete at its end.
const SLEW_WINDOW: f64 = 1.0 / 32.0;
/// State events handled within one piece before the rest of it is taken as it is (a guard
/// against chattering; no physical configuration comes near it).
const MAX_EVENTS: usize = 64;
/// Where the switch node's voltage is kept while it rings (in place of `esl`'s branch current).
const NODE: usize = 3;
/// Longest piece of a ringing node, as a fraction of its ring's period `2π·√(L·Csw)`: within
/// it the node has at most one extremum (see [`first_crossing`]).
const RING_PIECE: f64 = 1.0 / 8.0;
/// Pieces of a ring watched for a clamp: its first half-cycle, where the node swings to the
/// far extreme from the clamp it started at. After that the swings only shrink (`RL` damps the
/// ring; the output barely moves over one), so the node stays between the clamps and the rest
/// goes in one piece; a ring whose first swing stays clear of both clamps is not watched at
/// all ([`Converter::ring_may_clamp`]).
const RING_WATCH: u8 = 4;
/// Pieces per period of a diode's conduction under its exponential law (`diode_emission`):
/// over each the diode's drop is held at its mean along the piece's current.
const DIODE_PIECES: f64 = 16.0;

/// Which gate of the half bridge is on over an interval fixed by the PWM timing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Gate {
    /// High side on: `[0, d·T)`.
    High,
    /// Low side on (synchronous buck, outside dead time).
    Low,
    /// Both off: dead time, or the off-time of the asynchronous buck; diodes decide.
    Off,
    /// Both off, the window of an `Off` interval in which the switch node slews between the
    /// rails, charged by il (`switch_node_capacitance`): diodes decide as in `Off`, the node held
    /// at its mean over the window.
    Slew,
    /// Averaged mode: the switch node carries `d·vin`.
    Averaged,
}

/// What conducts over a piece: the linear circuit and the switch-node voltage follow from it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Topology {
    /// High-side switch (either current direction): `u_sw = vin`, `RL + Rsw`.
    High,
    /// Low-side switch (either direction): `u_sw = 0`, `RL + Rsw·low_side_ratio`.
    Low,
    /// Averaged switch node `d·vin`, `RL` plus the switches' resistance averaged over the period.
    Averaged,
    /// Low-side diode with `il > 0`: `u_sw = −Vf`, `RL + Rd`.
    LowDiode,
    /// High-side body diode with `il < 0`: `u_sw = vin + V_bd`, `RL + Rd`.
    HighDiode,
    /// Everything off: `il` held at 0 and the switch node floating at the output, or, where it
    /// rings ([`Params::rings`]), the node (`x[3]`) ringing with `L` until it reaches a diode's
    /// clamp.
    Blocked,
}

/// Identity of a linear circuit: series resistance, incremental inductance, load capacitance
/// (as bits) and the blocked inductor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Circuit {
    r: u64,
    l: u64,
    cl: u64,
    blocked: bool,
}

/// A cached transition of a circuit over a whole gate interval, inputs `u = [u_sw, io]`.
#[derive(Debug, Clone)]
struct Piece {
    step: Transition,
    circuit: Circuit,
}

/// A buck converter that advances exactly over steps of any length.
///
/// The engine is piecewise linear: between events the circuit is one `Topology` (what
/// conducts) with its `A`, `B` from [`Params::piece_lti`], held inputs `[u_sw, io]`, and an
/// exact transition of the state and its integral, cached per (circuit, piece length). Fixed-time
/// events come from the PWM timing (high-side turn-off at `d·T`, the dead-time edges, the period
/// end); state events (`il = 0` of a conducting diode, `|il| = isat`) are located inside a piece
/// on the exact solution to `1e-15·T` (bisection over the circuit's `Ladder` of exact
/// transitions, then safeguarded Newton iteration on its local Taylor polynomial), the piece is
/// split there and the topology re-chosen. One loop handles both, for any communication step.
///
/// ```
/// use buck_model::{Converter, Mode, Params};
/// let mut conv = Converter::new(Params::default(), Mode::Switched);
/// conv.initialize();
/// for _ in 0..3000 {
///     conv.step(conv.params().period()).unwrap();
/// }
/// let y = conv.outputs();
/// // Averaged CCM steady state: vout = d·U − RL·io = 0.5·12 − 0.1·1.
/// assert!((y.vout_avg - 5.9).abs() < 0.01);
/// ```
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Converter {
    params: Params,
    mode: Mode,
    start_at_steady_state: bool,
    inputs: Inputs,
    /// `[il, vc, vcl, ic]`; without `esl`, `x[3]` is the switch node's voltage where it rings
    /// ([`Params::rings`]: the rail a switch holds it at, a diode's clamp, the ring), else 0.
    x: Vector4<f64>,
    /// Integral of `x` since the start of the current period.
    z: Vector4<f64>,
    /// Integral of the load current since the start of the current period [A·s].
    io_integral: f64,
    /// Load current held over the latest piece \[A\]: `vout` depends on it through `load_esr`,
    /// and an input set after a step must not change the outputs of that step.
    io_held: f64,
    /// Time since the start of the current period \[s\].
    phase: f64,
    /// Duty in force during the current period (latched at its start).
    latched_duty: f64,
    /// The PWM signal was high at the end of the previous period (duty 1): no rising edge, so
    /// no dead time, at this period's start; a duty-0 period then starts with a falling edge.
    pwm_high_before: bool,
    /// Load capacitance in force during the current period (`cap_dc_bias`) \[F\].
    cl_now: f64,
    /// Voltage across Cl at the previous period start, for the mid-period extrapolation of
    /// `cl_now` (`None` right after a state was set).
    vcl_last_start: Option<f64>,
    /// The inductor current stopped at zero with both switches off (DCM) until the next turn-on
    /// (or, ringing with the switch node, until the node reaches a diode's clamp).
    blocked: bool,
    /// Pieces of the current ring still watched for a clamp ([`RING_WATCH`]; 0 when none).
    ring_watch: u8,
    /// The rail a switch last held the switch node at (`vin` or 0), until an `Off` interval
    /// starts from it.
    node_rail: Option<f64>,
    /// The window of the current `Off` interval that holds the node's slew: the phase it ends
    /// at and the node's mean voltage over it (`switch_node_capacitance`).
    slew: Option<(f64, f64)>,
    /// The next piece starts a fixed-time interval (a switching edge or the period start).
    at_edge: bool,
    /// `vout = cx·x + d·io` ([`Params::vout_map`], kept at hand: outputs are read every step).
    vout_map: ([f64; 4], f64),
    /// Saturation region when `|il| = isat` exactly (after an event): −1, 0 or +1.
    sat_region: i8,
    /// The next piece starts a new period and must latch the duty first.
    at_period_start: bool,
    /// The ADC reads `[vout, il]` later in this period (`adc_delay`, `adc_vout_skew`, switched
    /// mode), not yet done.
    adc_pending: [bool; 2],
    /// Averages `[il, vc, vcl, ic]` over the last completed period.
    last_average: Vector4<f64>,
    /// Average load current over the last completed period \[A\].
    last_io_average: f64,
    /// ADC, controller, delay line, DPWM.
    digital: Digital,
    /// Index of the current period.
    period_index: u64,
    time: f64,
    #[serde(skip)]
    cache: Vec<Piece>,
    #[serde(skip)]
    ladders: Vec<(Circuit, Ladder)>,
    #[serde(skip)]
    next_ladder: usize,
}

impl Converter {
    /// A converter with default inputs; call [`Converter::initialize`] before stepping.
    pub fn new(params: Params, mode: Mode) -> Self {
        let mut conv = Self {
            params,
            mode,
            start_at_steady_state: true,
            inputs: Inputs::default(),
            x: Vector4::zeros(),
            z: Vector4::zeros(),
            io_integral: 0.0,
            io_held: 0.0,
            phase: 0.0,
            latched_duty: 0.0,
            pwm_high_before: false,
            cl_now: params.cl,
            vcl_last_start: None,
            vout_map: params.vout_map(),
            blocked: false,
            ring_watch: 0,
            node_rail: None,
            slew: None,
            at_edge: true,
            sat_region: 0,
            at_period_start: true,
            adc_pending: [false; 2],
            last_average: Vector4::zeros(),
            last_io_average: 0.0,
            digital: Digital::default(),
            period_index: 0,
            time: 0.0,
            cache: Vec::with_capacity(CACHE_SLOTS),
            ladders: Vec::with_capacity(LADDER_SLOTS),
            next_ladder: 0,
        };
        conv.initialize();
        conv
    }

    /// A converter with every input and parameter at its start value in the variable table.
    pub fn from_start_values() -> Self {
        let mut conv = Self::new(Params::default(), Mode::Averaged);
        for var in variables::VARIABLES {
            let start = match var.ty {
                Type::Real { start, .. } => start,
                Type::Integer { start, .. } => Some(f64::from(start)),
                Type::Boolean { start } => Some(f64::from(u8::from(start))),
            };
            if let Some(value) = start {
                // Start values lie inside their ranges (pinned by a test), so this cannot fail.
                let _ = conv.set(var.id, value);
            }
        }
        conv.initialize();
        conv
    }

    /// Circuit parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Switch-node model.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Current inputs.
    pub fn inputs(&self) -> &Inputs {
        &self.inputs
    }

    /// Simulated time \[s\].
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Sets the simulated time (e.g. the experiment start) without changing the state.
    pub fn set_time(&mut self, time: f64) {
        self.time = time;
    }

    /// Sets the inputs after checking each against its range.
    pub fn set_inputs(&mut self, inputs: Inputs) -> Result<(), ModelError> {
        self.set(VarId::Duty, inputs.duty)?;
        self.set(VarId::Io, inputs.io)?;
        self.set(VarId::Vin, inputs.vin)?;
        self.set(VarId::Vref, inputs.vref)?;
        self.set(VarId::Dither, inputs.dither)
    }

    /// The digital side (ADC, controller, delay, DPWM).
    pub fn digital(&self) -> &Digital {
        &self.digital
    }

    /// Circuit state.
    pub fn state(&self) -> State {
        State { il: self.x[0], vc: self.x[1], vo: self.x[2], ic: if self.params.esl > 0.0 { self.x[3] } else { 0.0 } }
    }

    /// Puts the circuit at the start of a period in the given state, e.g. from an initial
    /// condition computed elsewhere (the ADC's filter settled at its `vout`).
    pub fn set_state(&mut self, s: State) {
        let ic = if self.params.esl > 0.0 { s.ic } else { 0.0 };
        self.x = Vector4::new(s.il, s.vc, s.vo, ic);
        self.z = Vector4::zeros();
        self.io_integral = 0.0;
        self.io_held = self.inputs.io;
        self.phase = 0.0;
        self.at_period_start = true;
        self.blocked = false;
        self.ring_watch = 0;
        self.node_rail = None;
        self.slew = None;
        self.at_edge = true;
        self.sat_region = 0;
        self.cl_now = self.params.cl_at(s.vo);
        self.vcl_last_start = None;
        self.digital.settle_filters(self.vout(), self.x[0]);
        self.last_average = self.x;
        self.last_io_average = self.io_held;
    }

    /// Starts a new run at a period start: from the averaged DC operating point of the current
    /// inputs when `start_at_steady_state` is set (the default), from zero otherwise. In closed
    /// loop the operating point is the one where `vout = vref`, and the controller starts there.
    pub fn initialize(&mut self) {
        let Inputs { duty, io, vin, vref, .. } = self.inputs;
        let d0 = match self.digital.control {
            Control::Open => duty,
            // The command whose stretched pulse holds vref.
            Control::Closed if vin > 0.0 => (self.params.duty_for(vref, vin, io) - self.params.pulse_width_distortion * self.params.fs).clamp(0.0, 1.0),
            Control::Closed => 0.0,
        };
        // The share of the period the high side conducts under that command.
        let on = self.params.effective_duty(d0);
        let x0 = if self.start_at_steady_state { self.params.steady_state(on, vin, io) } else { [0.0; 3] };
        self.set_state(State { il: x0[0], vc: x0[1], vo: x0[2], ic: 0.0 });
        self.pwm_high_before = on >= 1.0;
        self.period_index = 0;
        self.digital.restart(d0, self.vout(), x0[0]);
    }

    /// `cx·x + d·io` (the converter's `vout_map`): `vout` of a state, or its integral or mean of a
    /// state's.
    fn through_vout_map(&self, x: &Vector4<f64>, io: f64) -> f64 {
        let (cx, d) = self.vout_map;
        cx[0] * x[0] + cx[1] * x[1] + cx[2] * x[2] + cx[3] * x[3] + d * io
    }

    /// Output (node) voltage of the current state with the load current of the latest piece.
    fn vout(&self) -> f64 {
        self.through_vout_map(&self.x, self.io_held)
    }

    /// `vout` as the ADC's `vout` channel sees it now: through its anti-alias filter
    /// (`adc_filter`), where there is one (unquantized and without noise).
    pub fn vout_read(&self) -> f64 {
        self.digital.vout_channel(self.vout())
    }

    /// `il` as the ADC's `il` channel sees it now: through its filter (`adc_il_filter`), where
    /// there is one (unquantized).
    pub fn il_read(&self) -> f64 {
        self.digital.il_channel(self.x[0])
    }

    /// `∫ vout dt` since the current period started [V·s] (exact, as `vout_avg` is over a whole
    /// period).
    pub fn vout_integral(&self) -> f64 {
        self.through_vout_map(&self.z, self.io_integral)
    }

    /// Current outputs.
    pub fn outputs(&self) -> Outputs {
        let avg = &self.last_average;
        Outputs {
            vout: self.vout(),
            il: self.x[0],
            vc: self.x[1],
            vout_avg: self.through_vout_map(avg, self.last_io_average),
            il_avg: avg[0],
            duty_applied: self.digital.applied(),
            vout_adc: self.digital.reading().0,
            il_adc: self.digital.reading().1,
        }
    }

    /// Reads a variable of the table (integers and Booleans as exact `f64`).
    pub fn get_real(&self, id: VarId) -> f64 {
        let y = self.outputs();
        let p = &self.params;
        let d = &self.digital;
        match id {
            VarId::Duty => self.inputs.duty,
            VarId::Io => self.inputs.io,
            VarId::Vin => self.inputs.vin,
            VarId::Vref => self.inputs.vref,
            VarId::Dither => self.inputs.dither,
            VarId::Vout => y.vout,
            VarId::Il => y.il,
            VarId::Vc => y.vc,
            VarId::VoutAvg => y.vout_avg,
            VarId::IlAvg => y.il_avg,
            VarId::DutyApplied => y.duty_applied,
            VarId::VoutAdc => y.vout_adc,
            VarId::IlAdc => y.il_adc,
            VarId::L => p.l,
            VarId::Rl => p.rl,
            VarId::C => p.c,
            VarId::Rc => p.rc,
            VarId::Cl => p.cl,
            VarId::Fs => p.fs,
            VarId::Mode => f64::from(match self.mode {
                Mode::Averaged => 1,
                Mode::Switched => 2,
            }),
            VarId::SteadyStart => f64::from(u8::from(self.start_at_steady_state)),
            VarId::Control => f64::from(match d.control {
                Control::Open => 1,
                Control::Closed => 2,
            }),
            VarId::Kp => d.kp,
            VarId::Ki => d.ki,
            VarId::Kd => d.kd,
            VarId::Delay => f64::from(d.delay),
            VarId::AdcBits => f64::from(d.adc_bits),
            VarId::AdcVfs => d.adc_vfs,
            VarId::AdcIfs => d.adc_ifs,
            VarId::AdcNoise => d.adc_noise,
            VarId::AdcIlNoise => d.adc_il_noise,
            VarId::AdcDelay => d.adc_delay,
            VarId::AdcVoutSkew => d.adc_vout_skew,
            VarId::AdcFilter => d.adc_filter,
            VarId::AdcIlFilter => d.adc_il_filter,
            VarId::NoiseSeed => d.noise_seed as f64,
            VarId::DpwmBits => f64::from(d.dpwm_bits),
            VarId::SwitchResistance => p.switch_resistance,
            VarId::DiodeDrop => p.diode_drop,
            VarId::Dcm => f64::from(u8::from(p.dcm)),
            VarId::SwitchNodeRing => f64::from(u8::from(p.switch_node_ring)),
            VarId::DeadTime => p.dead_time,
            VarId::LoadEsr => p.load_esr,
            VarId::Esl => p.esl,
            VarId::InductorSaturation => p.inductor_saturation,
            VarId::Isat => p.isat,
            VarId::CapDcBias => p.cap_dc_bias,
            VarId::CapRatedVoltage => p.cap_rated_voltage,
            VarId::Rload => p.rload,
            VarId::DiodeResistance => p.diode_resistance,
            VarId::DiodeEmission => p.diode_emission,
            VarId::PulseWidthDistortion => p.pulse_width_distortion,
            VarId::SwitchNodeCapacitance => p.switch_node_capacitance,
            VarId::SwitchNodeDamping => p.switch_node_damping,
            VarId::LowSideRatio => p.low_side_ratio,
        }
    }

    /// Writes an input or parameter after checking it against its declared range.
    ///
    /// Changing a parameter takes effect at once; call [`Converter::initialize`] to restart
    /// from the new operating point.
    pub fn set(&mut self, id: VarId, value: f64) -> Result<(), ModelError> {
        let var = &variables::VARIABLES[variables::vr(id) as usize];
        match var.ty {
            Type::Real { .. } => {
                let value = var.check_real(value)?;
                let p = &mut self.params;
                let d = &mut self.digital;
                match id {
                    VarId::Duty => self.inputs.duty = value,
                    VarId::Io => self.inputs.io = value,
                    VarId::Vin => self.inputs.vin = value,
                    VarId::Vref => self.inputs.vref = value,
                    VarId::Dither => self.inputs.dither = value,
                    VarId::L => p.l = value,
                    VarId::Rl => p.rl = value,
                    VarId::C => p.c = value,
                    VarId::Rc => p.rc = value,
                    VarId::Cl => p.cl = value,
                    VarId::Fs => p.fs = value,
                    VarId::SwitchResistance => p.switch_resistance = value,
                    VarId::DiodeDrop => p.diode_drop = value,
                    VarId::DiodeResistance => p.diode_resistance = value,
                    VarId::DiodeEmission => p.diode_emission = value,
                    VarId::PulseWidthDistortion => p.pulse_width_distortion = value,
                    VarId::SwitchNodeCapacitance => p.switch_node_capacitance = value,
                    VarId::SwitchNodeDamping => p.switch_node_damping = value,
                    VarId::LowSideRatio => p.low_side_ratio = value,
                    VarId::DeadTime => p.dead_time = value,
                    VarId::LoadEsr => p.load_esr = value,
                    VarId::Esl => p.esl = value,
                    VarId::InductorSaturation => p.inductor_saturation = value,
                    VarId::Isat => p.isat = value,
                    VarId::CapDcBias => p.cap_dc_bias = value,
                    VarId::CapRatedVoltage => p.cap_rated_voltage = value,
                    VarId::Rload => p.rload = value,
                    VarId::Kp => d.kp = value,
                    VarId::Ki => d.ki = value,
                    VarId::Kd => d.kd = value,
                    VarId::AdcVfs => d.adc_vfs = value,
                    VarId::AdcIfs => d.adc_ifs = value,
                    VarId::AdcNoise => d.adc_noise = value,
                    VarId::AdcIlNoise => d.adc_il_noise = value,
                    VarId::AdcDelay => d.adc_delay = value,
                    VarId::AdcVoutSkew => d.adc_vout_skew = value,
                    VarId::AdcFilter => d.adc_filter = value,
                    VarId::AdcIlFilter => d.adc_il_filter = value,
                    _ => return Err(ModelError::NotSettable { name: var.name, when: "at all: it is an output" }),
                }
                if var.causality == variables::Causality::Parameter {
                    self.parameters_changed();
                }
            }
            Type::Integer { .. } => {
                let v = var.check_integer(value)?;
                let d = &mut self.digital;
                match id {
                    VarId::Mode => self.mode = if v == 1 { Mode::Averaged } else { Mode::Switched },
                    VarId::Control => d.control = if v == 1 { Control::Open } else { Control::Closed },
                    VarId::Delay => d.delay = v.unsigned_abs(),
                    VarId::AdcBits => d.adc_bits = v.unsigned_abs(),
                    VarId::NoiseSeed => d.noise_seed = u64::from(v.unsigned_abs()),
                    VarId::DpwmBits => d.dpwm_bits = v.unsigned_abs(),
                    _ => return Err(ModelError::NotSettable { name: var.name, when: "as an integer" }),
                }
            }
            Type::Boolean { .. } => match id {
                VarId::SteadyStart => self.start_at_steady_state = value != 0.0,
                VarId::Dcm => {
                    self.params.dcm = value != 0.0;
                    self.parameters_changed();
                }
                VarId::SwitchNodeRing => {
                    self.params.switch_node_ring = value != 0.0;
                    self.parameters_changed();
                }
                _ => return Err(ModelError::NotSettable { name: var.name, when: "as a Boolean" }),
            },
        }
        Ok(())
    }

    /// Drops transitions computed from old parameters and re-derives what depends on them.
    fn parameters_changed(&mut self) {
        self.cache.clear();
        self.ladders.clear();
        self.next_ladder = 0;
        self.cl_now = self.params.cl_at(self.x[2]);
        self.vout_map = self.params.vout_map();
        if self.params.esl == 0.0 {
            self.x[3] = 0.0;
        }
    }

    /// Advances by `h` seconds, crossing every switching event exactly.
    pub fn step(&mut self, h: f64) -> Result<(), ModelError> {
        if !(h > 0.0 && h.is_finite()) {
            return Err(ModelError::BadStep(h));
        }
        let period = self.params.period();
        if self.digital.adc_delay >= period {
            return Err(ModelError::OutOfRange { name: "adc_delay", value: self.digital.adc_delay, range: format!("below the switching period 1/fs = {period:e} s") });
        }
        let vout_at = self.digital.adc_delay + self.digital.adc_vout_skew;
        if !(0.0..period).contains(&vout_at) {
            let range = format!("such that vout is read within the period: adc_delay + adc_vout_skew in [0, 1/fs = {period:e} s), with adc_delay = {:e} s", self.digital.adc_delay);
            return Err(ModelError::OutOfRange { name: "adc_vout_skew", value: self.digital.adc_vout_skew, range });
        }
        let instants = self.adc_instants();
        let snap = SNAP * period;
        let mut remaining = h;
        loop {
            if self.at_period_start {
                let Inputs { duty, dither, vref, .. } = self.inputs;
                self.latched_duty = self.digital.latch(duty, dither, vref);
                // cap_dc_bias: Cl held over the period at its mid-period value.
                self.cl_now = self.params.cl_for_period(self.x[2], self.vcl_last_start);
                self.vcl_last_start = Some(self.x[2]);
                self.at_period_start = false;
                self.adc_pending = instants.map(|t| t > 0.0);
            }
            if self.at_edge {
                self.slew = self.slew_at_edge(period);
                self.at_edge = false;
            }
            let (gate, edge) = self.gate(period);
            // The ADC's next reading within the period, where it comes before the next edge.
            let next_read = (0..2).filter(|&c| self.adc_pending[c]).map(|c| instants[c]).fold(f64::INFINITY, f64::min);
            let reading = next_read < edge;
            let event = if reading { next_read } else { edge };
            let to_event = event - self.phase;
            if remaining + snap < to_event {
                // The step ends before the next event: advance exactly, however short.
                self.advance_read(remaining, gate, period);
                self.phase += remaining;
                break;
            }
            self.advance_read(to_event, gate, period);
            remaining -= to_event;
            self.phase = event;
            if reading {
                // (Both channels at once where they read at one instant.)
                if self.adc_pending[0] && instants[0] == event {
                    self.adc_pending[0] = false;
                    self.digital.sample_vout(self.vout(), self.period_index);
                }
                if self.adc_pending[1] && instants[1] == event {
                    self.adc_pending[1] = false;
                    self.digital.sample_il(self.x[0], self.period_index);
                }
            } else {
                self.at_edge = true;
            }
            if !reading && event >= period {
                self.last_average = self.z / period;
                self.last_io_average = self.io_integral / period;
                self.z = Vector4::zeros();
                self.io_integral = 0.0;
                self.phase = 0.0;
                self.at_period_start = true;
                self.pwm_high_before = self.params.effective_duty(self.latched_duty) >= 1.0;
                self.period_index += 1;
                if instants[0] == 0.0 {
                    self.digital.sample_vout(self.vout(), self.period_index);
                }
                if instants[1] == 0.0 {
                    self.digital.sample_il(self.x[0], self.period_index);
                }
            }
            // What is left after an event within the snap tolerance is the master's rounding
            // (e.g. a sum of steps of T), not time to simulate: the next period must latch the
            // duty the master sets after this step.
            if remaining <= snap {
                break;
            }
        }
        self.time += h;
        Ok(())
    }

    /// [`Self::advance`] by `span`, the ADC's channel filters following `vout` and `il`
    /// (`adc_filter`, `adc_il_filter`, see [`Digital::follow`]) in pieces of at most a
    /// [`FILTER_PIECES`]th of the `period`.
    fn advance_read(&mut self, span: f64, gate: Gate, period: f64) {
        if !self.digital.filters() || span <= 0.0 {
            return self.advance(span, gate);
        }
        let n = (FILTER_PIECES * span / period).ceil().max(1.0);
        let dt = span / n;
        for _ in 0..n as usize {
            // (At the load current the piece draws, which may have been set since the last.)
            let start = [self.through_vout_map(&self.x, self.inputs.io), self.x[0]];
            let integral0 = [self.vout_integral(), self.z[0]];
            self.advance(dt, gate);
            let mean = [(self.vout_integral() - integral0[0]) / dt, (self.z[0] - integral0[1]) / dt];
            self.digital.follow(start, [self.vout(), self.x[0]], mean, dt);
        }
    }

    /// The instants `[vout, il]` into each period at which the ADC reads each channel: `il` at
    /// `adc_delay`, `vout` `adc_vout_skew` after it (switched mode); 0 is the period start.
    fn adc_instants(&self) -> [f64; 2] {
        match self.mode {
            Mode::Switched => [self.digital.adc_delay + self.digital.adc_vout_skew, self.digital.adc_delay],
            Mode::Averaged => [0.0; 2],
        }
    }

    /// The gate in force at the current phase and the end of its interval (the next fixed
    /// event). Synchronous, each turn-on delayed by the dead time as gate drivers do: dead
    /// `[0, td)`, high `[td, dT)`, dead `[dT, dT + td)`, low `[dT + td, T)` (no leading dead
    /// interval after a duty-1 period, whose PWM signal never fell); asynchronous: high
    /// `[0, dT)`, off `[dT, T)`.
    fn gate(&self, period: f64) -> (Gate, f64) {
        let (gate, end) = self.pwm_gate(period);
        match self.slew {
            Some((until, _)) if gate == Gate::Off && self.phase < until => (Gate::Slew, until.min(end)),
            _ => (gate, end),
        }
    }

    /// The window of the `Off` interval that starts now that holds the switch node's slew, if
    /// there is one (see [`Params::switch_node_capacitance`]): from the rail a switch held it
    /// at, the current at the edge `i0` (held: the slew lasts nanoseconds) drives the node
    /// toward the diode clamp on its side (il > 0 down to `−Vf`, il < 0 up to `vin + V_bd`) in
    /// `Csw·|ΔV|/|i0|` (after a jump of `Rd·|i0|` behind a damping resistance `Rd`, see
    /// [`Params::switch_node_damping`]), and the clamp holds it from there; a turn-on that
    /// comes first completes the swing (hard switching). The window is the dead interval, or
    /// the first [`SLEW_WINDOW`] of a diode buck's off-time, and the node is held at its mean
    /// over it: the same volt-seconds, pieces of fixed length (their transitions stay cached),
    /// and il at the window's end right to first order.
    fn slew_at_edge(&mut self, period: f64) -> Option<(f64, f64)> {
        let (gate, end) = self.pwm_gate(period);
        if gate != Gate::Off {
            return None;
        }
        let v0 = self.node_rail.take()?;
        let (p, i0) = (&self.params, self.x[0]);
        if p.switch_node_capacitance == 0.0 || i0 == 0.0 || self.blocked {
            return None;
        }
        let target = if i0 > 0.0 { self.low_clamp() } else { self.high_clamp() };
        // Behind a damping resistance the node jumps by `Rd·|i0|` first: the capacitance then
        // swings what is left of the way (nothing where the jump reaches the clamp).
        let swing = (target - v0).abs() - p.switch_node_damping * i0.abs();
        if swing <= 0.0 {
            return None;
        }
        let v1 = target - swing * (target - v0).signum();
        let transit = p.switch_node_capacitance * swing / i0.abs();
        let window = if p.asynchronous() { (SLEW_WINDOW * period).min(end - self.phase) } else { end - self.phase };
        // The ramp's volt-seconds within the window, then the clamp's.
        let ramp = if transit <= window { 0.5 * (v1 + target) * transit } else { (v1 + 0.5 * (target - v1) * window / transit) * window };
        let mean = (ramp + target * (window - transit).max(0.0)) / window;
        Some((self.phase + window, mean))
    }

    /// The gate the PWM timing and the dead time call for (before any slew of the node).
    fn pwm_gate(&self, period: f64) -> (Gate, f64) {
        if self.mode == Mode::Averaged {
            return (Gate::Averaged, period);
        }
        let on = self.params.effective_duty(self.latched_duty) * period;
        if self.params.asynchronous() {
            return if self.phase < on { (Gate::High, on) } else { (Gate::Off, period) };
        }
        // Each turn-on comes `td` after the PWM edge that calls for it (the high side's after the
        // rising edge at the period start, the low side's after the falling edge at dT).
        let td = self.params.dead_time;
        let rising = on > 0.0 && !self.pwm_high_before;
        let high_start = if rising { td.min(on) } else { 0.0 };
        if self.phase < high_start {
            return (Gate::Off, high_start);
        }
        if self.phase < on {
            return (Gate::High, on);
        }
        if on >= period {
            return (Gate::High, period);
        }
        let falling = on > 0.0 || self.pwm_high_before;
        let low_start = if falling { (on + td).min(period) } else { 0.0 };
        if self.phase < low_start { (Gate::Off, low_start) } else { (Gate::Low, period) }
    }

    /// What conducts under `gate` in the current state.
    fn topology(&mut self, gate: Gate) -> Topology {
        match gate {
            Gate::High => Topology::High,
            Gate::Low => Topology::Low,
            Gate::Averaged => Topology::Averaged,
            Gate::Off | Gate::Slew if self.blocked => Topology::Blocked,
            Gate::Off | Gate::Slew if self.x[0] > 0.0 => Topology::LowDiode,
            Gate::Off | Gate::Slew if self.x[0] < 0.0 => Topology::HighDiode,
            Gate::Off | Gate::Slew => {
                // Zero current with both switches off: neither diode is forward-biased while the
                // output lies within [−Vf, vin + V_bd] (re-conduction from a blocked inductor is
                // not modelled).
                self.blocked = true;
                self.ring_watch = if self.params.rings() { self.ring_may_clamp(self.x[NODE]) } else { 0 };
                Topology::Blocked
            }
        }
    }

    /// The pieces a ring that starts at the node voltage `from` is watched for a clamp: its
    /// first half-cycle ([`RING_WATCH`]) if its swing to the far side of the output node (to
    /// `2·vout − from`, less what damping takes) comes within a twentieth of the swing of a
    /// diode's clamp, else none (it cannot reach one: the swings only shrink).
    fn ring_may_clamp(&self, from: f64) -> u8 {
        let vn = self.vout();
        let far = 2.0 * vn - from;
        let margin = 0.05 * (vn - from).abs();
        if far <= self.low_clamp() + margin || far >= self.high_clamp() - margin { RING_WATCH } else { 0 }
    }

    /// Saturation region of the current state: by value, or as recorded at `|il| = isat`.
    fn region(&self) -> i8 {
        let (il, isat) = (self.x[0], self.params.isat);
        if self.params.inductor_saturation == 0.0 {
            0
        } else if il > isat {
            1
        } else if il < -isat {
            -1
        } else if il.abs() < isat {
            0
        } else {
            self.sat_region
        }
    }

    /// The switch node's voltage while the low side's diode conducts (`il > 0`): `−Vf`.
    fn low_clamp(&self) -> f64 {
        -self.params.low_diode_drop()
    }

    /// The switch node's voltage while the high side's body diode conducts (`il < 0`):
    /// `vin + V_bd`.
    fn high_clamp(&self) -> f64 {
        self.inputs.vin + self.params.body_diode_drop()
    }

    /// The circuit and switch-node voltage of `topology`.
    fn configure(&self, topology: Topology) -> (Circuit, f64) {
        let p = &self.params;
        let vin = self.inputs.vin;
        let r_diode = p.rl + p.diode_resistance;
        let (r, u_sw) = match topology {
            Topology::High => (p.switching_resistance(1.0), vin),
            Topology::Low => (p.switching_resistance(0.0), 0.0),
            Topology::Averaged => {
                let d = p.effective_duty(self.latched_duty);
                (p.switching_resistance(d), d * vin)
            }
            Topology::LowDiode => (r_diode, self.low_clamp()),
            Topology::HighDiode => (r_diode, self.high_clamp()),
            Topology::Blocked => (p.rl, 0.0),
        };
        let blocked = topology == Topology::Blocked;
        let l = if !blocked && self.region() != 0 { p.l * (1.0 - p.inductor_saturation) } else { p.l };
        (Circuit { r: r.to_bits(), l: l.to_bits(), cl: self.cl_now.to_bits(), blocked }, u_sw)
    }

    /// Levels of a state (`il`, or a ringing node's voltage) whose crossing ends the piece:
    /// `(state, level, side)`, the side (+1 above, −1 below) the state lies on now.
    fn thresholds(&self, topology: Topology) -> ([(usize, f64, f64); 3], usize) {
        let mut out = [(0, 0.0, 0.0); 3];
        let mut n = 0;
        match topology {
            // A ringing node ends at a diode's clamp: the low side's below, the high side's above.
            Topology::Blocked if self.params.rings() && self.ring_watch > 0 => {
                out[0] = (NODE, self.low_clamp(), 1.0);
                out[1] = (NODE, self.high_clamp(), -1.0);
                return (out, 2);
            }
            Topology::Blocked => return (out, 0),
            Topology::LowDiode => {
                out[0] = (0, 0.0, 1.0);
                n = 1;
            }
            Topology::HighDiode => {
                out[0] = (0, 0.0, -1.0);
                n = 1;
            }
            _ => {}
        }
        if self.params.inductor_saturation > 0.0 {
            let isat = self.params.isat;
            match self.region() {
                1 => out[n] = (0, isat, 1.0),
                -1 => out[n] = (0, -isat, -1.0),
                _ => {
                    out[n] = (0, isat, -1.0);
                    n += 1;
                    out[n] = (0, -isat, 1.0);
                }
            }
            n += 1;
        }
        (out, n)
    }

    /// Advances `[x; z]` over `tau` seconds of one gate interval, splitting at state events.
    fn advance(&mut self, tau: f64, gate: Gate) {
        if tau <= 0.0 {
            return;
        }
        let io = self.inputs.io;
        self.io_held = io;
        self.io_integral += io * tau;
        let rail = match gate {
            Gate::High => Some(self.inputs.vin),
            Gate::Low => Some(0.0),
            _ => None,
        };
        if let Some(v) = rail {
            self.node_rail = rail;
            if self.params.rings() {
                self.x[NODE] = v;
            }
        }
        if !matches!(gate, Gate::Off | Gate::Slew) {
            self.blocked = false;
        }
        let mut left = tau;
        let mut events = 0;
        let mut first = true;
        loop {
            let topology = self.topology(gate);
            let (circuit, mut u_sw) = self.configure(topology);
            if let (Gate::Slew, Some((_, mean)), Topology::LowDiode | Topology::HighDiode) = (gate, self.slew, topology) {
                u_sw = mean;
            }
            // A conducting diode on its exponential law goes in short pieces, each at its mean drop.
            let law = self.params.diode_emission > 0.0 && gate != Gate::Slew && matches!(topology, Topology::LowDiode | Topology::HighDiode);
            let diode_piece = law.then(|| self.params.period() / DIODE_PIECES);
            // A ringing node goes in short pieces while it is watched (see `first_crossing`).
            let ringing = topology == Topology::Blocked && self.params.rings();
            let watched = ringing && self.ring_watch > 0;
            let span =
                if watched { left.min(RING_PIECE * std::f64::consts::TAU * (self.params.l * self.params.switch_node_capacitance).sqrt()) } else { diode_piece.map_or(left, |piece| left.min(piece)) };
            if law {
                u_sw = self.diode_law_node(topology, circuit, io, span);
            }
            let u = Vector2::new(u_sw, io);
            // A whole gate interval, and a diode's whole pieces, go by their own (cached)
            // transitions; the rest after a state event, and a ringing node, are reached on the ladder.
            let end = if (first || diode_piece == Some(span)) && !ringing {
                self.whole(circuit, span, &u)
            } else {
                let i = self.ladder(circuit, span);
                self.ladders[i].1.reach(&Point { t: 0.0, x: self.x, z: self.z }, &u, span)
            };
            first = false;
            let (levels, n) = self.thresholds(topology);
            let crossed = if n == 0 || events == MAX_EVENTS { None } else { self.cross(circuit, &end, &u, span, &levels[..n]) };
            let Some(t) = crossed else {
                self.commit(&end);
                left -= span;
                if left <= 0.0 {
                    return;
                }
                // Only a watched ring's and a diode's pieces are shorter than what is left.
                if watched {
                    self.ring_watch -= 1;
                }
                continue;
            };
            events += 1;
            left -= t;
            if left <= 0.0 {
                return;
            }
        }
    }

    /// The switch node's voltage over the next `span` of a conducting diode on its exponential
    /// law (`topology` `LowDiode` or `HighDiode`, its `circuit`): the clamp at the diode's mean
    /// drop along the current, taken as linear over the piece from its slope at the start (found
    /// at the drop of the piece's start, then once more at the mean drop), up to where it
    /// reaches zero.
    fn diode_law_node(&mut self, topology: Topology, circuit: Circuit, io: f64, span: f64) -> f64 {
        let p = self.params;
        let (vf, base, sign) = if topology == Topology::LowDiode { (p.low_diode_drop(), 0.0, -1.0) } else { (p.body_diode_drop(), self.inputs.vin, 1.0) };
        let i0 = self.x[0].abs();
        let mut u_sw = base + sign * p.diode_law_mean(vf, i0, i0);
        let i = self.ladder(circuit, span);
        for _ in 0..2 {
            let slope = self.ladders[i].1.dil(&self.x, &Vector2::new(u_sw, io)) * self.x[0].signum();
            u_sw = base + sign * p.diode_law_mean(vf, i0, (i0 + slope * span).max(0.0));
        }
        u_sw
    }

    /// Moves to the first state event at one of `levels` on the way from the current point to
    /// `end`, `tau` later in the same piece (inputs `u`), and crosses it: the time that took, or
    /// `None` (and nothing moved) if there is none.
    fn cross(&mut self, circuit: Circuit, end: &Point, u: &Vector2<f64>, tau: f64, levels: &[(usize, f64, f64)]) -> Option<f64> {
        let start = Point { t: 0.0, x: self.x, z: self.z };
        let tol = ROOT_TOL * self.params.period();
        let i = self.ladder(circuit, tau);
        let ladder = &self.ladders[i].1;
        let (mut at, state, level) = first_crossing(ladder, (&start, end), u, tau, levels, tol)?;
        at.x[state] = level;
        // Above isat when |il| keeps growing (the sign of dil/dt is the same for both
        // inductances, so this does not depend on the region just left).
        let dil = ladder.dil(&at.x, u);
        self.commit(&at);
        if state == NODE {
            // The ringing node reached a clamp: that diode conducts (il has the sign that drove
            // the node there), the node held at the clamp.
            self.blocked = false;
            self.ring_watch = 0;
        } else if level == 0.0 {
            self.blocked = true;
            if self.params.rings() {
                // The diode that conducted held the node at its clamp: the ring starts there.
                self.x[NODE] = u[0];
                self.ring_watch = self.ring_may_clamp(u[0]);
            }
        } else {
            self.sat_region = if dil * level > 0.0 { level.signum() as i8 } else { 0 };
        }
        Some(at.t)
    }

    fn commit(&mut self, p: &Point) {
        self.x = p.x;
        self.z = p.z;
    }

    /// The continuous circuit.
    fn lti(&self, circuit: Circuit) -> Lti {
        let bits = f64::from_bits;
        self.params.piece_lti(bits(circuit.r), bits(circuit.l), bits(circuit.cl), circuit.blocked)
    }

    /// The current point advanced over a whole gate interval of length `tau`.
    ///
    /// The transition comes from the Van Loan exponential of [`Lti::discretize`] and is cached,
    /// so that the ideal circuit is the design's discretization bit for bit. Where nothing
    /// repeats, the interval is reached on the circuit's [`Ladder`] (cheaper to build than the
    /// dynamic-size exponential, and shared by the pieces of the period and their state
    /// events): under `cap_dc_bias`, whose `Cl` and so circuit change every period, and once the
    /// cache is full (a duty that moves every period, as a closed loop's does, or a host that
    /// steps at instants of its own), where each new length cost an exponential, evicting one
    /// that was to come again (a closed-loop record of 76 duty levels took 22 times as long to
    /// diagnose as an open-loop one).
    fn whole(&mut self, circuit: Circuit, tau: f64, u: &Vector2<f64>) -> Point {
        let cached = if self.params.cap_dc_bias > 0.0 { None } else { self.cached(circuit, tau) };
        let Some(i) = cached else {
            let i = self.ladder(circuit, tau);
            return self.ladders[i].1.reach(&Point { t: 0.0, x: self.x, z: self.z }, u, tau);
        };
        let (x, z) = self.cache[i].step.apply(&self.x, &self.z, u);
        Point { t: tau, x, z }
    }

    /// Index of the cached transition of `circuit` over `tau`, computing it on a miss while the
    /// cache has room (`None` once it is full).
    fn cached(&mut self, circuit: Circuit, tau: f64) -> Option<usize> {
        // The length first: it tells the cached pieces of one circuit apart.
        if let Some(i) = self.cache.iter().position(|p| p.step.h.to_bits() == tau.to_bits() && p.circuit == circuit) {
            return Some(i);
        }
        if self.cache.len() == CACHE_SLOTS {
            return None;
        }
        let d = self.lti(circuit).discretize(tau);
        let step = Transition { h: tau, ad: pad(&d.ad), bd: pad(&d.bd), ia: pad(&d.ia), ib: pad(&d.ib) };
        self.cache.push(Piece { step, circuit });
        Some(self.cache.len() - 1)
    }

    /// Index of the cached [`Ladder`] of `circuit`, building it on a miss, grown for a piece of
    /// `length`.
    fn ladder(&mut self, circuit: Circuit, length: f64) -> usize {
        let i = match self.ladders.iter().position(|(c, _)| *c == circuit) {
            Some(i) => i,
            None => {
                let lti = self.lti(circuit);
                let (a, b, top) = (pad(&lti.a), pad(&lti.b), self.params.period());
                if self.ladders.len() < LADDER_SLOTS {
                    self.ladders.push((circuit, Ladder::new(a, b, top)));
                    self.ladders.len() - 1
                } else {
                    // The oldest slot, rebuilt in place.
                    let i = self.next_ladder;
                    self.next_ladder = (i + 1) % LADDER_SLOTS;
                    self.ladders[i].0 = circuit;
                    self.ladders[i].1.rebuild(a, b, top);
                    i
                }
            }
        };
        self.ladders[i].1.grow(length);
        i
    }
}

/// The earliest instant in `(0, tau]` at which a state `x` (`il`, or a ringing node's voltage)
/// reaches one of `levels` (each `(state, level, s)` with the side `s` it starts on, so that
/// `s·(x − level) ≥ 0` at `start`): the point there, the state and the level.
///
/// A crossing is bracketed by the sign of `s·(x − level)` at the piece end `end`, or, when the
/// state first moves towards the level and then away (an extremum inside the piece), by the
/// value at the extremum, located on `dx/dt`. Within one piece `il` is a smooth sum of
/// exponentials far slower than the period, and a ringing node is taken in pieces of an eighth
/// of its ring ([`Converter::advance`]): at most one extremum, which is what this relies on:
/// inside the bracket there is one crossing, located on `x`. Both are located to `tol`.
fn first_crossing(ladder: &Ladder, (start, end): (&Point, &Point), u: &Vector2<f64>, tau: f64, levels: &[(usize, f64, f64)], tol: f64) -> Option<(Point, usize, f64)> {
    let mut best: Option<(Point, usize, f64)> = None;
    for &(state, level, side) in levels {
        let crossing = Watch { state, order: 0, level, sign: side };
        let hi = if ladder.value(crossing, &end.x, u) <= 0.0 {
            tau
        } else {
            let towards = Watch { state, order: 1, level: 0.0, sign: -side };
            if !(ladder.value(towards, &start.x, u) > 0.0 && ladder.value(towards, &end.x, u) < 0.0) {
                continue;
            }
            let turn = ladder.descend(start, u, tau, towards, tol);
            if ladder.value(crossing, &turn.x, u) > 0.0 {
                continue;
            }
            turn.t
        };
        let at = ladder.descend(start, u, hi, crossing, tol);
        if best.is_none_or(|(b, _, _)| at.t < b.t) {
            best = Some((at, state, level));
        }
    }
    best
}

#[cfg(test)]
#[path = "converter_tests.rs"]
mod tests;

#[cfg(test)]
#[path = "effects_tests.rs"]
mod effects_tests;
