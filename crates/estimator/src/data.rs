//! Data sets: one row per switching period, from an FMU run, the in-process model or a CSV file.
//!
//! Row `k` holds the duty applied during period `k` (`[k·T, (k+1)·T)`), the outputs sampled at
//! the period start `k·T` (`vout`, `il`) and, when the source offers them, the exact averages
//! over period `k` (`vout_avg`, `il_avg`).
use std::collections::BTreeMap;
use std::path::Path;

use csv_header::{Column, Found};

use crate::error::{EstimatorError, data_err};

/// Least mean `vout`, as a share of the mean `duty·vin`, of a record a buck can have produced
/// ([`DataSet::check_output_level`]).
pub const MIN_OUTPUT_SHARE: f64 = 0.1;

/// Most mean `vout`, as a share of the mean `vin`, of a record a buck can have produced
/// (its output at no load in DCM approaches `vin`; a probe's gain error adds a little).
pub const MAX_OUTPUT_SHARE: f64 = 1.5;

/// Measured or simulated signals at one sample per switching period.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DataSet {
    /// Period start times \[s\], uniformly spaced by `1/fs`.
    pub time: Vec<f64>,
    /// Duty applied during each period.
    pub duty: Vec<f64>,
    /// Input voltage \[V\].
    pub vin: Vec<f64>,
    /// Load current \[A\].
    pub io: Vec<f64>,
    /// Output voltage at each period start \[V\].
    pub vout: Vec<f64>,
    /// Inductor current at each period start \[A\], when measured.
    pub il: Option<Vec<f64>>,
    /// Average output voltage over each period \[V\], when available.
    pub vout_avg: Option<Vec<f64>>,
    /// Average inductor current over each period \[A\], when available.
    pub il_avg: Option<Vec<f64>>,
    /// `# key = value` metadata (e.g. `fs`, `L`, `U`), as read or to be written.
    pub meta: BTreeMap<String, String>,
}

/// Metadata key (and optional constant column) of the load resistance \[Ω\].
pub const RLOAD: &str = "rload";

/// How far a step between rows may differ from their mean spacing, in periods.
const STEP_SLACK: f64 = 0.5;

/// How far a row's time may lie off the uniform grid of the mean spacing, in periods (a row
/// missing in the middle of a record puts the rows around it half a period off).
const GRID_SLACK: f64 = 0.25;

/// Largest relative difference between the metadata `fs` and the rate of the rows: a
/// controller's oscillator is within a few percent of its nominal frequency; a time column in
/// milliseconds, or every second period kept, is far outside.
pub const FS_MISMATCH: f64 = 0.05;

/// Columns of the CSV contract, in the order they are written, then `rload` (read into the
/// metadata): SI units, `time` and `vout` required.
const COLUMNS: [Column; 9] = [
    Column::required("time", "s"),
    Column::optional("duty", ""),
    Column::optional("vin", "V"),
    Column::optional("io", "A"),
    Column::required("vout", "V"),
    Column::optional("il", "A"),
    Column::optional("vout_avg", "V"),
    Column::optional("il_avg", "A"),
    Column::optional(RLOAD, "Ω"),
];

impl DataSet {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// Sample period \[s\] (the switching period).
    pub fn sample_period(&self) -> f64 {
        if self.len() < 2 { f64::NAN } else { (self.time[self.len() - 1] - self.time[0]) / (self.len() - 1) as f64 }
    }

    /// A metadata value parsed as a number.
    pub fn meta_f64(&self, key: &str) -> Result<Option<f64>, EstimatorError> {
        self.meta.get(key).map(|v| v.trim().parse::<f64>().map_err(|_| data_err(format!("metadata `{key} = {v}` is not a number")))).transpose()
    }

