//! `weight_curve.png`: the weight of each collapse, in order (log scale when all are > 0).
//!
//! Text needs a font: plotters is built without system font support (no system libraries),
//! so a TrueType font is loaded from `PORTALFIND_FONT` or a few usual places (DejaVu Sans,
//! Liberation Sans, Arial). Without one, the chart is drawn without captions and labels.

use super::OutputError;
use crate::decimate::Step;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

const FONT_CANDIDATES: [&str; 6] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/Library/Fonts/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

/// Registers a font as "sans-serif" once; returns whether one is available.
fn font_available() -> bool {
    static FONT: OnceLock<bool> = OnceLock::new();
    *FONT.get_or_init(|| {
        let env = std::env::var("PORTALFIND_FONT").ok();
        let paths = env.iter().map(|s| s.as_str()).chain(FONT_CANDIDATES);
        for p in paths {
            if let Ok(bytes) = std::fs::read(p) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok() {
                    return true;
                }
            }
        }
        false
    })
}

fn err<E: std::fmt::Debug>(e: E) -> OutputError {
    OutputError::Plot(format!("{e:?}"))
}

/// Draws the curve into `path` (PNG, 1000 × 600).
pub fn weight_curve(path: &Path, steps: &[Step], title: &str, threshold: Option<f64>) -> Result<(), OutputError> {
    let text = font_available();
    let root = BitMapBackend::new(path, (1000, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let n = steps.len().max(1) as f64;
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for s in steps {
        lo = lo.min(s.weight);
        hi = hi.max(s.weight);
    }
    if let Some(t) = threshold.filter(|t| t.is_finite()) {
        lo = lo.min(t);
        hi = hi.max(t);
    }
    if !lo.is_finite() || !hi.is_finite() {
        (lo, hi) = (1.0, 10.0);
    }
    let points: Vec<(f64, f64)> = steps
        .iter()
        .enumerate()
        .map(|(i, s)| ((i + 1) as f64, s.weight))
        .collect();
    let mut b = ChartBuilder::on(&root);
    b.margin(20);
    if text {
        b.caption(title, ("sans-serif", 22))
            .x_label_area_size(45)
            .y_label_area_size(80);
    }
    if lo > 0.0 {
        let (ylo, yhi) = if hi > lo {
            (lo / 1.2, hi * 1.2)
        } else {
            (lo / 2.0, lo * 2.0)
        };
        let mut chart = b.build_cartesian_2d(0.0..n, (ylo..yhi).log_scale()).map_err(err)?;
        if text {
            chart
                .configure_mesh()
                .x_desc("collapse")
                .y_desc("weight (log)")
                .draw()
                .map_err(err)?;
        }
        chart.draw_series(LineSeries::new(points, &BLUE)).map_err(err)?;
        if let Some(t) = threshold.filter(|t| *t > 0.0 && t.is_finite()) {
            chart
                .draw_series(LineSeries::new([(0.0, t), (n, t)], RED.stroke_width(1)))
                .map_err(err)?;
        }
    } else {
        let (ylo, yhi) = if hi > lo { (lo, hi * 1.05) } else { (lo - 1.0, lo + 1.0) };
        let mut chart = b.build_cartesian_2d(0.0..n, ylo..yhi).map_err(err)?;
        if text {
            chart
                .configure_mesh()
                .x_desc("collapse")
                .y_desc("weight")
                .draw()
                .map_err(err)?;
        }
        chart.draw_series(LineSeries::new(points, &BLUE)).map_err(err)?;
        if let Some(t) = threshold.filter(|t| t.is_finite()) {
            chart
                .draw_series(LineSeries::new([(0.0, t), (n, t)], RED.stroke_width(1)))
                .map_err(err)?;
        }
    }
    root.present().map_err(err)?;
    Ok(())
}

const FILE: &str = "weight_curve.png";

/// Writes `weight_curve.png`.
pub struct WeightPng;

impl super::Exporter for WeightPng {
    fn name(&self) -> &'static str {
        "weight curve (PNG)"
    }

    fn files(&self, _: &super::ExportContext<'_>) -> Vec<String> {
        vec![FILE.into()]
    }

    fn owns(&self, file_name: &str) -> bool {
        file_name == FILE
    }

    fn write(&self, ctx: &super::ExportContext<'_>) -> Result<Vec<std::path::PathBuf>, OutputError> {
        let dec = ctx.dec;
        let threshold = match dec.settings.stop {
            crate::decimate::StopRule::Threshold(w) => Some(w),
            _ => None,
        };
        let title = format!(
            "{}: {} / {}, {} collapses",
            ctx.model.name,
            dec.settings.heuristic,
            dec.settings.estimator,
            dec.steps.len()
        );
        let path = ctx.dir.join(FILE);
        super::write_atomic(&path, |tmp| weight_curve(tmp, &dec.steps, &title, threshold))?;
        Ok(vec![path])
    }
}

/// One labelled point of a [`scatter`] plot, in a series (drawn with the series' colour).
#[derive(Clone, Debug)]
pub struct ScatterPoint {
    /// Label written next to the point.
    pub label: String,
    /// Series index (0: blue circles, 1: red triangles, then more colours).
    pub series: usize,
    /// x (> 0: the axis is logarithmic).
    pub x: f64,
    /// y.
    pub y: f64,
}

fn scatter_on<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    points: &[ScatterPoint],
    title: &str,
    labels: (&str, &str),
    series: &[&str],
) -> Result<(), OutputError>
where
    DB::ErrorType: 'static,
{
    let text = font_available();
    root.fill(&WHITE).map_err(err)?;
    let (mut xlo, mut xhi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut yhi = 0.0f64;
    for p in points {
        xlo = xlo.min(p.x);
        xhi = xhi.max(p.x);
        yhi = yhi.max(p.y);
    }
    if !(xlo.is_finite() && xlo > 0.0) {
        (xlo, xhi) = (0.01, 10.0);
    }
    let mut b = ChartBuilder::on(&root);
    b.margin(20);
    if text {
        b.caption(title, ("sans-serif", 22))
            .x_label_area_size(45)
            .y_label_area_size(70);
    }
    let mut chart = b
        .build_cartesian_2d((xlo / 1.5..xhi * 3.0).log_scale(), 0.0..(yhi * 1.1).max(0.05))
        .map_err(err)?;
    if text {
        chart
            .configure_mesh()
            .x_label_formatter(&|x| format!("{x:.2}"))
            .x_desc(labels.0)
            .y_desc(labels.1)
            .draw()
            .map_err(err)?;
    }
    let colours = [BLUE, RED, GREEN, MAGENTA, CYAN, BLACK];
    for (k, name) in series.iter().enumerate() {
        let c = colours[k % colours.len()];
        let pts: Vec<&ScatterPoint> = points.iter().filter(|p| p.series == k).collect();
        let s = chart
            .draw_series(pts.iter().map(|p| {
                if k % 2 == 0 {
                    Circle::new((p.x, p.y), 5, c.filled()).into_dyn()
                } else {
                    TriangleMarker::new((p.x, p.y), 6, c.filled()).into_dyn()
                }
            }))
            .map_err(err)?;
        if text {
            s.label(*name).legend(move |(x, y)| Circle::new((x, y), 5, c.filled()));
            chart
                .draw_series(pts.iter().map(|p| {
                    Text::new(
                        p.label.clone(),
                        (p.x * 1.08, p.y),
                        ("sans-serif", 13).into_font().color(&c),
                    )
                }))
                .map_err(err)?;
        }
    }
    if text {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// A scatter plot of labelled points (log x), one marker and colour per series, as PNG
/// (1200 × 800) when `path` ends in `.png`, else SVG.
pub fn scatter(
    path: &Path,
    points: &[ScatterPoint],
    title: &str,
    labels: (&str, &str),
    series: &[&str],
) -> Result<(), OutputError> {
    if path.extension().is_some_and(|e| e == "png") {
        scatter_on(
            BitMapBackend::new(path, (1200, 800)).into_drawing_area(),
            points,
            title,
            labels,
            series,
        )
    } else {
        scatter_on(
            SVGBackend::new(path, (1200, 800)).into_drawing_area(),
            points,
            title,
            labels,
            series,
        )
    }
}
