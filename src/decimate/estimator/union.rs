//! Projected-area estimators and the per-cell state each keeps so that a collapse costs
//! about the size of what changed.
//!
//! | estimator | measure of a cell projected on the portal plane | per-cell state | merge |
//! |-----------|-----------------------------------------------|----------------|-------|
//! | `bbox`  | area of the bounding rectangle, axis-aligned in the plane's canonical frame ([`Frame`]) — the thesis's "bounding rectangle" | 3D convex hull | insert the smaller hull's vertices into the larger: `O(k·h)` |
//! | `hull`  | area of the 2D convex hull of the projected cell | 3D convex hull | as `bbox` |
//! | `union` | exact area of the union of the projected convex pieces | boundary faces keyed by patch (below) | symmetric difference: `O(size of the absorbed cell's boundary)` |
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
//! **Boundary faces for `union`.** The projection of a cell is the union of its pieces'
//! projections, which is the projection of the solid they fill: the union of the
//! projections of its *front* boundary faces (see [`Boundary`]). The state is the set of
//! boundary faces keyed by patch; a merge is a symmetric difference (cost: the absorbed
//! cell's boundary). On an unchanged plane the survivor's area grows incrementally: the
//! stored area plus what the absorbed cell's front faces add to the survivor's front
//! faces they overlap ([`union_area_delta`]). On a new plane (a pair whose portal set
//! changed) the whole front is unioned ([`union_area`]): an exact area on a new direction
//! depends on the cell's whole silhouette, so no state kept for other directions can make
//! that cheaper than the silhouette's size. Front faces overlap only where the solid has
//! several layers along the direction — not as deep as its pieces pile up, which made a
//! union over pieces quadratic in a merged room's size (e1m1 at `cells:60`: 807 s with
//! convex blocks of pieces, 384 s with boundary faces; `hull` takes under a second).

use super::hull3::Hull3;
use super::project::{Frame, P2, bbox_area, bbox2, hull2, polygon_area, union_area, union_area_delta};
use crate::geom::vec::dot;
use crate::geom::{ConvexPolygon, ConvexPolyhedron};
use crate::predicates::P3;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

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

/// What an estimator keeps per cell.
#[derive(Clone, Debug)]
pub(crate) enum Shape {
    /// For `bbox` and `hull`.
    Hull(Hull3),
    /// For `union`: the cell's boundary faces, keyed by patch (see [`Boundary`]).
    Boundary(Boundary),
}

/// The boundary of a merged cell: the faces of its pieces that no other piece of the cell
/// shares, keyed by the complex's patch id, each oriented outwards (counter-clockwise seen
/// from outside).
///
/// **Why this gives the exact union.** The pieces fill a solid `S`, and the union of their
/// projections is the projection of `S`. Every line along the projection direction `n`
/// that meets `S` leaves it through a boundary face whose outward normal has a positive
/// component along `n`; so `proj(S)` is the union of the projections of those *front*
/// faces (up to sets of zero area). Extra faces inside `S` (the two sides of a flat
/// membrane, say) project inside `proj(S)` and change nothing. Unlike the pieces, whose
/// projections pile up (every piece of a room projects onto the room's floor plan), front
/// faces overlap only where the solid has several layers along `n`, so the union is cheap.
///
/// **Merging** is a symmetric difference by patch id: a patch shared by the two cells
/// becomes interior and leaves both; the rest is kept. That costs the smaller boundary.
#[derive(Clone, Debug, Default)]
pub(crate) struct Boundary {
    faces: std::collections::HashMap<u32, Face>,
    /// Stamp of the last [`Boundary::absorb`]: the faces that came from the absorbed cell
    /// carry it, and every older face a smaller one.
    stamp: u32,
    /// The shared faces of the last merge, as the survivor and as the absorbed cell had them.
    shared_own: Vec<(u32, Face)>,
    shared_absorbed: Vec<(u32, Face)>,
    /// Keys of the absorbed cell's faces that the last merge kept (sorted), so that an
    /// incremental evaluation finds them without scanning the whole boundary.
    absorbed: Vec<u32>,
}

