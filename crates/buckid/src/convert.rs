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
    /// `vout=CH1`, `il=CH2`, `sw=CH3`, `time=TIME` (a unit in the header is kept: `CH1 [mV]`).
    /// The scope's preamble before its header row, and a row of units after it, are skipped.
    #[arg(long = "column", value_name = "NAME=HEADER", value_parser = column_pair)]
    columns: Vec<(String, String)>,
    /// Where to write the data-contract CSV.
    #[arg(long)]
    out: PathBuf,
}

/// Runs the command.
pub fn run(args: &ConvertArgs) -> Result<()> {
    eprintln!("reading {}", args.scope.display());
    let text = std::fs::read_to_string(&args.scope).with_context(|| format!("reading {}", args.scope.display()))?;
    let map: Vec<(&str, &str)> = args.columns.iter().map(|(to, from)| (to.as_str(), from.as_str())).collect();
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

/// `NAME=HEADER` of `--column`.
fn column_pair(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((name, header)) if !name.trim().is_empty() && !header.trim().is_empty() => Ok((name.trim().to_string(), header.trim().to_string())),
        _ => Err(format!("`{s}` is not NAME=HEADER (e.g. vout=CH1)")),
    }
}
