//! Oscilloscope captures reduced to the data contract: one row per complete switching period.
//!
//! A capture has many samples per period (e.g. 100 MS/s at 330 kHz) of `time` and `vout`, and
//! optionally `il`, `sw` (switch node), `gate` and `vin`. The period boundaries are the rising
//! edges of `gate` (preferred: a diode buck's switch node rings back to `vout` in DCM) or `sw`:
//! threshold at the middle between robust low and high levels (2nd and 98th percentiles),
//! hysteresis of ±10 % of the swing against noise, sub-sample timing by linear interpolation
//! of the mid-level crossing. Without edges the periods come from `fs` (given or `# fs`), their
//! phase from the valley of the folded inductor current when `il` is recorded. Each row: the
//! period start `time`, `duty` = (falling − rising)/T from the edges (from the peak of `il`
//! without edges), `vout`/`il` at the start (a line through the quiet stretch before the edge,
//! extrapolated to it: see `at_start`), `vout_avg`/`il_avg` by the trapezoid rule over the
//! period, `vin` as the period average when recorded.
//!
//! A capture comes as one file of all its channels ([`Capture::parse_csv`], an oscilloscope's
//! export with its columns named: [`Capture::parse_csv_with`]) or as one file per channel
//! ([`Trace`], [`Capture::from_traces`]).
#![forbid(unsafe_code)]

use std::collections::BTreeMap;

use csv_header::Column;

mod trace;
pub use trace::Trace;

/// What went wrong reading or reducing a capture.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CaptureError {
    /// The capture breaks its contract (the message names the line or the problem).
    #[error("{0}")]
    Data(String),
    /// The period boundaries cannot be found.
    #[error("{0}")]
    Periods(String),
}

fn data_err(m: impl Into<String>) -> CaptureError {
    CaptureError::Data(m.into())
}

/// A capture: samples of each recorded signal at `time`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Capture {
    /// Sample times \[s\], strictly increasing.
    pub time: Vec<f64>,
    /// Output voltage \[V\].
    pub vout: Vec<f64>,
    /// Inductor current \[A\].
    pub il: Option<Vec<f64>>,
    /// Switch-node voltage \[V\].
    pub sw: Option<Vec<f64>>,
    /// Gate drive of the high-side switch \[V\].
    pub gate: Option<Vec<f64>>,
    /// Input voltage \[V\].
    pub vin: Option<Vec<f64>>,
    /// `# key = value` metadata.
    pub meta: BTreeMap<String, String>,
}

const COLUMNS: [Column; 6] =
    [Column::required("time", "s"), Column::required("vout", "V"), Column::optional("il", "A"), Column::optional("sw", "V"), Column::optional("gate", "V"), Column::optional("vin", "V")];

/// The `(start, increment)` of a time column that numbers the samples (`Sequence` in the units
/// row `record`, at the time column `time`): a Rigol's export, whose `Start` and `Increment`
/// columns hold them in that row. `None` for a time column in seconds.
fn sample_sequence(headers: &[String], record: &csv::StringRecord, time: Option<usize>) -> Result<Option<(f64, f64)>, String> {
    if !time.and_then(|i| record.get(i)).is_some_and(|u| u.eq_ignore_ascii_case("sequence")) {
        return Ok(None);
    }
    let at = |name: &str| -> Result<f64, String> {
        let field = headers.iter().position(|h| h.eq_ignore_ascii_case(name)).and_then(|i| record.get(i));
        field.and_then(|v| v.parse::<f64>().ok()).filter(|v| v.is_finite()).ok_or_else(|| format!("the time column numbers the samples (`Sequence`) but the row has no `{name}` to time them by"))
    };
    let (start, increment) = (at("Start")?, at("Increment")?);
    if increment <= 0.0 {
        return Err(format!("the samples' `Increment` {increment:e} s is not positive"));
    }
    Ok(Some((start, increment)))
}

/// Lines an oscilloscope's preamble (its settings before the header row) may take.
const PREAMBLE_LINES: usize = 64;

/// A column of the contract under the capture's own name (`vout` as `CH1`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Named<'a> {
    /// The contract's name: `time`, `vout`, `il`, `sw`, `gate` or `vin`.
    pub column: &'a str,
    /// The capture's name of it, as its header row has it (without the unit).
    pub header: &'a str,
    /// What the values, as written, are multiplied by to give the column's SI unit, the
    /// header's unit then set aside: a current read in volts across a shunt, in amperes per
    /// volt (`None`: the values as the header's unit has them).
    pub scale: Option<f64>,
}

