//! Sweep files: one steady operating point per row.
//!
//! CSV, SI units, one header row; `# key = value` metadata lines before it give circuit values
//! (`L`, `RL`, `fs`, `rds_on`, `vbd`; `C`, `Rc`, `Cl` are accepted and do not enter a DC model)
//! and defaults for missing columns (`U` for `vin`, `io`, `rload`). Columns: `duty`, `vout`
//! (mean output voltage) required; `vin`; `io` and/or `rload` (the load is
//! `io + vout/rload`); optional `il` (mean inductor current). Unknown columns are ignored.
use std::collections::BTreeMap;
use std::path::Path;

use csv_header::Column;

use crate::error::{SweepError, data_err};
use crate::model::{Circuit, OperatingPoint};

/// A measured steady-state sweep.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Sweep {
    /// The operating points (inputs of the DC model).
    pub points: Vec<OperatingPoint>,
    /// Measured mean output voltage per point \[V\].
    pub vout: Vec<f64>,
    /// Measured mean inductor current per point \[A\], when recorded.
    pub il: Option<Vec<f64>>,
    /// `# key = value` metadata as read.
    pub meta: BTreeMap<String, String>,
}

/// Columns read (others are ignored).
const COLUMNS: [Column; 6] =
    [Column::required("duty", ""), Column::optional("vin", "V"), Column::optional("io", "A"), Column::optional("rload", "Ω"), Column::required("vout", "V"), Column::optional("il", "A")];

