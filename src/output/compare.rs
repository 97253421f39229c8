//! Comparison plots: several runs on one model (one heuristic against another) overlaid in
//! one picture, PNG and SVG: the weight of each collapse over the cells remaining (both on
//! log scales when positive, so runs with different initial cell counts and weight scales
//! share the axes; a run proceeds from right to left), a dot where each run stopped, a
//! cross at its first collapse joining two ground-truth rooms (when that happened before the
//! stop) and a dashed line at the true room count. The experiments' README links them
//! (`experiment::report`).

use super::OutputError;
use super::plot::{FONT_FAMILY, err, register_fonts};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// One run of a comparison.
#[derive(Clone, Debug, Default)]
pub struct Series {
    /// Legend text (e.g. `refined / hull`).
    pub label: String,
    /// Active cells before the first collapse.
    pub initial_cells: usize,
    /// Per collapse, in order: (weight, cells remaining after it), up to the run's stop.
    pub steps: Vec<(f64, usize)>,
    /// 1-based collapse of the first room join, if within `steps`.
    pub first_join: Option<usize>,
}

/// A comparison picture.
#[derive(Clone, Debug, Default)]
pub struct Comparison {
    /// Title.
    pub title: String,
    /// The runs.
    pub series: Vec<Series>,
    /// The true room count, when there is a ground truth.
    pub rooms: Option<usize>,
}

/// Image size of both files.
pub const SIZE: (u32, u32) = (1100, 620);

const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 90, 200),
    RGBColor(208, 16, 28),
    RGBColor(20, 140, 60),
    RGBColor(150, 60, 190),
    RGBColor(230, 120, 0),
    RGBColor(0, 150, 170),
];

/// Draws `c` onto `root`.
pub fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, c: &Comparison) -> Result<(), OutputError>
where
    DB::ErrorType: 'static,
{
    register_fonts();
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(&c.title, (FONT_FAMILY, 20)).map_err(err)?;
    let xmax = c.series.iter().map(|s| s.initial_cells).max().unwrap_or(1).max(2) as f64 * 1.3;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for s in &c.series {
        for &(w, _) in &s.steps {
            if w.is_finite() {
                lo = lo.min(w);
                hi = hi.max(w);
            }
        }
    }
    if !lo.is_finite() {
        (lo, hi) = (1.0, 10.0);
    }
    let point = |s: &Series, k: usize| -> Option<(f64, f64)> {
        let &(w, cells) = s.steps.get(k.checked_sub(1)?)?;
        Some((cells.max(1) as f64, w))
    };
    macro_rules! chart {
        ($range:expr, $desc:expr, $ylo:expr, $yhi:expr) => {{
            let mut chart = ChartBuilder::on(&root)
                .margin(14)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d((0.8f64..xmax).log_scale(), $range)
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_label_formatter(&|x| format!("{}", x.round() as i64))
                .y_label_formatter(&|y| super::plot::sig(*y))
                .x_desc("cells remaining (log scale; each run goes from right to left)")
                .y_desc($desc)
                .label_style((FONT_FAMILY, 13))
                .draw()
                .map_err(err)?;
            if let Some(r) = c.rooms {
                let x = r as f64;
                let grey = RGBColor(90, 90, 90);
                chart
                    .draw_series(DashedLineSeries::new(
                        [(x, $ylo), (x, $yhi)],
                        6,
                        4,
                        grey.stroke_width(1),
                    ))
                    .map_err(err)?
                    .label(format!("{r} rooms (ground truth)"))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], grey.stroke_width(1)));
            }
            for (i, s) in c.series.iter().enumerate() {
                let col = PALETTE[i % PALETTE.len()];
                let pts: Vec<(f64, f64)> = s
                    .steps
                    .iter()
                    .filter(|(w, _)| w.is_finite())
                    .map(|&(w, cells)| (cells.max(1) as f64, w))
                    .collect();
                chart
                    .draw_series(LineSeries::new(pts, col.stroke_width(2)))
                    .map_err(err)?
                    .label(format!(
                        "{} ({} → {} cells)",
                        s.label,
                        s.initial_cells,
                        s.steps.last().map_or(s.initial_cells, |l| l.1)
                    ))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
                if let Some(p) = point(s, s.steps.len()) {
                    chart.draw_series([Circle::new(p, 6, col.filled())]).map_err(err)?;
                }
                if let Some(p) = s.first_join.and_then(|j| point(s, j)) {
                    chart
                        .draw_series([Cross::new(p, 8, col.stroke_width(3))])
                        .map_err(err)?;
                }
            }
            let black = BLACK;
            chart
                .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
                .map_err(err)?
                .label("● the run's stop   ✕ its first room join (before the stop)")
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, black.filled()));
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
        // Headroom: the data in the lower 70% of the height (on the log scale), the legend above.
        let (ylo, yhi) = if hi > lo {
            let ylo = lo / 1.3;
            (ylo, ylo * (hi * 1.1 / ylo).powf(1.0 / 0.7))
        } else {
            (lo / 2.0, lo * 4.0)
        };
        chart!((ylo..yhi).log_scale(), "weight of the collapse (log scale)", ylo, yhi);
    } else {
        let (ylo, yhi) = if hi > lo {
            (lo, lo + (hi - lo) / 0.7)
        } else {
            (lo - 1.0, lo + 3.0)
        };
        chart!(ylo..yhi, "weight of the collapse", ylo, yhi);
    }
    root.present().map_err(err)?;
    Ok(())
}

/// Draws `c` into `path` as PNG.
pub fn comparison_png(path: &Path, c: &Comparison) -> Result<(), OutputError> {
    let root = BitMapBackend::new(path, SIZE).into_drawing_area();
    draw(&root, c)
}

/// `c` as an SVG document.
pub fn comparison_svg(c: &Comparison) -> Result<String, OutputError> {
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, SIZE).into_drawing_area();
        draw(&root, c)?;
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(label: &str, n: usize, scale: f64) -> Series {
        Series {
            label: label.into(),
            initial_cells: n,
            steps: (1..n - 3)
                .map(|k| (scale * (1.0 + k as f64 / n as f64), n - k))
                .collect(),
            first_join: Some(n - 6),
        }
    }

    #[test]
    fn two_runs_overlaid_with_legend_and_markers_in_both_formats() {
        let c = Comparison {
            title: "four rooms: refined against aspect".into(),
            series: vec![series("refined / hull", 96, 1.0), series("aspect / bbox", 14, 4.0)],
            rooms: Some(4),
        };
        let svg = comparison_svg(&c).unwrap();
        assert!(svg.contains("refined / hull (96 → 4 cells)"), "legend names each run");
        assert!(svg.contains("aspect / bbox (14 → 4 cells)"));
        assert!(svg.contains("4 rooms (ground truth)"));
        assert!(svg.contains("cells remaining"));
        // One polyline per run (the legend samples are paths of two points).
        assert!(svg.matches("<polyline").count() >= 2);
        let dir = std::env::temp_dir().join(format!("portalfind-compare-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let png = dir.join("c.png");
        comparison_png(&png, &c).unwrap();
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        std::fs::remove_dir_all(&dir).unwrap();
        // Non-positive weights switch to a linear axis.
        let mut lin = c.clone();
        lin.series[0].steps[0].0 = -1.0;
        assert!(svg.contains("weight of the collapse (log scale)"));
        let lin = comparison_svg(&lin).unwrap();
        assert!(lin.contains("weight of the collapse") && !lin.contains("weight of the collapse (log scale)"));
    }
}
