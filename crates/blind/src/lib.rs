//! Seeded datasets with one withheld non-ideal effect each, for proving the gap diagnosis
//! blind: a random effect of the design table with a random magnitude inside the table's range,
//! a random `Cl` and load current, simulated by the FMU (or the same model in process) or by
//! ngspice, plus clean datasets.
//!
//! The answer ([`Truth`]) is returned beside the data, never inside it: the data's metadata is
//! cut to `fs` and `U`, and this crate is not a dependency of the diagnosis (`gap`), so the
//! diagnosis cannot peek.
#![forbid(unsafe_code)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use buck_model::variables::by_name;
use buck_model::{Converter, Mode, Params};
use estimator::EstimatorError;
use estimator::data::DataSet;
use estimator::experiment::{Experiment, ModelPlant, Prbs, run};
use estimator::fmu_plant::{FmuOptions, FmuPlant};
use gap::Nominal;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Sensor noise on `vout` [V] of every dataset (at the ADC input for `adc_quantization`): the
/// floor under the gap, known to the scorer (the diagnosis estimates it from the data).
pub const NOISE_VOUT: f64 = 2e-3;

/// Samples per dataset (the thesis's 3001 periods).
pub const SAMPLES: usize = 3001;

/// What a dataset holds: the withheld effect and the values it was made with.
#[derive(Debug, Clone, PartialEq)]
pub struct Truth {
    /// The effect's contract name, or `none` for a clean dataset.
    pub effect: &'static str,
    /// The load capacitance [F].
    pub cl: f64,
    /// The load current [A].
    pub io: f64,
    /// Plant settings by FMU variable name (the effect's parameters).
    pub settings: Vec<(&'static str, f64)>,
}

impl Truth {
    /// RMS of the measurement noise on the readings [V]: the sensor noise, plus the
    /// quantization's `lsb²/12` (Sheppard) for `adc_quantization` at the plant's default full
    /// scale (the generator leaves `adc_vfs` alone).
    pub fn measurement_noise(&self) -> f64 {
        let bits = self.settings.iter().find(|(k, _)| *k == "adc_bits").map(|(_, v)| *v);
        let full_scale = buck_model::digital::Digital::default().adc_vfs;
        let quantization = bits.map_or(0.0, |b| (full_scale / b.exp2()).powi(2) / 12.0);
        (NOISE_VOUT.powi(2) + quantization).sqrt()
    }
}

/// One dataset of the blind check.
#[derive(Debug, Clone)]
pub struct Case {
    /// The data, metadata cut to `fs` and `U`.
    pub data: DataSet,
    /// The circuit values the user's model knows (the design's nominal values).
    pub nominal: Params,
    /// The user's simulation model: switched, or averaged for the `switching_ripple` cases.
    pub model: Nominal,
    /// The answer, for scoring only.
    pub truth: Truth,
    /// Where the data came from.
    pub source: &'static str,
}

/// The effects a plant dataset may withhold: clean data (`none`) against a switched model, and
/// every effect of the design table (`switching_ripple`: clean switched data against the
/// averaged model).
pub fn plant_effects() -> impl Iterator<Item = &'static str> {
    std::iter::once("none").chain(gap::EFFECTS)
}

/// The effects an ngspice dataset may withhold (the netlists' real devices).
pub const SPICE_EFFECTS: [&str; 10] = [
    "none",
    "switching_ripple",
    "switch_resistance",
    "param_drift",
    "diode_drop",
    "dead_time",
    "load_esr",
    "esl",
    "inductor_saturation",
    "cap_dc_bias",
];

fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    rng.random_range(lo..hi)
}

