//! One FMU instance behind the FMI boundary: the FMI 2.0 Co-Simulation state machine, value
//! access by reference, and FMU states. Safe code; `ffi.rs` only converts pointers to slices.
use buck_model::Converter;
use buck_model::variables::{self, Causality, Type, Variable};
use serde::{Deserialize, Serialize};

/// Outcome of a call, mapped one-to-one onto `fmi2Status` at the boundary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Success.
    Ok,
    /// Success with something the user should know.
    Warning,
    /// The call was not carried out, the instance is unharmed.
    Discard,
    /// The call failed; the instance is in the error state (reset or restore a state).
    Error,
    /// The instance is unusable.
    Fatal,
}

/// Phases of the FMI 2.0 Co-Simulation state machine that this FMU can be in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Phase {
    /// After `fmi2Instantiate` or `fmi2Reset`.
    Instantiated,
    /// Between enter and exit initialization mode.
    InitializationMode,
    /// Ready for `fmi2DoStep`.
    StepComplete,
    /// After `fmi2Terminate`.
    Terminated,
    /// A call returned `fmi2Error`.
    Error,
    /// A call returned `fmi2Fatal`.
    Fatal,
}

impl Phase {
    const fn bit(self) -> u8 {
        1 << self as u8
    }
}

/// Sets of phases in which a call is allowed (FMI 2.0 §4.2.4, state-machine table).
mod allowed {
    use super::Phase::*;
    const fn mask(phases: &[super::Phase]) -> u8 {
        let mut m = 0;
        let mut i = 0;
        while i < phases.len() {
            m |= phases[i].bit();
            i += 1;
        }
        m
    }
    pub const ANY_BUT_FATAL: u8 = mask(&[Instantiated, InitializationMode, StepComplete, Terminated, Error]);
    pub const INSTANTIATED: u8 = mask(&[Instantiated]);
    pub const INIT_MODE: u8 = mask(&[InitializationMode]);
    pub const STEP_COMPLETE: u8 = mask(&[StepComplete]);
    pub const GET: u8 = mask(&[InitializationMode, StepComplete, Terminated, Error]);
    pub const SET: u8 = mask(&[Instantiated, InitializationMode, StepComplete]);
    pub const STATUS: u8 = mask(&[StepComplete, Terminated]);
}

/// Receives log messages: status, category, message.
pub type Logger = Box<dyn Fn(Status, &str, &str)>;

/// Saved FMU state: enough to continue exactly where it was taken.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Snapshot {
    phase: Phase,
    converter: Converter,
}

/// Tag in front of serialized states, so that foreign or stale bytes are rejected (04: the
/// parameters carry the bias law's shape).
const STATE_MAGIC: &[u8; 8] = b"BUCKST07";

/// Most switching periods one `fmi2DoStep` may cross (≈ 1 s of computing in switched mode).
/// Without a bound, a step of 1e6 s or a huge `fs` restored from a state loops for hours: the
/// host would see a hang, not an error (found by the hostile-host harness).
pub const MAX_PERIODS_PER_STEP: f64 = 1e7;

/// FNV-1a 64 of the serialized body, stored after it: postcard reads most bit flips of a
/// state as other valid numbers (a NaN inductance, a phase past the period), so a corrupted
/// state must be caught before it is decoded, not by the physics that then hangs or panics.
fn checksum(bytes: &[u8]) -> [u8; 8] {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
    }
    h.to_le_bytes()
}

/// An FMU instance.
pub struct Instance {
    converter: Converter,
    phase: Phase,
    logger: Logger,
    log_calls: bool,
    /// Addresses of the FMU states this instance allocated and the host has not freed: freed
    /// with the instance (FMI 2.0 `fmi2FreeInstance` frees all memory the FMU allocated; a host
    /// that forgot them leaked, found by valgrind), and a pointer not in here is refused
    /// instead of being dereferenced (a state freed twice or another instance's).
    pub(crate) states: std::collections::HashSet<usize>,
}

