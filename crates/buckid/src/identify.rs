//! `buckid identify`: run or read the data, fit, validate, report.
use std::collections::BTreeMap;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use buck_model::Params;
use estimator::data::DataSet;
use estimator::experiment::{Experiment, Prbs, run as run_experiment};
use estimator::fmu_plant::{FmuOptions, FmuPlant};
use estimator::identify::{Identification, IdentifyOptions, identify};
use estimator::model::{Free, Sampling, Signal, Structure};
use estimator::pem::NoiseModel;
use estimator::validate::identified;
use serde::Serialize;

use crate::units::{si, unit_of, with_ci};
use crate::{CircuitValue, IdentifyArgs, ModelChoice, NoiseChoice, SamplingChoice};

/// Splits `NAME=VALUE`.
pub(crate) fn pair(s: &str, flag: &str) -> Result<(String, String)> {
    let (k, v) = s.split_once('=').with_context(|| format!("{flag} {s:?}: expected NAME=VALUE"))?;
    Ok((k.trim().to_string(), v.trim().to_string()))
}

/// Relative difference between the metadata `fs` and the rows' rate above which the rows'
/// rate is the nominal (the printed time of a record is exact to far less).
const FS_FROM_ROWS: f64 = 1e-3;

/// Known circuit values from the data's metadata; thesis values (with a note) where absent.
pub(crate) fn nominal_from(data: &DataSet) -> Result<(Params, Vec<String>)> {
    nominal_with(data, &BTreeMap::new())
}

/// Known circuit values: `given` (e.g. an FMU's parameter start values, by name) first, then
/// the data's metadata, then the thesis values. Returns the values and one note per value that
/// was assumed (not given) or that the metadata contradicts.
pub(crate) fn nominal_with(data: &DataSet, given: &BTreeMap<&str, f64>) -> Result<(Params, Vec<String>)> {
    let mut p = Params::default();
    let mut assumed = Vec::new();
    type Field = fn(&mut Params) -> &mut f64;
    let fields: [(&str, Field); 5] = [("L", |p| &mut p.l), ("RL", |p| &mut p.rl), ("C", |p| &mut p.c), ("Rc", |p| &mut p.rc), ("fs", |p| &mut p.fs)];
    let valid = |key: &str, v: f64| v.is_finite() && v > 0.0 || (key == "RL" && v == 0.0);
    for (key, field) in fields {
        let meta = data.meta_f64(key)?;
        if let Some(&v) = given.get(key) {
            if !valid(key, v) {
                bail!("the FMU's start value `{key} = {v}` is not a valid circuit value");
            }
            *field(&mut p) = v;
            if let Some(m) = meta.filter(|m| (m - v).abs() > 1e-9 * v.abs()) {
                assumed.push(format!("{key} = {} from the FMU (the data's metadata says {})", si(v, unit_of(key), 4), si(m, unit_of(key), 4)));
            }
            continue;
        }
        match meta {
            // The model switches once per row (the metadata agrees within
            // `estimator::data::FS_MISMATCH`, else the data is refused): a nominal frequency
            // the rows' own rate departs from is the rows'.
            Some(v) if key == "fs" && valid(key, v) && (v * data.sample_period() - 1.0).abs() > FS_FROM_ROWS => {
                p.fs = 1.0 / data.sample_period();
                assumed.push(format!("fs = {} from the rows' spacing (the metadata says {}; the model switches once per row)", si(p.fs, "Hz", 6), si(v, "Hz", 6)));
            }
            Some(v) if valid(key, v) => *field(&mut p) = v,
            Some(v) => bail!("metadata `{key} = {v}` is not a valid circuit value"),
            None if key == "fs" => {
                p.fs = 1.0 / data.sample_period();
                assumed.push(format!("fs = {} from the sample spacing", si(p.fs, "Hz", 6)));
            }
            None => assumed.push(format!("{key} = {} (thesis value; give `# {key} = …` to override)", si(*field(&mut p), unit_of(key), 4))),
        }
    }
    // The load resistor: none (0) unless the FMU or the data names one; its absence is the
    // contract's default, not an assumption worth a note.
    let meta = data.rload()?;
    p.rload = match given.get("rload") {
        Some(&v) if !(v.is_finite() && v >= 0.0) => bail!("the FMU's start value `rload = {v}` is not a valid load resistance"),
        Some(&v) => {
            if (meta - v).abs() > 1e-9 * v.abs() {
                assumed.push(format!("rload = {} from the FMU (the data's metadata says {})", si(v, "Ω", 4), si(meta, "Ω", 4)));
            }
            v
        }
        None => meta,
    };
    // No buck drives more load current than its input through L's resistance alone (a short
    // at the output): more is a column in other units.
    let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len().max(1) as f64;
    let (io, short) = (mean(&data.io), mean(&data.vin) / p.rl);
    if p.rl > 0.0 && io > short {
        bail!(
            "`io` averages {} where the input could drive {} through RL alone (vin/RL, a short at the output): milliamps under a bare `io` header, or another unit? The contract's io is in amperes",
            si(io, "A", 4),
            si(short, "A", 4)
        );
    }
    Ok((p, assumed))
}

