//! `walkthrough.png`: triangles rendered per frame by each method (Aliaga & Lastra's
//! figures), log scale.

use crate::visibility::walk::Frame;
use plotters::prelude::*;
use std::path::Path;

fn err<E: std::fmt::Debug>(e: E) -> std::io::Error {
    std::io::Error::other(format!("{e:?}"))
}

/// Draws the per-frame series into `path` (PNG, 1200 × 600).
pub fn frames(path: &Path, frames: &[Frame], names: &[String; 5], title: &str) -> Result<(), std::io::Error> {
    let text = crate::output::register_fonts();
    let root = BitMapBackend::new(path, (1200, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let series: [Vec<(f64, f64)>; 5] = std::array::from_fn(|k| {
        frames
            .iter()
            .map(|f| {
                let v = [f.frustum, f.portal, f.portal_rect, f.textured_a, f.textured_b][k];
                (f.frame as f64, (v.max(1)) as f64)
            })
            .collect()
    });
    let hi = series.iter().flatten().map(|p| p.1).fold(10.0f64, f64::max);
    let n = frames.len().max(2) as f64;
    let mut b = ChartBuilder::on(&root);
    b.margin(20);
    if text {
        b.caption(title, ("sans-serif", 22))
            .x_label_area_size(45)
            .y_label_area_size(80);
    }
    let mut chart = b.build_cartesian_2d(0.0..n, (1.0..hi * 1.5).log_scale()).map_err(err)?;
    if text {
        chart
            .configure_mesh()
            .x_desc("frame")
            .y_desc("triangles rendered (log)")
            .draw()
            .map_err(err)?;
    }
    let colours = [BLACK, BLUE, CYAN, RED, GREEN];
    for (k, s) in series.into_iter().enumerate() {
        let c = colours[k];
        let drawn = chart.draw_series(LineSeries::new(s, c.stroke_width(1))).map_err(err)?;
        if text {
            drawn
                .label(names[k].clone())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c));
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
