//! Quake's portal file, PRT1 (`cells.prt`, opt-in: `run --export prt`): the format qbsp
//! writes and vis and TrenchBroom read.
//!
//! ```text
//! PRT1
//! <leaves>
//! <portal lines>
//! <points> <leaf a> <leaf b> (x y z ) (x y z ) ...
//! ```
//!
//! Conventions, as in qbsp's own files (checked against `models/quake/e1m1.prt` by
//! `tests/exports.rs`):
//! - **Leaves** are the final cells: leaf `i` is the `i`-th cell of `result.json` (cells
//!   sorted by id). Leaves are numbered from 0 (qbsp's solid leaf 0 is not a visleaf).
//! - **One line per convex portal polygon**: a merged portal (several convex pieces between
//!   two cells) is several lines with the same two leaves.
//! - **Winding order**: vis takes a portal's plane from its first three points
//!   (`PlaneFromWinding`) and gives leaf `a` the portal with the opposite normal, leading
//!   into leaf `b`. So the points run counter-clockwise seen from leaf `b` (their
//!   right-hand normal points from `a` into `b`): every portal's plane then has all of
//!   leaf `a`'s other portals behind it. Lines have `a < b` and are sorted by `(a, b)`, as
//!   qbsp's mostly are. Coordinates are written in full (integers without a fraction).
//! - **Limits of vis** (`vis.h`): at most [`MAX_POINTS_ON_WINDING`] points per winding (a
//!   larger polygon is split into a fan of pieces that share its first point) and at most
//!   [`MAX_PORTALS_ON_LEAF`] portal lines per leaf. A cell over that limit is written as
//!   one leaf per convex piece: the first piece keeps the cell's leaf number, the others get
//!   new leaves after the last cell's (in cell order, then piece order), and the portals
//!   between pieces of that cell become portal lines too. A piece still over the limit is
//!   an error.
//!
//! **Convexity.** vis assumes that every leaf is convex (a BSP leaf): it clips the view
//! through a leaf's portals against the planes of the portals it came through. A merged cell
//! of portalfind is a union of convex pieces and in general **not** convex, so vis run on
//! this file may find a leaf seeing less than it does (its anti-penumbra clipping assumes
//! straight lines inside the leaf stay inside). For a conservative PVS, write the convex
//! pieces instead (the run's `cells:N` stop rule at the active cell count) or treat the
//! result as approximate. The file is exact as a portal *graph*: leaves, adjacency and
//! portal polygons.

use super::OutputError;
use super::export::{ExportContext, Exporter, write_atomic};
use crate::complex::CellComplex;
use crate::decimate::Partition;
use crate::predicates::P3;
use std::path::PathBuf;

/// vis's `MAX_POINTS_ON_WINDING`: points a portal winding may have.
pub const MAX_POINTS_ON_WINDING: usize = 64;
/// vis's `MAX_PORTALS_ON_LEAF`: portal lines that may name one leaf (vis stops with "Leaf
/// with too many portals" when a leaf already has this many).
pub const MAX_PORTALS_ON_LEAF: usize = 128;

const FILE: &str = "cells.prt";

/// The limits a file is written within.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PrtLimits {
    /// Points per winding (at least 3).
    pub points: usize,
    /// Portal lines per leaf.
    pub portals_per_leaf: usize,
}

impl PrtLimits {
    /// vis's: [`MAX_POINTS_ON_WINDING`], [`MAX_PORTALS_ON_LEAF`].
    pub const VIS: PrtLimits = PrtLimits {
        points: MAX_POINTS_ON_WINDING,
        portals_per_leaf: MAX_PORTALS_ON_LEAF,
    };
}

/// A PRT1 file: the leaf count and the portal lines.
#[derive(Clone, Debug, PartialEq)]
pub struct PrtFile {
    /// Number of leaves (the second header line).
    pub leaves: usize,
    /// The portal lines, in file order.
    pub portals: Vec<PrtPortal>,
    /// For each leaf: the id of the final cell it belongs to (only for files this module
    /// built; empty for parsed files).
    pub leaf_cells: Vec<u32>,
}

/// One portal line.
#[derive(Clone, Debug, PartialEq)]
pub struct PrtPortal {
    /// The two leaves; the winding's right-hand normal points from `leaves[0]` to `leaves[1]`.
    pub leaves: [usize; 2],
    /// The points.
    pub winding: Vec<P3>,
}

impl PrtFile {
    /// The file's text.
    pub fn to_text(&self) -> String {
        let mut s = format!("PRT1\n{}\n{}\n", self.leaves, self.portals.len());
        for p in &self.portals {
            s.push_str(&format!("{} {} {} ", p.winding.len(), p.leaves[0], p.leaves[1]));
            for v in &p.winding {
                s.push_str(&format!("({} {} {} ) ", v[0], v[1], v[2]));
            }
            s.push('\n');
        }
        s
    }

