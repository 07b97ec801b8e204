use serde::{Deserialize, Serialize};

use crate::ModelError;
use crate::lti::Lti;
use nalgebra::DMatrix;

/// Circuit parameters of the buck power stage (SI units). Defaults are the BMR450 thesis values
/// with every non-ideal effect off.
///
/// The effect fields carry the names of the design's effects table (a contract with the CLI and
/// JSON). `switch_resistance`, `load_esr`, `esl`, `inductor_saturation` and `cap_dc_bias` apply
/// in both modes; `diode_drop`, `diode_resistance`, `dcm`, `dead_time`, `switch_node_capacitance`
/// and `switch_node_ring` describe the switching of the half bridge and apply in
/// [`Mode::Switched`] only (the averaged model ignores them).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Params {
    /// Inductance `L` \[H\].
    pub l: f64,
    /// Inductor series resistance `RL` \[Ω\].
    pub rl: f64,
    /// Main output capacitance `C` \[F\].
    pub c: f64,
    /// Equivalent series resistance of `C`, `Rc` \[Ω\].
    pub rc: f64,
    /// Load capacitance `Cl` \[F\].
    pub cl: f64,
    /// Switching frequency `fs` \[Hz\].
    pub fs: f64,
    /// `switch_resistance`: on-resistance of each switch of the synchronous half bridge \[Ω\],
    /// in series with `RL` while a switch (not a diode) conducts.
    pub switch_resistance: f64,
    /// On-resistance of the low-side switch over the high side's (`switch_resistance`): 1 (the
    /// default) for equal switches. A real half bridge pairs a fast high side with a larger,
    /// lower-resistance low side, so the series resistance depends on the duty:
    /// `d·Rhs + (1 − d)·Rls` on average. Synchronous buck, both modes.
    pub low_side_ratio: f64,
    /// `diode_drop`: forward drop of the freewheeling diode \[V\]. Positive makes the buck
    /// asynchronous (the low side is a diode); also the body-diode drop during dead time.
    pub diode_drop: f64,
    /// Slope resistance of the diodes \[Ω\]: a conducting diode (the freewheeling diode, a body
    /// diode during dead time) drops `Vf + diode_resistance·|il|`, the threshold-voltage and
    /// slope-resistance model of a diode datasheet (a real diode's `n·Vt/I` plus its `Rs`).
    pub diode_resistance: f64,
    /// Emission voltage `n·Vt` of the diodes' exponential law \[V\] (about 26 mV times the
    /// ideality `n`): a real diode's drop grows with the logarithm of its current, steepest at
    /// light load. Positive, a conducting diode drops `n·Vt·ln(1 + |il|/Is) + diode_resistance·|il|`
    /// (Shockley's law with its series resistance), `Is` set so that the drop at 1 A is still
    /// `Vf + diode_resistance·1 A`: `diode_drop` keeps its meaning at 1 A. 0 (the default): the
    /// straight line `Vf + diode_resistance·|il|`. The switch node's slew and ring reach the
    /// diodes' clamps at `Vf` either way.
    pub diode_emission: f64,
    /// `dcm`: asynchronous buck with an ideal or `diode_drop` diode as the low side, so that the
    /// inductor current stops at zero (discontinuous conduction) instead of reversing.
    pub dcm: bool,
    /// `dead_time`: both switches off after the high-side turn-off and before its turn-on \[s\].
    pub dead_time: f64,
    /// The high side's on-time beyond the PWM's `d·T` \[s\], signed: a gate drive's turn-off
    /// delay minus its turn-on delay (pulse-width distortion; a MOSFET's turn-off delay is the
    /// longer, its gate discharging from the plateau). In CCM it moves `vout` by
    /// `vin·pulse_width_distortion/T`. A pulse the PWM gives is stretched or shortened, the
    /// on-time held within `[0, T]`; none is made where it gives none (duty 0), and a duty of 1
    /// stays on. 0 (the default): the switch follows the PWM. Both modes.
    pub pulse_width_distortion: f64,
    /// Capacitance of the switch node to ground \[F\] (the switches' output capacitances, the
    /// diode's junction, the layout). While both switches are off the inductor current
    /// charges it: the node slews from the rail a switch held it at toward the diode clamp the
    /// current pushes it to, in `Csw·ΔV/|il|` (soft switching where il drives it to the other
    /// rail, hard where the turn-on comes first). `il` is held at its edge value meanwhile and
    /// the node at its ramp's mean voltage (the slew lasts nanoseconds: il moves by milliamperes).
    /// 0 (the default): the node switches at once.
    pub switch_node_capacitance: f64,
    /// `switch_node_ring`: once the diode blocks (DCM), the inductor rings with the switch
    /// node's capacitance instead of holding at zero current: the node swings about the output
    /// at `1/(2π·√(L·Csw))` until the next turn-on or a diode's clamp, and the next on-time
    /// starts from the current the ring has then (in deep DCM that sets each period's charge).
    /// Off (the default), as the estimator's fits assume: a blocked inductor holds `il = 0`.
    pub switch_node_ring: bool,
    /// Resistance in series with the switch node's capacitance \[Ω\]: an RC snubber across the
    /// diode is a capacitance behind a resistor, and a diode buck's snubber is often the
    /// node's largest capacitance. The ring (`switch_node_ring`) is then damped, the node at
    /// `vcap − Rd·il`; at an edge the node jumps by `Rd·|il|` toward its clamp and slews the
    /// rest (none where `Rd·|il|` spans the whole swing: the snubber's charge then flows in
    /// the diode's loop, not through L). A ring's clamp is taken where the capacitance's voltage
    /// reaches it. 0 (the default): the capacitance sits on the node.
    pub switch_node_damping: f64,
    /// `load_esr`: series resistance of `Cl` \[Ω\]; `vout` is then the node voltage.
    pub load_esr: f64,
    /// `esl`: series inductance of the main capacitor branch `C`, `Rc` \[H\].
    pub esl: f64,
    /// `inductor_saturation`: fraction of `L` lost above `isat` (incremental inductance
    /// `L·(1 − inductor_saturation)` for `|il| > isat`).
    pub inductor_saturation: f64,
    /// Saturation current of the inductor \[A\].
    pub isat: f64,
    /// `cap_dc_bias`: fraction of `Cl` lost at `cap_rated_voltage`:
    /// `Cl(v) = Cl·(1 − cap_dc_bias·(v/V_rated)²)` (the [`BiasLaw`] in force), held at its
    /// rated-voltage value above it (`Cl` at `cl_reference_voltage`, scaled accordingly).
    pub cap_dc_bias: f64,
    /// The shape of the `cap_dc_bias` law. Not an FMU parameter (the FMU's is quadratic): a
    /// fit tries the other shape too, since data at a few voltages cannot tell them apart.
    pub cap_bias_law: BiasLaw,
    /// Rated voltage of `Cl` for `cap_dc_bias` \[V\].
    pub cap_rated_voltage: f64,
    /// Voltage at which `cl` is the load capacitance under `cap_dc_bias` \[V\]: 0 (the default)
    /// makes `cl` the zero-bias value. Not an FMU parameter: a fit sets it to the data's mean
    /// output so that the fitted `cl` is the capacitance the data shows, not an extrapolation
    /// to 0 V that depends on the bias law.
    pub cl_reference_voltage: f64,
    /// Load resistance from the output node `vout` to ground \[Ω\], drawing `vout/rload` beside
    /// the load current `io`; 0 means no resistor (the ideal current-load circuit, bit for bit).
    /// With `load_esr` it sits at the node, across the series `Cl` + ESR branch. Both modes.
    pub rload: f64,
    /// Instant after each period start at which the outputs are sampled \[s\] (a data
    /// acquisition or ADC that reads a little late). Not a circuit value: the estimator's plant
    /// simulator reads `vout` there (`sample_delay` effect). The FMU's own ADC reads at its
    /// `adc_delay` ([`crate::digital::Digital::adc_delay`]), which `vout_adc` and `il_adc` report.
    pub sample_delay: f64,
    /// How far the sampling instant moves with the duty, as a share of the on-time's change:
    /// the outputs are sampled `sample_delay + sample_duty_share·(D − ½)·T` after the period
    /// start (`sample_delay` is then the instant at half duty), an ADC triggered from the PWM
    /// rather than from the period. ½ with `sample_delay` = T/4: the middle of the on-time; ½
    /// with 3T/4: the middle of the off-time (where controllers read the average inductor
    /// current clear of the edges). 0 (the default): a fixed instant. Not an FMU parameter.
    pub sample_duty_share: f64,
    /// How long after the `il` reading's instant `vout` is read \[s\], signed: the two channels
    /// read at different instants, as a multiplexed ADC converts them one after the other or a
    /// scope's current probe is not deskewed against its voltage probe. `il` is read at the
    /// sampling instant ([`Params::sample_instant`]), `vout` this much later (earlier where
    /// negative); both must lie within the period. 0 (the default): one instant. Not a circuit
    /// value (`channel_skew` effect); the FMU's ADC reads so with its `adc_vout_skew`
    /// ([`crate::digital::Digital::adc_vout_skew`]).
    pub vout_skew: f64,
    /// Time constant of a first-order low-pass the `vout` reading passes through before it is
    /// sampled \[s\]: the RC anti-alias filter in front of a controller's ADC, commonly with its
    /// corner near half the switching frequency (τ ≈ T/π). 0 (the default): read directly. Not
    /// a circuit value: the estimator's plant simulator reads `vout` through it (`sensor_filter`
    /// effect); the FMU's ADC reads through its `adc_filter`
    /// ([`crate::digital::Digital::adc_filter`]), the same filter.
    pub vout_filter: f64,
    /// Time constant of a first-order low-pass the `il` reading passes through before it is
    /// sampled \[s\]: a current-sense amplifier's bandwidth, or an anti-alias filter in front of
    /// the ADC's `il` channel. 0 (the default): read directly. Not a circuit value: the
    /// estimator's plant simulator reads `il` through it; the FMU's ADC reads through its
    /// `adc_il_filter` ([`crate::digital::Digital::adc_il_filter`]), the same filter.
    pub il_filter: f64,
    /// Offset of the `vout` reading \[V\]: a probe's or an ADC's zero error, added to what is read
    /// (`sensor_offset` effect). Not a circuit value and not an FMU parameter, like
    /// `sample_delay`.
    pub vout_offset: f64,
    /// Relative gain error of the `vout` reading against the `vin` reading: `vout` is read as
    /// `(1 + vout_gain_error)·vout + vout_offset` (a divider's resistor tolerance, a probe's
    /// attenuation; `sensor_gain` effect). Not a circuit value and not an FMU parameter.
    pub vout_gain_error: f64,
    /// Offset of the `il` reading \[A\]: a current probe's or a sense amplifier's zero error. The
    /// estimator fits it beside a late reading, which `il` pins (see
    /// `estimator::simulated`). Not a circuit value and not an FMU parameter.
    pub il_offset: f64,
    /// Relative gain error of the `il` reading (a current probe's or a shunt's tolerance): `il`
    /// is read as `(1 + il_gain_error)·il + il_offset`. Fitted with `il_offset`.
    pub il_gain_error: f64,
}

