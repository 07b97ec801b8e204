//! `buckid simulate`: run any FMI 2.0 Co-Simulation FMU over its experiment with stepped inputs
//! from a CSV and write the recorded variables as a CSV (fmpy's result-file layout).
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use fmi2_import::simulate::{Experiment, Inputs, Recording, simulate};
use fmi2_import::{Fmu, Value, Variable};

use crate::identify::pair;

#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// FMI 2.0 Co-Simulation FMU to run.
    #[arg(long)]
    fmu: PathBuf,
    /// CSV of inputs: a `time` column, then one column per input (or tunable parameter) named as
    /// in the modelDescription; each row's values hold until the next row's time.
    #[arg(long)]
    input: Option<PathBuf>,
    /// Start value set before initialization (repeatable): a number, `true`/`false`, or text
    /// for a String variable.
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// Start time \[s\] (default: the DefaultExperiment's startTime, else 0).
    #[arg(long, allow_negative_numbers = true)]
    start: Option<f64>,
    /// Stop time \[s\] (default: the DefaultExperiment's stopTime, else start + 1).
    #[arg(long, allow_negative_numbers = true)]
    stop: Option<f64>,
    /// Communication step \[s\] (default: the DefaultExperiment's stepSize, else fmpy's automatic
    /// interval, 500–1000 steps).
    #[arg(long, allow_negative_numbers = true)]
    step: Option<f64>,
    /// Variable to record (repeatable, any causality; default: every output).
    #[arg(long = "output", value_name = "NAME")]
    output: Vec<String>,
    /// Result CSV (default: stdout).
    #[arg(long)]
    out: Option<PathBuf>,
}

impl SimulateArgs {
    /// The FMU it runs.
    pub fn fmu(&self) -> &Path {
        &self.fmu
    }
}

/// Runs the command.
pub fn run(args: &SimulateArgs) -> Result<()> {
    if !args.fmu.exists() {
        bail!("FMU {} does not exist", args.fmu.display());
    }
    let fmu = Fmu::open(&args.fmu).with_context(|| format!("opening FMU {}", args.fmu.display()))?;
    let exp = Experiment::for_fmu(&fmu, args.start, args.stop, args.step)?;
    let start_values = args
        .set
        .iter()
        .map(|s| {
            let (name, text) = pair(s, "--set")?;
            let var = fmu.resolve(&name).with_context(|| format!("--set {s}"))?;
            let value = Value::parse(var.kind, &text).map_err(|e| anyhow::anyhow!("--set {s}: {e}"))?;
            Ok((var, value))
        })
        .collect::<Result<Vec<_>>>()?;
    let record = recorded(&fmu, &args.output)?;
    let inputs = match &args.input {
        Some(path) => Some(read_inputs(&fmu, path)?),
        None => None,
    };
    eprintln!("simulating {} ({}) from {} s to {} s, step {} s", args.fmu.display(), fmu.model_description().model_name, exp.start, exp.stop, exp.step);
    let rec = simulate(&fmu, &exp, &start_values, inputs.as_ref(), &record)?;
    for note in &rec.notes {
        eprintln!("note: {note}");
    }
    match &args.out {
        Some(path) => {
            let file = std::fs::File::create(path).with_context(|| format!("writing {}", path.display()))?;
            write_csv(&rec, file).with_context(|| format!("writing {}", path.display()))?;
            eprintln!("wrote {} rows of {} variables to {}", rec.time.len(), rec.variables.len(), path.display());
        }
        None => write_csv(&rec, std::io::stdout().lock())?,
    }
    Ok(())
}

/// `--output` names (duplicates dropped), else every output of the FMU.
fn recorded(fmu: &Fmu, names: &[String]) -> Result<Vec<Variable>> {
    if names.is_empty() {
        let outputs = fmu.outputs();
        if outputs.is_empty() {
            eprintln!("note: the FMU has no outputs; recording time only (name variables with --output)");
        }
        return Ok(outputs);
    }
    let mut vars: Vec<Variable> = Vec::new();
    for name in names {
        let var = fmu.resolve(name).with_context(|| format!("--output {name}"))?;
        if !vars.contains(&var) {
            vars.push(var);
        }
    }
    Ok(vars)
}

/// Reads the input CSV: a header `time,NAME,…`, then one row per line. Errors name the file
/// and the line (the table's own checks count rows: row N is line N + 1).
fn read_inputs(fmu: &Fmu, path: &Path) -> Result<Inputs> {
    let file = std::fs::File::open(path).with_context(|| format!("input file {}", path.display()))?;
    let mut reader = csv::ReaderBuilder::new().trim(csv::Trim::All).from_reader(file);
    let header = reader.headers().with_context(|| format!("input file {}: reading the header", path.display()))?.clone();
    let where_ = |what: String| format!("input file {}: {what}", path.display());
    if header.get(0) != Some("time") {
        bail!(where_(format!("the first column must be `time`, not {:?}", header.get(0).unwrap_or(""))));
    }
    let variables = header.iter().skip(1).map(|name| fmu.resolve(name).with_context(|| where_(format!("column `{name}`")))).collect::<Result<Vec<_>>>()?;
    let (mut times, mut rows) = (Vec::new(), Vec::new());
    for record in reader.records() {
        let record = record.with_context(|| where_("reading a row".into()))?;
        let line = record.position().map_or(0, csv::Position::line);
        let at = |what: String| where_(format!("line {line}: {what}"));
        let t = record.get(0).unwrap_or("");
        let time = t.parse::<f64>().ok().with_context(|| at(format!("time {t:?} is not a number")))?;
        let row = variables
            .iter()
            .zip(record.iter().skip(1))
            .map(|(v, text)| Value::parse(v.kind, text).map_err(|e| anyhow::anyhow!(at(format!("column `{}`: {e}", v.name)))))
            .collect::<Result<Vec<_>>>()?;
        times.push(time);
        rows.push(row);
    }
    Inputs::new(variables, times, rows).with_context(|| where_("row N is line N + 1".into()))
}

/// `time`, then one column per variable; one row per communication point.
fn write_csv(rec: &Recording, out: impl Write) -> Result<()> {
    let mut w = csv::Writer::from_writer(out);
    w.write_record(std::iter::once("time").chain(rec.variables.iter().map(|v| v.name.as_str())))?;
    for (t, row) in rec.time.iter().zip(&rec.rows) {
        w.write_record(std::iter::once(t.to_string()).chain(row.iter().map(Value::to_string)))?;
    }
    w.flush()?;
    Ok(())
}
