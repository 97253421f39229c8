//! Projected-area estimators and the per-cell state each keeps so that a collapse costs
//! about the size of what changed.
//!
//! | estimator | measure of a cell projected on the portal plane | per-cell state | merge |
//! |-----------|-----------------------------------------------|----------------|-------|
//! | `bbox`  | area of the bounding rectangle, axis-aligned in the plane's canonical frame ([`Frame`]) — the thesis's "bounding rectangle" | 3D convex hull | insert the smaller hull's vertices into the larger: `O(k·h)` |
//! | `hull`  | area of the 2D convex hull of the projected cell | 3D convex hull | as `bbox` |
//! | `union` | exact area of the union of the projected convex pieces | convex blocks (below) | concatenate, then fuse touching blocks |
//!
//! **Why the 3D hull suffices for `bbox` and `hull`.** Orthogonal projection is linear, so
//! the projection of the convex hull of a point set is the convex hull of the projected
//! points, and the extreme points in any in-plane direction are projections of 3D hull
//! vertices. Both measures therefore depend only on the cell's 3D hull vertex set, and the
//! hull of a union is the hull of the two hulls' vertices. A merged room keeps tens to a
//! few hundred hull vertices however many pieces it absorbed; when the absorbed cell lies
//! inside the survivor's hull, nothing changes (exactly: the insertion is decided by exact
//! [`orient3d`](crate::predicates::orient3d)) and the survivor's other pairs keep their
//! weights without being re-weighed.
//!
//! **Blocks for `union`.** The projection of a cell is the union of its pieces'
//! projections. Pieces are grouped into *blocks* whose union is convex — checked when two
//! blocks are fused: the hull volume of the pair must not exceed the sum of their volumes
//! by more than [`FUSE_REL`] (relative) plus [`min_volume`] (the pieces' interiors are
//! disjoint, so equality means the union *is* the hull). A block's projection is then the
//! 2D hull of its projected hull vertices, and the cell's projected area is the exact
//! area of the union of its blocks' projections ([`union_area`]). Open space tiled by
//! many tetrahedra fuses into few blocks. Cost per evaluation is
//! `O(Σ_B |B| · Σ_{B' meets B} |B'|)` over the cell's blocks `B` — quadratic in the number
//! of overlapping blocks in the worst case; a merge tries to fuse each block of the
//! smaller cell with the larger cell's blocks whose boxes touch it.

use super::hull3::Hull3;
use super::project::{Frame, P2, bbox_area, hull2, polygon_area, union_area, union_area_delta};
use crate::geom::min_volume;
use crate::predicates::P3;
use crate::tolerances::Tolerances;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// Relative volume slack under which the union of two blocks counts as convex.
pub const FUSE_REL: f64 = 1e-9;

/// How the projected area of a (merged, non-convex) cell on a portal plane is measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Estimator {
    /// Axis-aligned bounding rectangle in the plane's canonical frame (thesis 4.4).
    Bbox,
    /// 2D convex hull of the projected vertices.
    Hull,
    /// Exact union of the projected convex pieces.
    Union,
}

impl Estimator {
    /// All estimators, in a fixed order.
    pub const ALL: [Estimator; 3] = [Estimator::Bbox, Estimator::Hull, Estimator::Union];

    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Estimator::Bbox => "bbox",
            Estimator::Hull => "hull",
            Estimator::Union => "union",
        }
    }
}

impl fmt::Display for Estimator {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Estimator {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "bbox" => Ok(Estimator::Bbox),
            "hull" => Ok(Estimator::Hull),
            "union" => Ok(Estimator::Union),
            _ => Err(format!("unknown estimator {s:?}; use bbox, hull or union")),
        }
    }
}

/// A convex group of pieces (for `union`).
#[derive(Clone, Debug)]
pub(crate) struct Block {
    hull: Hull3,
    volume: f64,
    aabb: (P3, P3),
    /// Bounding sphere (centre, radius) for the cheap overlap filter of [`union_area_delta`].
    centre: P3,
    radius: f64,
}

impl Block {
    fn new(hull: Hull3, volume: f64) -> Self {
        let aabb = hull.aabb();
        let centre = [0, 1, 2].map(|k| 0.5 * (aabb.0[k] + aabb.1[k]));
        let radius = 0.5 * (0..3).map(|k| (aabb.1[k] - aabb.0[k]).powi(2)).sum::<f64>().sqrt();
        Block {
            hull,
            volume,
            aabb,
            centre,
            radius,
        }
    }

    fn project(&self, frame: &Frame) -> Vec<P2> {
        hull2(self.hull.pts.iter().map(|p| frame.project(p)).collect())
    }
}

/// What an estimator keeps per cell.
#[derive(Clone, Debug)]
pub(crate) enum Shape {
    /// For `bbox` and `hull`.
    Hull(Hull3),
    /// For `union`: blocks; those from `pending` on were absorbed by the last collapse and
    /// are not fused yet (see [`Shape::settle`]).
    Blocks {
        /// The blocks.
        blocks: Vec<Block>,
        /// Start of the blocks absorbed by the last collapse.
        pending: usize,
    },
}

impl Shape {
    /// The state of one convex piece with vertices `verts` and volume `volume`.
    pub fn piece(est: Estimator, verts: &[P3], volume: f64) -> Self {
        let h = Hull3::new(verts);
        match est {
            Estimator::Bbox | Estimator::Hull => Shape::Hull(h),
            Estimator::Union => Shape::Blocks {
                blocks: vec![Block::new(h, volume)],
                pending: 1,
            },
        }
    }

