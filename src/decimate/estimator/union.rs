//! `union`: the exact area of the union of the projected convex pieces, from each cell's
//! boundary faces keyed by patch (see [`Boundary`]); merged by symmetric difference.

use super::AreaEstimator;
use crate::base::vec::{P3, dot};
use crate::decimate::project::{
    Frame, P2, bbox2, hull2, hull2_into, union_area, union_area_delta_slices, union_area_paired,
};
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
    /// Unchanged (`false`) when every face of the absorbed cell was shared: it was enclosed
    /// by the survivor, so every line through it meets the survivor (exact).
    fn absorb(state: &mut Boundary, other: Boundary) -> bool {
        state.absorb(other)
    }

    fn projected_area(state: &Boundary, frame: &Frame) -> f64 {
        state.projected_area(frame)
    }

    /// Incremental: what the front faces absorbed since version `since` add to the
    /// survivor's boundary as it was then.
    fn projected_area_grown(state: &Boundary, frame: &Frame, before: f64, since: u32) -> f64 {
        state.projected_area_grown(frame, before, since)
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
/// Neighbouring front faces share edges exactly (bit-identical vertices project to
/// bit-identical points), so the union integrates only the silhouette edges and the edges
/// of overlapping layers ([`union_area_paired`]).
///
/// **Merging** is a symmetric difference by patch id: a patch shared by the two cells
/// becomes interior and leaves both; the rest is kept. That costs the absorbed boundary
/// (hash look-ups into the survivor's index; faces live in one vector, removed by swap).
///
/// **Order.** Faces are unioned in storage order, which depends only on the merge history
/// (deterministic), never on a hash map's iteration order.
#[derive(Clone, Debug, Default)]
pub struct Boundary {
    faces: Vec<Face>,
    /// Position in `faces` of each patch.
    index: std::collections::HashMap<PatchId, u32, std::hash::BuildHasherDefault<IdHasher>>,
    /// Merges that brought a face (the version; see [`AreaEstimator::absorb`]). Each face
    /// records the version that added it ([`Face::added`]).
    ver: u32,
    /// The faces that merges removed from this boundary (they became interior), with the
    /// version current after their removal, in removal order (so versions ascend): the
    /// boundary as it was at an earlier version, which a grown area extends, is the
    /// present faces added by then plus the removed ones added by then and removed later.
    /// Only this cell's own faces are logged; the absorbed cell's log is dropped (a pair
    /// of the absorbed cell re-keyed to this one is recomputed from scratch).
    removed: Vec<(u32, Face)>,
    /// The areas computed since the last merge, by frame (normal and origin bits): a pair
    /// re-keyed to a new neighbour keeps its plane, so its unchanged side is asked again
    /// for the same area. Cleared by every merge.
    memo: std::cell::RefCell<Memo>,
}

/// Areas by frame key ([`frame_key`]).
type Memo = std::collections::HashMap<[u64; 6], f64, std::hash::BuildHasherDefault<IdHasher>>;

fn frame_key(frame: &Frame) -> [u64; 6] {
    let (n, o) = (frame.n, frame.o);
    [n[0], n[1], n[2], o[0], o[1], o[2]].map(f64::to_bits)
}

/// Hasher for `u32` patch ids (a multiplicative mix; deterministic).
#[derive(Clone, Copy, Debug, Default)]
pub struct IdHasher(u64);

impl std::hash::Hasher for IdHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(8) ^ b as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
    }
    fn write_u32(&mut self, i: u32) {
        self.0 = (self.0 ^ i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(32);
    }
}

/// One boundary face with what the per-evaluation filters need, computed once.
#[derive(Clone, Debug)]
struct Face {
    key: PatchId,
    /// The [`Boundary::ver`] of the merge that added it to this boundary (0: the piece's own).
    added: u32,
    /// Area vector (normal × area), outward.
    area: P3,
    /// Bounding sphere of the vertices.
    centre: P3,
    radius: f64,
    verts: Box<[P3]>,
}