/// The shape of a ceramic load capacitor's loss with its DC bias: the fraction of its capacitance
/// kept at a voltage, given the fraction `b` lost at its rated voltage.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum BiasLaw {
    /// `1 − b·x²` at `x = v/V_rated`: the loss grows with the voltage (concave).
    #[default]
    Quadratic,
    /// `1/(1 + c·x)²` with `c = 1/√(1 − b) − 1`, the same loss at the rated voltage: most of it
    /// at low bias and flattening above (convex), as the charge-controlled `q(v)` of a class-II
    /// ceramic's datasheet curve gives.
    Reciprocal,
}

impl BiasLaw {
    /// Fraction of the zero-bias capacitance kept at `x = v/V_rated` (in `[0, 1]`) when `b` is
    /// lost at the rated voltage.
    pub fn kept(self, b: f64, x: f64) -> f64 {
        match self {
            BiasLaw::Quadratic => 1.0 - b * x * x,
            BiasLaw::Reciprocal => (1.0 + ((1.0 - b).sqrt().recip() - 1.0) * x).powi(-2),
        }
    }

    /// The other shape.
    pub fn other(self) -> Self {
        match self {
            BiasLaw::Quadratic => BiasLaw::Reciprocal,
            BiasLaw::Reciprocal => BiasLaw::Quadratic,
        }
    }

    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            BiasLaw::Quadratic => "quadratic",
            BiasLaw::Reciprocal => "reciprocal",
        }
    }
}

