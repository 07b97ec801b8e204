//! Seeded datasets with one withheld non-ideal effect each, for proving the gap diagnosis
//! blind: a random effect of the design table with a random magnitude inside the table's range,
//! a random `Cl` and load current, simulated by the FMU (or the same model in process) or by
//! ngspice, plus clean datasets; and, from the independent harness
//! (`scripts/spice/harness/harness.py`: other devices, a switch-node capacitance, a late ADC,
//! drawn noise), datasets with one or two withheld effects.
//!
//! The answer ([`Truth`]) is returned beside the data, never inside it: the data's metadata is
//! cut to `fs` and `U`, and this crate is not a dependency of the diagnosis (`gap`), so the
//! diagnosis cannot peek.
#![forbid(unsafe_code)]

mod captures;

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

/// Sensor noise on `vout` \[V\] of every dataset (at the ADC input for `adc_quantization`): the
/// floor under the gap, known to the scorer (the diagnosis estimates it from the data).
pub const NOISE_VOUT: f64 = 2e-3;

/// Samples per dataset (the thesis's 3001 periods).
pub const SAMPLES: usize = 3001;

/// What a dataset holds: the withheld effect(s) and the values it was made with.
#[derive(Debug, Clone, PartialEq)]
pub struct Truth {
    /// The effect's contract name, or `none` for a clean dataset.
    pub effect: &'static str,
    /// Further withheld effects (the independent harness's datasets with two or more).
    pub also: Vec<&'static str>,
    /// Standard deviation of the sensor noise on `vout` \[V\].
    pub noise: f64,
    /// The load capacitance \[F\].
    pub cl: f64,
    /// The load current \[A\].
    pub io: f64,
    /// Plant settings by FMU variable name (the effect's parameters).
    pub settings: Vec<(&'static str, f64)>,
}

impl Case {
    /// What it holds, as JSON for people and scripts (`--keep`): its source, the withheld
    /// effects, Cl as drawn and as the scores compare against it (`cl_true`), the load current,
    /// the sensor noise and the plant's settings by name.
    pub fn truth_json(&self) -> serde_json::Value {
        let t = &self.truth;
        let settings: serde_json::Map<String, serde_json::Value> = t.settings.iter().map(|(k, v)| ((*k).to_string(), (*v).into())).collect();
        serde_json::json!({
            "source": self.source,
            "effects": t.effects(),
            "cl": t.cl,
            "cl_true": self.true_cl,
            "io": t.io,
            "noise": t.noise,
            "settings": settings,
        })
    }
}

impl Truth {
    /// The withheld effects (empty for a clean dataset).
    pub fn effects(&self) -> Vec<&'static str> {
        std::iter::once(self.effect).chain(self.also.iter().copied()).filter(|e| *e != "none").collect()
    }

    /// The withheld effects joined by `+`, or `none`.
    pub fn label(&self) -> String {
        let effects = self.effects();
        if effects.is_empty() { "none".to_string() } else { effects.join("+") }
    }

    /// RMS of the measurement noise on the readings \[V\]: the sensor noise, plus the
    /// quantization's `lsb²/12` (Sheppard) for `adc_quantization` at the plant's default full
    /// scale (the generator leaves `adc_vfs` alone).
    pub fn measurement_noise(&self) -> f64 {
        let bits = self.settings.iter().find(|(k, _)| *k == "adc_bits").map(|(_, v)| *v);
        let full_scale = buck_model::digital::Digital::default().adc_vfs;
        let quantization = bits.map_or(0.0, |b| (full_scale / b.exp2()).powi(2) / 12.0);
        (self.noise.powi(2) + quantization).sqrt()
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
    /// RMS of what the withheld effects alone add to `vout` over the held-out third \[V\], where
    /// a twin without them was run (the harness: its late ADC leaves a gap of its own); else
    /// the gap the nominal model leaves decides detectability.
    pub effect_rms: Option<f64>,
    /// Of a dataset withholding two or more distinct effects, what each adds to `vout` by
    /// itself (a twin run without it alone), in the order of [`Truth::effects`]; `None` for
    /// one without a twin (a diode or a dead time: the topology itself). Empty elsewhere.
    pub effect_rms_each: Vec<Option<f64>>,
    /// The load capacitance the data shows, which the scores compare against \[F\]: `truth.cl`,
    /// except for a DC-biased ceramic, whose small-signal capacitance at its operating point it
    /// is, the output voltage averaged in time (`operating_point`; the value at 0 V is an
    /// extrapolation by a bias law, which data that never leaves the operating point cannot
    /// tell; the diagnosis reports Cl there too).
    pub true_cl: f64,
}

/// The effects a plant dataset may withhold: clean data (`none`) against a switched model, and
/// every effect of the design table (`switching_ripple`: clean switched data against the
/// averaged model).
pub fn plant_effects() -> impl Iterator<Item = &'static str> {
    // The plant's datasets are read at the period start (its ADC's `adc_delay` is not drawn:
    // `run` takes a period's readings at its start): a late acquisition comes from the harness
    // only.
    // A diode's slope resistance, the switch node's capacitance and unequal switches refine a
    // diode, a dead time or the switches' resistance; alone they change nothing. The plant's
    // readings are exact: a sensor's calibration comes from the harness only, an anti-alias
    // filter from the third generator.
    std::iter::once("none").chain(gap::EFFECTS.into_iter().filter(|e| {
        !matches!(*e, "sample_delay" | "sensor_filter" | "channel_skew" | "diode_resistance" | "switch_node_capacitance" | "switch_node_ring" | "unequal_switches" | "sensor_offset" | "sensor_gain")
    }))
}