impl Sweep {
    /// Number of operating points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True without operating points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// A metadata value parsed as a number; the error names the key.
    pub fn meta_f64(&self, key: &str) -> Result<Option<f64>, SweepError> {
        self.meta
            .get(key)
            .map(|v| match v.trim().parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(data_err(format!("metadata `{key} = {v}` is not a finite number"))),
            })
            .transpose()
    }

    /// The nominal circuit from the metadata; what is missing is taken from `fallback`, and the
    /// returned notes say which values were assumed (for stderr).
    pub fn circuit(&self, fallback: &Circuit) -> Result<(Circuit, Vec<String>), SweepError> {
        let mut c = *fallback;
        let mut assumed = Vec::new();
        let fields: [(&str, &mut f64, &str); 5] =
            [("L", &mut c.l, "H"), ("RL", &mut c.rl, "Ω"), ("fs", &mut c.fs, "Hz"), ("rds_on", &mut c.rds_on, "Ω"), ("vbd", &mut c.body_diode_drop, "V (body diode drop, used with dead time)")];
        for (key, slot, unit) in fields {
            match self.meta_f64(key)? {
                Some(v) => *slot = v,
                None => assumed.push(format!("{key} = {} {unit} (not in the file)", *slot)),
            }
        }
        crate::model::check_circuit(&c)?;
        Ok((c, assumed))
    }

    /// Reads a sweep file (see the module documentation); errors name the file and line.
    pub fn read_csv(path: &Path) -> Result<Sweep, SweepError> {
        let text = std::fs::read_to_string(path).map_err(|source| SweepError::Io { path: path.display().to_string(), source })?;
        Self::parse_csv(&text).map_err(|e| data_err(format!("{}: {e}", path.display())))
    }

    /// Parses sweep CSV text (see [`Sweep::read_csv`]).
    pub fn parse_csv(text: &str) -> Result<Sweep, SweepError> {
        let csv_header::Split { meta, body, header_line } = csv_header::split(text);
        if body.trim().is_empty() {
            return Err(data_err("no header row and no data (empty file?)"));
        }
        let delimiter = csv_header::delimiter(body);
        let mut reader = csv::ReaderBuilder::new().trim(csv::Trim::All).comment(Some(b'#')).delimiter(delimiter).from_reader(body.as_bytes());
        let headers = reader.headers().map_err(|e| data_err(format!("line {header_line}: {e}")))?.clone();
        let index = csv_header::find(&headers.iter().collect::<Vec<_>>(), &COLUMNS).map_err(|e| data_err(format!("line {header_line}: {e}")))?;
        let mut cols: Vec<Vec<f64>> = vec![Vec::new(); COLUMNS.len()];
        for (r, record) in reader.records().enumerate() {
            let record = record.map_err(|e| data_err(format!("line {}: {}", header_line + 1 + r, csv_header::record_problem(&e))))?;
            let line = record.position().map_or(header_line + 1 + r, |p| header_line + p.line() as usize - 1);
            for (c, found) in index.iter().enumerate() {
                let Some(found) = *found else { continue };
                let value = csv_header::value(record.get(found.index).unwrap_or(""), COLUMNS[c].name, found, delimiter).map_err(|e| data_err(format!("line {line}: {e}")))?;
                let bad = match COLUMNS[c].name {
                    "duty" => (!(0.0..=1.0).contains(&value)).then_some("outside 0..1"),
                    "rload" => (value <= 0.0).then_some("not a positive resistance"),
                    "vin" => (value <= 0.0).then_some("not a positive voltage"),
                    _ => None,
                };
                if let Some(why) = bad {
                    return Err(data_err(format!("line {line}: column `{}` value {value} is {why}", COLUMNS[c].name)));
                }
                cols[c].push(value);
            }
        }
        let n = cols[0].len();
        if n == 0 {
            return Err(data_err("the file has a header but no data rows"));
        }
        let sweep = Sweep { meta, ..Default::default() };
        let column_or_meta = |c: usize, key: &str| -> Result<Option<Vec<f64>>, SweepError> {
            if index[c].is_some() {
                return Ok(Some(cols[c].clone()));
            }
            Ok(sweep.meta_f64(key)?.map(|v| vec![v; n]))
        };
        let vin = column_or_meta(1, "U")?.ok_or_else(|| data_err("column `vin` is missing and no `# U = …` metadata gives it"))?;
        let io = column_or_meta(2, "io")?;
        let rload = column_or_meta(3, "rload")?;
        if io.is_none() && rload.is_none() {
            return Err(data_err("no load: give a column `io` [A] and/or `rload` [Ω] (or `# io = …` / `# rload = …` metadata)"));
        }
        if let Some(r) = rload.as_ref().and_then(|r| r.iter().find(|v| **v <= 0.0)) {
            return Err(data_err(format!("metadata `rload = {r}` is not a positive resistance")));
        }
        let points = (0..n).map(|i| OperatingPoint { duty: cols[0][i], vin: vin[i], io: io.as_ref().map_or(0.0, |v| v[i]), rload: rload.as_ref().map(|v| v[i]) }).collect();
        let il = index[5].is_some().then(|| cols[5].clone());
        Ok(Sweep { points, vout: std::mem::take(&mut cols[4]), il, ..sweep })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_columns_metadata_and_load_kinds() {
        let s = Sweep::parse_csv("# U = 24\n# L = 1e-4\n# fs = 5e4\nduty,rload,vout,x\n0.1,10,1.94,a\n0.2,10,4.25,b\n").unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(s.points[1], OperatingPoint { duty: 0.2, vin: 24.0, io: 0.0, rload: Some(10.0) });
        let (c, assumed) = s.circuit(&Circuit::default()).unwrap();
        assert_eq!((c.l, c.fs), (1e-4, 5e4));
        assert!(assumed.iter().any(|a| a.starts_with("RL = ")), "{assumed:?}");
        let s = Sweep::parse_csv("duty,vin,io,vout,il\n0.5,12,1,5.9,1.01\n").unwrap();
        assert_eq!(s.points[0].rload, None);
        assert_eq!(s.il, Some(vec![1.01]));
    }

    #[test]
    fn bad_files_give_errors_naming_the_problem() {
        let cases = [
            ("", "empty"),
            ("# U = 12\n", "empty"),
            ("duty,vin,io,vout\n", "no data rows"),
            ("duty,vin,io\n0.5,12,1\n", "`vout` is missing"),
            ("vin,io,vout\n12,1,5\n", "`duty` is missing"),
            ("duty,vin,io,vout\n0.5,12,1,5\n0.6,12,1,nan\n", "line 3: column `vout`"),
            ("# U = 12\nduty,io,vout\n0.5,1,5\n0.6,1,abc\n", "line 4: column `vout` value \"abc\""),
            ("duty,vin,io,vout\n1.5,12,1,5\n", "line 2: column `duty` value 1.5 is outside 0..1"),
            ("duty,io,vout\n0.5,1,5\n", "`vin` is missing"),
            ("duty,vin,vout\n0.5,12,5\n", "no load"),
            ("duty,vin,rload,vout\n0.5,12,0,5\n", "not a positive resistance"),
            ("# U = twelve\nduty,io,vout\n0.5,1,5\n", "`U = twelve`"),
            ("duty,vin,io,vout\n0.5,12,1\n", "line 2: the row has 3 fields where the header has 4"),
        ];
        for (text, needle) in cases {
            let err = Sweep::parse_csv(text).unwrap_err().to_string();
            assert!(err.contains(needle), "{text:?}: {err:?} lacks {needle:?}");
        }
    }
}
