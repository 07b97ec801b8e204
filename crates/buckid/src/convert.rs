//! `buckid convert --scope FILE [--fs HZ] --out FILE`: an oscilloscope capture reduced to the
//! data contract, one row per switching period (the `capture` crate does the work).
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

/// Arguments of `buckid convert`.
#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// Oscilloscope capture (CSV: `time`, `vout`; optional `il`, `sw`, `gate`, `vin`).
    #[arg(long)]
    scope: PathBuf,
    /// Switching frequency [Hz], used when the capture has no switch-node or gate edges.
    #[arg(long)]
    fs: Option<f64>,
    /// The capture's own name of a column (repeatable), for an oscilloscope's export:
    /// `vout=CH1`, `il=CH2`, `sw=CH3`, `time=TIME` (a unit in the header is kept: `CH1 [mV]`),
    /// `il=CH2*10` for a current read in volts (here across a 0.1 Ω shunt: 10 A per volt; the
    /// values as written times the scale, the header's unit set aside).
    /// The scope's preamble before its header row, and a row of units after it, are skipped;
    /// a Rigol's numbered samples (`time=X`) are timed by the `Start` and `Increment` there.
    #[arg(long = "column", value_name = "NAME=HEADER[*SCALE]", value_parser = column_name)]
    columns: Vec<(String, String, Option<f64>)>,
    /// Where to write the data-contract CSV.
    #[arg(long)]
    out: PathBuf,
}

/// Runs the command.
pub fn run(args: &ConvertArgs) -> Result<()> {
    eprintln!("reading {}", args.scope.display());
    let text = std::fs::read_to_string(&args.scope).with_context(|| format!("reading {}", args.scope.display()))?;
    let map: Vec<capture::Named> = args.columns.iter().map(|(column, header, scale)| capture::Named { column, header, scale: *scale }).collect();
    let cap = capture::Capture::parse_csv_with(&text, &map).with_context(|| format!("{}", args.scope.display()))?;
    let periods = capture::reduce(&cap, args.fs)?;
    let mut meta = cap.meta.clone();
    if cap.vin.is_none() && !meta.contains_key("U") {
        eprintln!("note: no `vin` column and no `# U` metadata: the data file will need one before `identify`/`diagnose`");
    }
    meta.remove("periods_from");
    std::fs::write(&args.out, capture::to_csv(&periods, &meta)).with_context(|| format!("writing {}", args.out.display()))?;
    println!("periods     {} complete, fs {:.6} kHz measured ({})", periods.time.len(), periods.fs / 1e3, periods.source);
    println!("duty        {:.4} … {:.4}", periods.duty.iter().copied().fold(f64::INFINITY, f64::min), periods.duty.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    eprintln!("wrote {}", args.out.display());
    Ok(())
}

/// `NAME=HEADER[*SCALE]` of `--column`.
fn column_name(s: &str) -> Result<(String, String, Option<f64>), String> {
    let usage = || format!("`{s}` is not NAME=HEADER or NAME=HEADER*SCALE (e.g. vout=CH1, il=CH2*10)");
    let (name, header) = s.split_once('=').ok_or_else(usage)?;
    let (header, scale) = match header.rsplit_once('*') {
        Some((h, k)) => (h, Some(k.trim().parse::<f64>().map_err(|_| usage())?)),
        None => (header, None),
    };
    if name.trim().is_empty() || header.trim().is_empty() {
        return Err(usage());
    }
    Ok((name.trim().to_string(), header.trim().to_string(), scale))
}
