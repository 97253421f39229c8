//! `weight_curve.png` and `weight_curve.svg`: the weight of each collapse in order (log
//! scale when all weights are > 0) over the cells remaining, in two panels sharing the
//! collapse axis. The whole run is drawn, past the stop when the caller passes the full
//! decimation ([`super::Notes::full_steps`]; the collapses after the stop in a lighter
//! colour), with markers for the stop, the first collapse joining two ground-truth rooms
//! ([`super::Notes::first_join`]) and each snapshot, the stop threshold, and a legend.
//!
//! Text: the DejaVu Sans font is compiled into the binary (`assets/fonts/`, Bitstream Vera
//! licence, see `assets/fonts/DejaVuSans-LICENSE.txt`) and registered with plotters as
//! "sans-serif" ([`register_fonts`]), so labels never depend on the system's fonts.

use super::OutputError;
use crate::decimate::Step;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// DejaVu Sans, compiled in.
pub const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
/// The name the font is registered under.
pub const FONT_FAMILY: &str = "sans-serif";

/// Registers the bundled font with plotters (once; later calls return the first result).
/// The binary calls it at startup; drawing calls it too.
pub fn register_fonts() -> bool {
    static DONE: OnceLock<bool> = OnceLock::new();
    *DONE.get_or_init(|| plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT).is_ok())
}

pub(crate) fn err<E: std::fmt::Debug>(e: E) -> OutputError {
    OutputError::Plot(format!("{e:?}"))
}

/// The frame of the simple charts (the scatter plots, `evaluate`'s per-frame lines): a
/// 20-pixel margin and, when the font is registered (`text`), the caption (22 px) and the
/// label areas (45 px below, `y_area` left).
pub fn chart_frame<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    title: &str,
    text: bool,
    y_area: u32,
) -> ChartBuilder<'a, 'b, DB> {
    let mut b = ChartBuilder::on(area);
    b.margin(20);
    if text {
        b.caption(title, (FONT_FAMILY, 22))
            .x_label_area_size(45)
            .y_label_area_size(y_area);
    }
    b
}

/// The legend box of the simple charts: translucent white, black border.
pub fn legend_box<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
) -> Result<(), plotters::drawing::DrawingAreaErrorKind<DB::ErrorType>> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
}

/// What the weight curve shows.
#[derive(Clone, Debug, Default)]
pub struct Curve<'a> {
    /// Title.
    pub title: String,
    /// The collapses to draw (the full run when known).
    pub steps: &'a [Step],
    /// Collapses of the stopped run (the stop marker; `steps.len()` when it is the full run).
    pub stop: usize,
    /// Active cells before the first collapse.
    pub initial_cells: usize,
    /// The stop threshold, if the stop rule is one.
    pub threshold: Option<f64>,
    /// 1-based step of the first room-joining collapse.
    pub first_join: Option<usize>,
    /// Snapshots: (collapses, cells).
    pub snapshots: Vec<(usize, usize)>,
}

