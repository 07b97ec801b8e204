//! Speed of the fit alone (data already recorded): 3001 samples, vout with σ = 2 mV,
//! side by side with a scipy `least_squares` fit of the same averaged model on the same data
//! (`benches/scipy_baseline.py`, run with the project's venv).
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
    let python = args
        .iter()
        .position(|a| a == "--python")
        .and_then(|i| args.get(i + 1).map(PathBuf::from))
        .unwrap_or_else(|| root.join(".venv/bin/python"));
    let truth = Params { cl: 2.2e-6, ..Params::default() };
    let exp = Experiment { samples: 3001, noise_vout: 2e-3, ..Experiment::default() };
    let averaged = run(&mut ModelPlant::new(truth, Mode::Averaged), &exp).expect("run");
    let switched = run(&mut ModelPlant::new(truth, Mode::Switched), &exp).expect("run");

    let (t_avg, cl_avg) = median_fit_seconds(Structure::Averaged, &averaged);
    let (t_pwm, cl_pwm) = median_fit_seconds(Structure::Pwm, &switched);

    let csv = std::env::temp_dir().join("buckid-speed-averaged.csv");
    averaged.write_csv(&csv).expect("write csv");
    let scipy = Command::new(&python).arg(root.join("crates/estimator/benches/scipy_baseline.py")).arg(&csv).output();
    let baseline = match scipy {
        Ok(out) if out.status.success() => {
            let text = String::from_utf8_lossy(&out.stdout);
            let field = |k: &str| -> f64 {
                text.split(&format!("\"{k}\": ")).nth(1).and_then(|r| r.split([',', '}']).next()).and_then(|v| v.trim().parse().ok()).unwrap_or(f64::NAN)
            };
            Some((field("seconds"), field("cl"), field("nfev")))
        }
        Ok(out) => {
            eprintln!("scipy baseline failed: {}", String::from_utf8_lossy(&out.stderr));
            None
        }
        Err(e) => {
            eprintln!("cannot run {}: {e} (run scripts/setup)", python.display());
            None
        }
    };

    println!("Cl identification from 3001 samples (true Cl = 2.2 µF, σ = 2 mV on vout); median of {REPEAT} fits\n");
    println!("| fit | model | wall time | Cl [µF] | vs scipy |");
    println!("|---|---|---:|---:|---:|");
    let ratio = |t: f64| baseline.map_or("–".to_string(), |(s, _, _)| format!("{:.0}× faster", s / t));
    println!("| buckid PEM (Rust) | averaged | {:.2} ms | {:.4} | {} |", t_avg * 1e3, cl_avg * 1e6, ratio(t_avg));
    println!("| buckid PEM (Rust) | sampled-data PWM (switched data) | {:.2} ms | {:.4} | {} |", t_pwm * 1e3, cl_pwm * 1e6, ratio(t_pwm));
    if let Some((s, cl, nfev)) = baseline {
        println!("| scipy least_squares (best of 5) | averaged | {:.2} ms | {:.4} | 1× ({nfev} evaluations) |", s * 1e3, cl * 1e6);
    }
}
