//! `buckid convert (--scope FILE | --channel NAME=FILE…) [--fs HZ] [--meta KEY=VALUE…] --out
//! FILE`: an oscilloscope capture reduced to the data contract, one row per switching period
//! (the `capture` crate does the work).
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

/// Arguments of `buckid convert`.
#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// Oscilloscope capture (CSV: `time`, `vout`; optional `il`, `sw`, `gate`, `vin`).
    #[arg(long, required_unless_present = "channels", conflicts_with = "channels")]
    scope: Option<PathBuf>,
    /// One channel of the capture in a file of its own (repeatable; `vout` required), as a
    /// LeCroy (`Time,Ampl` after its notes) or a Tektronix TDS (no header row, each row its
    /// settings then the sample's time and value) saves them, or `time,value` rows:
    /// `vout=C1.txt`, `sw=C3.txt`, `il=C2.txt*10` for a current read in volts (10 A per volt).
    /// The channels must come from one acquisition (the same sample times).
    #[arg(long = "channel", value_name = "NAME=FILE[*SCALE]", value_parser = channel_file)]
    channels: Vec<(String, PathBuf, f64)>,
    /// Switching frequency \[Hz\], used when the capture has no switch-node or gate edges.
    #[arg(long)]
    fs: Option<f64>,
    /// The capture's own name of a column (repeatable), for an oscilloscope's export:
    /// `vout=CH1`, `il=CH2`, `sw=CH3`, `time=TIME` (a unit in the header is kept: `CH1 [mV]`),
    /// `il=CH2*10` for a current read in volts (here across a 0.1 Ω shunt: 10 A per volt; the
    /// values as written times the scale, the header's unit set aside).
    /// The scope's preamble before its header row, and a row of units after it, are skipped;
    /// a Rigol's numbered samples (`time=X`) are timed by the `Start` and `Increment` there.
    #[arg(long = "column", value_name = "NAME=HEADER[*SCALE]", value_parser = column_name, requires = "scope")]
    columns: Vec<(String, String, Option<f64>)>,
    /// Metadata written at the top of the data file (repeatable): the nominal values the
    /// capture does not carry, `U=12` (without a `vin` channel), `L=4.7e-6`, `C=1e-4`, ….
    #[arg(long = "meta", value_name = "KEY=VALUE", value_parser = meta_entry)]
    meta: Vec<(String, String)>,
    /// Where to write the data-contract CSV.
    #[arg(long)]
    out: PathBuf,
}

/// Runs the command.
pub fn run(args: &ConvertArgs) -> Result<()> {
    let read = |path: &PathBuf| {
        eprintln!("reading {}", path.display());
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))
    };
    let cap = match &args.scope {
        Some(scope) => {
            let map: Vec<capture::Named> = args.columns.iter().map(|(column, header, scale)| capture::Named { column, header, scale: *scale }).collect();
            capture::Capture::parse_csv_with(&read(scope)?, &map).with_context(|| format!("{}", scope.display()))?
        }
        None => {
            let traces = args.channels.iter().map(|(name, path, scale)| Ok((name.as_str(), capture::Trace::parse_csv(&read(path)?).with_context(|| format!("{}", path.display()))?, *scale)));
            capture::Capture::from_traces(traces.collect::<Result<_>>()?)?
        }
    };
    let periods = capture::reduce(&cap, args.fs)?;
    let mut meta = cap.meta.clone();
    meta.extend(args.meta.iter().cloned());
    if cap.vin.is_none() && !meta.contains_key("U") {
        eprintln!("note: no `vin` column and no `# U` metadata: the data file will need one before `identify`/`diagnose` (`--meta U=…`)");
    }
    meta.remove("periods_from");
    std::fs::write(&args.out, capture::to_csv(&periods, &meta)).with_context(|| format!("writing {}", args.out.display()))?;
    println!("periods     {} complete, fs {:.6} kHz measured ({})", periods.time.len(), periods.fs / 1e3, periods.source);
    println!("duty        {:.4} … {:.4}", periods.duty.iter().copied().fold(f64::INFINITY, f64::min), periods.duty.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    eprintln!("wrote {}", args.out.display());
    Ok(())
}

/// `NAME=FILE[*SCALE]` of `--channel` (a `*` followed by anything but a number is part of the
/// file's name).
fn channel_file(s: &str) -> Result<(String, PathBuf, f64), String> {
    let (name, file) =
        s.split_once('=').filter(|(n, f)| !n.trim().is_empty() && !f.trim().is_empty()).ok_or_else(|| format!("`{s}` is not NAME=FILE or NAME=FILE*SCALE (e.g. vout=C1.txt, il=C2.txt*10)"))?;
    let (file, scale) = file.rsplit_once('*').and_then(|(f, k)| Some((f, k.trim().parse::<f64>().ok()?))).unwrap_or((file, 1.0));
    Ok((name.trim().to_string(), PathBuf::from(file.trim()), scale))
}

/// `KEY=VALUE` of `--meta`.
fn meta_entry(s: &str) -> Result<(String, String), String> {
    s.split_once('=').map(|(k, v)| (k.trim().to_string(), v.trim().to_string())).filter(|(k, v)| !k.is_empty() && !v.is_empty()).ok_or_else(|| format!("`{s}` is not KEY=VALUE (e.g. U=12)"))
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
