//! Wavefront OBJ of the cells and portals (`cells.obj` + `cells.mtl`, opt-in:
//! `run --export obj`), for Blender and other modelling tools.
//!
//! - One object per final cell, `o Cell_<id>` with material `cell_<id>`: its boundary
//!   faces, i.e. the faces of its convex pieces that are not shared by two pieces of the same
//!   cell (walls, portals to other cells, and open faces alike), counter-clockwise seen
//!   from outside the cell (normals point out of the cell).
//! - One object per pair of cells with portals, `o Portal_<a>_<b>` (`a < b`) with material
//!   `portal`: its convex pieces, counter-clockwise seen from cell `b` (normals from `a` to
//!   `b`).
//!   This is the merged portal as one surface (pieces stitched at shared vertices, possibly
//!   non-planar).
//! - After each, `o Portal_<a>_<b>_hull` with material `portal_hull`: one convex planar
//!   polygon standing in for the whole portal, for engines that take only convex portals
//!   ([`crate::visibility::merged::convex_portal`]: the hull of the pieces projected along
//!   their mean normal, normal from `a` to `b`; omitted when the pieces' normals cancel).
//! - `cells.mtl`: one diffuse colour per cell (hues by the golden ratio, so neighbouring ids
//!   differ), portals yellow and half transparent, portal hulls orange and more transparent.
//!
//! Vertices are shared within an object (bit-identical coordinates), not between objects,
//! so each object is a separate mesh when imported.

use super::OutputError;
use super::export::{ExportContext, Exporter, write_atomic};
use crate::complex::{CellComplex, HULL};
use crate::decimate::{MergedCell, Partition};
use crate::geom::ConvexPolygon;
use crate::predicates::P3;
use crate::visibility::merged::convex_portal;
use std::borrow::Cow;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::PathBuf;

const OBJ: &str = "cells.obj";
const MTL: &str = "cells.mtl";

/// The boundary faces of a merged cell: the faces of its convex pieces whose other side is
/// not a piece of the same cell, each counter-clockwise seen from outside.
pub(super) fn boundary_faces<'a>(
    cx: &'a CellComplex,
    partition: &Partition,
    cell: &MergedCell,
) -> Vec<Cow<'a, ConvexPolygon>> {
    let mut out = Vec::new();
    for &p in &cell.pieces {
        let cell = &cx.cells[p.idx()];
        for (f, &tag) in cell.faces_cow().zip(cell.tags()) {
            let cells = cx.patches.get(tag as usize).map(|pa| pa.cells);
            let inner = cells.is_some_and(|[c0, c1]| {
                let other = if c0 == p { c1 } else { c0 };
                other != HULL
                    && other != p
                    && partition.cell_of(other).is_some()
                    && partition.cell_of(other) == partition.cell_of(p)
            });
            if !inner {
                out.push(f);
            }
        }
    }
    out
}

