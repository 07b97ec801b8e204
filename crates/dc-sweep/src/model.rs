//! The averaged DC model of a buck converter with its non-ideal effects, solved per operating
//! point.
//!
//! In periodic steady state the inductor's volt-seconds and the capacitors' charge balance over
//! a period, so the capacitors (C, Rc, Cl and their parasitics) drop out: `avg(il) = io_total`
//! and `avg(vout) = avg(v_sw) − avg(R·il)`, with `io_total = io + vout/rload`. What remains is
//! the average switch-node voltage, which each effect changes:
//!
//! - **Synchronous buck** (no diode): `v_sw = U` for `D·T`, `0` otherwise; the inductor path has
//!   `RL + r_series + rds_on` all period, so `vout = D·U − (RL + r_series + rds_on)·io_total`.
//! - **Dead time** `td` (synchronous only; the convention of `buck_model`): each turn-on comes
//!   `td` after its PWM edge, the high side's after the rising edge at the period start, the low
//!   side's after the falling edge at `D·T`. During each dead interval a body diode (drop `Vbd`)
//!   carries the current by its sign at that edge, so per period:
//!   rising edge with the valley current `i_v > 0`: the node is `−Vbd` instead of `U`, a loss
//!   of `td·(U + Vbd)`; with `i_v < 0`: `U + Vbd` instead of `U`, a gain of `td·Vbd`;
//!   falling edge with the peak current `i_p > 0`: `−Vbd` instead of `0`, a loss of `td·Vbd`;
//!   with `i_p < 0`: `U + Vbd` instead of `0`, a gain of `td·(U + Vbd)`.
//!   With `il > 0` all period `avg(v_sw)` loses `td·fs·(U + 2·Vbd)`; with `il < 0` it gains the
//!   same; when the ripple crosses zero (`i_v < 0 < i_p`) the two edges cancel (`td·fs·Vbd` each
//!   way). The switch resistance is out of the path during the dead intervals (a fraction
//!   `2·td·fs` of the period). The edge currents depend on `vout`, so the signs are found by
//!   trying each consistent combination.
//! - **Asynchronous (diode) buck**: `v_sw = U` for `D·T` (resistance `RL + r_series + rds_on`)
//!   and `−Vf` while the diode conducts (resistance `RL + r_series`). In CCM
//!   `vout = D·U − (1 − D)·Vf − (RL + r_series + D·rds_on)·io_total`. The diode blocks a
//!   negative current, so at light load the current stops (DCM), found by the model itself when
//!   the CCM valley current `io_total − ΔI/2` would be negative. In DCM the current rises
//!   from 0 to `Ip` in `D·T` and falls back in `t2`; with linear ramps and the resistive drop
//!   taken at the ramp's mean `Ip/2`:
//!   `Ip = (U − vout)·D·T / (L + R_on·D·T/2)`, `t2 = L·Ip / (vout + Vf + R_off·Ip/2)`,
//!   `avg(il) = Ip·(D·T + t2)/(2·T) = io_total`, solved for `vout` by bisection (the left side
//!   falls and the right side rises with `vout`, so the root is unique).
//!
//! Neglected: the output-voltage ripple and the curvature of the current ramps (`R·T/L ≪ 1`),
//! which the comparison with the exact switched simulator bounds (`tests/against_switched.rs`).
use crate::error::{SweepError, model_err};

/// Circuit values of the nominal model that matter in DC.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circuit {
    /// Inductance \[H\] (sets the DCM boundary and the ripple at the dead-time edges).
    pub l: f64,
    /// Series resistance of the inductor \[Ω\].
    pub rl: f64,
    /// Switching frequency \[Hz\].
    pub fs: f64,
    /// On-resistance of the switches \[Ω\], in the path while a switch conducts (as
    /// `buck_model::Params::switch_resistance`).
    pub rds_on: f64,
    /// Drop of the body diodes that conduct during dead time \[V\].
    pub body_diode_drop: f64,
}

