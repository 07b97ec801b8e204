//! The header of the project's CSV contracts (time series, sweeps, scope captures): `# key =
//! value` lines, blank lines, then the header row, whose columns are found by name in any case
//! with an optional unit (`Vout [mV]`). One reader for all three, line endings of either kind
//! (Excel and oscilloscopes write CRLF), comma-, semicolon- or tab-separated.
#![forbid(unsafe_code)]

use std::collections::BTreeMap;

/// A CSV text split at its header row.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Split<'a> {
    /// The `# key = value` metadata, keys and values trimmed (comment lines without `=` are
    /// skipped).
    pub meta: BTreeMap<String, String>,
    /// The text from the header row on (empty when there is none).
    pub body: &'a str,
    /// 1-based line number of the header row in the whole text (0 when there is none).
    pub header_line: usize,
}

/// Splits `text` into its metadata and the rest, from the header row on. A UTF-8 byte-order
/// mark at the start is skipped.
///
/// ```
/// let s = csv_header::split("# fs = 330000\r\n\r\ntime,vout\r\n0,1\r\n");
/// assert_eq!(s.meta["fs"], "330000");
/// assert_eq!(s.header_line, 3);
/// assert!(s.body.starts_with("time,vout"));
/// ```
pub fn split(text: &str) -> Split<'_> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut meta = BTreeMap::new();
    let mut start = 0;
    for (i, line) in text.split_inclusive('\n').enumerate() {
        let trimmed = line.trim();
        if let Some(rest) = trimmed.strip_prefix('#') {
            if let Some((k, v)) = rest.split_once('=') {
                meta.insert(k.trim().to_string(), v.trim().to_string());
            }
        } else if !trimmed.is_empty() {
            return Split { meta, body: &text[start..], header_line: i + 1 };
        }
        start += line.len();
    }
    Split { meta, body: "", header_line: 0 }
}

/// The fields of one CSV row split at `delimiter`, trimmed and unquoted (a header row as an
/// oscilloscope writes it: `"TIME","CH1"`).
pub fn fields(row: &str, delimiter: u8) -> Vec<&str> {
    row.trim_end_matches(['\r', '\n']).split(char::from(delimiter)).map(|f| f.trim().trim_matches('"').trim()).collect()
}

/// `header` renamed from the name `from` (any case) to `to`, its unit kept (`CH1 [mV]` →
/// `vout [mV]`, `CH2/mA` → `il [mA]`); `None` where its name is not `from`.
///
/// ```
/// assert_eq!(csv_header::renamed("CH1 [mV]", "ch1", "vout").as_deref(), Some("vout [mV]"));
/// assert_eq!(csv_header::renamed("TIME", "time", "time").as_deref(), Some("time"));
/// assert_eq!(csv_header::renamed("CH2", "CH1", "vout"), None);
/// ```
pub fn renamed(header: &str, from: &str, to: &str) -> Option<String> {
    let (name, unit) = match name_and_unit(header) {
        (_, _, Some((n, u))) if n.eq_ignore_ascii_case(from) => (n, u),
        (name, unit, _) => (name, unit),
    };
    name.eq_ignore_ascii_case(from).then(|| if unit.is_empty() { to.to_string() } else { format!("{to} [{unit}]") })
}

/// A column a contract reads: its name, its SI unit (`""` for a ratio such as the duty), and
/// whether a file must have it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Column {
    /// Its name in the header row (any case).
    pub name: &'static str,
    /// Its SI unit, `""` for a ratio.
    pub unit: &'static str,
    /// A file without it is an error.
    pub required: bool,
}

impl Column {
    /// A column every file must have.
    pub const fn required(name: &'static str, unit: &'static str) -> Self {
        Self { name, unit, required: true }
    }

    /// A column a file may have.
    pub const fn optional(name: &'static str, unit: &'static str) -> Self {
        Self { name, unit, required: false }
    }
}

/// Where a column was found in the header row, and the power of ten that takes its values to SI.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Found {
    /// Its position in the row.
    pub index: usize,
    /// The unit its header names is `10^power` of the SI unit (0 without one).
    pub power: i32,
}

impl Found {
    /// `v` in the header's unit, in SI: divided by a power of ten below 1 (exact powers of ten,
    /// so that `1940` mV is the double nearest 1.94 V, as if written in volts).
    pub fn si(&self, v: f64) -> f64 {
        let ten = 10f64.powi(self.power.abs());
        if self.power < 0 { v / ten } else { v * ten }
    }
}

