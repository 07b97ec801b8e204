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

/// `[lo, hi]` with 4 significant digits.
fn ci(c: [f64; 2]) -> String {
    format!("[{:.4e}, {:.4e}]", c[0], c[1])
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
    let after_name = format!("with {}", dx.verdict);
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
        title: "Held-out data: measured, nominal model and the verdict's model",
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
            let params: Vec<String> = e
                .params
                .iter()
                .map(|(k, v)| match e.ci95.get(k) {
                    Some(c) => format!("{} = {v:.4e} {}", esc(k), ci(*c)),
                    None => format!("{} = {v:.4e}", esc(k)),
                })
                .collect();
            let name = if e.name == dx.verdict { format!("<b>{}</b>", e.name) } else { e.name.to_string() };
            vec![
                name,
                params.join("<br>"),
                format!("{:.4} {}", e.cl.estimate * 1e6, ci(e.cl.ci95.map(|c| c * 1e6))),
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
        "<p>Data: <code>{}</code>, {} held-out samples of {}. Nominal model: <b>{}</b> with L = {:.4e} H, RL = {:.4e} Ω, C = {:.4e} F, Rc = {:.4e} Ω, fs = {:.6e} Hz{}.</p>",
        esc(ctx.source),
        t.measured.len(),
        ctx.data.len(),
        model_name(dx.nominal),
        p.l,
        p.rl,
        p.c,
        p.rc,
        p.fs,
        if ctx.assumed.is_empty() { String::new() } else { format!(" (assumed: {})", esc(&ctx.assumed.join("; "))) },
    ));
    page.html(&format!(
        "<p><b>Verdict: {}</b>. Gap before: held-out NRMSE {:.4} (nominal fit, Cl = {:.4} µF).{}</p>",
        esc(&dx.verdict),
        dx.gap_before.nrmse,
        dx.gap_before.cl * 1e6,
        ctx.fmu.map_or(String::new(), |(path, nrmse, _)| format!(" The FMU as given (<code>{}</code>): held-out NRMSE {nrmse:.4}.", esc(path))),
    ));
    let (cl, ci95, test) = dx.final_cl();
    page.html(&format!("<p>Cl of the final model: {:.4} µF, CI95 [{:.4}, {:.4}] µF; {}.</p>", cl * 1e6, ci95[0] * 1e6, ci95[1] * 1e6, esc(&test)));
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
    page.html(&table(&["effect", "parameters [CI95]", "Cl [µF] [CI95]", "NRMSE after", "shrink [%]", "gap over the floor closed [%]", "ΔAIC", "LR / 99 %", "standing"], &rows));
    if !not_tested.is_empty() {
        page.html(&format!("<h2>Not tested</h2><ul>{not_tested}</ul>"));
    }
    page.write(dir)
}
