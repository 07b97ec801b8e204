//! Accuracy of the Cl estimate on the thesis grid, without any post-hoc mapping.
//!
//! `cargo bench -p estimator --bench accuracy -- [--runs N] [--fmu PATH] [--rload R]`
//!
//! `--rload R` adds a load resistor of R Ω beside the 1 A load current in every plant (the FMU
//! gets `rload = R`); the models take it from the data's `# rload` metadata, as the CLI does.
//! The third-party FMUs have no resistor and are skipped then.
//!
//! 1. Averaged plant, averaged model, outputs vout and il with σ = 2 mV and 20 mA, 3001
//!    samples: Monte Carlo over N noise seeds (default 500). Per Cl: the RMS error against the
//!    Cramér–Rao σ, the first run's error in units of that σ (target ≤ 3), and the coverage of
//!    the 95 % confidence interval (target 95 ± 3 %).
//! 2. The switched FMU (default `fmu/BuckConverter.fmu`, built by `cargo xtask fmu`), sampled at
//!    the period start, σ = 2 mV / 20 mA, 3001 samples: the sampled-data PWM model against the
//!    averaged one (target |error| < 2 % for Cl ≥ 1 µF, < 10 % for 0.2–0.5 µF), and the CI
//!    coverage of the PWM model over N/5 in-process switched runs.
//! 3. The pythonfmu and qfmu FMUs of `tests/thirdparty` with their hidden Cl: inside the CI95?
//! 4. The thesis's figures beside ours (docs/thesis-figures.md).
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test or benchmark: failing loudly is the point
use std::path::PathBuf;
use std::sync::OnceLock;
use std::time::Instant;

use buck_model::{Mode, Params};
use estimator::data::DataSet;
use estimator::experiment::{Experiment, ModelPlant, Plant, run};
use estimator::fmu_plant::{FmuOptions, FmuPlant};
use estimator::model::{Free, Model, Sampling, Signal, Structure};
use estimator::pem::{FitOptions, crlb, fit};

const GRID_UF: [f64; 11] = [0.2, 0.5, 1.0, 2.0, 3.0, 5.0, 7.0, 10.0, 50.0, 80.0, 100.0];
const SIGMA: [f64; 2] = [2e-3, 20e-3];
const OUTPUTS: [Signal; 2] = [Signal::Vout, Signal::Il];

fn arg(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1).cloned())
}

/// The load resistor of every plant \[Ω\] (`--rload`, 0 = none).
fn rload() -> f64 {
    static RLOAD: OnceLock<f64> = OnceLock::new();
    *RLOAD.get_or_init(|| arg("--rload").map_or(0.0, |s| s.parse().expect("--rload R: a number of ohms")))
}

/// The plant's circuit with this Cl \[F\].
fn circuit(cl: f64) -> Params {
    Params { cl, rload: rload(), ..Params::default() }
}

fn experiment(seed: u64, noisy: bool) -> Experiment {
    let (v, i) = if noisy { (SIGMA[0], SIGMA[1]) } else { (0.0, 0.0) };
    Experiment { samples: 3001, noise_vout: v, noise_il: i, noise_seed: seed, ..Experiment::default() }
}

fn model(structure: Structure, data: &DataSet) -> Model {
    let period = data.sample_period();
    Model::new(structure, Sampling::PeriodStart, &OUTPUTS, &[Free::Cl], data, period).expect("model")
}

/// Relative error, relative CI bounds and coverage of one fit.
struct Outcome {
    err: f64,
    covered: bool,
    ci: (f64, f64),
}

fn identify(structure: Structure, data: &DataSet, truth: f64) -> Outcome {
    // The known circuit: the thesis values and the data's load resistor.
    let nominal = Params { rload: data.rload().expect("rload metadata"), ..Params::default() };
    let f = fit(&model(structure, data), &nominal, &FitOptions::default()).expect("fit");
    let e = f.estimate("Cl").expect("Cl");
    Outcome { err: e.value / truth - 1.0, covered: e.ci95.0 <= truth && truth <= e.ci95.1, ci: e.ci95 }
}