/// Draws the magnitudes of `effect` (inside the design table's ranges), Cl (log-uniform
/// 1–100 µF) and the load current.
pub fn draw(effect: &'static str, rng: &mut ChaCha8Rng) -> Truth {
    let cl = 10f64.powf(uniform(rng, -6.0, -4.0));
    let mut io = uniform(rng, 0.5, 3.0);
    let settings: Vec<(&'static str, f64)> = match effect {
        "none" | "switching_ripple" => vec![],
        "switch_resistance" => vec![("switch_resistance", uniform(rng, 5e-3, 30e-3))],
        "diode_drop" => vec![("diode_drop", uniform(rng, 0.3, 0.8))],
        "dead_time" => vec![("dead_time", uniform(rng, 10e-9, 50e-9))],
        "dcm" => {
            // Light load: below half the ripple (≈ 1.3 A at 0.4/0.6 and 12 V).
            io = uniform(rng, 0.1, 1.0);
            vec![("dcm", 1.0)]
        }
        "load_esr" => vec![("load_esr", uniform(rng, 1e-3, 50e-3))],
        "esl" => vec![("esl", uniform(rng, 0.5e-9, 2e-9))],
        "delay" => vec![("delay", f64::from(rng.random_range(1..=2)))],
        "adc_quantization" => vec![("adc_bits", f64::from(rng.random_range(10..=12))), ("adc_noise", NOISE_VOUT)],
        "inductor_saturation" => {
            let isat = io + uniform(rng, 0.2, 1.2);
            vec![("inductor_saturation", uniform(rng, 0.1, 0.3)), ("isat", isat)]
        }
        "cap_dc_bias" => vec![("cap_dc_bias", uniform(rng, 0.3, 0.6))],
        "param_drift" => {
            let name = ["L", "C", "Rc"][rng.random_range(0..3)];
            let nominal = Params::default();
            let value = match name {
                "L" => nominal.l,
                "C" => nominal.c,
                _ => nominal.rc,
            };
            let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            vec![(name, value * (1.0 + sign * uniform(rng, 0.05, 0.2)))]
        }
        other => unreachable!("no generator for {other}"),
    };
    Truth { effect, cl, io, settings }
}

/// The experiment of every dataset: PRBS duty 0.4/0.6, 3001 samples, seeded noise.
fn experiment(truth: &Truth, seed: u64) -> Experiment {
    let adc = truth.effect == "adc_quantization";
    Experiment {
        samples: SAMPLES,
        io: truth.io,
        noise_vout: if adc { 0.0 } else { NOISE_VOUT },
        noise_seed: seed,
        prbs: Prbs { seed, ..Prbs::default() },
        ..Experiment::default()
    }
}

/// The user's model for a dataset withholding `effect`.
fn model_for(effect: &str) -> Nominal {
    if effect == "switching_ripple" { Nominal::Averaged } else { Nominal::Switched }
}

/// Cuts the metadata to what a measurement would carry (nothing that names the effect).
fn blind(mut data: DataSet) -> DataSet {
    data.meta.retain(|k, _| k == "fs" || k == "U");
    data
}

/// A dataset from the FMU at `fmu` (switched mode), or from the same model in process when
/// `fmu` is `None`.
pub fn plant_case(truth: Truth, seed: u64, fmu: Option<&Path>) -> Result<Case, EstimatorError> {
    let exp = experiment(&truth, seed);
    let adc = truth.effect == "adc_quantization";
    let data = match fmu {
        Some(path) => {
            let mut set: Vec<(String, f64)> = vec![("Cl".into(), truth.cl), ("mode".into(), 2.0)];
            set.extend(truth.settings.iter().map(|(k, v)| ((*k).to_string(), *v)));
            let mut map = BTreeMap::new();
            if adc {
                map.insert("vout".to_string(), "vout_adc".to_string());
            }
            let mut plant = FmuPlant::open(path, &FmuOptions { set, map, ..FmuOptions::default() })?;
            run(&mut plant, &exp)?
        }
        None => {
            let mut conv = Converter::new(Params { cl: truth.cl, ..Params::default() }, Mode::Switched);
            for (name, value) in &truth.settings {
                let var = by_name(name).ok_or_else(|| EstimatorError::Config(format!("no plant variable `{name}`")))?;
                conv.set(var.id, *value).map_err(|e| EstimatorError::Plant(e.to_string()))?;
            }
            let plant = ModelPlant::with_converter_in_open_loop(conv);
            run(&mut if adc { plant.reading_adc() } else { plant }, &exp)?
        }
    };
    let model = model_for(truth.effect);
    Ok(Case { data: blind(data), nominal: Params::default(), model, truth, source: if fmu.is_some() { "fmu" } else { "in-process" } })
}

