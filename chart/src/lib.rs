//! Every system's figures (stairs, campaign, perception, LIP map, multi-layer traces, arm):
//! a small declarative description ([`Chart`]: lines, dots, filled rectangles, optionally
//! one scale on both axes for maps) drawn by `plotters` as SVG and as PNG.
//!
//! SVG keeps its text as text; the text is laid out, and drawn into the PNG, with DejaVu
//! Sans, embedded in the binary, so no system font is looked for.

#![warn(missing_docs)]

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;

/// One line (or set of dots) of a chart.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text; empty: drawn but not listed (one of many outlines of a kind).
    pub name: String,
    /// Colour: `#rrggbb`, or one of the names `black`, `gray`, `red`, `green`, `blue`,
    /// `orange` (anything else draws black).
    pub color: &'static str,
    /// Data points `(x, y)` in data units; a non-finite one breaks the line there.
    pub points: Vec<(f64, f64)>,
    /// Drawn dashed (reference lines).
    pub dashed: bool,
    /// Drawn as separate dots instead of a line (e.g. footsteps).
    pub markers: bool,
}

impl Series {
    /// A solid line named `name` in `color` through `points`.
    pub fn new(name: &str, color: &'static str, points: Vec<(f64, f64)>) -> Self {
        Self { name: name.to_string(), color, points, dashed: false, markers: false }
    }

    /// Draw this series dashed.
    pub fn dashed(mut self) -> Self {
        self.dashed = true;
        self
    }

    /// Draw this series as separate dots.
    pub fn markers(mut self) -> Self {
        self.markers = true;
        self
    }
}

/// A filled axis-aligned rectangle in data coordinates (e.g. an obstacle).
#[derive(Debug, Clone, PartialEq)]
pub struct Area {
    /// Lower-left corner `(x, y)` in data units.
    pub min: (f64, f64),
    /// Upper-right corner `(x, y)` in data units.
    pub max: (f64, f64),
    /// Fill colour, as [`Series::color`].
    pub fill: &'static str,
}

/// A chart: title, axis labels, series.
#[derive(Debug, Clone)]
pub struct Chart {
    /// Title above the plot.
    pub title: String,
    /// Label under the x-axis (put the unit in it).
    pub x_label: String,
    /// Label along the y-axis (put the unit in it).
    pub y_label: String,
    /// Lines and dot sets, drawn in order and listed in the legend in that order.
    pub series: Vec<Series>,
    /// Drawn under the series.
    pub areas: Vec<Area>,
    /// One data unit is as long on x as on y (maps).
    pub equal_axes: bool,
}

/// Figure size in pixels (the PNG's; the SVG's in its units).
pub const SIZE: (u32, u32) = (800, 440);
/// Points drawn per series at most; longer series are thinned evenly.
const MAX_POINTS: usize = 4000;
// Margins around the plotting area, as the chart is built (caption, tick labels, axis
// descriptions): what `equal_axes` divides the data's extent by.
const CAPTION: u32 = 30;
const MARGIN: u32 = 12;
const X_LABELS: u32 = 45;
const Y_LABELS: u32 = 70;