/// The effects an ngspice dataset may withhold (the netlists' real devices).
pub const SPICE_EFFECTS: [&str; 10] = ["none", "switching_ripple", "switch_resistance", "param_drift", "diode_drop", "dead_time", "load_esr", "esl", "inductor_saturation", "cap_dc_bias"];

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
        // A gate drive's turn-off delay beyond its turn-on delay: 0.3–1.7 % of the period.
        "pulse_width_distortion" => vec![("pulse_width_distortion", uniform(rng, 10e-9, 50e-9))],
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
    Truth { effect, also: Vec::new(), noise: NOISE_VOUT, cl, io, settings }
}

/// The experiment of every dataset: PRBS duty 0.4/0.6, 3001 samples, seeded noise.
fn experiment(truth: &Truth, seed: u64) -> Experiment {
    let adc = truth.effect == "adc_quantization";
    Experiment { samples: SAMPLES, io: truth.io, noise_vout: if adc { 0.0 } else { truth.noise }, noise_seed: seed, prbs: Prbs { seed, ..Prbs::default() }, ..Experiment::default() }
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
    let true_cl = model_biased_cl(&truth, operating_point(&data)?);
    Ok(Case { data: blind(data), nominal: Params::default(), model, source: if fmu.is_some() { "fmu" } else { "in-process" }, true_cl, truth, effect_rms: None, effect_rms_each: Vec::new() })
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
    let noise = Normal::new(0.0, truth.noise).map_err(|e| EstimatorError::Config(e.to_string()))?;
    data.vout.iter_mut().for_each(|v| *v += noise.sample(&mut rng));
    let model = model_for(truth.effect);
    let true_cl = model_biased_cl(&truth, operating_point(&data)?);
    Ok(Case { data: blind(data), nominal, model, source: "ngspice", true_cl, truth, effect_rms: None, effect_rms_each: Vec::new() })
}

/// How to run the independent harness (`scripts/spice/harness/harness.py`): circuits written
/// apart from the model and from the own netlists (see the script's doc).
#[derive(Debug, Clone)]
pub struct Harness {
    /// Python interpreter (with numpy).
    pub python: PathBuf,
    /// The harness script.
    pub script: PathBuf,
    /// The repository, whose recorded runs (`tests/fixtures/captures`) are read instead of
    /// simulated.
    pub root: PathBuf,
}

impl Harness {
    /// The repository's harness with its venv's Python, when ngspice and both are present.
    pub fn find(root: &Path) -> Option<Self> {
        let python = root.join(".venv/bin/python");
        let script = root.join("scripts/spice/harness/harness.py");
        let ngspice = std::env::var_os("PATH").is_some_and(|p| std::env::split_paths(&p).any(|d| d.join("ngspice").is_file()));
        (ngspice && python.is_file() && script.is_file()).then_some(Self { python, script, root: root.to_path_buf() })
    }
}

