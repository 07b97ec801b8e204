//! The converter as a simulator: inputs, state, exact stepping over any step length.
use nalgebra::{SMatrix, Vector2, Vector3};
use serde::{Deserialize, Serialize};

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
}

impl Default for Inputs {
    fn default() -> Self {
        Self { duty: 0.5, io: 1.0, vin: 12.0 }
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
                Type::Mode { start } => Some(f64::from(start)),
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
        self.set(VarId::Vin, inputs.vin)
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
    /// inputs when `start_at_steady_state` is set (the default), from zero otherwise.
    pub fn initialize(&mut self) {
        let x0 = if self.start_at_steady_state {
            self.params.steady_state(self.inputs.duty, self.inputs.vin, self.inputs.io)
        } else {
            [0.0; 3]
        };
        self.set_state(State { il: x0[0], vc: x0[1], vo: x0[2] });
    }

    /// Current outputs.
    pub fn outputs(&self) -> Outputs {
        Outputs {
            vout: self.x[2],
            il: self.x[0],
            vc: self.x[1],
            vout_avg: self.last_average[2],
            il_avg: self.last_average[0],
        }
    }

    /// Reads a real variable of the table.
    pub fn get_real(&self, id: VarId) -> f64 {
        let y = self.outputs();
        let p = &self.params;
        match id {
            VarId::Duty => self.inputs.duty,
            VarId::Io => self.inputs.io,
            VarId::Vin => self.inputs.vin,
            VarId::Vout => y.vout,
            VarId::Il => y.il,
            VarId::Vc => y.vc,
            VarId::VoutAvg => y.vout_avg,
            VarId::IlAvg => y.il_avg,
            VarId::L => p.l,
            VarId::Rl => p.rl,
            VarId::C => p.c,
            VarId::Rc => p.rc,
            VarId::Cl => p.cl,
            VarId::Fs => p.fs,
            VarId::Mode => f64::from(self.mode_item()),
            VarId::SteadyStart => f64::from(u8::from(self.start_at_steady_state)),
        }
    }

    /// Writes an input or parameter after checking it against its declared range.
    ///
    /// Changing a parameter takes effect at once; call [`Converter::initialize`] to restart
    /// from the new operating point.
    pub fn set(&mut self, id: VarId, value: f64) -> Result<(), ModelError> {
        let var = &variables::VARIABLES[variables::vr(id) as usize];
        let value = match var.ty {
            Type::Real { .. } => var.check_real(value)?,
            Type::Mode { .. } => {
                let item = self.check_item(var.name, value)?;
                self.mode = if item == 1 { Mode::Averaged } else { Mode::Switched };
                return Ok(());
            }
            Type::Boolean { .. } => {
                self.start_at_steady_state = value != 0.0;
                return Ok(());
            }
        };
        let p = &mut self.params;
        match id {
            VarId::Duty => self.inputs.duty = value,
            VarId::Io => self.inputs.io = value,
            VarId::Vin => self.inputs.vin = value,
            VarId::L => p.l = value,
            VarId::Rl => p.rl = value,
            VarId::C => p.c = value,
            VarId::Rc => p.rc = value,
            VarId::Cl => p.cl = value,
            VarId::Fs => p.fs = value,
            _ => return Err(ModelError::NotSettable { name: var.name, when: "at all: it is an output" }),
        }
        if var.causality == variables::Causality::Parameter {
            self.cache.clear();
        }
        Ok(())
    }

    fn mode_item(&self) -> i32 {
        match self.mode {
            Mode::Averaged => 1,
            Mode::Switched => 2,
        }
    }

    fn check_item(&self, name: &'static str, value: f64) -> Result<i32, ModelError> {
        let n = variables::MODE_ITEMS.len();
        if value.fract() == 0.0 && value >= 1.0 && value <= n as f64 {
            Ok(value as i32)
        } else {
            let items: Vec<String> =
                variables::MODE_ITEMS.iter().enumerate().map(|(i, (s, _))| format!("{} = {s}", i + 1)).collect();
            Err(ModelError::OutOfRange { name, value, range: format!("one of {}", items.join(", ")) })
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
                self.latched_duty = self.inputs.duty;
                self.at_period_start = false;
            }
            let switch_off = match self.mode {
                Mode::Switched => self.latched_duty * period,
                Mode::Averaged => period,
            };
            let (event, u_sw) = if self.phase < switch_off {
                let u = match self.mode {
                    Mode::Switched => self.inputs.vin,
                    Mode::Averaged => self.inputs.duty * self.inputs.vin,
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