/// Body-diode drop used during dead time when `diode_drop` is 0 \[V\] (a silicon MOSFET body
/// diode).
pub const BODY_DIODE_DROP: f64 = 0.7;

impl Default for Params {
    fn default() -> Self {
        Self {
            l: 3.3e-6,
            rl: 0.1,
            c: 100e-6,
            rc: 0.1,
            cl: 10e-6,
            fs: 330e3,
            switch_resistance: 0.0,
            low_side_ratio: 1.0,
            diode_drop: 0.0,
            diode_resistance: 0.0,
            diode_emission: 0.0,
            dcm: false,
            dead_time: 0.0,
            pulse_width_distortion: 0.0,
            switch_node_capacitance: 0.0,
            switch_node_ring: false,
            switch_node_damping: 0.0,
            load_esr: 0.0,
            esl: 0.0,
            inductor_saturation: 0.0,
            isat: 10.0,
            cap_dc_bias: 0.0,
            cap_rated_voltage: 16.0,
            cl_reference_voltage: 0.0,
            cap_bias_law: BiasLaw::Quadratic,
            rload: 0.0,
            sample_delay: 0.0,
            sample_duty_share: 0.0,
            vout_skew: 0.0,
            vout_filter: 0.0,
            il_filter: 0.0,
            vout_offset: 0.0,
            vout_gain_error: 0.0,
            il_offset: 0.0,
            il_gain_error: 0.0,
        }
    }
}

