//! References: the CCM DC balance (inductor volt-second and capacitor charge balance), the
//! triangular ripple valley, and self-consistency of the exact stepping.
use approx::assert_relative_eq;

use super::*;

fn settled(mode: Mode, params: Params, inputs: Inputs, periods: usize) -> Converter {
    let mut conv = Converter::new(params, mode);
    conv.set_inputs(inputs).unwrap();
    conv.initialize();
    for _ in 0..periods {
        conv.step(params.period()).unwrap();
    }
    conv
}

/// From zero initial state the averaged model settles on `vout = d·U − RL·io`.
#[test]
fn averaged_settles_on_analytic_dc_point() {
    let p = Params::default();
    let mut conv = Converter::new(p, Mode::Averaged);
    conv.set(VarId::SteadyStart, 0.0).unwrap();
    conv.set_inputs(Inputs { duty: 0.4, io: 2.0, vin: 12.0, ..Inputs::default() }).unwrap();
    conv.initialize();
    assert_eq!(conv.outputs().vout, 0.0);
    for _ in 0..20_000 {
        conv.step(p.period()).unwrap();
    }
    let y = conv.outputs();
    assert_relative_eq!(y.vout, 0.4 * 12.0 - 0.1 * 2.0, epsilon = 1e-9);
    assert_relative_eq!(y.il, 2.0, epsilon = 1e-9);
    assert_relative_eq!(y.vout_avg, y.vout, epsilon = 1e-9);
}

/// In periodic steady state the exact period averages obey volt-second and charge balance
/// exactly: `avg(vo) = d·U − RL·io` and `avg(il) = io`, whatever the ripple.
#[test]
fn switched_period_averages_obey_dc_balance() {
    for &(d, io, cl) in &[(0.4, 1.0, 0.2e-6), (0.6, 3.0, 10e-6), (0.5, -0.5, 100e-6), (1.0, 1.0, 1e-6), (0.0, 1.0, 1e-6)] {
        let p = Params { cl, ..Default::default() };
        let conv = settled(Mode::Switched, p, Inputs { duty: d, io, vin: 12.0, ..Inputs::default() }, 4000);
        let y = conv.outputs();
        assert_relative_eq!(y.vout_avg, d * 12.0 - p.rl * io, epsilon = 1e-7);
        assert_relative_eq!(y.il_avg, io, epsilon = 1e-7);
    }
}

/// Sampled at the period start, the inductor current sits at the ripple valley
/// `io − U·d(1−d)/(2·L·fs)`; the triangular-ripple formula neglects the exponential
/// curvature and the output ripple, which stay below 1 % of the ripple here.
#[test]
fn switched_period_start_sample_is_the_ripple_valley() {
    for &d in &[0.4, 0.5, 0.6] {
        let p = Params::default();
        let io = 1.0;
        let conv = settled(Mode::Switched, p, Inputs { duty: d, io, vin: 12.0, ..Inputs::default() }, 4000);
        let half_ripple = 12.0 * d * (1.0 - d) / (2.0 * p.l * p.fs);
        let valley = conv.outputs().il;
        assert_relative_eq!(valley, io - half_ripple, epsilon = 0.01 * half_ripple);
    }
}

/// Ragged communication steps that cross switching events anywhere give the same trajectory
/// as one step per period, as long as the duty changes only at period starts.
#[test]
fn step_length_does_not_change_the_trajectory() {
    let p = Params { cl: 0.2e-6, ..Default::default() };
    let t = p.period();
    let duties = [0.4, 0.6, 0.6, 0.4, 0.6, 0.4, 0.4, 0.6];
    let fractions = [0.37, 0.05, 0.21, 0.02, 0.2, 0.15]; // sums to 1
    let mut even = Converter::new(p, Mode::Switched);
    let mut ragged = even.clone();
    for (k, &d) in duties.iter().cycle().take(200).enumerate() {
        even.set(VarId::Duty, d).unwrap();
        ragged.set(VarId::Duty, d).unwrap();
        even.step(t).unwrap();
        for f in fractions {
            ragged.step(f * t).unwrap();
        }
        let (a, b) = (even.outputs(), ragged.outputs());
        assert_relative_eq!(a.vout, b.vout, epsilon = 1e-9);
        assert_relative_eq!(a.il, b.il, epsilon = 1e-9);
        assert_relative_eq!(a.vout_avg, b.vout_avg, epsilon = 1e-9);
        assert!(k > 0 || a.vout.is_finite());
    }
    // A step spanning many periods, ending mid-period, also lands on the same trajectory.
    let mut long = Converter::new(p, Mode::Switched);
    let mut short = long.clone();
    long.step(17.5 * t).unwrap();
    for _ in 0..35 {
        short.step(0.5 * t).unwrap();
    }
    assert_relative_eq!(long.outputs().vout, short.outputs().vout, epsilon = 1e-9);
    assert_relative_eq!(long.outputs().il, short.outputs().il, epsilon = 1e-9);
}

