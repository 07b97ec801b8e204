//! The report of `identify`: the held-out traces with the residual against the noise floor
//! below them, the residual ACF and input CCF with their 99 % bands, and the Bode plot of the
//! fitted model (with its CI95 as a band) against the nominal one.
use std::path::{Path, PathBuf};

use anyhow::Result;
use buck_model::Params;
use estimator::identify::Identification;
use estimator::model::frequency_response;
use estimator::validate::LAGS;

use super::plot::{Axis, BLUE, Band, Chart, FLOOR, GREY, Line, Mark, Panel, RED};
use super::{Page, esc, table};
use crate::units::{si, si_text, with_ci};

/// Most held-out samples drawn.
const MAX_TRACE: usize = 2000;

/// What the page says besides the identification.
pub struct Context<'a> {
    /// The FMU or data file.
    pub source: &'a str,
    /// How the plant was excited, for an FMU run.
    pub excitation: Option<&'a str>,
    /// What the reader should know of the circuit values: those assumed, those estimated with Cl.
    pub circuit: &'a [String],
    /// White sensor noise on `vout` from the data alone (`gap::noise_floor`) \[V\], if found.
    pub noise_floor: Option<f64>,
    /// Cl's tested interval, for data from a file (`gap::tested_cl`).
    pub cl_test: Option<&'a gap::TestedCl>,
}