/// What is wrong with a record the csv crate refused, in the file's terms (its own message
/// counts records and lines from the header row, beside the file's line the caller names). A
/// row of the wrong length says so with the likely cause: `"the row has 4 fields where the
/// header has 5 (a value missing, or the row cut short?)"`.
pub fn record_problem(e: &csv::Error) -> String {
    let csv::ErrorKind::UnequalLengths { expected_len, len, .. } = *e.kind() else { return e.to_string() };
    let why = if len < expected_len { "a value missing, or the row cut short" } else { "a delimiter inside a value, e.g. a decimal comma" };
    format!("the row has {len} fields where the header has {expected_len} ({why}?)")
}

/// The field delimiter of a header row: a comma, or a semicolon or tab where the row has no
/// comma (a spreadsheet's export where the decimal separator is a comma; tab-separated text).
///
/// ```
/// assert_eq!(csv_header::delimiter("time;vout\r\n"), b';');
/// assert_eq!(csv_header::delimiter("time,vout"), b',');
/// ```
pub fn delimiter(header_row: &str) -> u8 {
    let row = header_row.lines().next().unwrap_or("");
    if row.contains(',') {
        b','
    } else if row.contains(';') {
        b';'
    } else if row.contains('\t') {
        b'\t'
    } else {
        b','
    }
}

/// The value in `field` of the column `name` found as `found`, in SI; where the delimiter is not
/// a comma, a decimal comma is read as a point. An error names the column and the field when it
/// is not a finite number.
pub fn value(field: &str, name: &str, found: Found, delimiter: u8) -> Result<f64, String> {
    let v = number(field, delimiter).ok_or_else(|| format!("column `{name}` value {field:?} is not a number"))?;
    if !v.is_finite() {
        return Err(format!("column `{name}` value {field:?} is not finite"));
    }
    Ok(found.si(v))
}

/// A field as a number, a decimal comma read as a point where the delimiter is not a comma
/// (`None` where it is not a number; `nan` and `inf` are numbers here, not finite ones).
///
/// ```
/// assert_eq!(csv_header::number("0,25", b';'), Some(0.25));
/// assert_eq!(csv_header::number("0,25", b','), None);
/// ```
pub fn number(field: &str, delimiter: u8) -> Option<f64> {
    match field.parse() {
        Ok(v) => Some(v),
        Err(_) if delimiter != b',' && field.matches(',').count() == 1 && !field.contains('.') => field.replace(',', ".").parse().ok(),
        Err(_) => None,
    }
}

/// SI prefixes a unit may carry, with their powers of ten.
const PREFIXES: [(&str, i32); 8] = [("p", -12), ("n", -9), ("u", -6), ("µ", -6), ("μ", -6), ("m", -3), ("k", 3), ("M", 6)];

/// The power of ten from `unit` (as written in a header) to the SI unit `si`, if it is one of
/// its.
fn power(unit: &str, si: &str) -> Option<i32> {
    // Spellings of the ohm: the Greek capital, the ohm sign, the word.
    let unit = ["Ohm", "ohm", "\u{2126}"].iter().find_map(|w| unit.strip_suffix(w)).filter(|_| si == "Ω").map_or_else(|| unit.to_string(), |p| format!("{p}Ω"));
    // No unit written: the contract's own.
    if unit.is_empty() {
        return Some(0);
    }
    if si.is_empty() {
        return match unit.as_str() {
            "1" => Some(0),
            "%" => Some(-2),
            _ => None,
        };
    }
    match unit.strip_suffix(si)? {
        "" => Some(0),
        prefix => PREFIXES.iter().find(|(p, _)| *p == prefix).map(|(_, e)| *e),
    }
}

/// A header split into its name and the unit in brackets or parentheses after it (`""` when
/// there is none), and, where there is none, the unit after a slash (`Vout/mV`, the
/// quantity-over-unit style of many exports), which may also be a ratio of two columns.
fn name_and_unit(header: &str) -> (&str, &str, Option<(&str, &str)>) {
    let header = header.trim();
    for (open, close) in [('[', ']'), ('(', ')')] {
        if let Some(inner) = header.strip_suffix(close)
            && let Some((name, unit)) = inner.rsplit_once(open)
        {
            return (name.trim(), unit.trim(), None);
        }
    }
    (header, "", header.rsplit_once('/').map(|(name, unit)| (name.trim(), unit.trim())))
}