    /// Load resistance `rload` \[Ω\] from the metadata `# rload = R` (a `rload` column is folded
    /// into it when read): 0 (no resistor) when absent; negative or non-finite values are an
    /// error.
    ///
    /// ```
    /// let d = estimator::data::DataSet::parse_csv("# rload = 10\n# U = 12\n# io = 0\ntime,duty,vout\n0,0.5,5\n1e-6,0.5,5\n").unwrap();
    /// assert_eq!(d.rload().unwrap(), 10.0);
    /// ```
    pub fn rload(&self) -> Result<f64, EstimatorError> {
        match self.meta_f64(RLOAD)? {
            None => Ok(0.0),
            Some(r) if r >= 0.0 && r.is_finite() => Ok(r),
            Some(r) => Err(data_err(format!("metadata `{RLOAD} = {r}`: a load resistance must be ≥ 0 Ω (0 = none)"))),
        }
    }

    /// Rows `range` as a new data set (metadata kept).
    pub fn slice(&self, range: std::ops::Range<usize>) -> DataSet {
        let cut = |v: &Vec<f64>| v[range.clone()].to_vec();
        DataSet {
            time: cut(&self.time),
            duty: cut(&self.duty),
            vin: cut(&self.vin),
            io: cut(&self.io),
            vout: cut(&self.vout),
            il: self.il.as_ref().map(cut),
            vout_avg: self.vout_avg.as_ref().map(cut),
            il_avg: self.il_avg.as_ref().map(cut),
            meta: self.meta.clone(),
        }
    }

    /// Checks that `vout` holds a buck's output in volts: its mean at least
    /// [`MIN_OUTPUT_SHARE`] of the mean `duty·vin` the record's inputs call for (a buck gives
    /// that less its drops, more in DCM) and at most [`MAX_OUTPUT_SHARE`] of the mean `vin` (a
    /// buck steps down). An AC-coupled scope channel (mean near zero), a probe zeroed at the
    /// operating point or a column in millivolts does not, and fitting the first once named a
    /// 626 mΩ load ESR with Cl on its 1 F bound.
    pub fn check_output_level(&self) -> Result<(), EstimatorError> {
        let rows = self.len().max(1) as f64;
        let vout = self.vout.iter().sum::<f64>() / rows;
        let called_for = self.duty.iter().zip(&self.vin).map(|(d, v)| d * v).sum::<f64>() / rows;
        if called_for > 0.0 && vout < MIN_OUTPUT_SHARE * called_for {
            // (A mean that rounds to zero is printed as one, not as -0.000.)
            let vout = if vout.abs() < 5e-4 { 0.0 } else { vout };
            return Err(data_err(format!(
                "`vout` averages {vout:.3} V where duty·vin averages {called_for:.3} V, and a buck's output is near that: an AC-coupled or zeroed channel, or another unit? The contract's `vout` is the output voltage, DC-coupled, in volts"
            )));
        }
        let vin = self.vin.iter().sum::<f64>() / rows;
        if vin > 0.0 && vout > MAX_OUTPUT_SHARE * vin {
            return Err(data_err(format!("`vout` averages {vout:.4e} V, above the {vin:.3} V `vin` averages, and a buck steps down: millivolts, or another unit? The contract's `vout` is in volts")));
        }
        Ok(())
    }

