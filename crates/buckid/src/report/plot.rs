//! The reports' figures, drawn with plotters' SVG backend (text stays `<text>`: no font files):
//! line charts of stacked panels over one x axis, with shaded bands and the legend below the
//! plot area, and horizontal bar charts of floating bars (gaps against a reference, waterfalls).
//! Axis units carry SI prefixes chosen from the data (`time [ms]`, `residual [mV]`).
use anyhow::Result;
use std::ops::Range;

use plotters::coord::Shift;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::FontStyle;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::units::{prefix, si, tick};

/// Width of every figure \[px\].
const W: u32 = 720;
/// Height of the title strip \[px\].
const TITLE: u32 = 30;
/// Height of the x tick labels and axis name under the bottom panel \[px\].
const X_AREA: u32 = 42;
/// Width of the y tick labels and axis name of line charts \[px\].
const Y_AREA: u32 = 72;
/// Height of one legend row \[px\].
const LEGEND_ROW: u32 = 20;
/// Height of one bar's row \[px\].
const BAR_ROW: u32 = 26;
/// Right margin of the plot area \[px\].
const RIGHT: u32 = 18;
/// Approximate advance of one character of the 12 px sans-serif text \[px\].
const CHAR: f64 = 6.8;

/// Grey of the measurement and the nominal model.
pub const GREY: RGBColor = RGBColor(120, 120, 120);
/// Black: measured points.
pub const BLACK: RGBColor = RGBColor(0, 0, 0);
/// Blue: the nominal model, or the first series.
pub const BLUE: RGBColor = RGBColor(31, 119, 180);
/// Red: the fitted or final model.
pub const RED: RGBColor = RGBColor(214, 39, 40);
/// Green: a third series (the FMU as given), or a share closed.
pub const GREEN: RGBColor = RGBColor(44, 160, 44);
/// Orange: gaps above the noise floor.
pub const ORANGE: RGBColor = RGBColor(255, 127, 14);
/// Blue-grey of the noise-floor band.
pub const FLOOR: RGBColor = RGBColor(90, 120, 160);

/// A font of `px` pixels (plotters writes `font-size` as the size over 1.24).
fn font(px: f64) -> FontDesc<'static> {
    ("sans-serif", px * 1.24).into_font()
}

/// An axis: what it shows, in which unit (SI-prefixed from the data unless unitless, `dB`, `%`).
#[derive(Clone, Copy)]
pub struct Axis<'a> {
    /// Name, e.g. `time since hold-out start`.
    pub label: &'a str,
    /// SI unit without prefix, e.g. `s`, `V`; `""` for a ratio.
    pub unit: &'a str,
    /// Logarithmic (each decade ticked with its own prefix).
    pub log: bool,
}

impl<'a> Axis<'a> {
    /// A linear axis.
    pub fn linear(label: &'a str, unit: &'a str) -> Self {
        Self { label, unit, log: false }
    }
}

/// How a [`Line`] is drawn.
#[derive(Clone, Copy, PartialEq)]
pub enum Mark {
    /// A solid line.
    Solid,
    /// A dashed line.
    Dashed,
    /// A stem from zero to each point.
    Stems,
    /// A dot at each point.
    Dots,
}

/// A named series of points `(x, y)`.
pub struct Line {
    /// Legend text (empty: not in the legend, e.g. when the panel's caption names it).
    pub name: String,
    /// Colour.
    pub color: RGBColor,
    /// Line, dashes or stems.
    pub mark: Mark,
    /// The data (non-finite points are skipped).
    pub points: Vec<(f64, f64)>,
}

/// A shaded region between two curves over x (e.g. `±` the noise floor, a CI95).
pub struct Band {
    /// Legend text.
    pub name: String,
    /// Colour (drawn translucent).
    pub color: RGBColor,
    /// Lower curve.
    pub lower: Vec<(f64, f64)>,
    /// Upper curve.
    pub upper: Vec<(f64, f64)>,
}

impl Band {
    /// The band `±half` around zero from `x0` to `x1`.
    pub fn symmetric(name: String, color: RGBColor, half: f64, (x0, x1): (f64, f64)) -> Self {
        Self { name, color, lower: vec![(x0, -half), (x1, -half)], upper: vec![(x0, half), (x1, half)] }
    }
}