/// Finds `wanted` among `headers`. A header names a column when it is the column's name in any
/// case, alone or followed by a unit in brackets, parentheses or after a slash (`Vout [mV]`,
/// `time (ms)`, `IL/A`):
/// the column's SI unit with or without a prefix (`p n µ u m k M`), or `%` for a ratio. A unit
/// of another quantity, two headers for one column, or a required column missing is an error
/// naming it.
///
/// ```
/// use csv_header::{Column, find};
/// let wanted = [Column::required("time", "s"), Column::required("vout", "V")];
/// let found = find(&["Time [ms]", "extra", "VOUT (V)"], &wanted).unwrap();
/// assert_eq!(found[0].map(|f| (f.index, f.power)), Some((0, -3)));
/// assert_eq!(found[1].map(|f| f.index), Some(2));
/// assert!(find(&["time", "vout [A]"], &wanted).unwrap_err().contains("not a unit of"));
/// ```
pub fn find(headers: &[&str], wanted: &[Column]) -> Result<Vec<Option<Found>>, String> {
    wanted
        .iter()
        .map(|col| {
            let mut found: Option<(Found, &str)> = None;
            for (index, header) in headers.iter().enumerate() {
                // `name/unit` names the column only with a unit of its (`vout/vin` is a ratio).
                let (name, unit) = match name_and_unit(header) {
                    (_, _, Some((n, u))) if n.eq_ignore_ascii_case(col.name) && power(u, col.unit).is_some() => (n, u),
                    (name, unit, _) => (name, unit),
                };
                if !name.eq_ignore_ascii_case(col.name) {
                    continue;
                }
                let Some(power) = power(unit, col.unit) else {
                    let si = if col.unit.is_empty() { "a ratio (none, or %)".to_string() } else { format!("{} (or with a prefix: m{0}, µ{0}, k{0}…)", col.unit) };
                    return Err(format!("column `{header}`: `{unit}` is not a unit of `{}`, which is read in {si}", col.name));
                };
                if let Some((_, first)) = found {
                    return Err(format!("two columns are `{}`: `{first}` and `{header}`", col.name));
                }
                found = Some((Found { index, power }, header));
            }
            if found.is_none() && col.required {
                return Err(format!("required column `{}` is missing (found: {})", col.name, headers.join(", ")));
            }
            Ok(found.map(|(f, _)| f))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lf_crlf_and_a_byte_order_mark_split_alike() {
        for text in ["# a = 1\n# note\n\nx,y\n1,2\n", "# a = 1\r\n# note\r\n\r\nx,y\r\n1,2\r\n", "\u{feff}# a = 1\n# note\n\nx,y\n1,2\n"] {
            let s = split(text);
            assert_eq!(s.meta.len(), 1, "{text:?}");
            assert_eq!(s.meta["a"], "1");
            assert_eq!(s.header_line, 4);
            assert!(s.body.starts_with("x,y"), "{:?}", s.body);
        }
    }

    #[test]
    fn no_header_row_leaves_an_empty_body() {
        let s = split("# only = metadata\n\n");
        assert_eq!((s.body, s.header_line), ("", 0));
        assert_eq!(split(""), Split { meta: BTreeMap::new(), body: "", header_line: 0 });
    }

    #[test]
    fn headers_are_found_in_any_case_with_a_unit_of_theirs() {
        let wanted = [Column::required("time", "s"), Column::optional("duty", ""), Column::optional("il", "A"), Column::optional("rload", "Ω")];
        let found = find(&["Time (us)", "DUTY [%]", "IL/mA", "rload [kOhm]"], &wanted).unwrap();
        let powers: Vec<i32> = found.iter().map(|f| f.unwrap().power).collect();
        assert_eq!(powers, [-6, -2, -3, 3]);
        let millivolts = Found { index: 0, power: -3 };
        assert_eq!(millivolts.si(1940.0), 1.94, "as if written in volts");
        assert_eq!(Found { index: 0, power: 3 }.si(2.2), 2200.0);
        assert_eq!(find(&["time", "x"], &wanted).unwrap()[1], None, "an optional column may be absent");
        assert_eq!(find(&["time", "il/vout"], &wanted).unwrap()[2], None, "a ratio of two columns is another column");
        let cases: [(&[&str], &str); 4] = [
            (&["time [V]"], "`V` is not a unit of `time`"),
            (&["time", "duty [ms]"], "which is read in a ratio"),
            (&["time", "il", "IL [A]"], "two columns are `il`: `il` and `IL [A]`"),
            (&["t", "vout"], "required column `time` is missing (found: t, vout)"),
        ];
        for (headers, needle) in cases {
            let err = find(headers, &wanted).unwrap_err();
            assert!(err.contains(needle), "{headers:?}: {err:?} lacks {needle:?}");
        }
    }

    #[test]
    fn a_semicolon_or_tab_separated_export_reads_a_decimal_comma() {
        assert_eq!((delimiter("a;b"), delimiter("a\tb"), delimiter("a")), (b';', b'\t', b','));
        assert_eq!(number("1,5", b';'), Some(1.5));
        assert_eq!(number("-2,5e-3", b'\t'), Some(-2.5e-3));
        assert_eq!(number("1,5", b','), None, "a comma-separated file has no decimal comma");
        assert_eq!(number("1.000,5", b';'), None, "thousands separators are not guessed");
    }
}