/// The withheld effects of a harness dataset: the first, and the others.
pub type HarnessCase = (&'static str, &'static [&'static str]);

/// The withheld effects of the harness's datasets: one each, or two.
pub const HARNESS_CASES: [HarnessCase; 12] = [
    ("none", &[]),
    ("switch_resistance", &[]),
    ("diode_drop", &[]),
    ("dead_time", &[]),
    ("load_esr", &[]),
    ("esl", &[]),
    ("param_drift", &[]),
    ("inductor_saturation", &[]),
    ("cap_dc_bias", &[]),
    ("diode_drop", &["switch_resistance"]),
    ("dead_time", &["load_esr"]),
    ("param_drift", &["switch_resistance"]),
];

/// Converters as real ones come, several effects at once (besides the late ADC every harness
/// dataset has): a synchronous buck with dead time, unequal switches and two of L, C, Rc off
/// nominal; a diode buck with its high side's resistance and one of them off.
pub const HARNESS_SEVERAL: [HarnessCase; 2] = [("dead_time", &["switch_resistance", "param_drift", "param_drift"]), ("diode_drop", &["switch_resistance", "param_drift"])];

fn log_uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    uniform(rng, lo.ln(), hi.ln()).exp()
}

/// The settings of one withheld effect in the harness (keys are the script's options with `_`
/// for `-`), drawn wider than the design table where a real part would be.
fn harness_effect(effect: &'static str, io: f64, rng: &mut ChaCha8Rng) -> Vec<(&'static str, f64)> {
    match effect {
        // Unequal switches: the resistance depends on the duty, as in a real half bridge.
        "switch_resistance" => vec![("ron_hs", uniform(rng, 5e-3, 40e-3)), ("ron_ls", uniform(rng, 5e-3, 40e-3))],
        // A Schottky (Vf ≈ 0.3–0.45 V) or a pn diode (≈ 0.55–0.8 V) card of the harness's own.
        "diode_drop" => {
            if rng.random_bool(0.5) {
                vec![("diode_is", log_uniform(rng, 1e-6, 5e-5)), ("diode_n", uniform(rng, 1.0, 1.1)), ("diode_rs", uniform(rng, 10e-3, 40e-3)), ("diode_cjo", uniform(rng, 100e-12, 600e-12))]
            } else {
                vec![("diode_is", log_uniform(rng, 1e-10, 1e-8)), ("diode_n", uniform(rng, 1.2, 1.4)), ("diode_rs", uniform(rng, 10e-3, 40e-3)), ("diode_cjo", uniform(rng, 100e-12, 600e-12))]
            }
        }
        // Dead time at both edges; the body diodes are pn cards (Vf ≈ 0.6–0.9 V).
        "dead_time" => vec![
            ("dead_time", uniform(rng, 10e-9, 60e-9)),
            ("diode_is", log_uniform(rng, 1e-12, 1e-10)),
            ("diode_n", uniform(rng, 1.0, 1.3)),
            ("diode_rs", uniform(rng, 5e-3, 30e-3)),
            ("diode_cjo", uniform(rng, 100e-12, 600e-12)),
        ],
        "load_esr" => vec![("load_esr", uniform(rng, 1e-3, 50e-3))],
        "esl" => vec![("esl", uniform(rng, 0.5e-9, 3e-9))],
        "param_drift" => {
            let nominal = Params::default();
            let (name, value) = [("L", nominal.l), ("C", nominal.c), ("Rc", nominal.rc)][rng.random_range(0..3)];
            let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            vec![(name, value * (1.0 + sign * uniform(rng, 0.05, 0.25)))]
        }
        // A smooth knee (5 % of isat wide) somewhere inside the ripple's upper half.
        "inductor_saturation" => vec![("sat", uniform(rng, 0.1, 0.3)), ("isat", io + uniform(rng, 0.0, 1.2))],
        "cap_dc_bias" => vec![("dcbias", uniform(rng, 0.3, 0.6)), ("vrated", [6.3, 10.0, 16.0][rng.random_range(0..3)])],
        _ => vec![],
    }
}

/// Ranges of the harness's draws that a run may change.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HarnessRanges {
    /// Delay of the ADC's sample after the period start, drawn uniformly in [lo, hi] \[s\].
    pub adc_delay: [f64; 2],
}

impl Default for HarnessRanges {
    /// The ADC 20–300 ns late.
    fn default() -> Self {
        Self { adc_delay: [20e-9, 300e-9] }
    }
}

/// Draws a harness dataset withholding `effect` (and `also`): Cl log-uniform 0.2–100 µF, a
/// current load 0.3–5 A (light loads put the diode buck in DCM and reverse the synchronous
/// buck's current within a period), sensor noise σ 1–4 mV on `vout` and 2–10 mA on `il`, the
/// ADC `ranges.adc_delay` after the period start, gate ramps 2–20 ns, a switch-node capacitance
/// 50 pF–1 nF, driver resistance 0.5–3 Ω into 1–3 nF; switches of 1–3 µΩ (`SW` pair) or
/// 20–50 µΩ (level-1 NMOS: a few µΩ let ngspice's step collapse at some edges) unless
/// `switch_resistance` is withheld (0.1 mΩ already shows over 3001 samples at a few amperes).
pub fn draw_harness(effect: &'static str, also: &[&'static str], ranges: &HarnessRanges, rng: &mut ChaCha8Rng) -> Truth {
    let cl = log_uniform(rng, 0.2e-6, 100e-6);
    let io = uniform(rng, 0.3, 5.0);
    let noise = uniform(rng, 1e-3, 4e-3);
    // Drawn as a fraction so that the other draws do not depend on the range.
    let adc = uniform(rng, 0.0, 1.0);
    let effects: Vec<&str> = std::iter::once(effect).chain(also.iter().copied()).collect();
    let ron = if harness_topology(&effects) == "sw" { [1e-6, 3e-6] } else { [20e-6, 50e-6] };
    let mut settings: Vec<(&'static str, f64)> = vec![
        ("noise_vout", noise),
        ("noise_il", uniform(rng, 2e-3, 10e-3)),
        ("adc_delay", ranges.adc_delay[0] + adc * (ranges.adc_delay[1] - ranges.adc_delay[0])),
        ("ramp", uniform(rng, 2e-9, 20e-9)),
        ("csw", log_uniform(rng, 50e-12, 1e-9)),
        ("rdrv", uniform(rng, 0.5, 3.0)),
        ("cgs", uniform(rng, 1e-9, 3e-9)),
        ("ron_hs", uniform(rng, ron[0], ron[1])),
        ("ron_ls", uniform(rng, ron[0], ron[1])),
    ];
    for &e in &effects {
        let mut drawn = harness_effect(e, io, rng);
        // A second drift drifts another value.
        while e == "param_drift" && drawn.iter().any(|(k, _)| settings.iter().any(|(s, _)| s == k)) {
            drawn = harness_effect(e, io, rng);
        }
        for (key, value) in drawn {
            // A withheld effect's value replaces the near-ideal default of the same key.
            settings.retain(|(k, _)| *k != key);
            settings.push((key, value));
        }
    }
    Truth { effect, also: also.to_vec(), noise, cl, io, settings }
}