/// How to run the ngspice generator (`scripts/spice/buck_spice.py`).
#[derive(Debug, Clone)]
pub struct Spice {
    /// Python interpreter (with numpy).
    pub python: PathBuf,
    /// The generator script.
    pub script: PathBuf,
}

impl Spice {
    /// The repository's generator with its venv's Python, when ngspice and both are present.
    pub fn find(root: &Path) -> Option<Self> {
        let python = root.join(".venv/bin/python");
        let script = root.join("scripts/spice/buck_spice.py");
        let ngspice = std::env::var_os("PATH").is_some_and(|p| std::env::split_paths(&p).any(|d| d.join("ngspice").is_file()));
        (ngspice && python.is_file() && script.is_file()).then_some(Self { python, script })
    }
}

/// A dataset from an ngspice netlist: `none`/`switching_ripple` from the ideal-switch circuit,
/// `switch_resistance` and `param_drift` from it with RL, L, C or Rc changed, `load_esr` and
/// `esl` from it with a resistor in series with Cl or an inductor in series with C,
/// `inductor_saturation` and `cap_dc_bias` from it with a behavioural inductor (L·(1 − s) above
/// isat) or load capacitor (Cl·(1 − b·min((v/16 V)², 1))), `diode_drop` from
/// the asynchronous Schottky buck and `dead_time` from the synchronous MOSFET buck (both with
/// near-ideal 1 mΩ switches, so that the diode or the dead time is the one effect).
pub fn spice_case(truth: Truth, seed: u64, spice: &Spice) -> Result<Case, EstimatorError> {
    let dir = tempfile::tempdir().map_err(|e| EstimatorError::Io { path: "temporary directory".into(), source: e })?;
    let out = dir.path().join("data.csv");
    let nominal = Params::default();
    let mut args: Vec<String> = vec![
        "--periods".into(),
        SAMPLES.to_string(),
        "--warmup".into(),
        "200".into(),
        "--seed".into(),
        seed.max(1).to_string(),
        "--cl".into(),
        format!("{:e}", truth.cl),
        "--io".into(),
        format!("{}", truth.io),
        "--out".into(),
        out.display().to_string(),
    ];
    let circuit = match truth.effect {
        "diode_drop" => "async",
        "dead_time" => "sync",
        _ => "ideal",
    };
    args.extend(["--circuit".into(), circuit.into(), "--rds-on".into(), "1e-3".into()]);
    for (name, value) in &truth.settings {
        match *name {
            "switch_resistance" => args.extend(["--RL".into(), format!("{}", nominal.rl + value)]),
            "dead_time" => args.extend(["--dead-time".into(), format!("{value:e}")]),
            "L" | "C" | "Rc" => args.extend([format!("--{name}"), format!("{value:e}")]),
            "load_esr" => args.extend(["--load-esr".into(), format!("{value:e}")]),
            "esl" => args.extend(["--esl".into(), format!("{value:e}")]),
            "inductor_saturation" => args.extend(["--inductor-saturation".into(), format!("{value:e}")]),
            "isat" => args.extend(["--isat".into(), format!("{value:e}")]),
            "cap_dc_bias" => args.extend(["--cap-dc-bias".into(), format!("{value:e}")]),
            // The Schottky's drop is the device's own; the drawn value is not used.
            "diode_drop" => {}
            other => return Err(EstimatorError::Config(format!("ngspice datasets cannot withhold `{other}`"))),
        }
    }
    let status = Command::new(&spice.python)
        .arg(&spice.script)
        .args(&args)
        .stdout(std::process::Stdio::null())
        .status()
        .map_err(|e| EstimatorError::Io { path: spice.python.display().to_string(), source: e })?;
    if !status.success() {
        return Err(EstimatorError::Plant(format!("ngspice generator failed ({status}) with {}", args.join(" "))));
    }
    let mut data = DataSet::read_csv(&out)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, NOISE_VOUT).map_err(|e| EstimatorError::Config(e.to_string()))?;
    data.vout.iter_mut().for_each(|v| *v += noise.sample(&mut rng));
    let model = model_for(truth.effect);
    Ok(Case { data: blind(data), nominal, model, truth, source: "ngspice" })
}

