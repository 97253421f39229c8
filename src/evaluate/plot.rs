//! `walkthrough.png`: triangles rendered per frame by each method (Aliaga & Lastra's
//! figures), log scale; [`log_lines`], the per-frame line plot it is drawn with (also the
//! walkthrough benchmark's, `crate::suite::walkthrough`).

use crate::visibility::walk::Frame;
use plotters::prelude::*;
use std::path::Path;

fn err<E: std::fmt::Debug>(e: E) -> std::io::Error {
    std::io::Error::other(format!("{e:?}"))
}

/// Draws the per-frame series into `path` (PNG, 1200 × 600).
pub fn frames(path: &Path, frames: &[Frame], names: &[String; 5], title: &str) -> Result<(), std::io::Error> {
    let colours = [BLACK, BLUE, CYAN, RED, GREEN];
    let series: Vec<Series> = (0..5)
        .map(|k| Series {
            name: names[k].clone(),
            colour: colours[k],
            points: frames
                .iter()
                .map(|f| {
                    let v = [f.frustum, f.portal, f.portal_rect, f.textured_a, f.textured_b][k];
                    (f.frame as f64, (v.max(1)) as f64)
                })
                .collect(),
        })
        .collect();
    let hi = series
        .iter()
        .flat_map(|s| &s.points)
        .map(|p| p.1)
        .fold(10.0f64, f64::max);
    let root = BitMapBackend::new(path, (1200, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let panel = Panel {
        title,
        x_max: frames.len().max(2) as f64,
        y: (1.0, hi * 1.5),
        y_desc: "triangles rendered (log)",
    };
    log_lines(&root, &panel, &series)?;
    root.present().map_err(err)?;
    Ok(())
}

/// One line of a per-frame plot.
pub struct Series {
    /// Legend.
    pub name: String,
    /// Colour.
    pub colour: RGBColor,
    /// (frame, value > 0).
    pub points: Vec<(f64, f64)>,
}

/// A panel of a per-frame plot: frames on x from 0, a log y axis.
pub struct Panel<'a> {
    /// Caption.
    pub title: &'a str,
    /// End of the x axis.
    pub x_max: f64,
    /// Range of the y axis (both > 0).
    pub y: (f64, f64),
    /// Label of the y axis.
    pub y_desc: &'a str,
}

/// Draws `series` as lines on a log y axis into `area` (already filled), with a legend when
/// the font is available.
pub fn log_lines<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    panel: &Panel,
    series: &[Series],
) -> Result<(), std::io::Error>
where
    DB::ErrorType: 'static,
{
    let text = crate::output::register_fonts();
    let mut chart = crate::output::plot::chart_frame(area, panel.title, text, 80)
        .build_cartesian_2d(0.0..panel.x_max, (panel.y.0..panel.y.1).log_scale())
        .map_err(err)?;
    if text {
        chart
            .configure_mesh()
            .x_desc("frame")
            .y_desc(panel.y_desc)
            .draw()
            .map_err(err)?;
    }
    for s in series {
        let c = s.colour;
        let drawn = chart
            .draw_series(LineSeries::new(s.points.iter().copied(), c.stroke_width(1)))
            .map_err(err)?;
        if text {
            drawn
                .label(s.name.clone())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c));
        }
    }
    if text {
        crate::output::plot::legend_box(&mut chart).map_err(err)?;
    }
    Ok(())
}