impl Default for Circuit {
    /// The thesis circuit: 3.3 µH, 0.1 Ω, 330 kHz, ideal switches, 0.7 V body diodes.
    fn default() -> Self {
        Self { l: 3.3e-6, rl: 0.1, fs: 330e3, rds_on: 0.0, body_diode_drop: 0.7 }
    }
}

/// Non-ideal effects of the DC model (all off: the ideal synchronous buck with `RL` only).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Effects {
    /// Asynchronous buck: a freewheeling diode instead of the low-side switch (DCM at light
    /// load follows).
    pub diode: bool,
    /// Forward drop of the freewheeling diode \[V\] (asynchronous buck).
    pub diode_drop: f64,
    /// Extra series resistance in the inductor path all period \[Ω\] (beside `RL`).
    pub r_series: f64,
    /// Dead time before each turn-on \[s\] (synchronous buck).
    pub dead_time: f64,
}

/// One steady operating point: the inputs of the DC model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OperatingPoint {
    /// Duty of the PWM signal (0..1).
    pub duty: f64,
    /// Input voltage \[V\].
    pub vin: f64,
    /// Constant-current part of the load \[A\].
    pub io: f64,
    /// Resistive part of the load \[Ω\] (`None`: none).
    pub rload: Option<f64>,
}

impl OperatingPoint {
    /// Load conductance \[S\] (0 without a resistor).
    pub fn conductance(&self) -> f64 {
        self.rload.map_or(0.0, |r| 1.0 / r)
    }

    /// Total load current at the output voltage `vout` \[A\].
    pub fn load_current(&self, vout: f64) -> f64 {
        self.io + vout * self.conductance()
    }
}

/// Conduction mode of a solved operating point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Conduction {
    /// The inductor current never stops.
    Continuous,
    /// The diode blocks for part of the period.
    Discontinuous,
}

/// The solved operating point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DcPoint {
    /// Mean output voltage \[V\].
    pub vout: f64,
    /// Mean inductor current \[A\] (the total load current).
    pub il: f64,
    /// Conduction mode.
    pub conduction: Conduction,
}

/// Checks that the circuit values are usable; the error names the value.
pub fn check_circuit(c: &Circuit) -> Result<(), SweepError> {
    let positive = [("L", c.l), ("fs", c.fs)];
    for (name, v) in positive {
        if !(v.is_finite() && v > 0.0) {
            return Err(model_err(format!("circuit value {name} = {v} must be positive and finite")));
        }
    }
    for (name, v) in [("RL", c.rl), ("rds_on", c.rds_on), ("body diode drop", c.body_diode_drop)] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(model_err(format!("circuit value {name} = {v} must be non-negative and finite")));
        }
    }
    Ok(())
}

/// Solves the DC model at one operating point (see the module documentation for the model).
pub fn solve(c: &Circuit, e: &Effects, op: &OperatingPoint) -> Result<DcPoint, SweepError> {
    if !(op.duty.is_finite() && (0.0..=1.0).contains(&op.duty)) {
        return Err(model_err(format!("duty {} is outside 0..1", op.duty)));
    }
    if !(op.vin.is_finite() && op.io.is_finite()) {
        return Err(model_err(format!("vin {} or io {} is not finite", op.vin, op.io)));
    }
    if let Some(r) = op.rload
        && !(r.is_finite() && r > 0.0)
    {
        return Err(model_err(format!("rload {r} must be positive and finite")));
    }
    for (name, v) in [("diode drop", e.diode_drop), ("series resistance", e.r_series), ("dead time", e.dead_time)] {
        if !v.is_finite() {
            return Err(model_err(format!("{name} {v} is not finite")));
        }
    }
    if e.diode { solve_async(c, e, op) } else { Ok(solve_sync(c, e, op)) }
}