/// One plot area of a [`Chart`].
pub struct Panel<'a> {
    /// Line above the area (empty: none).
    pub caption: String,
    /// Its y axis.
    pub y: Axis<'a>,
    /// Shaded bands, drawn under the lines.
    pub bands: Vec<Band>,
    /// The lines.
    pub lines: Vec<Line>,
    /// Height of the plot area \[px\].
    pub height: u32,
}

/// A figure of stacked panels sharing one x axis, ticked and named under the bottom one.
pub struct Chart<'a> {
    /// Title above the figure.
    pub title: &'a str,
    /// The shared x axis.
    pub x: Axis<'a>,
    /// The panels, top to bottom.
    pub panels: Vec<Panel<'a>>,
}

/// 1-2-5 ticks covering `[lo, hi]`.
fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = (hi - lo).max(1e-300);
    let mag = 10f64.powf((span / 5.0).log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| span / s <= 6.0).unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step + 1e-9).floor() as i64;
    (first..=last).map(|k| k as f64 * step).collect()
}

/// An axis laid out over a data range: drawing coordinates (`log10` of the value on a log
/// axis), ticks, and the text of its ticks and name.
struct Scale {
    lo: f64,
    hi: f64,
    ticks: Vec<f64>,
    minor: Vec<f64>,
    log: bool,
    /// The prefix's scale (linear axes).
    factor: f64,
    unit: String,
    desc: String,
}

impl Scale {
    /// `axis` over the data range `[lo, hi]` (already in drawing coordinates for a log axis),
    /// padded by `pad` of the span on each side.
    fn new(axis: &Axis<'_>, lo: f64, hi: f64, pad: f64) -> Self {
        let (lo, hi) = if lo.is_finite() && hi.is_finite() { (lo, hi) } else { (0.0, 1.0) };
        let (lo, hi) = if hi - lo > 1e-12 * (lo.abs() + hi.abs()).max(1e-300) { (lo, hi) } else { (lo - 0.5 * lo.abs().max(1e-12), hi + 0.5 * hi.abs().max(1e-12)) };
        let (lo, hi) = (lo - pad * (hi - lo), hi + pad * (hi - lo));
        if axis.log {
            let ticks: Vec<f64> = (lo.ceil() as i64..=hi.floor() as i64).map(|k| k as f64).collect();
            let minor = (lo.floor() as i64..=hi.ceil() as i64).flat_map(|d| (2..10).map(move |m| d as f64 + (m as f64).log10())).filter(|v| (lo..=hi).contains(v)).collect();
            return Self { lo, hi, ticks, minor, log: true, factor: 1.0, unit: axis.unit.to_string(), desc: axis.label.to_string() };
        }
        let (factor, p) = prefix(lo.abs().max(hi.abs()), axis.unit);
        let unit = format!("{p}{}", axis.unit);
        let ticks = ticks(lo / factor, hi / factor).into_iter().map(|t| t * factor).collect();
        Self { lo, hi, ticks, minor: Vec::new(), log: false, factor, desc: name(axis.label, &unit), unit }
    }

    /// A value's drawing coordinate.
    fn map(&self, v: f64) -> f64 {
        if self.log { v.log10() } else { v }
    }

    /// A tick's text: the number in the axis's prefix, or each decade with its own.
    fn text(&self, v: f64) -> String {
        if self.log { si(10f64.powf(v.round()), &self.unit, 1) } else { tick(v / self.factor) }
    }

    fn coord(&self) -> Ticked {
        Ticked { inner: (self.lo..self.hi).into(), ticks: self.ticks.clone(), minor: self.minor.clone() }
    }
}

/// A linear coordinate with our own ticks (plotters' `WithKeyPoints` over `f64` has no label
/// formatting to hand the mesh).
struct Ticked {
    inner: RangedCoordf64,
    ticks: Vec<f64>,
    minor: Vec<f64>,
}

impl Ranged for Ticked {
    type ValueType = f64;
    type FormatOption = DefaultFormatting;

