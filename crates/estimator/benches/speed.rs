//! Speed of the fit alone (data already recorded): 3001 samples, vout with σ = 2 mV,
//! side by side with scipy `least_squares` fits of the same averaged model on the same data
//! (`benches/scipy_baseline.py`, run with the project's venv): one simulating with the
//! textbook `dlsim`, one hand-vectorized with `lfilter`.
//!
//! `cargo bench -p estimator --bench speed -- [--python .venv/bin/python]`
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test or benchmark: failing loudly is the point
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use buck_model::{Mode, Params};
use estimator::data::DataSet;
use estimator::experiment::{Experiment, ModelPlant, run};
use estimator::model::{Free, Model, Sampling, Signal, Structure};
use estimator::pem::{FitOptions, fit};

const REPEAT: usize = 50;

fn median_fit_seconds(structure: Structure, data: &DataSet) -> (f64, f64) {
    let mut times = Vec::with_capacity(REPEAT);
    let mut cl = f64::NAN;
    for _ in 0..REPEAT {
        let start = Instant::now();
        let model = Model::new(structure, Sampling::PeriodStart, &[Signal::Vout], &[Free::Cl], data, data.sample_period()).expect("model");
        let f = fit(&model, &Params::default(), &FitOptions::default()).expect("fit");
        times.push(start.elapsed().as_secs_f64());
        cl = f.estimate("Cl").expect("Cl").value;
    }
    times.sort_by(f64::total_cmp);
    (times[REPEAT / 2], cl)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let python = args.iter().position(|a| a == "--python").and_then(|i| args.get(i + 1).map(PathBuf::from)).unwrap_or_else(|| root.join(".venv/bin/python"));
    let truth = Params { cl: 2.2e-6, ..Params::default() };
    let exp = Experiment { samples: 3001, noise_vout: 2e-3, ..Experiment::default() };
    let averaged = run(&mut ModelPlant::new(truth, Mode::Averaged), &exp).expect("run");
    let switched = run(&mut ModelPlant::new(truth, Mode::Switched), &exp).expect("run");

    let (t_avg, cl_avg) = median_fit_seconds(Structure::Averaged, &averaged);
    let (t_pwm, cl_pwm) = median_fit_seconds(Structure::Pwm, &switched);

    let csv = std::env::temp_dir().join("buckid-speed-averaged.csv");
    averaged.write_csv(&csv).expect("write csv");
    let script = root.join("crates/estimator/benches/scipy_baseline.py");
    type Baseline<'a> = (&'a str, Option<(f64, f64, f64)>);
    let baselines: Vec<Baseline> = ["lfilter", "dlsim"].into_iter().map(|sim| (sim, scipy(&python, &script, &csv, sim))).collect();
    let fastest = baselines.iter().filter_map(|(_, b)| b.map(|b| b.0)).fold(f64::INFINITY, f64::min);
    println!("Cl identification from 3001 samples (true Cl = 2.2 µF, σ = 2 mV on vout); median of {REPEAT} fits\n");
    println!("| fit | model | wall time | Cl [µF] | vs scipy |");
    println!("|---|---|---:|---:|---:|");
    let ratio = |t: f64| if fastest.is_finite() { format!("{:.0}× faster than the fastest scipy", fastest / t) } else { "–".to_string() };
    println!("| buckid PEM (Rust) | averaged | {:.2} ms | {:.4} | {} |", t_avg * 1e3, cl_avg * 1e6, ratio(t_avg));
    println!("| buckid PEM (Rust) | sampled-data PWM (switched data) | {:.2} ms | {:.4} | {} |", t_pwm * 1e3, cl_pwm * 1e6, ratio(t_pwm));
    for (sim, b) in baselines {
        if let Some((s, cl, nfev)) = b {
            println!("| scipy least_squares + {sim} (best of 5) | averaged | {:.2} ms | {:.4} | buckid averaged is {:.0}× faster ({nfev} evaluations) |", s * 1e3, cl * 1e6, s / t_avg);
        }
    }
}

/// Runs the scipy baseline with one simulator: `(seconds, Cl, evaluations)`.
fn scipy(python: &std::path::Path, script: &std::path::Path, csv: &std::path::Path, simulator: &str) -> Option<(f64, f64, f64)> {
    match Command::new(python).arg(script).arg(csv).args(["--simulator", simulator]).output() {
        Ok(out) if out.status.success() => {
            let text = String::from_utf8_lossy(&out.stdout);
            let field = |k: &str| -> f64 { text.split(&format!("\"{k}\": ")).nth(1).and_then(|r| r.split([',', '}']).next()).and_then(|v| v.trim().parse().ok()).unwrap_or(f64::NAN) };
            Some((field("seconds"), field("cl"), field("nfev")))
        }
        Ok(out) => {
            eprintln!("scipy baseline ({simulator}) failed: {}", String::from_utf8_lossy(&out.stderr));
            None
        }
        Err(e) => {
            eprintln!("cannot run {}: {e} (run scripts/setup)", python.display());
            None
        }
    }
}