/// A header row with the capture's own names of the contract's columns (`named`) renamed to
/// them, as `csv_header::find` reads it (without its unit where a scale replaces it).
fn mapped_headers(row: &[&str], named: &[Named]) -> Vec<String> {
    let rename = |h: &str, n: &Named| csv_header::renamed(h, n.header, n.column).map(|r| if n.scale.is_some() { n.column.to_string() } else { r });
    row.iter().map(|h| named.iter().find_map(|n| rename(h, n)).unwrap_or_else(|| (*h).to_string())).collect()
}

impl Capture {
    /// Parses capture CSV text: `# key = value` lines, a header, then numbers; `time` and
    /// `vout` required, unknown columns ignored.
    pub fn parse_csv(text: &str) -> Result<Capture, CaptureError> {
        Self::parse_csv_with(text, &[])
    }

    /// [`Capture::parse_csv`] for an oscilloscope's own export: `map` gives the capture's names
    /// of the contract's columns ([`Named`]: `vout` as `CH1`, `time` as `TIME`), the header row
    /// is the first of the first `PREAMBLE_LINES` that names `time` and `vout` (the lines
    /// before it, the scope's settings, are skipped), and a row of units right after it
    /// (`second,Volt`) is skipped too.
    pub fn parse_csv_with(text: &str, map: &[Named]) -> Result<Capture, CaptureError> {
        if let Some(n) = map.iter().find(|n| !COLUMNS.iter().any(|c| c.name == n.column)) {
            let names: Vec<&str> = COLUMNS.iter().map(|c| c.name).collect();
            return Err(data_err(format!("`{}` is not a column of a capture (one of {})", n.column, names.join(", "))));
        }
        if let Some(n) = map.iter().find(|n| n.scale.is_some_and(|k| !(k.is_finite() && k != 0.0))) {
            return Err(data_err(format!("the scale of `{}` must be a finite number other than zero", n.column)));
        }
        let csv_header::Split { meta, body, header_line } = csv_header::split(text);
        if body.trim().is_empty() {
            return Err(data_err("no header row and no data (empty file?)"));
        }
        // The header row: the first that names the required columns; where none does, the
        // first row's error says what is missing.
        let named = |row: &str| csv_header::find(&mapped_headers(&csv_header::fields(row, csv_header::delimiter(row)), map).iter().map(String::as_str).collect::<Vec<_>>(), &COLUMNS);
        let first = body.lines().next().unwrap_or("");
        let preamble = body.split_inclusive('\n').take(PREAMBLE_LINES).position(|row| named(row).is_ok());
        let Some(skipped) = preamble else {
            let why = named(first).err().unwrap_or_default();
            let missing = why.contains("is missing");
            let hint = if map.is_empty() && missing { "; an oscilloscope's export names its columns itself: map them, e.g. `--column vout=CH1 --column time=TIME`" } else { "" };
            return Err(data_err(format!("line {header_line}: {why}{hint}")));
        };
        let body: &str = &body[body.split_inclusive('\n').take(skipped).map(str::len).sum::<usize>()..];
        let header_line = header_line + skipped;
        let delimiter = csv_header::delimiter(body);
        let mut reader = csv::ReaderBuilder::new().trim(csv::Trim::All).delimiter(delimiter).flexible(true).from_reader(body.as_bytes());
        let headers = reader.headers().map_err(|e| data_err(format!("line {header_line}: {e}")))?.clone();
        let headers = mapped_headers(&headers.iter().collect::<Vec<_>>(), map);
        let index = csv_header::find(&headers.iter().map(String::as_str).collect::<Vec<_>>(), &COLUMNS).map_err(|e| data_err(format!("line {header_line}: {e}")))?;
        let mut cols: Vec<Vec<f64>> = vec![Vec::new(); COLUMNS.len()];
        let mut record = csv::StringRecord::new();
        let mut line = header_line;
        // The time of a sample numbered in sequence: its start and increment (see `sample_sequence`).
        let mut sequence: Option<(f64, f64)> = None;
        loop {
            line += 1;
            match reader.read_record(&mut record) {
                Ok(true) => {}
                Ok(false) => break,
                Err(e) => return Err(data_err(format!("line {line}: {e}"))),
            }
            // A row of units under the header (`second,Volt,Volt`): no field of it is a number.
            let units = line == header_line + 1 && index.iter().flatten().all(|f| record.get(f.index).is_some_and(|v| v.parse::<f64>().is_err()));
            if units {
                sequence = sample_sequence(&headers, &record, index[0].map(|f| f.index)).map_err(|e| data_err(format!("line {line}: {e}")))?;
                continue;
            }
            for (c, found) in index.iter().enumerate() {
                let Some(found) = *found else { continue };
                let v = csv_header::value(record.get(found.index).unwrap_or(""), COLUMNS[c].name, found, delimiter).map_err(|e| data_err(format!("line {line}: {e}")))?;
                cols[c].push(v);
            }
            let n = cols[0].len();
            if n >= 2 && cols[0][n - 1] <= cols[0][n - 2] {
                return Err(data_err(format!("line {line}: `time` {} does not increase (previous {})", cols[0][n - 1], cols[0][n - 2])));
            }
        }
        if cols[0].is_empty() {
            return Err(data_err("the file has a header but no data rows"));
        }
        if let Some((start, increment)) = sequence {
            cols[0].iter_mut().for_each(|k| *k = start + *k * increment);
        }
        for n in map {
            if let (Some(k), Some(c)) = (n.scale, COLUMNS.iter().position(|c| c.name == n.column)) {
                cols[c].iter_mut().for_each(|v| *v *= k);
            }
        }
        let opt = |c: usize, cols: &mut Vec<Vec<f64>>| index[c].is_some().then(|| std::mem::take(&mut cols[c]));
        Ok(Capture { il: opt(2, &mut cols), sw: opt(3, &mut cols), gate: opt(4, &mut cols), vin: opt(5, &mut cols), time: std::mem::take(&mut cols[0]), vout: std::mem::take(&mut cols[1]), meta })
    }
}