impl Chart {
    /// An empty chart with its title and axis labels.
    pub fn new(title: &str, x_label: &str, y_label: &str) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            areas: Vec::new(),
            equal_axes: false,
        }
    }

    /// Add a filled rectangle, drawn under the series.
    pub fn with_area(mut self, area: Area) -> Self {
        self.areas.push(area);
        self
    }

    /// Give x and y one scale, so that shapes keep their proportions (maps).
    pub fn equal_axes(mut self) -> Self {
        self.equal_axes = true;
        self
    }

    /// Add a series.
    pub fn with(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }

    /// The chart as an SVG document.
    ///
    /// # Errors
    /// What `plotters` reports while drawing (nothing, for an in-memory document).
    pub fn to_svg(&self) -> std::io::Result<String> {
        let mut svg = String::new();
        self.draw(SVGBackend::with_string(&mut svg, SIZE).into_drawing_area())?;
        Ok(svg)
    }

    /// Write the chart as `dir/stem.svg` and `dir/stem.png`; returns both paths.
    ///
    /// # Errors
    /// A file that cannot be written.
    pub fn write(&self, dir: &Path, stem: &str) -> std::io::Result<[PathBuf; 2]> {
        std::fs::create_dir_all(dir).map_err(at(dir))?;
        let (svg, png) = (dir.join(format!("{stem}.svg")), dir.join(format!("{stem}.png")));
        std::fs::write(&svg, self.to_svg()?).map_err(at(&svg))?;
        self.draw(BitMapBackend::new(&png, SIZE).into_drawing_area()).map_err(at(&png))?;
        Ok([svg, png])
    }

    /// The data's ranges, padded, and for `equal_axes` widened about their centres so
    /// that a data unit takes as many pixels on either axis.
    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let finite = |&(x, y): &(f64, f64)| x.is_finite() && y.is_finite();
        let corners = self.areas.iter().flat_map(|a| [a.min, a.max]);
        let all = self.series.iter().flat_map(|s| s.points.iter().copied()).chain(corners).filter(finite);
        let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for (x, y) in all {
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
        }
        // No finite point, or all at one value: a unit range around it.
        let widen = |lo: f64, hi: f64| match lo.partial_cmp(&hi) {
            Some(std::cmp::Ordering::Less) => (lo, hi),
            _ if lo.is_finite() => (lo - 0.5, lo + 0.5),
            _ => (0.0, 1.0),
        };
        let ((x0, x1), (y0, y1)) = (widen(x0, x1), widen(y0, y1));
        let pad = 0.05 * (y1 - y0);
        let (y0, y1) = (y0 - pad, y1 + pad);
        if !self.equal_axes {
            return ((x0, x1), (y0, y1));
        }
        let pw = f64::from(SIZE.0 - Y_LABELS - 2 * MARGIN);
        let ph = f64::from(SIZE.1 - CAPTION - X_LABELS - 2 * MARGIN);
        let scale = ((x1 - x0) / pw).max((y1 - y0) / ph);
        let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
        ((cx - 0.5 * scale * pw, cx + 0.5 * scale * pw), (cy - 0.5 * scale * ph, cy + 0.5 * scale * ph))
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> std::io::Result<()> {
        // Text is laid out with the font's metrics for either backend.
        register_font();
        self.draw_on(&root).map_err(|e| std::io::Error::other(format!("drawing {:?}: {e}", self.title)))?;
        root.present().map_err(|e| std::io::Error::other(format!("writing {:?}: {e}", self.title)))
    }

    fn draw_on<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        root.fill(&WHITE)?;
        let ((x0, x1), (y0, y1)) = self.ranges();
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", 18))
            .margin(MARGIN)
            .x_label_area_size(X_LABELS)
            .y_label_area_size(Y_LABELS)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .light_line_style(RGBColor(240, 240, 240))
            .bold_line_style(RGBColor(215, 215, 215))
            .label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 13))
            .draw()?;
        for a in self.areas.iter().filter(|a| [a.min.0, a.min.1, a.max.0, a.max.1].iter().all(|v| v.is_finite())) {
            chart.draw_series(std::iter::once(Rectangle::new([a.min, a.max], rgb(a.fill).filled())))?;
        }
        for s in &self.series {
            let color = rgb(s.color);
            let style = color.stroke_width(2);
            let legend = !s.name.is_empty();
            if s.markers {
                let dots = s.points.iter().copied().filter(|(x, y)| x.is_finite() && y.is_finite());
                let drawn = chart.draw_series(dots.map(|p| Circle::new(p, 3, color.filled())))?;
                if legend {
                    drawn.label(&s.name).legend(move |(x, y)| Circle::new((x + 10, y), 3, color.filled()));
                }
                continue;
            }
            let stride = s.points.len().div_ceil(MAX_POINTS).max(1);
            let thinned: Vec<(f64, f64)> = s.points.iter().copied().step_by(stride).collect();
            // A non-finite point ends one run of the line and the next finite one starts
            // another; the legend entry goes with the first run.
            let runs = thinned.split(|(x, y)| !(x.is_finite() && y.is_finite())).filter(|run| !run.is_empty());
            for (k, run) in runs.enumerate() {
                let drawn = if s.dashed {
                    chart.draw_series(DashedLineSeries::new(run.iter().copied(), 6, 4, style))?
                } else {
                    chart.draw_series(LineSeries::new(run.iter().copied(), style))?
                };
                if legend && k == 0 {
                    drawn.label(&s.name).legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
                }
            }
        }
        if self.series.iter().any(|s| !s.name.is_empty()) {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperLeft)
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(160, 160, 160))
                .label_font(("sans-serif", 12))
                .draw()?;
        }
        Ok(())
    }
}

/// Writes each chart as `dir/<stem>.svg` and `dir/<stem>.png`; returns the paths written.
///
/// # Errors
/// A file that cannot be written.
pub fn write_charts(dir: &Path, charts: &[(String, Chart)]) -> std::io::Result<Vec<PathBuf>> {
    let mut written = Vec::with_capacity(2 * charts.len());
    for (stem, chart) in charts {
        written.extend(chart.write(dir, stem)?);
    }
    Ok(written)
}