impl Face {
    fn new(key: PatchId, poly: ConvexPolygon) -> Self {
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
            key,
            added: 0,
            area,
            centre,
            radius,
            verts: poly.verts.into_boxed_slice(),
        }
    }

    /// Whether the face faces along the frame's direction (its outward area vector has a
    /// positive component along it). Faces seen edge-on project to slivers, which the
    /// unions drop by their width test.
    fn is_front(&self, frame: &Frame) -> bool {
        dot(&self.area, &frame.n) > 0.0
    }

    /// Appends the projection (its 2D hull, as [`hull2`]) to `out`; `scratch` is reused.
    fn project_into(&self, frame: &Frame, scratch: &mut Vec<P2>, out: &mut Vec<P2>) {
        scratch.clear();
        scratch.extend(self.verts.iter().map(|p| frame.project(p)));
        hull2_into(scratch, out);
    }

    /// Whether the projection may meet the box `(lo, hi)` (bounding-sphere test).
    fn may_meet(&self, frame: &Frame, lo: &P2, hi: &P2) -> bool {
        let c = frame.project(&self.centre);
        let r = self.radius;
        (0..2).all(|k| c[k] - r <= hi[k] && lo[k] <= c[k] + r)
    }
}

/// Projected faces in one flat buffer.
#[derive(Default)]
struct Flat {
    pts: Vec<P2>,
    ends: Vec<usize>,
    scratch: Vec<P2>,
}

impl Flat {
    fn push(&mut self, f: &Face, frame: &Frame) {
        f.project_into(frame, &mut self.scratch, &mut self.pts);
        self.ends.push(self.pts.len());
    }

    fn slices(&self) -> Vec<&[P2]> {
        let mut s = 0;
        self.ends
            .iter()
            .map(|&e| {
                let p = &self.pts[s..e];
                s = e;
                p
            })
            .collect()
    }
}

