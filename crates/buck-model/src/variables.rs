//! The one table of externally visible variables.
//!
//! The FMU's value references, its `modelDescription.xml` and its GUID are all derived from
//! [`VARIABLES`]; nothing else declares a variable. A variable's value reference is its index
//! in the table.
use sha2::{Digest, Sha256};

use crate::ModelError;

/// Identity of each variable, for code that reads or writes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[allow(missing_docs)] // the table below documents each one
pub enum VarId {
    Duty,
    Io,
    Vin,
    Vout,
    Il,
    Vc,
    VoutAvg,
    IlAvg,
    L,
    Rl,
    C,
    Rc,
    Cl,
    Fs,
    Mode,
    SteadyStart,
    Vref,
    Dither,
    DutyApplied,
    VoutAdc,
    IlAdc,
    Control,
    Kp,
    Ki,
    Kd,
    Delay,
    AdcBits,
    AdcVfs,
    AdcIfs,
    AdcNoise,
    NoiseSeed,
    DpwmBits,
    SwitchResistance,
    DiodeDrop,
    Dcm,
    DeadTime,
    LoadEsr,
    Esl,
    InductorSaturation,
    Isat,
    CapDcBias,
    CapRatedVoltage,
    Rload,
    DiodeResistance,
    SwitchNodeCapacitance,
    LowSideRatio,
    SwitchNodeRing,
    SwitchNodeDamping,
    AdcDelay,
    AdcFilter,
    DiodeEmission,
    PulseWidthDistortion,
    AdcIlFilter,
    AdcVoutSkew,
    AdcIlNoise,
}

/// FMI causality.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    /// Set by the user before initialization.
    Parameter,
    /// Set by the master at every communication point.
    Input,
    /// Computed by the model.
    Output,
}

/// FMI variability.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variability {
    /// Constant after initialization.
    Fixed,
    /// Changes continuously in time.
    Continuous,
}

/// FMI base type with its type-specific attributes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Type {
    /// A real number with unit and inclusive range.
    Real {
        /// Unit name (see [`UNITS`]).
        unit: &'static str,
        /// Smallest allowed value (inclusive).
        min: f64,
        /// Largest allowed value (inclusive).
        max: f64,
        /// Start value (`None` for calculated outputs).
        start: Option<f64>,
    },
    /// An integer with inclusive range. Choices such as `mode` are Integers rather than
    /// Enumerations because OSP libcosim ignores FMI 2.0 Enumerations; their description
    /// names the values.
    Integer {
        /// Smallest allowed value.
        min: i32,
        /// Largest allowed value.
        max: i32,
        /// Start value.
        start: i32,
    },
    /// A Boolean.
    Boolean {
        /// Start value.
        start: bool,
    },
}

/// One externally visible variable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Variable {
    /// Which quantity this is.
    pub id: VarId,
    /// Name in the FMU and the CLI.
    pub name: &'static str,
    /// FMI causality.
    pub causality: Causality,
    /// FMI variability.
    pub variability: Variability,
    /// Type and type-specific attributes.
    pub ty: Type,
    /// One-line description.
    pub description: &'static str,
}

const fn real(id: VarId, name: &'static str, causality: Causality, unit: &'static str, range: (f64, f64), start: Option<f64>, description: &'static str) -> Variable {
    let variability = if matches!(causality, Causality::Parameter) { Variability::Fixed } else { Variability::Continuous };
    Variable { id, name, causality, variability, ty: Type::Real { unit, min: range.0, max: range.1, start }, description }
}

const fn integer(id: VarId, name: &'static str, range: (i32, i32), start: i32, description: &'static str) -> Variable {
    Variable { id, name, causality: Causality::Parameter, variability: Variability::Fixed, ty: Type::Integer { min: range.0, max: range.1, start }, description }
}

const ANY: (f64, f64) = (f64::NEG_INFINITY, f64::INFINITY);
use Causality::{Input, Output, Parameter};

