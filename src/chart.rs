//! Minimal SVG charts for every system's figures (stairs, LIP map, multi-layer traces, arm): lines, markers, filled rectangles, and
//! optionally equal x/y scales for maps. SVG keeps text as text for the viewer to render,
//! so no font has to be found or shipped at run time.

use std::fmt::Write;

/// One line of a chart.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// SVG colour: a name or `#rrggbb`.
    pub color: &'static str,
    /// Data points `(x, y)` in data units; non-finite ones are skipped when drawn.
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
    /// SVG fill colour: a name or `#rrggbb`.
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

const WIDTH: f64 = 800.0;
const HEIGHT: f64 = 420.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 20.0;
const TOP: f64 = 40.0;
const BOTTOM: f64 = 50.0;
/// Points drawn per series at most; longer series are thinned evenly.
const MAX_POINTS: usize = 4000;

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

    /// The chart as an SVG document. Non-finite points are skipped.
    pub fn to_svg(&self) -> String {
        let finite = |&(x, y): &(f64, f64)| x.is_finite() && y.is_finite();
        let corners = self.areas.iter().flat_map(|a| [a.min, a.max]);
        let all = self.series.iter().flat_map(|s| s.points.iter().copied()).chain(corners).filter(finite);
        let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for (x, y) in all {
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
        }
        // No finite point, or all at one x: a unit range around it.
        if x0.partial_cmp(&x1) != Some(std::cmp::Ordering::Less) {
            (x0, x1) = if x0.is_finite() { (x0 - 0.5, x0 + 0.5) } else { (0.0, 1.0) };
        }
        if y0.partial_cmp(&y1) != Some(std::cmp::Ordering::Less) {
            (y0, y1) = if y0.is_finite() { (y0 - 0.5, y0 + 0.5) } else { (0.0, 1.0) };
        }
        let pad = 0.05 * (y1 - y0);
        (y0, y1) = (y0 - pad, y1 + pad);
        let (pw, ph) = (WIDTH - LEFT - RIGHT, HEIGHT - TOP - BOTTOM);
        if self.equal_axes {
            // Widen the range that has more data per pixel, about its centre.
            let scale = ((x1 - x0) / pw).max((y1 - y0) / ph);
            let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
            (x0, x1, y0, y1) =
                (cx - 0.5 * scale * pw, cx + 0.5 * scale * pw, cy - 0.5 * scale * ph, cy + 0.5 * scale * ph);
        }
        let sx = |x: f64| LEFT + (x - x0) / (x1 - x0) * pw;
        let sy = |y: f64| TOP + (1.0 - (y - y0) / (y1 - y0)) * ph;

        let mut svg = String::new();
        // Writing to a String cannot fail.
        let _ = writeln!(
            svg,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" font-family="sans-serif" font-size="12">"#
        );
        let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="22" font-size="15" text-anchor="middle">{}</text>"#,
            WIDTH / 2.0,
            escape(&self.title)
        );
        let _ = writeln!(svg, r#"<rect x="{LEFT}" y="{TOP}" width="{pw}" height="{ph}" fill="none" stroke="black"/>"#);
        for x in round_ticks(x0, x1) {
            let _ = writeln!(svg, r##"<line x1="{0}" y1="{TOP}" x2="{0}" y2="{1}" stroke="#ddd"/>"##, sx(x), TOP + ph);
            let _ =
                writeln!(svg, r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#, sx(x), TOP + ph + 16.0, tick(x));
        }
        for y in round_ticks(y0, y1) {
            let _ =
                writeln!(svg, r##"<line x1="{LEFT}" y1="{0}" x2="{1}" y2="{0}" stroke="#ddd"/>"##, sy(y), LEFT + pw);
            let _ =
                writeln!(svg, r#"<text x="{}" y="{}" text-anchor="end">{}</text>"#, LEFT - 6.0, sy(y) + 4.0, tick(y));
        }
        let _ = writeln!(
            svg,
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
            LEFT + pw / 2.0,
            HEIGHT - 10.0,
            escape(&self.x_label)
        );
        let _ = writeln!(
            svg,
            r#"<text x="16" y="{0}" text-anchor="middle" transform="rotate(-90 16 {0})">{1}</text>"#,
            TOP + ph / 2.0,
            escape(&self.y_label)
        );
        for a in self.areas.iter().filter(|a| finite(&a.min) && finite(&a.max)) {
            let (left, top) = (sx(a.min.0), sy(a.max.1));
            let (w, h) = (sx(a.max.0) - left, sy(a.min.1) - top);
            let _ =
                writeln!(svg, r#"<rect x="{left:.1}" y="{top:.1}" width="{w:.1}" height="{h:.1}" fill="{}"/>"#, a.fill);
        }
        // Legend rows for named series only: a series without a name (one of many outlines
        // of the same kind) is drawn but not listed.
        let mut row = 0usize;
        for s in &self.series {
            let k = row;
            row += usize::from(!s.name.is_empty());
            if s.markers {
                for (x, y) in s.points.iter().filter(|p| finite(p)) {
                    let _ =
                        writeln!(svg, r#"<circle cx="{:.1}" cy="{:.1}" r="3" fill="{}"/>"#, sx(*x), sy(*y), s.color);
                }
                if !s.name.is_empty() {
                    let ly = TOP + 14.0 + 16.0 * k as f64;
                    let _ =
                        writeln!(svg, r#"<circle cx="{}" cy="{}" r="3" fill="{}"/>"#, LEFT + 20.0, ly - 4.0, s.color);
                    let _ = writeln!(svg, r#"<text x="{}" y="{ly}">{}</text>"#, LEFT + 36.0, escape(&s.name));
                }
                continue;
            }
            let stride = s.points.len().div_ceil(MAX_POINTS).max(1);
            let mut path = String::new();
            for (x, y) in s.points.iter().step_by(stride).filter(|p| finite(p)) {
                let _ = write!(path, "{:.1},{:.1} ", sx(*x), sy(*y));
            }
            let dash = if s.dashed { r#" stroke-dasharray="6 4""# } else { "" };
            let _ = writeln!(
                svg,
                r#"<polyline fill="none" stroke="{}" stroke-width="1.5"{dash} points="{path}"/>"#,
                s.color
            );
            if s.name.is_empty() {
                continue;
            }
            let ly = TOP + 14.0 + 16.0 * k as f64;
            let _ = writeln!(
                svg,
                r#"<line x1="{0}" y1="{1}" x2="{2}" y2="{1}" stroke="{3}" stroke-width="2"{dash}/>"#,
                LEFT + 10.0,
                ly - 4.0,
                LEFT + 30.0,
                s.color
            );
            let _ = writeln!(svg, r#"<text x="{}" y="{ly}">{}</text>"#, LEFT + 36.0, escape(&s.name));
        }
        svg.push_str("</svg>\n");
        svg
    }
}

/// Tick positions inside `[lo, hi]` at the smallest round step (1, 2 or 5 × 10^k) giving at
/// most about 8 ticks.
fn round_ticks(lo: f64, hi: f64) -> impl Iterator<Item = f64> {
    let raw = (hi - lo) / 8.0;
    let magnitude = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * magnitude).find(|&s| s >= raw).unwrap_or(raw);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    // Multiples of the step, snapped so that 0.1 * 3 prints as 0.3.
    (first..=last).map(move |k| (k as f64 * step / magnitude).round() * magnitude)
}

fn tick(v: f64) -> String {
    if v == 0.0 || (1e-2..1e4).contains(&v.abs()) {
        format!("{v:.3}").trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.1e}")
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// Create `dir` and write each `(file name, text)` into it; returns the paths written.
///
/// # Errors
/// The directory or a file cannot be written.
pub fn write_files(dir: &std::path::Path, files: Vec<(String, String)>) -> std::io::Result<Vec<std::path::PathBuf>> {
    std::fs::create_dir_all(dir)?;
    files
        .into_iter()
        .map(|(name, text)| {
            let path = dir.join(name);
            std::fs::write(&path, text)?;
            Ok(path)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_fall_on_round_steps_inside_the_range() {
        let ticks: Vec<f64> = round_ticks(-0.205, 6.145).collect();
        assert_eq!(ticks, [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let ticks: Vec<f64> = round_ticks(-1.625, 1.125).collect();
        assert_eq!(ticks, [-1.5, -1.0, -0.5, 0.0, 0.5, 1.0]);
        let ticks: Vec<String> = round_ticks(0.0, 9.999).map(tick).collect();
        assert_eq!(ticks, ["0", "2", "4", "6", "8"]);
    }

    #[test]
    fn a_chart_maps_its_extremes_to_the_plot_corners() {
        let svg = Chart::new("t <1>", "x", "y")
            .with(Series::new("a", "red", vec![(0.0, 0.0), (1.0, 1.0), (0.5, f64::NAN)]))
            .to_svg();
        assert!(svg.contains("t &lt;1&gt;"));
        // y spans [0, 1] padded by 5 %: the data's corners sit inside the frame.
        let (pw, ph) = (WIDTH - LEFT - RIGHT, HEIGHT - TOP - BOTTOM);
        let low = format!("{:.1},{:.1}", LEFT, TOP + ph * (1.0 - 0.05 / 1.1));
        let high = format!("{:.1},{:.1}", LEFT + pw, TOP + ph * (0.05 / 1.1));
        assert!(svg.contains(&low) && svg.contains(&high), "{svg}");
        assert_eq!(svg.matches("<polyline").count(), 1);
    }

    #[test]
    fn equal_axes_give_both_axes_one_scale_and_areas_and_markers_are_drawn() {
        let svg = Chart::new("map", "x", "y")
            .equal_axes()
            .with_area(Area { min: (0.0, 0.0), max: (1.0, 1.0), fill: "gray" })
            .with(Series::new("dots", "red", vec![(0.0, 0.0), (4.0, 1.0)]).markers())
            .to_svg();
        // The unit square must come out square in pixels.
        let rect = svg.lines().find(|l| l.contains(r#"fill="gray""#)).expect("area drawn");
        let attr = |name: &str| -> f64 {
            let start = rect.find(&format!(r#" {name}=""#)).expect("attribute") + name.len() + 3;
            rect[start..].split('"').next().and_then(|v| v.parse().ok()).expect("number")
        };
        assert!((attr("width") - attr("height")).abs() <= 0.2, "{rect}");
        assert!(attr("width") > 10.0);
        assert_eq!(svg.matches("<circle").count(), 3, "two dots and a legend dot");
        assert_eq!(svg.matches("<polyline").count(), 0);
    }
}