fn solve_sync(c: &Circuit, e: &Effects, op: &OperatingPoint) -> DcPoint {
    let (d, u, t) = (op.duty, op.vin, 1.0 / c.fs);
    let g = op.conductance();
    let r_on = c.rl + e.r_series + c.rds_on;
    // No PWM edge at duty 0 or 1, so no dead interval (as in buck_model).
    let edges = d > 0.0 && d < 1.0 && e.dead_time != 0.0;
    let solve_with = |sv: f64, sp: f64| -> (f64, f64, f64) {
        let (mut vsw, mut r) = (d * u, r_on);
        if edges {
            let vbd = c.body_diode_drop;
            let td_r = e.dead_time.min(d * t) * c.fs;
            let td_f = e.dead_time.min((1.0 - d) * t) * c.fs;
            vsw += if sv > 0.0 { -td_r * (u + vbd) } else { td_r * vbd };
            vsw += if sp > 0.0 { -td_f * vbd } else { td_f * (u + vbd) };
            r -= c.rds_on * (td_r + td_f);
        }
        let vout = (vsw - r * op.io) / (1.0 + r * g);
        let il = op.io + g * vout;
        let ripple = (u - vout - r_on * il) * d * t / c.l;
        (vout, il - ripple / 2.0, il + ripple / 2.0)
    };
    if !edges {
        let (vout, _, _) = solve_with(1.0, 1.0);
        return DcPoint { vout, il: op.load_current(vout), conduction: Conduction::Continuous };
    }
    for (sv, sp) in [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0)] {
        let (vout, valley, peak) = solve_with(sv, sp);
        if (valley >= 0.0) == (sv > 0.0) && (peak >= 0.0) == (sp > 0.0) {
            return DcPoint { vout, il: op.load_current(vout), conduction: Conduction::Continuous };
        }
    }
    // No sign pattern is self-consistent: the current at one edge crosses zero inside its dead
    // interval, where the node lies between the two diode levels. Take the mean of the solutions
    // on either side of that edge's step (first order in its dead-time term).
    let (v_pp, valley_pp, _) = solve_with(1.0, 1.0);
    let (v_np, valley_np, _) = solve_with(-1.0, 1.0);
    let (v_nn, _, _) = solve_with(-1.0, -1.0);
    let vout = if valley_pp < 0.0 && valley_np >= 0.0 { 0.5 * (v_pp + v_np) } else { 0.5 * (v_np + v_nn) };
    DcPoint { vout, il: op.load_current(vout), conduction: Conduction::Continuous }
}