/// Every variable of the converter; the index is the FMI value reference.
#[rustfmt::skip] // a variable per line: the table reads as one
pub const VARIABLES: &[Variable] = &[
    real(VarId::Duty, "duty", Input, "1", (0.0, 1.0), Some(0.5), "Duty cycle command in open loop (latched at each period start)"),
    real(VarId::Io, "io", Input, "A", (-100.0, 100.0), Some(1.0), "Load current drawn from the output"),
    real(VarId::Vin, "vin", Input, "V", (0.0, 1000.0), Some(12.0), "Input voltage U"),
    real(VarId::Vout, "vout", Output, "V", ANY, None, "Output voltage (across Cl), instantaneous"),
    real(VarId::Il, "il", Output, "A", ANY, None, "Inductor current, instantaneous"),
    real(VarId::Vc, "vc", Output, "V", ANY, None, "Voltage of C behind its ESR, instantaneous"),
    real(VarId::VoutAvg, "vout_avg", Output, "V", ANY, None, "Exact average of vout over the last completed switching period"),
    real(VarId::IlAvg, "il_avg", Output, "A", ANY, None, "Exact average of il over the last completed switching period"),
    real(VarId::L, "L", Parameter, "H", (1e-9, 1.0), Some(3.3e-6), "Inductance"),
    real(VarId::Rl, "RL", Parameter, "Ohm", (0.0, 10.0), Some(0.1), "Inductor series resistance"),
    real(VarId::C, "C", Parameter, "F", (1e-9, 1.0), Some(100e-6), "Main output capacitance"),
    real(VarId::Rc, "Rc", Parameter, "Ohm", (1e-6, 10.0), Some(0.1), "Equivalent series resistance of C"),
    real(VarId::Cl, "Cl", Parameter, "F", (1e-9, 1.0), Some(10e-6), "Load capacitance"),
    real(VarId::Fs, "fs", Parameter, "Hz", (1.0, 1e8), Some(330e3), "Switching frequency"),
    integer(VarId::Mode, "mode", (1, 2), 1, "Switch-node model: 1 = averaged, 2 = switched (exact PWM)"),
    Variable {
        id: VarId::SteadyStart,
        name: "start_at_steady_state",
        causality: Parameter,
        variability: Variability::Fixed,
        ty: Type::Boolean { start: true },
        description: "Start from the averaged DC operating point of the initial inputs (else from zero)",
    },
    real(VarId::Vref, "vref", Input, "V", (0.0, 1000.0), Some(5.0), "Output voltage reference of the controller (control = 2)"),
    real(VarId::Dither, "duty_dither", Input, "1", (-1.0, 1.0), Some(0.0), "Added to the controller's duty, for excitation (control = 2)"),
    real(VarId::DutyApplied, "duty_applied", Output, "1", ANY, None, "Duty that drove the switch in the last latched period"),
    real(VarId::VoutAdc, "vout_adc", Output, "V", ANY, None, "The ADC's latest reading of vout, at the period start or adc_delay into the period (noise, quantization)"),
    real(VarId::IlAdc, "il_adc", Output, "A", ANY, None, "The ADC's latest reading of il, at the period start or adc_delay into the period (noise, quantization)"),
    integer(VarId::Control, "control", (1, 2), 1, "Who sets the duty: 1 = open loop (duty input), 2 = closed loop (PID on vref - vout_adc, plus duty_dither)"),
    real(VarId::Kp, "kp", Parameter, "1/V", (0.0, 100.0), Some(0.08), "Controller proportional gain"),
    real(VarId::Ki, "ki", Parameter, "1/V", (0.0, 100.0), Some(0.008), "Controller integral gain per period"),
    real(VarId::Kd, "kd", Parameter, "1/V", (0.0, 100.0), Some(0.3), "Controller derivative gain (on the error difference per period)"),
    integer(VarId::Delay, "delay", (0, 8), 0, "Periods between a duty command and the switch (computation delay in closed loop)"),
    integer(VarId::AdcBits, "adc_bits", (0, 24), 0, "ADC resolution on vout and il (0 = ideal)"),
    real(VarId::AdcVfs, "adc_vfs", Parameter, "V", (1e-3, 1e4), Some(16.0), "ADC full scale of vout, unipolar"),
    real(VarId::AdcIfs, "adc_ifs", Parameter, "A", (1e-3, 1e4), Some(32.0), "ADC full scale of il, bipolar"),
    real(VarId::AdcNoise, "adc_noise", Parameter, "V", (0.0, 10.0), Some(0.0), "Standard deviation of white sensor noise on vout at the ADC"),
    integer(VarId::NoiseSeed, "noise_seed", (0, i32::MAX), 1, "Seed of the ADC noise"),
    integer(VarId::DpwmBits, "dpwm_bits", (0, 24), 0, "Resolution of the DPWM duty register (0 = ideal)"),
    real(VarId::SwitchResistance, "switch_resistance", Parameter, "Ohm", (0.0, 10.0), Some(0.0), "On-resistance of each switch, in series with RL while a switch conducts (both modes)"),
    real(VarId::DiodeDrop, "diode_drop", Parameter, "V", (0.0, 5.0), Some(0.0), "Forward drop of the freewheeling diode; > 0 makes the buck asynchronous with DCM (switched mode only)"),
    Variable {
        id: VarId::Dcm,
        name: "dcm",
        causality: Parameter,
        variability: Variability::Fixed,
        ty: Type::Boolean { start: false },
        description: "Asynchronous buck (diode low side, also with diode_drop = 0): il stops at 0 in discontinuous conduction (switched mode only)",
    },
    real(VarId::DeadTime, "dead_time", Parameter, "s", (0.0, 1e-5), Some(0.0), "Each turn-on delayed after its PWM edge; body diodes conduct meanwhile (switched mode only)"),
    real(VarId::LoadEsr, "load_esr", Parameter, "Ohm", (0.0, 10.0), Some(0.0), "Series resistance of Cl; vout is then the output node voltage (both modes)"),
    real(VarId::Esl, "esl", Parameter, "H", (0.0, 1e-6), Some(0.0), "Series inductance of the C branch (both modes)"),
    real(VarId::InductorSaturation, "inductor_saturation", Parameter, "1", (0.0, 0.9), Some(0.0), "Fraction of L lost for |il| > isat (both modes)"),
    real(VarId::Isat, "isat", Parameter, "A", (1e-3, 1e4), Some(10.0), "Saturation current of the inductor"),
    real(VarId::CapDcBias, "cap_dc_bias", Parameter, "1", (0.0, 0.9), Some(0.0), "Fraction of Cl lost at cap_rated_voltage, Cl(v) = Cl (1 - cap_dc_bias (v/V_rated)^2), capped at V_rated, held over each period at its value for the mid-period voltage (both modes)"),
    real(VarId::CapRatedVoltage, "cap_rated_voltage", Parameter, "V", (0.1, 1000.0), Some(16.0), "Rated voltage of Cl for cap_dc_bias"),
    real(VarId::Rload, "rload", Parameter, "Ohm", (0.0, 1e9), Some(0.0), "Load resistance from the output node vout to ground, beside the load current io; 0 = none (both modes)"),
    real(VarId::DiodeResistance, "diode_resistance", Parameter, "Ohm", (0.0, 10.0), Some(0.0), "Slope resistance of the freewheeling and body diodes: a conducting diode drops its forward voltage plus diode_resistance |il| (switched mode only)"),
    real(VarId::SwitchNodeCapacitance, "switch_node_capacitance", Parameter, "F", (0.0, 1e-6), Some(0.0), "Capacitance of the switch node, charged by il while both switches are off (dead time, the diode buck's turn-off): the node slews between the rails (switched mode only)"),
    real(VarId::LowSideRatio, "low_side_ratio", Parameter, "1", (0.01, 100.0), Some(1.0), "On-resistance of the low-side switch over the high side's switch_resistance; 1 = equal switches (synchronous buck, both modes)"),
    Variable {
        id: VarId::SwitchNodeRing,
        name: "switch_node_ring",
        causality: Parameter,
        variability: Variability::Fixed,
        ty: Type::Boolean { start: false },
        description: "Once the diode blocks (DCM), il rings with switch_node_capacitance (the node swings about vout until the next turn-on or a diode clamp) instead of holding at 0 (switched mode only; not with esl)",
    },
    real(VarId::SwitchNodeDamping, "switch_node_damping", Parameter, "Ohm", (0.0, 1e4), Some(0.0), "Resistance in series with switch_node_capacitance (an RC snubber's resistor): damps the ring, and at an edge the node jumps by switch_node_damping |il| before it slews (switched mode only)"),
    real(VarId::AdcDelay, "adc_delay", Parameter, "s", (0.0, 1.0), Some(0.0), "Instant of the ADC's reading after each period start, below the period: vout_adc, il_adc and the controller read vout and il there (0 = at the period start; switched mode only)"),
    real(VarId::AdcFilter, "adc_filter", Parameter, "s", (0.0, 1.0), Some(0.0), "Time constant of the RC anti-alias filter in front of the ADC's vout channel: vout_adc and the controller read vout through it (0 = no filter; a corner near half the switching frequency is tau = 1/(pi fs))"),
    real(VarId::DiodeEmission, "diode_emission", Parameter, "V", (0.0, 0.5), Some(0.0), "Emission voltage n Vt of the diodes' exponential (Shockley) law: a conducting diode drops diode_emission ln(1 + |il|/Is) + diode_resistance |il|, Is set so that the drop at 1 A is diode_drop + diode_resistance 1 A (0 = the straight line diode_drop + diode_resistance |il|; switched mode only)"),
    real(VarId::PulseWidthDistortion, "pulse_width_distortion", Parameter, "s", (-1e-5, 1e-5), Some(0.0), "The high side's on-time beyond the PWM's duty T, signed: the gate drive's turn-off delay minus its turn-on delay; the on-time held within [0, T], none made at duty 0 (both modes)"),
    real(VarId::AdcIlFilter, "adc_il_filter", Parameter, "s", (0.0, 1.0), Some(0.0), "Time constant of the first-order low-pass in front of the ADC's il channel (a current-sense amplifier's bandwidth or the channel's anti-alias filter): il_adc reads il through it (0 = no filter)"),
    real(VarId::AdcVoutSkew, "adc_vout_skew", Parameter, "s", (-1.0, 1.0), Some(0.0), "How long after il the ADC converts vout, signed (a multiplexed ADC converts its channels one after the other): il_adc reads il at adc_delay, vout_adc and the controller read vout at adc_delay + adc_vout_skew, which must lie within the period (0 = one instant; switched mode only)"),
    real(VarId::AdcIlNoise, "adc_il_noise", Parameter, "A", (0.0, 100.0), Some(0.0), "Standard deviation of white sensor noise on il at the ADC, independent of the noise on vout (same noise_seed)"),
];

