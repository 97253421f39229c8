//! `cells.svg`: a top view in the style of the thesis figures — the model's walls projected
//! to the xy plane (thin grey; floors and ceilings as a faint fill) and the final portals
//! (bold, one colour per cell pair). Written by hand: no fonts or backends needed.

use super::ResultDoc;
use crate::ids::PolygonId;
use crate::model::Model;
use std::fmt::Write;
use std::path::PathBuf;

const WIDTH: f64 = 1200.0;
const MARGIN: f64 = 20.0;

/// A distinct, saturated colour for index `i` (golden-angle hues).
fn colour(i: usize) -> String {
    let h = (i as f64 * 137.507_764) % 360.0;
    format!("hsl({h:.1},85%,42%)")
}

/// The SVG document.
pub fn cells_svg(model: &Model, doc: &ResultDoc) -> String {
    let (lo, hi) = model.bbox();
    let (w, h) = ((hi[0] - lo[0]).max(1e-12), (hi[1] - lo[1]).max(1e-12));
    let s = (WIDTH - 2.0 * MARGIN) / w;
    let height = h * s + 2.0 * MARGIN + 30.0;
    // x to the right, y up.
    let tx = |p: &[f64; 3]| -> (f64, f64) { (MARGIN + (p[0] - lo[0]) * s, MARGIN + 30.0 + (hi[1] - p[1]) * s) };
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH:.0}" height="{height:.0}" viewBox="0 0 {WIDTH:.0} {height:.0}">"#
    );
    let _ = writeln!(out, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let title = format!(
        "{} — {} / {}, stop {} — {} cells, {} portals (top view)",
        doc.model.name,
        doc.settings.heuristic,
        doc.settings.estimator,
        doc.settings.stop,
        doc.cells.len(),
        doc.portals.len()
    );
    let _ = writeln!(
        out,
        r#"<text x="{MARGIN}" y="22" font-family="sans-serif" font-size="16">{}</text>"#,
        escape(&title)
    );
    let path_of = |pts: &mut dyn Iterator<Item = (f64, f64)>| -> String {
        let mut d = String::new();
        for (k, (x, y)) in pts.enumerate() {
            let _ = write!(d, "{}{x:.2},{y:.2} ", if k == 0 { "M" } else { "L" });
        }
        d.push('Z');
        d
    };
    let mut floors = String::new();
    let mut walls = String::new();
    for (i, p) in model.polygons.iter().enumerate() {
        let n = model.polygon_normal(PolygonId(i as u32));
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if l.is_nan() || l <= 0.0 {
            continue;
        }
        let d = path_of(&mut p.verts.iter().map(|v| tx(&model.vertices[v.idx()])));
        if n[2].abs() / l > 0.5 {
            let _ = write!(floors, "{d} ");
        } else {
            let _ = write!(walls, "{d} ");
        }
    }
    let _ = writeln!(
        out,
        r##"<path d="{floors}" fill="#000" fill-opacity="0.04" stroke="none"/>"##
    );
    let _ = writeln!(
        out,
        r##"<path d="{walls}" fill="none" stroke="#888" stroke-width="0.5" stroke-linejoin="round"/>"##
    );
    for (i, p) in doc.portals.iter().enumerate() {
        let c = colour(i);
        let mut d = String::new();
        for poly in &p.polygons {
            let _ = write!(d, "{} ", path_of(&mut poly.iter().map(&tx)));
        }
        let _ = writeln!(
            out,
            r#"<path d="{d}" fill="{c}" fill-opacity="0.3" stroke="{c}" stroke-width="2.5" stroke-linejoin="round"><title>cells {} – {}, area {:.4}</title></path>"#,
            p.cells[0], p.cells[1], p.area
        );
    }
    out.push_str("</svg>\n");
    out
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

const FILE: &str = "cells.svg";

/// Writes the top view of the final cells, `cells.svg`.
pub struct CellsSvg;

impl super::Exporter for CellsSvg {
    fn name(&self) -> &'static str {
        "top view"
    }

    fn files(&self, _: &super::ExportContext<'_>) -> Vec<String> {
        vec![FILE.into()]
    }

    fn owns(&self, file_name: &str) -> bool {
        file_name == FILE
    }

    fn write(&self, ctx: &super::ExportContext<'_>) -> Result<Vec<PathBuf>, super::OutputError> {
        let path = ctx.dir.join(FILE);
        let svg = cells_svg(ctx.model, ctx.doc);
        super::write_atomic(&path, |tmp| std::fs::write(tmp, svg))?;
        Ok(vec![path])
    }
}

/// Writes the top view of each snapshot, `cells_<N>.svg`.
pub struct Snapshots;

impl super::Exporter for Snapshots {
    fn name(&self) -> &'static str {
        "snapshot top views"
    }

    fn files(&self, ctx: &super::ExportContext<'_>) -> Vec<String> {
        ctx.snapshots.iter().map(|(s, _)| s.file.clone()).collect()
    }

    fn owns(&self, file_name: &str) -> bool {
        file_name.starts_with("cells_") && file_name.ends_with(".svg")
    }

    fn write(&self, ctx: &super::ExportContext<'_>) -> Result<Vec<PathBuf>, super::OutputError> {
        let mut written = Vec::new();
        for (snap, sdoc) in ctx.snapshots {
            let path = ctx.dir.join(&snap.file);
            let svg = cells_svg(ctx.model, sdoc);
            if let Err(e) = super::write_atomic(&path, |tmp| std::fs::write(tmp, svg)) {
                for p in &written {
                    let _ = std::fs::remove_file(p);
                }
                return Err(e);
            }
            written.push(path);
        }
        Ok(written)
    }
}
