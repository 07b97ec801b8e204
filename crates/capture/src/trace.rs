//! One channel of a capture saved in a file of its own, as many oscilloscopes save them: a
//! LeCroy's `C1--trace--00000.txt` (a few lines about the acquisition, then `Time,Ampl`), a
//! Tektronix TDS's `F0000CH1.CSV` (no header row: each row its settings' label, value and unit,
//! then the sample's time and value), or any file of `time,value` rows. The channels of one
//! acquisition, each in its file, make one [`Capture`] ([`Capture::from_traces`]).
use std::collections::BTreeMap;

use csv_header::number;

use crate::{COLUMNS, Capture, CaptureError, PREAMBLE_LINES, data_err};

/// One channel: its samples' times \[s\] and values (in the unit the file has them).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trace {
    /// Sample times \[s\], strictly increasing.
    pub time: Vec<f64>,
    /// The channel's value at each time.
    pub values: Vec<f64>,
    /// `# key = value` metadata before the samples.
    pub meta: BTreeMap<String, String>,
}

/// The field delimiter of a row of numbers: a semicolon or a tab where there is one (a comma
/// is then a decimal one), else a comma.
fn row_delimiter(row: &str) -> u8 {
    [b';', b'\t'].into_iter().find(|&d| row.contains(char::from(d))).unwrap_or(b',')
}

impl Trace {
    /// Parses one channel's file. Its samples are the rows with a number in each of the two
    /// columns where its last row has its only two numbers (time, then value); the rows before
    /// the first of them (at most `PREAMBLE_LINES`) are the instrument's notes and are
    /// skipped, and every row from there on must be a sample. `# key = value` lines at the top
    /// are metadata.
    pub fn parse_csv(text: &str) -> Result<Trace, CaptureError> {
        let csv_header::Split { meta, body, header_line } = csv_header::split(text);
        let rows: Vec<(usize, &str)> = body.lines().enumerate().map(|(i, row)| (header_line + i, row)).filter(|(_, row)| !row.trim().is_empty()).collect();
        let Some(&(last_line, last)) = rows.last() else {
            return Err(data_err("no samples (empty file?)"));
        };
        let delimiter = row_delimiter(last);
        let numbers: Vec<usize> = csv_header::fields(last, delimiter).iter().enumerate().filter(|(_, f)| number(f, delimiter).is_some()).map(|(i, _)| i).collect();
        let [t, v] = numbers[..] else {
            let why = if numbers.len() > 2 {
                format!("{} numbers, not a time and one value: a file of several channels goes in as one capture (`--scope`, its columns named with `--column`)", numbers.len())
            } else {
                "no time and value (two numbers)".to_string()
            };
            return Err(data_err(format!("line {last_line}: the last row has {why}")));
        };
        let sample = |row: &str| {
            let fields = csv_header::fields(row, delimiter);
            let at = |i: usize| fields.get(i).and_then(|f| number(f, delimiter));
            at(t).zip(at(v))
        };
        let first = rows.iter().take(PREAMBLE_LINES + 1).position(|(_, row)| sample(row).is_some());
        let Some(first) = first else {
            return Err(data_err(format!(
                "no sample among the first {PREAMBLE_LINES} rows after the notes: a sample is a row with a time and a value in columns {} and {}, as the last row has them",
                t + 1,
                v + 1
            )));
        };
        let mut trace = Trace { meta, ..Trace::default() };
        for &(line, row) in &rows[first..] {
            let (time, value) = sample(row).ok_or_else(|| data_err(format!("line {line}: no time and value in columns {} and {} (where the samples have them)", t + 1, v + 1)))?;
            if !(time.is_finite() && value.is_finite()) {
                return Err(data_err(format!("line {line}: the time {time} or the value {value} is not a finite number")));
            }
            if let Some(&previous) = trace.time.last()
                && time <= previous
            {
                return Err(data_err(format!("line {line}: the time {time} does not increase (previous {previous})")));
            }
            trace.time.push(time);
            trace.values.push(value);
        }
        Ok(trace)
    }
}

/// Largest offset between two channels' sample times, as a fraction of the sample interval,
/// at which they are taken as the same instants (one acquisition's files write the same times,
/// up to the digits they print).
const SAME_INSTANT: f64 = 0.01;

