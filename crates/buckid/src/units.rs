//! Numbers as an engineer reads them: SI prefixes, units, and intervals that say when they
//! tell nothing.

/// The unit of an effect or circuit parameter by its contract name (`""` for a ratio).
pub fn unit_of(name: &str) -> &'static str {
    match name {
        "diode_drop" | "lsb" | "input_noise_rms" => "V",
        "dead_time" | "sample_delay" => "s",
        "switch_resistance" | "load_esr" | "RL" | "RL_nominal" | "Rc" | "Rc_nominal" => "Ω",
        "esl" | "L" | "L_nominal" => "H",
        "C" | "C_nominal" | "Cl" => "F",
        "isat" => "A",
        "delay" => "periods",
        _ => "",
    }
}

/// `value` with an SI prefix and `digits` significant digits, e.g. `437 mV`, `84.0 nH`.
pub fn si(value: f64, unit: &str, digits: usize) -> String {
    if !value.is_finite() {
        return format!("{value} {unit}").trim_end().to_string();
    }
    if unit.is_empty() || unit == "periods" {
        return format!("{} {unit}", significant(value, digits)).trim_end().to_string();
    }
    const PREFIXES: [(f64, &str); 9] = [(1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n"), (1e-12, "p"), (1e-15, "f")];
    let magnitude = value.abs();
    let (scale, prefix) = PREFIXES.iter().copied().find(|(s, _)| magnitude >= *s * 0.999_5).unwrap_or((1e-15, "f"));
    let scaled = if magnitude == 0.0 { 0.0 } else { value / scale };
    format!("{} {prefix}{unit}", significant(scaled, digits))
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

/// Whether an interval pins a positive quantity down: positive, finite, narrower than a decade.
pub fn identified([lo, hi]: [f64; 2]) -> bool {
    lo > 0.0 && hi.is_finite() && hi < 10.0 * lo
}

/// Digits that resolve an interval's half-width to about two significant digits.
fn digits_for(value: f64, [lo, hi]: [f64; 2]) -> usize {
    let half = 0.5 * (hi - lo);
    if !(half > 0.0 && value != 0.0) {
        return 4;
    }
    ((value.abs().log10() - half.log10()).floor() as i64 + 2).clamp(2, 7) as usize
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
    }

    #[test]
    fn useless_intervals_say_not_identified() {
        assert_eq!(with_ci(1e-9, Some([1.9350e-144, 6.2289e137]), "H"), "1.00 nH (not identified)");
        assert_eq!(with_ci(1e-9, Some([0.0, f64::INFINITY]), "H"), "1.00 nH (not identified)");
        assert_eq!(with_ci(0.4367, Some([0.4120, 0.4620]), "V"), "437 mV (CI95 412 mV … 462 mV)");
    }
}