    fn range(&self) -> Range<f64> {
        self.inner.range()
    }

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() { self.minor.clone() } else { self.ticks.clone() }
    }
}

/// An axis name with its unit in brackets (none for a ratio).
fn name(label: &str, unit: &str) -> String {
    if unit.is_empty() { label.to_string() } else { format!("{label} [{unit}]") }
}

/// Smallest and largest of `values` that are finite.
fn extent(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values.filter(|v| v.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)))
}

/// What a legend entry's swatch looks like.
#[derive(Clone, Copy)]
enum Swatch {
    Line(Mark),
    Area,
}

/// The legend under the plot area: entries in rows, wrapped to the figure's width.
struct Legend {
    entries: Vec<(String, RGBColor, Swatch)>,
}

impl Legend {
    /// Each entry's position: `(row, x)` \[px\].
    fn layout(&self) -> Vec<(u32, u32)> {
        let (mut row, mut x) = (0, Y_AREA);
        self.entries
            .iter()
            .map(|(text, _, _)| {
                let width = 30 + (CHAR * text.chars().count() as f64) as u32 + 22;
                if x + width > W - RIGHT && x > Y_AREA {
                    (row, x) = (row + 1, Y_AREA);
                }
                let at = (row, x);
                x += width;
                at
            })
            .collect()
    }

    fn height(&self) -> u32 {
        if self.entries.is_empty() { 0 } else { LEGEND_ROW * (self.layout().last().map_or(0, |l| l.0) + 1) + 6 }
    }

    fn draw(&self, area: &DrawingArea<SVGBackend<'_>, Shift>) -> Result<()> {
        for ((text, color, swatch), (row, x)) in self.entries.iter().zip(self.layout()) {
            let (x, y) = (x as i32, (row * LEGEND_ROW + LEGEND_ROW / 2) as i32);
            match swatch {
                Swatch::Area => area.draw(&Rectangle::new([(x, y - 6), (x + 24, y + 6)], color.mix(0.3).filled()))?,
                Swatch::Line(Mark::Dashed) => {
                    for dx in [0, 10, 20] {
                        area.draw(&PathElement::new(vec![(x + dx, y), (x + dx + 5, y)], color.stroke_width(2)))?;
                    }
                }
                Swatch::Line(Mark::Stems) => area.draw(&PathElement::new(vec![(x + 12, y - 7), (x + 12, y + 7)], color.stroke_width(2)))?,
                Swatch::Line(Mark::Dots) => area.draw(&Circle::new((x + 12, y), 3, color.filled()))?,
                Swatch::Line(Mark::Solid) => area.draw(&PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(2)))?,
            }
            area.draw(&Text::new(text.clone(), (x + 30, y), TextStyle::from(font(12.0)).pos(Pos::new(HPos::Left, VPos::Center))))?;
        }
        Ok(())
    }
}

/// Draws the figure's title and returns the area below it.
fn titled<'a>(root: &DrawingArea<SVGBackend<'a>, Shift>, title: &str) -> Result<DrawingArea<SVGBackend<'a>, Shift>> {
    root.fill(&WHITE)?;
    let (top, rest) = root.split_vertically(TITLE);
    top.draw(&Text::new(title.to_string(), (8, 10), font(14.0).style(FontStyle::Bold)))?;
    Ok(rest)
}