/// One boundary face with what the per-evaluation filters need, computed once.
#[derive(Clone, Debug)]
struct Face {
    poly: ConvexPolygon,
    /// Area vector (normal × area), outward.
    area: P3,
    /// Bounding sphere of the vertices.
    centre: P3,
    radius: f64,
    /// The [`Boundary::stamp`] of the merge that brought it into this cell.
    stamp: u32,
}

impl Face {
    fn new(poly: ConvexPolygon) -> Self {
        let area = poly.area_vector();
        let n = poly.verts.len().max(1) as f64;
        let mut centre = [0.0; 3];
        for v in &poly.verts {
            for k in 0..3 {
                centre[k] += v[k] / n;
            }
        }
        let radius = poly
            .verts
            .iter()
            .map(|v| (0..3).map(|k| (v[k] - centre[k]).powi(2)).sum::<f64>().sqrt())
            .fold(0.0, f64::max);
        Face {
            area,
            centre,
            radius,
            poly,
            stamp: 0,
        }
    }

    /// The projection if the face faces along the frame's direction (its outward area
    /// vector has a positive component along it). Faces seen edge-on project to slivers,
    /// which [`union_area`] drops by its width test.
    fn front(&self, frame: &Frame) -> Option<Vec<P2>> {
        (dot(&self.area, &frame.n) > 0.0).then(|| hull2(self.poly.verts.iter().map(|p| frame.project(p)).collect()))
    }

    /// Whether the projection may meet the box `(lo, hi)` (bounding-sphere test).
    fn may_meet(&self, frame: &Frame, lo: &P2, hi: &P2) -> bool {
        let c = frame.project(&self.centre);
        let r = self.radius;
        (0..2).all(|k| c[k] - r <= hi[k] && lo[k] <= c[k] + r)
    }
}

impl Boundary {
    fn of(poly: &ConvexPolyhedron) -> Self {
        // A cell's faces name distinct patches (checked by `CellComplex::validate`).
        debug_assert!({
            let mut t = poly.tags.clone();
            t.sort_unstable();
            t.windows(2).all(|w| w[0] != w[1])
        });
        Boundary {
            faces: poly
                .tags
                .iter()
                .copied()
                .zip(poly.faces.iter().cloned().map(Face::new))
                .collect(),
            ..Default::default()
        }
    }

    /// `self ← self ∪ other`. Costs the size of `other`'s boundary.
    fn absorb(&mut self, other: Boundary) {
        self.stamp = self.stamp.max(other.stamp) + 1;
        self.shared_own.clear();
        self.shared_absorbed.clear();
        self.absorbed.clear();
        for (k, mut f) in other.faces {
            match self.faces.remove(&k) {
                Some(mine) => {
                    self.shared_own.push((k, mine));
                    self.shared_absorbed.push((k, f));
                }
                None => {
                    f.stamp = self.stamp;
                    self.faces.insert(k, f);
                    self.absorbed.push(k);
                }
            }
        }
        self.absorbed.sort_unstable();
        self.shared_own.sort_unstable_by_key(|e| e.0);
        self.shared_absorbed.sort_unstable_by_key(|e| e.0);
    }

    /// The exact area of the union of the projected pieces, from the front faces.
    fn projected_area(&self, frame: &Frame) -> f64 {
        // Faces in patch order, so that the tie rules of `union_area` (which follow input
        // order) do not depend on the hash map's iteration order.
        let mut front: Vec<(u32, Vec<P2>)> = self
            .faces
            .iter()
            .filter_map(|(k, f)| f.front(frame).map(|p| (*k, p)))
            .collect();
        front.sort_unstable_by_key(|e| e.0);
        let polys: Vec<Vec<P2>> = front.into_iter().map(|e| e.1).collect();
        union_area(&polys)
    }

