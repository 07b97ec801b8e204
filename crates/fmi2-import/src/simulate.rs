//! Runs an FMU over an experiment with stepped inputs and records variables at every
//! communication point: the Co-Simulation master loop of fmpy's `simulate_fmu`, so results
//! compare point by point.
//!
//! ```no_run
//! use fmi2_import::{Fmu, simulate::{Experiment, simulate}};
//!
//! let fmu = Fmu::open("BouncingBall.fmu")?;
//! let exp = Experiment::for_fmu(&fmu, None, None, None)?; // its DefaultExperiment
//! let rec = simulate(&fmu, &exp, &[], None, &fmu.outputs())?;
//! println!("{} rows of {} variables", rec.time.len(), rec.variables.len());
//! # Ok::<(), fmi2_import::ImportError>(())
//! ```
use crate::{Fmu, ImportError, Value, Variable};

/// Most rows a run may record: a guard against a step far too small for its span.
pub const MAX_ROWS: usize = 10_000_000;

fn error(reason: String) -> ImportError {
    ImportError::Simulation(reason)
}

/// `math.isclose` with its defaults (relative 1e-9, no absolute floor), as fmpy's loop uses it.
fn isclose(a: f64, b: f64) -> bool {
    a == b || (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
}

/// Start and stop time and communication step \[s\].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Experiment {
    /// Start time \[s\].
    pub start: f64,
    /// Stop time \[s\].
    pub stop: f64,
    /// Communication step \[s\]; the last step is shortened to end at `stop` when the FMU can
    /// handle a variable step.
    pub step: f64,
}

impl Experiment {
    /// The given times, else the FMU's `DefaultExperiment`: start 0 and stop start + 1 when it
    /// gives none (as fmpy), the step its `stepSize`, else fmpy's `auto_interval` of the span
    /// (a round step giving 500–1000 steps).
    pub fn for_fmu(fmu: &Fmu, start: Option<f64>, stop: Option<f64>, step: Option<f64>) -> Result<Self, ImportError> {
        let default = fmu.model_description().default_experiment.clone().unwrap_or_default();
        let start = start.or(default.start_time).unwrap_or(0.0);
        let stop = stop.or(default.stop_time).unwrap_or(start + 1.0);
        let step = step.or(default.step_size).unwrap_or_else(|| auto_interval(stop - start));
        let exp = Self { start, stop, step };
        exp.validate()?;
        Ok(exp)
    }

    /// Finite times, `step > 0`, `stop ≥ start`, at most [`MAX_ROWS`] steps.
    pub fn validate(&self) -> Result<(), ImportError> {
        let Self { start, stop, step } = *self;
        for (name, x) in [("start time", start), ("stop time", stop), ("step", step)] {
            if !x.is_finite() {
                return Err(error(format!("the {name} {x} is not a finite number")));
            }
        }
        if step <= 0.0 {
            return Err(error(format!("the step {step} s must be positive")));
        }
        if stop < start {
            return Err(error(format!("the stop time {stop} s is before the start time {start} s")));
        }
        let steps = ((stop - start) / step).ceil();
        if steps > MAX_ROWS as f64 {
            return Err(error(format!("{steps:.0} steps of {step} s from {start} to {stop} s exceed the limit of {MAX_ROWS} rows; take a larger step")));
        }
        Ok(())
    }
}

/// fmpy's `auto_interval`: a round interval that divides `span` into 500–1000 steps.
fn auto_interval(span: f64) -> f64 {
    if !(span > 0.0 && span.is_finite()) {
        return 1e-3;
    }
    let h = 10f64.powf(span.log10().round() - 3.0);
    let n = span / h;
    let factor = match n {
        n if n >= 2500.0 => 5.0,
        n if n >= 2000.0 => 4.0,
        n if n >= 1000.0 => 2.0,
        n if n <= 200.0 => 1.0 / 5.0,
        n if n <= 250.0 => 1.0 / 4.0,
        n if n <= 500.0 => 1.0 / 2.0,
        _ => 1.0,
    };
    h * factor
}

/// A table of input values: each row holds from its time until the next row's (zero-order
/// hold); before the first row the first row's values apply, after the last the last's.
#[derive(Debug, Clone, PartialEq)]
pub struct Inputs {
    variables: Vec<Variable>,
    times: Vec<f64>,
    rows: Vec<Vec<Value>>,
}

