//! `buckid`: identify the load capacitance `Cl` of a buck converter from an FMU or a data file.
//!
//! Human-readable summary on stdout, progress on stderr, machine-readable JSON with `--json`,
//! an HTML report with `--report DIR`.
#![forbid(unsafe_code)]

mod convert;
mod diagnose;
mod identify;
mod isolate;
mod nominal_fmu;
mod report;
mod simulate;
mod sweep;
mod units;

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

/// Identify the load capacitance of a buck DC-DC converter.
#[derive(Debug, Parser)]
#[command(name = "buckid", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Estimate Cl with its 95 % confidence interval, validated on held-out data.
    Identify(Box<IdentifyArgs>),
    /// Say where the averaged model misses the data, which unmodelled effect explains it, and
    /// how far the held-out error shrinks once it is added.
    Diagnose(DiagnoseArgs),
    /// Convert a measurement into the data contract (an oscilloscope capture: one row per
    /// switching period).
    Convert(convert::ConvertArgs),
    /// Run any FMI 2.0 Co-Simulation FMU with stepped inputs and record its variables to a CSV.
    Simulate(simulate::SimulateArgs),
}

#[derive(Debug, Args)]
struct DiagnoseArgs {
    /// CSV data file (the data contract), e.g. from ngspice (`scripts/spice/buck_spice.py`).
    #[arg(long, required_unless_present = "sweep", default_value = "-", hide_default_value = true)]
    data: PathBuf,
    /// A steady-state sweep (one operating point per row, see the README): which DC effects
    /// explain the gap to the nominal DC model.
    #[arg(long, conflicts_with_all = ["fmu", "nominal"])]
    sweep: Option<PathBuf>,
    /// The nominal model given as an FMI 2.0 Co-Simulation FMU: its start values of L, RL, C,
    /// Rc, fs and `mode` set the nominal circuit and model, and it is also run on the data's
    /// inputs to report its own held-out error.
    #[arg(long)]
    fmu: Option<PathBuf>,
    /// The nominal simulation model (default: the FMU's `mode`, else the one the data calls
    /// for: switched where it shows its switching, averaged where it does not).
    #[arg(long, value_enum)]
    nominal: Option<NominalChoice>,
    /// Map an input/output role (duty, io, vin, vout) to a variable of the --fmu.
    #[arg(long = "map", value_name = "ROLE=NAME", requires = "fmu")]
    map: Vec<String>,
    /// Fraction of the samples, at the end, held out for judging.
    #[arg(long, default_value_t = 1.0 / 3.0)]
    holdout: f64,
    /// Relative tolerance of the nominal circuit values: a fitted L, C or Rc within it of its
    /// nominal is reported as consistent with the nominal, not as `param_drift`.
    #[arg(long, default_value_t = 0.01)]
    tolerance: f64,
    /// Write the diagnosis as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write an HTML report with SVG plots into this folder.
    #[arg(long)]
    report: Option<PathBuf>,
}

/// A known circuit value that can be estimated with Cl.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum CircuitValue {
    /// Inductance.
    #[value(name = "L")]
    L,
    /// Inductor series resistance.
    #[value(name = "RL")]
    Rl,
    /// Main capacitance.
    #[value(name = "C")]
    C,
    /// ESR of the main capacitance.
    #[value(name = "Rc")]
    Rc,
}

/// The nominal model of a diagnosis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum NominalChoice {
    /// The averaged circuit (no switching ripple).
    Averaged,
    /// The ideal switched circuit sampled at period starts (sampled-data PWM model).
    Switched,
}

/// Model structure choice.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ModelChoice {
    /// Fit averaged and PWM, keep the better one on held-out data.
    Auto,
    /// Averaged third-order model.
    Averaged,
    /// Sampled-data PWM model (exact for switched plants sampled at period start).
    Pwm,
    /// Reduced second-order model driven by the measured inductor current.
    Reduced,
}

/// Predictor disturbance model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum NoiseChoice {
    /// Output error (K = 0): white measurement noise; ML for open-loop sensor noise.
    Oe,
    /// Innovations form with the Kalman gain estimated.
    Kalman,
}

/// Which samples are the outputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum SamplingChoice {
    /// Instantaneous values at each period start (the digital controller's view).
    Start,
    /// Exact averages over each period.
    Average,
}

