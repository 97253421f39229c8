//! Visibility of a partition: cell-to-cell potentially visible sets (PVS) through portal
//! sequences, the rendering cost they imply, a sampling check that they are conservative,
//! and qbsp's PRT1 portal files for comparison.
//!
//! - [`PortalGraph`]: cells (no geometry needed) and portals made of convex planar pieces.
//!   Built from a decimated [`Partition`] ([`PortalGraph::from_partition`]), from the
//!   complex's own cells ([`PortalGraph::from_complex`]) or from a PRT1 file ([`prt`]).
//! - [`pvs`]: Quake vis's portal flow (Teller & Séquin 1991's stabbing question answered
//!   conservatively with separating planes), giving one bitset per cell.
//! - [`cost`]: polygons per cell (by the side their occluders face), PVS cost in triangles
//!   and area, the volume-weighted expected cost and the culling ratio ([`VisibilityReport`]).
//! - [`sample`]: random points and rays with a BVH ray caster ([`raycast`]); every polygon
//!   hit from the front must face a cell of the point's cell's PVS.
//! - [`walk`]: walkthroughs (view-frustum culling, portal culling with pluggable frustum
//!   representations, portal textures), as Aliaga & Lastra measured them.
//!
//! **Merged cells are not convex.** A cell of a decimated partition is a union of convex
//! pieces, so a line entering it through one portal may be blocked inside it before it
//! reaches another portal. The PVS ignores that: a cell's interior is treated as seeing all
//! of its own portals (every portal piece of the cell is a possible source, and a line that
//! enters the cell may leave through any of its portal pieces). This can only add cells to
//! a PVS, never remove one: the PVS stays conservative, and overestimates more the less
//! convex the cells are. PRT leaves are convex, but the same rule applies to them.

pub mod bitset;
pub mod cost;
pub mod doors;
pub mod kgon;
pub mod mask;
pub mod merged;
pub mod prt;
pub mod pvs;
pub mod raycast;
pub mod sample;
pub mod walk;

pub use bitset::BitSet;
pub use cost::{CellPolygons, VisibilityReport};
pub use pvs::{Pvs, PvsSettings, PvsStats};

use crate::base::vec::P3;
use crate::complex::CellComplex;
use crate::decimate::Partition;

/// One portal: convex planar pieces between two cells.
#[derive(Clone, Debug, PartialEq)]
pub struct GraphPortal {
    /// The two cells (indices into the graph's cells), `cells[0] != cells[1]`.
    pub cells: [u32; 2],
    /// Convex pieces, each counter-clockwise around its normal, which points from
    /// `cells[0]` into `cells[1]`.
    pub pieces: Vec<Vec<P3>>,
}

/// Cells and the portals between them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PortalGraph {
    /// Number of cells.
    pub cells: usize,
    /// Portals.
    pub portals: Vec<GraphPortal>,
    /// Every cell is convex (the complex's cells, PRT leaves): a line enters each cell at
    /// most once, so the flow never re-enters a cell of the current chain. False for
    /// merged cells.
    pub convex_cells: bool,
}

/// Adds the complex's crack links ([`CellComplex::cracks`]) to `portals`: each between two
/// different graph cells (`cell_of`) becomes pieces of that pair's portal, oriented like it,
/// or a new portal. A sight line may cross a crack, so the PVS must let it through.
fn add_cracks(portals: &mut Vec<GraphPortal>, cx: &CellComplex, cell_of: impl Fn(crate::CellId) -> Option<u32>) {
    if cx.cracks.is_empty() {
        return;
    }
    let mut by_pair: std::collections::HashMap<(u32, u32), usize> = portals
        .iter()
        .enumerate()
        .map(|(k, p)| ((p.cells[0].min(p.cells[1]), p.cells[0].max(p.cells[1])), k))
        .collect();
    for crack in &cx.cracks {
        let (Some(a), Some(b)) = (cell_of(crack.cells[0]), cell_of(crack.cells[1])) else {
            continue;
        };
        if a == b {
            continue;
        }
        let k = *by_pair.entry((a.min(b), a.max(b))).or_insert_with(|| {
            portals.push(GraphPortal {
                cells: [a, b],
                pieces: Vec::new(),
            });
            portals.len() - 1
        });
        // Crack pieces point from `crack.cells[0]` (in `a`) to `crack.cells[1]` (in `b`).
        let forward = portals[k].cells == [a, b];
        for q in &crack.pieces {
            portals[k].pieces.push(if forward {
                q.verts.to_vec()
            } else {
                q.reversed().verts.into_vec()
            });
        }
    }
}

impl PortalGraph {
    /// The portal graph of a partition: cell `i` is `partition.cells[i]`; one portal per
    /// [`crate::decimate::MergedPortal`], with its convex pieces (possibly non-coplanar),
    /// plus the complex's crack links ([`CellComplex::cracks`]) between different cells:
    /// added as pieces of the pair's portal (a new portal if the pair has none).
    pub fn from_partition(cx: &CellComplex, partition: &Partition) -> Self {
        let mut portals: Vec<GraphPortal> = partition
            .portals(cx)
            .into_iter()
            .filter_map(|mp| {
                let a = partition.cell_of(mp.cells[0])? as u32;
                let b = partition.cell_of(mp.cells[1])? as u32;
                Some(GraphPortal {
                    cells: [a, b],
                    pieces: mp.pieces.into_iter().map(|q| q.verts.into_vec()).collect(),
                })
            })
            .collect();
        add_cracks(&mut portals, cx, |c| partition.cell_of(c).map(|i| i as u32));
        PortalGraph {
            cells: partition.len(),
            portals,
            convex_cells: false,
        }
    }

    /// The portal graph of the complex's active cells, numbered in the order of
    /// [`CellComplex::active_cells`]; returns the graph and, per complex cell id, its index
    /// (`u32::MAX` for inactive cells).
    pub fn from_complex(cx: &CellComplex) -> (Self, Vec<u32>) {
        let mut index = vec![u32::MAX; cx.cells.len()];
        let mut n = 0;
        for (c, _) in cx.active_cells() {
            index[c.idx()] = n;
            n += 1;
        }
        let mut portals: Vec<GraphPortal> = cx
            .portals
            .iter()
            .filter_map(|p| {
                let (a, b) = (index[p.cells[0].idx()], index[p.cells[1].idx()]);
                (a != u32::MAX && b != u32::MAX && a != b).then(|| GraphPortal {
                    cells: [a, b],
                    pieces: p.pieces.iter().map(|q| q.verts.to_vec()).collect(),
                })
            })
            .collect();
        add_cracks(&mut portals, cx, |c| Some(index[c.idx()]).filter(|&i| i != u32::MAX));
        (
            PortalGraph {
                cells: n as usize,
                portals,
                convex_cells: true,
            },
            index,
        )
    }

    /// Number of convex portal pieces.
    pub fn pieces(&self) -> usize {
        self.portals.iter().map(|p| p.pieces.len()).sum()
    }

    /// Bounding-box diagonal of all portal vertices (0 without portals).
    pub fn diagonal(&self) -> f64 {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.portals {
            for q in &p.pieces {
                for v in q {
                    for k in 0..3 {
                        lo[k] = lo[k].min(v[k]);
                        hi[k] = hi[k].max(v[k]);
                    }
                }
            }
        }
        if lo[0] > hi[0] {
            return 0.0;
        }
        ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt()
    }
}