impl Inputs {
    /// Checks that every variable may change while stepping (an input or a tunable
    /// parameter), that times are finite and strictly increasing, and that every row has one
    /// value of the right type per variable. Errors name the variable or the row (1-based).
    pub fn new(variables: Vec<Variable>, times: Vec<f64>, rows: Vec<Vec<Value>>) -> Result<Self, ImportError> {
        for v in &variables {
            if !v.settable_while_stepping() {
                return Err(error(format!(
                    "input column `{}`: the variable is a {:?} {:?} variable; only inputs and tunable parameters may change during a simulation (give a start value instead)",
                    v.name, v.variability, v.causality
                )));
            }
        }
        if times.is_empty() {
            return Err(error("the input table has no rows".into()));
        }
        if times.len() != rows.len() {
            return Err(error(format!("the input table has {} times but {} rows", times.len(), rows.len())));
        }
        for (i, &t) in times.iter().enumerate() {
            if !t.is_finite() {
                return Err(error(format!("input row {}: time {t} is not a finite number", i + 1)));
            }
            if i > 0 && t <= times[i - 1] {
                return Err(error(format!("input row {}: time {t} does not increase (row {} has {}); each row holds until the next, so times must strictly increase", i + 1, i, times[i - 1])));
            }
        }
        for (i, row) in rows.iter().enumerate() {
            if row.len() != variables.len() {
                return Err(error(format!("input row {}: {} values for {} variables", i + 1, row.len(), variables.len())));
            }
            for (v, x) in variables.iter().zip(row) {
                if !v.accepts(x) {
                    return Err(ImportError::BadValue { name: v.name.clone(), reason: format!("input row {}: a {:?} value for a {:?} variable", i + 1, x.kind(), v.kind) });
                }
                if let Value::Real(r) = x
                    && !r.is_finite()
                {
                    return Err(ImportError::BadValue { name: v.name.clone(), reason: format!("input row {}: {r} is not finite", i + 1) });
                }
            }
        }
        Ok(Self { variables, times, rows })
    }

    /// The row in force at `t`: the last that starts at or before it (within fmpy's
    /// `isclose`), else the first.
    fn row_at(&self, t: f64) -> usize {
        self.times.iter().rposition(|&r| r < t || isclose(r, t)).unwrap_or(0)
    }

    /// The first row start after `t`, if any.
    fn next_change(&self, t: f64) -> Option<f64> {
        self.times.iter().copied().find(|&r| r > t && !isclose(r, t))
    }

    fn apply(&self, inst: &mut crate::Instance, t: f64) -> Result<(), ImportError> {
        let row = &self.rows[self.row_at(t)];
        for (v, x) in self.variables.iter().zip(row) {
            inst.set_value(v, x)?;
        }
        Ok(())
    }
}

/// What [`simulate`] recorded.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// The recorded variables, in the order asked.
    pub variables: Vec<Variable>,
    /// Each communication point \[s\], the start included.
    pub time: Vec<f64>,
    /// One value per variable at each communication point.
    pub rows: Vec<Vec<Value>>,
    /// What a reader of the result should know (e.g. a shortened run).
    pub notes: Vec<String>,
}