#[cfg(test)]
thread_local! {
    /// Tests switch to the reference evaluation (every area from scratch by
    /// [`union_area`] over the front faces in patch order, as before the paired union).
    static REFERENCE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

#[cfg(test)]
fn reference() -> bool {
    REFERENCE.with(|c| c.get())
}

#[cfg(not(test))]
fn reference() -> bool {
    false
}

impl Boundary {
    fn of(poly: &ConvexPolyhedron) -> Self {
        // A cell's faces name distinct patches (checked by `CellComplex::validate`).
        debug_assert!({
            let mut t = poly.tags.clone();
            t.sort_unstable();
            t.windows(2).all(|w| w[0] != w[1])
        });
        let faces: Vec<Face> = poly
            .tags
            .iter()
            .zip(poly.faces.iter())
            .map(|(&t, f)| Face::new(PatchId(t), f.clone()))
            .collect();
        let index = faces.iter().enumerate().map(|(i, f)| (f.key, i as u32)).collect();
        Boundary {
            faces,
            index,
            ..Default::default()
        }
    }

    /// Removes the face at position `i` (the last face takes its place).
    fn remove_at(&mut self, i: usize) -> Face {
        let f = self.faces.swap_remove(i);
        self.index.remove(&f.key);
        if let Some(moved) = self.faces.get(i) {
            self.index.insert(moved.key, i as u32);
        }
        f
    }

    /// `self ← self ∪ other`; returns whether the absorbed cell brought any face (when it
    /// did not, it was enclosed by `self` and no projection changed). Costs the size of
    /// `other`'s boundary. A merge that brought a face advances [`Boundary::ver`]; faces
    /// that became interior go to the removal log.
    fn absorb(&mut self, other: Boundary) -> bool {
        self.memo.get_mut().clear();
        let mut fresh = Vec::new();
        let mut gone = Vec::new();
        for f in other.faces {
            match self.index.get(&f.key) {
                Some(&i) => gone.push(self.remove_at(i as usize)),
                None => fresh.push(f),
            }
        }
        let changed = !fresh.is_empty();
        if changed {
            self.ver += 1;
        }
        self.removed.extend(gone.into_iter().map(|f| (self.ver, f)));
        for mut f in fresh {
            f.added = self.ver;
            self.index.insert(f.key, self.faces.len() as u32);
            self.faces.push(f);
        }
        changed
    }

    /// The exact area of the union of the projected pieces, from the front faces.
    fn projected_area(&self, frame: &Frame) -> f64 {
        if reference() {
            return self.projected_area_reference(frame);
        }
        let key = frame_key(frame);
        if let Some(&a) = self.memo.borrow().get(&key) {
            return a;
        }
        let mut flat = Flat::default();
        for f in self.faces.iter().filter(|f| f.is_front(frame)) {
            flat.push(f, frame);
        }
        let a = union_area_paired(&flat.slices());
        self.memo.borrow_mut().insert(key, a);
        a
    }

    /// The reference: the front faces in patch order, each projected by [`hull2`], unioned
    /// by [`union_area`].
    fn projected_area_reference(&self, frame: &Frame) -> f64 {
        let mut front: Vec<&Face> = self.faces.iter().filter(|f| f.is_front(frame)).collect();
        front.sort_unstable_by_key(|f| f.key);
        let polys: Vec<Vec<P2>> = front
            .iter()
            .map(|f| hull2(f.verts.iter().map(|p| frame.project(p)).collect()))
            .collect();
        union_area(&polys)
    }

    /// The projected area now, given the area `before` on the same plane when the version
    /// was `since` (`S_v`, grown since by merges into `S`): `before` plus what the front
    /// faces added since add to `S_v`'s front faces that they overlap
    /// ([`union_area_delta_slices`]).
    ///
    /// Exact because `proj(S) = proj(S_v) ∪ proj(F)`, `F` the front faces of `S` added after
    /// `v`: a line along the direction that meets `S` but not `S_v` leaves `S` (for the last
    /// time) through a front face of a piece absorbed after `v`, which that merge added
    /// (faces that become interior never return). `S_v`'s boundary (at the end of version
    /// `v`; merges that brought no face change no projection) is the present faces added by
    /// `v` plus the logged ones added by `v` and removed after it. Local because only those
    /// whose bounding spheres, then projected boxes, meet the new faces' projected box take
    /// part (one scan of two dot products per face; the union work is the size of what
    /// changed). When more than an eighth of the faces are new, the area is computed from
    /// scratch.
    fn projected_area_grown(&self, frame: &Frame, before: f64, since: u32) -> f64 {
        if reference() {
            return self.projected_area(frame);
        }
        if since >= self.ver {
            return before;
        }
        let key = frame_key(frame);
        if let Some(&a) = self.memo.borrow().get(&key) {
            return a;
        }
        // The delta does not pair edges, and its old faces overlap the new ones' box: it
        // pays off only when little changed (on caverns to the end, allowing up to half the
        // faces to be new cost 30 % more instructions than recomputing).
        let new = self.faces.iter().filter(|f| f.added > since).count();
        if 8 * new > self.faces.len() {
            return self.projected_area(frame);
        }
        let mut v = Flat::default();
        for f in self.faces.iter().filter(|f| f.added > since && f.is_front(frame)) {
            v.push(f, frame);
        }
        if v.ends.is_empty() {
            self.memo.borrow_mut().insert(key, before);
            return before;
        }
        let (lo, hi) = bbox2(v.pts.iter());
        // Projected boxes farther than this from the new faces' box cannot meet them.
        let m = 1e-6 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
        let (glo, ghi) = ([lo[0] - m, lo[1] - m], [hi[0] + m, hi[1] + m]);
        let from = self.removed.partition_point(|(r, _)| *r <= since);
        let mut u = Flat::default();
        for f in self
            .faces
            .iter()
            .chain(self.removed[from..].iter().map(|(_, f)| f))
            .filter(|f| f.added <= since && f.may_meet(frame, &glo, &ghi) && f.is_front(frame))
        {
            let at = u.pts.len();
            f.project_into(frame, &mut u.scratch, &mut u.pts);
            let (plo, phi) = bbox2(u.pts[at..].iter());
            if plo[0] <= ghi[0] && glo[0] <= phi[0] && plo[1] <= ghi[1] && glo[1] <= phi[1] {
                u.ends.push(u.pts.len());
            } else {
                u.pts.truncate(at);
            }
        }
        let d = union_area_delta_slices(&u.slices(), &v.slices());
        let a = before + if d.is_finite() { d.max(0.0) } else { 0.0 };
        self.memo.borrow_mut().insert(key, a);
        a
    }
}

#[cfg(test)]
mod tests {
    use super::REFERENCE;
    use crate::complex::CellComplex;
    use crate::decimate::{Decimation, Estimator, HeuristicKind, Settings, StopRule};

    fn thesis(name: &str) -> CellComplex {
        crate::decimate::thesis_complex(name)
    }

    fn run(cx: &CellComplex, h: HeuristicKind, stop: StopRule, reference: bool) -> Decimation {
        REFERENCE.with(|c| c.set(reference));
        let d = Decimation::run(
            cx,
            &Settings {
                heuristic: h,
                estimator: Estimator::Union,
                stop,
                ..Settings::default()
            },
        );
        REFERENCE.with(|c| c.set(false));
        d
    }

    /// The incremental evaluation (paired unions of front faces, grown areas from fresh
    /// faces, enclosed cells leaving their survivor unchanged, memoised areas) makes the
    /// same decisions as the reference (every area from scratch by `union_area` over the
    /// front faces in patch order, the evaluation before the paired union), on the thesis
    /// models and a generated scene, for the three thesis heuristics, at the default stop
    /// and to the end: as many collapses, the same weight at every step (to 1e-6), the
    /// same final partition. Areas differ in the last bits (summation order), so pairs
    /// whose weights tie up to rounding — many at ≈ 1, where a portal fills a whole
    /// tetrahedron face — may swap places within their run of ties; the count of steps
    /// that name the same pair is printed.
    #[test]
    fn decisions_equal_the_reference_evaluation() {
        let s = crate::generate::four_rooms::four_rooms();
        let m = crate::model::from_soup("four_rooms", s.vertices.clone(), s.polygons.clone()).expect("model");
        let mut cases = vec![("four_rooms (generated)", crate::pipeline::complex_of_unchecked(&m).expect("complex"))];
        for name in ["four_room_tessellated", "four_room_optimized", "four_room_distorted", "caverns"] {
            cases.push((name, thesis(name)));
        }
        for (name, cx) in &cases {
            for h in [HeuristicKind::Aspect, HeuristicKind::Refined, HeuristicKind::Volume] {
                for stop in [h.default_stop(), StopRule::None] {
                    let fast = run(cx, h, stop, false);
                    let reference = run(cx, h, stop, true);
                    assert!(fast.steps.len() > 50, "{name}/{h}/{stop}: {} steps", fast.steps.len());
                    assert_eq!(fast.steps.len(), reference.steps.len(), "{name}/{h}/{stop}");
                    let mut same = 0;
                    for (k, (f, r)) in fast.steps.iter().zip(&reference.steps).enumerate() {
                        assert!(
                            (f.weight - r.weight).abs() <= 1e-6 * r.weight,
                            "{name}/{h}/{stop} step {k}: weight {} vs {}",
                            f.weight,
                            r.weight
                        );
                        same += usize::from((f.a, f.b) == (r.a, r.b));
                    }
                    assert_eq!(fast.partition, reference.partition, "{name}/{h}/{stop}");
                    eprintln!("{name}/{h}/{stop}: {same} of {} steps name the same pair", fast.steps.len());
                }
            }
        }
    }
}