#[derive(Debug, Args)]
struct IdentifyArgs {
    /// FMI 2.0 Co-Simulation FMU to drive with a PRBS duty.
    #[arg(long, conflicts_with = "data", required_unless_present = "data")]
    fmu: Option<PathBuf>,
    /// CSV data file (see the data contract in the README).
    #[arg(long)]
    data: Option<PathBuf>,
    /// Also estimate this circuit value with Cl (L, RL, C or Rc; repeatable): its CI95 says
    /// whether the data identifies it.
    #[arg(long = "estimate", value_name = "NAME", value_enum)]
    estimate: Vec<CircuitValue>,
    /// Also estimate every circuit value (L, RL, C, Rc) the data's metadata does not give.
    #[arg(long)]
    estimate_missing: bool,
    /// Start value of Cl \[F\] (default: a grid search over 0.1–300 µF).
    #[arg(long)]
    cl_guess: Option<f64>,
    /// Samples used for estimation (FMU runs record half as many again for validation).
    #[arg(long, default_value_t = 3001)]
    samples: usize,
    /// Seed of the PRBS and of the added noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Map an estimator role (duty, io, vin, vout, il, vout_avg, il_avg) to an FMU variable.
    #[arg(long = "map", value_name = "ROLE=NAME")]
    map: Vec<String>,
    /// Start value of an FMU variable before initialization (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// σ of white noise added to the recorded vout \[V\] (FMU runs).
    #[arg(long, default_value_t = 0.0)]
    noise_vout: f64,
    /// σ of white noise added to the recorded il \[A\] (FMU runs).
    #[arg(long, default_value_t = 0.0)]
    noise_il: f64,
    /// Model structure.
    #[arg(long, value_enum, default_value_t = ModelChoice::Auto)]
    model: ModelChoice,
    /// Also fit the inductor current as a second output (when measured).
    #[arg(long)]
    with_il: bool,
    /// Output sampling.
    #[arg(long, value_enum, default_value_t = SamplingChoice::Start)]
    sampling: SamplingChoice,
    /// Predictor disturbance model (default: oe in open loop, kalman in closed loop).
    #[arg(long, value_enum)]
    noise_model: Option<NoiseChoice>,
    /// Levels of the PRBS: duties in open loop (default 0.4 0.6), duty dither in closed loop
    /// (default −0.02 0.02).
    #[arg(long, num_args = 2, value_names = ["LOW", "HIGH"], allow_negative_numbers = true)]
    duty: Option<Vec<f64>>,
    /// Identify while the FMU's controller regulates: excite through `duty_dither`, record the
    /// applied duty (`duty_applied`) and the ADC readings, fit with the Kalman predictor.
    #[arg(long)]
    closed_loop: bool,
    /// σ of an unmeasured load-current disturbance drawn every period \[A\] (FMU runs).
    #[arg(long, default_value_t = 0.0)]
    load_noise: f64,
    /// Switching periods per PRBS bit.
    #[arg(long, default_value_t = 8)]
    bit_periods: usize,
    /// Constant load current during the experiment \[A\].
    #[arg(long, default_value_t = 1.0)]
    io: f64,
    /// Input voltage during the experiment \[V\].
    #[arg(long, default_value_t = 12.0)]
    vin: f64,
    /// Fraction of a data file held out for validation (FMU runs record extra samples instead).
    #[arg(long, default_value_t = 1.0 / 3.0)]
    holdout: f64,
    /// Write the result as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write an HTML report with SVG plots into this folder.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Write the recorded data set (CSV contract) to this file (FMU runs).
    #[arg(long)]
    save_data: Option<PathBuf>,
}

/// An error and its causes, each said once: a cause whose words the message so far already
/// ends with is not repeated (the library errors print their cause, `"{path}: {source}"`, and
/// also chain it, which read "No such file or directory (os error 2)" twice).
fn message(e: &anyhow::Error) -> String {
    e.chain().skip(1).fold(e.to_string(), |text, cause| {
        let cause = cause.to_string();
        if text.ends_with(&cause) { text } else { format!("{text}: {cause}") }
    })
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    // A command that loads an FMU runs in a child process (see `isolate`).
    let fmu = match &cli.command {
        Command::Identify(args) => args.fmu.as_deref(),
        Command::Diagnose(args) => args.fmu.as_deref(),
        Command::Simulate(args) => Some(args.fmu()),
        Command::Convert(_) => None,
    };
    if let Some(code) = fmu.and_then(isolate::supervise) {
        return code;
    }
    let result = match cli.command {
        Command::Identify(args) => identify::run(&args),
        Command::Diagnose(args) if args.sweep.is_some() => sweep::run(&args),
        Command::Diagnose(args) => diagnose::run(&args),
        Command::Convert(args) => convert::run(&args),
        Command::Simulate(args) => simulate::run(&args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", message(&e));
            std::process::ExitCode::FAILURE
        }
    }
}