/// Cramér–Rao relative σ of Cl for this plant and input (initial state unknown).
fn crlb_rel(plant: &mut dyn Plant, structure: Structure, truth: &Params) -> f64 {
    let clean = run(plant, &experiment(0, false)).expect("run");
    let m = model(structure, &clean);
    let f = fit(&m, truth, &FitOptions { guess: Some(vec![truth.cl]), ..FitOptions::default() }).expect("clean fit");
    crlb(&m, truth, &f.x0, &SIGMA).expect("crlb")[(0, 0)].sqrt()
}

fn monte_carlo(plant: &mut dyn Plant, structure: Structure, truth: f64, runs: usize) -> (f64, f64, f64, f64) {
    let (mut sum, mut sq, mut covered, mut first) = (0.0, 0.0, 0usize, 0.0);
    for r in 0..runs {
        let data = run(plant, &experiment(1000 + r as u64, true)).expect("run");
        let o = identify(structure, &data, truth);
        let le = (1.0 + o.err).ln();
        if r == 0 {
            first = le;
        }
        sum += le;
        sq += le * le;
        covered += usize::from(o.covered);
    }
    let n = runs as f64;
    (first, sum / n, (sq / n).sqrt(), 100.0 * covered as f64 / n)
}

fn main() {
    let runs: usize = arg("--runs").and_then(|s| s.parse().ok()).unwrap_or(500);
    // The packaged FMU, rebuilt when stale (its path even when that fails, for the message).
    let fmu = arg("--fmu").map(PathBuf::from).unwrap_or_else(|| fmu_fixture::buck_fmu().map_or_else(|_| fmu_fixture::root().join("fmu/BuckConverter.fmu"), PathBuf::from));
    let start = Instant::now();
    if rload() > 0.0 {
        println!("Load: io = 1 A and a load resistor rload = {} Ω in every plant.\n", rload());
    }

    println!("## 1. Averaged plant, averaged model, vout + il (σ = 2 mV, 20 mA), 3001 samples, {runs} Monte Carlo runs\n");
    println!("| Cl [µF] | σ_CRLB [%] | RMS error [%] | RMS / σ_CRLB | mean error [%] | first run / σ_CRLB | CI95 coverage [%] |");
    println!("|---:|---:|---:|---:|---:|---:|---:|");
    let mut worst_cover: (f64, f64) = (100.0, 0.0);
    for cl in GRID_UF {
        let truth = circuit(cl * 1e-6);
        let mut plant = ModelPlant::new(truth, Mode::Averaged);
        let sigma = crlb_rel(&mut plant, Structure::Averaged, &truth);
        let (first, mean, rms, cover) = monte_carlo(&mut plant, Structure::Averaged, truth.cl, runs);
        worst_cover = (worst_cover.0.min(cover), worst_cover.1.max(cover));
        println!("| {cl} | {:.3} | {:.3} | {:.2} | {:+.3} | {:+.2} | {:.1} |", 100.0 * sigma, 100.0 * rms, rms / sigma, 100.0 * mean, first / sigma, cover);
    }
    println!("\nCoverage range over the grid: {:.1}–{:.1} % (target 95 ± 3 %).\n", worst_cover.0, worst_cover.1);

    println!("## 2. Switched plant sampled at the period start, vout + il (σ = 2 mV, 20 mA), 3001 samples\n");
    println!("The error and CI columns are one FMU run (seed 1); the RMS column is the typical error.\n");
    let have_fmu = fmu.is_file();
    if !have_fmu {
        println!("(FMU {} not found: run `cargo xtask fmu`; using the in-process switched model)\n", fmu.display());
    }
    let mc_runs = (runs / 5).max(20);
    println!("| Cl [µF] | PWM model error [%] | PWM CI95 [µF] | target | averaged model error [%] | PWM RMS error over {mc_runs} runs [%] | PWM σ_CRLB [%] | PWM coverage [%] |");
    println!("|---:|---:|---|---:|---:|---:|---:|---:|");
    for cl in GRID_UF {
        let truth = circuit(cl * 1e-6);
        let data = if have_fmu {
            let mut set = vec![("Cl".into(), truth.cl), ("mode".into(), 2.0)];
            if truth.rload > 0.0 {
                set.push(("rload".into(), truth.rload));
            }
            let opts = FmuOptions { set, ..FmuOptions::default() };
            let mut plant = FmuPlant::open(&fmu, &opts).expect("open FMU");
            run(&mut plant, &experiment(1, true)).expect("FMU run")
        } else {
            run(&mut ModelPlant::new(truth, Mode::Switched), &experiment(1, true)).expect("run")
        };
        let pwm = identify(Structure::Pwm, &data, truth.cl);
        let avg = identify(Structure::Averaged, &data, truth.cl);
        let target = if cl >= 1.0 { 2.0 } else { 10.0 };
        let mut switched = ModelPlant::new(truth, Mode::Switched);
        let sigma = crlb_rel(&mut switched, Structure::Pwm, &truth);
        let (_, _, rms, cover) = monte_carlo(&mut switched, Structure::Pwm, truth.cl, mc_runs);
        println!(
            "| {cl} | {:+.3} {} | [{:.4}, {:.4}] | < {target} % | {:+.2} | {:.3} | {:.3} | {:.1} |",
            100.0 * pwm.err,
            if 100.0 * pwm.err.abs() < target { "✓" } else { "✗" },
            pwm.ci.0 * 1e6,
            pwm.ci.1 * 1e6,
            100.0 * avg.err,
            100.0 * rms,
            100.0 * sigma,
            cover
        );
    }
    println!("\n## 3. Third-party FMUs with a hidden Cl (averaged model, σ = 2 mV / 20 mA, seed 1)\n");
    if rload() > 0.0 {
        println!("(skipped with --rload: these FMUs have no load resistor)");
    } else {
        third_party(&fmu_fixture::root());
    }
    println!("\n## 4. The thesis (Osman & Osman, BTH 2011), for comparison\n");
    let thesis = fmu_fixture::root().join("docs/thesis-figures.md");
    match std::fs::read_to_string(&thesis) {
        Ok(text) => println!("See {} — its tables:\n\n{}", thesis.display(), thesis_tables(&text)),
        Err(_) => println!("(docs/thesis-figures.md not found)"),
    }
    eprintln!("accuracy bench took {:.1} s", start.elapsed().as_secs_f64());
}