impl Instance {
    /// Creates an instance after checking the GUID the host read from the modelDescription.
    pub fn new(guid: &str, logger: Logger) -> Result<Self, String> {
        let expected = variables::guid();
        if guid != expected {
            let msg = format!(
                "fmi2Instantiate: GUID {guid} does not match this binary's {expected}; \
                 the modelDescription.xml was generated from another variable table"
            );
            logger(Status::Error, "logStatusError", &msg);
            return Err(msg);
        }
        Ok(Self { converter: default_converter(), phase: Phase::Instantiated, logger, log_calls: false, states: Default::default() })
    }

    /// Current phase of the state machine.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    fn error(&mut self, func: &str, msg: impl std::fmt::Display) -> Status {
        (self.logger)(Status::Error, "logStatusError", &format!("{func}: {msg}"));
        if self.phase != Phase::Fatal {
            self.phase = Phase::Error;
        }
        Status::Error
    }

    /// Marks the instance unusable after a panic inside `func`.
    pub fn fatal(&mut self, func: &str) {
        self.phase = Phase::Fatal;
        (self.logger)(Status::Fatal, "logStatusError", &format!("{func}: internal error (panic); instance is unusable"));
    }

    /// Checks the call order; logs and returns `Err(Status::Error)` when `func` is not allowed now.
    fn enter(&mut self, func: &str, allowed: u8) -> Result<(), Status> {
        if self.log_calls {
            (self.logger)(Status::Ok, "logCalls", func);
        }
        if allowed & self.phase.bit() != 0 {
            Ok(())
        } else if self.phase == Phase::Fatal {
            (self.logger)(Status::Fatal, "logStatusError", &format!("{func}: instance is unusable after a fatal error"));
            Err(Status::Fatal)
        } else {
            let phase = self.phase;
            Err(self.error(func, format!("not allowed in phase {phase:?}")))
        }
    }

    /// `fmi2SetDebugLogging`.
    pub fn set_debug_logging(&mut self, on: bool, categories: &[&str]) -> Status {
        if let Err(s) = self.enter("fmi2SetDebugLogging", allowed::ANY_BUT_FATAL) {
            return s;
        }
        let known = |c: &&str| crate::description::LOG_CATEGORIES.iter().any(|(n, _)| n == c);
        if let Some(bad) = categories.iter().find(|c| !known(c)) {
            return self.error("fmi2SetDebugLogging", format!("unknown log category {bad:?}"));
        }
        self.log_calls = on && (categories.is_empty() || categories.contains(&"logCalls"));
        Status::Ok
    }

    /// `fmi2SetupExperiment`.
    pub fn setup_experiment(&mut self, start_time: f64) -> Status {
        if let Err(s) = self.enter("fmi2SetupExperiment", allowed::INSTANTIATED) {
            return s;
        }
        if !start_time.is_finite() {
            return self.error("fmi2SetupExperiment", format!("startTime {start_time} is not finite"));
        }
        self.converter.set_time(start_time);
        Status::Ok
    }

    /// `fmi2EnterInitializationMode`.
    pub fn enter_initialization_mode(&mut self) -> Status {
        if let Err(s) = self.enter("fmi2EnterInitializationMode", allowed::INSTANTIATED) {
            return s;
        }
        self.converter.initialize();
        self.phase = Phase::InitializationMode;
        Status::Ok
    }

    /// `fmi2ExitInitializationMode`: the state starts at the operating point of the inputs and
    /// parameters set so far.
    pub fn exit_initialization_mode(&mut self) -> Status {
        if let Err(s) = self.enter("fmi2ExitInitializationMode", allowed::INIT_MODE) {
            return s;
        }
        self.converter.initialize();
        self.phase = Phase::StepComplete;
        Status::Ok
    }

    /// `fmi2Terminate`.
    pub fn terminate(&mut self) -> Status {
        if let Err(s) = self.enter("fmi2Terminate", allowed::STEP_COMPLETE) {
            return s;
        }
        self.phase = Phase::Terminated;
        Status::Ok
    }

    /// `fmi2Reset`: back to the state right after instantiation (start values).
    pub fn reset(&mut self) -> Status {
        if let Err(s) = self.enter("fmi2Reset", allowed::ANY_BUT_FATAL) {
            return s;
        }
        self.converter = default_converter();
        self.phase = Phase::Instantiated;
        Status::Ok
    }

    fn variable(&mut self, func: &str, vr: u32, want: &str) -> Result<&'static Variable, Status> {
        let Some(var) = variables::by_vr(vr) else {
            return Err(self.error(func, format!("no variable has value reference {vr}")));
        };
        let kind = match var.ty {
            Type::Real { .. } => "Real",
            Type::Integer { .. } => "Integer",
            Type::Boolean { .. } => "Boolean",
        };
        if kind != want {
            return Err(self.error(func, format!("value reference {vr} is {} of type {kind}, not {want}", var.name)));
        }
        Ok(var)
    }

    /// Reads variables of one base type as `f64` (Integer and Boolean are exact in `f64`).
    pub fn get(&mut self, func: &str, kind: &str, vrs: &[u32], out: &mut [f64]) -> Status {
        if let Err(s) = self.enter(func, allowed::GET) {
            return s;
        }
        for (vr, slot) in vrs.iter().zip(out.iter_mut()) {
            match self.variable(func, *vr, kind) {
                Ok(var) => *slot = self.converter.get_real(var.id),
                Err(s) => return s,
            }
        }
        Status::Ok
    }

    /// Writes variables of one base type given as `f64`, checking each against its range and
    /// whether it may be set in the current phase.
    pub fn set(&mut self, func: &str, kind: &str, vrs: &[u32], values: &[f64]) -> Status {
        if let Err(s) = self.enter(func, allowed::SET) {
            return s;
        }
        let initializing = matches!(self.phase, Phase::Instantiated | Phase::InitializationMode);
        for (vr, value) in vrs.iter().zip(values) {
            let var = match self.variable(func, *vr, kind) {
                Ok(var) => var,
                Err(s) => return s,
            };
            match var.causality {
                Causality::Output => return self.error(func, format!("{} is an output and cannot be set", var.name)),
                Causality::Parameter if !initializing => {
                    return self.error(func, format!("{} is a fixed parameter: set it before fmi2ExitInitializationMode", var.name));
                }
                _ => {}
            }
            if let Err(e) = self.converter.set(var.id, *value) {
                return self.error(func, e);
            }
        }
        if initializing {
            // Outputs read during initialization reflect the operating point set so far.
            self.converter.initialize();
        }
        Status::Ok
    }

    /// `fmi2DoStep`.
    pub fn do_step(&mut self, current_time: f64, step: f64) -> Status {
        const FUNC: &str = "fmi2DoStep";
        if let Err(s) = self.enter(FUNC, allowed::STEP_COMPLETE) {
            return s;
        }
        if !(step > 0.0 && step.is_finite()) {
            return self.error(FUNC, format!("communicationStepSize {step} must be positive and finite"));
        }
        // Masters accumulate time in their own arithmetic; adopt theirs unless it is off by
        // more than half a step, which means a skipped or repeated step.
        let own = self.converter.time();
        let offset = (current_time - own).abs();
        if offset.is_nan() || offset > 0.5 * step {
            return self.error(FUNC, format!("currentCommunicationPoint {current_time} does not continue from the FMU time {own}"));
        }
        let periods = step * self.converter.params().fs;
        if periods.is_nan() || periods > MAX_PERIODS_PER_STEP {
            return self.error(
                FUNC,
                format!(
                    "communicationStepSize {step} s spans {periods:e} switching periods, more than the \
                     {MAX_PERIODS_PER_STEP:e} one call may take; split it into shorter steps"
                ),
            );
        }
        self.converter.set_time(current_time);
        match self.converter.step(step) {
            Ok(()) => Status::Ok,
            Err(e) => self.error(FUNC, e),
        }
    }

    /// `fmi2GetRealStatus(fmi2LastSuccessfulTime)`.
    pub fn last_successful_time(&mut self) -> Result<f64, Status> {
        self.enter("fmi2GetRealStatus", allowed::STATUS)?;
        Ok(self.converter.time())
    }

    /// `fmi2GetBooleanStatus(fmi2Terminated)`: this FMU never asks to stop.
    pub fn wants_to_terminate(&mut self) -> Result<bool, Status> {
        self.enter("fmi2GetBooleanStatus", allowed::STATUS)?;
        Ok(false)
    }

    /// Logs and rejects a call this FMU does not support (declared so in the modelDescription).
    pub fn unsupported(&mut self, func: &str, why: &str) -> Status {
        if let Err(s) = self.enter(func, allowed::ANY_BUT_FATAL) {
            return s;
        }
        self.error(func, why)
    }

    /// `fmi2GetFMUstate`.
    pub fn snapshot(&mut self) -> Result<Snapshot, Status> {
        self.enter("fmi2GetFMUstate", allowed::ANY_BUT_FATAL)?;
        Ok(Snapshot { phase: self.phase, converter: self.converter.clone() })
    }

    /// `fmi2SetFMUstate`: also leaves the error phase.
    pub fn restore(&mut self, snapshot: &Snapshot) -> Status {
        if let Err(s) = self.enter("fmi2SetFMUstate", allowed::ANY_BUT_FATAL) {
            return s;
        }
        self.converter = snapshot.converter.clone();
        self.phase = snapshot.phase;
        Status::Ok
    }

    /// `fmi2SerializeFMUstate` (size and bytes).
    pub fn serialize(&mut self, func: &str, snapshot: &Snapshot) -> Result<Vec<u8>, Status> {
        self.enter(func, allowed::ANY_BUT_FATAL)?;
        let bytes = STATE_MAGIC.to_vec();
        match postcard::to_extend(snapshot, bytes) {
            Ok(mut bytes) => {
                let sum = checksum(&bytes[STATE_MAGIC.len()..]);
                bytes.extend_from_slice(&sum);
                Ok(bytes)
            }
            Err(e) => Err(self.error(func, format!("cannot serialize: {e}"))),
        }
    }

    /// `fmi2DeSerializeFMUstate`.
    pub fn deserialize(&mut self, bytes: &[u8]) -> Result<Snapshot, Status> {
        const FUNC: &str = "fmi2DeSerializeFMUstate";
        self.enter(FUNC, allowed::ANY_BUT_FATAL)?;
        let Some(rest) = bytes.strip_prefix(STATE_MAGIC.as_slice()) else {
            return Err(self.error(FUNC, "the bytes are not a serialized state of this FMU"));
        };
        let Some((body, sum)) = rest.split_last_chunk::<8>() else {
            return Err(self.error(FUNC, format!("corrupt serialized state: {} bytes are too few", bytes.len())));
        };
        if checksum(body) != *sum {
            return Err(self.error(FUNC, "corrupt serialized state: the checksum does not match (truncated or altered bytes)"));
        }
        let snapshot: Snapshot = postcard::from_bytes(body).map_err(|e| self.error(FUNC, format!("corrupt serialized state: {e}")))?;
        // A state that passes the checksum but holds out-of-range parameters (a crafted one) is
        // refused like a bad fmi2SetReal.
        if let Err(e) = snapshot.converter.params().validate() {
            return Err(self.error(FUNC, format!("serialized state holds invalid parameters: {e}")));
        }
        Ok(snapshot)
    }
}

fn default_converter() -> Converter {
    Converter::from_start_values()
}

#[cfg(test)]
#[path = "instance_tests.rs"]
mod tests;
