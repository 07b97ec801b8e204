//! Simulates the converter one switching period per line read from stdin (the duty in open
//! loop, the duty dither with `control=2`) and prints
//! `time,duty,vout,il,vc,vout_avg,il_avg,duty_applied,vout_adc` at each period end; the wall
//! time of the simulation alone goes to stderr. Used by the cross-tool tests and the speed
//! benchmark.
//!
//! `cargo run --release -p buck-model --example trajectory -- [switched|averaged] [Cl] [io] [NAME=VALUE ...]`
//! where NAME is any variable of the table (e.g. `control=2 delay=1 adc_noise=2e-3`).
use std::io::{BufRead, Write};
use std::time::Instant;

use buck_model::variables::{self, VarId};
use buck_model::{Converter, Mode, Params};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mode = match args.first().map(String::as_str) {
        Some("averaged") => Mode::Averaged,
        _ => Mode::Switched,
    };
    let cl: f64 = args.get(1).map_or(Ok(10e-6), |s| s.parse())?;
    let io: f64 = args.get(2).map_or(Ok(1.0), |s| s.parse())?;
    let settings: Vec<(VarId, f64)> = args
        .iter()
        .skip(3)
        .map(|a| {
            let (name, value) = a.split_once('=').ok_or_else(|| format!("expected NAME=VALUE, got {a}"))?;
            let var = variables::by_name(name).ok_or_else(|| format!("no variable {name}"))?;
            Ok((var.id, value.parse::<f64>()?))
        })
        .collect::<Result<_, Box<dyn std::error::Error>>>()?;
    let duties: Vec<f64> = std::io::stdin().lock().lines().map(|l| Ok(l?.trim().parse()?)).collect::<Result<_, Box<dyn std::error::Error>>>()?;

    let params = Params { cl, ..Params::default() };
    let mut conv = Converter::new(params, mode);
    conv.set(VarId::Io, io)?;
    for (id, value) in &settings {
        conv.set(*id, *value)?;
    }
    let input = if conv.get_real(VarId::Control) == 2.0 { VarId::Dither } else { VarId::Duty };
    conv.set(input, duties.first().copied().unwrap_or(0.5))?;
    conv.initialize();
    let mut rows = Vec::with_capacity(duties.len());
    let start = Instant::now();
    for &d in &duties {
        conv.set(input, d)?;
        conv.step(params.period())?;
        rows.push((conv.time(), d, conv.outputs()));
    }
    let elapsed = start.elapsed();
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    writeln!(out, "time,duty,vout,il,vc,vout_avg,il_avg,duty_applied,vout_adc")?;
    for (t, d, y) in rows {
        writeln!(out, "{t:e},{d},{:e},{:e},{:e},{:e},{:e},{:e},{:e}", y.vout, y.il, y.vc, y.vout_avg, y.il_avg, y.duty_applied, y.vout_adc)?;
    }
    eprintln!("simulated {} periods in {:.3} ms", duties.len(), elapsed.as_secs_f64() * 1e3);
    Ok(())
}