impl Capture {
    /// A capture from one file per channel: each [`Trace`] with the contract's name of its
    /// channel (`vout`, `il`, `sw`, `gate` or `vin`, each at most once, `vout` required) and the
    /// scale its values are multiplied by to give the channel's SI unit (`il` read in volts
    /// across a 0.1 Ω shunt: 10). The channels must come from one acquisition: the same
    /// samples at the same times. The traces' metadata are merged; a key two of them give
    /// different values is an error.
    pub fn from_traces(traces: Vec<(&str, Trace, f64)>) -> Result<Capture, CaptureError> {
        let channels: Vec<&str> = COLUMNS[1..].iter().map(|c| c.name).collect();
        for (i, (name, _, scale)) in traces.iter().enumerate() {
            if !channels.contains(name) {
                return Err(data_err(format!("`{name}` is not a channel of a capture (one of {})", channels.join(", "))));
            }
            if traces[..i].iter().any(|(other, ..)| other == name) {
                return Err(data_err(format!("`{name}` is given twice")));
            }
            if !(scale.is_finite() && *scale != 0.0) {
                return Err(data_err(format!("the scale of `{name}` must be a finite number other than zero")));
            }
        }
        let Some((_, reference, _)) = traces.iter().find(|(name, ..)| *name == "vout") else {
            return Err(data_err("no `vout` channel: the output voltage is required"));
        };
        let time = reference.time.clone();
        let interval = (time.last().unwrap_or(&0.0) - time.first().unwrap_or(&0.0)) / (time.len().max(2) - 1) as f64;
        let mut cap = Capture { time, ..Capture::default() };
        for (name, trace, scale) in &traces {
            if trace.time.len() != cap.time.len() {
                return Err(data_err(format!("`{name}` has {} samples where `vout` has {}: the channels must come from one acquisition", trace.time.len(), cap.time.len())));
            }
            if let Some(k) = trace.time.iter().zip(&cap.time).position(|(a, b)| (a - b).abs() > SAME_INSTANT * interval) {
                return Err(data_err(format!("`{name}`'s sample {} is at {:e} s where `vout`'s is at {:e} s: the channels must come from one acquisition", k + 1, trace.time[k], cap.time[k])));
            }
            for (key, value) in &trace.meta {
                match cap.meta.get(key) {
                    Some(other) if other != value => return Err(data_err(format!("`{name}` gives `# {key} = {value}` where another channel gives {other}"))),
                    _ => {
                        cap.meta.insert(key.clone(), value.clone());
                    }
                }
            }
            let values = trace.values.iter().map(|v| v * scale).collect();
            match *name {
                "vout" => cap.vout = values,
                "il" => cap.il = Some(values),
                "sw" => cap.sw = Some(values),
                "gate" => cap.gate = Some(values),
                _ => cap.vin = Some(values), // `vin`: the names were checked above
            }
        }
        Ok(cap)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Four periods of a 100 kHz buck at 5 MS/s: the switch node at duty 0.4, `vout` a ripple,
    /// `il` a triangle read in volts across a 0.1 Ω shunt (times written to the last digit).
    fn channels() -> (Vec<f64>, [Vec<f64>; 3]) {
        let time: Vec<f64> = (0..200).map(|k| -2e-6 + k as f64 * 2e-7).collect();
        let phase = |t: f64| (t * 1e5).rem_euclid(1.0);
        let sw = time.iter().map(|&t| if phase(t) < 0.4 { 12.0 } else { 0.0 }).collect();
        let vout = time.iter().map(|&t| 4.8 + 0.01 * (phase(t) - 0.5).abs()).collect();
        let shunt = time.iter().map(|&t| 0.1 * (2.0 + (phase(t) - 0.4).abs())).collect();
        (time, [vout, sw, shunt])
    }

    /// `rows` of time and value as a LeCroy writes them (its notes, then `Time,Ampl`), as a
    /// Tektronix TDS does (each row its settings' label, value and unit first, no header row),
    /// and as plain `time,value` rows with a header.
    fn lecroy(time: &[f64], v: &[f64]) -> String {
        let rows: String = time.iter().zip(v).map(|(t, v)| format!("{t:e},{v:e}\n")).collect();
        format!("LECROYWR104Xi,51234,Waveform\nSegments,1,SegmentSize,{}\nSegment,TrigTime,TimeSinceSegment1\n#1,27-Nov-2026 10:11:12,0\nTime,Ampl\n{rows}", time.len())
    }

    fn tds(time: &[f64], v: &[f64], source: &str) -> String {
        let n = format!("{:e}", time.len() as f64);
        let notes = [
            ("Record Length", n.as_str()),
            ("Sample Interval", "2.000000e-07"),
            ("Trigger Point", "1.0e+01"),
            ("", ""),
            ("Source", source),
            ("Vertical Units", "V"),
            ("Horizontal Units", "s"),
            ("Probe Atten", "1.000000e+01"),
        ];
        let label = |k: usize| notes.get(k).map_or_else(|| ",,".to_string(), |(a, b)| format!("{a},{b},"));
        time.iter().zip(v).enumerate().map(|(k, (t, v))| format!("{},{t:e},{v:e},\r\n", label(k))).collect()
    }

    #[test]
    fn each_channel_in_a_file_of_its_own_reads_as_one_capture() {
        let (time, [vout, sw, shunt]) = channels();
        let il: Vec<f64> = shunt.iter().map(|v| v * 10.0).collect();
        let rows: String = (0..time.len()).map(|k| format!("{:e},{:e},{:e},{:e}\n", time[k], vout[k], il[k], sw[k])).collect();
        let whole = Capture::parse_csv(&format!("# U = 12\ntime,vout,il,sw\n{rows}")).unwrap();
        let plain = |v: &[f64]| "# U = 12\ntime,value\n".to_string() + &time.iter().zip(v).map(|(t, v)| format!("{t:e},{v:e}\n")).collect::<String>();
        let traces = vec![
            ("vout", Trace::parse_csv(&lecroy(&time, &vout)).unwrap(), 1.0),
            ("sw", Trace::parse_csv(&tds(&time, &sw, "CH3")).unwrap(), 1.0),
            ("il", Trace::parse_csv(&plain(&shunt)).unwrap(), 10.0),
        ];
        let cap = Capture::from_traces(traces).unwrap();
        assert_eq!((&cap.time, &cap.vout, &cap.sw, &cap.meta), (&whole.time, &whole.vout, &whole.sw, &whole.meta));
        assert!(cap.il.unwrap().iter().zip(whole.il.as_ref().unwrap()).all(|(a, b)| (a - b).abs() < 1e-12), "the shunt's volts scaled to amperes");
        // A spreadsheet's export: semicolons, decimal commas.
        let comma = Trace::parse_csv("Zeit;Spannung\n0,000001;4,75\n0,000002;4,8\n").unwrap();
        assert_eq!((comma.time, comma.values), (vec![1e-6, 2e-6], vec![4.75, 4.8]));
    }

    #[test]
    fn a_trace_that_is_not_one_says_why() {
        let cases = [
            ("", "no samples (empty file?)"),
            ("time,value\n", "line 1: the last row has no time and value"),
            ("time,ch1,ch2\n0,1,2\n1e-6,1,2\n", "line 3: the last row has 3 numbers, not a time and one value: a file of several channels"),
            ("time,value\n0,1\nnote\n1e-6,1\n", "line 3: no time and value in columns 1 and 2"),
            ("time,value\n0,1\n1e-6,nan\n", "line 3: the time 0.000001 or the value NaN is not a finite number"),
            ("time,value\n0,1\n0,1\n", "line 3: the time 0 does not increase (previous 0)"),
        ];
        for (text, needle) in cases {
            let e = Trace::parse_csv(text).unwrap_err().to_string();
            assert!(e.contains(needle), "{text:?}: {e}");
        }
        let notes: String = (0..=PREAMBLE_LINES).map(|k| format!("note {k}\n")).collect();
        let e = Trace::parse_csv(&format!("{notes}0,1\n1e-6,1\n")).unwrap_err().to_string();
        assert!(e.contains("no sample among the first 64 rows"), "{e}");
    }

    #[test]
    fn channels_of_different_acquisitions_are_refused() {
        let trace = |time: &[f64], meta: &[(&str, &str)]| Trace { time: time.to_vec(), values: vec![1.0; time.len()], meta: meta.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect() };
        let a = trace(&[0.0, 1e-6, 2e-6], &[("U", "12")]);
        let cases = [
            (vec![("il", a.clone(), 1.0)], "no `vout` channel"),
            (vec![("vout", a.clone(), 1.0), ("vo", a.clone(), 1.0)], "`vo` is not a channel of a capture (one of vout, il, sw, gate, vin)"),
            (vec![("vout", a.clone(), 1.0), ("vout", a.clone(), 1.0)], "`vout` is given twice"),
            (vec![("vout", a.clone(), 0.0)], "the scale of `vout` must be"),
            (vec![("vout", a.clone(), 1.0), ("il", trace(&[0.0, 1e-6], &[]), 1.0)], "`il` has 2 samples where `vout` has 3"),
            (vec![("vout", a.clone(), 1.0), ("sw", trace(&[0.0, 1.1e-6, 2e-6], &[]), 1.0)], "`sw`'s sample 2 is at 1.1e-6 s where `vout`'s is at 1e-6 s"),
            (vec![("vout", a.clone(), 1.0), ("sw", trace(&[0.0, 1e-6, 2e-6], &[("U", "24")]), 1.0)], "`sw` gives `# U = 24` where another channel gives 12"),
        ];
        for (traces, needle) in cases {
            let e = Capture::from_traces(traces).unwrap_err().to_string();
            assert!(e.contains(needle), "{e}");
        }
        // The same instants printed to fewer digits are the same instants.
        let rounded = trace(&[0.0, 1.00001e-6, 2e-6], &[("U", "12")]);
        assert!(Capture::from_traces(vec![("vout", a, 1.0), ("gate", rounded, 1.0)]).unwrap().gate.is_some());
    }
}