/// The capture reduced to one row per complete period (the data contract's columns).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Periods {
    /// Period starts \[s\].
    pub time: Vec<f64>,
    /// Duty measured per period.
    pub duty: Vec<f64>,
    /// vout at each period start \[V\].
    pub vout: Vec<f64>,
    /// il at each period start \[A\].
    pub il: Option<Vec<f64>>,
    /// vout averaged over each period \[V\].
    pub vout_avg: Vec<f64>,
    /// il averaged over each period \[A\].
    pub il_avg: Option<Vec<f64>>,
    /// vin averaged over each period \[V\].
    pub vin: Option<Vec<f64>>,
    /// Mean switching frequency measured \[Hz\].
    pub fs: f64,
    /// How the boundaries were found (for the user).
    pub source: String,
}

/// Whether a `period` holds at least [`MIN_SAMPLES_PER_PERIOD`] samples `dt` apart.
fn enough_samples(period: f64, dt: f64) -> Result<(), CaptureError> {
    if period / dt < MIN_SAMPLES_PER_PERIOD {
        return Err(CaptureError::Periods(format!("too few samples per period: {:.1} (sample spacing {dt:e} s, period {period:e} s); at least {MIN_SAMPLES_PER_PERIOD} are needed", period / dt)));
    }
    Ok(())
}

/// Robust low/high levels: the 2nd and 98th percentiles.
fn levels(x: &[f64]) -> (f64, f64) {
    let mut s = x.to_vec();
    s.sort_by(f64::total_cmp);
    let at = |q: f64| s[((s.len() - 1) as f64 * q).round() as usize];
    (at(0.02), at(0.98))
}

/// Rising and falling mid-level crossings with hysteresis, timed by linear interpolation.
fn edges(t: &[f64], x: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (lo, hi) = levels(x);
    let mid = 0.5 * (lo + hi);
    let hyst = 0.1 * (hi - lo);
    let (mut rising, mut falling) = (Vec::new(), Vec::new());
    // Also false for NaN levels.
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return (rising, falling);
    }
    let mut state: Option<bool> = None; // Some(true): high
    let mut last_cross = 0; // last index where x crossed mid
    for i in 0..x.len() {
        if i > 0 && (x[i - 1] - mid) * (x[i] - mid) <= 0.0 && x[i - 1] != x[i] {
            last_cross = i;
        }
        let now = if x[i] > mid + hyst {
            Some(true)
        } else if x[i] < mid - hyst {
            Some(false)
        } else {
            state
        };
        if let (Some(before), Some(after)) = (state, now)
            && before != after
            && last_cross > 0
        {
            let j = last_cross;
            let f = (mid - x[j - 1]) / (x[j] - x[j - 1]);
            let tc = t[j - 1] + f * (t[j] - t[j - 1]);
            if after { rising.push(tc) } else { falling.push(tc) }
        }
        state = now;
    }
    (rising, falling)
}