    /// Portal lines naming each leaf (what vis counts against [`MAX_PORTALS_ON_LEAF`]).
    pub fn portals_per_leaf(&self) -> Vec<usize> {
        let mut n = vec![0; self.leaves];
        for p in &self.portals {
            for &l in &p.leaves {
                if let Some(c) = n.get_mut(l) {
                    *c += 1;
                }
            }
        }
        n
    }
}

/// Reads a PRT1 file's text (as qbsp writes it; `name` names it in errors). Checks the
/// header, the portal count, each line's point count and leaf numbers.
pub fn parse_prt(name: &str, text: &str) -> Result<PrtFile, String> {
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let mut header = |what: &str| {
        lines
            .next()
            .map(|(i, l)| (i + 1, l.trim().to_string()))
            .ok_or_else(|| format!("{name}: missing {what}"))
    };
    let (_, magic) = header("the PRT1 header")?;
    if magic != "PRT1" {
        return Err(format!(
            "{name}: line 1 is {magic:?}, not PRT1 (PRT2 and PRT1-AM are not read)"
        ));
    }
    let count = |(i, l): (usize, String), what: &str| {
        l.parse::<usize>()
            .map_err(|_| format!("{name}:{i}: {what} {l:?} is not a count"))
    };
    let leaves = count(header("the leaf count")?, "leaf count")?;
    let n = count(header("the portal count")?, "portal count")?;
    let mut portals = Vec::with_capacity(n);
    for (i, line) in lines {
        let ln = i + 1;
        let toks: Vec<&str> = line
            .split(|c: char| c.is_whitespace() || c == '(' || c == ')')
            .filter(|t| !t.is_empty())
            .collect();
        let int = |k: usize| {
            toks.get(k)
                .and_then(|t| t.parse::<usize>().ok())
                .ok_or_else(|| format!("{name}:{ln}: expected a count or leaf number"))
        };
        let np = int(0)?;
        let leaves_of = [int(1)?, int(2)?];
        if np < 3 || toks.len() != 3 + 3 * np {
            return Err(format!(
                "{name}:{ln}: {np} points announced, {} numbers given",
                toks.len().saturating_sub(3)
            ));
        }
        if leaves_of.iter().any(|&l| l >= leaves) {
            return Err(format!(
                "{name}:{ln}: leaf {leaves_of:?} out of range (leaves: {leaves})"
            ));
        }
        let mut winding = Vec::with_capacity(np);
        for k in 0..np {
            let mut v = [0.0; 3];
            for (j, x) in v.iter_mut().enumerate() {
                *x = toks[3 + 3 * k + j]
                    .parse()
                    .map_err(|_| format!("{name}:{ln}: bad coordinate {:?}", toks[3 + 3 * k + j]))?;
            }
            winding.push(v);
        }
        portals.push(PrtPortal {
            leaves: leaves_of,
            winding,
        });
    }
    if portals.len() != n {
        return Err(format!(
            "{name}: header announces {n} portals, {} lines found",
            portals.len()
        ));
    }
    Ok(PrtFile {
        leaves,
        portals,
        leaf_cells: Vec::new(),
    })
}

/// Splits a convex winding into pieces of at most `max` points (at least 3): a fan around
/// its first point, consecutive pieces sharing an edge.
fn split_winding(v: &[P3], max: usize) -> Vec<Vec<P3>> {
    let max = max.max(3);
    if v.len() <= max {
        return vec![v.to_vec()];
    }
    let mut out = Vec::new();
    let mut s = 1;
    while s + 1 < v.len() {
        let e = (s + max - 2).min(v.len() - 1);
        let mut w = vec![v[0]];
        w.extend_from_slice(&v[s..=e]);
        out.push(w);
        s = e;
    }
    out
}