/// The duty is latched at the period start: changing it mid-period has no effect until the
/// next period.
#[test]
fn duty_is_latched_at_period_start() {
    let p = Params::default();
    let t = p.period();
    let mut a = Converter::new(p, Mode::Switched);
    let mut b = a.clone();
    a.step(0.3 * t).unwrap();
    b.step(0.3 * t).unwrap();
    b.set(VarId::Duty, 0.9).unwrap();
    a.step(0.7 * t).unwrap();
    b.step(0.7 * t).unwrap();
    assert_eq!(a.outputs(), b.outputs());
    a.step(t).unwrap();
    b.step(t).unwrap();
    assert!(b.outputs().vout_avg > a.outputs().vout_avg + 0.01);
}

/// The stiff corner (Cl = 1 nF, the smallest allowed, Rc·Cl = 0.1 ns ≪ T) stays exact.
#[test]
fn stiff_corner_is_stable() {
    let p = Params { cl: 1e-9, ..Default::default() };
    let conv = settled(Mode::Switched, p, Inputs::default(), 3000);
    assert_relative_eq!(conv.outputs().vout_avg, 5.9, epsilon = 1e-6);
}

#[test]
fn bad_values_are_rejected_by_name() {
    let mut conv = Converter::new(Params::default(), Mode::Averaged);
    let before = conv.clone();
    for (id, v) in [(VarId::Duty, 1.5), (VarId::Duty, f64::NAN), (VarId::L, 0.0), (VarId::Cl, -1e-6), (VarId::Fs, f64::INFINITY)] {
        let err = conv.set(id, v).unwrap_err().to_string();
        let name = variables::VARIABLES[variables::vr(id) as usize].name;
        assert!(err.starts_with(name), "{err}");
    }
    assert_eq!(conv.params(), before.params());
    assert!(conv.set(VarId::Mode, 3.0).is_err());
    assert!(conv.set(VarId::Vout, 1.0).is_err());
    assert_eq!(conv.step(0.0), Err(ModelError::BadStep(0.0)));
    assert!(conv.step(f64::NAN).is_err());
}

/// The Rust defaults and the table's start values are one set of numbers.
#[test]
fn start_values_are_the_defaults_and_in_range() {
    let conv = Converter::from_start_values();
    assert_eq!(*conv.params(), Params::default());
    assert_eq!(*conv.inputs(), Inputs::default());
    assert_eq!(conv.mode(), Mode::Averaged);
    for var in variables::VARIABLES {
        if let Type::Real { start: Some(s), .. } = var.ty {
            assert_eq!(var.check_real(s), Ok(s), "{}", var.name);
        }
    }
}

/// Steps far shorter than the snap tolerance still advance the state (no silent drop), and
/// a thousand of them equal one step of their total length.
#[test]
fn tiny_steps_are_simulated() {
    let p = Params::default();
    let mut conv = Converter::new(p, Mode::Switched);
    conv.set(VarId::SteadyStart, 0.0).unwrap();
    conv.initialize();
    let mut one = conv.clone();
    for _ in 0..1000 {
        conv.step(1e-15).unwrap();
    }
    assert!(conv.outputs().il > 0.0, "state did not move");
    one.step(1e-12).unwrap();
    assert_relative_eq!(conv.outputs().il, one.outputs().il, max_relative = 1e-9);
}

/// A master that steps by T in floating point (times accumulating rounding error) still
/// latches each period's duty from the input it set for that period.
#[test]
fn rounding_in_the_masters_time_does_not_shift_the_latch() {
    let p = Params::default();
    let t = p.period();
    let mut exact = Converter::new(p, Mode::Switched);
    let mut rounded = exact.clone();
    for k in 0..300 {
        let d = if (k / 3) % 2 == 0 { 0.4 } else { 0.6 };
        exact.set(VarId::Duty, d).unwrap();
        rounded.set(VarId::Duty, d).unwrap();
        exact.step(t).unwrap();
        // Alternately a hair longer and shorter than T, as (k+1)·T − k·T is in floating point.
        rounded.step(t * (1.0 + if k % 2 == 0 { 1e-13 } else { -1e-13 })).unwrap();
        assert_relative_eq!(exact.outputs().vout_avg, rounded.outputs().vout_avg, epsilon = 1e-9);
    }
}

/// A duty that moves every period (a closed loop's) needs more pieces than the cache holds;
/// those beyond it go on the circuit's ladder. Each period so stepped agrees with the same period
/// stepped by a fresh converter, whose empty cache takes the exponential of its own pieces,
/// within 1e-12 of the state's scale.
#[test]
fn pieces_beyond_the_cache_step_as_the_exponential_does() {
    let p = Params::default();
    let inputs = Inputs { duty: 0.3, io: 2.0, vin: 12.0, ..Inputs::default() };
    let mut conv = settled(Mode::Switched, p, inputs, 10);
    for k in 0..60 {
        let duty = 0.3 + 0.005 * k as f64;
        let start = conv.state();
        conv.set(VarId::Duty, duty).unwrap();
        conv.step(p.period()).unwrap();
        let mut fresh = Converter::new(p, Mode::Switched);
        fresh.set_inputs(Inputs { duty, ..inputs }).unwrap();
        fresh.initialize();
        fresh.set_state(start);
        fresh.step(p.period()).unwrap();
        let (a, b) = (conv.state(), fresh.state());
        for (x, y, scale) in [(a.il, b.il, 2.0), (a.vc, b.vc, 12.0), (a.vo, b.vo, 12.0)] {
            assert!((x - y).abs() <= 1e-12 * scale, "period {k}: {x} against {y}");
        }
    }
}