/// Linear interpolation of `x(t)` at `tq` (inside the record).
fn interp(t: &[f64], x: &[f64], tq: f64) -> f64 {
    let j = t.partition_point(|v| *v <= tq).clamp(1, t.len() - 1);
    let f = (tq - t[j - 1]) / (t[j] - t[j - 1]);
    x[j - 1] + f * (x[j] - x[j - 1])
}

/// Trapezoid average of `x` over `[a, b]` with interpolated ends.
fn average(t: &[f64], x: &[f64], a: f64, b: f64) -> f64 {
    let i0 = t.partition_point(|v| *v <= a);
    let i1 = t.partition_point(|v| *v < b);
    let mut pts: Vec<(f64, f64)> = vec![(a, interp(t, x, a))];
    pts.extend((i0..i1).map(|i| (t[i], x[i])));
    pts.push((b, interp(t, x, b)));
    pts.windows(2).map(|w| 0.5 * (w[0].1 + w[1].1) * (w[1].0 - w[0].0)).sum::<f64>() / (b - a)
}

/// Least samples per period for a meaningful reduction.
pub const MIN_SAMPLES_PER_PERIOD: f64 = 8.0;

/// Stretch before a period's start left out of its start value, as a fraction of the period:
/// the switch node starts to move (and a probe's `vout` to ring) before the edge's mid-level.
const START_GUARD: f64 = 0.01;
/// Stretch before that guard whose samples give a period's start value, as a fraction of the
/// period (never reaching back past the previous falling edge, into the on-time).
const START_SPAN: f64 = 0.1;
/// Fewest samples in that stretch for a straight line through them; with fewer, the start value
/// is interpolated at the edge.
const START_SAMPLES: usize = 4;

/// `x` at a period start `a`: the least-squares line through the samples of the quiet stretch
/// `[from, a − guard]` before it, `from` = `a − guard − span` but not before `off` (the previous
/// falling edge plus the guard) nor the capture's start, extrapolated to `a`. Between edges
/// `vout` and `il` are smooth (straight to within the ripple's curvature over a tenth of a
/// period), so the line averages a scope's noise and its 8-bit steps over the stretch and keeps
/// off the edge's spike; with too few samples there (a capture that begins at the edge), the
/// value interpolated at `a`.
fn at_start(t: &[f64], x: &[f64], a: f64, period: f64, off: Option<f64>) -> f64 {
    let guard = START_GUARD * period;
    let from = (a - guard - START_SPAN * period).max(off.map_or(f64::NEG_INFINITY, |f| f + guard));
    let (i0, i1) = (t.partition_point(|v| *v < from), t.partition_point(|v| *v <= a - guard));
    if i1 < i0 + START_SAMPLES {
        return interp(t, x, a);
    }
    let n = (i1 - i0) as f64;
    let (mt, mx) = (t[i0..i1].iter().map(|v| v - a).sum::<f64>() / n, x[i0..i1].iter().sum::<f64>() / n);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (ti, xi) in t[i0..i1].iter().zip(&x[i0..i1]) {
        let dt = ti - a - mt;
        sxy += dt * (xi - mx);
        sxx += dt * dt;
    }
    mx - mt * sxy / sxx
}

