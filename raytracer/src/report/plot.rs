//! SVG charts for experiments and sweeps, drawn with `plotters`.
//!
//! The SVG backend needs a font only to measure text; the one it uses is
//! DejaVu Sans, shipped in `raytracer/assets/fonts` (its licence is next to
//! it), so no system font or fontconfig is involved. Output depends only on
//! the data: the same figures give the same bytes.

use std::path::Path;
use std::sync::OnceLock;

use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

use crate::{Error, Result};

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

fn ensure_font() -> Result<()> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok =
        *REGISTERED.get_or_init(|| register_font("sans-serif", FontStyle::Normal, FONT).is_ok());
    if ok {
        Ok(())
    } else {
        Err(Error::Other(
            "cannot load the shipped DejaVu Sans font".into(),
        ))
    }
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mark {
    /// A polyline through the points.
    Line,
    /// Unconnected dots.
    Points,
    /// A polyline with a dot at each point.
    LinePoints,
    /// A dashed-looking thin line (reference curves such as "ideal").
    Reference,
}

/// One named series of (x, y) points.
#[derive(Clone, Debug)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub mark: Mark,
}

impl Series {
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>, mark: Mark) -> Self {
        Series {
            name: name.into(),
            points,
            mark,
        }
    }
}

/// An x-y chart of several series.
#[derive(Clone, Debug, Default)]
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Fixed y range (default: 0 or the data minimum to the data maximum).
    pub y_range: Option<(f64, f64)>,
    /// Logarithmic x axis (all x must be positive).
    pub x_log: bool,
}

/// A stacked bar chart: one bar per category, one stack segment per part.
#[derive(Clone, Debug, Default)]
pub struct Bars {
    pub title: String,
    pub y_label: String,
    pub categories: Vec<String>,
    /// (part name, value per category).
    pub parts: Vec<(String, Vec<f64>)>,
}

const WIDTH: u32 = 720;
const HEIGHT: u32 = 440;

fn palette(i: usize) -> RGBColor {
    const P: [RGBColor; 10] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(127, 127, 127),
        RGBColor(188, 189, 34),
        RGBColor(23, 190, 207),
    ];
    P[i % P.len()]
}

fn plot_err(e: impl std::fmt::Display) -> Error {
    Error::Other(format!("plot: {e}"))
}

fn range_of(values: impl Iterator<Item = f64>, from_zero: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if from_zero && lo > 0.0 {
        lo = 0.0;
    }
    if hi - lo < 1e-12 {
        hi = lo + 1.0;
    }
    let pad = (hi - lo) * 0.05;
    (if lo == 0.0 { 0.0 } else { lo - pad }, hi + pad)
}

impl Chart {
    /// The chart as an SVG document.
    pub fn to_svg(&self) -> Result<String> {
        ensure_font()?;
        let mut out = String::new();
        {
            let root = SVGBackend::with_string(&mut out, (WIDTH, HEIGHT)).into_drawing_area();
            root.fill(&WHITE).map_err(plot_err)?;
            let pts = || self.series.iter().flat_map(|s| s.points.iter());
            let (x0, x1) = range_of(pts().map(|p| p.0), false);
            let (y0, y1) = self
                .y_range
                .unwrap_or_else(|| range_of(pts().map(|p| p.1), true));
            let mut builder = ChartBuilder::on(&root);
            builder
                .caption(&self.title, ("sans-serif", 18))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(60);
            if self.x_log {
                let lo = pts()
                    .map(|p| p.0)
                    .filter(|x| *x > 0.0)
                    .fold(f64::INFINITY, f64::min);
                let lo = if lo.is_finite() { lo * 0.8 } else { 1e-3 };
                let hi = x1.max(lo * 10.0);
                let mut chart = builder
                    .build_cartesian_2d((lo..hi).log_scale(), y0..y1)
                    .map_err(plot_err)?;
                self.draw_mesh_and_series(&mut chart)?;
            } else {
                let mut chart = builder
                    .build_cartesian_2d(x0..x1, y0..y1)
                    .map_err(plot_err)?;
                self.draw_mesh_and_series(&mut chart)?;
            }
            root.present().map_err(plot_err)?;
        }
        Ok(out)
    }

    /// Axes, labels and every series, on either x axis (linear or log).
    fn draw_mesh_and_series<'a, DB, X, Y>(
        &self,
        chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    ) -> Result<()>
    where
        DB: DrawingBackend + 'a,
        X: plotters::coord::ranged1d::Ranged<ValueType = f64>
            + plotters::coord::ranged1d::ValueFormatter<f64>,
        Y: plotters::coord::ranged1d::Ranged<ValueType = f64>
            + plotters::coord::ranged1d::ValueFormatter<f64>,
    {
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .label_style(("sans-serif", 12))
            .draw()
            .map_err(plot_err)?;
        draw_series(chart, &self.series)
    }

    /// Writes the chart as SVG to `path`.
    pub fn write_svg(&self, path: &Path) -> Result<()> {
        let svg = self.to_svg()?;
        std::fs::write(path, svg).map_err(|e| Error::io(path, e))
    }
}

