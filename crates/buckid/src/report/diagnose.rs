//! The report of `diagnose`: the gap by frequency band, by operating point and by time window
//! (each against the noise floor), the held-out traces of the measurement, the nominal model
//! and the verdict, the table of effects and the effects not tested.
use std::path::{Path, PathBuf};

use anyhow::Result;
use buck_model::Params;
use estimator::data::DataSet;
use gap::{Diagnosis, Group, Nominal};

use super::{Page, table};
use crate::svg::{Bar, Bars, Plot, Series, esc};
use crate::diagnose::effect_params;
use crate::units::{si, with_ci};

/// Most held-out samples drawn in the trace overlay.
const MAX_TRACE: usize = 2000;

/// What the report shows besides the diagnosis.
pub struct Context<'a> {
    /// The data file.
    pub source: &'a str,
    /// The data (for the held-out time axis).
    pub data: &'a DataSet,
    /// Nominal circuit values used.
    pub nominal: &'a Params,
    /// Notes on assumed circuit values.
    pub assumed: &'a [String],
    /// The FMU as given: its path, held-out NRMSE and held-out `vout` simulation.
    pub fmu: Option<(&'a str, f64, &'a [f64])>,
}

fn model_name(n: Nominal) -> &'static str {
    match n {
        Nominal::Averaged => "averaged",
        Nominal::Switched => "switched (sampled-data PWM)",
    }
}

fn group_bars<'a>(title: &'a str, groups: &[Group]) -> Bars<'a> {
    Bars {
        title,
        value_label: "residual RMS / noise-floor RMS",
        bars: groups.iter().map(|g| Bar { label: format!("{} ({} samples)", g.label, g.samples), value: g.rms_over_floor }).collect(),
        reference: Some((1.0, "noise floor")),
        color: "#ff7f0e",
    }
}

/// An effect's parameters as the CLI prints them, one per line.
fn params_html(e: &gap::EffectFit) -> String {
    effect_params(e).iter().map(|p| esc(p)).collect::<Vec<_>>().join("<br>")
}