/// Records a data set from the FMU: `samples` for estimation plus half as many for validation.
fn record_from_fmu(args: &IdentifyArgs, path: &std::path::Path) -> Result<(DataSet, f64, f64)> {
    let map: BTreeMap<String, String> = args.map.iter().map(|m| pair(m, "--map")).collect::<Result<_>>()?;
    let set = args
        .set
        .iter()
        .map(|s| {
            let (k, v) = pair(s, "--set")?;
            let value = v.parse::<f64>().with_context(|| format!("--set {k}={v}: the value is not a number"))?;
            Ok((k, value))
        })
        .collect::<Result<Vec<_>>>()?;
    let mut defaults = vec![("mode".to_string(), 2.0)];
    let mut default_map = Vec::new();
    if args.closed_loop {
        // Our FMU's closed loop; FMUs without these variables keep their own settings.
        defaults.extend([("control".to_string(), 2.0), ("dpwm_bits".to_string(), 10.0)]);
        default_map = [("duty", "duty_dither"), ("vout", "vout_adc"), ("il", "il_adc")].map(|(r, n)| (r.to_string(), n.to_string())).to_vec();
    }
    let opts = FmuOptions { map, set, defaults, default_map, fs: None };
    eprintln!("loading {}", path.display());
    let mut plant = FmuPlant::open(path, &opts)?;
    let validation = args.samples / 2;
    let levels = excitation_levels(args);
    let exp = Experiment {
        samples: args.samples + validation,
        prbs: Prbs { low: levels[0], high: levels[1], bit_periods: args.bit_periods, seed: args.seed, ..Prbs::default() },
        io: args.io,
        vin: args.vin,
        noise_vout: args.noise_vout,
        noise_il: args.noise_il,
        noise_load: args.load_noise,
        noise_seed: args.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15),
        record_applied_duty: args.closed_loop,
        ..Experiment::default()
    };
    eprintln!(
        "running {} switching periods ({}, PRBS {}/{}, {} periods per bit)",
        exp.samples + exp.warmup,
        if args.closed_loop { "closed loop, dither" } else { "open loop, duty" },
        levels[0],
        levels[1],
        args.bit_periods
    );
    let start = Instant::now();
    let data = run_experiment(&mut plant, &exp)?;
    Ok((data, start.elapsed().as_secs_f64(), validation as f64 / exp.samples as f64))
}