fn draw_series<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    series: &[Series],
) -> Result<()>
where
    DB: DrawingBackend + 'a,
    X: plotters::coord::ranged1d::Ranged<ValueType = f64>,
    Y: plotters::coord::ranged1d::Ranged<ValueType = f64>,
{
    for (i, s) in series.iter().enumerate() {
        let color = palette(i);
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        let style = ShapeStyle::from(&color).stroke_width(2);
        let anno = match s.mark {
            Mark::Line | Mark::LinePoints => chart
                .draw_series(LineSeries::new(pts.clone(), style))
                .map_err(plot_err)?,
            Mark::Reference => chart
                .draw_series(LineSeries::new(
                    pts.clone(),
                    ShapeStyle::from(&color.mix(0.6)).stroke_width(1),
                ))
                .map_err(plot_err)?,
            Mark::Points => chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
                .map_err(plot_err)?,
        };
        anno.label(s.name.clone()).legend(move |(x, y)| {
            PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
        });
        if s.mark == Mark::LinePoints {
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
                .map_err(plot_err)?;
        }
    }
    if series.len() > 1 {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 12))
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .map_err(plot_err)?;
    }
    Ok(())
}

impl Bars {
    /// The chart as an SVG document.
    pub fn to_svg(&self) -> Result<String> {
        ensure_font()?;
        let n = self.categories.len().max(1);
        let totals: Vec<f64> = (0..n)
            .map(|c| {
                self.parts
                    .iter()
                    .map(|(_, v)| v.get(c).copied().unwrap_or(0.0).max(0.0))
                    .sum()
            })
            .collect();
        let top = totals.iter().copied().fold(0.0f64, f64::max).max(1e-12) * 1.08;
        let mut out = String::new();
        {
            let root = SVGBackend::with_string(&mut out, (WIDTH, HEIGHT)).into_drawing_area();
            root.fill(&WHITE).map_err(plot_err)?;
            let mut chart = ChartBuilder::on(&root)
                .caption(&self.title, ("sans-serif", 18))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d((0u32..n as u32).into_segmented(), 0f64..top)
                .map_err(plot_err)?;
            let cats = self.categories.clone();
            chart
                .configure_mesh()
                .disable_x_mesh()
                .x_labels(n.min(64))
                .x_label_formatter(&move |v| match v {
                    SegmentValue::CenterOf(i) => cats.get(*i as usize).cloned().unwrap_or_default(),
                    _ => String::new(),
                })
                .y_desc(&self.y_label)
                .label_style(("sans-serif", 12))
                .draw()
                .map_err(plot_err)?;
            let mut base = vec![0.0; n];
            for (k, (name, values)) in self.parts.iter().enumerate() {
                let color = palette(k);
                let rects: Vec<_> = (0..n)
                    .map(|c| {
                        let v = values.get(c).copied().unwrap_or(0.0).max(0.0);
                        let mut r = Rectangle::new(
                            [
                                (SegmentValue::Exact(c as u32), base[c]),
                                (SegmentValue::Exact(c as u32 + 1), base[c] + v),
                            ],
                            color.filled(),
                        );
                        r.set_margin(0, 0, 6, 6);
                        base[c] += v;
                        r
                    })
                    .collect();
                chart
                    .draw_series(rects)
                    .map_err(plot_err)?
                    .label(name.clone())
                    .legend(move |(x, y)| {
                        Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled())
                    });
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 12))
                .position(SeriesLabelPosition::UpperRight)
                .draw()
                .map_err(plot_err)?;
            root.present().map_err(plot_err)?;
        }
        Ok(out)
    }

    /// Writes the chart as SVG to `path`.
    pub fn write_svg(&self, path: &Path) -> Result<()> {
        let svg = self.to_svg()?;
        std::fs::write(path, svg).map_err(|e| Error::io(path, e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn charts_are_deterministic_svg_with_every_label() {
        let chart = Chart {
            title: "speed-up".into(),
            x_label: "processors".into(),
            y_label: "speed-up".into(),
            series: vec![
                Series::new("ideal", vec![(1.0, 1.0), (8.0, 8.0)], Mark::Reference),
                Series::new(
                    "hybrid",
                    vec![(1.0, 1.0), (2.0, 1.9), (8.0, 6.5)],
                    Mark::LinePoints,
                ),
            ],
            ..Chart::default()
        };
        let a = chart.to_svg().unwrap();
        assert_eq!(a, chart.to_svg().unwrap());
        assert!(a.starts_with("<svg"));
        for word in ["speed-up", "processors", "ideal", "hybrid"] {
            assert!(a.contains(word), "{word} missing");
        }
        let log = Chart {
            x_log: true,
            ..chart
        };
        assert!(log.to_svg().unwrap().contains("hybrid"));
    }

    #[test]
    fn stacked_bars_and_degenerate_input() {
        let bars = Bars {
            title: "time".into(),
            y_label: "s".into(),
            categories: vec!["p0".into(), "p1".into()],
            parts: vec![
                ("executing".into(), vec![1.0, 2.0]),
                ("idle".into(), vec![0.5, f64::NAN]),
            ],
        };
        let svg = bars.to_svg().unwrap();
        assert!(svg.contains("executing") && svg.contains("p1"));
        // No data at all still draws (empty axes), never panics.
        assert!(Chart::default().to_svg().is_ok());
        assert!(Bars::default().to_svg().is_ok());
    }
}
