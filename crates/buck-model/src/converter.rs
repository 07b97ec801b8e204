//! The converter as a simulator: inputs, state, exact stepping over any step length.
use nalgebra::{DMatrix, SMatrix, Vector2, Vector4};
use serde::{Deserialize, Serialize};

use crate::digital::{Control, Digital};
use crate::lti::Lti;
use crate::variables::{self, Type, VarId};
use crate::{Mode, ModelError, Params};

/// Inputs, held constant over a communication step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Inputs {
    /// Duty cycle command, 0..1.
    pub duty: f64,
    /// Load current [A].
    pub io: f64,
    /// Input voltage [V].
    pub vin: f64,
    /// Output voltage reference of the controller [V] (closed loop).
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
    /// Inductor current [A].
    pub il: f64,
    /// Voltage of C behind its ESR [V].
    pub vc: f64,
    /// Voltage across Cl [V] (the output voltage unless `load_esr > 0`).
    pub vo: f64,
    /// Current into the C branch [A]; a state only when `esl > 0`, else ignored.
    pub ic: f64,
}

/// Everything the converter reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outputs {
    /// Instantaneous output (node) voltage [V].
    pub vout: f64,
    /// Instantaneous inductor current [A].
    pub il: f64,
    /// Instantaneous voltage of C behind its ESR [V].
    pub vc: f64,
    /// Exact average of `vout` over the last completed switching period [V].
    pub vout_avg: f64,
    /// Exact average of `il` over the last completed switching period [A].
    pub il_avg: f64,
    /// Duty that drove the switch in the last latched period.
    pub duty_applied: f64,
    /// ADC reading of `vout` at the last period start [V].
    pub vout_adc: f64,
    /// ADC reading of `il` at the last period start [A].
    pub il_adc: f64,
}

/// Relative tolerance (of the period) within which a step end snaps onto a switching event, so
/// that a host stepping by `T` in floating point does not create femtosecond slivers or latch
/// the next period's duty a rounding error too early. A step that ends away from any event
/// is simulated exactly, however short.
const SNAP: f64 = 1e-9;
/// Pieces with cached transition matrices (PRBS between two duty levels needs four, dead time
/// and diode conduction a few more).
const CACHE_SLOTS: usize = 16;
/// Relative tolerance (of the period) of the instants of state events (`il = 0`, `|il| = isat`).
const ROOT_TOL: f64 = 1e-15;
/// State events handled within one piece before the rest of it is taken as it is (a guard
/// against chattering; no physical configuration comes near it).
const MAX_EVENTS: usize = 64;

/// Largest number of circuit states (`[il, vc, vcl, ic]`, `ic` only with `esl`).
const NX: usize = 4;
type Mat = SMatrix<f64, NX, NX>;
type Inp = SMatrix<f64, NX, 2>;

/// Which gate of the half bridge is on over an interval fixed by the PWM timing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Gate {
    /// High side on: `[0, d·T)`.
    High,
    /// Low side on (synchronous buck, outside dead time).
    Low,
    /// Both off: dead time, or the off-time of the asynchronous buck; diodes decide.
    Off,
    /// Averaged mode: the switch node carries `d·vin`.
    Averaged,
}

/// What conducts over a piece: the linear circuit and the switch-node voltage follow from it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Topology {
    /// High-side switch (either current direction): `u_sw = vin`, `RL + Rsw`.
    High,
    /// Low-side switch (either direction): `u_sw = 0`, `RL + Rsw`.
    Low,
    /// Averaged switch node `d·vin`, `RL + Rsw`.
    Averaged,
    /// Low-side diode with `il > 0`: `u_sw = −Vf`, `RL`.
    LowDiode,
    /// High-side body diode with `il < 0`: `u_sw = vin + V_bd`, `RL`.
    HighDiode,
    /// Everything off, `il` held at 0; the switch node floats at the output.
    Blocked,
}

/// Identity of a cached transition: the linear circuit (series resistance, incremental
/// inductance, load capacitance, blocked inductor) and the piece length, all as bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Key {
    tau: u64,
    r: u64,
    l: u64,
    cl: u64,
    blocked: bool,
}