/// The pythonfmu and qfmu buck FMUs of `tests/thirdparty` (built by its `build.sh`), with the
/// Cl their sources hide. Their variables are mapped onto the estimator's roles.
fn third_party(root: &std::path::Path) {
    type Target<'a> = (&'a str, f64, &'a [(&'a str, &'a str)]);
    let targets: [Target; 2] = [
        ("BuckPy.fmu (pythonfmu)", 4.7e-6, &[("duty", "D"), ("io", "Iload"), ("vin", "Vin"), ("vout", "Vout"), ("il", "IL")]),
        ("BuckQ.fmu (qfmu)", 2.2e-6, &[("duty", "u1"), ("io", "u2"), ("vout", "y1"), ("il", "y2")]),
    ];
    println!("| FMU | hidden Cl [µF] | estimate [µF] | CI95 [µF] | inside |");
    println!("|---|---:|---:|---|---|");
    for (name, truth, map) in targets {
        let file = root.join("target/thirdparty").join(name.split(' ').next().unwrap_or(name));
        if !file.is_file() {
            println!("| {name} | {} | not built: run `bash tests/thirdparty/build.sh` | | |", truth * 1e6);
            continue;
        }
        let opts = FmuOptions { map: map.iter().map(|(r, n)| (r.to_string(), n.to_string())).collect(), ..FmuOptions::default() };
        let mut plant = FmuPlant::open(&file, &opts).expect("open FMU");
        let data = run(&mut plant, &experiment(1, true)).expect("FMU run");
        let o = identify(Structure::Averaged, &data, truth);
        let est = truth * (1.0 + o.err);
        println!("| {name} | {} | {:.4} | [{:.4}, {:.4}] | {} |", truth * 1e6, est * 1e6, o.ci.0 * 1e6, o.ci.1 * 1e6, if o.covered { "✓" } else { "✗" });
    }
}

/// The Markdown table blocks of the thesis notes.
fn thesis_tables(text: &str) -> String {
    let mut out = String::new();
    let mut in_table = false;
    for line in text.lines() {
        let is_row = line.trim_start().starts_with('|');
        if is_row || (in_table && line.trim().is_empty()) {
            out.push_str(line);
            out.push('\n');
        } else if line.starts_with("#") || line.starts_with("**Table") {
            out.push('\n');
            out.push_str(line);
            out.push('\n');
        }
        in_table = is_row;
    }
    out
}
