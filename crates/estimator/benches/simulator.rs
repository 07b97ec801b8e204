//! Speed of the switched plant simulator (`estimator::simulated::simulate`, what every
//! diagnosis fit runs once per trial step), on 3001 periods of open-loop PRBS data (two duty
//! levels) and of closed-loop data (the converter's own PID and 10-bit DPWM, a ±0.02 PRBS
//! dither: the duty moves every period over tens of levels), and of the open-loop data read
//! through an RC anti-alias filter (`vout_filter`, followed on pieces of T/8), side by side in one
//! run.
//!
//! `cargo bench -p estimator --bench simulator`
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test or benchmark: failing loudly is the point
use std::time::Instant;

use buck_model::variables::VarId;
use buck_model::{Converter, Mode, Params};
use estimator::data::DataSet;
use estimator::experiment::{Experiment, ModelPlant, Prbs, run};
use estimator::simulated::simulate;

const REPEAT: usize = 30;

/// Median wall time of one simulation of `data` with the circuit `p`.
fn median_seconds(p: &Params, data: &DataSet) -> f64 {
    let mut times: Vec<f64> = (0..REPEAT)
        .map(|_| {
            let start = Instant::now();
            simulate(p, data, data.vout[0]).expect("simulate");
            start.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[REPEAT / 2]
}

fn levels(data: &DataSet) -> usize {
    data.duty.iter().map(|d| d.to_bits()).collect::<std::collections::BTreeSet<_>>().len()
}

fn main() {
    let p = Params { cl: 4.7e-6, ..Params::default() };
    let open = run(&mut ModelPlant::new(p, Mode::Switched), &Experiment { noise_vout: 2e-3, ..Experiment::default() }).expect("open loop");
    let mut c = Converter::new(p, Mode::Switched);
    for (id, v) in [(VarId::Control, 2.0), (VarId::DpwmBits, 10.0), (VarId::AdcNoise, 2e-3)] {
        c.set(id, v).expect("loop setting");
    }
    let exp = Experiment { record_applied_duty: true, prbs: Prbs { low: -0.02, high: 0.02, ..Prbs::default() }, ..Experiment::default() };
    let closed = run(&mut ModelPlant::closed_loop(c), &exp).expect("closed loop");
    let (t_open, t_closed) = (median_seconds(&p, &open), median_seconds(&p, &closed));
    let t_filtered = median_seconds(&Params { vout_filter: p.period() / std::f64::consts::PI, ..p }, &open);
    println!("Switched plant simulator, 3001 periods, median of {REPEAT} runs\n");
    println!("| data | duty levels | wall time | vs open loop |");
    println!("|---|---:|---:|---:|");
    println!("| open loop, PRBS 0.4/0.6 | {} | {:.2} ms | 1.00× |", levels(&open), t_open * 1e3);
    println!("| closed loop, PID + 10-bit DPWM, PRBS dither ±0.02 | {} | {:.2} ms | {:.2}× |", levels(&closed), t_closed * 1e3, t_closed / t_open);
    println!("| open loop read through an RC filter, τ = T/π | {} | {:.2} ms | {:.2}× |", levels(&open), t_filtered * 1e3, t_filtered / t_open);
}
