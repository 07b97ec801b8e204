//! The digital side of the converter: the ADC that samples `vout` and `il` at each period start,
//! the optional voltage-mode PID controller, the delay between a duty command and the switch,
//! and the DPWM register's resolution.
//!
//! Timeline of period `k`: at `k·T` the ADC samples the state (in switched mode `il` at
//! `adc_delay` into the period and `vout` `adc_vout_skew` after it, where they are set); at the
//! latch (the start of the
//! first step that runs period `k`) the duty command is formed — the `duty` input in open loop,
//! `PID(vref − vout_adc) + duty_dither` in closed loop — quantized to the DPWM resolution, and
//! pushed into the delay line; the command from `delay` periods earlier drives the switch.
//! Each channel may read through a first-order RC low-pass: `vout` through the ADC's anti-alias
//! filter (`adc_filter`), `il` through its sense chain's (`adc_il_filter`).
use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

/// Who sets the duty.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Control {
    /// The `duty` input.
    #[default]
    Open,
    /// The PID controller regulating `vout` to `vref`, plus `duty_dither`.
    Closed,
}

/// Settings and state of the digital side.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Digital {
    /// Who sets the duty.
    pub control: Control,
    /// Proportional gain [1/V].
    pub kp: f64,
    /// Integral gain per period [1/V].
    pub ki: f64,
    /// Derivative gain (on the error difference per period) [1/V].
    pub kd: f64,
    /// Periods between a duty command and the switch (computation/transport delay).
    pub delay: u32,
    /// ADC resolution in bits (0: ideal, no quantization).
    pub adc_bits: u32,
    /// ADC full scale of `vout`, unipolar `[0, vfs]` \[V\].
    pub adc_vfs: f64,
    /// ADC full scale of `il`, bipolar `[−ifs, ifs]` \[A\].
    pub adc_ifs: f64,
    /// Standard deviation of white sensor noise on `vout` at the ADC input \[V\].
    pub adc_noise: f64,
    /// Standard deviation of white sensor noise on `il` at the ADC input \[A\], independent of
    /// the noise on `vout`.
    pub adc_il_noise: f64,
    /// Seed of the noise on both channels (each sequence a pure function of seed and period
    /// index).
    pub noise_seed: u64,
    /// Instant of the reading after each period start \[s\] (0: at the period start, the
    /// previous period's end).
    pub adc_delay: f64,
    /// How long after `il` the ADC converts `vout` \[s\], signed (a multiplexed ADC converts its
    /// channels one after the other): `il` is read at `adc_delay`, `vout` at
    /// `adc_delay + adc_vout_skew`, both within the period (0: one instant).
    pub adc_vout_skew: f64,
    /// Time constant of the RC anti-alias filter in front of the `vout` channel \[s\] (0: none).
    pub adc_filter: f64,
    /// Time constant of the first-order low-pass in front of the `il` channel \[s\] (0: none): a
    /// current-sense amplifier's bandwidth or the channel's own anti-alias filter.
    pub adc_il_filter: f64,
    /// DPWM resolution in bits (0: ideal).
    pub dpwm_bits: u32,
    integral: f64,
    e_prev: f64,
    line: VecDeque<f64>,
    reading: [f64; 2],
    applied: f64,
    /// The channels' filter outputs `[vout, il]` (`adc_filter`, `adc_il_filter`).
    filtered: [f64; 2],
}

impl Default for Digital {
    fn default() -> Self {
        Self {
            control: Control::Open,
            kp: 0.08,
            ki: 0.008,
            kd: 0.3,
            delay: 0,
            adc_bits: 0,
            adc_vfs: 16.0,
            adc_ifs: 32.0,
            adc_noise: 0.0,
            adc_il_noise: 0.0,
            noise_seed: 1,
            adc_delay: 0.0,
            adc_vout_skew: 0.0,
            adc_filter: 0.0,
            adc_il_filter: 0.0,
            dpwm_bits: 0,
            integral: 0.0,
            e_prev: 0.0,
            line: VecDeque::new(),
            reading: [0.0; 2],
            applied: 0.0,
            filtered: [0.0; 2],
        }
    }
}

/// SplitMix64: a counter-based generator, so the noise of period `k` needs no stored state.
fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// `value` with white noise of standard deviation `sigma` drawn for `(seed, k)` ([`normal`]);
/// `value` itself, bit for bit, without noise.
fn with_noise(value: f64, sigma: f64, seed: u64, k: u64) -> f64 {
    if sigma > 0.0 { value + sigma * normal(seed, k) } else { value }
}