/// The harness's circuit for `effects`: the diode buck for `diode_drop`, the synchronous
/// MOSFET buck for `dead_time`, the switch pair without dead time otherwise.
fn harness_topology(effects: &[&str]) -> &'static str {
    if effects.contains(&"diode_drop") {
        "async"
    } else if effects.contains(&"dead_time") {
        "sync"
    } else {
        "sw"
    }
}

/// The harness settings that make a withheld effect, which its twin run leaves out (back to
/// the harness's near-ideal defaults); `None` where the effect is the topology itself (a diode
/// or a dead time has no twin without it).
fn harness_effect_keys(effect: &str) -> Option<&'static [&'static str]> {
    match effect {
        "switch_resistance" => Some(&["ron_hs", "ron_ls"]),
        "load_esr" => Some(&["load_esr"]),
        "esl" => Some(&["esl"]),
        "param_drift" => Some(&["L", "C", "Rc"]),
        "inductor_saturation" => Some(&["sat", "isat"]),
        "cap_dc_bias" => Some(&["dcbias", "vrated"]),
        _ => None,
    }
}

/// A dataset of `periods` periods from the independent harness (its own noise, seeded by
/// `seed`), to be diagnosed against the design's nominal values and the switched model.
///
/// Where the withheld effects have a twin (`harness_effect_keys`), the harness runs again
/// without them, same seed (same PRBS, same noise, same late ADC): the RMS of the difference in
/// `vout` over the held-out third is what the effects themselves leave ([`Case::effect_rms`]),
/// which the ADC's own gap would otherwise hide from the detection limit.
pub fn harness_case(truth: Truth, seed: u64, harness: &Harness, periods: usize) -> Result<Case, EstimatorError> {
    let dir = tempfile::tempdir().map_err(|e| EstimatorError::Io { path: "temporary directory".into(), source: e })?;
    let run = |cl: f64, settings: &[(&'static str, f64)], file: &str| -> Result<DataSet, EstimatorError> {
        let out = dir.path().join(file);
        let mut args: Vec<String> = vec![
            "--topology".into(),
            harness_topology(&truth.effects()).into(),
            "--periods".into(),
            periods.to_string(),
            "--seed".into(),
            (seed % 1_000_000_007).max(1).to_string(),
            "--cl".into(),
            format!("{cl:e}"),
            "--io".into(),
            format!("{}", truth.io),
            "--effects".into(),
            truth.effects().join(","),
        ];
        for (name, value) in settings {
            args.extend([format!("--{}", name.replace('_', "-")), format!("{value:e}")]);
        }
        let store_error = |e: std::io::Error| EstimatorError::Io { path: "tests/fixtures/captures".into(), source: e };
        if !captures::read_recorded(&harness.root, &harness.script, &args, &out).map_err(store_error)? {
            let output = Command::new(&harness.python)
                .arg(&harness.script)
                .args(&args)
                .arg("--out")
                .arg(&out)
                .output()
                .map_err(|e| EstimatorError::Io { path: harness.python.display().to_string(), source: e })?;
            if !output.status.success() {
                let stderr = String::from_utf8_lossy(&output.stderr);
                return Err(EstimatorError::Plant(format!("harness failed ({}) with {}: {stderr}", output.status, args.join(" "))));
            }
            if captures::recording() {
                captures::record(&harness.root, &harness.script, &args, &out).map_err(store_error)?;
            }
        }
        DataSet::read_csv(&out)
    };
    let data = run(truth.cl, &truth.settings, "data.csv")?;
    let true_cl = harness_biased_cl(&truth, operating_point(&data)?);
    // What the settings `keys` add to `vout` over the held-out third: the RMS of the data less
    // a twin run without them. A biased ceramic's twin is the linear capacitor of its operating
    // point: what is left is the bias's nonlinearity, the only part a fitted Cl cannot take up.
    let footprint = |keys: &[&str]| -> Result<f64, EstimatorError> {
        let settings: Vec<(&'static str, f64)> = truth.settings.iter().copied().filter(|(k, _)| !keys.contains(k)).collect();
        let twin = run(true_cl, &settings, "twin.csv")?;
        let start = data.len() - data.len() / 3;
        let d: Vec<f64> = data.vout[start..].iter().zip(&twin.vout[start..]).map(|(a, b)| a - b).collect();
        Ok((d.iter().map(|x| x * x).sum::<f64>() / d.len().max(1) as f64).sqrt())
    };
    let effects = truth.effects();
    let keys: Option<Vec<&str>> = effects.iter().map(|e| harness_effect_keys(e)).collect::<Option<Vec<_>>>().map(|k| k.concat());
    let effect_rms = keys.filter(|k| !k.is_empty()).map(|keys| footprint(&keys)).transpose()?;
    let distinct = effects.iter().all(|e| effects.iter().filter(|a| *a == e).count() == 1);
    let effect_rms_each = if effects.len() >= 2 && distinct { effects.iter().map(|e| harness_effect_keys(e).map(footprint).transpose()).collect::<Result<Vec<_>, _>>()? } else { Vec::new() };
    Ok(Case { data: blind(data), nominal: Params::default(), model: Nominal::Switched, truth, source: "harness", effect_rms, effect_rms_each, true_cl })
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len().max(1) as f64
}

/// The operating point of a generator's record: its output voltage averaged in time, from the
/// plant's own period averages (`vout_avg`: the FMU, the own netlists) or the harness's
/// `vout_time_mean` \[V\]. Not the samples' mean: they are all taken at one phase of the ripple.
fn operating_point(data: &DataSet) -> Result<f64, EstimatorError> {
    if let Some(averages) = data.vout_avg.as_deref() {
        return Ok(mean(averages));
    }
    data.meta
        .get(HARNESS_TIME_MEAN)
        .and_then(|v| v.parse::<f64>().ok())
        .ok_or_else(|| EstimatorError::Data(format!("the generator recorded no time average of vout (`vout_avg` or `# {HARNESS_TIME_MEAN}`)")))
}

/// The harness's metadata key for the output voltage averaged in time over the record.
const HARNESS_TIME_MEAN: &str = "vout_time_mean";

/// The load capacitance at the voltage `v` under the model's DC-bias law (the FMU's and the
/// own netlists', `cap_rated_voltage` 16 V unless set) \[F\]; `truth.cl` without a bias.
fn model_biased_cl(truth: &Truth, v: f64) -> f64 {
    let mut p = Params { cl: truth.cl, ..Params::default() };
    for (key, value) in &truth.settings {
        match *key {
            "cap_dc_bias" => p.cap_dc_bias = *value,
            "cap_rated_voltage" => p.cap_rated_voltage = *value,
            _ => {}
        }
    }
    p.cl_at(v)
}

/// The small-signal load capacitance at the voltage `v` under the harness's DC-bias law
/// (`scripts/spice/harness/harness.py`: `Cl(v) = Cl/(1 + c·v/Vr)²`, `c = 1/√(1 − dcbias) − 1`)
/// \[F\]; `truth.cl` without a bias.
pub fn harness_biased_cl(truth: &Truth, v: f64) -> f64 {
    let setting = |key: &str| truth.settings.iter().find(|(k, _)| *k == key).map(|(_, x)| *x);
    match (setting("dcbias"), setting("vrated")) {
        (Some(bias), Some(rated)) if bias > 0.0 => {
            let c = 1.0 / (1.0 - bias).sqrt() - 1.0;
            truth.cl / (1.0 + c * v / rated).powi(2)
        }
        _ => truth.cl,
    }
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
    /// The effects the diagnosis named, in its order (empty for `none` and for an error; see
    /// [`named_effects`]).
    pub named: Vec<String>,
    /// The effects the diagnosis said its data does not tell from a named one ([`gap::Alike`]).
    pub alike: Vec<String>,
    /// Held-out NRMSE shrink of the final model (the last selected effect) [%] (sensor noise included).
    pub shrink_percent: Option<f64>,
    /// Share of the held-out gap above the true measurement noise
    /// ([`Truth::measurement_noise`]) that the verdict's effect closed [%]; `None` when the
    /// nominal model's gap is not above that noise ([`gap::closed_percent`]).
    pub closed_percent: Option<f64>,
    /// The withheld effect is detectable at all: what it adds to `vout` ([`Case::effect_rms`],
    /// where a twin was run), else the nominal model's miss, exceeds the true measurement noise
    /// ([`gap::gap_above`]).
    pub detectable: bool,
    /// Of a dataset withholding several distinct effects, the ones whose own footprint
    /// ([`Case::effect_rms_each`]) is not above the true measurement noise: no diagnosis can
    /// name them from this data.
    pub below_detection: Vec<&'static str>,
    /// The diagnosis's own, model-free estimate of the sensor noise \[V\].
    pub noise_floor: Option<f64>,
    /// The verdict's Cl estimate and its CI95 \[F\].
    pub cl: Option<(f64, [f64; 2])>,
    /// The test of the verdict's Cl interval (see [`gap::ClCheck`]).
    pub cl_check: Option<gap::ClCheck>,
    /// The Cl estimate and CI95 the diagnosis ends with (the nominal's for `none`) \[F\].
    pub final_cl: Option<(f64, [f64; 2])>,
    /// Wall time of the diagnosis \[s\].
    pub seconds: f64,
    /// The load capacitance the data shows ([`Case::true_cl`]) \[F\].
    pub true_cl: f64,
}

/// Whether `ci95` holds `truth` and is identified ([`estimator::validate::identified`]): an
/// interval from zero to infinity holds every value and says nothing, so it scores a miss.
fn covers(ci95: [f64; 2], truth: f64) -> bool {
    estimator::validate::identified(ci95) && ci95[0] <= truth && truth <= ci95[1]
}

impl Outcome {
    /// Whether the true Cl lies in the verdict's CI95 and that interval pins Cl down (`None`
    /// without a verdict's Cl).
    pub fn cl_in_ci95(&self) -> Option<bool> {
        self.cl.map(|(_, ci95)| covers(ci95, self.true_cl))
    }

    /// Whether the true Cl lies in the final CI95 and that interval pins Cl down (`None`
    /// without one).
    pub fn final_cl_in_ci95(&self) -> Option<bool> {
        self.final_cl.map(|(_, ci95)| covers(ci95, self.true_cl))
    }

    /// Whether the diagnosis got the truth: a clean dataset called `none`, a one-effect dataset
    /// with its effect named first, a two-effect dataset with both named (in any order).
    pub fn hit(&self) -> bool {
        if self.verdict.starts_with("error") {
            return false;
        }
        let named = self.named_withheld();
        match self.truth.effects().as_slice() {
            [] => named.is_empty(),
            [one] => named.first().is_some_and(|n| n == one),
            all => self.withheld_named() == all.len(),
        }
    }

    /// How many of the withheld effects were named (each as often as it was withheld: two
    /// drifts need two named).
    pub fn withheld_named(&self) -> usize {
        let (all, named) = (self.truth.effects(), self.named_withheld());
        let mut distinct = all.clone();
        distinct.dedup();
        distinct.iter().map(|e| all.iter().filter(|a| *a == e).count().min(named.iter().filter(|n| n.as_str() == *e).count())).sum()
    }

    /// The named effects less `sample_delay` where the data was acquired late (the harness's
    /// ADC, in every one of its datasets): naming it is right there, and it is not the withheld
    /// effect being scored.
    pub fn named_withheld(&self) -> Vec<&String> {
        let late = self.truth.settings.iter().any(|(k, v)| *k == "adc_delay" && *v > 0.0);
        self.named.iter().filter(|n| !(late && *n == "sample_delay")).collect()
    }

    /// Whether the diagnosis got the truth ([`Outcome::hit`]) or said what it missed alike to a
    /// named effect ([`gap::Alike`]): a one-effect dataset's effect said alike, each of several
    /// named or said alike. The diagnosis told the engineer of each, if not as the one it took.
    pub fn told(&self) -> bool {
        if self.hit() {
            return true;
        }
        let alike = |e: &str| self.alike.iter().any(|a| a == e);
        match self.truth.effects().as_slice() {
            _ if self.verdict.starts_with("error") => false,
            [] => false,
            [one] => alike(one),
            all => all.iter().all(|e| alike(e) || self.named_withheld().iter().any(|n| n == e)),
        }
    }

    /// What the diagnosis said, for tables: the named effects joined by `+`, or the verdict
    /// (`none`, or the error).
    pub fn said(&self) -> String {
        if self.named.is_empty() { self.verdict.clone() } else { self.named.join("+") }
    }
}

/// The effects a diagnosis names, in its order; empty for `none`. Every score goes through
/// this one function.
pub fn named_effects(dx: &gap::Diagnosis) -> Vec<String> {
    dx.selected.iter().map(|e| e.name.to_string()).collect()
}

/// Diagnoses `case` as a user would (data, nominal values, model; nothing else) and scores it.
pub fn diagnose_case(case: &Case) -> Outcome {
    let opts = gap::DiagnoseOptions { nominal: case.model, ..gap::DiagnoseOptions::default() };
    let noise = case.truth.measurement_noise();
    let clock = std::time::Instant::now();
    let result = gap::diagnose(&case.data, &case.nominal, &opts);
    let seconds = clock.elapsed().as_secs_f64();
    let mut outcome = Outcome {
        truth: case.truth.clone(),
        source: case.source,
        verdict: String::new(),
        named: Vec::new(),
        alike: Vec::new(),
        shrink_percent: None,
        closed_percent: None,
        detectable: false,
        below_detection: case.truth.effects().into_iter().zip(&case.effect_rms_each).filter(|(_, rms)| rms.is_some_and(|r| !gap::gap_above(r.hypot(noise), noise))).map(|(e, _)| e).collect(),
        noise_floor: None,
        cl: None,
        cl_check: None,
        final_cl: None,
        seconds,
        true_cl: case.true_cl,
    };
    match result {
        Ok(dx) => {
            // The gap the final model leaves: the last selected effect's.
            let best = dx.selected.last();
            outcome.verdict.clone_from(&dx.verdict);
            outcome.named = named_effects(&dx);
            outcome.alike = dx.selected.iter().flat_map(|e| e.alike.iter().map(|a| a.name.to_string())).collect();
            let (cl, ci95, _) = dx.final_cl();
            outcome.final_cl = Some((cl, ci95));
            outcome.shrink_percent = best.map(|e| e.shrink_percent);
            outcome.detectable = match case.effect_rms {
                Some(rms) => gap::gap_above(rms.hypot(noise), noise),
                None => gap::gap_above(dx.gap_before.rms, noise),
            };
            outcome.closed_percent = best.and_then(|e| gap::closed_percent(dx.gap_before.rms, e.rms_after, case.truth.measurement_noise()));
            outcome.noise_floor = (dx.location.noise_floor_from == gap::FloorSource::Differences).then_some(dx.location.noise_floor_rms);
            outcome.cl = best.map(|e| (e.cl.estimate, e.cl.ci95));
            outcome.cl_check = best.and_then(|e| e.cl.check.clone());
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
    /// Datasets withholding an effect, with it named or said alike to the one named
    /// ([`Outcome::told`]).
    pub told: usize,
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
    /// Datasets withholding two effects.
    pub pair_cases: usize,
    /// Of those, with both named.
    pub pair_named: usize,
    /// Of those, with at least one named.
    pub pair_one_named: usize,
    /// Of those, the ones each of whose effects leaves a gap above the measurement noise by
    /// itself ([`Outcome::below_detection`] empty).
    pub pair_detectable_cases: usize,
    /// Of those, with both named.
    pub pair_detectable_named: usize,
    /// Datasets withholding two effects, with each named or said alike ([`Outcome::told`]).
    pub pair_told: usize,
    /// Datasets withholding three or more effects.
    pub several_cases: usize,
    /// Of those, with every one named.
    pub several_named: usize,
    /// The withheld effects of those datasets.
    pub several_effects: usize,
    /// Of those, named.
    pub several_effects_named: usize,
    /// Datasets with a final Cl interval.
    pub final_cl_cases: usize,
    /// Of those, with the true Cl inside it.
    pub final_cl_covered: usize,
}

/// Scores `outcomes` (one-effect, clean and two-effect datasets apart; the gap and Cl scores
/// over every correctly named dataset with an effect).
pub fn score(outcomes: &[Outcome]) -> Scores {
    let effect: Vec<&Outcome> = outcomes.iter().filter(|o| o.truth.effects().len() == 1).collect();
    let pair: Vec<&Outcome> = outcomes.iter().filter(|o| o.truth.effects().len() == 2).collect();
    let several: Vec<&Outcome> = outcomes.iter().filter(|o| o.truth.effects().len() > 2).collect();

    let clean: Vec<&Outcome> = outcomes.iter().filter(|o| o.truth.effects().is_empty()).collect();
    let named: Vec<&Outcome> = outcomes.iter().filter(|o| !o.truth.effects().is_empty() && o.hit()).collect();
    let finals: Vec<bool> = outcomes.iter().filter_map(Outcome::final_cl_in_ci95).collect();
    Scores {
        effect_cases: effect.len(),
        named: effect.iter().filter(|o| o.hit()).count(),
        detectable_cases: effect.iter().filter(|o| o.detectable).count(),
        detectable_named: effect.iter().filter(|o| o.detectable && o.hit()).count(),
        told: effect.iter().filter(|o| o.told()).count(),
        clean_cases: clean.len(),
        none: clean.iter().filter(|o| o.hit()).count(),
        with_gap: named.iter().filter(|o| o.closed_percent.is_some()).count(),
        closed_70: named.iter().filter(|o| o.closed_percent.is_some_and(|s| s >= 70.0)).count(),
        cl_covered: named.iter().filter(|o| o.cl_in_ci95() == Some(true)).count(),
        pair_cases: pair.len(),
        pair_named: pair.iter().filter(|o| o.hit()).count(),
        pair_one_named: pair.iter().filter(|o| o.truth.effects().iter().any(|e| o.named.iter().any(|n| n == e))).count(),
        pair_detectable_cases: pair.iter().filter(|o| o.below_detection.is_empty()).count(),
        pair_detectable_named: pair.iter().filter(|o| o.below_detection.is_empty() && o.hit()).count(),
        pair_told: pair.iter().filter(|o| o.told()).count(),
        several_cases: several.len(),
        several_named: several.iter().filter(|o| o.hit()).count(),
        several_effects: several.iter().map(|o| o.truth.effects().len()).sum(),
        several_effects_named: several.iter().map(|o| o.withheld_named()).sum(),
        final_cl_cases: finals.len(),
        final_cl_covered: finals.iter().filter(|c| **c).count(),
    }
}

/// The confusion matrix (rows: withheld effect(s), columns: what the diagnosis said) as a
/// Markdown table.
pub fn confusion_matrix(outcomes: &[Outcome]) -> String {
    let mut rows: Vec<String> = Vec::new();
    let mut cols: Vec<String> = Vec::new();
    for o in outcomes {
        if !rows.contains(&o.truth.label()) {
            rows.push(o.truth.label());
        }
        if !cols.contains(&o.said()) {
            cols.push(o.said());
        }
    }
    let order = |name: &str| {
        let first = name.split('+').next().unwrap_or(name);
        (plant_effects().position(|e| e == first).unwrap_or(usize::MAX), name.contains('+'))
    };
    rows.sort_by_key(|r| (order(r), r.clone()));
    cols.sort_by_key(|c| (order(c), c.clone()));
    let mut s = format!("| withheld \\ verdict | {} |\n|---|{}\n", cols.join(" | "), "---:|".repeat(cols.len()));
    for r in &rows {
        let counts: Vec<String> = cols
            .iter()
            .map(|c| {
                let n = outcomes.iter().filter(|o| &o.truth.label() == r && &o.said() == c).count();
                if n == 0 { ".".to_string() } else { n.to_string() }
            })
            .collect();
        s += &format!("| {r} | {} |\n", counts.join(" | "));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An outcome of a harness dataset (its ADC late) withholding `effects`, naming `named`.
    fn outcome(effects: &[&'static str], named: &[&str]) -> Outcome {
        let truth = Truth { effect: effects[0], also: effects[1..].to_vec(), noise: 1e-3, cl: 1e-6, io: 1.0, settings: vec![("adc_delay", 1e-7)] };
        Outcome {
            truth,
            source: "harness-several",
            verdict: named.first().map_or("none", |n| n).to_string(),
            named: named.iter().map(|n| n.to_string()).collect(),
            alike: Vec::new(),
            shrink_percent: None,
            closed_percent: None,
            detectable: true,
            below_detection: Vec::new(),
            noise_floor: None,
            cl: None,
            cl_check: None,
            final_cl: None,
            seconds: 0.0,
            true_cl: 1e-6,
        }
    }

    /// Two drifts withheld need two named; the late reading the harness always has is not
    /// scored; the order does not matter.
    #[test]
    fn each_withheld_effect_counts_as_often_as_it_was_withheld() {
        let withheld = ["dead_time", "switch_resistance", "param_drift", "param_drift"];
        let one_drift = outcome(&withheld, &["dead_time", "param_drift", "sample_delay", "switch_resistance"]);
        assert_eq!(one_drift.withheld_named(), 3);
        assert!(!one_drift.hit());
        let both = outcome(&withheld, &["param_drift", "dead_time", "sample_delay", "param_drift", "switch_resistance"]);
        assert_eq!(both.withheld_named(), 4);
        assert!(both.hit());
        let scores = score(&[one_drift, both]);
        assert_eq!((scores.several_cases, scores.several_named, scores.several_effects, scores.several_effects_named, scores.pair_cases), (2, 1, 8, 7, 0));
    }

    /// A pair with an effect that leaves no gap above the noise by itself is scored apart: both
    /// named over all pairs, and over the pairs each of whose effects shows.
    #[test]
    fn a_pair_with_an_effect_below_detection_is_scored_apart() {
        let pair = ["dead_time", "load_esr"];
        let missed_faint = Outcome { below_detection: vec!["load_esr"], ..outcome(&pair, &["dead_time"]) };
        let missed = outcome(&pair, &["dead_time", "switch_resistance"]);
        let both = outcome(&pair, &["dead_time", "load_esr"]);
        let s = score(&[missed_faint, missed, both]);
        assert_eq!((s.pair_cases, s.pair_named, s.pair_one_named), (3, 1, 3));
        assert_eq!((s.pair_detectable_cases, s.pair_detectable_named), (2, 1));
    }

    /// An effect the diagnosis said its data does not tell from the one it named is told, not
    /// named: scored apart, for a single effect and for each of a pair's.
    #[test]
    fn an_effect_said_alike_is_told_but_not_named() {
        let slope_for_switches = Outcome { alike: vec!["switch_resistance".into()], ..outcome(&["diode_drop", "switch_resistance"], &["diode_drop", "diode_resistance"]) };
        let gain_for_esl = Outcome { alike: vec!["esl".into()], ..outcome(&["esl"], &["sensor_gain"]) };
        let missed = outcome(&["esl"], &["sensor_gain"]);
        // Named, but not first: no more told than named.
        let named_later = outcome(&["esl"], &["sensor_gain", "esl"]);
        assert!(slope_for_switches.told() && !slope_for_switches.hit());
        assert!(!named_later.told() && !named_later.hit());
        let s = score(&[slope_for_switches, gain_for_esl, missed]);
        assert_eq!((s.pair_named, s.pair_told, s.named, s.told), (0, 1, 0, 1));
    }
}