/// The inductor current is optional: a model that needs it (`--with-il`, the reduced model)
/// is refused with the missing role or column named; every other model fits vout alone.
fn require_il(args: &IdentifyArgs, data: &DataSet) -> Result<()> {
    let average = args.sampling == SamplingChoice::Average;
    let (needs, why): (&[&str], &str) = match (args.model, args.with_il) {
        (ModelChoice::Reduced, _) => (&["il", "il_avg"], "the reduced model takes the measured inductor current as its input"),
        (_, true) if average => (&["il_avg"], "--with-il fits the period-average inductor current"),
        (_, true) => (&["il"], "--with-il fits the inductor current"),
        _ => return Ok(()),
    };
    let has = |col: &str| if col == "il" { data.il.is_some() } else { data.il_avg.is_some() };
    let missing: Vec<&str> = needs.iter().copied().filter(|c| !has(c)).collect();
    if missing.is_empty() {
        return Ok(());
    }
    let list = missing.iter().map(|c| format!("`{c}`")).collect::<Vec<_>>().join(" and ");
    match &args.fmu {
        Some(fmu) => bail!(
            "{why}, but the FMU {} has no {list} role{} (no variable of that name, no --map {}=NAME); drop {} to identify Cl from vout alone",
            fmu.display(),
            if missing.len() > 1 { "s" } else { "" },
            missing[0],
            if args.model == ModelChoice::Reduced { "--model reduced" } else { "--with-il" }
        ),
        None => bail!(
            "{why}, but the data has no {list} column{}; drop {} to identify Cl from vout alone",
            if missing.len() > 1 { "s" } else { "" },
            if args.model == ModelChoice::Reduced { "--model reduced" } else { "--with-il" }
        ),
    }
}

/// PRBS levels: `--duty`, or the open/closed-loop defaults.
fn excitation_levels(args: &IdentifyArgs) -> [f64; 2] {
    match &args.duty {
        Some(v) => [v[0], v[1]],
        None if args.closed_loop => [-0.02, 0.02],
        None => [0.4, 0.6],
    }
}

/// What excited the plant and what was recorded, for the report.
#[derive(Debug, Serialize)]
struct Excitation {
    closed_loop: bool,
    signal: &'static str,
    levels: [f64; 2],
    recorded_duty: &'static str,
    load_noise: f64,
}

/// Machine-readable result (the contract of `--json`).
#[derive(Debug, Serialize)]
struct Output {
    cl: Interval,
    /// How Cl's interval was tested, for data from a file (see [`gap::TestedCl`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    cl_test: Option<ClTest>,
    fit_percent: FitPercent,
    model: &'static str,
    samples: usize,
    validation_samples: usize,
    seconds: f64,
    seconds_experiment: Option<f64>,
    outputs: Vec<&'static str>,
    noise_model: &'static str,
    sigma: Vec<f64>,
    residuals: Residuals,
    nominal: BTreeMap<&'static str, f64>,
    assumed: Vec<String>,
    source: String,
    excitation: Option<Excitation>,
    candidates: Vec<CandidateOut>,
    /// Circuit values estimated with Cl (`--estimate`, `--estimate-missing`).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    estimated: BTreeMap<&'static str, Estimated>,
}

/// A circuit value estimated with Cl.
#[derive(Debug, Serialize)]
struct Estimated {
    estimate: f64,
    ci95: [f64; 2],
    /// The CI95 pins it down (positive, finite, narrower than a decade).
    identified: bool,
}

/// Cl and the circuit values asked for (`--estimate`), or missing from the data's metadata
/// (`--estimate-missing`; an FMU run's data carries its circuit values).
fn free_parameters(args: &IdentifyArgs, data: &DataSet) -> Vec<Free> {
    let mut free = vec![Free::Cl];
    let asked = args.estimate.iter().map(|c| match c {
        CircuitValue::L => Free::L,
        CircuitValue::Rl => Free::RL,
        CircuitValue::C => Free::C,
        CircuitValue::Rc => Free::Rc,
    });
    let missing = [Free::L, Free::RL, Free::C, Free::Rc].into_iter().filter(|f| args.estimate_missing && !data.meta.contains_key(f.name()));
    for f in asked.chain(missing) {
        if !free.contains(&f) {
            free.push(f);
        }
    }
    free
}

