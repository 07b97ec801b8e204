//! Minimal SVG line plots for the HTML report (no plotting dependency needed for lines,
//! bands and axes).
use std::fmt::Write;

/// One named line.
pub struct Series<'a> {
    /// Legend text.
    pub name: &'a str,
    /// CSS colour.
    pub color: &'a str,
    /// Points `(x, y)`.
    pub points: Vec<(f64, f64)>,
    /// Draw markers (stems) instead of a line.
    pub stems: bool,
}

/// A plot: title, axis labels, series, optional symmetric band `±b` around zero.
pub struct Plot<'a> {
    /// Title above the plot.
    pub title: &'a str,
    /// X axis label.
    pub x_label: &'a str,
    /// Y axis label.
    pub y_label: &'a str,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Dashed lines at `±band`.
    pub band: Option<f64>,
    /// The data.
    pub series: Vec<Series<'a>>,
}

const W: f64 = 680.0;
const H: f64 = 300.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 20.0;
const TOP: f64 = 30.0;
const BOTTOM: f64 = 45.0;

fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = (hi - lo).max(1e-300);
    let raw = span / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| span / s <= 6.0).unwrap_or(10.0 * mag);
    let mut t = (lo / step).ceil() * step;
    let mut out = Vec::new();
    while t <= hi + 1e-9 * step {
        out.push(if t.abs() < 1e-12 * step { 0.0 } else { t });
        t += step;
    }
    out
}

fn label(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) { format!("{v:.1e}") } else { format!("{}", (v * 1e6).round() / 1e6) }
}

impl Plot<'_> {
    /// Renders the plot as an inline `<svg>` element.
    pub fn render(&self) -> String {
        let tx = |x: f64| if self.log_x { x.max(1e-300).log10() } else { x };
        let all = self.series.iter().flat_map(|s| s.points.iter()).filter(|(x, y)| x.is_finite() && y.is_finite());
        let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for &(x, y) in all {
            x0 = x0.min(tx(x));
            x1 = x1.max(tx(x));
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        if let Some(b) = self.band {
            y0 = y0.min(-b);
            y1 = y1.max(b);
        }
        if !x0.is_finite() {
            (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
        }
        let pad = 0.05 * (y1 - y0).max(1e-12);
        let (y0, y1) = (y0 - pad, y1 + pad);
        let x1 = if x1 > x0 { x1 } else { x0 + 1.0 };
        let px = |x: f64| LEFT + (tx(x) - x0) / (x1 - x0) * (W - LEFT - RIGHT);
        let py = |y: f64| TOP + (y1 - y) / (y1 - y0) * (H - TOP - BOTTOM);
        let mut s = String::new();
        let _ = write!(s, r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" font-size="11">"#);
        let _ = write!(s, r#"<text x="{}" y="18" font-size="13" font-weight="bold">{}</text>"#, LEFT, esc(self.title));
        let _ = write!(s, r##"<rect x="{LEFT}" y="{TOP}" width="{}" height="{}" fill="none" stroke="#888"/>"##, W - LEFT - RIGHT, H - TOP - BOTTOM);
        for t in ticks(y0, y1) {
            let y = py(t);
            let _ = write!(s, r##"<line x1="{LEFT}" x2="{}" y1="{y:.1}" y2="{y:.1}" stroke="#eee"/><text x="{}" y="{:.1}" text-anchor="end">{}</text>"##, W - RIGHT, LEFT - 4.0, y + 4.0, label(t));
        }
        for t in ticks(x0, x1) {
            let x = LEFT + (t - x0) / (x1 - x0) * (W - LEFT - RIGHT);
            let text = if self.log_x { label(10f64.powf(t)) } else { label(t) };
            let _ = write!(s, r##"<line x1="{x:.1}" x2="{x:.1}" y1="{TOP}" y2="{}" stroke="#eee"/><text x="{x:.1}" y="{}" text-anchor="middle">{text}</text>"##, H - BOTTOM, H - BOTTOM + 14.0);
        }
        let _ = write!(s, r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#, (LEFT + W - RIGHT) / 2.0, H - 8.0, esc(self.x_label));
        let _ = write!(s, r#"<text x="14" y="{}" text-anchor="middle" transform="rotate(-90 14 {})">{}</text>"#, (TOP + H - BOTTOM) / 2.0, (TOP + H - BOTTOM) / 2.0, esc(self.y_label));
        if let Some(b) = self.band {
            for v in [b, -b] {
                let _ = write!(s, r##"<line x1="{LEFT}" x2="{}" y1="{:.1}" y2="{:.1}" stroke="#c00" stroke-dasharray="4 3"/>"##, W - RIGHT, py(v), py(v));
            }
        }
        for (i, ser) in self.series.iter().enumerate() {
            if ser.stems {
                for &(x, y) in &ser.points {
                    let _ = write!(s, r#"<line x1="{:.1}" x2="{:.1}" y1="{:.1}" y2="{:.1}" stroke="{}" stroke-width="2"/>"#, px(x), px(x), py(0.0), py(y), ser.color);
                }
            } else {
                let pts: Vec<String> = ser.points.iter().filter(|(x, y)| x.is_finite() && y.is_finite()).map(|&(x, y)| format!("{:.1},{:.1}", px(x), py(y))).collect();
                let _ = write!(s, r#"<polyline fill="none" stroke="{}" stroke-width="1.3" points="{}"/>"#, ser.color, pts.join(" "));
            }
            let ly = TOP + 14.0 + 14.0 * i as f64;
            let _ = write!(s, r#"<line x1="{}" x2="{}" y1="{ly}" y2="{ly}" stroke="{}" stroke-width="3"/><text x="{}" y="{}">{}</text>"#, W - 190.0, W - 172.0, ser.color, W - 166.0, ly + 4.0, esc(ser.name));
        }
        s.push_str("</svg>");
        s
    }
}

/// Escapes text for XML.
pub fn esc(t: &str) -> String {
    t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        assert_eq!(ticks(0.0, 1.0), vec![0.0, 0.2, 0.4, 0.6000000000000001, 0.8, 1.0]);
        let t = ticks(-0.013, 0.021);
        assert!(t.first().unwrap() >= &-0.013 && t.last().unwrap() <= &0.021 && t.len() >= 3);
    }

    #[test]
    fn plot_is_well_formed_svg_with_escaped_text() {
        let p = Plot {
            title: "a < b",
            x_label: "x",
            y_label: "y",
            log_x: true,
            band: Some(0.1),
            series: vec![Series { name: "s", color: "red", points: vec![(1.0, 0.0), (10.0, 1.0), (100.0, f64::NAN)], stems: false }],
        };
        let svg = p.render();
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>"));
        assert!(svg.contains("a &lt; b") && !svg.contains("NaN"));
    }
}