/// A distinct colour for the `i`-th cell: hue stepped by the golden ratio, RGB in [0, 1].
pub(super) fn cell_colour(i: usize) -> [f64; 3] {
    let h = (i as f64 * 0.618_033_988_749_895).fract() * 6.0;
    let (s, v) = (0.55, 0.92);
    let c = v * s;
    let x = c * (1.0 - (h % 2.0 - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    [r + m, g + m, b + m]
}

/// The portal colour (RGB) and opacity.
pub(super) const PORTAL_COLOUR: [f64; 4] = [1.0, 0.82, 0.1, 0.5];

/// The portal hulls' colour (RGB) and opacity.
pub(super) const PORTAL_HULL_COLOUR: [f64; 4] = [1.0, 0.45, 0.05, 0.3];

/// Appends one object's faces, sharing its vertices (by their bits in the model's frame);
/// `next` is the next OBJ vertex index. Vertices are written in the input's frame:
/// `origin` ([`crate::model::Model::origin`]) added.
fn object(out: &mut String, next: &mut usize, name: &str, material: &str, faces: &[&[P3]], origin: P3) {
    let _ = writeln!(out, "o {name}\nusemtl {material}");
    let mut index: HashMap<[u64; 3], usize> = HashMap::new();
    let mut face_lines = String::new();
    for f in faces {
        face_lines.push('f');
        for v in *f {
            let key = v.map(f64::to_bits);
            let i = *index.entry(key).or_insert_with(|| {
                let v = crate::model::translate_point(*v, origin);
                let _ = writeln!(out, "v {} {} {}", v[0], v[1], v[2]);
                *next += 1;
                *next - 1
            });
            let _ = write!(face_lines, " {i}");
        }
        face_lines.push('\n');
    }
    out.push_str(&face_lines);
}

/// The text of `cells.obj` and `cells.mtl`, coordinates in the input's frame (`origin`
/// added to the complex's).
pub fn cells_obj_text(cx: &CellComplex, partition: &Partition, header: &str, origin: P3) -> (String, String) {
    let mut obj = String::new();
    for l in header.lines() {
        let _ = writeln!(obj, "# {l}");
    }
    let _ = writeln!(obj, "mtllib {MTL}");
    let mut mtl = String::from("# portalfind: one colour per cell, portals translucent\n");
    let mut next = 1;
    for (i, c) in partition.cells.iter().enumerate() {
        let boundary = boundary_faces(cx, partition, c);
        let faces: Vec<&[P3]> = boundary.iter().map(|f| &f.verts[..]).collect();
        let name = format!("cell_{}", c.id.0);
        object(&mut obj, &mut next, &format!("Cell_{}", c.id.0), &name, &faces, origin);
        let [r, g, b] = cell_colour(i);
        let _ = writeln!(mtl, "\nnewmtl {name}\nKd {r:.4} {g:.4} {b:.4}\nKa 0 0 0\nd 1");
    }
    for p in partition.portals(cx) {
        let faces: Vec<&[P3]> = p.pieces.iter().map(|q| &q.verts[..]).collect();
        let name = format!("Portal_{}_{}", p.cells[0].0, p.cells[1].0);
        object(&mut obj, &mut next, &name, "portal", &faces, origin);
        let pieces: Vec<Vec<P3>> = p.pieces.iter().map(|q| q.verts.to_vec()).collect();
        if let Some(h) = convex_portal(&pieces) {
            object(
                &mut obj,
                &mut next,
                &format!("{name}_hull"),
                "portal_hull",
                &[&h.verts[..]],
                origin,
            );
        }
    }
    let [r, g, b, a] = PORTAL_COLOUR;
    let _ = writeln!(mtl, "\nnewmtl portal\nKd {r} {g} {b}\nKa 0 0 0\nd {a}");
    let [r, g, b, a] = PORTAL_HULL_COLOUR;
    let _ = writeln!(mtl, "\nnewmtl portal_hull\nKd {r} {g} {b}\nKa 0 0 0\nd {a}");
    (obj, mtl)
}

/// `cells.obj` and `cells.mtl`.
pub struct CellsObj;

impl Exporter for CellsObj {
    fn name(&self) -> &'static str {
        "cells and portals as OBJ"
    }

    fn files(&self, _ctx: &ExportContext<'_>) -> Vec<String> {
        vec![OBJ.into(), MTL.into()]
    }

    fn owns(&self, file_name: &str) -> bool {
        file_name == OBJ || file_name == MTL
    }

    fn opt_in(&self) -> Option<&'static str> {
        Some("obj")
    }

    fn write(&self, ctx: &ExportContext<'_>) -> Result<Vec<PathBuf>, OutputError> {
        let cx = ctx.complex(OBJ)?;
        let header = format!(
            "portalfind {}: cells and portals of {} ({} cells, {} portal pairs)\n\
             objects Cell_<id> (boundary faces, normals outward), Portal_<a>_<b> (the merged portal's pieces, normals from a to b)\n\
             and Portal_<a>_<b>_hull (one convex polygon containing the pieces' projection along their mean normal)",
            env!("CARGO_PKG_VERSION"),
            ctx.doc.model.name,
            ctx.doc.cells.len(),
            ctx.doc.portals.len()
        );
        let (obj, mtl) = cells_obj_text(cx, &ctx.dec.partition, &header, ctx.model.origin);
        let (po, pm) = (ctx.dir.join(OBJ), ctx.dir.join(MTL));
        write_atomic(&pm, |tmp| std::fs::write(tmp, &mtl))?;
        if let Err(e) = write_atomic(&po, |tmp| std::fs::write(tmp, &obj)) {
            let _ = std::fs::remove_file(&pm);
            return Err(e);
        }
        Ok(vec![po, pm])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colours_are_in_range_and_neighbours_differ() {
        for i in 0..50 {
            let c = cell_colour(i);
            assert!(c.iter().all(|x| (0.0..=1.0).contains(x)), "{c:?}");
            let d = cell_colour(i + 1);
            assert!(c.iter().zip(&d).map(|(a, b)| (a - b).abs()).sum::<f64>() > 0.1);
        }
    }
}
