//! What perception found, drawn over the truth: a side view (x–z) and a top view (x–y) of
//! the points coloured by the plane they lie on, each plane's hull, the edge cuboids
//! found (filled) and the true ones (dashed outlines).

use nalgebra::Vector3;

use super::planes::Plane;
use cbfgen::geometry::OrientedBox;
use cbfgen_chart::{Area, Chart, Series};

const PALETTE: [&str; 10] =
    ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#bcbd22", "#17becf", "#7f7f7f"];
/// Points drawn at most (evenly thinned): an SVG of 10⁵ dots is slow to open.
const MAX_DRAWN: usize = 6000;
/// A point within this of a plane (and, for a level plane, over its hull) is drawn in its
/// colour \[m\].
const ON_PLANE: f64 = 0.02;

/// Which axes a view shows: (horizontal, vertical) component indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum View {
    /// x against z.
    Side,
    /// x against y.
    Top,
}

impl View {
    fn axes(self) -> (usize, usize) {
        match self {
            View::Side => (0, 2),
            View::Top => (0, 1),
        }
    }
}

fn corners(b: &OrientedBox) -> impl Iterator<Item = Vector3<f64>> + '_ {
    (0..8).map(move |k| {
        let sign = Vector3::new([-1.0, 1.0][k & 1], [-1.0, 1.0][(k >> 1) & 1], [-1.0, 1.0][(k >> 2) & 1]);
        b.center() + b.rotation() * b.half_extents().component_mul(&sign)
    })
}

/// The box's bounding rectangle in the view.
fn extent(b: &OrientedBox, (h, v): (usize, usize)) -> ((f64, f64), (f64, f64)) {
    corners(b).fold(((f64::INFINITY, f64::INFINITY), (f64::NEG_INFINITY, f64::NEG_INFINITY)), |(lo, hi), c| {
        ((lo.0.min(c[h]), lo.1.min(c[v])), (hi.0.max(c[h]), hi.1.max(c[v])))
    })
}

/// Both views, named `side` and `top`, of what [`chart`] draws.
pub fn side_and_top(
    points: &[Vector3<f64>],
    planes: &[Plane],
    found: &[OrientedBox],
    truth: &[OrientedBox],
) -> [(&'static str, Chart); 2] {
    [View::Side, View::Top].map(|view| {
        let name = if view == View::Side { "side" } else { "top" };
        (name, chart(view, points, planes, found, truth))
    })
}

/// One view of `points`, `planes`, the `found` cuboids and the `truth`.
pub fn chart(
    view: View,
    points: &[Vector3<f64>],
    planes: &[Plane],
    found: &[OrientedBox],
    truth: &[OrientedBox],
) -> Chart {
    let (h, v) = view.axes();
    let name = match view {
        View::Side => "side view",
        View::Top => "top view",
    };
    let mut chart = Chart::new(
        &format!("Perception, {name}: points by plane, hulls, edge cuboids found (filled) and true (dashed)"),
        "x [m]",
        if view == View::Side { "z [m]" } else { "y [m]" },
    )
    .equal_axes();
    for b in found {
        let (min, max) = extent(b, (h, v));
        chart = chart.with_area(Area { min, max, fill: "#f4a6a6" });
    }
    let step = points.len().div_ceil(MAX_DRAWN).max(1);
    let mut by_plane: Vec<Vec<(f64, f64)>> = vec![Vec::new(); planes.len() + 1];
    for p in points.iter().step_by(step) {
        let k = planes
            .iter()
            .position(|pl| pl.distance(p).abs() <= ON_PLANE && (pl.normal.z < 0.9 || pl.covers_xy(p)))
            .unwrap_or(planes.len());
        by_plane[k].push((p[h], p[v]));
    }
    for (k, pts) in by_plane.into_iter().enumerate() {
        let (label, color) = if k < planes.len() {
            (format!("plane {k}"), PALETTE[k % PALETTE.len()])
        } else {
            ("no plane".into(), "#c8c8c8")
        };
        chart = chart.with(Series::new(&label, color, pts).markers());
    }
    for (k, plane) in planes.iter().enumerate() {
        let outline: Vec<(f64, f64)> =
            plane.polygon.iter().chain(plane.polygon.first()).map(|p| (p[h], p[v])).collect();
        chart = chart.with(Series::new(if k == 0 { "hulls" } else { "" }, "#333333", outline));
    }
    for (k, b) in truth.iter().enumerate() {
        let ((x0, y0), (x1, y1)) = extent(b, (h, v));
        let outline = vec![(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)];
        chart = chart.with(Series::new(if k == 0 { "true edge cuboids" } else { "" }, "#b00000", outline).dashed());
    }
    chart
}
