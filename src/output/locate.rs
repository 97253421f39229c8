//! Point location in the final cells of a [`ResultDoc`] (`portalfind locate`), and the
//! points file it reads.

use super::{OutputError, ResultDoc};
use crate::ids::CellId;
use crate::predicates::P3;
use std::path::Path;

/// Point location in the final cells of a [`ResultDoc`].
pub struct Locator<'a> {
    doc: &'a ResultDoc,
    /// (cell index, piece index, aabb lo, aabb hi), by cell id order.
    boxes: Vec<(usize, usize, P3, P3)>,
    slack: f64,
}

impl<'a> Locator<'a> {
    /// Prepares the pieces' bounding boxes. A point counts as inside a piece when it is
    /// within the plane tolerance (`tolerances.plane_abs()`) of the inside of every plane.
    /// The document and the points are in the model's frame (`read_result` gives it so;
    /// `portalfind locate` subtracts `doc.model.origin` from the user's points). For a
    /// recentred model the slack also covers the rounding of `result.json`'s coordinates
    /// in the input's frame (a few units in the last place of the largest coordinate
    /// there), which the round trip through the file adds.
    pub fn new(doc: &'a ResultDoc) -> Self {
        let mut boxes = Vec::new();
        for (ci, c) in doc.cells.iter().enumerate() {
            for (pi, p) in c.pieces.iter().enumerate() {
                let (lo, hi) = crate::base::vec::bounds(&p.vertices);
                boxes.push((ci, pi, lo, hi));
            }
        }
        let o = doc.model.origin;
        let mut slack = doc.model.tolerances.plane_abs();
        if o != [0.0; 3] {
            let far = o.iter().fold(0.0f64, |a, x| a.max(x.abs())) + doc.model.tolerances.scale;
            slack += 8.0 * f64::EPSILON * far;
        }
        Locator { doc, boxes, slack }
    }

    /// The id of the final cell containing `p` (the lowest id if it lies on a shared
    /// boundary), or `None` (outside every cell: in a wall, outside the model, or in a
    /// sliver gap).
    pub fn locate(&self, p: &P3) -> Option<CellId> {
        let s = self.slack;
        for &(ci, pi, lo, hi) in &self.boxes {
            if (0..3).any(|k| p[k] < lo[k] - s || p[k] > hi[k] + s) {
                continue;
            }
            let piece = &self.doc.cells[ci].pieces[pi];
            if piece
                .planes
                .iter()
                .all(|q| q[0] * p[0] + q[1] * p[1] + q[2] * p[2] - q[3] <= s)
            {
                return Some(CellId(self.doc.cells[ci].id));
            }
        }
        None
    }
}

/// Parses `x,y,z` rows (blank lines and lines starting with `#` skipped; a first row that
/// does not parse as numbers is taken as a header).
pub fn read_points(path: &Path) -> Result<Vec<P3>, OutputError> {
    let text = std::fs::read_to_string(path).map_err(|source| OutputError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let mut out = Vec::new();
    let mut header_allowed = true;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = t.split(',').map(|s| s.trim()).collect();
        let nums: Option<Vec<f64>> = f.iter().map(|s| s.parse::<f64>().ok()).collect();
        let first = std::mem::replace(&mut header_allowed, false);
        match nums {
            Some(v) if v.len() == 3 && v.iter().all(|x| x.is_finite()) => out.push([v[0], v[1], v[2]]),
            // A header row (names such as `x,y,z`), not a malformed first point.
            None if first && f.len() == 3 && f.iter().all(|s| s.starts_with(|c: char| c.is_ascii_alphabetic())) => {
                continue;
            }
            Some(v) if v.len() == 3 => {
                return Err(OutputError::Points {
                    path: path.to_path_buf(),
                    line: i + 1,
                    message: format!("coordinates must be finite numbers, got {t:?}"),
                });
            }
            _ => {
                return Err(OutputError::Points {
                    path: path.to_path_buf(),
                    line: i + 1,
                    message: format!("expected x,y,z, got {t:?}"),
                });
            }
        }
    }
    if out.is_empty() {
        return Err(OutputError::NoPoints {
            path: path.to_path_buf(),
        });
    }
    Ok(out)
}
