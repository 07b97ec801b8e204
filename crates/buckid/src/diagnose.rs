//! `buckid diagnose`: where, which and how far, for a data file against the nominal model
//! (averaged or switched; its circuit values optionally from an FMU, which is then also run
//! as given).
use std::collections::BTreeMap;

use anyhow::{Context, Result};
use buck_model::Params;
use estimator::data::DataSet;
use gap::{DiagnoseOptions, Nominal, diagnose};
use serde::Serialize;

use crate::identify::{nominal_with, pair};
use crate::nominal_fmu::NominalFmu;
use crate::units::{si, unit_of, with_ci};
use crate::{DiagnoseArgs, NominalChoice};

/// The `"fmu"` member of the JSON: the FMU as given, run on the data.
#[derive(Debug, Serialize)]
struct FmuOut {
    path: String,
    model_name: String,
    /// The nominal model its `mode` start value selects, if it has one.
    mode: Option<Nominal>,
    /// Circuit values taken from its start values.
    circuit: BTreeMap<&'static str, f64>,
    /// Cl it was run with (the nominal fit's), when it has a `Cl` parameter \[F\].
    cl: Option<f64>,
    /// Held-out NRMSE of its simulation.
    nrmse: f64,
}

fn name(n: Nominal) -> &'static str {
    match n {
        Nominal::Averaged => "averaged",
        Nominal::Switched => "switched",
    }
}

/// The nominal model: `--nominal`, else the FMU's `mode`, else the one the data calls for
/// ([`gap::nominal_for`]); notes on stderr.
fn choose_nominal(asked: Option<NominalChoice>, fmu: Option<&NominalFmu>, data: &DataSet, nominal: &Params, holdout: f64) -> Nominal {
    let from_fmu = fmu.and_then(NominalFmu::nominal);
    let asked = asked.map(|c| match c {
        NominalChoice::Averaged => Nominal::Averaged,
        NominalChoice::Switched => Nominal::Switched,
    });
    match (asked, from_fmu) {
        (Some(n), Some(Ok(m))) if n != m => {
            eprintln!("nominal model {} as asked (the FMU's `mode` selects {}; the FMU itself runs as given)", name(n), name(m));
            n
        }
        (Some(n), _) => n,
        (None, Some(Ok(m))) => {
            eprintln!("nominal model {} from the FMU's `mode` start value", name(m));
            m
        }
        (None, Some(Err(v))) => {
            eprintln!("the FMU's `mode` start value {v} is neither 1 (averaged) nor 2 (switched): assuming the averaged nominal model");
            Nominal::Averaged
        }
        (None, None) => {
            let e = gap::nominal_for(data, nominal, holdout);
            let why = if e.nominal == Nominal::Switched { "samples of a switching converter" } else { "the averaged model fits and the data holds no switching ripple" };
            eprintln!(
                "nominal model {} ({why}: the averaged model's held-out residual {:.2} noise floors, the ripple's share in it {:.2}; --nominal sets the model)",
                name(e.nominal),
                e.averaged_floors,
                e.ripple_share
            );
            e.nominal
        }
    }
}