    /// Checks lengths, finiteness and uniform time; the error names the column and row.
    pub fn validate(&self) -> Result<(), EstimatorError> {
        let n = self.len();
        if n < 2 {
            return Err(data_err(format!("the data set has {n} samples; at least 2 are needed")));
        }
        for (name, col) in self.columns() {
            let Some(col) = col else { continue };
            if col.len() != n {
                return Err(data_err(format!("column `{name}` has {} values, `time` has {n}", col.len())));
            }
            if let Some(i) = col.iter().position(|v| !v.is_finite()) {
                return Err(data_err(format!("column `{name}` row {}: value {} is not finite", i + 1, col[i])));
            }
        }
        let dt = self.sample_period();
        if dt.is_nan() || dt <= 0.0 {
            return Err(data_err("`time` must increase"));
        }
        // Finite times 1e308 apart have an infinite spacing, which the uniformity test below
        // cannot judge (inf − inf is NaN) and no model can use (found by fuzzing).
        if !dt.is_finite() || !(self.time[n - 1] - self.time[0]).is_finite() {
            return Err(data_err(format!("`time` spans {:e} … {:e} s: the sample period is not a finite number", self.time[0], self.time[n - 1])));
        }
        // Rounding and jitter of the printed time pass (a logger's six significant digits are
        // 0.5 % of the period at row 3000); a missing or repeated row does not, nor the rows of a
        // log that is not one per period.
        let contract = "one row per switching period is the contract: a row missing or repeated?";
        let step = |i: usize| self.time[i] - self.time[i - 1];
        if let Some(i) = (1..n).find(|&i| (step(i) - dt).abs() > STEP_SLACK * dt) {
            return Err(data_err(format!("`time` is not uniform: row {} follows row {i} by {:e} s, {:.2} times the mean spacing {dt:e} s ({contract})", i + 1, step(i), step(i) / dt)));
        }
        let off = |i: usize| self.time[i] - (self.time[0] + i as f64 * dt);
        if let Some(i) = (1..n).find(|&i| off(i).abs() > GRID_SLACK * dt) {
            return Err(data_err(format!("`time` is not uniform: row {} lies {:+.2} periods off the grid of the mean spacing {dt:e} s ({contract})", i + 1, off(i) / dt)));
        }
        if let Some(fs) = self.meta_f64("fs")?
            && (!fs.is_finite() || (fs * dt - 1.0).abs() > FS_MISMATCH)
        {
            return Err(data_err(format!(
                "metadata `fs = {fs}` but `time` is spaced by {dt:e} s, a rate of {:.1} kHz: the model switches once per row, so the two must agree within {:.0} % (time in other units than seconds? only every n-th period kept?)",
                1e-3 / dt,
                FS_MISMATCH * 100.0
            )));
        }
        // A duty in percent reaches the simulator as an out-of-range input and the fit as a
        // diverging predictor, which names neither.
        if let Some(i) = self.duty.iter().position(|d| !(0.0..=1.0).contains(d)) {
            let percent = self.duty.iter().all(|d| (0.0..=100.0).contains(d));
            return Err(data_err(format!(
                "column `duty` row {}: {} is outside [0, 1], the fraction of the switching period the high side is on{}",
                i + 1,
                self.duty[i],
                if percent { " (in percent? divide by 100)" } else { "" }
            )));
        }
        Ok(())
    }

