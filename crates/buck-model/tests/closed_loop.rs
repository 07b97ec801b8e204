//! The digital voltage-mode loop with its default gains: stability margins from the discrete
//! loop gain, and vref steps in the exact switched circuit.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: failing loudly is the point
use buck_model::digital::Digital;
use buck_model::variables::VarId;
use buck_model::{Converter, Mode, Params};
use nalgebra::{Complex, DMatrix};

const CL_GRID: [f64; 6] = [0.2e-6, 1e-6, 5e-6, 20e-6, 50e-6, 100e-6];

/// Loop gain `L(z) = PID(z)·z⁻ᴺ·P(z)` at `z = e^{jωT}`, with `P` the averaged model from duty
/// to the period-start sample of vout (ZOH discretization at T, U = 12 V).
fn loop_gain(p: &Params, (ad, bd): &(DMatrix<Complex<f64>>, DMatrix<Complex<f64>>), delay: u32, f: f64) -> Complex<f64> {
    let t = p.period();
    let z = Complex::from_polar(1.0, 2.0 * std::f64::consts::PI * f * t);
    let x = (DMatrix::<Complex<f64>>::identity(3, 3) * z - ad).lu().solve(bd).unwrap();
    let plant = x[2];
    let g = Digital::default();
    let zi = Complex::new(1.0, 0.0) / z;
    let pid = Complex::new(g.kp, 0.0) + Complex::new(g.ki, 0.0) / (Complex::new(1.0, 0.0) - zi) + (Complex::new(1.0, 0.0) - zi) * g.kd;
    pid * plant * zi.powu(delay)
}

/// Phase margin [°] at each 0 dB crossing and gain margin \[dB\] at each −180° crossing, from a
/// dense logarithmic sweep 100 Hz – fs/2.
fn margins(p: &Params, delay: u32) -> (f64, f64) {
    let n = 5_000;
    let d = p.full_lti().discretize(p.period());
    let plant = (d.ad.map(|x| Complex::new(x, 0.0)), d.bd.columns(0, 1).map(|x| Complex::new(12.0 * x, 0.0)));
    let freqs: Vec<f64> = (0..n).map(|i| 100.0 * (0.4999 * p.fs / 100.0).powf(i as f64 / (n - 1) as f64)).collect();
    let l: Vec<Complex<f64>> = freqs.iter().map(|&f| loop_gain(p, &plant, delay, f)).collect();
    let (mut pm, mut gm) = (f64::INFINITY, f64::INFINITY);
    for w in l.windows(2) {
        if (w[0].norm() - 1.0) * (w[1].norm() - 1.0) <= 0.0 {
            pm = pm.min(180.0 + w[1].arg().to_degrees());
        }
        if w[0].im * w[1].im <= 0.0 && w[1].re < 0.0 {
            gm = gm.min(-20.0 * w[1].norm().log10());
        }
    }
    (pm, gm)
}

/// Default gains: phase margin ≥ 45° and gain margin ≥ 6 dB for Cl = 0.2–100 µF and a
/// computation delay of 0, 1 or 2 periods (design values: PM ≥ 55°, GM ≥ 7.9 dB).
#[test]
fn default_gains_have_margins_across_cl_and_delay() {
    for cl in CL_GRID {
        for delay in 0..=2 {
            let (pm, gm) = margins(&Params { cl, ..Params::default() }, delay);
            assert!(pm >= 45.0, "Cl {cl:e}, delay {delay}: phase margin {pm:.1}°");
            assert!(gm >= 6.0, "Cl {cl:e}, delay {delay}: gain margin {gm:.1} dB");
        }
    }
}

fn closed_loop(cl: f64, delay: u32) -> Converter {
    let mut conv = Converter::new(Params { cl, ..Params::default() }, Mode::Switched);
    conv.set(VarId::Control, 2.0).unwrap();
    conv.set(VarId::Delay, f64::from(delay)).unwrap();
    conv.set(VarId::Vref, 5.0).unwrap();
    conv.initialize();
    conv
}

/// A vref step 5 → 6 V in the switched circuit settles within 0.5 % in 300 periods (0.9 ms)
/// and the controlled sample (the ADC reading of vout at the period start) then has no
/// steady-state error (< 0.1 mV after 3000 periods), for every Cl and delay 0–2.
#[test]
fn vref_step_settles_without_steady_state_error() {
    for cl in CL_GRID {
        for delay in 0..=2 {
            let mut conv = closed_loop(cl, delay);
            let t = conv.params().period();
            conv.set(VarId::Vref, 6.0).unwrap();
            let mut samples = Vec::new();
            for _ in 0..3000 {
                conv.step(t).unwrap();
                samples.push(conv.outputs().vout_adc);
            }
            let worst_after = samples[300..].iter().map(|v| (v - 6.0).abs()).fold(0.0, f64::max);
            assert!(worst_after < 0.005 * 6.0, "Cl {cl:e}, delay {delay}: {worst_after:e} V off after 300 periods");
            let last = *samples.last().unwrap();
            assert!((last - 6.0).abs() < 1e-4, "Cl {cl:e}, delay {delay}: steady-state error {:e} V", last - 6.0);
            assert!(samples.iter().all(|v| v.is_finite() && *v < 9.0), "Cl {cl:e}, delay {delay}: overshoot");
        }
    }
}

/// Starting in closed loop at steady state, the loop stays there: vout = vref, and the applied
/// duty is the DC duty (vref + RL·io)/vin.
#[test]
fn closed_loop_starts_in_steady_state() {
    let mut conv = closed_loop(10e-6, 1);
    let t = conv.params().period();
    for _ in 0..200 {
        conv.step(t).unwrap();
    }
    let y = conv.outputs();
    assert!((y.vout_avg - 5.0).abs() < 0.05, "vout_avg {}", y.vout_avg);
    assert!((y.duty_applied - (5.0 + 0.1) / 12.0).abs() < 0.01, "duty {}", y.duty_applied);
}

/// Dither is added to the controller's duty, and the DPWM register quantizes what is applied.
#[test]
fn dither_and_dpwm_shape_the_applied_duty() {
    let mut conv = closed_loop(10e-6, 0);
    conv.set(VarId::DpwmBits, 8.0).unwrap();
    conv.initialize();
    let t = conv.params().period();
    let mut applied = Vec::new();
    for k in 0..400 {
        conv.set(VarId::Dither, if (k / 8) % 2 == 0 { 0.03 } else { -0.03 }).unwrap();
        conv.step(t).unwrap();
        applied.push(conv.outputs().duty_applied);
    }
    assert!(applied.iter().all(|d| (d * 256.0).fract() == 0.0), "not on the 8-bit DPWM grid");
    let spread = applied.iter().copied().fold(f64::NEG_INFINITY, f64::max) - applied.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(spread > 0.04, "dither did not reach the switch: spread {spread}");
}