/// The estimates of the free circuit values other than Cl.
fn estimated(c: &estimator::identify::Candidate, free: &[Free]) -> BTreeMap<&'static str, Estimated> {
    free.iter()
        .filter(|f| **f != Free::Cl)
        .filter_map(|f| c.fit.estimate(f.name()))
        .map(|e| (e.name, Estimated { estimate: e.value, ci95: [e.ci95.0, e.ci95.1], identified: identified([e.ci95.0, e.ci95.1]) }))
        .collect()
}

/// The test of Cl's interval on a circuit's data: a sentence, and the test's parts.
#[derive(Debug, Serialize)]
struct ClTest {
    sentence: String,
    #[serde(flatten)]
    tested: gap::TestedCl,
}

#[derive(Debug, Serialize)]
struct Interval {
    estimate: f64,
    ci95: [f64; 2],
    rel_std: f64,
}

#[derive(Debug, Serialize)]
struct FitPercent {
    simulation: f64,
    prediction: f64,
}

#[derive(Debug, Serialize)]
struct Residuals {
    white: bool,
    ljung_box: f64,
    ljung_box_limit: f64,
    independent_of_input: bool,
    ccf_statistic: f64,
    ccf_limit: f64,
}

#[derive(Debug, Serialize)]
struct CandidateOut {
    model: &'static str,
    cl: Interval,
    fit_percent: FitPercent,
    seconds: f64,
}

fn interval(c: &estimator::identify::Candidate) -> Interval {
    let e = c.fit.estimate("Cl").copied().unwrap_or(estimator::pem::Estimate { name: "Cl", value: f64::NAN, ci95: (f64::NAN, f64::NAN), rel_std: f64::NAN });
    Interval { estimate: e.value, ci95: [e.ci95.0, e.ci95.1], rel_std: e.rel_std }
}

/// Cl's tested interval, its relative standard deviation read from the interval's log width.
fn tested_interval(t: &gap::TestedCl) -> Interval {
    Interval { estimate: t.cl.estimate, ci95: t.cl.ci95, rel_std: (t.cl.ci95[1] / t.cl.ci95[0]).ln() / (2.0 * estimator::validate::Z_975) }
}

fn fit_percent(c: &estimator::identify::Candidate) -> FitPercent {
    FitPercent { simulation: c.validation.fit_simulation[0], prediction: c.validation.fit_prediction[0] }
}

fn signal_name(s: Signal) -> &'static str {
    match s {
        Signal::Vout => "vout",
        Signal::Il => "il",
    }
}