    fn columns(&self) -> [(&'static str, Option<&Vec<f64>>); 8] {
        [
            ("time", Some(&self.time)),
            ("duty", Some(&self.duty)),
            ("vin", Some(&self.vin)),
            ("io", Some(&self.io)),
            ("vout", Some(&self.vout)),
            ("il", self.il.as_ref()),
            ("vout_avg", self.vout_avg.as_ref()),
            ("il_avg", self.il_avg.as_ref()),
        ]
    }

    /// Reads the CSV contract: `# key = value` lines, one header row, SI units; `time` and
    /// `vout` required; `duty`, `vin`, `io`, `il`, `vout_avg`, `il_avg` optional (missing
    /// `duty`/`vin`/`io` are taken from metadata `duty`, `U`, `io` or are an error); a load
    /// resistance \[Ω\] from metadata `rload` or a constant `rload` column (see
    /// [`DataSet::rload`]); unknown columns ignored.
    pub fn read_csv(path: &Path) -> Result<DataSet, EstimatorError> {
        let bytes = std::fs::read(path).map_err(|source| EstimatorError::Io { path: path.display().to_string(), source })?;
        // "stream did not contain valid UTF-8" named neither the place nor the likely cause.
        let text = decode(&bytes).map_err(|e| data_err(format!("{}: {e}", path.display())))?;
        Self::parse_csv(text).map_err(|e| data_err(format!("{}: {e}", path.display())))
    }

    /// Parses CSV text (see [`DataSet::read_csv`]).
    pub fn parse_csv(text: &str) -> Result<DataSet, EstimatorError> {
        let csv_header::Split { mut meta, body, header_line } = csv_header::split(text);
        if body.trim().is_empty() {
            return Err(data_err("no header row and no data (empty file?)"));
        }
        let delimiter = csv_header::delimiter(body);
        let mut reader = csv::ReaderBuilder::new().trim(csv::Trim::All).delimiter(delimiter).from_reader(body.as_bytes());
        let headers = reader.headers().map_err(|e| data_err(format!("line {header_line}: {e}")))?.clone();
        let mut wanted = csv_header::find(&headers.iter().collect::<Vec<_>>(), &COLUMNS).map_err(|e| data_err(format!("line {header_line}: {e}")))?;
        let rload_col = wanted.pop().flatten();
        let mut cols: Vec<Vec<f64>> = vec![Vec::new(); wanted.len()];
        // A load-resistance column must hold one value (the models take a fixed resistor): it
        // becomes the `rload` metadata, which it must agree with when both are given.
        let mut rload: Option<(f64, usize)> = None;
        // The line of a record is the reader's, counted from the header row: blank lines and
        // quoted cells spanning lines would shift a count of records (found by fuzzing).
        let line_of = |pos: Option<&csv::Position>, fallback: usize| pos.map_or(fallback, |p| header_line - 1 + p.line() as usize);
        for (r, record) in reader.records().enumerate() {
            let record = record.map_err(|e| {
                let line = line_of(e.position(), header_line + 1 + r);
                data_err(format!("line {line}: {}", csv_header::record_problem(&e)))
            })?;
            let line = line_of(record.position(), header_line + 1 + r);
            let value_at = |found: Found, name: &str| csv_header::value(record.get(found.index).unwrap_or(""), name, found, delimiter).map_err(|e| data_err(format!("line {line}: {e}")));
            if let Some(found) = rload_col {
                let value = value_at(found, RLOAD)?;
                if value < 0.0 {
                    return Err(data_err(format!("line {line}: column `{RLOAD}` value {value} Ω must be a resistance ≥ 0 Ω (0 = none)")));
                }
                match rload {
                    None => rload = Some((value, line)),
                    Some((first, first_line)) if first != value => {
                        return Err(data_err(format!(
                            "line {line}: column `{RLOAD}` is {value} Ω, line {first_line} had {first} Ω: a varying load resistance is not modelled (split the file where it changes)"
                        )));
                    }
                    Some(_) => {}
                }
            }
            for (c, found) in wanted.iter().enumerate() {
                let Some(found) = *found else { continue };
                let value = value_at(found, COLUMNS[c].name)?;
                cols[c].push(value);
            }
        }
        let n = cols[0].len();
        if n == 0 {
            return Err(data_err("the file has a header but no data rows"));
        }
        if let Some((r, line)) = rload {
            match meta.get(RLOAD).map(|m| (m, m.trim().parse::<f64>())) {
                Some((_, Ok(m))) if m == r => {}
                Some((m, _)) => {
                    return Err(data_err(format!("line {line}: column `{RLOAD}` is {r} Ω but the metadata says `# {RLOAD} = {m}`")));
                }
                None => {
                    meta.insert(RLOAD.to_string(), format!("{r}"));
                }
            }
        }
        let mut data = DataSet { meta, ..Default::default() };
        let fill = |c: usize, key: &str, data: &DataSet| -> Result<Vec<f64>, EstimatorError> {
            if wanted[c].is_some() {
                return Ok(cols[c].clone());
            }
            match data.meta_f64(key)? {
                Some(v) => Ok(vec![v; n]),
                None => Err(data_err(format!("column `{}` is missing and no `# {key} = …` metadata gives it", COLUMNS[c].name))),
            }
        };
        data.duty = fill(1, "duty", &data)?;
        data.vin = fill(2, "U", &data)?;
        data.io = fill(3, "io", &data)?;
        let optional = |c: usize| wanted[c].is_some().then(|| cols[c].clone());
        data.il = optional(5);
        data.vout_avg = optional(6);
        data.il_avg = optional(7);
        data.time = std::mem::take(&mut cols[0]);
        data.vout = std::mem::take(&mut cols[4]);
        data.validate()?;
        data.rload()?;
        Ok(data)
    }

    /// Writes the CSV contract (metadata first, then the columns that are present).
    pub fn write_csv(&self, path: &Path) -> Result<(), EstimatorError> {
        let io_err = |source| EstimatorError::Io { path: path.display().to_string(), source };
        std::fs::write(path, self.to_csv()).map_err(io_err)
    }

    /// The CSV text of [`DataSet::write_csv`].
    pub fn to_csv(&self) -> String {
        let mut out = String::new();
        for (k, v) in &self.meta {
            out.push_str(&format!("# {k} = {v}\n"));
        }
        let present: Vec<(&str, &Vec<f64>)> = self.columns().into_iter().filter_map(|(n, c)| c.map(|c| (n, c))).collect();
        out.push_str(&present.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(","));
        out.push('\n');
        for i in 0..self.len() {
            let row: Vec<String> = present.iter().map(|(_, c)| format!("{:e}", c[i])).collect();
            out.push_str(&row.join(","));
            out.push('\n');
        }
        out
    }
}

/// The text of a data file: UTF-8 (with or without a byte-order mark); anything else is an
/// error naming the line and byte, and the encoding when its byte-order mark shows it.
fn decode(bytes: &[u8]) -> Result<&str, String> {
    if bytes.starts_with(&[0xff, 0xfe]) || bytes.starts_with(&[0xfe, 0xff]) {
        return Err("the file is UTF-16 text (it starts with a UTF-16 byte-order mark); save it as UTF-8".into());
    }
    std::str::from_utf8(bytes).map_err(|e| {
        let at = e.valid_up_to();
        let line = 1 + bytes[..at].iter().filter(|&&b| b == b'\n').count();
        format!("line {line}: byte {at} (0x{:02x}) is not UTF-8; save the file as UTF-8 (Latin-1 `µ` or `°` are a common cause)", bytes[at])
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "# fs = 330000\n# U = 12\ntime,duty,vout,extra\n0,0.4,4.7,x\n3.0303e-6,0.6,4.8,y\n6.0606e-6,0.6,4.9,z\n";

    #[test]
    fn reads_metadata_defaults_and_ignores_unknown_columns() {
        let d = DataSet::parse_csv(&GOOD.replace(",extra", "").replace(",x", "").replace(",y", "").replace(",z", "").replace("# U = 12\n", "# U = 12\n# io = 2\n")).unwrap();
        assert_eq!(d.len(), 3);
        assert_eq!(d.vin, vec![12.0; 3]);
        assert_eq!(d.io, vec![2.0; 3]);
        assert_eq!(d.meta_f64("fs").unwrap(), Some(330000.0));
        assert!(d.il.is_none());
    }

    /// Excel and many oscilloscopes write CRLF line endings (and a byte-order mark): the same
    /// data set as with LF (a CRLF file was once rejected with "required column `time` is
    /// missing (found: = 10)").
    #[test]
    fn crlf_and_a_byte_order_mark_read_like_lf() {
        let good = GOOD.replace("# U = 12\n", "# U = 12\n# io = 2\n");
        let lf = DataSet::parse_csv(&good).unwrap();
        for text in [good.replace('\n', "\r\n"), format!("\u{feff}{good}")] {
            let d = DataSet::parse_csv(&text).unwrap();
            assert_eq!((d.time.clone(), d.duty.clone(), d.vout.clone()), (lf.time.clone(), lf.duty.clone(), lf.vout.clone()));
            assert_eq!(d.meta, lf.meta);
        }
    }

    #[test]
    fn bad_files_give_errors_naming_the_problem() {
        let cases = [
            ("", "empty"),
            ("# only = meta\n", "empty"),
            ("time,vout\n", "no data rows"),
            ("time,duty\n0,1\n", "`vout` is missing"),
            ("time,vout,duty,vin,io\n0,1,0.5,12,1\n1e-6,nan,0.5,12,1\n", "line 3: column `vout`"),
            ("time,vout,duty,vin,io\n0,1,0.5,12,1\n1e-6,abc,0.5,12,1\n", "line 3: column `vout` value \"abc\""),
            ("time,vout,duty,vin,io\n0,1,0.5,12,1\n1e-6,1,0.5,12,1\n5e-6,1,0.5,12,1\n", "not uniform"),
            ("time,vout\n0,1\n1e-6,1\n", "column `duty` is missing"),
            ("time,vout,duty,vin,io\n0,1,0.5,12,1\n1e-6,1,0.5,12,1\n2e-6,1,0.5,12,1\n4e-6,1,0.5,12,1\n5e-6,1,0.5,12,1\n", "row 4 follows row 3 by 2e-6 s, 1.60 times"),
            ("# fs = 500000\ntime,vout,duty,vin,io\n0,1,0.5,12,1\n1e-6,1,0.5,12,1\n2e-6,1,0.5,12,1\n", "a rate of 1000.0 kHz"),
            ("time,vout,duty,vin,io\n0,1,40,12,1\n1e-6,1,60,12,1\n", "row 1: 40 is outside [0, 1], the fraction of the switching period the high side is on (in percent?"),
            ("time,vout [ms]\n0,1\n", "`ms` is not a unit of `vout`"),
            ("time,vout,duty,vin,io\n0,1,0.5,12\n", "line 2: the row has 4 fields where the header has 5"),
            ("# fs = 1e6\ntime,vout,duty,vin,io\n0,1,0.5,12,1\n1e-6,1,0.5,12,1,7\n", "line 4: the row has 6 fields where the header has 5"),
        ];
        for (text, needle) in cases {
            let err = DataSet::parse_csv(text).unwrap_err().to_string();
            assert!(err.contains(needle), "{text:?}: {err:?} lacks {needle:?}");
        }
    }

    #[test]
    fn rload_comes_from_metadata_or_a_constant_column() {
        let body = "time,duty,vout\n0,0.4,4.7\n1e-6,0.6,4.8\n";
        let head = "# U = 12\n# io = 0\n";
        assert_eq!(DataSet::parse_csv(&format!("{head}{body}")).unwrap().rload().unwrap(), 0.0, "absent: no resistor");
        assert_eq!(DataSet::parse_csv(&format!("{head}# rload = 10\n{body}")).unwrap().rload().unwrap(), 10.0);
        let col = "time,duty,vout,rload\n0,0.4,4.7,2.5\n1e-6,0.6,4.8,2.5\n";
        let d = DataSet::parse_csv(&format!("{head}{col}")).unwrap();
        assert_eq!(d.rload().unwrap(), 2.5);
        assert_eq!(DataSet::parse_csv(&d.to_csv()).unwrap().rload().unwrap(), 2.5, "written back as metadata");
        assert_eq!(DataSet::parse_csv(&format!("{head}# rload = 2.5\n{col}")).unwrap().rload().unwrap(), 2.5);
        let cases = [
            (format!("{head}# rload = -1\n{body}"), "rload = -1"),
            (format!("{head}# rload = abc\n{body}"), "not a number"),
            (format!("{head}# rload = 3\n{col}"), "metadata says"),
            (format!("{head}time,duty,vout,rload\n0,0.4,4.7,2\n1e-6,0.6,4.8,3\n"), "line 5: column `rload` is 3"),
            (format!("{head}time,duty,vout,rload\n0,0.4,4.7,-2\n1e-6,0.6,4.8,-2\n"), "line 4: column `rload`"),
            (format!("{head}time,duty,vout,rload\n0,0.4,4.7,x\n1e-6,0.6,4.8,2\n"), "line 4: column `rload` value \"x\""),
        ];
        for (text, needle) in cases {
            let err = DataSet::parse_csv(&text).unwrap_err().to_string();
            assert!(err.contains(needle), "{text:?}: {err:?} lacks {needle:?}");
        }
    }

    #[test]
    fn csv_round_trips() {
        let mut d = DataSet::parse_csv("# U = 12\n# io = 1\ntime,duty,vout,il\n0,0.4,4.7,1.1\n1e-6,0.6,4.8,0.9\n").unwrap();
        d.meta.insert("note".into(), "x".into());
        let back = DataSet::parse_csv(&d.to_csv()).unwrap();
        assert_eq!(back, d);
    }
}