/// The PRT1 file of a partition of `cx`'s cells within `limits` (see the module docs for
/// the conventions; `run --export prt` uses [`PrtLimits::VIS`]).
pub fn prt_file(cx: &CellComplex, partition: &Partition, limits: PrtLimits) -> Result<PrtFile, String> {
    let mut leaf_of = vec![usize::MAX; cx.cells.len()];
    let mut leaf_cells: Vec<u32> = partition.cells.iter().map(|c| c.id.0).collect();
    for (i, c) in partition.cells.iter().enumerate() {
        for p in &c.pieces {
            leaf_of[p.idx()] = i;
        }
    }
    let lines = |leaf_of: &[usize]| {
        let mut out = Vec::new();
        for p in &cx.portals {
            let (a, b) = (leaf_of[p.cells[0].idx()], leaf_of[p.cells[1].idx()]);
            if a == usize::MAX || b == usize::MAX || a == b {
                continue;
            }
            for q in &p.pieces {
                // Make `a < b`, reversing the winding so it still runs from a to b.
                let (leaves, verts) = if a < b {
                    ([a, b], q.verts.clone())
                } else {
                    ([b, a], q.verts.iter().rev().copied().collect())
                };
                for w in split_winding(&verts, limits.points) {
                    out.push(PrtPortal { leaves, winding: w });
                }
            }
        }
        out.sort_by_key(|p| p.leaves);
        out
    };
    let mut file = PrtFile {
        leaves: leaf_cells.len(),
        portals: lines(&leaf_of),
        leaf_cells: Vec::new(),
    };
    let over: Vec<usize> = file
        .portals_per_leaf()
        .iter()
        .enumerate()
        .filter(|&(_, &n)| n > limits.portals_per_leaf)
        .map(|(i, _)| i)
        .collect();
    if !over.is_empty() {
        for i in over {
            let c = &partition.cells[i];
            for p in &c.pieces[1..] {
                leaf_of[p.idx()] = leaf_cells.len();
                leaf_cells.push(c.id.0);
            }
        }
        file.leaves = leaf_cells.len();
        file.portals = lines(&leaf_of);
        if let Some((l, n)) = file
            .portals_per_leaf()
            .into_iter()
            .enumerate()
            .find(|&(_, n)| n > limits.portals_per_leaf)
        {
            return Err(format!(
                "leaf {l} (a convex piece of cell {}) has {n} portal lines, more than the \
                 limit of {} (vis's MAX_PORTALS_ON_LEAF is {MAX_PORTALS_ON_LEAF})",
                leaf_cells[l], limits.portals_per_leaf
            ));
        }
    }
    file.leaf_cells = leaf_cells;
    Ok(file)
}

/// `cells.prt`.
pub struct Prt;

impl Exporter for Prt {
    fn name(&self) -> &'static str {
        "quake portal file"
    }

    fn files(&self, _ctx: &ExportContext<'_>) -> Vec<String> {
        vec![FILE.into()]
    }

    fn owns(&self, file_name: &str) -> bool {
        file_name == FILE
    }

    fn opt_in(&self) -> Option<&'static str> {
        Some("prt")
    }

    fn write(&self, ctx: &ExportContext<'_>) -> Result<Vec<PathBuf>, OutputError> {
        let cx = ctx.complex(FILE)?;
        let mut prt = prt_file(cx, &ctx.dec.partition, PrtLimits::VIS).map_err(|e| OutputError::Write {
            file: FILE.into(),
            source: e.into(),
        })?;
        // Windings in the input's frame.
        for v in prt.portals.iter_mut().flat_map(|p| p.winding.iter_mut()) {
            *v = ctx.model.to_user(*v);
        }
        let path = ctx.dir.join(FILE);
        write_atomic(&path, |tmp| std::fs::write(tmp, prt.to_text()))?;
        Ok(vec![path])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_windings_split_into_fans_within_the_limit() {
        let n = 150;
        let v: Vec<P3> = (0..n)
            .map(|i| {
                let t = std::f64::consts::TAU * i as f64 / n as f64;
                [t.cos(), t.sin(), 0.0]
            })
            .collect();
        let parts = split_winding(&v, MAX_POINTS_ON_WINDING);
        assert!(parts.iter().all(|w| w.len() <= MAX_POINTS_ON_WINDING && w.len() >= 3));
        // Every fan triangle (v0, vi, vi+1) is in exactly one part.
        let tris: usize = parts.iter().map(|w| w.len() - 2).sum();
        assert_eq!(tris, n - 2);
        assert_eq!(parts.len(), 3);
        assert_eq!(split_winding(&v[..64], MAX_POINTS_ON_WINDING).len(), 1);
        assert!(split_winding(&v[..10], 4).iter().all(|w| w.len() <= 4));
    }

    #[test]
    fn text_round_trips_and_bad_files_name_the_line() {
        let f = PrtFile {
            leaves: 2,
            portals: vec![PrtPortal {
                leaves: [0, 1],
                winding: vec![[0.0, 0.0, 0.0], [1.5, 0.0, -0.25], [1.0, 1.0, 1e-7]],
            }],
            leaf_cells: Vec::new(),
        };
        let t = f.to_text();
        assert_eq!(
            t.lines().nth(3).unwrap(),
            "3 0 1 (0 0 0 ) (1.5 0 -0.25 ) (1 1 0.0000001 ) "
        );
        assert_eq!(parse_prt("x.prt", &t).unwrap(), f);
        let e = parse_prt("x.prt", &t.replace("3 0 1", "3 0 2")).unwrap_err();
        assert!(e.starts_with("x.prt:4: leaf"), "{e}");
        let e = parse_prt("x.prt", &t.replace("PRT1\n2\n1", "PRT1\n2\n2")).unwrap_err();
        assert!(e.contains("announces 2 portals"), "{e}");
    }
}
