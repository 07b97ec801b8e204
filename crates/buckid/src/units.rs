//! Numbers as an engineer reads them: SI prefixes, units, and intervals that say when they
//! tell nothing.

use estimator::validate::identified;

/// The unit of an effect or circuit parameter by its contract name (`""` for a ratio).
pub fn unit_of(name: &str) -> &'static str {
    match name {
        "diode_drop" | "lsb" | "input_noise_rms" | "cap_rated_voltage" | "cl_reference_voltage" | "vout_offset" => "V",
        "dead_time" | "pulse_width_distortion" | "sample_delay" | "vout_filter" | "il_filter" | "sensor_filter" | "channel_skew" | "vout_skew" => "s",
        "switch_resistance" | "diode_resistance" | "switch_node_damping" | "series_resistance" | "load_esr" | "RL" | "RL_nominal" | "Rc" | "Rc_nominal" => "Ω",
        "esl" | "L" | "L_nominal" => "H",
        "C" | "C_nominal" | "Cl" | "switch_node_capacitance" => "F",
        "isat" | "il_offset" => "A",
        "fs" => "Hz",
        "delay" => "periods",
        _ => "",
    }
}

/// Units printed without an SI prefix (ratios, counts, logarithmic and relative measures).
const UNPREFIXED: [&str; 5] = ["", "periods", "samples", "dB", "%"];