/// Writes `index.html` and the figures into `dir` and returns the page's path.
pub fn write(dir: &Path, dx: &Diagnosis, ctx: &Context<'_>) -> Result<PathBuf> {
    let w = &dx.location;
    let bands = Bars {
        title: "Gap by frequency band: residual PSD over the noise floor's",
        value_label: "dB over the noise floor",
        bars: w.bands.iter().map(|b| Bar { label: format!("{:.1}–{:.1} kHz", b.from_hz / 1e3, b.to_hz / 1e3), value: b.db_over_floor }).collect(),
        reference: Some((0.0, "noise floor")),
        color: "#1f77b4",
    };
    let points = group_bars("Gap by operating point", &w.operating_points);
    let windows = group_bars("Gap by time window of the held-out part", &w.windows);

    let t = &dx.traces;
    let shown = t.measured.len().min(MAX_TRACE);
    let time = &ctx.data.time[t.start.min(ctx.data.len())..];
    let t0 = time.first().copied().unwrap_or(0.0);
    let trace = |y: &[f64]| -> Vec<(f64, f64)> { time.iter().zip(y).take(shown).map(|(t, y)| ((t - t0) * 1e3, *y)).collect() };
    let nominal_name = format!("nominal {} model", model_name(dx.nominal));
    let after_name = format!("with {}", dx.selected.iter().map(|e| e.name).collect::<Vec<_>>().join(" + "));
    let mut series = vec![
        Series { name: "measured", color: "#999", points: trace(&t.measured), stems: false },
        Series { name: &nominal_name, color: "#1f77b4", points: trace(&t.nominal), stems: false },
    ];
    if let Some(after) = &t.after {
        series.push(Series { name: &after_name, color: "#d62728", points: trace(after), stems: false });
    }
    if let Some((_, _, sim)) = ctx.fmu {
        series.push(Series { name: "FMU as given", color: "#2ca02c", points: trace(sim), stems: false });
    }
    let overlay = Plot {
        title: "Held-out data: measured, nominal model and the final model",
        x_label: "time since hold-out start [ms]",
        y_label: "vout [V]",
        log_x: false,
        band: None,
        series,
    };

    let rows: Vec<Vec<String>> = dx
        .effects
        .iter()
        .map(|e| {
            let name = if e.name == dx.verdict { format!("<b>{}</b>", e.name) } else { e.name.to_string() };
            vec![
                name,
                params_html(e),
                esc(&with_ci(e.cl.estimate, Some(e.cl.ci95), "F")),
                format!("{:.4}", e.nrmse_after),
                format!("{:.1}", e.shrink_percent),
                e.closed_percent.map_or_else(|| "–".to_string(), |c| format!("{c:.1}")),
                format!("{:.1}", e.delta_aic),
                match (e.lr_statistic, e.lr_limit) {
                    (Some(s), Some(l)) => format!("{s:.1} / {l:.1}"),
                    (Some(s), None) => format!("{s:.1}"),
                    _ => "–".to_string(),
                },
                e.standing().to_string(),
            ]
        })
        .collect();
    let not_tested: String = dx.not_tested.iter().map(|n| format!("<li><code>{}</code>: {}</li>", n.name, esc(&n.reason))).collect();
    let p = ctx.nominal;

    let mut page = Page::new("buckid diagnose", "Sim-to-real gap diagnosis");
    page.html(&format!(
        "<p>Data: <code>{}</code>, {} held-out samples of {}. Nominal model: <b>{}</b> with L = {}, RL = {}, C = {}, Rc = {}, fs = {}{}{}.</p>",
        esc(ctx.source),
        t.measured.len(),
        ctx.data.len(),
        model_name(dx.nominal),
        si(p.l, "H", 4),
        si(p.rl, "Ω", 4),
        si(p.c, "F", 4),
        si(p.rc, "Ω", 4),
        si(p.fs, "Hz", 6),
        if p.rload > 0.0 { format!(", load resistor {}", si(p.rload, "Ω", 4)) } else { String::new() },
        if ctx.assumed.is_empty() { String::new() } else { format!(" (assumed: {})", esc(&ctx.assumed.join("; "))) },
    ));
    page.html(&format!(
        "<p><b>Verdict: {}</b>{}. Gap before: held-out NRMSE {:.4} (nominal fit, Cl = {:.4} µF).{}</p>",
        esc(&dx.verdict),
        if dx.selected.len() > 1 { format!(" (selected in turn: {})", dx.selected.iter().map(|e| e.name).collect::<Vec<_>>().join(", ")) } else { String::new() },
        dx.gap_before.nrmse,
        dx.gap_before.cl * 1e6,
        ctx.fmu.map_or(String::new(), |(path, nrmse, _)| format!(" The FMU as given (<code>{}</code>): held-out NRMSE {nrmse:.4}.", esc(path))),
    ));
    let (cl, ci95, test) = dx.final_cl();
    page.html(&format!("<p>Cl of the final model: {}; {}.</p>", esc(&with_ci(cl, Some(ci95), "F")), esc(&test)));
    let steps: Vec<Vec<String>> = dx
        .selected
        .iter()
        .enumerate()
        .map(|(i, e)| {
            vec![
                format!("{}", i + 1),
                format!("<b>{}</b>", e.name),
                params_html(e),
                e.closed_percent.map_or_else(|| "–".to_string(), |c| format!("{c:.1}")),
                e.closed_of_remaining.map_or_else(|| "–".to_string(), |c| format!("{c:.1}")),
                esc(&si(e.rms_after, "V", 3)),
            ]
        })
        .collect();
    page.html("<h2>Effects selected, in order</h2>");
    if steps.is_empty() {
        page.html(&format!("<p>None: {}.</p>", esc(&dx.selection_ended)));
    } else {
        page.html(&table(&["step", "effect", "parameters at the final fit [CI95]", "gap over the floor closed [%]", "of what was left [%]", "held-out residual RMS"], &steps));
        page.html(&format!("<p>The sequence ended: {}.</p>", esc(&dx.selection_ended)));
    }
    page.html(&format!(
        "<p>Where: {} (noise floor {:.3e} V RMS: {}; held-out residual {:.3e} V RMS).</p>",
        esc(&w.summary),
        w.noise_floor_rms,
        esc(w.noise_floor_from.describe()),
        dx.gap_before.rms
    ));
    page.figure("gap_bands", bands.render());
    page.figure("gap_operating_points", points.render());
    page.figure("gap_windows", windows.render());
    page.figure("heldout", overlay.render());
    page.html("<h2>Effects, best held-out error first</h2>");
    page.html(&table(&["effect", "parameters [CI95]", "Cl [CI95]", "NRMSE after", "shrink [%]", "gap over the floor closed [%]", "ΔAIC", "LR / 99 %", "standing"], &rows));
    if !not_tested.is_empty() {
        page.html(&format!("<h2>Not tested</h2><ul>{not_tested}</ul>"));
    }
    page.write(dir)
}