/// How the switch node is modelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Mode {
    /// State-space average: the switch node carries `duty·vin` continuously.
    #[default]
    Averaged,
    /// Exact trailing-edge PWM: the switch node is `vin` for `duty·T` after each period start
    /// and 0 for the rest of the period; the duty is latched at the period start.
    Switched,
}

impl Params {
    /// Checks every value against its variable's range in the table (e.g. a negative or NaN
    /// `rload`, a non-positive `Cl`): the error names the variable and the range.
    pub fn validate(&self) -> Result<(), ModelError> {
        use crate::variables::{VarId, by_vr, vr};
        let reals = [
            (VarId::L, self.l),
            (VarId::Rl, self.rl),
            (VarId::C, self.c),
            (VarId::Rc, self.rc),
            (VarId::Cl, self.cl),
            (VarId::Fs, self.fs),
            (VarId::SwitchResistance, self.switch_resistance),
            (VarId::LowSideRatio, self.low_side_ratio),
            (VarId::DiodeDrop, self.diode_drop),
            (VarId::DiodeResistance, self.diode_resistance),
            (VarId::DiodeEmission, self.diode_emission),
            (VarId::DeadTime, self.dead_time),
            (VarId::PulseWidthDistortion, self.pulse_width_distortion),
            (VarId::SwitchNodeCapacitance, self.switch_node_capacitance),
            (VarId::SwitchNodeDamping, self.switch_node_damping),
            (VarId::LoadEsr, self.load_esr),
            (VarId::Esl, self.esl),
            (VarId::InductorSaturation, self.inductor_saturation),
            (VarId::Isat, self.isat),
            (VarId::CapDcBias, self.cap_dc_bias),
            (VarId::CapRatedVoltage, self.cap_rated_voltage),
            (VarId::Rload, self.rload),
        ];
        for (id, value) in reals {
            let var = by_vr(vr(id)).ok_or(ModelError::UnknownReference { vr: vr(id), kind: "Real" })?;
            var.check_real(value)?;
        }
        // Above the rated voltage the law holds Cl flat, so a reference there is allowed.
        if !(self.cl_reference_voltage.is_finite() && self.cl_reference_voltage >= 0.0) {
            return Err(ModelError::OutOfRange { name: "cl_reference_voltage", value: self.cl_reference_voltage, range: "finite and ≥ 0 V".into() });
        }
        Ok(())
    }

    /// Conductance of the load resistor `1/rload` \[S\], 0 without one (`rload = 0`).
    pub fn load_conductance(&self) -> f64 {
        if self.rload > 0.0 { 1.0 / self.rload } else { 0.0 }
    }

    /// Switching period `T = 1/fs` \[s\].
    pub fn period(&self) -> f64 {
        1.0 / self.fs
    }

    /// The instant after a period start of length `period` at which a period of duty `duty` is
    /// read: `sample_delay + sample_duty_share·(duty − ½)·period` \[s\].
    pub fn sample_instant(&self, duty: f64, period: f64) -> f64 {
        self.sample_delay + self.sample_duty_share * (duty - 0.5) * period
    }

    /// Share of the period the high side conducts under the PWM duty `duty`
    /// ([`Params::pulse_width_distortion`]): `duty` itself without distortion.
    pub fn effective_duty(&self, duty: f64) -> f64 {
        if self.pulse_width_distortion == 0.0 || duty <= 0.0 || duty >= 1.0 {
            return duty;
        }
        (duty + self.pulse_width_distortion * self.fs).clamp(0.0, 1.0)
    }

    /// Whether the low side is a diode (asynchronous buck): `dcm` or a positive `diode_drop`.
    pub fn asynchronous(&self) -> bool {
        self.dcm || self.diode_drop > 0.0
    }

    /// Drop of the body diodes that conduct during dead time \[V\]: `diode_drop` when positive,
    /// else `BODY_DIODE_DROP`.
    pub fn body_diode_drop(&self) -> f64 {
        if self.diode_drop > 0.0 { self.diode_drop } else { BODY_DIODE_DROP }
    }

