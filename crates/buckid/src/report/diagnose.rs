//! The report of `diagnose`: the effect's signature (the held-out residual of the nominal and
//! of the final model against the ±noise-floor band), the forward selection as a waterfall of
//! the gap closed, the gap by frequency band, operating point and time window (each against the
//! floor), the table of effects and the effects not tested.
use std::path::{Path, PathBuf};

use anyhow::Result;
use buck_model::Params;
use estimator::data::DataSet;
use gap::{Diagnosis, Group, Nominal};

use super::plot::{Axis, BLUE, Band, Bar, Bars, Chart, FLOOR, GREEN, GREY, Line, Mark, ORANGE, Panel, RED};
use super::{Page, esc, table};
use crate::diagnose::{alike_text, effect_params};
use crate::units::{si, si_text, with_ci};

/// Most held-out samples drawn.
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

/// A `[%]` share ([`share_text`]), or `–` when there is none.
fn percent(v: Option<f64>) -> String {
    v.map_or_else(|| "–".to_string(), share_text)
}

fn group_bars<'a>(title: &'a str, groups: &[Group]) -> Bars<'a> {
    Bars {
        title,
        value: Axis::linear("residual RMS / noise-floor RMS", ""),
        bars: groups.iter().map(|g| Bar::value(format!("{} ({} samples)", si_text(&g.label), g.samples), g.rms_over_floor, "", ORANGE)).collect(),
        reference: Some((1.0, "noise floor".into())),
        connect: false,
    }
}

/// One step of the forward selection, as the waterfall needs it.
pub struct Step<'a> {
    /// The effect added.
    pub name: &'a str,
    /// Share of the nominal's gap above the floor closed once it is added [%].
    pub closed_percent: f64,
    /// Held-out residual RMS with it \[V\].
    pub rms_after: f64,
    /// Share of il's gap above its floor it closed, where it is judged in il (a late reading,
    /// il's filter) [%].
    pub il_closed_percent: Option<f64>,
}

/// The least share [%] the report shows as other than nothing: half its last digit.
const LEAST_SHOWN: f64 = 0.05;

/// A share [%] to a tenth of a percent (a step that closes nothing of vout's gap, as one judged
/// in il, reads 0.0 %, not "−0.000362 %").
fn share_text(v: f64) -> String {
    format!("{:.1} %", if v.abs() < LEAST_SHOWN { 0.0 } else { v })
}

/// The forward selection as a waterfall of the nominal's gap above the noise floor: the gap
/// (100 %), one bar per selected effect for what it closed, and what is left.
pub fn waterfall<'a>(gap_rms: f64, steps: &[Step<'_>]) -> Bars<'a> {
    let mut bars = vec![Bar { label: format!("nominal model, residual {} RMS", si(gap_rms, "V", 3)), from: 0.0, to: 100.0, color: ORANGE, text: si(100.0, "%", 3) }];
    let mut level = 100.0;
    for s in steps {
        let next = 100.0 - s.closed_percent;
        let closed = level - next;
        // Red where it made the gap wider by what the text shows.
        let color = if closed > -LEAST_SHOWN { GREEN } else { RED };
        let in_il = s.il_closed_percent.map_or(String::new(), |c| format!("; il's gap {} closed", share_text(c)));
        bars.push(Bar { label: format!("+ {} → {}", s.name, si(s.rms_after, "V", 3)), from: next, to: level, color, text: format!("{} closed{in_il}", share_text(closed)) });
        level = next;
    }
    bars.push(Bar { label: "left above the floor".into(), from: 0.0, to: level, color: GREY, text: share_text(level) });
    Bars { title: "The gap above the noise floor, closed effect by effect", value: Axis::linear("share of the nominal's gap above the floor (power)", "%"), bars, reference: None, connect: true }
}