impl Chart<'_> {
    /// The figure as an `<svg>` element.
    pub fn render(&self) -> Result<String> {
        let lines = || self.panels.iter().flat_map(|p| &p.lines);
        let x_axis = self.x;
        let xs = lines().flat_map(|l| l.points.iter().map(|p| p.0)).chain(self.panels.iter().flat_map(|p| &p.bands).flat_map(|b| b.lower.iter().chain(&b.upper).map(|p| p.0)));
        let (x0, x1) = extent(xs.filter(|x| !x_axis.log || *x > 0.0).map(|x| if x_axis.log { x.log10() } else { x }));
        // Dots at the ends are drawn whole.
        let x = Scale::new(&x_axis, x0, x1, if lines().any(|l| l.mark == Mark::Dots) { 0.03 } else { 0.0 });
        let y_extent = |p: &Panel<'_>| {
            let stems = p.lines.iter().any(|l| l.mark == Mark::Stems).then_some(0.0);
            extent(p.lines.iter().flat_map(|l| l.points.iter().map(|q| q.1)).chain(p.bands.iter().flat_map(|b| b.lower.iter().chain(&b.upper).map(|q| q.1))).chain(stems))
        };
        let mut legend = Legend { entries: Vec::new() };
        for p in &self.panels {
            let entries = p.bands.iter().map(|b| (b.name.clone(), b.color, Swatch::Area)).chain(p.lines.iter().map(|l| (l.name.clone(), l.color, Swatch::Line(l.mark))));
            for e in entries {
                if !e.0.is_empty() && !legend.entries.iter().any(|f| f.0 == e.0) {
                    legend.entries.push(e);
                }
            }
        }
        let captions: u32 = self.panels.iter().map(|p| if p.caption.is_empty() { 8 } else { 22 }).sum();
        let height = TITLE + captions + self.panels.iter().map(|p| p.height).sum::<u32>() + X_AREA + legend.height() + 4;
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (W, height)).into_drawing_area();
            let mut rest = titled(&root, self.title)?;
            for (i, p) in self.panels.iter().enumerate() {
                let bottom = i + 1 == self.panels.len();
                let caption = if p.caption.is_empty() { 8 } else { 22 };
                let (here, below) = rest.split_vertically(p.height + caption + if bottom { X_AREA } else { 0 });
                rest = below;
                let (lo, hi) = y_extent(p);
                let y = Scale::new(&p.y, lo, hi, 0.06);
                let mut chart = ChartBuilder::on(&here)
                    .margin_top(caption)
                    .margin_right(RIGHT)
                    .x_label_area_size(if bottom { X_AREA } else { 0 })
                    .y_label_area_size(Y_AREA)
                    .build_cartesian_2d(x.coord(), y.coord())?;
                let (x_text, y_text) = (|v: &f64| x.text(*v), |v: &f64| y.text(*v));
                chart
                    .configure_mesh()
                    .x_label_formatter(&x_text)
                    .y_label_formatter(&y_text)
                    .x_desc(x.desc.as_str())
                    .y_desc(y.desc.as_str())
                    .label_style(font(11.0))
                    .axis_desc_style(font(12.0))
                    .bold_line_style(RGBColor(225, 225, 225))
                    .light_line_style(RGBColor(243, 243, 243))
                    .draw()?;
                if !p.caption.is_empty() {
                    here.draw(&Text::new(p.caption.clone(), (Y_AREA as i32, 4), font(12.0).style(FontStyle::Bold)))?;
                }
                let at = |&(a, b): &(f64, f64)| (x.map(a), y.map(b));
                let finite = |q: &(f64, f64)| q.0.is_finite() && q.1.is_finite() && (!x.log || q.0 > 0.0);
                for b in &p.bands {
                    let outline: Vec<_> = b.upper.iter().filter(|q| finite(q)).chain(b.lower.iter().filter(|q| finite(q)).rev()).map(at).collect();
                    chart.draw_series(std::iter::once(Polygon::new(outline, b.color.mix(0.22).filled())))?;
                }
                for l in &p.lines {
                    let points = l.points.iter().filter(|q| finite(q)).map(at);
                    match l.mark {
                        Mark::Solid => chart.draw_series(LineSeries::new(points, l.color.stroke_width(1)))?,
                        Mark::Dashed => chart.draw_series(DashedLineSeries::new(points, 6, 4, l.color.stroke_width(2)))?,
                        Mark::Stems => chart.draw_series(points.map(|(a, b)| PathElement::new(vec![(a, 0.0), (a, b)], l.color.stroke_width(2))))?,
                        Mark::Dots => chart.draw_series(points.map(|q| Circle::new(q, 3, l.color.filled())))?,
                    };
                }
            }
            legend.draw(&rest)?;
            root.present()?;
        }
        Ok(svg)
    }
}

/// One row of a [`Bars`] chart: a bar from `from` to `to` with its text beside it.
pub struct Bar {
    /// Category text, left of the axis.
    pub label: String,
    /// Where the bar starts (non-finite: no bar, `n/a`).
    pub from: f64,
    /// Where it ends.
    pub to: f64,
    /// Its colour.
    pub color: RGBColor,
    /// Text right of the bar (its value).
    pub text: String,
}