/// Units used by the table with their SI base-unit exponents `(kg, m, s, A)`.
pub const UNITS: &[(&str, [i32; 4])] = &[
    ("1", [0, 0, 0, 0]),
    ("A", [0, 0, 0, 1]),
    ("V", [1, 2, -3, -1]),
    ("Ohm", [1, 2, -3, -2]),
    ("H", [1, 2, -2, -2]),
    ("F", [-1, -2, 4, 2]),
    ("Hz", [0, 0, -1, 0]),
    ("s", [0, 0, 1, 0]),
    ("1/V", [-1, -2, 3, 1]),
];

impl Variable {
    /// The FMI value reference (the index in [`VARIABLES`]).
    pub fn vr(&self) -> u32 {
        vr(self.id)
    }

    /// Checks a real value against the declared range; NaN is always rejected.
    pub fn check_real(&self, value: f64) -> Result<f64, ModelError> {
        match self.ty {
            Type::Real { min, max, .. } if value >= min && value <= max => Ok(value),
            Type::Real { unit, min, max, .. } => Err(ModelError::OutOfRange {
                name: self.name,
                value,
                range: format!("within [{}, {}]{}", engineering(min), engineering(max), if unit == "1" { String::new() } else { format!(" {unit}") }),
            }),
            _ => Err(ModelError::UnknownReference { vr: self.vr(), kind: "Real" }),
        }
    }