/// Writes `index.html` and the figures into `dir` and returns the page's path.
pub fn write(dir: &Path, dx: &Diagnosis, ctx: &Context<'_>) -> Result<PathBuf> {
    let w = &dx.location;
    let bands = Bars {
        title: "Gap by frequency band: residual PSD over the noise floor's",
        value: Axis::linear("residual PSD over the noise floor's", "dB"),
        bars: w.bands.iter().map(|b| Bar::value(format!("{} – {}", si(b.from_hz, "Hz", 3), si(b.to_hz, "Hz", 3)), b.db_over_floor, "dB", BLUE)).collect(),
        reference: Some((0.0, "noise floor".into())),
        connect: false,
    };
    let points = group_bars("Gap by operating point", &w.operating_points);
    let windows = group_bars("Gap by time window of the held-out part", &w.windows);

    let t = &dx.traces;
    let shown = t.measured.len().min(MAX_TRACE);
    let time = &ctx.data.time[t.start.min(ctx.data.len())..];
    let t0 = time.first().copied().unwrap_or(0.0);
    let x: Vec<f64> = time.iter().take(shown).map(|t| t - t0).collect();
    let line = |name: &str, color, y: &[f64]| Line { name: name.to_string(), color, mark: Mark::Solid, points: x.iter().copied().zip(y.iter().copied()).collect() };
    let residual = |y: &[f64]| -> Vec<f64> { t.measured.iter().zip(y).take(shown).map(|(m, y)| m - y).collect() };
    let labels: Vec<String> = dx.selected.iter().map(|e| e.label()).collect();
    let nominal_name = format!("nominal {} model", model_name(dx.nominal));
    // A legend holds three names; more read as the final model.
    let final_name = if labels.len() <= 3 { format!("with {}", labels.join(" + ")) } else { format!("the final model ({} effects)", labels.len()) };
    let floor = w.noise_floor_rms;
    let band = || Band::symmetric(format!("±noise floor ({} RMS)", si(floor, "V", 3)), FLOOR, floor, (0.0, x.last().copied().unwrap_or(1.0)));
    let mut models: Vec<(&str, &[f64], _)> = vec![(nominal_name.as_str(), t.nominal.as_slice(), BLUE)];
    if let Some(after) = &t.after {
        models.push((final_name.as_str(), after.as_slice(), RED));
    }
    if let Some((_, _, sim)) = ctx.fmu {
        models.push(("FMU as given", sim, GREEN));
    }
    let mut panels = vec![Panel {
        caption: "vout: measured and simulated".into(),
        y: Axis::linear("vout", "V"),
        bands: Vec::new(),
        lines: std::iter::once(line("measured", GREY, &t.measured[..shown])).chain(models.iter().map(|(name, y, color)| line(name, *color, y))).collect(),
        height: 130,
    }];
    for (name, y, color) in &models {
        panels.push(Panel {
            caption: format!("measured − {name}: {} RMS, {}× the floor", si(rms(&residual(y)), "V", 3), si(rms(&residual(y)) / floor, "", 3)),
            y: Axis::linear("residual", "V"),
            bands: vec![band()],
            lines: vec![line("", *color, &residual(y))],
            height: 110,
        });
    }
    let signature = Chart { title: "Held-out residual against the noise floor: the effect's signature", x: Axis::linear("time since hold-out start", "s"), panels };

    let steps: Option<Vec<Step<'_>>> =
        dx.selected.iter().zip(&labels).map(|(e, label)| Some(Step { name: label, closed_percent: e.closed_percent?, rms_after: e.rms_after, il_closed_percent: e.il_closed_percent })).collect();

    let rows: Vec<Vec<String>> = dx
        .effects
        .iter()
        .map(|e| {
            let name = if e.name == dx.verdict { format!("<b>{}</b>", e.name) } else { e.name.to_string() };
            vec![
                name,
                params_html(e),
                esc(&with_ci(e.cl.estimate, Some(e.cl.ci95), "F")),
                si(e.nrmse_after, "", 3),
                si(e.shrink_percent, "%", 3),
                percent(e.closed_percent),
                si(e.delta_aic, "", 3),
                match (e.lr_statistic, e.lr_limit) {
                    (Some(s), Some(l)) => format!("{} / {}", si(s, "", 3), si(l, "", 3)),
                    (Some(s), None) => si(s, "", 3),
                    _ => "–".to_string(),
                },
                e.standing().to_string(),
            ]
        })
        .collect();
    let not_tested: String = dx.not_tested.iter().map(|n| format!("<li><code>{}</code>: {}</li>", n.name, esc(&si_text(&n.reason)))).collect();
    let p = ctx.nominal;

    let mut page = Page::new("buckid diagnose", "Sim-to-real gap diagnosis");
    let (cl, ci95, test) = dx.final_cl();
    page.html(&format!(
        "<p class=\"result\"><b>Verdict: {}</b>{}. Cl of the final model: <b>{}</b>; {}.</p>",
        esc(&dx.verdict_text()),
        if dx.selected.len() > 1 { format!(" (selected in turn: {})", labels.join(", ")) } else { String::new() },
        esc(&with_ci(cl, Some(ci95), "F")),
        esc(&si_text(&test)),
    ));
    if let Some(leverage) = dx.leverage() {
        page.html(&format!("<p>Leverage: {}.</p>", esc(&leverage)));
    }
    page.html(&format!(
        "<p>Data: <code>{}</code>, {} held-out samples of {}. Nominal model: <b>{}</b> with L = {}, RL = {}, C = {}, Rc = {}, fs = {}{}{}. \
Gap before: held-out NRMSE {}, residual {} RMS over a noise floor of {} RMS ({}; nominal fit Cl = {}).{}</p>",
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
        if ctx.assumed.is_empty() { String::new() } else { format!(" (assumed: {})", esc(&si_text(&ctx.assumed.join("; ")))) },
        si(dx.gap_before.nrmse, "", 3),
        si(dx.gap_before.rms, "V", 3),
        si(floor, "V", 3),
        esc(w.noise_floor_from.describe()),
        si(dx.gap_before.cl, "F", 4) + &dx.gap_before.cl_not_identified().map_or(String::new(), |why| format!(", {}", esc(&why))),
        ctx.fmu.map_or(String::new(), |(path, nrmse, _)| format!(" The FMU as given (<code>{}</code>): held-out NRMSE {}.", esc(path), si(nrmse, "", 3))),
    ));
    for input in &dx.measured_inputs {
        page.html(&format!("<p>Input: {}.</p>", esc(&input.sentence(&si(input.noise, input.unit(), 3)))));
    }
    page.figure("signature", signature.render()?);
    page.html("<h2>Effects selected, in order</h2>");
    if dx.selected.is_empty() {
        page.html(&format!("<p>None: {}.</p>", esc(&si_text(&dx.selection_ended))));
    } else {
        match &steps {
            Some(steps) => page.figure("waterfall", waterfall(dx.gap_before.rms, steps).render()?),
            None if dx.location.noise_floor_from == gap::FloorSource::ModelResidual => {
                page.html("<p>No waterfall: the noise floor is a model's residual (the inputs step too often for a model-free one), so there is no gap to take shares of.</p>")
            }
            None => page.html("<p>No waterfall: the nominal's gap is within the noise floor, so there is no share to close.</p>"),
        }
        let rows: Vec<Vec<String>> = dx
            .selected
            .iter()
            .zip(&labels)
            .enumerate()
            .map(|(i, (e, label))| vec![format!("{}", i + 1), format!("<b>{}</b>", esc(label)), params_html(e), percent(e.closed_percent), percent(e.closed_of_remaining), si(e.rms_after, "V", 3)])
            .collect();
        page.html(&table(&["step", "effect", "parameters at the final fit (CI95)", "gap over the floor closed", "of what was left", "held-out residual RMS"], &rows));
        page.html(&format!("<p>The sequence ended: {}.</p>", esc(&si_text(&dx.selection_ended))));
        if let Some(regime) = dx.regime() {
            page.html(&format!("<p>Regime: {}.</p>", esc(&regime)));
        }
    }
    page.html("<h2>Where the nominal model misses</h2>");
    page.html(&format!("<p>{}.</p>", esc(&si_text(&w.summary))));
    page.figure("gap_bands", bands.render()?);
    page.figure("gap_operating_points", points.render()?);
    page.figure("gap_windows", windows.render()?);
    page.html("<h2>Effects, best held-out error first</h2>");
    page.html(&table(&["effect", "parameters (CI95)", "Cl (CI95)", "NRMSE after", "shrink", "gap over the floor closed", "ΔAIC", "LR / 99 %", "standing"], &rows));
    if !not_tested.is_empty() {
        page.html(&format!("<h2>Not tested</h2><ul>{not_tested}</ul>"));
    }
    page.write(dir)
}

