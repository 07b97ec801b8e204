//! The converter as a simulator: inputs, state, exact stepping over any step length.
use nalgebra::{SMatrix, Vector2, Vector3};
use serde::{Deserialize, Serialize};

use crate::digital::{Control, Digital};
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
    /// Output voltage across Cl [V].
    pub vo: f64,
}

/// Everything the converter reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outputs {
    /// Instantaneous output voltage [V].
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
/// Pieces with cached transition matrices (PRBS between two duty levels needs four).
const CACHE_SLOTS: usize = 8;

type Phi = SMatrix<f64, 6, 6>;
type Gamma = SMatrix<f64, 6, 2>;

/// Transition of `[x; ∫x]` over one held-input piece: `ξ(τ) = phi·ξ(0) + gamma·[u_sw, io]`.
#[derive(Debug, Clone)]
struct Piece {
    tau_bits: u64,
    phi: Phi,
    gamma: Gamma,
}

/// A buck converter that advances exactly over steps of any length.
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
    /// `[il, vc, vo]`.
    x: Vector3<f64>,
    /// Integral of `x` since the start of the current period.
    z: Vector3<f64>,
    /// Time since the start of the current period [s].
    phase: f64,
    /// Duty in force during the current period (latched at its start).
    latched_duty: f64,
    /// The next piece starts a new period and must latch the duty first.
    at_period_start: bool,
    /// Averages `[il, vc, vo]` over the last completed period.
    last_average: Vector3<f64>,
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
            x: Vector3::zeros(),
            z: Vector3::zeros(),
            phase: 0.0,
            latched_duty: 0.0,
            at_period_start: true,
            last_average: Vector3::zeros(),
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
        State { il: self.x[0], vc: self.x[1], vo: self.x[2] }
    }

    /// Puts the circuit at the start of a period in the given state, e.g. from an initial
    /// condition computed elsewhere.
    pub fn set_state(&mut self, s: State) {
        self.x = Vector3::new(s.il, s.vc, s.vo);
        self.z = Vector3::zeros();
        self.phase = 0.0;
        self.at_period_start = true;
        self.last_average = self.x;
    }

    /// Starts a new run at a period start: from the averaged DC operating point of the current
    /// inputs when `start_at_steady_state` is set (the default), from zero otherwise. In closed
    /// loop the operating point is the one where `vout = vref`, and the controller starts there.
    pub fn initialize(&mut self) {
        let Inputs { duty, io, vin, vref, .. } = self.inputs;
        let d0 = match self.digital.control {
            Control::Open => duty,
            Control::Closed if vin > 0.0 => ((vref + self.params.rl * io) / vin).clamp(0.0, 1.0),
            Control::Closed => 0.0,
        };
        let x0 = if self.start_at_steady_state { self.params.steady_state(d0, vin, io) } else { [0.0; 3] };
        self.set_state(State { il: x0[0], vc: x0[1], vo: x0[2] });
        self.period_index = 0;
        self.digital.restart(d0, x0[2], x0[0]);
    }

    /// Current outputs.
    pub fn outputs(&self) -> Outputs {
        Outputs {
            vout: self.x[2],
            il: self.x[0],
            vc: self.x[1],
            vout_avg: self.last_average[2],
            il_avg: self.last_average[0],
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
                    VarId::Kp => d.kp = value,
                    VarId::Ki => d.ki = value,
                    VarId::Kd => d.kd = value,
                    VarId::AdcVfs => d.adc_vfs = value,
                    VarId::AdcIfs => d.adc_ifs = value,
                    VarId::AdcNoise => d.adc_noise = value,
                    _ => return Err(ModelError::NotSettable { name: var.name, when: "at all: it is an output" }),
                }
                if matches!(id, VarId::L | VarId::Rl | VarId::C | VarId::Rc | VarId::Cl | VarId::Fs) {
                    self.cache.clear();
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
            Type::Boolean { .. } => self.start_at_steady_state = value != 0.0,
        }
        Ok(())
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
                self.at_period_start = false;
            }
            let switch_off = match self.mode {
                Mode::Switched => self.latched_duty * period,
                Mode::Averaged => period,
            };
            let (event, u_sw) = if self.phase < switch_off {
                let u = match self.mode {
                    Mode::Switched => self.inputs.vin,
                    Mode::Averaged => self.latched_duty * self.inputs.vin,
                };
                (switch_off, u)
            } else {
                (period, 0.0)
            };
            let to_event = event - self.phase;
            if remaining + snap < to_event {
                // The step ends before the next event: advance exactly, however short.
                self.advance(remaining, u_sw);
                self.phase += remaining;
                break;
            }
            self.advance(to_event, u_sw);
            remaining -= to_event;
            self.phase = event;
            if event >= period {
                self.last_average = self.z / period;
                self.z = Vector3::zeros();
                self.phase = 0.0;
                self.at_period_start = true;
                self.period_index += 1;
                self.digital.sample(self.x[2], self.x[0], self.period_index);
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

    /// Advances `[x; z]` over one piece of length `tau` with the switch node held at `u_sw`.
    fn advance(&mut self, tau: f64, u_sw: f64) {
        if tau <= 0.0 {
            return;
        }
        let piece = self.piece(tau);
        let xi = nalgebra::Vector6::new(self.x[0], self.x[1], self.x[2], self.z[0], self.z[1], self.z[2]);
        let next = piece.phi * xi + piece.gamma * Vector2::new(u_sw, self.inputs.io);
        self.x = next.fixed_rows::<3>(0).into_owned();
        self.z = next.fixed_rows::<3>(3).into_owned();
    }

    fn piece(&mut self, tau: f64) -> Piece {
        let bits = tau.to_bits();
        if let Some(p) = self.cache.iter().find(|p| p.tau_bits == bits) {
            return p.clone();
        }
        let d = self.params.full_lti().discretize(tau);
        let mut phi = Phi::zeros();
        let mut gamma = Gamma::zeros();
        phi.fixed_view_mut::<3, 3>(0, 0).copy_from(&d.ad);
        phi.fixed_view_mut::<3, 3>(3, 0).copy_from(&d.ia);
        phi.fixed_view_mut::<3, 3>(3, 3).fill_with_identity();
        gamma.fixed_view_mut::<3, 2>(0, 0).copy_from(&d.bd);
        gamma.fixed_view_mut::<3, 2>(3, 0).copy_from(&d.ib);
        let piece = Piece { tau_bits: bits, phi, gamma };
        if self.cache.len() < CACHE_SLOTS {
            self.cache.push(piece.clone());
        } else {
            self.cache[self.next_slot] = piece.clone();
            self.next_slot = (self.next_slot + 1) % CACHE_SLOTS;
        }
        piece
    }
}

#[cfg(test)]
#[path = "converter_tests.rs"]
mod tests;
