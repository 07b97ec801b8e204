//! The report of `identify`: held-out measured vs model, residual ACF and input CCF with
//! their 99 % bands, and the Bode plot of the fitted model against the nominal one.
use std::path::{Path, PathBuf};

use anyhow::Result;
use buck_model::Params;
use estimator::identify::Identification;
use estimator::model::frequency_response;
use estimator::validate::LAGS;

use super::{Page, table};
use crate::svg::{Plot, Series, esc};

/// Writes `index.html` and the figures into `dir` and returns the page's path.
/// `circuit`: what the reader should know of the circuit values: those assumed, those
/// estimated with Cl.
pub fn write(dir: &Path, id: &Identification, nominal: &Params, source: &str, excitation: Option<&str>, circuit: &[String]) -> Result<PathBuf> {
    let best = id.best();
    let v = &best.validation;
    let shown = v.traces.time.len().min(400);
    let t0 = v.traces.time.first().copied().unwrap_or(0.0);
    let trace = |y: &[f64]| -> Vec<(f64, f64)> { v.traces.time[..shown].iter().zip(y).map(|(t, y)| ((t - t0) * 1e3, *y)).collect() };
    let traces = Plot {
        title: "Held-out data: measured vs model",
        x_label: "time since hold-out start [ms]",
        y_label: "vout [V]",
        log_x: false,
        band: None,
        series: vec![
            Series { name: "measured", color: "#999", points: trace(&v.traces.measured), stems: false },
            Series { name: "simulated", color: "#1f77b4", points: trace(&v.traces.simulated), stems: false },
            Series { name: "1-step predicted", color: "#d62728", points: trace(&v.traces.predicted), stems: false },
        ],
    };
    let r = &v.residuals;
    let acf = Plot {
        title: "Residual autocorrelation (one-step prediction error), 99 % band",
        x_label: "lag [samples]",
        y_label: "correlation",
        log_x: false,
        band: Some(r.band99),
        series: vec![Series { name: "ACF", color: "#1f77b4", points: r.acf.iter().enumerate().map(|(i, c)| ((i + 1) as f64, *c)).collect(), stems: true }],
    };
    let ccf = Plot {
        title: "Cross-correlation residual vs duty, 99 % band",
        x_label: "lag [samples] (positive: input leads)",
        y_label: "correlation",
        log_x: false,
        band: Some(r.band99),
        series: vec![Series { name: "CCF", color: "#2ca02c", points: r.ccf.iter().enumerate().map(|(i, c)| (i as f64 - LAGS as f64, *c)).collect(), stems: true }],
    };
    let freqs: Vec<f64> = (0..200).map(|i| 100.0 * (nominal.fs / 2.0 / 100.0).powf(i as f64 / 199.0)).collect();
    let est = best.fit.estimate("Cl").map(|e| (e.value, e.ci95)).unwrap_or((f64::NAN, (f64::NAN, f64::NAN)));
    let bode_of = |cl: f64| -> Vec<(f64, f64)> {
        let p = Params { cl, ..*nominal };
        freqs.iter().zip(frequency_response(&p, 12.0, &freqs)).map(|(f, g)| (*f, 20.0 * g.norm().log10())).collect()
    };
    let nominal_name = format!("nominal Cl = {:.3} µF", nominal.cl * 1e6);
    let fitted_name = format!("fitted Cl = {:.3} µF", est.0 * 1e6);
    let bode = Plot {
        title: "Averaged model duty → vout, |G(j2πf)| (U = 12 V)",
        x_label: "frequency [Hz]",
        y_label: "magnitude [dB]",
        log_x: true,
        band: None,
        series: vec![
            Series { name: &nominal_name, color: "#999", points: bode_of(nominal.cl), stems: false },
            Series { name: &fitted_name, color: "#d62728", points: bode_of(est.0), stems: false },
            Series { name: "CI95 bounds", color: "#f4a582", points: bode_of(est.1.0), stems: false },
        ],
    };
    let rows: Vec<Vec<String>> = id
        .candidates
        .iter()
        .map(|c| {
            let e = c.fit.estimate("Cl");
            vec![
                c.structure.name().to_string(),
                format!("{:.4}", e.map_or(f64::NAN, |e| e.value * 1e6)),
                format!("[{:.4}, {:.4}]", e.map_or(f64::NAN, |e| e.ci95.0 * 1e6), e.map_or(f64::NAN, |e| e.ci95.1 * 1e6)),
                format!("{:.2}", c.validation.fit_simulation[0]),
                format!("{:.2}", c.validation.fit_prediction[0]),
                format!("{:.2}", c.seconds * 1e3),
            ]
        })
        .collect();
    let mut page = Page::new("buckid identify", "Load capacitance identification");
    page.html(&format!(
        "<p>Source: <code>{}</code>.{} {} estimation samples, {} held-out samples. Chosen model: <b>{}</b> (best held-out one-step prediction).
Residuals {} white (Ljung–Box {:.1} vs {:.1} at 99 %), {} of the input ({:.1} vs {:.1}).</p>",
        esc(source),
        excitation.map_or(String::new(), |e| format!(" Excitation: {}.", esc(e))),
        id.estimation_samples,
        id.validation_samples,
        best.structure.name(),
        if r.white() { "are" } else { "are NOT" },
        r.ljung_box,
        r.ljung_box_limit,
        if r.independent_of_input() { "independent" } else { "NOT independent" },
        r.ccf_statistic,
        r.ccf_limit,
    ));
    page.html(&table(&["model", "Cl [µF]", "95 % CI [µF]", "sim fit [%]", "pred fit [%]", "fit time [ms]"], &rows));
    if !circuit.is_empty() {
        let items: String = circuit.iter().map(|c| format!("<li>{}</li>", esc(c))).collect();
        page.html(&format!("<h2>Circuit values</h2><ul>{items}</ul>"));
    }
    page.figure("heldout", traces.render());
    page.figure("acf", acf.render());
    page.figure("ccf", ccf.render());
    page.figure("bode", bode.render());
    page.write(dir)
}