/// Transition over one held-input piece: `x(τ) = ad·x + bd·u`, `∫x = ia·x + ib·u` with
/// `u = [u_sw, io]`. States beyond the configuration's count stay zero (their rows and columns
/// are zero).
#[derive(Debug, Clone)]
struct Piece {
    key: Key,
    ad: Mat,
    bd: Inp,
    ia: Mat,
    ib: Inp,
}

impl Piece {
    /// `(x(τ), z + ∫x)`.
    ///
    /// Summed in the order of the ideal 3-state model's `[[ad, 0], [ia, I]]·[x; z] + Γ·u`, so
    /// that the ideal circuit is reproduced bit for bit.
    #[inline]
    fn apply(&self, x: &Vector4<f64>, z: &Vector4<f64>, u: &Vector2<f64>) -> (Vector4<f64>, Vector4<f64>) {
        let mut xn = Vector4::zeros();
        let mut zn = Vector4::zeros();
        for i in 0..NX {
            let (mut a, mut b) = (0.0, 0.0);
            for j in 0..NX {
                a += self.ad[(i, j)] * x[j];
                b += self.ia[(i, j)] * x[j];
            }
            xn[i] = a + (self.bd[(i, 0)] * u[0] + self.bd[(i, 1)] * u[1]);
            zn[i] = (b + z[i]) + (self.ib[(i, 0)] * u[0] + self.ib[(i, 1)] * u[1]);
        }
        (xn, zn)
    }
}