impl Bar {
    /// A bar from zero to `value`, `value` printed with `unit` and three significant digits.
    pub fn value(label: String, value: f64, unit: &str, color: RGBColor) -> Self {
        let text = if value.is_finite() { si(value, unit, 3) } else { "n/a".to_string() };
        Self { label, from: 0.0, to: value, color, text }
    }
}

/// Horizontal bars, one row each, top to bottom, against a value axis; optionally a dashed
/// reference line (e.g. the noise floor) and dotted connectors from each bar's end to the
/// next one's start (a waterfall).
pub struct Bars<'a> {
    /// Title above the chart.
    pub title: &'a str,
    /// The value axis.
    pub value: Axis<'a>,
    /// The rows.
    pub bars: Vec<Bar>,
    /// A dashed vertical line at this value, named in the legend.
    pub reference: Option<(f64, String)>,
    /// Connect each bar's left end to the next bar (a waterfall that falls to the left).
    pub connect: bool,
}

impl Bars<'_> {
    /// The chart as an `<svg>` element.
    pub fn render(&self) -> Result<String> {
        let n = self.bars.len().max(1);
        let ends = self.bars.iter().flat_map(|b| [b.from, b.to]).chain(self.reference.as_ref().map(|r| r.0)).chain([0.0]);
        let (lo, hi) = extent(ends);
        // Room right of the longest bar for its text.
        let longest_text = self.bars.iter().map(|b| b.text.chars().count()).max().unwrap_or(0) as f64;
        let label_width = self.bars.iter().map(|b| b.label.chars().count()).max().unwrap_or(0) as f64 * CHAR + 16.0;
        let y_area = label_width.clamp(f64::from(Y_AREA), 340.0) as u32;
        let plot_width = f64::from(W - RIGHT - y_area);
        let text_share = ((longest_text * CHAR + 10.0) / plot_width).min(0.4);
        let hi = hi + (hi - lo) * text_share / (1.0 - text_share);
        let x = Scale::new(&self.value, lo, hi, 0.0);
        let legend = Legend { entries: self.reference.iter().map(|(_, name)| (name.clone(), RED, Swatch::Line(Mark::Dashed))).collect() };
        let height = TITLE + 8 + BAR_ROW * n as u32 + X_AREA + legend.height() + 4;
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (W, height)).into_drawing_area();
            let rest = titled(&root, self.title)?;
            let (here, below) = rest.split_vertically(8 + BAR_ROW * n as u32 + X_AREA);
            let rows = self.bars.len() as f64;
            let mut chart = ChartBuilder::on(&here)
                .margin_top(8)
                .margin_right(RIGHT)
                .x_label_area_size(X_AREA)
                .y_label_area_size(y_area)
                .build_cartesian_2d(x.coord(), Ticked { inner: (-0.5..rows.max(1.0) - 0.5).into(), ticks: (0..self.bars.len()).map(|i| i as f64).collect(), minor: Vec::new() })?;
            let label = |v: &f64| {
                let i = self.bars.len() as i64 - 1 - v.round() as i64;
                usize::try_from(i).ok().and_then(|i| self.bars.get(i)).map_or_else(String::new, |b| b.label.clone())
            };
            let x_text = |v: &f64| x.text(*v);
            chart
                .configure_mesh()
                .disable_y_mesh()
                .x_label_formatter(&x_text)
                .y_label_formatter(&label)
                .x_desc(x.desc.as_str())
                .label_style(font(11.5))
                .axis_desc_style(font(12.0))
                .bold_line_style(RGBColor(225, 225, 225))
                .light_line_style(RGBColor(243, 243, 243))
                .draw()?;
            let row = |i: usize| rows - 1.0 - i as f64;
            for (i, b) in self.bars.iter().enumerate() {
                let y = row(i);
                if !(b.from.is_finite() && b.to.is_finite()) {
                    chart.draw_series(std::iter::once(Text::new(b.text.clone(), (0.0, y), TextStyle::from(font(11.0)).pos(Pos::new(HPos::Left, VPos::Center)))))?;
                    continue;
                }
                let (a, z) = (b.from.min(b.to), b.from.max(b.to));
                chart.draw_series(std::iter::once(Rectangle::new([(a, y - 0.32), (z, y + 0.32)], b.color.filled())))?;
                let text = Text::new(format!(" {}", b.text), (z, y), TextStyle::from(font(11.5)).pos(Pos::new(HPos::Left, VPos::Center)));
                chart.draw_series(std::iter::once(text))?;
                if self.connect
                    && let Some(next) = self.bars.get(i + 1)
                {
                    let level = if next.from.is_finite() { next.from.max(next.to) } else { a };
                    chart.draw_series(DashedLineSeries::new([(level, y - 0.32), (level, row(i + 1) + 0.32)], 3, 3, GREY.stroke_width(1)))?;
                }
            }
            chart.draw_series(std::iter::once(PathElement::new(vec![(0.0, -0.5), (0.0, rows - 0.5)], BLACK.stroke_width(1))))?;
            if let Some((v, _)) = &self.reference {
                chart.draw_series(DashedLineSeries::new([(*v, -0.5), (*v, rows - 0.5)], 6, 4, RED.stroke_width(2)))?;
            }
            legend.draw(&below)?;
            root.present()?;
        }
        Ok(svg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        assert_eq!(ticks(0.0, 1.0).len(), 6);
        let t = ticks(-0.013, 0.021);
        assert!(t[0] >= -0.013 && *t.last().unwrap() <= 0.021 && t.len() >= 3);
    }

    #[test]
    fn axes_take_the_prefix_of_their_data() {
        let x = Scale::new(&Axis::linear("time", "s"), 0.0, 4.5e-3, 0.0);
        assert_eq!(x.desc, "time [ms]");
        assert_eq!(x.text(2e-3), "2");
        let f = Scale::new(&Axis { label: "frequency", unit: "Hz", log: true }, 2.0, 5.2, 0.0);
        assert_eq!(f.ticks, vec![2.0, 3.0, 4.0, 5.0]);
        assert_eq!(f.text(3.0), "1 kHz");
        assert_eq!(Scale::new(&Axis::linear("correlation", ""), -0.1, 0.3, 0.0).desc, "correlation");
    }

    #[test]
    fn chart_is_svg_with_a_band_under_lines_and_the_legend_below() {
        let chart = Chart {
            title: "a < b",
            x: Axis::linear("time", "s"),
            panels: vec![Panel {
                caption: "residual".into(),
                y: Axis::linear("residual", "V"),
                bands: vec![Band::symmetric("±noise floor".into(), FLOOR, 2e-3, (0.0, 1e-3))],
                lines: vec![Line { name: "nominal".into(), color: BLUE, mark: Mark::Solid, points: vec![(0.0, 1e-3), (5e-4, f64::NAN), (1e-3, -3e-3)] }],
                height: 120,
            }],
        };
        let svg = chart.render().unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("a &lt; b") && svg.contains("residual [mV]") && svg.contains("time [ms]") && !svg.contains("NaN"));
        let (band, line, legend) = (svg.find("<polygon").unwrap(), svg.find(r##"stroke="#1F77B4""##).unwrap(), svg.find("±noise floor").unwrap());
        assert!(band < line && line < legend, "band under the line, legend after the plot");
    }

    #[test]
    fn bars_draw_one_rect_per_finite_bar_in_its_colour() {
        let bars = Bars {
            title: "t",
            value: Axis::linear("over the floor", "dB"),
            bars: vec![Bar::value("up".into(), 12.5, "dB", ORANGE), Bar::value("down <".into(), -3.0, "dB", ORANGE), Bar::value("none".into(), f64::NAN, "dB", ORANGE)],
            reference: Some((0.0, "noise floor".into())),
            connect: false,
        };
        let svg = bars.render().unwrap();
        assert_eq!(svg.matches(r##"fill="#FF7F0E""##).count(), 2, "{svg}");
        assert!(svg.contains("12.5 dB") && svg.contains("-3.00 dB") && svg.contains("n/a") && svg.contains("down &lt;"));
    }
}