/// The packaged FMU, rebuilt by `cargo xtask fmu` when missing or older than its sources
/// (`None` when that fails: the datasets then come from the same model in process).
pub fn bundled_fmu() -> Option<PathBuf> {
    fmu_fixture::buck_fmu().map(Path::to_path_buf).map_err(|e| eprintln!("{e}")).ok()
}

/// A seeded random stream for dataset `index` of a run with `seed`.
pub fn rng(seed: u64, index: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ index)
}

/// The diagnosis of one case, scored against its truth.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The answer.
    pub truth: Truth,
    /// Where the data came from.
    pub source: &'static str,
    /// What the diagnosis said (`none` or an effect), or the error it gave.
    pub verdict: String,
    /// Held-out NRMSE shrink of the verdict's effect [%] (sensor noise included).
    pub shrink_percent: Option<f64>,
    /// Share of the held-out gap above the true measurement noise
    /// ([`Truth::measurement_noise`]) that the verdict's effect closed [%]; `None` when the
    /// nominal model's gap is not above that noise ([`gap::closed_percent`]).
    pub closed_percent: Option<f64>,
    /// The nominal model misses the data by more than the true measurement noise
    /// ([`gap::gap_above`]): the withheld effect is detectable at all.
    pub detectable: bool,
    /// The diagnosis's own, model-free estimate of the sensor noise [V].
    pub noise_floor: Option<f64>,
    /// The verdict's Cl estimate and its CI95 [F].
    pub cl: Option<(f64, [f64; 2])>,
    /// The test of the verdict's Cl interval (see [`gap::ClCheck`]).
    pub cl_check: Option<gap::ClCheck>,
    /// Wall time of the diagnosis [s].
    pub seconds: f64,
}

impl Outcome {
    /// Whether the true Cl lies in the verdict's CI95 (`None` without a verdict's Cl).
    pub fn cl_in_ci95(&self) -> Option<bool> {
        self.cl.map(|(_, [lo, hi])| lo <= self.truth.cl && self.truth.cl <= hi)
    }
}

/// Diagnoses `case` as a user would (data, nominal values, model; nothing else) and scores it.
pub fn diagnose_case(case: &Case) -> Outcome {
    let opts = gap::DiagnoseOptions { nominal: case.model, ..gap::DiagnoseOptions::default() };
    let clock = std::time::Instant::now();
    let result = gap::diagnose(&case.data, &case.nominal, &opts);
    let seconds = clock.elapsed().as_secs_f64();
    let mut outcome = Outcome {
        truth: case.truth.clone(),
        source: case.source,
        verdict: String::new(),
        shrink_percent: None,
        closed_percent: None,
        detectable: false,
        noise_floor: None,
        cl: None,
        cl_check: None,
        seconds,
    };
    match result {
        Ok(dx) => {
            let best = dx.selected.first();
            outcome.verdict.clone_from(&dx.verdict);
            outcome.shrink_percent = best.map(|e| e.shrink_percent);
            outcome.detectable = gap::gap_above(dx.gap_before.rms, case.truth.measurement_noise());
            outcome.closed_percent = best.and_then(|e| gap::closed_percent(dx.gap_before.rms, e.rms_after, case.truth.measurement_noise()));
            outcome.noise_floor = (dx.location.noise_floor_from == gap::FloorSource::Differences).then_some(dx.location.noise_floor_rms);
            // The final model's Cl: the last selected effect's.
            let last = dx.selected.last();
            outcome.cl = last.map(|e| (e.cl.estimate, e.cl.ci95));
            outcome.cl_check = last.and_then(|e| e.cl.check.clone());
        }
        Err(e) => outcome.verdict = format!("error: {e}"),
    }
    outcome
}