    /// Checks an integer value (given as `f64`) against the declared range.
    pub fn check_integer(&self, value: f64) -> Result<i32, ModelError> {
        match self.ty {
            Type::Integer { min, max, .. } if value.fract() == 0.0 && value >= f64::from(min) && value <= f64::from(max) => Ok(value as i32),
            Type::Integer { min, max, .. } => Err(ModelError::OutOfRange { name: self.name, value, range: format!("an integer within [{min}, {max}]") }),
            _ => Err(ModelError::UnknownReference { vr: self.vr(), kind: "Integer" }),
        }
    }
}

/// Plain decimals for everyday magnitudes, exponent notation for tiny or huge ones.
fn engineering(x: f64) -> String {
    if x == 0.0 || (1e-3..1e6).contains(&x.abs()) { format!("{x}") } else { format!("{x:e}") }
}

/// Value reference of a variable.
pub fn vr(id: VarId) -> u32 {
    // The table is small and the position is its contract; a test pins that every id is present.
    VARIABLES.iter().position(|v| v.id == id).map_or(u32::MAX, |i| i as u32)
}

/// Looks a variable up by value reference.
pub fn by_vr(vr: u32) -> Option<&'static Variable> {
    VARIABLES.get(vr as usize)
}

/// Looks a variable up by name.
pub fn by_name(name: &str) -> Option<&'static Variable> {
    VARIABLES.iter().find(|v| v.name == name)
}