/// Runs the command.
pub fn run(args: &IdentifyArgs) -> Result<()> {
    if args.samples < 100 {
        bail!("--samples {} is too few: at least 100 are needed", args.samples);
    }
    let (data, experiment_seconds, holdout, source) = match (&args.fmu, &args.data) {
        (Some(fmu), _) => {
            let (data, secs, holdout) = record_from_fmu(args, fmu)?;
            if let Some(path) = &args.save_data {
                data.write_csv(path)?;
                eprintln!("wrote {}", path.display());
            }
            (data, Some(secs), holdout, fmu.display().to_string())
        }
        (None, Some(path)) => {
            eprintln!("reading {}", path.display());
            let data = DataSet::read_csv(path)?;
            data.check_output_level()?;
            (data, None, args.holdout, path.display().to_string())
        }
        (None, None) => bail!("give --fmu PATH or --data FILE"),
    };
    require_il(args, &data)?;
    let (nominal, assumed) = nominal_from(&data)?;
    for a in &assumed {
        eprintln!("assuming {a}");
    }
    let structures = match args.model {
        ModelChoice::Auto => vec![Structure::Averaged, Structure::Pwm],
        ModelChoice::Averaged => vec![Structure::Averaged],
        ModelChoice::Pwm => vec![Structure::Pwm],
        ModelChoice::Reduced => vec![Structure::Reduced],
    };
    let opts = IdentifyOptions {
        structures,
        sampling: match args.sampling {
            SamplingChoice::Start => Sampling::PeriodStart,
            SamplingChoice::Average => Sampling::PeriodAverage,
        },
        outputs: if args.with_il { vec![Signal::Vout, Signal::Il] } else { vec![Signal::Vout] },
        free: free_parameters(args, &data),
        noise: match args.noise_model {
            Some(NoiseChoice::Oe) => NoiseModel::OutputError,
            Some(NoiseChoice::Kalman) => NoiseModel::Innovations,
            None if args.closed_loop => NoiseModel::Innovations,
            None => NoiseModel::OutputError,
        },
        cl_guess: args.cl_guess,
        holdout,
    };
    eprintln!("fitting {} samples", data.len());
    // A measured vin or io drives the model with its levels, unless vout shows the converter's
    // response to its noise.
    let (data, id, measured) = estimator::inputs::drive_by_levels_unless_seen(&data, |d| identify(d, &nominal, &opts), |id| id.best().fit.params)?;
    for input in &measured {
        eprintln!("input: {input}");
    }
    // Data from a file is a circuit's (SPICE or a bench), which the model only approximates: a
    // fit of Cl alone has its interval tested as the diagnosis tests its own. An FMU's recording
    // is a model's, of known fidelity only when it is this one's, so its interval stays the
    // fit's.
    let tested = (args.fmu.is_none() && opts.free == [Free::Cl]).then(|| gap::tested_cl(&data, &nominal, id.best(), id.estimation_samples));
    let excitation = args.fmu.as_ref().map(|_| {
        let levels = excitation_levels(args);
        Excitation {
            closed_loop: args.closed_loop,
            signal: if args.closed_loop { "duty_dither" } else { "duty" },
            levels,
            recorded_duty: if args.closed_loop { "duty_applied" } else { "duty" },
            load_noise: args.load_noise,
        }
    });
    print_summary(&id, tested.as_ref(), &source);
    let excitation_text = excitation.as_ref().map(|e| {
        format!(
            "{} loop: PRBS {}/{} on {}, duty recorded from {}{}",
            if e.closed_loop { "closed" } else { "open" },
            e.levels[0],
            e.levels[1],
            e.signal,
            e.recorded_duty,
            if e.load_noise > 0.0 { format!(", load disturbance σ = {}", si(e.load_noise, "A", 3)) } else { String::new() }
        )
    });
    if let Some(text) = &excitation_text {
        println!("excitation  {text}");
    }
    let mut out = output(&id, tested.as_ref(), &nominal, &assumed, &source, experiment_seconds, opts.noise);
    out.estimated = estimated(id.best(), &opts.free);
    for (name, e) in &out.estimated {
        println!("{name:11} {}", with_ci(e.estimate, Some(e.ci95), unit_of(name)));
    }
    out.excitation = excitation;
    if let Some(path) = &args.json {
        std::fs::write(path, serde_json::to_string_pretty(&out)? + "\n").with_context(|| format!("writing {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    if let Some(dir) = &args.report {
        let circuit: Vec<String> = assumed
            .iter()
            .map(|a| format!("assumed: {a}"))
            .chain(out.estimated.iter().map(|(name, e)| format!("estimated with Cl: {name} = {}", with_ci(e.estimate, Some(e.ci95), unit_of(name)))))
            .collect();
        let ctx = crate::report::identify::Context { source: &source, excitation: excitation_text.as_deref(), circuit: &circuit, noise_floor: gap::noise_floor(&data), cl_test: tested.as_ref() };
        let file = crate::report::identify::write(dir, &id, &nominal, &ctx)?;
        eprintln!("wrote {}", file.display());
    }
    Ok(())
}

fn output(id: &Identification, tested: Option<&gap::TestedCl>, nominal: &Params, assumed: &[String], source: &str, experiment_seconds: Option<f64>, noise: NoiseModel) -> Output {
    let best = id.best();
    let r = &best.validation.residuals;
    Output {
        cl: tested.map_or_else(|| interval(best), tested_interval),
        cl_test: tested.map(|t| ClTest { sentence: t.sentence(), tested: t.clone() }),
        fit_percent: fit_percent(best),
        model: best.structure.name(),
        samples: id.estimation_samples,
        validation_samples: id.validation_samples,
        seconds: best.seconds,
        seconds_experiment: experiment_seconds,
        outputs: id.outputs.iter().map(|s| signal_name(*s)).collect(),
        noise_model: match noise {
            NoiseModel::OutputError => "output-error",
            NoiseModel::Innovations => "innovations",
        },
        sigma: best.fit.sigma.clone(),
        residuals: Residuals {
            white: r.white(),
            ljung_box: r.ljung_box,
            ljung_box_limit: r.ljung_box_limit,
            independent_of_input: r.independent_of_input(),
            ccf_statistic: r.ccf_statistic,
            ccf_limit: r.ccf_limit,
        },
        nominal: [("L", nominal.l), ("RL", nominal.rl), ("C", nominal.c), ("Rc", nominal.rc), ("fs", nominal.fs), ("rload", nominal.rload)].into_iter().collect(),
        assumed: assumed.to_vec(),
        source: source.to_string(),
        excitation: None,
        candidates: id.candidates.iter().map(|c| CandidateOut { model: c.structure.name(), cl: interval(c), fit_percent: fit_percent(c), seconds: c.seconds }).collect(),
        estimated: BTreeMap::new(),
    }
}

fn print_summary(id: &Identification, tested: Option<&gap::TestedCl>, source: &str) {
    let best = id.best();
    let i = tested.map_or_else(|| interval(best), tested_interval);
    let f = fit_percent(best);
    println!("source      {source}");
    println!("model       {} ({} estimation + {} held-out samples)", best.structure.name(), id.estimation_samples, id.validation_samples);
    if identified(i.ci95) {
        println!("Cl          {:.4} µF   95 % CI [{:.4}, {:.4}] µF   (±{:.2} %)", i.estimate * 1e6, i.ci95[0] * 1e6, i.ci95[1] * 1e6, 196.0 * i.rel_std);
    } else if let Some(k) = tested.and_then(|t| t.cl.misses_by_floors) {
        println!("Cl          not identified: the model misses vout by {k:.1}× its noise floor (`buckid diagnose` tells what it lacks); the fit says {:.4} µF", i.estimate * 1e6);
    } else {
        println!("Cl          not identified: the data does not pin it down (CI95 {} … {})", si(i.ci95[0], "F", 2), si(i.ci95[1], "F", 2));
    }
    if let Some(t) = tested {
        println!("interval    tested on a circuit's data: {}", t.sentence());
    }
    println!("held-out    fit {:.2} % simulation, {:.2} % one-step prediction", f.simulation, f.prediction);
    let r = &best.validation.residuals;
    println!(
        "residuals   {} (Ljung–Box {:.1} vs {:.1} at 99 %), {} of the input ({:.1} vs {:.1})",
        if r.white() { "white" } else { "NOT white" },
        r.ljung_box,
        r.ljung_box_limit,
        if r.independent_of_input() { "independent" } else { "NOT independent" },
        r.ccf_statistic,
        r.ccf_limit
    );
    if id.candidates.len() > 1 {
        for c in &id.candidates[1..] {
            let i = interval(c);
            println!("also tried  {}: Cl {:.4} µF, held-out prediction fit {:.2} %", c.structure.name(), i.estimate * 1e6, c.validation.fit_prediction[0]);
        }
    }
    println!("fit time    {:.2} ms", best.seconds * 1e3);
}