/// The SI prefix for a magnitude: its scale and symbol (`(1e-3, "m")` for 0.0437), or
/// `(1, "")` for a unit that takes none.
pub fn prefix(magnitude: f64, unit: &str) -> (f64, &'static str) {
    const PREFIXES: [(f64, &str); 9] = [(1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n"), (1e-12, "p"), (1e-15, "f")];
    if UNPREFIXED.contains(&unit) || magnitude == 0.0 || !magnitude.is_finite() {
        return (1.0, "");
    }
    PREFIXES.iter().copied().find(|(s, _)| magnitude >= *s * 0.999_5).unwrap_or((1e-15, "f"))
}

/// `value` with an SI prefix and `digits` significant digits, e.g. `437 mV`, `84.0 nH`. A
/// magnitude a thousand times past the smallest or largest prefix (a bound of an interval that
/// tells nothing, 5e-115 F … 2e102 F) reads as `0 F` or `∞ F`, not as a hundred digits.
pub fn si(value: f64, unit: &str, digits: usize) -> String {
    if !UNPREFIXED.contains(&unit) && value != 0.0 && value.is_finite() {
        if value.abs() < 1e-18 {
            return format!("0 {unit}");
        }
        if value.abs() >= 1e12 {
            return format!("{}∞ {unit}", if value < 0.0 { "-" } else { "" });
        }
    }
    if !value.is_finite() {
        return format!("{value} {unit}").trim_end().to_string();
    }
    let (scale, prefix) = prefix(value.abs(), unit);
    format!("{} {prefix}{unit}", significant(value / scale, digits)).trim_end().to_string()
}

/// An axis tick: `v` as a short plain decimal (no exponent, no trailing zeros), for values
/// already scaled to their axis's prefix.
pub fn tick(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".to_string() } else { s.to_string() }
}

/// Free text from other crates with every number in exponent notation (`1.2345e-3 Ω`)
/// rewritten with an SI prefix (`1.235 mΩ`), so no page shows an exponent.
pub fn si_text(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some((start, len, value)) = next_exponent(rest) {
        out.push_str(&rest[..start]);
        let after = &rest[start + len..];
        let unit = after.strip_prefix(' ').and_then(|a| ["Ω", "V", "A", "s", "H", "F", "Hz"].into_iter().find(|u| a.starts_with(u) && !a[u.len()..].starts_with(char::is_alphanumeric)));
        match unit {
            Some(u) => {
                out.push_str(&si(value, u, 4));
                rest = &after[1 + u.len()..];
            }
            None => {
                out.push_str(&si(value, "", 4));
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

/// The first number in exponent notation in `text`: its byte offset, length and value.
fn next_exponent(text: &str) -> Option<(usize, usize, f64)> {
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit() && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'.'));
        if starts {
            let from = if i > 0 && b[i - 1] == b'-' { i - 1 } else { i };
            let mut j = i;
            while j < b.len() && (b[j].is_ascii_digit() || b[j] == b'.') {
                j += 1;
            }
            if j < b.len() && b[j] == b'e' {
                let mut k = j + 1;
                if k < b.len() && (b[k] == b'-' || b[k] == b'+') {
                    k += 1;
                }
                let digits = k;
                while k < b.len() && b[k].is_ascii_digit() {
                    k += 1;
                }
                if k > digits
                    && let Ok(v) = text[from..k].parse::<f64>()
                {
                    return Some((from, k - from, v));
                }
            }
            i = j.max(i + 1);
        } else {
            i += 1;
        }
    }
    None
}

/// `v` rounded to `digits` significant digits, without an exponent.
fn significant(v: f64, digits: usize) -> String {
    if v == 0.0 {
        return "0".to_string();
    }
    let order = v.abs().log10().floor() as i32;
    let decimals = (digits as i32 - 1 - order).max(0) as usize;
    format!("{v:.decimals$}")
}

/// Digits that resolve the estimate's distance to the nearer bound of its interval (its
/// half-width where the estimate sits on a bound) to about two significant digits: a lopsided
/// interval, 23.15 µF within [18.74, 23.39] µF (Cl spanning another model's), would read
/// "23 µF (CI95 19 µF … 23 µF)" at its half-width's digits.
fn digits_for(value: f64, [lo, hi]: [f64; 2]) -> usize {
    let near = (value - lo).min(hi - value);
    let resolved = if near > 0.0 { near } else { 0.5 * (hi - lo) };
    if !(resolved > 0.0 && value != 0.0) {
        return 4;
    }
    ((value.abs().log10() - resolved.log10()).floor() as i64 + 2).clamp(2, 7) as usize
}

/// `value` with its CI95, as `437 mV [412, 462] mV`, or `437 mV (not identified)` when the
/// interval tells nothing (not positive, infinite, or wider than a decade).
pub fn with_ci(value: f64, ci: Option<[f64; 2]>, unit: &str) -> String {
    match ci {
        Some(c) if identified(c) => {
            let digits = digits_for(value, c);
            format!("{} (CI95 {} … {})", si(value, unit, digits), si(c[0], unit, digits), si(c[1], unit, digits))
        }
        Some(_) => format!("{} (not identified)", si(value, unit, 3)),
        None => si(value, unit, 4),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefixes_units_and_digits_read_as_an_engineer_writes_them() {
        assert_eq!(si(0.43670, "V", 3), "437 mV");
        assert_eq!(si(8.3977e-8, "H", 3), "84.0 nH");
        assert_eq!(si(4.8226e-3, "Ω", 3), "4.82 mΩ");
        assert_eq!(si(10.0089e-6, "F", 6), "10.0089 µF");
        assert_eq!(si(0.25, "", 2), "0.25");
        assert_eq!(si(1.0, "V", 3), "1.00 V");
        assert_eq!(si(0.0123, "dB", 3), "0.0123 dB");
        assert_eq!(si(62.345, "%", 3), "62.3 %");
        assert_eq!(prefix(4.5e-3, "s"), (1e-3, "m"));
        // An uninformative interval's bounds (`identify` printed a hundred digits of each).
        assert_eq!(si(5.5e-115, "F", 2), "0 F");
        assert_eq!(si(1.88e102, "F", 2), "∞ F");
        assert_eq!(si(-3e13, "Ω", 2), "-∞ Ω");
        assert_eq!(si(2.5e-17, "F", 2), "0.025 fF");
        assert_eq!(si(4.7e11, "Ω", 2), "470 GΩ");
    }

    #[test]
    fn ticks_and_free_text_show_no_exponent() {
        assert_eq!(tick(0.6000000000000001), "0.6");
        assert_eq!(tick(-1e-17), "0");
        assert_eq!(tick(250.0), "250");
        assert_eq!(
            si_text("the fitted series resistance 1.2346e-3 Ω is not above the nominal RL 1e-1 Ω: none; x 2.5e3 done"),
            "the fitted series resistance 1.235 mΩ is not above the nominal RL 100.0 mΩ: none; x 2500 done"
        );
        assert_eq!(si_text("rate -4.2e-6 V at 3e2 Hz, name x1e5"), "rate -4.200 µV at 300.0 Hz, name x1e5");
    }

    #[test]
    fn useless_intervals_say_not_identified() {
        assert_eq!(with_ci(1e-9, Some([1.9350e-144, 6.2289e137]), "H"), "1.00 nH (not identified)");
        assert_eq!(with_ci(1e-9, Some([0.0, f64::INFINITY]), "H"), "1.00 nH (not identified)");
        assert_eq!(with_ci(0.4367, Some([0.4120, 0.4620]), "V"), "437 mV (CI95 412 mV … 462 mV)");
        assert_eq!(with_ci(23.153e-6, Some([18.741e-6, 23.385e-6]), "F"), "23.2 µF (CI95 18.7 µF … 23.4 µF)");
        assert_eq!(with_ci(18.8e-6, Some([18.8e-6, 23.4e-6]), "F"), "19 µF (CI95 19 µF … 23 µF)");
        // A signed quantity (an offset) is identified below zero too, not across it.
        assert_eq!(with_ci(-0.0101, Some([-0.0104, -0.0098]), "V"), "-10.1 mV (CI95 -10.4 mV … -9.80 mV)");
        assert_eq!(with_ci(0.0002, Some([-0.0001, 0.0005]), "V"), "200 µV (not identified)");
    }
}
