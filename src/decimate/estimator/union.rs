//! `union`: the exact area of the union of the projected convex pieces, from each cell's
//! boundary faces keyed by patch (see [`Boundary`]); merged by symmetric difference.

use super::AreaEstimator;
use crate::base::vec::{P3, dot};
use crate::decimate::project::{Frame, P2, bbox2, hull2, union_area, union_area_delta};
use crate::geom::{ConvexPolygon, ConvexPolyhedron};
use crate::ids::PatchId;

/// Exact union of the projected convex pieces.
#[derive(Clone, Copy, Debug, Default)]
pub struct Union;

impl AreaEstimator for Union {
    const NAME: &'static str = "union";
    type State = Boundary;

    fn piece(poly: &ConvexPolyhedron) -> Boundary {
        Boundary::of(poly)
    }

    fn size(state: &Boundary) -> usize {
        state.faces.len()
    }

    /// The merge is remembered until the next one, so that
    /// [`Union::projected_area_grown`] integrates only what the absorbed cell adds.
    fn absorb(state: &mut Boundary, other: Boundary) -> bool {
        state.absorb(other);
        true
    }

    fn projected_area(state: &Boundary, frame: &Frame) -> f64 {
        state.projected_area(frame)
    }

    /// Incremental: what the absorbed cell's front faces add to the survivor's.
    fn projected_area_grown(state: &Boundary, frame: &Frame, before: f64) -> f64 {
        state.projected_area_grown(frame, before)
    }

    fn projected_area_direct(pieces: &[&ConvexPolyhedron], frame: &Frame) -> f64 {
        let proj = |p: &ConvexPolyhedron| -> Vec<P2> { p.vertices().iter().map(|v| frame.project(v)).collect() };
        union_area(&pieces.iter().map(|p| hull2(proj(p))).collect::<Vec<_>>())
    }
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
pub struct Boundary {
    faces: std::collections::HashMap<PatchId, Face>,
    /// Stamp of the last [`Boundary::absorb`]: the faces that came from the absorbed cell
    /// carry it, and every older face a smaller one.
    stamp: u32,
    /// The shared faces of the last merge, as the survivor and as the absorbed cell had them.
    shared_own: Vec<(PatchId, Face)>,
    shared_absorbed: Vec<(PatchId, Face)>,
    /// Keys of the absorbed cell's faces that the last merge kept (sorted), so that an
    /// incremental evaluation finds them without scanning the whole boundary.
    absorbed: Vec<PatchId>,
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
    /// which [`union_area`](super::super::project::union_area) drops by its width test.
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
                .map(PatchId)
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
        let mut front: Vec<(PatchId, Vec<P2>)> = self
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
    /// to the front faces of `S` that they overlap ([`union_area_delta`](super::super::project::union_area_delta)). Exact because
    /// `proj(S ∪ R) = proj(S) ∪ proj(R)`; local because only `S`'s faces whose bounding
    /// spheres project into `R`'s projected box take part (selecting them is one scan of
    /// two dot products per face; the union work is the size of what changed).
    fn projected_area_grown(&self, frame: &Frame, before: f64) -> f64 {
        if self.stamp == 0 {
            return self.projected_area(frame);
        }
        let mut absorbed: Vec<(PatchId, &Face)> = self
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
        let mut own: Vec<(PatchId, Vec<P2>)> = self
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