/// Reduces a capture to one row per complete period; `fs` \[Hz\] is used when the capture has
/// no switching edges (else `# fs`).
pub fn reduce(cap: &Capture, fs: Option<f64>) -> Result<Periods, CaptureError> {
    let t = &cap.time;
    if t.len() < 3 {
        return Err(data_err(format!("the capture has {} samples; far too few", t.len())));
    }
    let dt = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    let meta_fs = match cap.meta.get("fs") {
        Some(v) => Some(v.parse::<f64>().map_err(|_| data_err(format!("metadata `fs = {v}` is not a number")))?),
        None => None,
    };
    let mut found = None;
    for (name, sig) in [("gate", &cap.gate), ("sw", &cap.sw)] {
        if let Some(x) = sig {
            let (r, f) = edges(t, x);
            if r.len() >= 2 {
                found = Some((name, r, f));
                break;
            }
        }
    }
    let (boundaries, falling, source) = match found {
        Some((name, r, f)) => (r, Some(f), format!("rising edges of `{name}`")),
        None => {
            let fs = fs
                .or(meta_fs)
                .filter(|f| f.is_finite() && *f > 0.0)
                .ok_or_else(|| CaptureError::Periods("no switching edges found (no `sw` or `gate` column, or no two rising edges in it) and no switching frequency given (--fs or `# fs`)".into()))?;
            let period = 1.0 / fs;
            // Phase: the valley of the inductor current folded over one period is the period start.
            let (phase, how) = match &cap.il {
                Some(il) => {
                    let bins = 64;
                    let mut sum = vec![0.0; bins];
                    let mut cnt = vec![0usize; bins];
                    for (ti, v) in t.iter().zip(il) {
                        let b = ((((ti - t[0]) / period).fract()) * bins as f64) as usize % bins;
                        sum[b] += v;
                        cnt[b] += 1;
                    }
                    let mean: Vec<f64> = sum.iter().zip(&cnt).map(|(s, c)| if *c > 0 { s / *c as f64 } else { f64::INFINITY }).collect();
                    let k = (0..bins).min_by(|a, b| mean[*a].total_cmp(&mean[*b])).unwrap_or(0);
                    ((k as f64 + 0.5) / bins as f64 * period, "phase from the valley of il")
                }
                None => (0.0, "phase: the first sample (no il to find it from)"),
            };
            // Checked before the boundaries are laid: a capture whose times span far more
            // periods than it has samples would otherwise ask for billions of them.
            enough_samples(period, dt)?;
            let first = t[0] + phase;
            let count = ((t[t.len() - 1] - first) / period).floor() as usize + 1;
            ((0..count).map(|k| first + k as f64 * period).collect(), None, format!("fs = {fs} Hz given, {how}"))
        }
    };
    if boundaries.len() < 2 {
        return Err(CaptureError::Periods("fewer than one complete period in the capture".into()));
    }
    let mean_period = (boundaries[boundaries.len() - 1] - boundaries[0]) / (boundaries.len() - 1) as f64;
    enough_samples(mean_period, dt)?;
    let mut out = Periods { fs: 1.0 / mean_period, source, ..Periods::default() };
    let (mut il0, mut il_avg, mut vin) = (Vec::new(), Vec::new(), Vec::new());
    for w in boundaries.windows(2) {
        let (a, b) = (w[0], w[1]);
        let duty = match &falling {
            Some(f) => {
                let k = f.partition_point(|v| *v <= a);
                match f.get(k) {
                    Some(fe) if *fe < b => (fe - a) / (b - a),
                    _ => return Err(CaptureError::Periods(format!("no falling edge between the rising edges at {a:e} s and {b:e} s"))),
                }
            }
            None => match &cap.il {
                Some(il) => {
                    let i0 = t.partition_point(|v| *v < a);
                    let i1 = t.partition_point(|v| *v < b);
                    let k = (i0..i1).max_by(|x, y| il[*x].total_cmp(&il[*y])).unwrap_or(i0);
                    (t[k] - a) / (b - a)
                }
                None => return Err(CaptureError::Periods("the duty cannot be measured: no `sw`/`gate` edges and no `il`".into())),
            },
        };
        // The off-time before this start begins at the last falling edge before it.
        let off = falling.as_ref().and_then(|f| f[..f.partition_point(|v| *v < a)].last().copied());
        out.time.push(a);
        out.duty.push(duty);
        out.vout.push(at_start(t, &cap.vout, a, mean_period, off));
        out.vout_avg.push(average(t, &cap.vout, a, b));
        if let Some(il) = &cap.il {
            il0.push(at_start(t, il, a, mean_period, off));
            il_avg.push(average(t, il, a, b));
        }
        if let Some(v) = &cap.vin {
            vin.push(average(t, v, a, b));
        }
    }
    if cap.il.is_some() {
        out.il = Some(il0);
        out.il_avg = Some(il_avg);
    }
    if cap.vin.is_some() {
        out.vin = Some(vin);
    }
    Ok(out)
}