/// An effect's parameters as the CLI prints them, one per line, and what explains its step alike.
fn params_html(e: &gap::EffectFit) -> String {
    let alike = alike_text(e).map(|a| format!("<br><i>{}</i>", esc(&a))).unwrap_or_default();
    effect_params(e).iter().map(|p| esc(p)).collect::<Vec<_>>().join("<br>") + &alike
}

/// Root mean square of `x`.
fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_waterfall_has_the_gap_one_bar_per_selected_effect_and_what_is_left() {
        let step = |name, closed_percent, rms_after, il_closed_percent| Step { name, closed_percent, rms_after, il_closed_percent };
        let steps = [step("diode_drop", 80.0, 3e-3, None), step("dead_time", 95.0, 2.1e-3, None), step("sensor_filter (il)", 94.9996, 2.1e-3, Some(99.94))];
        let w = waterfall(9e-3, &steps);
        let spans: Vec<(f64, f64)> = w.bars.iter().map(|b| (b.from, b.to)).collect();
        assert_eq!(spans[..3], [(0.0, 100.0), (20.0, 100.0), (5.0, 20.0)]);
        assert_eq!(spans.len(), 5, "the gap, three steps, what is left");
        assert_eq!(w.bars[2].text, "15.0 % closed");
        // A step judged in il closes nothing of vout's gap, and says what it closes of il's.
        assert_eq!(w.bars[3].text, "0.0 % closed; il's gap 99.9 % closed");
        // What is left reads as the steps do, to a tenth of a percent (5.0004 %, not "5.00 %").
        assert_eq!(w.bars[4].text, "5.0 %");
        let svg = w.render().unwrap();
        assert_eq!(svg.matches(r##"fill="#2CA02C""##).count(), 3, "one green bar per selected effect");
        assert!(svg.contains("+ dead_time → 2.10 mV") && svg.contains("nominal model, residual 9.00 mV RMS"));
    }

    /// The tables' shares read as the waterfall's: a tenth of a percent, nothing closed as 0.0 %
    /// (a step judged in il closes −0.0159 % of vout's gap), none as `–`.
    #[test]
    fn shares_are_given_to_a_tenth_of_a_percent() {
        assert_eq!([Some(97.73), Some(-0.0159), Some(-12.36), None].map(percent), ["97.7 %", "0.0 %", "-12.4 %", "–"]);
    }
}