    /// Number of stored vertices (hull vertices or blocks' hull vertices).
    pub fn size(&self) -> usize {
        match self {
            Shape::Hull(h) => h.pts.len(),
            Shape::Blocks { blocks, .. } => blocks.iter().map(|b| b.hull.pts.len()).sum(),
        }
    }

    /// Merges `other` into `self` (the cell that absorbs it); returns whether any
    /// projected measure of `self` may have changed. `false` is exact: the state is then
    /// untouched. For `union` the absorbed blocks stay pending (unfused) until
    /// [`Shape::settle`], so that [`Shape::projected_area_grown`] can integrate only what
    /// they add.
    pub fn absorb(&mut self, other: Shape) -> bool {
        match (self, other) {
            (Shape::Hull(a), Shape::Hull(b)) => a.insert_all(&b),
            (Shape::Blocks { blocks, pending }, Shape::Blocks { blocks: b, .. }) => {
                *pending = blocks.len();
                blocks.extend(b);
                true
            }
            _ => unreachable!("shapes of one run come from one estimator"),
        }
    }

    /// Fuses the pending blocks of the last [`Shape::absorb`] (no-op for hulls).
    pub fn settle(&mut self, tol: &Tolerances) {
        if let Shape::Blocks { blocks, pending } = self
            && *pending < blocks.len()
        {
            let incoming = blocks.split_off(*pending);
            fuse_blocks(blocks, incoming, tol);
            *pending = blocks.len();
        }
    }

    /// The projected area after the last [`Shape::absorb`], given the area `before` it on
    /// the same plane. For `union`: `before` plus what the pending blocks add
    /// ([`union_area_delta`], against only the old blocks whose bounding spheres' projections
    /// meet the new blocks' projected box) — about the size of what changed instead of the
    /// whole cell. For `bbox` and `hull` the full measure (cheap anyway).
    pub fn projected_area_grown(&self, est: Estimator, frame: &Frame, before: f64) -> f64 {
        let Shape::Blocks { blocks, pending } = self else {
            return self.projected_area(est, frame);
        };
        let (old, new) = blocks.split_at((*pending).min(blocks.len()));
        let v: Vec<Vec<P2>> = new.iter().map(|b| b.project(frame)).collect();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in v.iter().flatten() {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let u: Vec<Vec<P2>> = old
            .iter()
            .filter(|b| {
                let c = frame.project(&b.centre);
                (0..2).all(|k| c[k] + b.radius >= lo[k] && c[k] - b.radius <= hi[k])
            })
            .map(|b| b.project(frame))
            .collect();
        let d = union_area_delta(&u, &v);
        let a = before + if d.is_finite() { d.max(0.0) } else { 0.0 };
        if a.is_finite() { a } else { 0.0 }
    }

    /// Projected area on the plane of `frame`.
    pub fn projected_area(&self, est: Estimator, frame: &Frame) -> f64 {
        let proj = |pts: &[P3]| -> Vec<P2> { pts.iter().map(|p| frame.project(p)).collect() };
        let a = match (est, self) {
            (Estimator::Bbox, Shape::Hull(h)) => bbox_area(&proj(&h.pts)),
            (Estimator::Hull, Shape::Hull(h)) => polygon_area(&hull2(proj(&h.pts))),
            (Estimator::Union, Shape::Blocks { blocks, .. }) => {
                if blocks.len() == 1 {
                    polygon_area(&blocks[0].project(frame))
                } else {
                    let polys: Vec<Vec<P2>> = blocks.iter().map(|b| b.project(frame)).collect();
                    union_area(&polys)
                }
            }
            _ => unreachable!("shape does not match estimator"),
        };
        if a.is_finite() { a.max(0.0) } else { 0.0 }
    }
}

fn touch(a: &(P3, P3), b: &(P3, P3), slack: f64) -> bool {
    (0..3).all(|k| a.0[k] <= b.1[k] + slack && b.0[k] <= a.1[k] + slack)
}

/// Appends `incoming` to `blocks`, fusing each incoming block into the first block of
/// `blocks` whose box touches it and whose union with it is convex.
fn fuse_blocks(blocks: &mut Vec<Block>, incoming: Vec<Block>, tol: &Tolerances) {
    let slack = tol.plane_abs().max(tol.weld_abs());
    let vmin = min_volume(tol);
    for b in incoming {
        let mut fused = false;
        for k in 0..blocks.len() {
            let a = &blocks[k];
            if !touch(&a.aabb, &b.aabb, slack) {
                continue;
            }
            let mut h = a.hull.clone();
            h.insert_all(&b.hull);
            let v = a.volume + b.volume;
            if h.volume() <= v * (1.0 + FUSE_REL) + vmin {
                blocks[k] = Block::new(h, v);
                fused = true;
                break;
            }
        }
        if !fused {
            blocks.push(b);
        }
    }
}

/// The projected area of a cell given by its convex pieces, computed from scratch (no
/// hulls kept, no blocks fused): the reference the incremental states are tested against.
/// `bbox` and `hull` use all piece vertices; `union` the union of the pieces' projections.
pub fn projected_area_direct(est: Estimator, pieces: &[&crate::geom::ConvexPolyhedron], frame: &Frame) -> f64 {
    let proj =
        |p: &crate::geom::ConvexPolyhedron| -> Vec<P2> { p.vertices().iter().map(|v| frame.project(v)).collect() };
    match est {
        Estimator::Bbox => bbox_area(&pieces.iter().flat_map(|p| proj(p)).collect::<Vec<_>>()),
        Estimator::Hull => polygon_area(&hull2(pieces.iter().flat_map(|p| proj(p)).collect())),
        Estimator::Union => union_area(&pieces.iter().map(|p| hull2(proj(p))).collect::<Vec<_>>()),
    }
}