    /// Drop of the diode that carries a positive il with both switches off \[V\]: the freewheeling
    /// diode of the asynchronous buck, else the low-side switch's body diode.
    pub fn low_diode_drop(&self) -> f64 {
        if self.asynchronous() { self.diode_drop } else { self.body_diode_drop() }
    }

    /// Mean drop of a diode whose forward drop at 1 A is `vf`, beyond its slope resistance
    /// (which sits in the circuit's series resistance), while its current runs linearly from
    /// `i0` to `i1` (both ≥ 0) \[V\]: `vf` on the straight-line law, the mean of
    /// `n·Vt·ln(1 + i/Is)` under `diode_emission` (see [`Params::diode_emission`]).
    pub fn diode_law_mean(&self, vf: f64, i0: f64, i1: f64) -> f64 {
        let nvt = self.diode_emission;
        if nvt == 0.0 || vf <= 0.0 {
            return vf;
        }
        // Is from the drop at 1 A, in units of 1 A: ln Is = −ln(e^k − 1), k = Vf/(n·Vt), taken
        // so that it holds where Is underflows (a steep law, k past 709) or e^k − 1 does.
        let k = vf / nvt;
        let ln_is = -(k + (-(-k).exp_m1()).ln());
        let is = ln_is.exp();
        if is.is_infinite() {
            return 0.0; // A law this shallow drops nothing at any finite current.
        }
        // ln(1 + i/Is), and ∫ ln(1 + i/Is) di = (Is + i)·ln(1 + i/Is) − i.
        let log = |i: f64| {
            let ratio = i / is;
            if i == 0.0 {
                0.0
            } else if ratio.is_finite() {
                ratio.ln_1p()
            } else {
                i.ln() - ln_is
            }
        };
        let antiderivative = |i: f64| (is + i) * log(i) - i;
        let (a, b) = (i0.max(0.0), i1.max(0.0));
        if (b - a).abs() <= 1e-9 * (a + b + is) {
            return nvt * log(0.5 * (a + b));
        }
        nvt * (antiderivative(b) - antiderivative(a)) / (b - a)
    }

    /// Load capacitance at the voltage `v` across it under `cap_dc_bias` \[F\].
    pub fn cl_at(&self, v: f64) -> f64 {
        if self.cap_dc_bias == 0.0 {
            return self.cl;
        }
        let kept = |v: f64| self.cap_bias_law.kept(self.cap_dc_bias, (v / self.cap_rated_voltage).min(1.0));
        self.cl * kept(v) / kept(self.cl_reference_voltage)
    }

    /// Load capacitance held over a period under `cap_dc_bias` \[F\]: its value for the
    /// mid-period voltage across Cl, extrapolated from this period start's `v` and the last
    /// one's `last` (the midpoint rule in v; `v` itself without a last start). Over the LC
    /// transients after a duty step, holding the start value missed a continuous Cl(v) by
    /// 0.5 mV at 16 V rated; the extrapolation misses only in the first period after a step.
    pub fn cl_for_period(&self, v: f64, last: Option<f64>) -> f64 {
        self.cl_at(last.map_or(v, |last| v + 0.5 * (v - last)))
    }

    /// Number of circuit states: 3 (`[il, vc, vcl]`), or 4 with the branch current of `C`
    /// when `esl > 0`.
    pub fn states(&self) -> usize {
        if self.esl > 0.0 { 4 } else { 3 }
    }