/// Instantiates `fmu`, sets `start_values` after `fmi2SetupExperiment`, applies the inputs in
/// initialization mode and before every `fmi2DoStep`, and records `record` at the start and
/// after every step, then terminates. Communication points are `start + k·step`; with inputs,
/// an FMU that can handle a variable step also stops at each input row's time (so a row takes
/// effect when it starts), and its last step ends at `stop`. An FMU that cannot stops at the
/// last whole step (noted). A step the FMU discards because it terminated ends the run at
/// the time it reached (recorded, noted), as in fmpy.
pub fn simulate(fmu: &Fmu, exp: &Experiment, start_values: &[(Variable, Value)], inputs: Option<&Inputs>, record: &[Variable]) -> Result<Recording, ImportError> {
    exp.validate()?;
    if let Some(v) = record.iter().find(|v| v.name == "time") {
        return Err(error(format!("`{}` cannot be recorded: the first column is the time already", v.name)));
    }
    let variable_step = fmu.co_simulation().can_handle_variable_communication_step_size == Some(true);
    let mut inst = fmu.instantiate(fmu.model_identifier())?;
    inst.setup_experiment(exp.start, Some(exp.stop))?;
    for (v, x) in start_values {
        inst.set_value(v, x)?;
    }
    inst.enter_initialization_mode()?;
    if let Some(inputs) = inputs {
        inputs.apply(&mut inst, exp.start)?;
    }
    inst.exit_initialization_mode()?;

    let mut rec = Recording { variables: record.to_vec(), time: Vec::new(), rows: Vec::new(), notes: Vec::new() };
    let mut time = exp.start;
    rec.time.push(time);
    rec.rows.push(inst.get_values(record)?);
    let mut n_steps = 0u64;
    while !(time > exp.stop || isclose(time, exp.stop)) {
        let regular = exp.start + (n_steps + 1) as f64 * exp.step;
        let mut next = regular;
        if let Some(change) = inputs.and_then(|i| i.next_change(time))
            && variable_step
            && next > change
            && !isclose(next, change)
        {
            next = change;
        }
        if next > exp.stop && !isclose(next, exp.stop) {
            if !variable_step {
                rec.notes.push(format!("stopped at {time} s, not {} s: the FMU cannot shorten its last step (canHandleVariableCommunicationStepSize is not true)", exp.stop));
                break;
            }
            next = exp.stop;
        }
        if let Some(inputs) = inputs {
            inputs.apply(&mut inst, time)?;
        }
        match inst.do_step(time, next - time) {
            Ok(()) => time = next,
            // fmpy's rule: a discarded step whose FMU asks to terminate ends the run at the
            // last time it reached, recorded.
            Err(e @ ImportError::Call { status: crate::Status::Discard, .. }) => match inst.terminated_at() {
                Ok(Some(t)) => {
                    rec.notes.push(format!("the FMU ended the simulation at {t} s (fmi2DoStep returned fmi2Discard with fmi2Terminated)"));
                    rec.time.push(t);
                    rec.rows.push(inst.get_values(record)?);
                    break;
                }
                _ => return Err(e),
            },
            Err(e) => return Err(e),
        }
        rec.time.push(time);
        rec.rows.push(inst.get_values(record)?);
        if isclose(time, regular) {
            n_steps += 1;
        }
    }
    inst.terminate()?;
    Ok(rec)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::VarKind;
    use fmi2_schema::{Causality, Variability};

    fn var(name: &str, causality: Causality, variability: Variability) -> Variable {
        Variable { name: name.into(), value_reference: 1, kind: VarKind::Real, causality, variability }
    }

    #[test]
    fn auto_interval_matches_fmpy() {
        // fmpy 0.3.32: auto_interval(1) = 0.002, (2) = 0.004, (3) = 0.005, (10) = 0.02, (0.5) = 0.0005.
        for (span, h) in [(1.0, 0.002), (2.0, 0.004), (3.0, 0.005), (10.0, 0.02), (0.5, 0.0005)] {
            assert!((auto_interval(span) - h).abs() < 1e-15 * h.max(1.0), "{span}: {}", auto_interval(span));
        }
    }

    #[test]
    fn bad_times_are_named() {
        let bad = |start, stop, step| Experiment { start, stop, step }.validate().unwrap_err().to_string();
        assert!(bad(0.0, 1.0, 0.0).contains("step 0 s must be positive"));
        assert!(bad(0.0, 1.0, -1.0).contains("must be positive"));
        assert!(bad(1.0, 0.5, 0.1).contains("before the start time"));
        assert!(bad(0.0, f64::NAN, 0.1).contains("stop time NaN is not a finite"));
        assert!(bad(0.0, 1.0, 1e-9).contains("exceed the limit"));
        assert!(Experiment { start: 1.0, stop: 1.0, step: 0.1 }.validate().is_ok());
    }

    #[test]
    fn inputs_hold_each_row_until_the_next() {
        let u = var("u", Causality::Input, Variability::Continuous);
        let rows = vec![vec![Value::Real(1.0)], vec![Value::Real(2.0)], vec![Value::Real(3.0)]];
        let table = Inputs::new(vec![u.clone()], vec![0.5, 1.0, 2.0], rows.clone()).unwrap();
        assert_eq!(table.row_at(0.0), 0, "before the first row: the first");
        assert_eq!(table.row_at(0.99), 0);
        assert_eq!(table.row_at(1.0 - 1e-12), 1, "within isclose of a row start");
        assert_eq!(table.row_at(5.0), 2);
        assert_eq!(table.next_change(0.5), Some(1.0));
        assert_eq!(table.next_change(2.0), None);

        let err = Inputs::new(vec![u.clone()], vec![0.0, 1.0, 1.0], rows.clone()).unwrap_err().to_string();
        assert!(err.contains("input row 3: time 1 does not increase"), "{err}");
        let err = Inputs::new(vec![u.clone()], vec![0.0, f64::NAN, 2.0], rows.clone()).unwrap_err().to_string();
        assert!(err.contains("row 2: time NaN"), "{err}");
        let nan = vec![vec![Value::Real(f64::NAN)]];
        let err = Inputs::new(vec![u.clone()], vec![0.0], nan).unwrap_err().to_string();
        assert!(err.contains("variable `u`: input row 1: NaN is not finite"), "{err}");
        let p = var("k", Causality::Parameter, Variability::Fixed);
        let err = Inputs::new(vec![p], vec![0.0], vec![vec![Value::Real(1.0)]]).unwrap_err().to_string();
        assert!(err.contains("input column `k`") && err.contains("Fixed Parameter"), "{err}");
        let tunable = var("e", Causality::Parameter, Variability::Tunable);
        assert!(Inputs::new(vec![tunable], vec![0.0], vec![vec![Value::Real(1.0)]]).is_ok());
    }
}
