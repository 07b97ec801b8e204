//! The DC model against the workspace's exact switched simulator (`buck_model::Converter` in
//! `Mode::Switched`, current load) in periodic steady state: run 8000 periods, average
//! `vout_avg` over the last 200. CCM points are exact up to the neglected ramp curvature
//! (R·T/L ≈ 1e-2 here gives < 1 mV); DCM points up to the output ripple and the linear-ramp
//! treatment of the resistive drop (tolerance 0.5 % of vout).
use buck_model::{Converter, Inputs, Mode, Params};
use dc_sweep::{Circuit, Conduction, Effects, OperatingPoint, solve};

fn simulate(p: Params, duty: f64, io: f64) -> f64 {
    let mut conv = Converter::new(p, Mode::Switched);
    conv.set_inputs(Inputs { duty, io, vin: 12.0, ..Inputs::default() }).unwrap_or_else(|e| panic!("{e}"));
    conv.initialize();
    let t = 1.0 / p.fs;
    for _ in 0..8000 {
        conv.step(t).unwrap_or_else(|e| panic!("{e}"));
    }
    let mut sum = 0.0;
    for _ in 0..200 {
        conv.step(t).unwrap_or_else(|e| panic!("{e}"));
        sum += conv.outputs().vout_avg;
    }
    sum / 200.0
}

fn dc(p: &Params, duty: f64, io: f64) -> dc_sweep::DcPoint {
    let c = Circuit { l: p.l, rl: p.rl, fs: p.fs, rds_on: p.switch_resistance, body_diode_drop: p.body_diode_drop() };
    let e = Effects { diode: p.asynchronous(), diode_drop: p.diode_drop, dead_time: p.dead_time, ..Effects::default() };
    solve(&c, &e, &OperatingPoint { duty, vin: 12.0, io, rload: None }).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn dc_model_matches_the_switched_simulator() {
    let base = Params { c: 300e-6, rc: 0.01, ..Params::default() };
    let cases = [
        ("sync + rds_on", Params { switch_resistance: 0.03, ..base }, 0.4, 2.0, Conduction::Continuous, 1e-3),
        ("sync + dead time, il > 0", Params { dead_time: 30e-9, ..base }, 0.45, 3.0, Conduction::Continuous, 1e-3),
        ("sync + dead time, il < 0", Params { dead_time: 30e-9, ..base }, 0.45, -3.0, Conduction::Continuous, 1e-3),
        ("diode CCM", Params { diode_drop: 0.5, switch_resistance: 0.02, ..base }, 0.45, 3.0, Conduction::Continuous, 1e-3),
        ("diode DCM", Params { diode_drop: 0.5, ..base }, 0.3, 0.3, Conduction::Discontinuous, 5e-3),
        ("ideal diode DCM", Params { dcm: true, ..base }, 0.2, 0.2, Conduction::Discontinuous, 5e-3),
    ];
    for (what, p, d, io, mode, tol) in cases {
        let model = dc(&p, d, io);
        let sim = simulate(p, d, io);
        assert_eq!(model.conduction, mode, "{what}");
        let rel = (model.vout - sim).abs() / sim.abs();
        assert!(rel < tol, "{what}: DC model {} V, switched {sim} V (rel {rel:e})", model.vout);
    }
}