    /// The linear circuit of one piece: states `[il, vc, vcl]` (plus the current `ic` of the
    /// `C` branch when `esl > 0`), inputs `[u_sw, io]`, with the series resistance `r` and the
    /// incremental inductance `l` of the inductor path and the load capacitance `cl` in force.
    /// `blocked`: both switches and the diode off. The inductor then rings with the switch
    /// node's capacitance where there is one ([`Params::rings`]): the capacitance's voltage
    /// `vsw` is a fourth state, `L dil/dt = vsw − (Rd + r)·il − vn`, `Csw dvsw/dt = −il` (`Rd`
    /// the `switch_node_damping`); else `il` stays at zero.
    ///
    /// Without `esl`, the node voltage is `vn = vcl + load_esr·icl` with the current into `Cl`
    /// `icl = k·(il − io + (vc − vcl)/Rc)`, `k = Rc/(Rc + load_esr)`:
    ///
    /// ```text
    /// L  dil/dt  = u_sw − r·il − vn
    /// C  dvc/dt  = (vn − vc)/Rc
    /// Cl dvcl/dt = icl
    /// ```
    ///
    /// With `load_esr = 0` this is [`Params::full_lti`] entry for entry (bit-identical). With
    /// `esl = Lc > 0` the branch current is a state and `vn = vcl + load_esr·(il − ic − io)`:
    ///
    /// ```text
    /// L  dil/dt  = u_sw − r·il − vn
    /// C  dvc/dt  = ic
    /// Cl dvcl/dt = il − ic − io
    /// Lc dic/dt  = vn − Rc·ic − vc
    /// ```
    ///
    /// A load resistor (`rload > 0`, conductance `G`) at the node draws `G·vn` beside `io`; the
    /// node voltage then follows from KCL at the node ([`Params::vout_map`]), `Cl` takes
    /// `icl = il − io − G·vn − (vn − vc)/Rc` (without `esl`) or `il − ic − io − G·vn` (with it).
    /// Without the resistor the matrices are built exactly as before it existed.
    #[rustfmt::skip] // the matrices row by row
    pub fn piece_lti(&self, r: f64, l: f64, cl: f64, blocked: bool) -> Lti {
        let Self { c, rc, load_esr: re, esl, .. } = *self;
        let mut lti = if self.rload > 0.0 {
            self.resistive_piece_lti(r, l, cl)
        } else if esl > 0.0 {
            // vn = [re, 0, 1, −re]·x − re·io
            Lti::new(
                4,
                2,
                &[
                    (-r - re) / l, 0.0, -1.0 / l, re / l, //
                    0.0, 0.0, 0.0, 1.0 / c, //
                    1.0 / cl, 0.0, 0.0, -1.0 / cl, //
                    re / esl, -1.0 / esl, 1.0 / esl, (-rc - re) / esl,
                ],
                &[
                    1.0 / l, re / l, //
                    0.0, 0.0, //
                    0.0, -1.0 / cl, //
                    0.0, -re / esl,
                ],
            )
        } else {
            let k = rc / (rc + re);
            // re·icl = s·(il − io + (vc − vcl)/Rc) with s = re·k: the part of vn above vcl.
            let s = re * k;
            Lti::new(
                3,
                2,
                &[
                    (-r - s) / l, -(s / rc) / l, (-1.0 + s / rc) / l, //
                    s / (rc * c), -1.0 / (rc * c) + s / (rc * rc * c), 1.0 / (rc * c) - s / (rc * rc * c), //
                    k / cl, k / (rc * cl), -k / (rc * cl),
                ],
                &[
                    1.0 / l, s / l, //
                    0.0, -s / (rc * c), //
                    0.0, -k / cl,
                ],
            )
        };
        if blocked && self.rings() {
            return ringing(&lti, l, self.switch_node_capacitance, self.switch_node_damping);
        }
        if blocked {
            lti.a.row_mut(0).fill(0.0);
            lti.b.row_mut(0).fill(0.0);
        }
        lti
    }

    /// Whether a blocked inductor rings with the switch node's capacitance (`switch_node_ring`
    /// with a capacitance, see [`Params::piece_lti`]). The node's voltage takes the place of the
    /// `C` branch's current, so not with `esl`: there the blocked current stays at zero.
    pub fn rings(&self) -> bool {
        self.switch_node_ring && self.switch_node_capacitance > 0.0 && self.esl == 0.0
    }

    /// [`Params::piece_lti`] with a load resistor, from the node map `vn = cv·x + dv·io`.
    #[rustfmt::skip] // the matrices row by row
    fn resistive_piece_lti(&self, r: f64, l: f64, cl: f64) -> Lti {
        let Self { c, rc, esl, .. } = *self;
        let g = self.load_conductance();
        let ([c0, c1, c2, c3], dv) = self.vout_map();
        if esl > 0.0 {
            // L dil = u − r·il − vn, C dvc = ic, Cl dvcl = il − ic − io − G·vn,
            // Lc dic = vn − Rc·ic − vc.
            Lti::new(
                4,
                2,
                &[
                    (-r - c0) / l, -c1 / l, -c2 / l, -c3 / l, //
                    0.0, 0.0, 0.0, 1.0 / c, //
                    (1.0 - g * c0) / cl, -g * c1 / cl, -g * c2 / cl, (-1.0 - g * c3) / cl, //
                    c0 / esl, (c1 - 1.0) / esl, c2 / esl, (c3 - rc) / esl,
                ],
                &[
                    1.0 / l, -dv / l, //
                    0.0, 0.0, //
                    0.0, (-1.0 - g * dv) / cl, //
                    0.0, dv / esl,
                ],
            )
        } else {
            // L dil = u − r·il − vn, C dvc = (vn − vc)/Rc,
            // Cl dvcl = il − io + vc/Rc − (G + 1/Rc)·vn.
            let k = g + 1.0 / rc;
            Lti::new(
                3,
                2,
                &[
                    (-r - c0) / l, -c1 / l, -c2 / l, //
                    c0 / (rc * c), (c1 - 1.0) / (rc * c), c2 / (rc * c), //
                    (1.0 - k * c0) / cl, (1.0 / rc - k * c1) / cl, -k * c2 / cl,
                ],
                &[
                    1.0 / l, -dv / l, //
                    0.0, dv / (rc * c), //
                    0.0, (-1.0 - k * dv) / cl,
                ],
            )
        }
    }