/// Create `dir` and write each `(file name, text)` into it; returns the paths written.
///
/// # Errors
/// The directory or a file cannot be written.
pub fn write_files(dir: &Path, files: Vec<(String, String)>) -> std::io::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(at(dir))?;
    files
        .into_iter()
        .map(|(name, text)| {
            let path = dir.join(name);
            std::fs::write(&path, text).map_err(at(&path))?;
            Ok(path)
        })
        .collect()
}

/// An I/O error that names the path it happened at (the OS's own message does not).
pub fn at(path: &Path) -> impl Fn(std::io::Error) -> std::io::Error + '_ {
    move |e| std::io::Error::new(e.kind(), format!("{}: {e}", path.display()))
}

/// DejaVu Sans as plotters' "sans-serif", once per process: the metrics text is laid out
/// with, and the glyphs the PNGs draw.
fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The embedded file is a valid font; were it not, the PNGs would lack their text.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular());
    });
}

/// A colour from `#rrggbb` or one of the few names the figures use; black otherwise.
fn rgb(color: &str) -> RGBColor {
    let named = match color {
        "black" => Some(RGBColor(0, 0, 0)),
        "gray" | "grey" => Some(RGBColor(128, 128, 128)),
        "red" => Some(RGBColor(220, 30, 30)),
        "green" => Some(RGBColor(40, 150, 40)),
        "blue" => Some(RGBColor(30, 80, 200)),
        "orange" => Some(RGBColor(255, 140, 0)),
        _ => None,
    };
    named
        .or_else(|| {
            let hex = color.strip_prefix('#').filter(|h| h.len() == 6)?;
            let byte = |i: usize| u8::from_str_radix(hex.get(i..i + 2)?, 16).ok();
            Some(RGBColor(byte(0)?, byte(2)?, byte(4)?))
        })
        .unwrap_or(BLACK)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_parse_from_hex_and_names() {
        assert_eq!(rgb("#1f77b4"), RGBColor(0x1f, 0x77, 0xb4));
        assert_eq!(rgb("gray"), RGBColor(128, 128, 128));
        assert_eq!(rgb("#12345"), BLACK);
        assert_eq!(rgb("#gg0000"), BLACK);
    }

    #[test]
    fn equal_axes_give_a_data_unit_the_same_pixels_on_both_axes() {
        let chart = Chart::new("map", "x", "y")
            .equal_axes()
            .with(Series::new("dots", "red", vec![(0.0, 0.0), (4.0, 1.0)]).markers());
        let ((x0, x1), (y0, y1)) = chart.ranges();
        let pw = f64::from(SIZE.0 - Y_LABELS - 2 * MARGIN);
        let ph = f64::from(SIZE.1 - CAPTION - X_LABELS - 2 * MARGIN);
        assert!(((x1 - x0) / pw - (y1 - y0) / ph).abs() < 1e-12);
        // The data still fits.
        assert!(x0 <= 0.0 && x1 >= 4.0 && y0 <= 0.0 && y1 >= 1.0);
    }

    #[test]
    fn a_chart_is_drawn_as_svg_and_png_with_its_text() {
        let dir = std::env::temp_dir().join(format!("cbfgen_chart_{}", std::process::id()));
        let chart = Chart::new("title <1>", "time [s]", "h")
            .with_area(Area { min: (0.2, 0.0), max: (0.4, 0.5), fill: "#f3d9d9" })
            .with(Series::new("a", "#1f77b4", vec![(0.0, 0.0), (1.0, 1.0), (1.5, f64::NAN), (2.0, 0.5), (3.0, 0.7)]))
            .with(Series::new("b", "black", vec![(0.0, 1.0), (3.0, 1.0)]).dashed());
        let [svg, png] = chart.write(&dir, "chart").expect("written");
        let text = std::fs::read_to_string(&svg).expect("svg");
        assert!(text.contains("title &lt;1&gt;") && text.contains("time [s]"), "{text}");
        // Three runs of line: "a" in two pieces around its NaN, and "b" (dashes are
        // drawn as separate segments).
        assert!(text.matches("<polyline").count() >= 3);
        let bytes = std::fs::read(&png).expect("png");
        assert_eq!(&bytes[1..4], b"PNG");
        // Text drawn into the PNG: its pixels are not all background and lines.
        assert!(bytes.len() > 5000);
        std::fs::remove_dir_all(&dir).ok();
    }
}
