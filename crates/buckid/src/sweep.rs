//! `buckid diagnose --sweep FILE`: which DC effects explain the gap between a measured
//! steady-state sweep and the nominal DC model (the `dc-sweep` crate does the work).
use anyhow::{Context, Result};
use dc_sweep::{Circuit, Diagnosis, Options, Sweep, diagnose};

use crate::DiagnoseArgs;
use crate::report::plot::{Axis, BLACK, Chart, GREY, Line, Mark, Panel, RED};
use crate::report::{Page, esc, table};
use crate::units::si;

/// Fallback circuit of a sweep: the thesis L and fs, but RL = 0 (an unknown series resistance
/// should show up as an effect, not hide in an assumed nominal).
fn fallback() -> Circuit {
    Circuit { rl: 0.0, ..Circuit::default() }
}

/// A DC effect's parameter with its SI prefix and unit.
fn fmt_param(name: &str, v: f64) -> String {
    let unit = match name {
        "vf" => "V",
        "r_series" => "Ω",
        "td" => "s",
        "l" => "H",
        _ => "",
    };
    si(v, unit, 4)
}

fn fmt_ci(name: &str, ci: [f64; 2]) -> String {
    format!("[{}, {}]", fmt_param(name, ci[0]), fmt_param(name, ci[1]))
}

/// Runs `diagnose --sweep`.
pub fn run(args: &DiagnoseArgs) -> Result<()> {
    let path = args.sweep.as_ref().context("--sweep FILE is required")?;
    eprintln!("reading {}", path.display());
    let sweep = Sweep::read_csv(path)?;
    let (circuit, assumed) = sweep.circuit(&fallback())?;
    for a in &assumed {
        eprintln!("assuming {a}");
    }
    let d = diagnose(&sweep, &circuit, &Options::default())?;
    print_summary(&d, sweep.len());
    if let Some(out) = &args.json {
        let mut v = serde_json::to_value(&d)?;
        if let Some(obj) = v.as_object_mut() {
            obj.insert("sweep".into(), serde_json::json!(path.display().to_string()));
            obj.insert("circuit".into(), serde_json::json!({"L": circuit.l, "RL": circuit.rl, "fs": circuit.fs, "rds_on": circuit.rds_on, "vbd": circuit.body_diode_drop}));
            obj.insert("assumed".into(), serde_json::json!(assumed));
        }
        std::fs::write(out, serde_json::to_string_pretty(&v)?).with_context(|| format!("writing {}", out.display()))?;
        eprintln!("wrote {}", out.display());
    }
    if let Some(dir) = &args.report {
        let index = report(&d, &path.display().to_string(), &assumed)?.write(dir)?;
        eprintln!("wrote {}", index.display());
    }
    Ok(())
}

fn print_summary(d: &Diagnosis, n: usize) {
    println!("sweep       {n} operating points ({} distinct)", d.distinct_points);
    println!("gap before  {:.1} mV RMS (nominal DC model: ideal buck with RL)", d.gap_before.rms * 1e3);
    if let Some(m) = &d.message {
        println!("answer      none: {m}");
        return;
    }
    for (i, s) in d.selected.iter().enumerate() {
        println!(
            "step {}      + {:<18} residual {:.1} mV RMS, closes {:.1} % of the nominal gap (p = {:.1e})",
            i + 1,
            s.name,
            s.rms_after.unwrap_or(f64::NAN) * 1e3,
            s.closed_percent.unwrap_or(f64::NAN),
            s.p_value.unwrap_or(f64::NAN)
        );
    }
    if let Some(f) = &d.final_fit {
        for (effect, params) in &f.params {
            for (name, v) in params {
                let ci = f.ci95.get(effect).and_then(|c| c.get(name)).map(|c| fmt_ci(name, *c)).unwrap_or_default();
                println!("            {effect}.{name} = {}  95 % CI {ci}", fmt_param(name, *v));
            }
        }
        println!("gap after   {:.1} mV RMS", f.gap.rms * 1e3);
    }
    for e in &d.effects {
        if let Some(note) = &e.note {
            println!("note        {}: {note}", e.name);
        }
    }
    println!("verdict     {}", d.verdict);
}

fn report(d: &Diagnosis, source: &str, assumed: &[String]) -> Result<Page> {
    let mut page = Page::new("buckid sweep diagnosis", "Steady-state sweep: which DC effects explain the gap");
    page.html(&format!("<p>Sweep <code>{}</code>; verdict <b>{}</b>.</p>", esc(source), esc(&d.verdict)));
    if !assumed.is_empty() {
        page.html(&format!("<p>Assumed (not in the file): {}.</p>", esc(&assumed.join("; "))));
    }
    if let Some(m) = &d.message {
        page.html(&format!("<p><b>{}</b></p>", esc(m)));
    }
    let mut pts: Vec<_> = d.location.by_operating_point.iter().collect();
    pts.sort_by(|a, b| a.duty.total_cmp(&b.duty));
    let series = |f: fn(&dc_sweep::diagnose::PointGap) -> f64| pts.iter().map(|p| (p.duty, f(p))).collect::<Vec<_>>();
    let line = |name: &str, color, mark, f: fn(&dc_sweep::diagnose::PointGap) -> f64| Line { name: name.to_string(), color, mark, points: series(f) };
    let chart = |title, y: Axis<'static>, lines| Chart { title, x: Axis::linear("duty", ""), panels: vec![Panel { caption: String::new(), y, bands: Vec::new(), lines, height: 220 }] };
    let plot = chart(
        "Mean output voltage against duty",
        Axis::linear("vout", "V"),
        vec![line("measured", BLACK, Mark::Dots, |p| p.measured), line("nominal", GREY, Mark::Dashed, |p| p.expected), line("with the selected effects", RED, Mark::Solid, |p| p.fitted)],
    );
    page.figure("vout_vs_duty", plot.render()?);
    let resid = chart(
        "Residual against duty",
        Axis::linear("measured − model", "V"),
        vec![line("nominal", GREY, Mark::Dots, |p| p.residual), line("with the selected effects", RED, Mark::Dots, |p| p.residual_after)],
    );
    page.figure("residual_vs_duty", resid.render()?);
    let rows: Vec<Vec<String>> = d
        .effects
        .iter()
        .map(|e| {
            vec![
                esc(e.name),
                e.params.as_ref().map_or("—".into(), |p| p.iter().map(|(k, v)| format!("{k} = {}", fmt_param(k, *v))).collect::<Vec<_>>().join(", ")),
                e.rms_after.map_or("—".into(), |r| si(r, "V", 3)),
                e.closed_percent.map_or("—".into(), |c| si(c, "%", 3)),
                format!("{}", e.significant && e.identifiable),
                esc(e.note.as_deref().unwrap_or("")),
            ]
        })
        .collect();
    page.html("<h2>Each effect alone</h2>");
    page.html(&table(&["effect", "params", "RMS after", "closed", "significant & identified", "note"], &rows));
    let steps: Vec<Vec<String>> = d.selected.iter().map(|s| vec![esc(s.name), s.rms_after.map_or("—".into(), |r| si(r, "V", 3)), s.p_value.map_or("—".into(), p_value)]).collect();
    page.html("<h2>Forward selection</h2>");
    page.html(&table(&["added", "RMS after", "p (F test)"], &steps));
    Ok(page)
}

/// A p-value as people read it: `< 0.0001` below that, else two significant digits.
fn p_value(p: f64) -> String {
    if p < 1e-4 { "&lt; 0.0001".to_string() } else { si(p, "", 2) }
}