/// Runs the command.
pub fn run(args: &DiagnoseArgs) -> Result<()> {
    let map: BTreeMap<String, String> = args.map.iter().map(|m| pair(m, "--map")).collect::<Result<_>>()?;
    eprintln!("reading {}", args.data.display());
    let data = DataSet::read_csv(&args.data)?;
    data.check_output_level()?;
    let fmu = match &args.fmu {
        Some(path) => {
            eprintln!("loading {}", path.display());
            Some(NominalFmu::open(path)?)
        }
        None => None,
    };
    let given = fmu.as_ref().map(|f| f.circuit.clone()).unwrap_or_default();
    if !given.is_empty() {
        eprintln!("circuit values from the FMU's start values: {}", given.keys().copied().collect::<Vec<_>>().join(", "));
    }
    let (nominal, assumed) = nominal_with(&data, &given)?;
    for a in &assumed {
        eprintln!("assuming {a}");
    }
    let model = choose_nominal(args.nominal, fmu.as_ref(), &data, &nominal, args.holdout);
    eprintln!("fitting the nominal {} model and the candidate effects", name(model));
    if !(0.0..1.0).contains(&args.tolerance) {
        anyhow::bail!("--tolerance {} must be a relative tolerance in [0, 1)", args.tolerance);
    }
    let dx = diagnose(&data, &nominal, &DiagnoseOptions { holdout: args.holdout, nominal: model, tolerance: args.tolerance })?;
    let fmu_out = match (fmu, &args.fmu) {
        (Some(f), Some(path)) => {
            eprintln!("running {} on the data's inputs", path.display());
            let (model_name, mode, circuit) = (f.model_name().to_string(), f.nominal().and_then(Result::ok), f.circuit.clone());
            // Driven as the diagnosis's models were: by the measured inputs' levels where it
            // replaced them.
            let levels = dx.measured_inputs.iter().any(|m| m.replaced).then(|| estimator::inputs::average_measured(&data).0);
            let run = f.run(levels.as_ref().unwrap_or(&data), dx.traces.start, dx.gap_before.cl, map)?;
            let out = FmuOut { path: path.display().to_string(), model_name, mode, circuit, cl: run.cl, nrmse: run.nrmse };
            Some((out, run.simulated))
        }
        _ => None,
    };

    println!("source      {}", args.data.display());
    for input in &dx.measured_inputs {
        println!("input       {input}");
    }
    let nominal_cl = dx.gap_before.cl_not_identified().map_or(String::new(), |why| format!(", {why}"));
    println!("gap before  held-out NRMSE {:.4} ({} model, Cl {:.4} µF{nominal_cl})", dx.gap_before.nrmse, name(dx.nominal), dx.gap_before.cl * 1e6);
    if let Some((f, _)) = &fmu_out {
        let cl = f.cl.map_or_else(|| "its own Cl".to_string(), |cl| format!("Cl {:.4} µF", cl * 1e6));
        println!("FMU         held-out NRMSE {:.4} as given ({}, {cl})", f.nrmse, f.path);
    }
    println!("noise floor {:.3e} V RMS under a held-out residual of {:.3e} V RMS (floor: {})", dx.location.noise_floor_rms, dx.gap_before.rms, dx.location.noise_floor_from.describe());
    println!("where       {}", dx.location.summary);
    for e in &dx.effects {
        let mut params = effect_params(e);
        if let Some(hi) = e.ruled_out_above {
            params.push(format!("ruled out above {} (95 %)", si(hi, unit_of(e.name), 2)));
        }
        println!(
            "effect      {:19} NRMSE {:.4} ({:+6.1} %)  closes {} of the gap over the floor  {:24}  Cl {}  {}",
            e.name,
            e.nrmse_after,
            -e.shrink_percent,
            e.closed_percent.map_or_else(|| "   –   ".to_string(), |c| format!("{c:5.1} %")),
            e.standing(),
            si(e.cl.estimate, "F", 5),
            params.join(", ")
        );
    }
    for n in &dx.not_tested {
        println!("not tested  {:19} {}", n.name, n.reason);
    }
    for (i, e) in dx.selected.iter().enumerate() {
        // Without a model-free floor there is no gap to measure a share of: the NRMSE's shrink.
        let closed = match (e.closed_percent, dx.location.noise_floor_from) {
            (Some(c), _) => format!("{c:.1} % of the gap over the floor closed"),
            (None, gap::FloorSource::ModelResidual) => format!("held-out NRMSE {:+.1} % (no model-free floor to measure a gap against)", -e.shrink_percent),
            (None, gap::FloorSource::Differences) => "no gap in vout above the floor".to_string(),
        };
        println!("selected    {}. {:16} {}; held-out residual {}  {}", i + 1, e.label(), closed, si(e.rms_after, "V", 3), effect_params(e).join(", "));
        if let Some(alike) = alike_text(e) {
            println!("            alike: {alike}");
        }
    }
    println!("selection   {}", dx.selection_ended);
    println!("verdict     {}", dx.verdict_text());
    if let Some(regime) = dx.regime() {
        println!("regime      {regime}");
    }
    let (cl, ci95, test) = dx.final_cl();
    println!("Cl          {}; {test}", with_ci(cl, Some(ci95), "F"));
    if let Some(leverage) = dx.leverage() {
        println!("leverage    {leverage}");
    }

    if let Some(path) = &args.json {
        let mut json = serde_json::to_value(&dx)?;
        if let (Some(obj), Some((f, _))) = (json.as_object_mut(), &fmu_out) {
            obj.insert("fmu".to_string(), serde_json::to_value(f)?);
        }
        std::fs::write(path, serde_json::to_string_pretty(&json)? + "\n").with_context(|| format!("writing {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    if let Some(dir) = &args.report {
        let source = args.data.display().to_string();
        let ctx =
            crate::report::diagnose::Context { source: &source, data: &data, nominal: &nominal, assumed: &assumed, fmu: fmu_out.as_ref().map(|(f, sim)| (f.path.as_str(), f.nrmse, sim.as_slice())) };
        let file = crate::report::diagnose::write(dir, &dx, &ctx)?;
        eprintln!("wrote {}", file.display());
    }
    Ok(())
}

/// An effect's parameters with units and CI95 ("not identified" where the interval tells
/// nothing), and a drift's distance from its nominal (the nominal value itself left out): for
/// the CLI and the report alike.
pub(crate) fn effect_params(e: &gap::EffectFit) -> Vec<String> {
    let mut out = fitted_values(&e.params, &e.ci95);
    if e.params.contains_key(gap::RECIPROCAL_BIAS_LAW) {
        out.push("under the reciprocal law: Cl kept 1/(1 + c·v/cap_rated_voltage)², c = 1/√(1 − cap_dc_bias) − 1".to_string());
    }
    if let Some(d) = e.drift_percent {
        out.push(format!("{d:+.2} % from nominal"));
    }
    if let Some(r) = e.of_rl_percent {
        out.push(format!("{r:+.2} % of RL"));
    }
    if let Some(stand_in) = &e.stand_in {
        out.push(stand_in.clone());
    }
    if let Some(c) = e.il_closed_percent {
        out.push(format!("closes {c:.1} % of il's gap over its floor"));
    }
    out
}

/// Fitted values with units and CI95 ("not identified" where the interval tells nothing), the
/// nominal values and flags among them left out.
fn fitted_values(params: &BTreeMap<String, f64>, ci95: &BTreeMap<String, [f64; 2]>) -> Vec<String> {
    params
        .iter()
        .filter(|(k, _)| !k.ends_with("_nominal") && *k != "dcm" && *k != gap::RECIPROCAL_BIAS_LAW)
        .map(|(k, v)| {
            // A delay is a whole number of periods; a reading's gain error reads as a percentage.
            if k == "delay" {
                let late_readings = if *v < 0.0 { " (the readings a period late: each row's outputs taken at its period's end, not its start as the data contract has them)" } else { "" };
                return format!("delay = {v:.0} period{}{late_readings}", if v.abs() == 1.0 { "" } else { "s" });
            }
            // A reading locked to the PWM: `sample_delay` is then its instant at half duty.
            if k == "sample_duty_share" {
                return format!("sample_duty_share = {v} (an ADC triggered from the PWM: read sample_delay + {v}·(D − ½)·T after each period start)");
            }
            let (scale, unit) = if k.ends_with("_gain_error") { (100.0, "%") } else { (1.0, unit_of(k)) };
            let value = format!("{k} = {}", with_ci(v * scale, ci95.get(k).map(|c| c.map(|x| x * scale)), unit));
            // The channels read apart: which comes first.
            if k == "vout_skew" {
                return format!("{value} (vout read {} il)", if *v >= 0.0 { "after" } else { "before" });
            }
            value
        })
        .collect()
}

/// The findings that explain a selected step's gap alike ([`gap::Alike`]), in words.
pub(crate) fn alike_text(e: &gap::EffectFit) -> Option<String> {
    let each: Vec<String> = e.alike.iter().map(|a| format!("{} ({}; {} held out, Cl {})", a.label, fitted_values(&a.params, &a.ci95).join(", "), si(a.rms_after, "V", 3), si(a.cl, "F", 4))).collect();
    (!each.is_empty()).then(|| format!("the data does not tell it from {}", each.join(" or ")))
}
