//! Minimal SVG line plots and bar charts for the HTML reports (no plotting dependency needed
//! for lines, bars, bands and axes).
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

/// The plot area of a figure `w`×`h` px with the given margins: the `<svg>` element, its
/// title, the frame, and the axis labels, shared by every kind of figure.
struct Frame {
    w: f64,
    h: f64,
    left: f64,
    top: f64,
}

impl Frame {
    fn right(&self) -> f64 {
        self.w - RIGHT
    }

    fn bottom(&self) -> f64 {
        self.h - BOTTOM
    }

    /// Opens the `<svg>` with the title and the frame; the caller closes it.
    fn open(&self, title: &str) -> String {
        let mut s = String::new();
        let (w, h, left, top) = (self.w, self.h, self.left, self.top);
        let _ = write!(s, r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="11">"#);
        let _ = write!(s, r#"<text x="{LEFT}" y="18" font-size="13" font-weight="bold">{}</text>"#, esc(title));
        let _ = write!(s, r##"<rect x="{left}" y="{top}" width="{}" height="{}" fill="none" stroke="#888"/>"##, self.right() - left, self.bottom() - top);
        s
    }

    /// A vertical grid line with its tick label at `x` [px].
    fn x_tick(&self, s: &mut String, x: f64, text: &str) {
        let _ = write!(
            s,
            r##"<line x1="{x:.1}" x2="{x:.1}" y1="{}" y2="{}" stroke="#eee"/><text x="{x:.1}" y="{}" text-anchor="middle">{text}</text>"##,
            self.top,
            self.bottom(),
            self.bottom() + 14.0
        );
    }

    /// The x axis label below the frame.
    fn x_label(&self, s: &mut String, text: &str) {
        let _ = write!(s, r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#, (self.left + self.right()) / 2.0, self.h - 8.0, esc(text));
    }
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
        let frame = Frame { w: W, h: H, left: LEFT, top: TOP };
        let px = |x: f64| LEFT + (tx(x) - x0) / (x1 - x0) * (W - LEFT - RIGHT);
        let py = |y: f64| TOP + (y1 - y) / (y1 - y0) * (H - TOP - BOTTOM);
        let mut s = frame.open(self.title);
        for t in ticks(y0, y1) {
            let y = py(t);
            let _ = write!(s, r##"<line x1="{LEFT}" x2="{}" y1="{y:.1}" y2="{y:.1}" stroke="#eee"/><text x="{}" y="{:.1}" text-anchor="end">{}</text>"##, W - RIGHT, LEFT - 4.0, y + 4.0, label(t));
        }
        for t in ticks(x0, x1) {
            let x = LEFT + (t - x0) / (x1 - x0) * (W - LEFT - RIGHT);
            let text = if self.log_x { label(10f64.powf(t)) } else { label(t) };
            frame.x_tick(&mut s, x, &text);
        }
        frame.x_label(&mut s, self.x_label);
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

/// One bar of a [`Bars`] chart.
pub struct Bar {
    /// Category text, left of the bar.
    pub label: String,
    /// Length of the bar (non-finite: no bar, marked `n/a`).
    pub value: f64,
}

/// A horizontal bar chart: one bar per category, from zero, with an optional dashed
/// reference line (e.g. the noise floor).
pub struct Bars<'a> {
    /// Title above the chart.
    pub title: &'a str,
    /// Label of the value axis (below the chart).
    pub value_label: &'a str,
    /// The bars, top to bottom.
    pub bars: Vec<Bar>,
    /// Dashed line at this value, with its legend text.
    pub reference: Option<(f64, &'a str)>,
    /// CSS colour of the bars.
    pub color: &'a str,
}

/// Height of one bar's row [px].
const ROW: f64 = 22.0;
/// Room right of the longest bar for its value [px].
const VALUE_ROOM: f64 = 56.0;
/// Longest category text drawn; longer ones are cut (the bar's tooltip has it whole).
const MAX_LABEL: usize = 46;

/// A bar's value with three significant digits (at least one decimal below 100).
fn value_text(v: f64) -> String {
    match v.abs() {
        a if a >= 100.0 => format!("{v:.0}"),
        a if a >= 10.0 => format!("{v:.1}"),
        _ => format!("{v:.2}"),
    }
}

/// `text` cut to `MAX_LABEL` characters with an ellipsis.
fn cut(text: &str) -> String {
    if text.chars().count() <= MAX_LABEL { text.to_string() } else { text.chars().take(MAX_LABEL - 1).chain(['…']).collect() }
}

impl Bars<'_> {
    /// Renders the chart as an inline `<svg>` element; each bar is a `<rect class="bar">`
    /// with a `<title>` giving its value.
    pub fn render(&self) -> String {
        let longest = self.bars.iter().map(|b| cut(&b.label).chars().count()).max().unwrap_or(0) as f64;
        let left = (6.4 * longest + 12.0).clamp(LEFT, 330.0);
        let h = TOP + ROW * self.bars.len().max(1) as f64 + 10.0 + BOTTOM;
        let frame = Frame { w: W, h, left, top: TOP };
        let finite = self.bars.iter().map(|b| b.value).filter(|v| v.is_finite());
        let reference = self.reference.map(|r| r.0).filter(|v| v.is_finite());
        let (mut lo, mut hi) = (0.0f64, 0.0f64);
        for v in finite.chain(reference) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if hi - lo < 1e-12 {
            hi = lo + 1.0;
        }
        // Bars span [from, to]; the room beyond is for the values printed at their ends.
        let from = if lo < 0.0 { left + VALUE_ROOM } else { left };
        let to = frame.right() - VALUE_ROOM;
        let px = |v: f64| from + (v - lo) / (hi - lo) * (to - from);
        let mut s = frame.open(self.title);
        for t in ticks(lo, hi) {
            frame.x_tick(&mut s, px(t), &label(t));
        }
        frame.x_label(&mut s, self.value_label);
        for (i, b) in self.bars.iter().enumerate() {
            let y = TOP + 5.0 + ROW * i as f64;
            let _ = write!(s, r#"<text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"#, left - 4.0, y + ROW / 2.0 + 1.0, esc(&cut(&b.label)));
            if !b.value.is_finite() {
                let _ = write!(s, r##"<text x="{:.1}" y="{:.1}" fill="#888">n/a</text>"##, px(0.0) + 4.0, y + ROW / 2.0 + 1.0);
                continue;
            }
            let (a, z) = (px(0.0).min(px(b.value)), px(0.0).max(px(b.value)));
            let value = value_text(b.value);
            let _ = write!(
                s,
                r#"<rect class="bar" x="{a:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="{}"><title>{}: {value}</title></rect>"#,
                y + 3.0,
                (z - a).max(0.5),
                ROW - 6.0,
                self.color,
                esc(&b.label)
            );
            let (tx, anchor) = if b.value >= 0.0 { (z + 3.0, "start") } else { (a - 3.0, "end") };
            let _ = write!(s, r#"<text x="{tx:.1}" y="{:.1}" text-anchor="{anchor}">{value}</text>"#, y + ROW / 2.0 + 1.0);
        }
        let _ = write!(s, r##"<line x1="{0:.1}" x2="{0:.1}" y1="{TOP}" y2="{1}" stroke="#444"/>"##, px(0.0), frame.bottom());
        if let Some((v, name)) = self.reference.filter(|r| r.0.is_finite()) {
            let x = px(v);
            let _ = write!(s, r##"<line x1="{x:.1}" x2="{x:.1}" y1="{TOP}" y2="{}" stroke="#c00" stroke-dasharray="4 3"/>"##, frame.bottom());
            let _ = write!(s, r##"<text x="{}" y="{}" text-anchor="end" fill="#c00">- - {}</text>"##, frame.right(), TOP - 4.0, esc(name));
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

    #[test]
    fn bars_draw_one_rect_per_finite_value_on_both_sides_of_zero() {
        let b = Bars {
            title: "t",
            value_label: "dB",
            bars: vec![
                Bar { label: "up".into(), value: 12.5 },
                Bar { label: "down <".into(), value: -3.0 },
                Bar { label: "none".into(), value: f64::NAN },
            ],
            reference: Some((0.0, "floor")),
            color: "#1f77b4",
        };
        let svg = b.render();
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>"));
        assert_eq!(svg.matches(r#"class="bar""#).count(), 2, "{svg}");
        assert!(svg.contains("<title>up: 12.5</title>") && svg.contains("down &lt;: -3.00"));
        assert!(svg.contains("n/a") && !svg.contains("NaN"));
    }
}