    /// The projected area after the last [`Boundary::absorb`] (`S ← S ∪ R`), given `S`'s
    /// projected area `before` on the same plane: `before` plus what `R`'s front faces add
    /// to the front faces of `S` that they overlap ([`union_area_delta`]). Exact because
    /// `proj(S ∪ R) = proj(S) ∪ proj(R)`; local because only `S`'s faces whose bounding
    /// spheres project into `R`'s projected box take part (selecting them is one scan of
    /// two dot products per face; the union work is the size of what changed).
    fn projected_area_grown(&self, frame: &Frame, before: f64) -> f64 {
        if self.stamp == 0 {
            return self.projected_area(frame);
        }
        let mut absorbed: Vec<(u32, &Face)> = self
            .absorbed
            .iter()
            .map(|k| (*k, &self.faces[k]))
            .chain(self.shared_absorbed.iter().map(|(k, f)| (*k, f)))
            .collect();
        absorbed.sort_unstable_by_key(|e| e.0);
        let v: Vec<Vec<P2>> = absorbed.iter().filter_map(|(_, f)| f.front(frame)).collect();
        if v.is_empty() {
            return before;
        }
        let (lo, hi) = bbox2(v.iter().flatten());
        let mut own: Vec<(u32, Vec<P2>)> = self
            .faces
            .iter()
            .filter(|(_, f)| f.stamp != self.stamp)
            .chain(self.shared_own.iter().map(|(k, f)| (k, f)))
            .filter(|(_, f)| f.may_meet(frame, &lo, &hi))
            .filter_map(|(k, f)| f.front(frame).map(|p| (*k, p)))
            .collect();
        own.sort_unstable_by_key(|e| e.0);
        let u: Vec<Vec<P2>> = own.into_iter().map(|e| e.1).collect();
        let d = union_area_delta(&u, &v);
        before + if d.is_finite() { d.max(0.0) } else { 0.0 }
    }
}

impl Shape {
    /// The state of one convex piece (a cell of the complex, faces tagged by patch).
    pub fn piece(est: Estimator, poly: &ConvexPolyhedron) -> Self {
        match est {
            Estimator::Bbox | Estimator::Hull => Shape::Hull(Hull3::new(&poly.vertices())),
            Estimator::Union => Shape::Boundary(Boundary::of(poly)),
        }
    }

    /// Size of the state: hull vertices, or boundary faces for `union`.
    pub fn size(&self) -> usize {
        match self {
            Shape::Hull(h) => h.pts.len(),
            Shape::Boundary(b) => b.faces.len(),
        }
    }

    /// Merges `other` into `self` (the cell that absorbs it); returns whether any
    /// projected measure of `self` may have changed. `false` is exact: the state is then
    /// untouched. For `union` the merge is remembered until the next one, so that
    /// [`Shape::projected_area_grown`] can integrate only what the absorbed cell adds.
    pub fn absorb(&mut self, other: Shape) -> bool {
        match (self, other) {
            (Shape::Hull(a), Shape::Hull(b)) => a.insert_all(&b),
            (Shape::Boundary(a), Shape::Boundary(b)) => {
                a.absorb(b);
                true
            }
            _ => unreachable!("shapes of one run come from one estimator"),
        }
    }

    /// The projected area after the last [`Shape::absorb`], given the area `before` it on
    /// the same plane: incremental for `union` ([`Boundary::projected_area_grown`]), the
    /// full (cheap) measure for `bbox` and `hull`.
    pub fn projected_area_grown(&self, est: Estimator, frame: &Frame, before: f64) -> f64 {
        let a = match self {
            Shape::Boundary(b) => b.projected_area_grown(frame, before),
            Shape::Hull(_) => return self.projected_area(est, frame),
        };
        if a.is_finite() { a.max(0.0) } else { 0.0 }
    }

    /// Projected area on the plane of `frame`.
    pub fn projected_area(&self, est: Estimator, frame: &Frame) -> f64 {
        let proj = |pts: &[P3]| -> Vec<P2> { pts.iter().map(|p| frame.project(p)).collect() };
        let a = match (est, self) {
            (Estimator::Bbox, Shape::Hull(h)) => bbox_area(&proj(&h.pts)),
            (Estimator::Hull, Shape::Hull(h)) => polygon_area(&hull2(proj(&h.pts))),
            (Estimator::Union, Shape::Boundary(b)) => b.projected_area(frame),
            _ => unreachable!("shape does not match estimator"),
        };
        if a.is_finite() { a.max(0.0) } else { 0.0 }
    }
}

/// The projected area of a cell given by its convex pieces, computed from scratch (no
/// hulls or boundary faces kept): the reference the incremental states are tested against.
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