    /// The output (node) voltage `vout = cx·x + d_io·io` of [`Params::piece_lti`]'s states:
    /// `(cx, d_io)`, `cx` padded with zeros to 4 entries.
    ///
    /// With a load resistor (conductance `G`), KCL at the node gives, without `esl`,
    /// `vn = (vcl + re·(il − io) + (re/Rc)·vc)/(1 + re/Rc + re·G)`, and with `esl`
    /// `vn = (vcl + re·(il − ic − io))/(1 + re·G)`; with `load_esr = re = 0` both are `vcl`.
    pub fn vout_map(&self) -> ([f64; 4], f64) {
        let Self { rc, load_esr: re, esl, .. } = *self;
        if self.rload > 0.0 {
            let g = self.load_conductance();
            return if esl > 0.0 {
                let k = 1.0 / (1.0 + re * g);
                ([k * re, 0.0, k, -k * re], -k * re)
            } else {
                let k = 1.0 / (1.0 + re / rc + re * g);
                ([k * re, k * re / rc, k, 0.0], -k * re)
            };
        }
        if esl > 0.0 {
            ([re, 0.0, 1.0, -re], -re)
        } else {
            let s = re * (rc / (rc + re));
            ([s, s / rc, 1.0 - s / rc, 0.0], -s)
        }
    }

    /// The averaged third-order model: states `[il, vc, vo]`, inputs `[u_sw, io]`.
    ///
    /// ```text
    /// L  dil/dt = u_sw − RL·il − vo
    /// C  dvc/dt = (vo − vc)/Rc
    /// Cl dvo/dt = il − io − vo/rload − (vo − vc)/Rc
    /// ```
    ///
    /// The `vo/rload` term is there only with a load resistor (`rload > 0`).
    #[rustfmt::skip] // the matrices row by row
    pub fn full_lti(&self) -> Lti {
        let Self { l, rl, c, rc, cl, .. } = *self;
        let mut lti = Lti::new(
            3,
            2,
            &[
                -rl / l, 0.0, -1.0 / l, //
                0.0, -1.0 / (rc * c), 1.0 / (rc * c), //
                1.0 / cl, 1.0 / (rc * cl), -1.0 / (rc * cl),
            ],
            &[
                1.0 / l, 0.0, //
                0.0, 0.0, //
                0.0, -1.0 / cl,
            ],
        );
        if self.rload > 0.0 {
            lti.a[(2, 2)] -= self.load_conductance() / cl;
        }
        lti
    }

    /// The reduced second-order model with the inductor current as an input: states
    /// `[vc, vo]`, inputs `[il, io]` (with `−vo/rload` at the output node when `rload > 0`).
    #[rustfmt::skip] // the matrices row by row
    pub fn reduced_lti(&self) -> Lti {
        let Self { c, rc, cl, .. } = *self;
        let mut lti = Lti::new(
            2,
            2,
            &[
                -1.0 / (rc * c), 1.0 / (rc * c), //
                1.0 / (rc * cl), -1.0 / (rc * cl),
            ],
            &[
                0.0, 0.0, //
                1.0 / cl, -1.0 / cl,
            ],
        );
        if self.rload > 0.0 {
            lti.a[(1, 1)] -= self.load_conductance() / cl;
        }
        lti
    }

    /// Series resistance of the inductor path while the switches conduct, averaged over a
    /// period at `duty`: `RL + d·Rhs + (1 − d)·Rls` (`Rls = low_side_ratio·switch_resistance`).
    pub fn switching_resistance(&self, duty: f64) -> f64 {
        self.rl + self.switch_resistance * (duty + (1.0 - duty) * self.low_side_ratio)
    }

    /// DC operating point `[il, vc, vo]` of the averaged model in continuous conduction:
    /// `il = io + vo/rload`, `vc = vo = (d·vin − r·io)/(1 + r/rload)` with `r` the
    /// [`Params::switching_resistance`] (no current in the capacitor branches, so neither
    /// `load_esr` nor `esl` shifts it); without a load resistor `il = io`, `vo = d·vin − r·io`.
    pub fn steady_state(&self, duty: f64, vin: f64, io: f64) -> [f64; 3] {
        let r = self.switching_resistance(duty);
        if self.rload > 0.0 {
            let vo = (duty * vin - r * io) * self.rload / (self.rload + r);
            return [io + vo / self.rload, vo, vo];
        }
        let vo = duty * vin - r * io;
        [io, vo, vo]
    }