/// Three significant digits, without a trailing ".0" on integers.
pub(crate) fn sig(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let mag = v.abs().log10().floor() as i32;
    let dec = (2 - mag).max(0) as usize;
    let s = format!("{v:.dec$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Draws `c` onto `root`.
pub fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, c: &Curve<'_>) -> Result<(), OutputError>
where
    DB::ErrorType: 'static,
{
    register_fonts();
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(&c.title, (FONT_FAMILY, 22)).map_err(err)?;
    let (upper, lower) = root.split_vertically(root.dim_in_pixel().1 * 62 / 100);
    let n = c.steps.len().max(1) as i64;
    let stop = c.stop.min(c.steps.len());

    // Upper panel: weights.
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for s in c.steps {
        lo = lo.min(s.weight);
        hi = hi.max(s.weight);
    }
    if let Some(t) = c.threshold.filter(|t| t.is_finite()) {
        lo = lo.min(t);
        hi = hi.max(t);
    }
    if !lo.is_finite() || !hi.is_finite() {
        (lo, hi) = (1.0, 10.0);
    }
    let before: Vec<(i64, f64)> = c.steps[..stop]
        .iter()
        .enumerate()
        .map(|(i, s)| (i as i64 + 1, s.weight))
        .collect();
    let after: Vec<(i64, f64)> = if stop < c.steps.len() {
        let from = stop.saturating_sub(1);
        c.steps[from..]
            .iter()
            .enumerate()
            .map(|(i, s)| ((from + i) as i64 + 1, s.weight))
            .collect()
    } else {
        Vec::new()
    };
    let blue = RGBColor(31, 90, 200);
    let light = RGBColor(140, 175, 235);
    let red = RGBColor(208, 16, 28);
    let orange = RGBColor(230, 120, 0);
    let grey = RGBColor(120, 120, 120);
    let green = RGBColor(20, 140, 60);
    // One function for both scales: plotters' linear and log coordinates are different types.
    macro_rules! weights {
        ($range:expr, $desc:expr) => {{
            let mut chart = ChartBuilder::on(&upper)
                .margin(12)
                .x_label_area_size(30)
                .y_label_area_size(70)
                .build_cartesian_2d(0i64..n, $range)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_label_formatter(&|x| format!("{x}"))
                .y_label_formatter(&|y| sig(*y))
                .y_desc($desc)
                .label_style((FONT_FAMILY, 13))
                .draw()
                .map_err(err)?;
            let (ylo, yhi) = (lo.min(hi), hi.max(lo));
            chart
                .draw_series(LineSeries::new(before, blue.stroke_width(2)))
                .map_err(err)?
                .label("weight of each collapse")
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], blue.stroke_width(2)));
            if !after.is_empty() {
                chart
                    .draw_series(LineSeries::new(after, light.stroke_width(2)))
                    .map_err(err)?
                    .label("after the stop (full run)")
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], light.stroke_width(2)));
            }
            if let Some(t) = c.threshold.filter(|t| t.is_finite() && (*t > 0.0 || lo <= 0.0)) {
                chart
                    .draw_series(LineSeries::new([(0, t), (n, t)], green.stroke_width(1)))
                    .map_err(err)?
                    .label(format!("stop threshold {}", sig(t)))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], green.stroke_width(1)));
            }
            let vline = |x: i64| vec![(x, ylo), (x, yhi)];
            chart
                .draw_series(LineSeries::new(vline(stop as i64), red.stroke_width(2)))
                .map_err(err)?
                .label(format!("stop after {stop} collapses"))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], red.stroke_width(2)));
            if let Some(j) = c.first_join {
                chart
                    .draw_series(LineSeries::new(vline(j as i64), orange.stroke_width(2)))
                    .map_err(err)?
                    .label(format!("first room join: collapse {j}"))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], orange.stroke_width(2)));
            }
            for (k, &(at, _)) in c.snapshots.iter().enumerate() {
                let s = chart
                    .draw_series(LineSeries::new(vline(at as i64), grey.stroke_width(1)))
                    .map_err(err)?;
                if k == 0 {
                    let names: Vec<String> = c.snapshots.iter().map(|s| s.1.to_string()).collect();
                    s.label(format!("snapshots at {} cells", names.join(", ")))
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], grey.stroke_width(1)));
                }
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperLeft)
                .label_font((FONT_FAMILY, 13))
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()
                .map_err(err)?;
        }};
    }
    if lo > 0.0 {
        let (ylo, yhi) = if hi > lo {
            (lo / 1.2, hi * 1.2)
        } else {
            (lo / 2.0, lo * 2.0)
        };
        (lo, hi) = (ylo, yhi);
        weights!((ylo..yhi).log_scale(), "weight (log scale)");
    } else {
        let (ylo, yhi) = if hi > lo { (lo, hi * 1.05) } else { (lo - 1.0, lo + 1.0) };
        (lo, hi) = (ylo, yhi);
        weights!(ylo..yhi, "weight");
    }

    // Lower panel: cells remaining.
    let mut cells: Vec<(i64, f64)> = vec![(0, c.initial_cells.max(1) as f64)];
    cells.extend(
        c.steps
            .iter()
            .enumerate()
            .map(|(i, s)| (i as i64 + 1, s.cells_remaining.max(1) as f64)),
    );
    let top = (c.initial_cells.max(2) as f64) * 1.3;
    let mut chart = ChartBuilder::on(&lower)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0i64..n, (0.8f64..top).log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_label_formatter(&|x| format!("{x}"))
        .y_label_formatter(&|y| format!("{}", y.round() as i64))
        .x_desc("collapse")
        .y_desc("cells remaining (log)")
        .label_style((FONT_FAMILY, 13))
        .draw()
        .map_err(err)?;
    chart
        .draw_series(LineSeries::new(cells, BLACK.stroke_width(2)))
        .map_err(err)?
        .label("cells remaining")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    let vline = |x: i64| vec![(x, 0.8), (x, top)];
    chart
        .draw_series(LineSeries::new(vline(stop as i64), red.stroke_width(2)))
        .map_err(err)?;
    if let Some(j) = c.first_join {
        chart
            .draw_series(LineSeries::new(vline(j as i64), orange.stroke_width(2)))
            .map_err(err)?;
    }
    for &(at, _) in &c.snapshots {
        chart
            .draw_series(LineSeries::new(vline(at as i64), grey.stroke_width(1)))
            .map_err(err)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FONT_FAMILY, 13))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

/// Image size of both files.
pub const SIZE: (u32, u32) = (1100, 720);

/// Draws `c` into `path` as PNG.
pub fn weight_curve_png(path: &Path, c: &Curve<'_>) -> Result<(), OutputError> {
    let root = BitMapBackend::new(path, SIZE).into_drawing_area();
    draw(&root, c)
}