/// A buck converter that advances exactly over steps of any length.
///
/// The engine is piecewise linear: between events the circuit is one [`Topology`] (what
/// conducts) with its `A`, `B` from [`Params::piece_lti`], held inputs `[u_sw, io]`, and an
/// exact transition of the state and its integral, cached per (circuit, piece length). Fixed-time
/// events come from the PWM timing (high-side turn-off at `d·T`, the dead-time edges, the period
/// end); state events (`il = 0` of a conducting diode, `|il| = isat`) are located inside a piece
/// on the exact solution by safeguarded Newton iteration to `1e-15·T`, the piece is split there
/// and the topology re-chosen. One loop handles both, for any communication step.
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
    /// `[il, vc, vcl, ic]` (`ic` stays 0 without `esl`).
    x: Vector4<f64>,
    /// Integral of `x` since the start of the current period.
    z: Vector4<f64>,
    /// Integral of the load current since the start of the current period [A·s].
    io_integral: f64,
    /// Load current held over the latest piece [A]: `vout` depends on it through `load_esr`,
    /// and an input set after a step must not change the outputs of that step.
    io_held: f64,
    /// Time since the start of the current period [s].
    phase: f64,
    /// Duty in force during the current period (latched at its start).
    latched_duty: f64,
    /// Load capacitance in force during the current period (`cap_dc_bias`) [F].
    cl_now: f64,
    /// The inductor current stopped at zero with both switches off (DCM) until the next turn-on.
    blocked: bool,
    /// `vout = cx·x + d·io` ([`Params::vout_map`], kept at hand: outputs are read every step).
    vout_map: ([f64; 4], f64),
    /// Saturation region when `|il| = isat` exactly (after an event): −1, 0 or +1.
    sat_region: i8,
    /// The next piece starts a new period and must latch the duty first.
    at_period_start: bool,
    /// Averages `[il, vc, vcl, ic]` over the last completed period.
    last_average: Vector4<f64>,
    /// Average load current over the last completed period [A].
    last_io_average: f64,
    /// ADC, controller, delay line, DPWM.
    digital: Digital,
    /// Index of the current period.
    period_index: u64,
    time: f64,
    #[serde(skip)]
    cache: Vec<Piece>,
    #[serde(skip)]
    next_slot: usize,
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
            cl_now: params.cl,
            vout_map: params.vout_map(),
            blocked: false,
            sat_region: 0,
            at_period_start: true,
            last_average: Vector4::zeros(),
            last_io_average: 0.0,
            digital: Digital::default(),
            period_index: 0,
            time: 0.0,
            cache: Vec::with_capacity(CACHE_SLOTS),
            next_slot: 0,
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

    /// Simulated time [s].
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
        State { il: self.x[0], vc: self.x[1], vo: self.x[2], ic: self.x[3] }
    }

    /// Puts the circuit at the start of a period in the given state, e.g. from an initial
    /// condition computed elsewhere.
    pub fn set_state(&mut self, s: State) {
        let ic = if self.params.esl > 0.0 { s.ic } else { 0.0 };
        self.x = Vector4::new(s.il, s.vc, s.vo, ic);
        self.z = Vector4::zeros();
        self.io_integral = 0.0;
        self.io_held = self.inputs.io;
        self.phase = 0.0;
        self.at_period_start = true;
        self.blocked = false;
        self.sat_region = 0;
        self.cl_now = self.params.cl_at(s.vo);
        self.last_average = self.x;
        self.last_io_average = self.io_held;
    }

    /// Starts a new run at a period start: from the averaged DC operating point of the current
    /// inputs when `start_at_steady_state` is set (the default), from zero otherwise. In closed
    /// loop the operating point is the one where `vout = vref`, and the controller starts there.
    pub fn initialize(&mut self) {
        let Inputs { duty, io, vin, vref, .. } = self.inputs;
        let r = self.params.rl + self.params.switch_resistance;
        let d0 = match self.digital.control {
            Control::Open => duty,
            Control::Closed if vin > 0.0 => ((vref + r * io) / vin).clamp(0.0, 1.0),
            Control::Closed => 0.0,
        };
        let x0 = if self.start_at_steady_state { self.params.steady_state(d0, vin, io) } else { [0.0; 3] };
        self.set_state(State { il: x0[0], vc: x0[1], vo: x0[2], ic: 0.0 });
        self.period_index = 0;
        self.digital.restart(d0, self.vout(), x0[0]);
    }

    /// Output (node) voltage of the current state with the load current of the latest piece.
    fn vout(&self) -> f64 {
        let (cx, d) = self.vout_map;
        cx[0] * self.x[0] + cx[1] * self.x[1] + cx[2] * self.x[2] + cx[3] * self.x[3] + d * self.io_held
    }

    /// Current outputs.
    pub fn outputs(&self) -> Outputs {
        let (cx, d) = self.vout_map;
        let avg = &self.last_average;
        Outputs {
            vout: self.vout(),
            il: self.x[0],
            vc: self.x[1],
            vout_avg: cx[0] * avg[0] + cx[1] * avg[1] + cx[2] * avg[2] + cx[3] * avg[3] + d * self.last_io_average,
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
            VarId::NoiseSeed => d.noise_seed as f64,
            VarId::DpwmBits => f64::from(d.dpwm_bits),
            VarId::SwitchResistance => p.switch_resistance,
            VarId::DiodeDrop => p.diode_drop,
            VarId::Dcm => f64::from(u8::from(p.dcm)),
            VarId::DeadTime => p.dead_time,
            VarId::LoadEsr => p.load_esr,
            VarId::Esl => p.esl,
            VarId::InductorSaturation => p.inductor_saturation,
            VarId::Isat => p.isat,
            VarId::CapDcBias => p.cap_dc_bias,
            VarId::CapRatedVoltage => p.cap_rated_voltage,
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
                    VarId::DeadTime => p.dead_time = value,
                    VarId::LoadEsr => p.load_esr = value,
                    VarId::Esl => p.esl = value,
                    VarId::InductorSaturation => p.inductor_saturation = value,
                    VarId::Isat => p.isat = value,
                    VarId::CapDcBias => p.cap_dc_bias = value,
                    VarId::CapRatedVoltage => p.cap_rated_voltage = value,
                    VarId::Kp => d.kp = value,
                    VarId::Ki => d.ki = value,
                    VarId::Kd => d.kd = value,
                    VarId::AdcVfs => d.adc_vfs = value,
                    VarId::AdcIfs => d.adc_ifs = value,
                    VarId::AdcNoise => d.adc_noise = value,
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
                _ => return Err(ModelError::NotSettable { name: var.name, when: "as a Boolean" }),
            },
        }
        Ok(())
    }

    /// Drops transitions computed from old parameters and re-derives what depends on them.
    fn parameters_changed(&mut self) {
        self.cache.clear();
        self.next_slot = 0;
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
        let snap = SNAP * period;
        let mut remaining = h;
        loop {
            if self.at_period_start {
                let Inputs { duty, dither, vref, .. } = self.inputs;
                self.latched_duty = self.digital.latch(duty, dither, vref);
                // cap_dc_bias, quasi-static: Cl follows the voltage across it once per period.
                self.cl_now = self.params.cl_at(self.x[2]);
                self.at_period_start = false;
            }
            let (gate, event) = self.gate(period);
            let to_event = event - self.phase;
            if remaining + snap < to_event {
                // The step ends before the next event: advance exactly, however short.
                self.advance(remaining, gate);
                self.phase += remaining;
                break;
            }
            self.advance(to_event, gate);
            remaining -= to_event;
            self.phase = event;
            if event >= period {
                self.last_average = self.z / period;
                self.last_io_average = self.io_integral / period;
                self.z = Vector4::zeros();
                self.io_integral = 0.0;
                self.phase = 0.0;
                self.at_period_start = true;
                self.period_index += 1;
                self.digital.sample(self.vout(), self.x[0], self.period_index);
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

    /// The gate in force at the current phase and the end of its interval (the next fixed
    /// event). Synchronous: high `[0, dT)`, dead `[dT, dT + td)`, low `[dT + td, T − td)`,
    /// dead `[T − td, T)`; asynchronous: high `[0, dT)`, off `[dT, T)`.
    fn gate(&self, period: f64) -> (Gate, f64) {
        if self.mode == Mode::Averaged {
            return (Gate::Averaged, period);
        }
        let on = self.latched_duty * period;
        if self.phase < on {
            return (Gate::High, on);
        }
        if self.params.asynchronous() {
            return (Gate::Off, period);
        }
        let td = self.params.dead_time;
        let (low_start, low_end) = (on + td, period - td);
        if low_start >= low_end {
            (Gate::Off, period)
        } else if self.phase < low_start {
            (Gate::Off, low_start)
        } else if self.phase < low_end {
            (Gate::Low, low_end)
        } else {
            (Gate::Off, period)
        }
    }

    /// What conducts under `gate` in the current state.
    fn topology(&mut self, gate: Gate) -> Topology {
        match gate {
            Gate::High => Topology::High,
            Gate::Low => Topology::Low,
            Gate::Averaged => Topology::Averaged,
            Gate::Off if self.blocked => Topology::Blocked,
            Gate::Off if self.x[0] > 0.0 => Topology::LowDiode,
            Gate::Off if self.x[0] < 0.0 => Topology::HighDiode,
            Gate::Off => {
                // Zero current with both switches off: neither diode is forward-biased while the
                // output lies within [−Vf, vin + V_bd] (re-conduction from a blocked inductor is
                // not modelled).
                self.blocked = true;
                Topology::Blocked
            }
        }
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

    /// The circuit and switch-node voltage of `topology` for a piece of length `tau`.
    fn configure(&self, topology: Topology, tau: f64) -> (Key, f64) {
        let p = &self.params;
        let vin = self.inputs.vin;
        let r_switch = p.rl + p.switch_resistance;
        let (r, u_sw) = match topology {
            Topology::High => (r_switch, vin),
            Topology::Low => (r_switch, 0.0),
            Topology::Averaged => (r_switch, self.latched_duty * vin),
            Topology::LowDiode => (p.rl, -if p.asynchronous() { p.diode_drop } else { p.body_diode_drop() }),
            Topology::HighDiode => (p.rl, vin + p.body_diode_drop()),
            Topology::Blocked => (p.rl, 0.0),
        };
        let blocked = topology == Topology::Blocked;
        let l = if !blocked && self.region() != 0 { p.l * (1.0 - p.inductor_saturation) } else { p.l };
        let key = Key { tau: tau.to_bits(), r: r.to_bits(), l: l.to_bits(), cl: self.cl_now.to_bits(), blocked };
        (key, u_sw)
    }

    /// Levels of `il` whose crossing ends the piece, each with the side (+1 above, −1 below)
    /// the current lies on now.
    fn thresholds(&self, topology: Topology) -> ([(f64, f64); 3], usize) {
        let mut out = [(0.0, 0.0); 3];
        let mut n = 0;
        match topology {
            Topology::Blocked => return (out, 0),
            Topology::LowDiode => {
                out[0] = (0.0, 1.0);
                n = 1;
            }
            Topology::HighDiode => {
                out[0] = (0.0, -1.0);
                n = 1;
            }
            _ => {}
        }
        if self.params.inductor_saturation > 0.0 {
            let isat = self.params.isat;
            match self.region() {
                1 => out[n] = (isat, 1.0),
                -1 => out[n] = (-isat, -1.0),
                _ => {
                    out[n] = (isat, -1.0);
                    n += 1;
                    out[n] = (-isat, 1.0);
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
        if gate != Gate::Off {
            self.blocked = false;
        }
        let mut left = tau;
        for event in 0..=MAX_EVENTS {
            let topology = self.topology(gate);
            let (key, u_sw) = self.configure(topology, left);
            let u = Vector2::new(u_sw, io);
            // Only whole intervals repeat; the rest after a state event would churn the cache.
            let next = if event == 0 {
                let i = self.cached(key);
                self.cache[i].apply(&self.x, &self.z, &u)
            } else {
                self.piece(key).apply(&self.x, &self.z, &u)
            };
            let (levels, n) = self.thresholds(topology);
            let crossing = if n == 0 || event == MAX_EVENTS {
                None
            } else {
                let lti = self.lti(&key);
                first_crossing(&lti, &self.x, &u, left, next.0[0], &levels[..n], ROOT_TOL * self.params.period())
            };
            let Some((t, level)) = crossing else {
                self.commit(&next);
                return;
            };
            if t > 0.0 {
                let at = self.piece(Key { tau: t.to_bits(), ..key }).apply(&self.x, &self.z, &u);
                self.commit(&at);
            }
            self.x[0] = level;
            if level == 0.0 {
                self.blocked = true;
            } else {
                // Above isat when |il| keeps growing (the sign of dil/dt is the same for both
                // inductances, so this does not depend on the region just left).
                let lti = self.lti(&key);
                let dil = derivative(&lti, &self.x, &u);
                self.sat_region = if dil * level > 0.0 { level.signum() as i8 } else { 0 };
            }
            left -= t;
            if left <= 0.0 {
                return;
            }
        }
    }

    fn commit(&mut self, (x, z): &(Vector4<f64>, Vector4<f64>)) {
        self.x = *x;
        self.z = *z;
    }

    /// The continuous circuit of a piece.
    fn lti(&self, key: &Key) -> Lti {
        self.params.piece_lti(f64::from_bits(key.r), f64::from_bits(key.l), f64::from_bits(key.cl), key.blocked)
    }

    /// Exact transition over the piece `key`.
    fn piece(&self, key: Key) -> Piece {
        let d = self.lti(&key).discretize(f64::from_bits(key.tau));
        let n = d.ad.nrows();
        let mut piece = Piece { key, ad: Mat::zeros(), bd: Inp::zeros(), ia: Mat::zeros(), ib: Inp::zeros() };
        piece.ad.view_mut((0, 0), (n, n)).copy_from(&d.ad);
        piece.bd.view_mut((0, 0), (n, 2)).copy_from(&d.bd);
        piece.ia.view_mut((0, 0), (n, n)).copy_from(&d.ia);
        piece.ib.view_mut((0, 0), (n, 2)).copy_from(&d.ib);
        piece
    }

    /// Index of the cached transition for `key`, computing it on a miss.
    fn cached(&mut self, key: Key) -> usize {
        if let Some(i) = self.cache.iter().position(|p| p.key == key) {
            return i;
        }
        let piece = self.piece(key);
        if self.cache.len() < CACHE_SLOTS {
            self.cache.push(piece);
            self.cache.len() - 1
        } else {
            let i = self.next_slot;
            self.cache[i] = piece;
            self.next_slot = (i + 1) % CACHE_SLOTS;
            i
        }
    }
}

/// `dil/dt` of the circuit `lti` at state `x` with inputs `u`.
fn derivative(lti: &Lti, x: &Vector4<f64>, u: &Vector2<f64>) -> f64 {
    let n = lti.states();
    (0..n).map(|j| lti.a[(0, j)] * x[j]).sum::<f64>() + lti.b[(0, 0)] * u[0] + lti.b[(0, 1)] * u[1]
}

/// `il(t)` and `dil/dt(t)` on the exact solution from `x0` with held inputs `u`:
/// `x(t) = e^{At}·x0 + Γ(t)·u` from the exponential of `[[A, B], [0, 0]]·t`.
fn il_at(lti: &Lti, x0: &Vector4<f64>, u: &Vector2<f64>, t: f64) -> (f64, f64) {
    let n = lti.states();
    let mut g = DMatrix::zeros(n + 2, n + 2);
    g.view_mut((0, 0), (n, n)).copy_from(&lti.a);
    g.view_mut((0, n), (n, 2)).copy_from(&lti.b);
    let e = (g * t).exp();
    let mut x = Vector4::zeros();
    for i in 0..n {
        x[i] = (0..n).map(|j| e[(i, j)] * x0[j]).sum::<f64>() + e[(i, n)] * u[0] + e[(i, n + 1)] * u[1];
    }
    (x[0], derivative(lti, &x, u))
}

/// The earliest instant in `(0, tau]` at which `il` reaches one of `levels` (each given with
/// the side `s` it starts on, so that `s·(il − level) ≥ 0` now), with that level.
///
/// A crossing is bracketed by the sign of `s·(il − level)` at the piece end, or, when the
/// current first moves towards the level and then away (an extremum inside the piece), by the
/// value at the extremum, found by bisection on `dil/dt`. Within one piece `il` is a smooth
/// sum of exponentials far slower than the period (at most one extremum), which is what this
/// relies on. The root is polished by Newton iteration kept inside the bracket.
fn first_crossing(
    lti: &Lti,
    x0: &Vector4<f64>,
    u: &Vector2<f64>,
    tau: f64,
    il_end: f64,
    levels: &[(f64, f64)],
    tol: f64,
) -> Option<(f64, f64)> {
    let mut best: Option<(f64, f64)> = None;
    let mut slopes: Option<(f64, f64)> = None;
    for &(level, side) in levels {
        let f = |t: f64| {
            let (il, dil) = il_at(lti, x0, u, t);
            (side * (il - level), side * dil)
        };
        let hi = if side * (il_end - level) <= 0.0 {
            tau
        } else {
            let (d0, d1) = *slopes.get_or_insert_with(|| (derivative(lti, x0, u), il_at(lti, x0, u, tau).1));
            let (d0, d1) = (side * d0, side * d1);
            if !(d0 < 0.0 && d1 > 0.0) {
                continue;
            }
            // The extremum of il: dil/dt changes sign once inside.
            let (mut lo, mut up) = (0.0, tau);
            while up - lo > tol {
                let mid = 0.5 * (lo + up);
                if f(mid).1 < 0.0 { lo = mid } else { up = mid }
            }
            if f(up).0 > 0.0 {
                continue;
            }
            up
        };
        let t = newton(f, hi, side * (x0[0] - level), tol);
        if best.is_none_or(|(b, _)| t < b) {
            best = Some((t, level));
        }
    }
    best
}

/// Root of `f` in `[0, hi]` with `f(0) = f0 ≥ 0 ≥ f(hi)`: Newton steps from the secant guess,
/// replaced by bisection whenever they leave the bracket.
fn newton(f: impl Fn(f64) -> (f64, f64), hi: f64, f0: f64, tol: f64) -> f64 {
    let (mut lo, mut up) = (0.0, hi);
    let f_hi = f(hi).0;
    let mut t = if f0 - f_hi > 0.0 { hi * f0 / (f0 - f_hi) } else { hi };
    for _ in 0..100 {
        let (v, dv) = f(t);
        if v > 0.0 {
            lo = t;
        } else {
            up = t;
        }
        if v == 0.0 || up - lo <= tol {
            return t;
        }
        let mut next = t - v / dv;
        if !(next > lo && next < up) {
            next = 0.5 * (lo + up);
        }
        if (next - t).abs() <= tol {
            return next;
        }
        t = next;
    }
    t
}

#[cfg(test)]
#[path = "converter_tests.rs"]
mod tests;

#[cfg(test)]
#[path = "effects_tests.rs"]
mod effects_tests;