/// The data-contract CSV of `periods`: metadata (`# fs` measured, the capture's other keys),
/// then `time,duty[,vin],vout[,il],vout_avg[,il_avg]`.
pub fn to_csv(p: &Periods, meta: &BTreeMap<String, String>) -> String {
    let mut m = meta.clone();
    if let Some(f) = m.remove("fs") {
        m.insert("fs_given".into(), f);
    }
    m.insert("fs".into(), format!("{:e}", p.fs));
    m.insert("periods_from".into(), p.source.clone());
    let mut s: String = m.iter().map(|(k, v)| format!("# {k} = {v}\n")).collect();
    let mut cols: Vec<(&str, &Vec<f64>)> = vec![("time", &p.time), ("duty", &p.duty)];
    if let Some(v) = &p.vin {
        cols.push(("vin", v));
    }
    cols.push(("vout", &p.vout));
    if let Some(v) = &p.il {
        cols.push(("il", v));
    }
    cols.push(("vout_avg", &p.vout_avg));
    if let Some(v) = &p.il_avg {
        cols.push(("il_avg", v));
    }
    s.push_str(&cols.iter().map(|c| c.0).collect::<Vec<_>>().join(","));
    s.push('\n');
    for i in 0..p.time.len() {
        s.push_str(&cols.iter().map(|c| format!("{:e}", c.1[i])).collect::<Vec<_>>().join(","));
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic square wave: duty 0.3 at 100 kHz sampled at 9.73 MS/s, vout a ramp.
    fn square() -> Capture {
        let (fs, rate) = (100e3, 9.73e6);
        let n = (20.0 / fs * rate) as usize;
        let time: Vec<f64> = (0..n).map(|i| 1e-7 + i as f64 / rate).collect();
        let sw = time.iter().map(|t| if (t * fs).fract() < 0.3 { 12.0 } else { 0.0 }).collect();
        let vout = time.iter().map(|t| 5.0 + t * 1e3).collect();
        Capture { time, vout, sw: Some(sw), ..Capture::default() }
    }

    #[test]
    fn square_wave_gives_its_duty_and_frequency() {
        let p = reduce(&square(), None).unwrap();
        assert_eq!(p.time.len(), 18); // rising edges at 10, 20, …, 190 µs
        assert!((p.fs - 100e3).abs() < 100e3 * 1e-3, "{}", p.fs);
        // One sample spacing (103 ns) of 10 µs bounds the timing error of a step edge.
        assert!(p.duty.iter().all(|d| (d - 0.3).abs() < 0.011), "{:?}", p.duty);
        // vout is a ramp (1 mV/µs): the trapezoid average is the value at mid-period, up to the
        // edge timing error (< one sample spacing, 103 ns → 0.1 mV).
        for (i, a) in p.vout_avg.iter().enumerate() {
            let mid = 5.0 + (p.time[i] + 5e-6) * 1e3;
            assert!((a - mid).abs() < 1e-4, "{a} vs {mid}");
        }
    }

    /// `cap`'s time, vout and switch node as CSV rows under `header`, after `preamble`.
    fn export(cap: &Capture, preamble: &str, header: &str) -> String {
        let rows = cap.time.iter().zip(&cap.vout).zip(cap.sw.as_ref().unwrap()).map(|((t, v), w)| format!("{t:e},{v},{w}\n"));
        format!("{preamble}{header}\n") + &rows.collect::<String>()
    }

    /// Exports as oscilloscopes write them, their columns named with `--column`: a Tektronix
    /// MSO's (settings before the header row, quoted names), a Keysight InfiniiVision's (a row
    /// of units under the header), one in millivolts, a Rigol's (numbered samples, timed by the
    /// units row) and a switch node read through a divider; each reads as the same capture.
    #[test]
    fn an_oscilloscopes_export_reads_with_its_columns_named() {
        let square = square();
        let plain = Capture::parse_csv(&export(&square, "", "time,vout,sw")).unwrap();
        let tek = "Model,MSO54\nFirmware Version,1.28\n\nWaveform Type,ANALOG\nPoint Format,Y\nHorizontal Units,s\nSample Interval,1.0277e-07\nRecord Length,19\n";
        let named = |column, header| Named { column, header, scale: None };
        let map = [named("time", "TIME"), named("vout", "CH1"), named("sw", "CH3")];
        assert_eq!(Capture::parse_csv_with(&export(&square, tek, "\"TIME\",\"CH1\",\"CH3\""), &map).unwrap(), plain);
        let keysight = [named("time", "x-axis"), named("vout", "1"), named("sw", "3")];
        assert_eq!(Capture::parse_csv_with(&export(&square, "", "x-axis,1,3\nsecond,Volt,Volt"), &keysight).unwrap(), plain);
        let milli = Capture { vout: square.vout.iter().map(|v| v * 1e3).collect(), ..square.clone() };
        let read = Capture::parse_csv_with(&export(&milli, "", "TIME,CH1 [mV],CH3"), &map).unwrap();
        assert!(read.vout.iter().zip(&plain.vout).all(|(a, b)| (a - b).abs() < 1e-12), "millivolts read as volts");
        // Unnamed, the export says what is missing and how to name it.
        let e = Capture::parse_csv(&export(&square, tek, "TIME,CH1,CH3")).unwrap_err().to_string();
        assert!(e.contains("line 1: required column `time` is missing") && e.contains("--column vout=CH1"), "{e}");
        // A Rigol's: the samples numbered, their start and increment in the units row.
        let rate = 9.73e6;
        let rows: String = square.vout.iter().zip(square.sw.as_ref().unwrap()).enumerate().map(|(k, (v, w))| format!("{k},{v},{w},\n")).collect();
        let rigol = format!("X,CH1,CH3,Start,Increment,\nSequence,Volt,Volt,{:e},{:e}\n{rows}", 1e-7, 1.0 / rate);
        let read = Capture::parse_csv_with(&rigol, &[named("time", "X"), map[1], map[2]]).unwrap();
        assert!(read.time.iter().zip(&plain.time).all(|(a, b)| (a - b).abs() < 1e-15), "the samples timed by start and increment");
        assert_eq!((read.vout, read.sw), (plain.vout.clone(), plain.sw.clone()));
        let e = Capture::parse_csv_with(&rigol.replace(",Increment,", ",Step,"), &[named("time", "X"), map[1], map[2]]).unwrap_err().to_string();
        assert!(e.contains("line 2: the time column numbers the samples (`Sequence`) but the row has no `Increment`"), "{e}");
        // The switch node read through a 10:1 divider in volts: scaled, its unit set aside.
        let divided = Capture { sw: Some(square.sw.as_ref().unwrap().iter().map(|v| v / 10.0).collect()), ..square.clone() };
        let scaled = [map[0], map[1], Named { scale: Some(10.0), ..named("sw", "CH3") }];
        let read = Capture::parse_csv_with(&export(&divided, "", "TIME,CH1,CH3 [V]"), &scaled).unwrap();
        assert!(read.sw.unwrap().iter().zip(plain.sw.as_ref().unwrap()).all(|(a, b)| (a - b).abs() < 1e-12));
        let e = Capture::parse_csv("time [V],vout\n0,1\n").unwrap_err().to_string();
        assert!(e.contains("`V` is not a unit of `time`") && !e.contains("--column"), "a unit's error is no missing column: {e}");
        let e = Capture::parse_csv_with("time,vout\n0,1\n", &[named("vo", "CH1")]).unwrap_err().to_string();
        assert!(e.contains("`vo` is not a column of a capture"), "{e}");
        let e = Capture::parse_csv_with("time,vout\n0,1\n", &[Named { scale: Some(0.0), ..named("vout", "CH1") }]).unwrap_err().to_string();
        assert!(e.contains("the scale of `vout` must be"), "{e}");
    }

    #[test]
    fn errors_name_the_problem() {
        let cases = [
            ("", "empty"),
            ("time,vout\n", "no data rows"),
            ("time,sw\n0,1\n", "`vout` is missing"),
            ("time,vout\n0,1\n0,1\n", "line 3: `time` 0 does not increase"),
            ("time,vout\n0,1\n1,nan\n", "line 3: column `vout`"),
        ];
        for (text, needle) in cases {
            let e = Capture::parse_csv(text).unwrap_err().to_string();
            assert!(e.contains(needle), "{text:?}: {e}");
        }
        let flat = Capture::parse_csv("time,vout\n0,1\n1e-6,1\n2e-6,1\n").unwrap();
        assert!(reduce(&flat, None).unwrap_err().to_string().contains("no switching edges"));
        let coarse = Capture { sw: None, ..square() };
        assert!(reduce(&coarse, Some(3e6)).unwrap_err().to_string().contains("too few samples per period"));
    }
}