/// Mixed into the seed of the `il` channel's noise, so that its sequence is not `vout`'s.
const IL_NOISE_STREAM: u64 = 0x696C_5F6E_6F69_7365; // "il_noise"

/// Standard normal sample for `(seed, k)` (Box–Muller on two SplitMix64 uniforms).
fn normal(seed: u64, k: u64) -> f64 {
    let a = splitmix(seed ^ splitmix(k));
    let b = splitmix(a);
    let u1 = ((a >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
    let u2 = (b >> 11) as f64 / (1u64 << 53) as f64;
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Pieces of a switching period over which the anti-alias filter follows `vout` at most.
pub(crate) const FILTER_PIECES: f64 = 8.0;

/// The output of a first-order low-pass `τ·y' = v − y` at `output` after a piece of length `dt`
/// over which its input went from `v0` to `v1` with mean `mean`, taken as the parabola through
/// those. For `v = v₀ + b·t + c·t²` the output follows `v − τ·v' + τ²·v''` and relaxes to it as
/// `e^{−t/τ}`: exact for a parabola (the ripple of a capacitor charged by a ramp of current), and
/// for any input in the limits `τ → 0` (the value) and `τ ≫ dt` (the mean). Pieces of a
/// [`FILTER_PIECES`]th of a switching period keep a converter's `vout` close to that.
fn low_pass(output: f64, tau: f64, v0: f64, v1: f64, mean: f64, dt: f64) -> f64 {
    let (rise, above) = (v1 - v0, mean - v0);
    let c = 3.0 * (rise - 2.0 * above) / (dt * dt);
    let b = (6.0 * above - 2.0 * rise) / dt;
    let curve = 2.0 * c * tau * tau;
    let (start, end) = (v0 - tau * b + curve, v1 - tau * (b + 2.0 * c * dt) + curve);
    end + (output - start) * (-dt / tau).exp()
}

fn quantize(x: f64, lo: f64, hi: f64, bits: u32) -> f64 {
    if bits == 0 {
        return x;
    }
    let lsb = (hi - lo) / f64::from(1u32 << bits.min(31));
    (lo + ((x - lo) / lsb).round() * lsb).clamp(lo, hi)
}

impl Digital {
    /// Restarts at an operating point: the controller's integrator holds `duty` (so a loop that
    /// starts in steady state stays there), the delay line is full of `duty`, the ADC reads the
    /// start state `(vout, il)`.
    pub fn restart(&mut self, duty: f64, vout: f64, il: f64) {
        self.integral = duty;
        self.e_prev = 0.0;
        self.line = std::iter::repeat_n(duty, self.delay as usize).collect();
        self.applied = duty;
        self.settle_filters(vout, il);
        self.sample(vout, il, 0);
    }

    /// The channels' filter time constants `[vout, il]` (0: none).
    fn taus(&self) -> [f64; 2] {
        [self.adc_filter, self.adc_il_filter]
    }

    /// Whether a channel reads through a filter (`adc_filter`, `adc_il_filter`).
    pub fn filters(&self) -> bool {
        self.taus().iter().any(|&tau| tau > 0.0)
    }

    /// The channels' filters following a piece of length `dt` over which `vout` and `il` each
    /// went from `start` to `end` with mean `mean` (`[vout, il]`, see `low_pass`); a channel
    /// without a filter ignores it.
    pub fn follow(&mut self, start: [f64; 2], end: [f64; 2], mean: [f64; 2], dt: f64) {
        for (c, tau) in self.taus().into_iter().enumerate() {
            if tau > 0.0 {
                self.filtered[c] = low_pass(self.filtered[c], tau, start[c], end[c], mean[c], dt);
            }
        }
    }

    /// The channels' filters settled at `vout` and `il` (a start at a state).
    pub fn settle_filters(&mut self, vout: f64, il: f64) {
        self.filtered = [vout, il];
    }

    /// What the `vout` channel sees of `vout` now: its filter's output, where there is one.
    pub fn vout_channel(&self, vout: f64) -> f64 {
        if self.adc_filter > 0.0 { self.filtered[0] } else { vout }
    }

    /// What the `il` channel sees of `il` now: its filter's output, where there is one.
    pub fn il_channel(&self, il: f64) -> f64 {
        if self.adc_il_filter > 0.0 { self.filtered[1] } else { il }
    }

    /// The ADC conversion of period `k` (its noise a function of `k`) of `vout` and `il`, each
    /// through its channel's filter where there is one.
    pub fn sample(&mut self, vout: f64, il: f64, k: u64) {
        self.sample_vout(vout, k);
        self.sample_il(il, k);
    }

    /// The conversion of period `k` of the `vout` channel alone (see [`Digital::sample`]).
    pub fn sample_vout(&mut self, vout: f64, k: u64) {
        let vout = self.vout_channel(vout);
        let noisy = with_noise(vout, self.adc_noise, self.noise_seed, k);
        self.reading[0] = quantize(noisy, 0.0, self.adc_vfs, self.adc_bits);
    }

    /// The conversion of period `k` of the `il` channel alone (see [`Digital::sample`]).
    pub fn sample_il(&mut self, il: f64, k: u64) {
        let il = self.il_channel(il);
        let noisy = with_noise(il, self.adc_il_noise, self.noise_seed ^ IL_NOISE_STREAM, k);
        self.reading[1] = quantize(noisy, -self.adc_ifs, self.adc_ifs, self.adc_bits);
    }

    /// The latest ADC reading `(vout, il)`.
    pub fn reading(&self) -> (f64, f64) {
        (self.reading[0], self.reading[1])
    }

    /// The duty in force during the latest latched period.
    pub fn applied(&self) -> f64 {
        self.applied
    }

    /// Forms this period's command from the inputs, and returns the duty that drives the switch.
    pub fn latch(&mut self, duty: f64, dither: f64, vref: f64) -> f64 {
        let command = match self.control {
            Control::Open => duty,
            Control::Closed => {
                let e = vref - self.reading[0];
                let integral = self.integral + self.ki * e;
                let raw = self.kp * e + integral + self.kd * (e - self.e_prev) + dither;
                // Anti-windup by conditional integration: no integration that pushes further
                // into saturation.
                let saturating = (raw > 1.0 && e > 0.0) || (raw < 0.0 && e < 0.0);
                if !saturating {
                    self.integral = integral;
                }
                self.e_prev = e;
                raw.clamp(0.0, 1.0)
            }
        };
        let command = quantize(command, 0.0, 1.0, self.dpwm_bits);
        self.line.push_back(command);
        self.applied = self.line.pop_front().unwrap_or(command);
        self.applied
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantizer_rounds_to_the_lsb_and_clamps() {
        assert_eq!(quantize(0.3, 0.0, 1.0, 0), 0.3);
        assert_eq!(quantize(0.3, 0.0, 1.0, 2), 0.25);
        assert_eq!(quantize(0.38, 0.0, 1.0, 2), 0.5);
        assert_eq!(quantize(1.7, 0.0, 1.0, 4), 1.0);
        assert_eq!(quantize(-3.1, -4.0, 4.0, 3), -3.0);
    }

    /// The noise is standard normal: mean ≈ 0, variance ≈ 1 over 20 000 draws (4σ bounds).
    #[test]
    fn noise_is_standard_normal_and_reproducible() {
        let n = 20_000;
        let v: Vec<f64> = (0..n).map(|k| normal(7, k)).collect();
        let mean = v.iter().sum::<f64>() / n as f64;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 4.0 / (n as f64).sqrt(), "{mean}");
        assert!((var - 1.0).abs() < 4.0 * (2.0 / n as f64).sqrt(), "{var}");
        assert_eq!(normal(7, 123), normal(7, 123));
        assert_ne!(normal(7, 123), normal(8, 123));
    }

    #[test]
    fn delay_line_applies_commands_late() {
        let mut d = Digital { delay: 2, ..Digital::default() };
        d.restart(0.5, 5.9, 1.0);
        let applied: Vec<f64> = [0.1, 0.2, 0.3, 0.4].iter().map(|&c| d.latch(c, 0.0, 0.0)).collect();
        assert_eq!(applied, vec![0.5, 0.5, 0.1, 0.2]);
    }

    #[test]
    fn controller_saturates_without_winding_up() {
        let mut d = Digital { control: Control::Closed, ..Digital::default() };
        d.restart(0.5, 5.0, 1.0);
        d.sample(0.0, 0.0, 1);
        for _ in 0..1000 {
            assert!(d.latch(0.0, 0.0, 5.0) >= 0.94, "a 5 V error keeps the duty near its top");
        }
        // Back at the reference (one period for the derivative kick to pass), the integrator has
        // not run away: without anti-windup it would hold 0.5 + 1000·0.04 = 40 and pin the duty at 1.
        d.sample(5.0, 0.0, 2);
        d.latch(0.0, 0.0, 5.0);
        assert!(d.latch(0.0, 0.0, 5.0) < 1.0);
    }
}