/// The declared range `[min, max]` of the real variable `name`, `None` for any other.
pub fn real_range(name: &str) -> Option<(f64, f64)> {
    match by_name(name)?.ty {
        Type::Real { min, max, .. } => Some((min, max)),
        _ => None,
    }
}

/// GUID derived from the table, so that an FMU binary rejects a modelDescription.xml that was
/// generated from another table.
pub fn guid() -> String {
    let mut hash = Sha256::new();
    for v in VARIABLES {
        hash.update(format!("{}|{:?}|{:?}|{:?}|{:?}|{}\n", v.name, v.id, v.causality, v.variability, v.ty, v.description));
    }
    let h = hash.finalize();
    let hex: String = h.iter().take(16).map(|b| format!("{b:02x}")).collect();
    format!("{{{}-{}-{}-{}-{}}}", &hex[0..8], &hex[8..12], &hex[12..16], &hex[16..20], &hex[20..32])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_every_id_is_present() {
        for (i, v) in VARIABLES.iter().enumerate() {
            assert_eq!(v.vr() as usize, i, "{} appears twice", v.name);
            assert_eq!(by_name(v.name).map(|w| w.id), Some(v.id), "name {} is not unique", v.name);
        }
    }

    #[test]
    fn units_are_declared() {
        for v in VARIABLES {
            if let Type::Real { unit, .. } = v.ty {
                assert!(UNITS.iter().any(|(u, _)| *u == unit), "unit {unit} of {} undeclared", v.name);
            }
        }
    }

    #[test]
    fn range_check_names_the_variable_and_rejects_nan() {
        let duty = by_name("duty").unwrap();
        assert_eq!(duty.check_real(0.4), Ok(0.4));
        let err = duty.check_real(1.2).unwrap_err().to_string();
        assert!(err.contains("duty") && err.contains("1.2"), "{err}");
        assert!(duty.check_real(f64::NAN).is_err());
        assert!(by_name("L").unwrap().check_real(0.0).is_err());
    }

    #[test]
    fn guid_is_stable_and_well_formed() {
        let g = guid();
        assert_eq!(g, guid());
        assert_eq!(g.len(), 38);
        assert!(g.starts_with('{') && g.ends_with('}'));
    }
}