fn solve_async(c: &Circuit, e: &Effects, op: &OperatingPoint) -> Result<DcPoint, SweepError> {
    let (d, u, t) = (op.duty, op.vin, 1.0 / c.fs);
    let g = op.conductance();
    let vf = e.diode_drop;
    let r_off = c.rl + e.r_series;
    let r_on = r_off + c.rds_on;
    // Continuous conduction first.
    let r_avg = r_off + d * c.rds_on;
    let vout = (d * u - (1.0 - d) * vf - r_avg * op.io) / (1.0 + r_avg * g);
    let il = op.io + g * vout;
    let ripple = (u - vout - r_on * il) * d * t / c.l;
    if il - ripple / 2.0 >= 0.0 && d > 0.0 {
        return Ok(DcPoint { vout, il, conduction: Conduction::Continuous });
    }
    if d == 0.0 {
        if op.io > 0.0 {
            return Err(model_err(format!("duty 0 with a load current io = {} A has no steady state in a diode buck", op.io)));
        }
        return Ok(DcPoint { vout: 0.0, il: 0.0, conduction: Conduction::Discontinuous });
    }
    // Discontinuous: mean inductor current minus load current, falling in vout.
    let excess = |v: f64| -> f64 {
        let ip = ((u - v) * d * t / (c.l + r_on * d * t / 2.0)).max(0.0);
        let fall = v + vf + r_off * ip / 2.0;
        let t2 = if ip == 0.0 { 0.0 } else { (c.l * ip / fall).min((1.0 - d) * t) };
        ip * (d * t + t2) / (2.0 * t) - op.load_current(v)
    };
    // Lower end: just above −Vf (where the fall time would be infinite: the full off-time).
    let mut lo = -vf + 1e-12 * u.abs().max(1.0);
    let mut hi = u;
    let (f_lo, f_hi) = (excess(lo), excess(hi));
    if !(f_lo >= 0.0 && f_hi <= 0.0) {
        return Err(model_err(format!(
            "no steady state of the diode buck at duty {d}, vin {u} V, io {} A{}: a diode cannot carry the load current this asks for",
            op.io,
            op.rload.map_or(String::new(), |r| format!(", rload {r} Ω"))
        )));
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if excess(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-14 * u.abs().max(1.0) {
            break;
        }
    }
    let vout = 0.5 * (lo + hi);
    Ok(DcPoint { vout, il: op.load_current(vout), conduction: Conduction::Discontinuous })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn op(duty: f64, io: f64, rload: Option<f64>) -> OperatingPoint {
        OperatingPoint { duty, vin: 12.0, io, rload }
    }

    #[test]
    fn ideal_sync_is_d_u_minus_rl_io() {
        let c = Circuit::default();
        let p = solve(&c, &Effects::default(), &op(0.4, 2.0, None)).unwrap();
        assert!((p.vout - (4.8 - 0.2)).abs() < 1e-12);
        let p = solve(&c, &Effects::default(), &op(0.5, 0.0, Some(10.0))).unwrap();
        assert!((p.vout - 6.0 * 10.0 / 10.1).abs() < 1e-12);
    }

    /// At the CCM/DCM boundary the two branches agree (continuity), and deep in DCM with no
    /// resistance the textbook `Vo = U·d²/(d² + K)`, `K = 2·L·fs·io/U` holds (current load,
    /// no diode drop).
    #[test]
    fn dcm_matches_the_textbook_formula_and_is_continuous() {
        let c = Circuit { rl: 0.0, ..Circuit::default() };
        let e = Effects { diode: true, ..Effects::default() };
        let (d, io) = (0.3, 0.3);
        let k = 2.0 * c.l * c.fs * io / 12.0;
        let p = solve(&c, &e, &op(d, io, None)).unwrap();
        assert_eq!(p.conduction, Conduction::Discontinuous);
        assert!((p.vout - 12.0 * d * d / (d * d + k)).abs() < 1e-9, "{}", p.vout);
        // Boundary: io = ripple/2 of the ideal CCM point.
        let vo = d * 12.0;
        let boundary = (12.0 - vo) * d / (c.fs * c.l) / 2.0;
        let a = solve(&c, &e, &op(d, boundary * (1.0 + 1e-9), None)).unwrap();
        let b = solve(&c, &e, &op(d, boundary * (1.0 - 1e-9), None)).unwrap();
        assert!((a.vout - b.vout).abs() < 1e-6, "{} vs {}", a.vout, b.vout);
    }

    #[test]
    fn dead_time_loses_with_positive_and_gains_with_negative_current() {
        let c = Circuit { rl: 0.0, ..Circuit::default() };
        let td = 30e-9;
        let e = Effects { dead_time: td, ..Effects::default() };
        let shift = td * c.fs * (12.0 + 2.0 * 0.7);
        let up = solve(&c, &e, &op(0.45, 3.0, None)).unwrap();
        assert!((up.vout - (0.45 * 12.0 - shift)).abs() < 1e-12);
        let down = solve(&c, &e, &op(0.45, -3.0, None)).unwrap();
        assert!((down.vout - (0.45 * 12.0 + shift)).abs() < 1e-12);
        // Ripple through zero: the edges cancel.
        let mid = solve(&c, &e, &op(0.45, 0.0, None)).unwrap();
        assert!((mid.vout - 0.45 * 12.0).abs() < 1e-12);
    }

    #[test]
    fn bad_inputs_are_errors_not_nan() {
        let c = Circuit::default();
        assert!(solve(&c, &Effects::default(), &op(1.5, 1.0, None)).unwrap_err().to_string().contains("duty"));
        assert!(solve(&c, &Effects::default(), &op(0.5, f64::NAN, None)).is_err());
        assert!(solve(&c, &Effects::default(), &op(0.5, 1.0, Some(0.0))).unwrap_err().to_string().contains("rload"));
        let e = Effects { diode: true, ..Effects::default() };
        assert!(solve(&c, &e, &op(0.5, -1.0, None)).unwrap_err().to_string().contains("diode"));
        assert!(check_circuit(&Circuit { l: 0.0, ..c }).unwrap_err().to_string().contains("L"));
    }
}