/// Writes `index.html` and the figures into `dir` and returns the page's path.
pub fn write(dir: &Path, id: &Identification, nominal: &Params, ctx: &Context<'_>) -> Result<PathBuf> {
    let best = id.best();
    let v = &best.validation;
    let tr = &v.traces;
    let shown = tr.time.len().min(MAX_TRACE);
    let t0 = tr.time.first().copied().unwrap_or(0.0);
    let time: Vec<f64> = tr.time[..shown].iter().map(|t| t - t0).collect();
    let line = |name: &str, color, mark, y: Vec<f64>| Line { name: name.to_string(), color, mark, points: time.iter().copied().zip(y).collect() };
    let diff = |a: &[f64], b: &[f64]| -> Vec<f64> { a.iter().zip(b).map(|(a, b)| a - b).collect() };
    // The floor from the data alone; else the fit's own residual σ.
    let (floor, floor_name) = match ctx.noise_floor {
        Some(f) => (f, format!("±noise floor ({} RMS, from the data)", si(f, "V", 3))),
        None => (best.fit.sigma.first().copied().unwrap_or(f64::NAN), "±residual σ of the fit".to_string()),
    };
    let span = (0.0, time.last().copied().unwrap_or(1.0));
    let mut residuals = vec![line("measured − simulated", BLUE, Mark::Solid, diff(&tr.measured[..shown], &tr.simulated[..shown]))];
    // Under the output-error predictor both residuals are the same; with a Kalman predictor not.
    if tr.predicted.iter().zip(&tr.simulated).any(|(p, s)| (p - s).abs() > 1e-9 * s.abs().max(1.0)) {
        residuals.push(line("measured − 1-step predicted", RED, Mark::Solid, diff(&tr.measured[..shown], &tr.predicted[..shown])));
    }
    let heldout = Chart {
        title: "Held-out data: the model's output and its residual against the noise floor",
        x: Axis::linear("time since hold-out start", "s"),
        panels: vec![
            Panel {
                caption: "vout: measured and simulated".into(),
                y: Axis::linear("vout", "V"),
                bands: Vec::new(),
                lines: vec![line("measured", GREY, Mark::Solid, tr.measured[..shown].to_vec()), line("simulated", BLUE, Mark::Solid, tr.simulated[..shown].to_vec())],
                height: 150,
            },
            Panel { caption: "residual".into(), y: Axis::linear("residual", "V"), bands: vec![Band::symmetric(floor_name, FLOOR, floor, span)], lines: residuals, height: 150 },
        ],
    };
    let r = &v.residuals;
    let correlation = |title, caption: &str, color, points: Vec<(f64, f64)>| {
        let span = (points.first().map_or(0.0, |p| p.0), points.last().map_or(1.0, |p| p.0));
        Chart {
            title,
            x: Axis::linear(if caption == "ACF" { "lag" } else { "lag (positive: the input leads)" }, "samples"),
            panels: vec![Panel {
                caption: String::new(),
                y: Axis::linear("correlation", ""),
                bands: vec![Band::symmetric("99 % band of white noise".into(), FLOOR, r.band99, span)],
                lines: vec![Line { name: caption.to_string(), color, mark: Mark::Stems, points }],
                height: 170,
            }],
        }
    };
    let acf = correlation("Residual autocorrelation (one-step prediction error)", "ACF", BLUE, r.acf.iter().enumerate().map(|(i, c)| ((i + 1) as f64, *c)).collect());
    let ccf = correlation("Cross-correlation of the residual with the duty", "CCF", super::plot::GREEN, r.ccf.iter().enumerate().map(|(i, c)| (i as f64 - LAGS as f64, *c)).collect());

    let freqs: Vec<f64> = (0..200).map(|i| 100.0 * (nominal.fs / 2.0 / 100.0).powf(i as f64 / 199.0)).collect();
    let (cl_value, ci) = match ctx.cl_test {
        Some(t) => (t.cl.estimate, t.cl.ci95),
        None => best.fit.estimate("Cl").map_or((f64::NAN, [f64::NAN; 2]), |e| (e.value, [e.ci95.0, e.ci95.1])),
    };
    let bode_of = |cl: f64| -> Vec<(f64, f64)> {
        let p = Params { cl, ..*nominal };
        freqs.iter().zip(frequency_response(&p, 12.0, &freqs)).map(|(f, g)| (*f, 20.0 * g.norm().log10())).collect()
    };
    let bode = Chart {
        title: "Averaged model duty → vout, |G(j2πf)| at U = 12 V",
        x: Axis { label: "frequency", unit: "Hz", log: true },
        panels: vec![Panel {
            caption: String::new(),
            y: Axis::linear("magnitude", "dB"),
            bands: if estimator::validate::identified(ci) { vec![Band { name: "CI95 of the fitted Cl".into(), color: RED, lower: bode_of(ci[0]), upper: bode_of(ci[1]) }] } else { Vec::new() },
            lines: vec![
                Line { name: format!("nominal Cl = {}", si(nominal.cl, "F", 3)), color: GREY, mark: Mark::Dashed, points: bode_of(nominal.cl) },
                Line { name: format!("fitted Cl = {}", with_ci(cl_value, Some(ci), "F")), color: RED, mark: Mark::Solid, points: bode_of(cl_value) },
            ],
            height: 230,
        }],
    };

    let rows: Vec<Vec<String>> = id
        .candidates
        .iter()
        .map(|c| {
            let e = c.fit.estimate("Cl");
            let name = if std::ptr::eq(c, best) { format!("<b>{}</b>", c.structure.name()) } else { c.structure.name().to_string() };
            vec![
                name,
                esc(&e.map_or_else(|| "–".to_string(), |e| with_ci(e.value, Some([e.ci95.0, e.ci95.1]), "F"))),
                si(c.validation.fit_simulation[0], "%", 4),
                si(c.validation.fit_prediction[0], "%", 4),
                si(c.seconds, "s", 3),
            ]
        })
        .collect();
    let mut page = Page::new("buckid identify", "Load capacitance identification");
    page.html(&format!("<p class=\"result\"><b>Cl = {}</b> ({} model).</p>", esc(&with_ci(cl_value, Some(ci), "F")), best.structure.name()));
    if let Some(t) = ctx.cl_test {
        page.html(&format!("<p>The interval, tested on a circuit's data: {}.</p>", esc(&si_text(&t.sentence()))));
    }
    page.html(&format!(
        "<p>Source: <code>{}</code>.{} {} estimation and {} held-out samples. Chosen model: <b>{}</b> (best held-out one-step prediction).
Residuals {} white (Ljung–Box {} vs {} at 99 %), {} of the input ({} vs {}).</p>",
        esc(ctx.source),
        ctx.excitation.map_or(String::new(), |e| format!(" Excitation: {}.", esc(&si_text(e)))),
        id.estimation_samples,
        id.validation_samples,
        best.structure.name(),
        if r.white() { "are" } else { "are NOT" },
        si(r.ljung_box, "", 3),
        si(r.ljung_box_limit, "", 3),
        if r.independent_of_input() { "independent" } else { "NOT independent" },
        si(r.ccf_statistic, "", 3),
        si(r.ccf_limit, "", 3),
    ));
    page.html(&table(&["model", "Cl (the fit's own CI95)", "held-out fit, simulation", "held-out fit, 1-step prediction", "fit time"], &rows));
    if !ctx.circuit.is_empty() {
        let items: String = ctx.circuit.iter().map(|c| format!("<li>{}</li>", esc(&si_text(c)))).collect();
        page.html(&format!("<h2>Circuit values</h2><ul>{items}</ul>"));
    }
    page.figure("heldout", heldout.render()?);
    page.figure("acf", acf.render()?);
    page.figure("ccf", ccf.render()?);
    page.figure("bode", bode.render()?);
    page.write(dir)
}