/// The blind check's scores over a set of outcomes.
#[derive(Debug, Clone, PartialEq)]
pub struct Scores {
    /// Datasets withholding an effect, and how many of them got it named.
    pub effect_cases: usize,
    /// Of those, named correctly.
    pub named: usize,
    /// Datasets withholding an effect that leaves a gap above the measurement noise (the
    /// others are below the detection limit: `none` is the right answer the data allows).
    pub detectable_cases: usize,
    /// Of those, named correctly.
    pub detectable_named: usize,
    /// Clean datasets, and how many got `none`.
    pub clean_cases: usize,
    /// Of those, `none`.
    pub none: usize,
    /// Correctly named datasets whose nominal model misses by more than the measurement noise
    /// (the others have no gap to close).
    pub with_gap: usize,
    /// Of those, with ≥ 70 % of the held-out gap above the measurement noise closed.
    pub closed_70: usize,
    /// Correctly named datasets with the true Cl inside the verdict's CI95.
    pub cl_covered: usize,
}

/// Scores `outcomes`.
pub fn score(outcomes: &[Outcome]) -> Scores {
    let effect: Vec<&Outcome> = outcomes.iter().filter(|o| o.truth.effect != "none").collect();
    let named: Vec<&&Outcome> = effect.iter().filter(|o| o.verdict == o.truth.effect).collect();
    let clean: Vec<&Outcome> = outcomes.iter().filter(|o| o.truth.effect == "none").collect();
    Scores {
        effect_cases: effect.len(),
        named: named.len(),
        detectable_cases: effect.iter().filter(|o| o.detectable).count(),
        detectable_named: named.iter().filter(|o| o.detectable).count(),
        clean_cases: clean.len(),
        none: clean.iter().filter(|o| o.verdict == "none").count(),
        with_gap: named.iter().filter(|o| o.closed_percent.is_some()).count(),
        closed_70: named.iter().filter(|o| o.closed_percent.is_some_and(|s| s >= 70.0)).count(),
        cl_covered: named.iter().filter(|o| o.cl_in_ci95() == Some(true)).count(),
    }
}

/// The confusion matrix (rows: withheld effect, columns: verdict) as a Markdown table.
pub fn confusion_matrix(outcomes: &[Outcome]) -> String {
    let mut rows: Vec<&str> = Vec::new();
    let mut cols: Vec<String> = Vec::new();
    for o in outcomes {
        if !rows.contains(&o.truth.effect) {
            rows.push(o.truth.effect);
        }
        if !cols.contains(&o.verdict) {
            cols.push(o.verdict.clone());
        }
    }
    let order = |name: &str| plant_effects().position(|e| e == name).unwrap_or(usize::MAX);
    rows.sort_by_key(|r| order(r));
    cols.sort_by_key(|c| (order(c), c.clone()));
    let mut s = format!("| withheld \\ verdict | {} |\n|---|{}\n", cols.join(" | "), "---:|".repeat(cols.len()));
    for r in &rows {
        let counts: Vec<String> = cols
            .iter()
            .map(|c| {
                let n = outcomes.iter().filter(|o| o.truth.effect == *r && &o.verdict == c).count();
                if n == 0 { ".".to_string() } else { n.to_string() }
            })
            .collect();
        s += &format!("| {r} | {} |\n", counts.join(" | "));
    }
    s
}