    /// Duty of the averaged DC operating point with output `vo` (continuous conduction):
    /// `(vo + r·(io + vo/rload))/vin`, `r` the [`Params::switching_resistance`] at that duty
    /// \[1\]; the inverse of [`Params::steady_state`], not clamped.
    pub fn duty_for(&self, vo: f64, vin: f64, io: f64) -> f64 {
        let il = io + vo * self.load_conductance();
        // r = RL + Rls + d·(Rhs − Rls): linear in d, so the balance d·vin = vo + r·il solves at once.
        let (r0, slope) = (self.rl + self.switch_resistance * self.low_side_ratio, self.switch_resistance * (1.0 - self.low_side_ratio));
        (vo + r0 * il) / (vin - slope * il)
    }
}

/// The three-state circuit `lti` of an inductor path with resistance in its `il` row and
/// inductance `l`, with the switch node as a fourth state `vsw` in place of the input `u_sw`:
/// the node's capacitance `csw` ringing with the blocked inductor through `damping` \[Ω\].
fn ringing(lti: &Lti, l: f64, csw: f64, damping: f64) -> Lti {
    let mut a = DMatrix::zeros(4, 4);
    a.view_mut((0, 0), (3, 3)).copy_from(&lti.a);
    a[(0, 0)] -= damping / l;
    a[(0, 3)] = 1.0 / l;
    a[(3, 0)] = -1.0 / csw;
    let mut b = DMatrix::zeros(4, 2);
    b.view_mut((0, 0), (3, 2)).copy_from(&lti.b);
    b[(0, 0)] = 0.0;
    Lti { a, b }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::DVector;

    /// The closed-form DC point must null the derivative of the general state-space model.
    #[test]
    fn steady_state_nulls_the_averaged_dynamics() {
        let p = Params::default();
        let (d, vin, io) = (0.43, 11.0, 2.5);
        let x = DVector::from_row_slice(&p.steady_state(d, vin, io));
        let u = DVector::from_row_slice(&[d * vin, io]);
        let lti = p.full_lti();
        let dx = &lti.a * x + &lti.b * u;
        assert!(dx.amax() < 1e-6, "derivative at the DC point: {dx}");
        assert_relative_eq!(p.steady_state(d, vin, io)[2], d * vin - p.rl * io);
    }

    /// The diode's mean drop along a linear current (`diode_law_mean`) against the law
    /// `n·Vt·ln(1 + i/Is)` averaged by the midpoint rule on 100 000 points: a Schottky's
    /// (Vf 0.35 V at 1 A, n·Vt 27 mV) from 3 A down to 0 and over 1 mA; `Vf` itself at 1 A; and
    /// finite at the ends of the range, where `Is` underflows (n·Vt 1 µV) or overflows (a drop
    /// of 1e-300 V).
    #[test]
    fn the_diodes_mean_drop_is_its_laws_average() {
        let p = Params { diode_emission: 0.027, ..Params::default() };
        let is = 1.0 / (0.35f64 / 0.027).exp_m1();
        let law = |i: f64| 0.027 * (i / is).ln_1p();
        for (a, b) in [(3.0, 0.0), (1e-3, 2e-3), (0.0, 0.5)] {
            let n = 100_000;
            let mean = (0..n).map(|k| law(a + (b - a) * (f64::from(k) + 0.5) / f64::from(n))).sum::<f64>() / f64::from(n);
            let got = p.diode_law_mean(0.35, a, b);
            assert!((got - mean).abs() < 1e-6, "{a}..{b} A: {got} V against {mean} V");
        }
        assert!((p.diode_law_mean(0.35, 1.0, 1.0) - 0.35).abs() < 1e-12);
        assert_eq!(Params::default().diode_law_mean(0.35, 0.0, 3.0), 0.35, "the straight line");
        for (nvt, vf) in [(1e-6, 0.35), (0.5, 1e-300), (0.5, 5.0), (1e-300, 5.0)] {
            let p = Params { diode_emission: nvt, ..Params::default() };
            for (a, b) in [(0.0, 0.0), (0.0, 1e-9), (2.0, 0.0), (1e-300, 100.0)] {
                assert!(p.diode_law_mean(vf, a, b).is_finite(), "n·Vt {nvt}, Vf {vf}, {a}..{b} A");
            }
        }
    }
}