/// `c` as an SVG document.
pub fn weight_curve_svg(c: &Curve<'_>) -> Result<String, OutputError> {
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, SIZE).into_drawing_area();
        draw(&root, c)?;
    }
    Ok(s)
}

const PNG: &str = "weight_curve.png";
const SVG: &str = "weight_curve.svg";

/// Writes `weight_curve.png` and `weight_curve.svg`.
pub struct WeightPlot;

impl super::Exporter for WeightPlot {
    fn name(&self) -> &'static str {
        "weight curve (PNG, SVG)"
    }

    fn files(&self, _: &super::ExportContext<'_>) -> Vec<String> {
        vec![PNG.into(), SVG.into()]
    }

    fn owns(&self, file_name: &str) -> bool {
        file_name == PNG || file_name == SVG
    }

    fn write(&self, ctx: &super::ExportContext<'_>) -> Result<Vec<std::path::PathBuf>, OutputError> {
        let dec = ctx.dec;
        let threshold = match dec.settings.stop {
            crate::decimate::StopRule::Threshold(w) => Some(w),
            _ => None,
        };
        let steps = ctx
            .notes
            .full_steps
            .filter(|f| f.len() >= dec.steps.len())
            .unwrap_or(&dec.steps);
        let title = format!(
            "{}: {} / {}, stop {}: {} of {} collapses",
            ctx.model.name,
            dec.settings.heuristic,
            dec.settings.estimator,
            dec.settings.stop,
            dec.steps.len(),
            steps.len()
        );
        let curve = Curve {
            title,
            steps,
            stop: dec.steps.len(),
            initial_cells: dec.stats.initial_cells,
            threshold,
            first_join: ctx.notes.first_join,
            snapshots: ctx.snapshots.iter().map(|(s, _)| (s.collapses, s.cells)).collect(),
        };
        let png = ctx.dir.join(PNG);
        super::write_atomic(&png, |tmp| weight_curve_png(tmp, &curve))?;
        let svg = ctx.dir.join(SVG);
        let r = weight_curve_svg(&curve).and_then(|text| super::write_atomic(&svg, |tmp| std::fs::write(tmp, text)));
        if let Err(e) = r {
            let _ = std::fs::remove_file(&png);
            return Err(e);
        }
        Ok(vec![png, svg])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ids::CellId;

    fn steps(n: usize) -> Vec<Step> {
        (0..n)
            .map(|i| Step {
                a: CellId(0),
                b: CellId(i as u32 + 1),
                weight: 1.0 + (i as f64 * 0.37).sin().abs() + i as f64 * 0.01,
                cells_remaining: n - i,
                portal_area: 1.0,
                projected: [1.0, 1.0],
            })
            .collect()
    }

    #[test]
    fn significant_digits() {
        assert_eq!(sig(2000.0), "2000");
        assert_eq!(sig(1.23456), "1.23");
        assert_eq!(sig(0.012345), "0.0123");
        assert_eq!(sig(3.0), "3");
    }

    /// The font is compiled in: text is drawn whatever fonts the system has (no font path
    /// is read; `PORTALFIND_FONT` and system font directories are not consulted).
    #[test]
    fn renders_text_without_system_fonts() {
        assert!(register_fonts());
        let (w, h) = (400u32, 120u32);
        let mut buf = vec![255u8; (w * h * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            root.fill(&WHITE).unwrap();
            root.draw_text("weight 2000", &(FONT_FAMILY, 30).into_text_style(&root), (10, 40))
                .unwrap();
            root.present().unwrap();
        }
        let dark = buf.chunks(3).filter(|p| p[0] < 128 && p[1] < 128 && p[2] < 128).count();
        assert!(dark > 200, "only {dark} dark pixels: the text was not drawn");
    }

    #[test]
    fn curve_with_markers_in_both_formats() {
        let all = steps(300);
        let c = Curve {
            title: "test: aspect / hull".into(),
            steps: &all,
            stop: 250,
            initial_cells: 301,
            threshold: Some(1.5),
            first_join: Some(280),
            snapshots: vec![(100, 201), (200, 101)],
        };
        let svg = weight_curve_svg(&c).unwrap();
        for label in [
            "stop after 250 collapses",
            "first room join: collapse 280",
            "snapshots at 201, 101 cells",
            "after the stop (full run)",
            "cells remaining",
            "collapse",
        ] {
            assert!(svg.contains(label), "missing {label:?}");
        }
        // Integer ticks on the collapse axis.
        assert!(!svg.contains(">100.0<") && !svg.contains(">2000.0<"));
        let dir = std::env::temp_dir().join(format!("portalfind-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let png = dir.join("c.png");
        weight_curve_png(&png, &c).unwrap();
        assert!(std::fs::metadata(&png).unwrap().len() > 10_000);
        std::fs::remove_dir_all(&dir).unwrap();
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
    let text = register_fonts();
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
    let mut chart = chart_frame(&root, title, text, 70)
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
        legend_box(&mut chart).map_err(err)?;
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
