//! Convex polyhedra as boundary representations that are cheap to split.

use std::collections::{HashMap, HashSet};

use serde::{Deserialize, Serialize};

use super::plane::{Classification, Classifier, Plane, Side};
use super::polygon::{ConvexPolygon, FacePlane, crossing, walk_split};
use super::vec::{Key, add, cross, dot, key, norm, scale, sub};

/// Up to this many vertex occurrences over all faces, [`ConvexPolyhedron::vertices`] scans
/// instead of hashing.
const SMALL_OCCURRENCES: usize = 96;
use crate::predicates::{P3, orient3d};
use crate::tolerances::Tolerances;

/// A convex polyhedron given by its boundary: convex polygons with outward normals.
///
/// The boundary may be *subdivided*: several coplanar faces (patches) may tile one facet,
/// and faces may carry collinear T-vertices. See the module docs of [`crate::geom`] for
/// the invariants (closed and conforming: every directed edge `p → q` of a face occurs
/// reversed, `q → p`, in exactly one other face, with bit-identical coordinates).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConvexPolyhedron {
    /// Boundary faces, counter-clockwise seen from outside.
    pub faces: Vec<ConvexPolygon>,
    /// One caller-defined tag per face (`tags.len() == faces.len()`), carried through
    /// [`cut`](ConvexPolyhedron::cut) and [`split_face`](ConvexPolyhedron::split_face).
    pub tags: Vec<u32>,
}

/// The two pieces of a polyhedron split by a plane.
#[derive(Clone, Debug, PartialEq)]
pub struct PolyhedronSplit {
    /// The part on the front (positive) side of the plane.
    pub front: ConvexPolyhedron,
    /// The part on the back side.
    pub back: ConvexPolyhedron,
    /// The cross-section, oriented with its normal along the plane normal `n`: it is the
    /// back piece's new face (outward = towards the front). The front piece holds the
    /// same polygon reversed. Both use the very same vertices as the pieces' other faces.
    pub section: ConvexPolygon,
    /// For each face of `front`: the index of the input face it is (part of), or `None`
    /// for the cross-section (always the last face).
    pub front_origin: Vec<Option<usize>>,
    /// As `front_origin`, for `back`.
    pub back_origin: Vec<Option<usize>>,
    /// The distance within which vertices counted as on the plane in this cut; faces of
    /// neighbours sharing a divided face must be subdivided with the same one
    /// ([`split_face_within`](ConvexPolyhedron::split_face_within)).
    pub on_dist: f64,
}

/// Outcome of [`ConvexPolyhedron::cut`].
#[derive(Clone, Debug, PartialEq)]
pub enum Cut {
    /// Not split; the polyhedron counts as in front of the plane.
    Front,
    /// Not split; the polyhedron counts as behind the plane.
    Back,
    /// Genuinely split into two non-sliver pieces.
    Split(Box<PolyhedronSplit>),
}

/// Smallest volume a piece of a split may have: `(tol.area · tol.scale)³`, i.e.
/// `tol.area_abs()^{3/2}` — the cube over the side of the smallest accepted area.
pub fn min_volume(tol: &Tolerances) -> f64 {
    let l = tol.area * tol.scale;
    l * l * l
}

/// `(volume, centroid)` of a closed boundary given as face loops (outward, counter-clockwise
/// seen from outside): sums over the tetrahedra joining a reference vertex (the first
/// face's first vertex) to a fan triangulation of each face (valid for subdivided
/// boundaries). One function for [`ConvexPolyhedron`] and for the implicit tetrahedra of
/// the cell complex, so that both give the same bits for the same faces.
pub fn moments_of<'a>(faces: impl Iterator<Item = &'a [P3]> + Clone) -> (f64, P3) {
    let r = faces.clone().find_map(|f| f.first().copied()).unwrap_or([0.0; 3]);
    let mut v6 = 0.0;
    let mut m = [0.0; 3];
    for v in faces {
        if v.len() < 3 {
            continue;
        }
        let a = sub(&v[0], &r);
        let mut prev = sub(&v[1], &r);
        for p in &v[2..] {
            let cur = sub(p, &r);
            let t = dot(&a, &cross(&prev, &cur));
            v6 += t;
            m = add(&m, &scale(&add(&a, &add(&prev, &cur)), t));
            prev = cur;
        }
    }
    let c = if v6 != 0.0 { add(&r, &scale(&m, 0.25 / v6)) } else { r };
    (v6 / 6.0, c)
}

/// Volume of a closed boundary for sums over a subdivision ([`ConvexPolyhedron::tiling_volume`]):
/// as [`moments_of`]'s, but each face of four or more vertices is fanned from a canonical
/// apex, the mean of its vertices added in the order of their bits, instead of from its
/// first vertex. Two cells sharing a face (the same vertex cycle, reversed, from any start)
/// then fan it identically; a triangle has one triangulation.
///
/// Why: a face of a cut cell need not be planar (vertices within the On band of a cut
/// stay where they are), and the volume under a non-planar face depends on its
/// triangulation. With first-vertex fans, two neighbours that list a shared face from
/// different starts see different volumes under it (e.g. 4.4e-7 in a BSP of size 60 whose
/// cells tile the box exactly: `tests/data/fuzz/pipeline/bsp_cells_cell_volumes_sum_to_n_the_hull_s_volum-6d7804f6.obj`);
/// with canonical fans their terms cancel (exactly, in exact arithmetic: the reference
/// vertex of a closed boundary does not change its volume), so cells that tile their hull
/// sum to its volume up to rounding.
///
/// Not covered: a shared face that carries a T-vertex in one cell's copy only (a vertex
/// on an edge, see `geom`'s module docs) has a different vertex mean there, and if the
/// face is non-planar the two fans still differ, by at most about its area times its
/// distance from planarity — far less than two first-vertex fans differ (1.7e-5 against
/// 3.3e-4 on the unit test's twisted quad, review of session 30), and within the check's
/// 1e-9 relative slack on the models fuzzed so far.
pub fn tiling_volume_of<'a>(faces: impl Iterator<Item = &'a [P3]> + Clone) -> f64 {
    let r = faces.clone().find_map(|f| f.first().copied()).unwrap_or([0.0; 3]);
    let mut v6 = 0.0;
    let mut sorted: Vec<P3> = Vec::new();
    for v in faces {
        if v.len() < 3 {
            continue;
        }
        if v.len() == 3 {
            let (a, b, c) = (sub(&v[0], &r), sub(&v[1], &r), sub(&v[2], &r));
            v6 += dot(&a, &cross(&b, &c));
            continue;
        }
        let g = sub(&canonical_apex(v, &mut sorted), &r);
        for i in 0..v.len() {
            let (a, b) = (sub(&v[i], &r), sub(&v[(i + 1) % v.len()], &r));
            v6 += dot(&g, &cross(&a, &b));
        }
    }
    v6 / 6.0
}

/// The apex [`tiling_volume_of`] fans a face from: the mean of its vertices, added in the
/// order of their bits (`-0.0` as `0.0`), so any listing of the same cycle (any start,
/// either direction) gives the same bits. `buf` is scratch space.
fn canonical_apex(v: &[P3], buf: &mut Vec<P3>) -> P3 {
    buf.clear();
    buf.extend_from_slice(v);
    buf.sort_unstable_by_key(key);
    let mut g = [0.0; 3];
    for p in buf.iter() {
        g = add(&g, p);
    }
    scale(&g, 1.0 / buf.len() as f64)
}

/// Distinct vertices (exact coordinates) of a boundary, in order of first appearance:
/// [`ConvexPolyhedron::vertices`] of these faces.
pub fn vertices_of(faces: &[ConvexPolygon]) -> Vec<P3> {
    let mut out = vec![];
    let occurrences: usize = faces.iter().map(|f| f.verts.len()).sum();
    if occurrences <= SMALL_OCCURRENCES {
        // Most cells are tetrahedra or a few cuts of one: a scan of the few distinct
        // vertices is far cheaper than hashing every occurrence (same first-seen order).
        let mut keys: Vec<Key> = Vec::with_capacity(occurrences);
        for f in faces {
            for v in &f.verts {
                let k = key(v);
                if !keys.contains(&k) {
                    keys.push(k);
                    out.push(*v);
                }
            }
        }
        return out;
    }
    let mut seen = HashSet::new();
    for f in faces {
        for v in &f.verts {
            if seen.insert(key(v)) {
                out.push(*v);
            }
        }
    }
    out
}

/// [`ConvexPolyhedron::contains`] of these faces.
pub fn contains_of(faces: &[ConvexPolygon], p: &P3, tol: &Tolerances) -> bool {
    faces.iter().filter_map(|f| FacePlane::new(f, tol)).all(|fp| {
        let (d, slack) = fp.test(p, tol);
        d <= slack
    })
}

impl ConvexPolyhedron {
    /// From faces and tags (not checked; see [`check`](Self::check)).
    pub fn from_faces(faces: Vec<ConvexPolygon>, tags: Vec<u32>) -> Self {
        assert_eq!(faces.len(), tags.len(), "one tag per face");
        ConvexPolyhedron { faces, tags }
    }

    /// Tetrahedron `abcd`. Expects `orient3d(a, b, c, d) > 0`; a negatively oriented
    /// input is fixed by swapping `a` and `b`. Face `k` (tag `k`) is the one opposite
    /// the `k`-th input vertex (`a, b, c, d`, after the swap if any).
    pub fn tetrahedron(a: &P3, b: &P3, c: &P3, d: &P3) -> Self {
        let (a, b) = if orient3d(a, b, c, d) < 0 { (b, a) } else { (a, b) };
        let f = |p: &P3, q: &P3, r: &P3| ConvexPolygon::new(vec![*p, *q, *r]);
        ConvexPolyhedron {
            faces: vec![f(b, c, d), f(a, d, c), f(a, b, d), f(a, c, b)],
            tags: vec![0, 1, 2, 3],
        }
    }

    /// Axis-aligned box. Faces/tags in the order −x, +x, −y, +y, −z, +z (tags 0..6).
    pub fn cuboid(lo: &P3, hi: &P3) -> Self {
        let p = |x: usize, y: usize, z: usize| -> P3 { [[lo[0], hi[0]][x], [lo[1], hi[1]][y], [lo[2], hi[2]][z]] };
        let q = |v: [P3; 4]| ConvexPolygon::new(v.to_vec());
        ConvexPolyhedron {
            faces: vec![
                q([p(0, 0, 0), p(0, 0, 1), p(0, 1, 1), p(0, 1, 0)]),
                q([p(1, 0, 0), p(1, 1, 0), p(1, 1, 1), p(1, 0, 1)]),
                q([p(0, 0, 0), p(1, 0, 0), p(1, 0, 1), p(0, 0, 1)]),
                q([p(0, 1, 0), p(0, 1, 1), p(1, 1, 1), p(1, 1, 0)]),
                q([p(0, 0, 0), p(0, 1, 0), p(1, 1, 0), p(1, 0, 0)]),
                q([p(0, 0, 1), p(1, 0, 1), p(1, 1, 1), p(0, 1, 1)]),
            ],
            tags: (0..6).collect(),
        }
    }

    /// `(volume, centroid)`: see [`moments_of`].
    fn moments(&self) -> (f64, P3) {
        moments_of(self.faces.iter().map(|f| &f.verts[..]))
    }

    /// Volume (positive for outward-oriented faces).
    pub fn volume(&self) -> f64 {
        self.moments().0
    }

    /// Volume for sums over a subdivision: [`tiling_volume_of`] (non-planar faces fanned
    /// from a canonical apex, so neighbours agree on the volume under a shared face). The
    /// same as [`volume`](Self::volume) in exact arithmetic when every face is planar.
    pub fn tiling_volume(&self) -> f64 {
        tiling_volume_of(self.faces.iter().map(|f| &f.verts[..]))
    }

    /// Volume centroid.
    pub fn centroid(&self) -> P3 {
        self.moments().1
    }

    /// Total area of the boundary faces.
    pub fn surface_area(&self) -> f64 {
        self.faces.iter().map(|f| f.area()).sum()
    }

    /// Distinct vertices (exact coordinates), in order of first appearance.
    pub fn vertices(&self) -> Vec<P3> {
        vertices_of(&self.faces)
    }

    /// Axis-aligned bounding box `(lo, hi)`.
    pub fn aabb(&self) -> (P3, P3) {
        crate::base::vec::bounds(self.faces.iter().flat_map(|f| f.verts.iter()))
    }

    /// Outward face planes (unit normals), one per face — coplanar patches give
    /// (nearly) equal planes. Inside is where every `signed_distance <= 0`.
    pub fn planes(&self) -> Vec<Plane> {
        self.faces.iter().map(|f| f.plane()).collect()
    }

    /// True when `p` is inside or within tolerance of every face plane. The tolerance is
    /// `tol.plane_abs()` plus the face plane's own rounding uncertainty (see
    /// [`check`](Self::check)); faces with area below `tol.area_abs()` are ignored.
    pub fn contains(&self, p: &P3, tol: &Tolerances) -> bool {
        contains_of(&self.faces, p, tol)
    }

    /// Classify the vertices against `plane` (tolerance `tol.plane_abs()`):
    /// [`Classification::Straddles`] iff some vertex is strictly in front and some strictly
    /// behind. (This is the raw test; [`cut`](Self::cut) may still refuse to split.)
    pub fn classify(&self, plane: &Plane, tol: &Tolerances) -> Classification {
        let c = Classifier::new(plane, tol);
        Classification::from_sides(self.vertices().iter().map(|p| c.side_of(c.dist(p))))
    }

    /// The part of `poly` inside this polyhedron (e.g. a model polygon clipped to a cell:
    /// an occluder). `poly` is split by every face plane (faces with area below
    /// `tol.area_abs()` are skipped; coplanar patches repeat a plane harmlessly) and its
    /// back part kept; a polygon lying *on* a face plane (all vertices within
    /// `tol.plane_abs()`) is kept whole by that plane, so polygons on the boundary survive
    /// (clipped to the face region by the other planes). `None` if the result has area
    /// below `tol.area_abs()`. The result keeps `poly`'s orientation.
    pub fn clip_polygon(&self, poly: &ConvexPolygon, tol: &Tolerances) -> Option<ConvexPolygon> {
        use super::polygon::PolygonSplit;
        let mut cur = poly.clone();
        for f in &self.faces {
            if f.area() < tol.area_abs() {
                continue;
            }
            match cur.split_exact(&f.plane(), tol) {
                PolygonSplit::Front => return None,
                PolygonSplit::Back | PolygonSplit::Coplanar => {}
                PolygonSplit::Split(_, b) => cur = b,
            }
        }
        (cur.area() >= tol.area_abs()).then_some(cur)
    }

    /// Split by `plane`; see [`cut`](Self::cut). `None` when not split.
    pub fn split(&self, plane: &Plane, tol: &Tolerances, new_tag: u32) -> Option<PolyhedronSplit> {
        match self.cut(plane, tol, new_tag) {
            Cut::Split(s) => Some(*s),
            _ => None,
        }
    }

    /// Cut by `plane` into front and back pieces, or decide which side the whole lies on.
    ///
    /// Every distinct vertex is classified once (Front/Back/On, tolerance
    /// `tol.plane_abs()`; if that gives no valid pieces, once more with
    /// [`Tolerances::snap_abs`], the weld distance: a vertex that near the plane is then on
    /// it, so no vertex is created within the weld distance of an edge's endpoint, the
    /// sliver edges and faces a later cut cannot classify consistently);
    /// faces become index cycles over that vertex table and both pieces are built from
    /// that one classification. On vertices go to both pieces; each crossed edge gets one
    /// new vertex (canonical interpolation, once per edge), shared by both faces along
    /// that edge, by both pieces and by the cross-section. The cross-section is the cycle
    /// of the back piece's open boundary edges (not an angular sort of points), and the
    /// front piece's open boundary must be its exact reverse; both pieces must pass
    /// [`check`](Self::check). So a valid polyhedron is only ever cut into valid pieces.
    /// Faces keep their tags; the cross-section gets `new_tag`.
    ///
    /// Not split (returns the side holding the polyhedron, or its larger part) when:
    /// - no vertex is strictly on one side (the plane misses or grazes: touches a vertex,
    ///   an edge or a face, within the weld distance);
    /// - the cross-section area is below `tol.area_abs()`;
    /// - a piece's volume is below [`min_volume`]`(tol)`;
    /// - the pieces would not be valid (a face lying on the plane fits neither piece),
    ///   a crossing point rounds onto another vertex, the open boundary is not one simple
    ///   cycle, or a piece fails [`check`](Self::check).
    pub fn cut(&self, plane: &Plane, tol: &Tolerances, new_tag: u32) -> Cut {
        self.cut_with(plane, tol, new_tag, true)
    }

    /// [`cut`](Self::cut) for a split that seals a crack (with
    /// [`Tolerances::sealing`]) and for the validation's crack test, which mirrors it:
    /// without the last fallback ([`cut_settling_runs`](Self::cut_settling_runs)). A
    /// crack's cells reach barely past the plane; settling a run there made a 3e-12 sliver
    /// piece whose section the validation then counted as a crossing (greedy-4 under noise
    /// 1e-5), where leaving the cell unsplit is what the sealing and the validation expect.
    pub fn cut_sealing(&self, plane: &Plane, tol: &Tolerances, new_tag: u32) -> Cut {
        self.cut_with(plane, tol, new_tag, false)
    }

    fn cut_with(&self, plane: &Plane, tol: &Tolerances, new_tag: u32, settle: bool) -> Cut {
        // First with the plane tolerance; when that gives no valid pieces (typically a
        // vertex a hair off the plane makes a sliver edge or face), once more with
        // vertices within the weld distance on the plane.
        // Then with no On band at all (every vertex strictly on the side of the sign of
        // its distance): a face nearly parallel to the plane then cannot have a run of On
        // vertices between its front and back parts, which no assignment makes conforming.
        match self.cut_within(&Classifier::new(plane, tol), plane, tol, new_tag) {
            (c, false) => c,
            (_, true) => match self.cut_within(&Classifier::snapping(plane, tol), plane, tol, new_tag) {
                (c, false) => c,
                (_, true) => match self.cut_within(&Classifier::with_eps(plane, 0.0), plane, tol, new_tag) {
                    (c, false) => c,
                    (c, true) => self
                        .cut_in_gaps(plane, tol, new_tag)
                        .or_else(|| settle.then(|| self.cut_settling_runs(plane, tol, new_tag)).flatten())
                        .unwrap_or(c),
                },
            },
        }
    }

    /// The last fallback of [`cut`](Self::cut): the On band put into a gap of the
    /// vertices' distances instead of at a fixed width. A plane through a vertex and
    /// (nearly) through an edge of one face, with vertices a few nanometres off it, leaves
    /// every fixed band inconsistent: `plane`/`weld` make three vertices of a face On with
    /// vertices on both sides (no convex face does that), 0 puts a vertex 1e-16 off the
    /// plane on one side and its crossings round onto it. Distances within the weld
    /// distance of the plane, sorted, split at their largest gaps (by ratio, up to
    /// three): vertices below the gap are On, above it on their side. The band follows
    /// the data; no constant is added.
    fn cut_in_gaps(&self, plane: &Plane, tol: &Tolerances, new_tag: u32) -> Option<Cut> {
        // Candidate bands: the geometric middle of each gap (half the first distance when
        // the lower end is 0), largest ratio first.
        for eps in self.gap_bands(plane, tol) {
            if let (c, false) = self.cut_within(&Classifier::with_eps(plane, eps), plane, tol, new_tag) {
                return Some(c);
            }
        }
        None
    }

    /// The fallback of [`cut`](Self::cut) after every band failed: a face holding a run of
    /// two or more On vertices between a Front and a Back vertex (a plane through a tiny
    /// edge, far below the weld distance, of a face it crosses: the run's vertices lie on
    /// the plane within rounding) puts the run's edges into both of its parts, so no band
    /// makes the pieces conforming. The plane meets that face along a chord ending at one
    /// vertex of the run; the run's vertices before it go to the side of the vertex before
    /// the run, those after it to the side after, as a neighbour's face is split along a
    /// chord ([`split_face_along`](Self::split_face_along)), so the neighbours, given the
    /// section, split their faces the same way. Each choice of chord end (up to
    /// [`SETTLE_CHOICES`] combinations over the runs found) is tried in order, with each
    /// band; the first whose pieces are valid wins. Only reached where every other
    /// attempt left the cell unsplit, and only for a cell reaching deeper than the
    /// validation's crossing thickness (`max(coplanar, weld)`, the depth below which
    /// [`crate::complex::CellComplex::validate`] does not count a polygon across a cell)
    /// on both sides of the plane: a cell left across the plane by more than that is an
    /// invalid complex (Nexuiz `stormkeep`: a wedge 2.4e-2 behind a wall, below the sliver
    /// width 4.5e-2 the rule once used), while settling a shallower one only makes
    /// slivers. Crack sealing never settles ([`cut_sealing`](Self::cut_sealing)).
    fn cut_settling_runs(&self, plane: &Plane, tol: &Tolerances, new_tag: u32) -> Option<Cut> {
        // The distances do not depend on the band: one vertex table for every band.
        let (faces, pos, dist) = self.vertex_table(&Classifier::new(plane, tol));
        let (mut maxf, mut maxb) = (0.0f64, 0.0f64);
        for &d in &dist {
            maxf = maxf.max(d);
            maxb = maxb.max(-d);
        }
        if maxf.min(maxb) <= tol.coplanar_abs().max(tol.weld_abs()) {
            return None;
        }
        for eps in [tol.plane_abs(), tol.snap_abs(), 0.0] {
            let cl = Classifier::with_eps(plane, eps);
            let sides: Vec<Side> = dist.iter().map(|&d| cl.side_of(d)).collect();
            // The runs: their vertices in face order, with the sides before and after (a
            // vertex in two faces' runs is settled by the first).
            let mut runs: Vec<(Vec<u32>, Side, Side)> = Vec::new();
            for f in &faces {
                for (a, len, before, after) in crossed_on_runs(f.len(), |k| sides[f[k] as usize]) {
                    let run: Vec<u32> = (0..len).map(|r| f[(a + r) % f.len()]).collect();
                    if !runs.iter().any(|(r, _, _)| r.iter().any(|v| run.contains(v))) {
                        runs.push((run, before, after));
                    }
                }
            }
            let combos: usize = runs.iter().map(|(r, _, _)| r.len()).product();
            if runs.is_empty() || combos > SETTLE_CHOICES {
                continue;
            }
            for mut c in 0..combos {
                let mut s2 = sides.clone();
                for (run, before, after) in &runs {
                    let h = c % run.len();
                    c /= run.len();
                    for (r, &v) in run.iter().enumerate() {
                        s2[v as usize] = settled(r, h, *before, *after);
                    }
                }
                if let (cut, false) = self.cut_with_sides(&faces, pos.clone(), &dist, s2, &cl, plane, tol, new_tag) {
                    return Some(cut);
                }
            }
        }
        None
    }

    /// The other valid splits [`cut`](Self::cut) could have chosen: the cuts with each
    /// On band it tries (plane tolerance, weld distance, none, the largest gaps of the
    /// vertices' distances), in that order, that split the polyhedron into valid pieces,
    /// except the one with On distance `chosen` (the one `cut` returned), one per distinct
    /// band.
    ///
    /// `cut` picks the first band whose pieces are valid *for this cell alone*; a split
    /// must also leave every neighbour whose shared face it divides valid (the neighbour
    /// subdivides that face with the same band, see
    /// [`split_face_within`](Self::split_face_within)). When it does not, another band
    /// often does: a vertex of the shared face that is On with one band and strictly on a
    /// side with another decides whether the face is split through that vertex or near
    /// it. The caller tries these in order (deterministic: the bands follow the data).
    pub fn cut_alternatives(&self, plane: &Plane, tol: &Tolerances, new_tag: u32, chosen: f64) -> Vec<PolyhedronSplit> {
        let mut eps: Vec<f64> = vec![tol.plane_abs(), tol.snap_abs(), 0.0];
        eps.extend(self.gap_bands(plane, tol));
        let mut out: Vec<PolyhedronSplit> = Vec::new();
        let mut seen: Vec<f64> = vec![chosen];
        for e in eps {
            if seen.iter().any(|x| x.to_bits() == e.to_bits()) {
                continue;
            }
            seen.push(e);
            if let (Cut::Split(s), false) = self.cut_within(&Classifier::with_eps(plane, e), plane, tol, new_tag) {
                out.push(*s);
            }
        }
        out
    }

    /// The candidate On bands of [`cut_in_gaps`](Self::cut_in_gaps), best first.
    fn gap_bands(&self, plane: &Plane, tol: &Tolerances) -> Vec<f64> {
        let cl = Classifier::new(plane, tol);
        let band = tol.snap_abs();
        let mut ds: Vec<f64> = self
            .faces
            .iter()
            .flat_map(|f| f.verts.iter().map(|v| cl.dist(v).abs()))
            .filter(|d| *d <= band)
            .collect();
        ds.sort_by(f64::total_cmp);
        ds.dedup();
        let mut gaps: Vec<(f64, f64)> = ds
            .windows(2)
            .map(|w| {
                if w[0] > 0.0 {
                    (w[1] / w[0], (w[0] * w[1]).sqrt())
                } else {
                    (f64::INFINITY, w[1] * 0.5)
                }
            })
            .filter(|(r, e)| *r > 2.0 && *e > 0.0)
            .collect();
        gaps.sort_by(|a, b| b.0.total_cmp(&a.0));
        gaps.iter().take(3).map(|g| g.1).collect()
    }

    /// [`cut`](Self::cut) with one On distance and no fallback: a cell cut together with
    /// a neighbour must classify their shared vertices as the neighbour's cut did (its
    /// [`PolyhedronSplit::on_dist`]), so that the crossings on shared edges are the same
    /// bits (`crossing` is canonical per edge).
    pub fn cut_with_eps(&self, plane: &Plane, tol: &Tolerances, new_tag: u32, on_dist: f64) -> Cut {
        self.cut_within(&Classifier::with_eps(plane, on_dist), plane, tol, new_tag)
            .0
    }

    /// [`cut`](Self::cut) with one classifier; the flag is true when the cut was refused
    /// only because its pieces would not have been valid.
    /// The vertex table of a cut: each distinct vertex (exact bits) once, with its one
    /// distance; faces as index cycles, so every decision of the cut is made once per
    /// vertex or per edge and both faces along an edge, and both pieces, see the same
    /// answer. Returns (faces, positions, distances).
    fn vertex_table(&self, cl: &Classifier) -> VertexTable {
        let mut index: HashMap<Key, u32> = HashMap::new();
        let mut pos: Vec<P3> = Vec::new();
        let mut dist: Vec<f64> = Vec::new();
        let faces: Vec<Vec<u32>> = self
            .faces
            .iter()
            .map(|f| {
                f.verts
                    .iter()
                    .map(|v| {
                        *index.entry(key(v)).or_insert_with(|| {
                            pos.push(*v);
                            dist.push(cl.dist(v));
                            (pos.len() - 1) as u32
                        })
                    })
                    .collect()
            })
            .collect();
        (faces, pos, dist)
    }

    fn cut_within(&self, cl: &Classifier, plane: &Plane, tol: &Tolerances, new_tag: u32) -> (Cut, bool) {
        let (faces, pos, dist) = self.vertex_table(cl);
        let sides: Vec<Side> = dist.iter().map(|&d| cl.side_of(d)).collect();
        self.cut_with_sides(&faces, pos, &dist, sides, cl, plane, tol, new_tag)
    }

    /// [`cut_within`](Self::cut_within) on a vertex table with the vertices' sides given.
    #[allow(clippy::too_many_arguments)]
    fn cut_with_sides(
        &self,
        faces: &[Vec<u32>],
        pos: Vec<P3>,
        dist: &[f64],
        sides: Vec<Side>,
        cl: &Classifier,
        plane: &Plane,
        tol: &Tolerances,
        new_tag: u32,
    ) -> (Cut, bool) {
        let eps = cl.eps;
        let (mut maxf, mut maxb) = (0.0f64, 0.0f64);
        for &d in dist {
            maxf = maxf.max(d);
            maxb = maxb.max(-d);
        }
        let larger = if maxf > maxb { Cut::Front } else { Cut::Back };
        if !(maxb > eps) {
            return (if maxf > eps { Cut::Front } else { larger }, false);
        }
        if !(maxf > eps) {
            return (Cut::Back, false);
        }
        let thick = tol.weld_abs().max(eps);
        if maxf < thick || maxb < thick {
            return (larger, false);
        }
        // Faces lying on the plane (every vertex On) while the polyhedron straddles it go
        // whole to the piece their body lies in (by the face's outward normal); a sliver
        // face's normal may say nothing, so the opposite assignment is tried as well.
        let has_on_face = faces.iter().any(|f| f.iter().all(|&i| sides[i as usize] == Side::On));
        let attempt = self
            .cut_topological(faces, pos.clone(), dist, &sides, cl, plane, tol, new_tag, false)
            .or_else(|| {
                has_on_face
                    .then(|| self.cut_topological(faces, pos, dist, &sides, cl, plane, tol, new_tag, true))
                    .flatten()
            });
        match attempt {
            Some(s) => {
                let (vf, vb) = (s.front.volume(), s.back.volume());
                if !(vf.min(vb) >= min_volume(tol)) {
                    return (if vf >= vb { Cut::Front } else { Cut::Back }, false);
                }
                (Cut::Split(Box::new(s)), false)
            }
            None => (larger, true),
        }
    }

    /// The pieces of a cut on the vertex table of [`cut`](Self::cut), or `None` when they
    /// would not be valid polyhedra (the caller then does not split). The cross-section is
    /// not found geometrically (ordering points by angle goes wrong for nearly collinear or
    /// nearly coincident points): it is the cycle of the back piece's open boundary edges,
    /// reversed, which is conforming by construction; the front piece's open boundary must
    /// be exactly its reverse. Both pieces must then pass [`check`](Self::check), so a cut
    /// never turns a valid polyhedron into an invalid one.
    ///
    /// A face with every vertex On lies on the plane (a face nearly coplanar with it, or a
    /// sliver face): it goes whole to the piece its body lies in, the back piece when its
    /// outward normal points to the plane's front (`flip_on` reverses this choice), and
    /// the section is the rest of the cross-section (so it borders that face).
    #[allow(clippy::too_many_arguments)]
    fn cut_topological(
        &self,
        faces: &[Vec<u32>],
        mut pos: Vec<P3>,
        dist: &[f64],
        sides: &[Side],
        cl: &Classifier,
        plane: &Plane,
        tol: &Tolerances,
        new_tag: u32,
        flip_on: bool,
    ) -> Option<PolyhedronSplit> {
        let mut bits: HashMap<Key, u32> = pos.iter().enumerate().map(|(i, p)| (key(p), i as u32)).collect();
        let mut xs: HashMap<(u32, u32), u32> = HashMap::new();
        let nf = faces.len();
        let (mut ff, mut ft, mut fo) = (
            Vec::with_capacity(nf + 1),
            Vec::with_capacity(nf + 1),
            Vec::with_capacity(nf + 1),
        );
        let (mut bf, mut bt, mut bo) = (
            Vec::with_capacity(nf + 1),
            Vec::with_capacity(nf + 1),
            Vec::with_capacity(nf + 1),
        );
        for (fi, v) in faces.iter().enumerate() {
            let fs: Vec<Side> = v.iter().map(|&i| sides[i as usize]).collect();
            let tag = self.tags[fi];
            let class = match Classification::from_sides(fs.iter().copied()) {
                Classification::Coplanar if (dot(&self.faces[fi].area_vector(), &plane.n) > 0.0) != flip_on => {
                    Classification::Back
                }
                c => c,
            };
            match class {
                Classification::Front | Classification::Coplanar => {
                    ff.push(v.clone());
                    ft.push(tag);
                    fo.push(Some(fi));
                }
                Classification::Back => {
                    bf.push(v.clone());
                    bt.push(tag);
                    bo.push(Some(fi));
                }
                Classification::Straddles => {
                    let mut fresh_collision = false;
                    let (f, b) = walk_split(v, &fs, |i, j| {
                        let (a, c) = (v[i], v[j]);
                        let k = if a < c { (a, c) } else { (c, a) };
                        *xs.entry(k).or_insert_with(|| {
                            let (a, c) = (a as usize, c as usize);
                            let x = crossing(&pos[a], dist[a], &pos[c], dist[c]);
                            let id = pos.len() as u32;
                            // A crossing point equal in bits to another vertex would merge
                            // two vertices the topology keeps apart: refuse.
                            if bits.insert(key(&x), id).is_some() {
                                fresh_collision = true;
                            }
                            pos.push(x);
                            id
                        })
                    });
                    if fresh_collision {
                        return None;
                    }
                    ff.push(f);
                    ft.push(tag);
                    fo.push(Some(fi));
                    bf.push(b);
                    bt.push(tag);
                    bo.push(Some(fi));
                }
            }
        }
        let section = section_cycle(&bf)?;
        // The front piece's open boundary is the section's cycle (its reverse is the back's).
        let mut front_open = open_edges(&ff)?;
        let mut expect: Vec<(u32, u32)> = (0..section.len())
            .map(|k| (section[k], section[(k + 1) % section.len()]))
            .collect();
        front_open.sort_unstable();
        expect.sort_unstable();
        if front_open != expect {
            return None;
        }
        let to_poly = |ix: &[u32]| ConvexPolygon::new(ix.iter().map(|&i| pos[i as usize]).collect());
        let section = to_poly(&section);
        // Oriented along the plane normal, and not a sliver.
        if !(dot(&section.area_vector(), &plane.n) > 0.0) || !(section.area() >= tol.area_abs()) {
            return None;
        }
        let mut fpoly: Vec<ConvexPolygon> = ff.iter().map(|f| to_poly(f)).collect();
        let mut bpoly: Vec<ConvexPolygon> = bf.iter().map(|f| to_poly(f)).collect();
        fpoly.push(section.reversed());
        ft.push(new_tag);
        fo.push(None);
        bpoly.push(section.clone());
        bt.push(new_tag);
        bo.push(None);
        let front = ConvexPolyhedron { faces: fpoly, tags: ft };
        let back = ConvexPolyhedron { faces: bpoly, tags: bt };
        if front.check(tol).is_err() || back.check(tol).is_err() {
            return None;
        }
        Some(PolyhedronSplit {
            front,
            back,
            section,
            front_origin: fo,
            back_origin: bo,
            on_dist: cl.eps,
        })
    }

    /// Subdivide face `i` into two coplanar patches along `plane` (typically: the cell
    /// across face `i` was split by `plane`). Face `i` becomes the front part with
    /// `front_tag`; the back part is appended with `back_tag`; its index is returned.
    /// The new vertices are also inserted into the neighbouring faces' edges (as
    /// collinear T-vertices), so the boundary stays conforming. Returns `None` (and
    /// changes nothing) unless the face straddles the plane (tolerance
    /// `tol.plane_abs()`); no area test is applied, so either patch may be small.
    pub fn split_face(
        &mut self,
        i: usize,
        plane: &Plane,
        tol: &Tolerances,
        front_tag: u32,
        back_tag: u32,
    ) -> Option<usize> {
        self.split_face_within(i, plane, tol.plane_abs(), front_tag, back_tag)
    }

    /// [`split_face`](Self::split_face) with vertices within `on_dist` of the plane on it
    /// (the [`PolyhedronSplit::on_dist`] of the cut being propagated).
    pub fn split_face_within(
        &mut self,
        i: usize,
        plane: &Plane,
        on_dist: f64,
        front_tag: u32,
        back_tag: u32,
    ) -> Option<usize> {
        self.split_face_along(i, plane, on_dist, &[], front_tag, back_tag)
    }

    /// [`split_face_within`](Self::split_face_within) for the face a cut shares with its
    /// neighbour, whose cross-section has the vertices `chord` (the chord of the face
    /// ends at some of them). The face may hold, beside the cut cell's vertices, collinear
    /// T-vertices of its own within `on_dist` of the plane next to a chord end (a vertex
    /// nanometres from the end on an edge the plane meets at a shallow angle): a run of
    /// two or more On vertices between a front and a back vertex, which would put the
    /// run's edges into both parts (a directed edge used twice). In such a run holding
    /// exactly one vertex of `chord`, that vertex is the chord's end and the others go to
    /// the side they lie towards, as on the cut cell's edge they lie on (issue 16,
    /// greedy-2 under noise 1e-5).
    pub fn split_face_along(
        &mut self,
        i: usize,
        plane: &Plane,
        on_dist: f64,
        chord: &[P3],
        front_tag: u32,
        back_tag: u32,
    ) -> Option<usize> {
        let cl = Classifier::with_eps(plane, on_dist);
        let v = self.faces[i].verts.clone();
        let ds: Vec<f64> = v.iter().map(|p| cl.dist(p)).collect();
        let mut sides: Vec<Side> = ds.iter().map(|&d| cl.side_of(d)).collect();
        if Classification::from_sides(sides.iter().copied()) != Classification::Straddles {
            return None;
        }
        if !chord.is_empty() {
            settle_on_runs(&v, &mut sides, chord);
        }
        // Keyed by the edge as the neighbouring face sees it (reversed).
        let mut ins: HashMap<(Key, Key), P3> = HashMap::new();
        let (f, b) = walk_split(&v, &sides, |a, c| {
            let x = crossing(&v[a], ds[a], &v[c], ds[c]);
            ins.insert((key(&v[c]), key(&v[a])), x);
            x
        });
        self.faces[i] = ConvexPolygon::new(f);
        self.tags[i] = front_tag;
        for (g, face) in self.faces.iter_mut().enumerate() {
            if g == i {
                continue;
            }
            let n = face.verts.len();
            let hit = (0..n).any(|k| ins.contains_key(&(key(&face.verts[k]), key(&face.verts[(k + 1) % n]))));
            if !hit {
                continue;
            }
            let mut nv = Vec::with_capacity(n + 2);
            for k in 0..n {
                let (p, q) = (&face.verts[k], &face.verts[(k + 1) % n]);
                nv.push(*p);
                if let Some(x) = ins.get(&(key(p), key(q))) {
                    nv.push(*x);
                }
            }
            face.verts = nv.into();
        }
        self.faces.push(ConvexPolygon::new(b));
        self.tags.push(back_tag);
        Some(self.faces.len() - 1)
    }

    /// Check the invariants; `Err` describes the first violation found:
    /// one tag per face; ≥ 4 faces of ≥ 3 vertices without repeated consecutive vertices;
    /// closed and conforming (every directed edge used once, its reverse once, exact
    /// coordinates); positive volume; convex: every vertex lies behind the plane of every
    /// face whose area is at least `tol.area_abs()`, within `tol.plane_abs()` plus that
    /// plane's rounding uncertainty. (A face's plane is only as good as its vertices:
    /// with coordinate rounding unit `u = ε·max|coord|` and face width
    /// `w = 2·area/perimeter`, its normal is uncertain by ~`u/w`, so the allowance at a
    /// point `p` is `8u(1 + |p − centroid|/w)` — e.g. ~1e-7 for a 1 cm wide face of a
    /// 1 km model at 1e6 offset.)
    pub fn check(&self, tol: &Tolerances) -> Result<(), String> {
        check_faces(&self.faces, self.tags.len(), tol)
    }
}

/// A cut's vertex table: faces as index cycles, vertex positions, signed distances.
type VertexTable = (Vec<Vec<u32>>, Vec<P3>, Vec<f64>);

/// Most combinations of chord ends [`ConvexPolyhedron::cut_settling_runs`] tries.
const SETTLE_CHOICES: usize = 16;

/// [`ConvexPolyhedron::check`] of a boundary given as faces (`ntags` tags).
pub fn check_faces(faces: &[ConvexPolygon], ntags: usize, tol: &Tolerances) -> Result<(), String> {
    if faces.len() != ntags {
        return Err(format!("{} faces but {} tags", faces.len(), ntags));
    }

    if faces.len() < 4 {
        return Err(format!("only {} faces", faces.len()));
    }
    let occurrences: usize = faces.iter().map(|f| f.verts.len()).sum();
    // Arrays sized to the cell (tetrahedra: 12 occurrences), so zeroing them is cheap.
    if occurrences <= 16 {
        return check_small::<16>(faces, tol);
    }
    if occurrences <= SMALL_OCCURRENCES {
        return check_small::<SMALL_OCCURRENCES>(faces, tol);
    }
    check_general(faces, tol)
}

/// Every face's vertex loop is convex up to the sliver width
/// ([`ConvexPolygon::convexity_defect`] at most its perimeter times
/// [`Tolerances::sliver_width`], plus the area tolerance). The plane tests alone do not
/// see a face whose loop crosses itself in its plane (a "bowtie"): on a cell thinner
/// than the weld distance every vertex lies within tolerance of every face plane, yet
/// its patch's open pieces, cut from a loop that is not convex, can exceed the patch
/// (fuzz find `d677291f`). Triangles are always convex and skipped.
fn check_convex_loops(faces: &[ConvexPolygon], tol: &Tolerances) -> Result<(), String> {
    for (fi, f) in faces.iter().enumerate() {
        let n = f.verts.len();
        if n <= 3 {
            continue;
        }
        let d = f.convexity_defect();
        if d <= 0.0 {
            continue;
        }
        let per: f64 = (0..n).map(|k| norm(&sub(&f.verts[(k + 1) % n], &f.verts[k]))).sum();
        let slack = per * tol.sliver_width() + 4.0 * tol.area_abs();
        if d > slack {
            return Err(format!(
                "face {fi} is not a convex loop: its vertices' hull exceeds its area by {d:e} (> {slack:e})"
            ));
        }
    }
    Ok(())
}

/// [`check_faces`] after the face count tests, for any size.
fn check_general(faces: &[ConvexPolygon], tol: &Tolerances) -> Result<(), String> {
    // Directed edges, sorted: a count is the length of an equal run (no hashing).
    let mut edges: Vec<(Key, Key)> = Vec::with_capacity(faces.iter().map(|f| f.verts.len()).sum());
    for (fi, f) in faces.iter().enumerate() {
        let n = f.verts.len();
        if n < 3 {
            return Err(format!("face {fi} has {n} vertices"));
        }
        for k in 0..n {
            let (a, b) = (key(&f.verts[k]), key(&f.verts[(k + 1) % n]));
            if a == b {
                return Err(format!("face {fi} repeats vertex {:?}", f.verts[k]));
            }
            edges.push((a, b));
        }
    }
    edges.sort_unstable();
    let count = |e: (Key, Key)| {
        let lo = edges.partition_point(|x| *x < e);
        edges[lo..].iter().take_while(|x| **x == e).count()
    };
    // In face order (not the map's), so the first violation reported is deterministic.
    for f in faces {
        let n = f.verts.len();
        for k in 0..n {
            let (a, b) = (key(&f.verts[k]), key(&f.verts[(k + 1) % n]));
            let c = count((a, b));
            if c != 1 {
                return Err(format!("directed edge {a:?}->{b:?} used {c} times"));
            }
            if count((b, a)) != 1 {
                return Err(format!("edge {a:?}->{b:?} has no reverse (open or T-junction)"));
            }
        }
    }
    let vol = moments_of(faces.iter().map(|f| &f.verts[..])).0;
    if !(vol > 0.0) {
        return Err(format!("volume {vol}"));
    }
    check_convex_loops(faces, tol)?;
    let verts = vertices_of(faces);
    for (fi, f) in faces.iter().enumerate() {
        let Some(fp) = FacePlane::new(f, tol) else { continue };
        for p in &verts {
            if let Some((d, slack)) = fp.violation(p, tol) {
                return Err(format!("vertex {p:?} is {d:e} (> {slack:e}) in front of face {fi}"));
            }
        }
    }
    Ok(())
}

/// [`check_faces`] for cells of at most [`SMALL_OCCURRENCES`] vertex occurrences
/// (tetrahedra and the few cuts of one: nearly every cell), the same tests in the
/// same order with the same messages, cheaper: vertices are numbered once (exact bit
/// keys, as `check` compares them), edges are pairs of small numbers, and a triangle
/// face all of whose vertices lie clearly behind its plane skips the rounding-aware
/// test. That skip is exact: the face's [`FacePlane`] has the Newell normal of the
/// triangle (the very cross product `n` below, normalized) through its centroid, so
/// the distance it computes for a vertex `p` differs from `n·(p − a) / |n|` by
/// rounding only — at most `16 ε (D + M)` with `D` the cell's diagonal and `M` its
/// largest coordinate (normalisation, the centroid's offset from the plane through
/// `a`, both dot products) — so a vertex within `snap_abs − 16 ε (D + M)` by the
/// cheap distance is within `snap_abs`, the smallest allowance `test` grants.
fn check_small<const N: usize>(faces: &[ConvexPolygon], tol: &Tolerances) -> Result<(), String> {
    // On the stack: no allocation per cell.
    let mut keys = [[0u64; 3]; N];
    let mut verts = [[0.0f64; 3]; N];
    let mut nv = 0;
    // Vertex number of every occurrence, face after face.
    let mut idx = [0u8; N];
    let mut ni = 0;
    for (fi, f) in faces.iter().enumerate() {
        let n = f.verts.len();
        if n < 3 {
            return Err(format!("face {fi} has {n} vertices"));
        }
        for k in 0..n {
            if key(&f.verts[k]) == key(&f.verts[(k + 1) % n]) {
                return Err(format!("face {fi} repeats vertex {:?}", f.verts[k]));
            }
        }
        for v in &f.verts {
            let kv = key(v);
            let i = match keys[..nv].iter().position(|x| *x == kv) {
                Some(i) => i,
                None => {
                    keys[nv] = kv;
                    verts[nv] = *v;
                    nv += 1;
                    nv - 1
                }
            };
            idx[ni] = i as u8;
            ni += 1;
        }
    }
    let (keys, verts, idx) = (&keys[..nv], &verts[..nv], &idx[..ni]);
    // Directed edges as `from · 128 + to` (at most 96 vertices), sorted.
    let code = |a: u8, b: u8| (a as u16) << 7 | b as u16;
    let mut edge_buf = [0u16; N];
    let mut at = 0;
    for f in faces {
        let n = f.verts.len();
        for k in 0..n {
            edge_buf[at + k] = code(idx[at + k], idx[at + (k + 1) % n]);
        }
        at += n;
    }
    let edges = &mut edge_buf[..ni];
    edges.sort_unstable();
    let edges = &*edges;
    let count = |e: u16| {
        let lo = edges.partition_point(|x| *x < e);
        edges[lo..].iter().take_while(|x| **x == e).count()
    };
    at = 0;
    for f in faces {
        let n = f.verts.len();
        for k in 0..n {
            let (a, b) = (idx[at + k], idx[at + (k + 1) % n]);
            let c = count(code(a, b));
            let (ka, kb) = (keys[a as usize], keys[b as usize]);
            if c != 1 {
                return Err(format!("directed edge {ka:?}->{kb:?} used {c} times"));
            }
            if count(code(b, a)) != 1 {
                return Err(format!("edge {ka:?}->{kb:?} has no reverse (open or T-junction)"));
            }
        }
        at += n;
    }
    let vol = moments_of(faces.iter().map(|f| &f.verts[..])).0;
    if !(vol > 0.0) {
        return Err(format!("volume {vol}"));
    }
    check_convex_loops(faces, tol)?;
    let (mut lo, mut hi, mut m) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3], 0.0f64);
    for v in verts {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
            m = m.max(v[k].abs());
        }
    }
    let diag = norm(&sub(&hi, &lo));
    let clear = tol.snap_abs() - 16.0 * f64::EPSILON * (diag + m);
    for (fi, f) in faces.iter().enumerate() {
        if f.verts.len() == 3 && clear > 0.0 {
            let a = &f.verts[0];
            let n = cross(&sub(&f.verts[1], a), &sub(&f.verts[2], a));
            let ln = norm(&n);
            if ln > 0.0 && ln.is_finite() && verts.iter().all(|p| dot(&n, &sub(p, a)) <= clear * ln) {
                continue;
            }
        }
        let Some(fp) = FacePlane::new(f, tol) else { continue };
        for p in verts {
            if let Some((d, slack)) = fp.violation(p, tol) {
                return Err(format!("vertex {p:?} is {d:e} (> {slack:e}) in front of face {fi}"));
            }
        }
    }
    Ok(())
}

/// In each maximal run of two or more On vertices (cyclic) between a Front and a Back
/// vertex that holds exactly one vertex of `chord` (bit for bit), the vertices before
/// that one take the side of the vertex before the run, those after it the side of the
/// vertex after the run (see [`ConvexPolyhedron::split_face_along`]).
fn settle_on_runs(v: &[P3], sides: &mut [Side], chord: &[P3]) {
    let n = v.len();
    let is_chord = |p: &P3| chord.iter().any(|c| key(c) == key(p));
    // The runs are bounded by vertices that are not On, which settling leaves as they are,
    // so finding them all first finds the same runs.
    for (a, len, before, after) in crossed_on_runs(n, |k| sides[k]) {
        let hits: Vec<usize> = (0..len).filter(|&r| is_chord(&v[(a + r) % n])).collect();
        if let [h] = hits[..] {
            for r in 0..len {
                sides[(a + r) % n] = settled(r, h, before, after);
            }
        }
    }
}

/// The maximal runs of two or more On vertices in a cycle of `n` vertices (`side(k)` of
/// vertex `k`) whose neighbours lie on opposite sides: (first vertex, length, side before,
/// side after). Empty when every vertex is On.
fn crossed_on_runs(n: usize, side: impl Fn(usize) -> Side) -> Vec<(usize, usize, Side, Side)> {
    let mut runs = Vec::new();
    let Some(start) = (0..n).find(|&k| side(k) != Side::On) else {
        return runs;
    };
    let mut k = 0;
    while k < n {
        let a = (start + k) % n;
        if side(a) != Side::On {
            k += 1;
            continue;
        }
        let mut len = 0;
        while side((a + len) % n) == Side::On {
            len += 1;
        }
        let (before, after) = (side((a + n - 1) % n), side((a + len) % n));
        if len >= 2 && before != after {
            runs.push((a, len, before, after));
        }
        k += len;
    }
    runs
}

/// The side of the `r`-th vertex of a run whose chord ends at its `h`-th: the side before
/// the run for those before `h`, after it for those after, On for `h` itself.
fn settled(r: usize, h: usize, before: Side, after: Side) -> Side {
    match r.cmp(&h) {
        std::cmp::Ordering::Less => before,
        std::cmp::Ordering::Greater => after,
        std::cmp::Ordering::Equal => Side::On,
    }
}

/// Directed edges of index faces that have no reverse, or `None` when some directed edge
/// is used twice or a face repeats a vertex consecutively (not a manifold surface).
fn open_edges(faces: &[Vec<u32>]) -> Option<Vec<(u32, u32)>> {
    let mut edges: HashSet<(u32, u32)> = HashSet::new();
    let mut order: Vec<(u32, u32)> = Vec::new();
    for f in faces {
        if f.len() < 3 {
            return None;
        }
        for k in 0..f.len() {
            let e = (f[k], f[(k + 1) % f.len()]);
            if e.0 == e.1 || !edges.insert(e) {
                return None;
            }
            order.push(e);
        }
    }
    Some(order.into_iter().filter(|&(a, b)| !edges.contains(&(b, a))).collect())
}

/// The cross-section of a cut as one index cycle: the reversed open boundary of the back
/// piece's faces, which must form a single simple cycle of at least 3 vertices. Starts at
/// the smallest index, so the result does not depend on face order.
fn section_cycle(back: &[Vec<u32>]) -> Option<Vec<u32>> {
    let open = open_edges(back)?;
    if open.len() < 3 {
        return None;
    }
    // Section edges run b -> a for each open edge a -> b.
    let mut next: HashMap<u32, u32> = HashMap::with_capacity(open.len());
    for &(a, b) in &open {
        if next.insert(b, a).is_some() {
            return None; // a vertex where the boundary touches itself
        }
    }
    let start = *next.keys().min()?;
    let mut cycle = vec![start];
    let mut cur = next[&start];
    while cur != start {
        if cycle.len() >= open.len() {
            return None;
        }
        cycle.push(cur);
        cur = *next.get(&cur)?;
    }
    (cycle.len() == open.len()).then_some(cycle)
}

#[cfg(test)]
mod tests {
    use super::super::testutil::{Frame, Rng, frames};
    use super::super::vec::norm;
    use super::*;

    /// A cell from its vertices (exact bits) and its faces as index cycles, each face
    /// tagged with its index; checked valid at `tol`.
    fn cell_of_table(v: &[P3], faces: &[&[usize]], tol: &Tolerances) -> ConvexPolyhedron {
        let cell = ConvexPolyhedron {
            faces: faces
                .iter()
                .map(|f| ConvexPolygon::new(f.iter().map(|&i| v[i]).collect()))
                .collect(),
            tags: (0..faces.len() as u32).collect(),
        };
        cell.check(tol).expect("the cell is valid");
        cell
    }

    /// Every On band alone fails to cut `cell` by `plane`, and `cut` (its settling
    /// fallback) splits it into valid pieces of more than one unit each that tile the cell
    /// up to the settled vertices' offsets from the plane (within the weld distance of it)
    /// over the section.
    fn assert_only_settling_cuts(cell: &ConvexPolyhedron, plane: &Plane, tol: &Tolerances) {
        let n = cell.faces.len() as u32;
        for eps in [tol.plane_abs(), tol.snap_abs(), 0.0] {
            assert!(cell.cut_within(&Classifier::with_eps(plane, eps), plane, tol, n).1);
        }
        let Cut::Split(s) = cell.cut(plane, tol, n) else {
            panic!("not split")
        };
        s.front.check(tol).expect("front piece");
        s.back.check(tol).expect("back piece");
        let (vf, vb, v) = (s.front.volume(), s.back.volume(), cell.volume());
        let slack = tol.weld_abs() * s.section.area();
        assert!(
            vf > 1.0 && vb > 1.0 && ((vf + vb) - v).abs() <= slack,
            "{vf} + {vb} vs {v}"
        );
    }

    /// A cell of Nexuiz's `racetrack` (issue 16, session 33) that no On band could cut: the
    /// plane of a terrain triangle passes through a 7e-5 edge (far below the weld distance
    /// 1.8e-3) of a face it crosses, so that face has a run of two On vertices between a
    /// Back and a Front vertex. Left unsplit, the triangle crossed the cell (2.5e3 of its
    /// area) and the complex was invalid at the model's own tolerances. Settling the run
    /// (one vertex the chord's end, the other on its side) splits it into valid pieces.
    #[test]
    fn a_plane_through_a_tiny_edge_of_a_crossed_face_still_cuts() {
        // The cell's 11 vertices (exact bits) and its faces as index cycles.
        let v: [P3; 11] = [
            [-2210.927978515625, 318.7740173339844, 736.4159545898438],
            [-2205.489494809718, 549.5914646357019, 691.3539805898995],
            [-2208.708050870531, 538.2518368688224, 695.3546544952268],
            [-2209.183626035592, 536.453600866162, 695.9679976453749],
            [-2261.46464169336, 337.8286848073214, 763.5644177550556],
            [-2261.4645793423415, 337.82866129809355, 763.5643842598814],
            [-2223.2106015913355, 407.246260821558, 726.8983979464173],
            [-2205.655908417168, 548.9859271900983, 691.5543190228906],
            [-2261.4589153912484, 337.822375320201, 763.5500885597766],
            [-2236.0975836949624, 327.80627519165256, 748.6957760326708],
            [-2233.191521378807, 326.6585668817346, 746.993674645237],
        ];
        let faces: [&[usize]; 8] = [
            &[0, 1, 2, 3, 4, 5],
            &[0, 6, 7, 1],
            &[0, 5, 8, 9],
            &[0, 9, 10],
            &[8, 5, 4, 3],
            &[2, 1, 7],
            &[0, 10, 6],
            &[3, 2, 7, 6, 10, 9, 8],
        ];
        let tol = Tolerances::for_scale(18441.636292985288);
        let cell = cell_of_table(&v, &faces, &tol);
        let plane = Plane {
            n: [0.513686916246755, 0.16195445561825592, 0.8425535629159095],
            d: -463.6280165569997,
        };
        // A crack's cut does not settle (`cut_sealing`): the cell stays whole there.
        assert!(!matches!(
            cell.cut_sealing(&plane, &tol, faces.len() as u32),
            Cut::Split(_)
        ));
        assert_only_settling_cuts(&cell, &plane, &tol);
    }

    /// Nexuiz `stormkeep` (level 0, before the depth rule moved to the validation's
    /// thickness): a flat wedge cell 0.08 units thick whose vertices lie -2.4e-2 to 5.9e-2
    /// from a wall's plane, less than the sliver width (4.5e-2) behind it but more than the
    /// crossing thickness the validation counts (max(coplanar, weld) = 4.5e-3). Every band
    /// fails on its own; the settling fallback must split it, or the wall crosses the cell.
    #[test]
    fn a_thin_wedge_deeper_than_the_crossing_thickness_is_settled() {
        let v: [P3; 10] = [
            [-631.5, 477.0, 909.125],
            [-533.25, 394.75, 768.0],
            [-534.5547477187365, 395.76600473245986, 769.6691506318983],
            [-589.8473586646887, 442.08389063463653, 849.1704662011698],
            [-521.75, 385.0, 981.875],
            [-521.7503219691458, 385.000272973841, 981.8690120738213],
            [-521.7570577966994, 385.0059837841583, 981.743740324426],
            [-521.7579568300862, 385.00668996158646, 981.7431359505464],
            [-521.7583357213086, 385.0069875750377, 981.7428812414762],
            [-535.0950199113042, 396.1867137297493, 770.3603154131596],
        ];
        let faces: [&[usize]; 7] = [
            &[0, 1, 2, 3],
            &[4, 5, 6, 1, 0],
            &[2, 1, 6, 7],
            &[8, 7, 6, 5],
            &[0, 3, 9, 8, 5, 4],
            &[2, 9, 3],
            &[9, 2, 7, 8],
        ];
        let tol = Tolerances::for_scale(4452.170706520585);
        let cell = cell_of_table(&v, &faces, &tol);
        let plane = Plane {
            n: [0.6422630946713799, 0.7664842463270561, 0.00013174060505069405],
            d: -39.874982002291716,
        };
        // Shallower than the sliver width on the back, deeper than the crossing thickness.
        let back = v.iter().map(|x| -plane.eval(x)).fold(0.0f64, f64::max);
        assert!(back < tol.sliver_width() && back > tol.coplanar_abs().max(tol.weld_abs()));
        assert_only_settling_cuts(&cell, &plane, &tol);
    }

    /// The apex has the same bits for every listing of a face, where the plain sum of its
    /// vertices in listing order does not (addition is not associative).
    #[test]
    fn canonical_apex_does_not_depend_on_the_listing() {
        let face: Vec<P3> = vec![
            [0.1, 0.7, 1e-17],
            [0.2, 0.30000000000000004, 3.0],
            [1e16, 0.3, -0.0],
            [-1e16, 1.1, 0.0],
            [0.3, 0.6, 2.0],
        ];
        let naive = |v: &[P3]| v.iter().fold([0.0; 3], |g, p| add(&g, p));
        let mut buf = Vec::new();
        let want = canonical_apex(&face, &mut buf).map(f64::to_bits);
        let mut naive_bits = std::collections::BTreeSet::new();
        for start in 0..face.len() {
            for reversed in [false, true] {
                let mut v: Vec<P3> = (0..face.len()).map(|i| face[(start + i) % face.len()]).collect();
                if reversed {
                    v.reverse();
                }
                assert_eq!(canonical_apex(&v, &mut buf).map(f64::to_bits), want, "start {start}");
                naive_bits.insert(naive(&v).map(f64::to_bits));
            }
        }
        assert!(naive_bits.len() > 1, "the listing order must matter for the plain sum");
    }

    /// Two cells sharing a twisted (non-planar) quad that each lists from a different
    /// start: their first-vertex fans cut the quad along different diagonals, so their
    /// volumes do not add up to the cube's; their tiling volumes do (the fuzz find
    /// `bsp_cells_cell_volumes_sum_..._volum-6d7804f6`, a BSP that tiles its box exactly,
    /// failed the volume-sum check this way). On planar faces both volumes agree.
    #[test]
    fn tiling_volumes_of_cells_sharing_a_twisted_face_add_up() {
        let d = 1e-3;
        let (p00, p10, p11, p01) = (
            [0.0, 0.0, 0.5],
            [1.0, 0.0, 0.5 + d],
            [1.0, 1.0, 0.5],
            [0.0, 1.0, 0.5 + d],
        );
        let poly = |faces: Vec<Vec<P3>>| {
            let n = faces.len();
            ConvexPolyhedron::from_faces(faces.into_iter().map(ConvexPolygon::new).collect(), vec![0; n])
        };
        let lower = poly(vec![
            vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, 0.0]],
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], p10, p00],
            vec![[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], p11, p10],
            vec![[1.0, 1.0, 0.0], [0.0, 1.0, 0.0], p01, p11],
            vec![[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], p00, p01],
            vec![p00, p10, p11, p01],
        ]);
        let upper = poly(vec![
            vec![[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0]],
            vec![p00, p10, [1.0, 0.0, 1.0], [0.0, 0.0, 1.0]],
            vec![p10, p11, [1.0, 1.0, 1.0], [1.0, 0.0, 1.0]],
            vec![p11, p01, [0.0, 1.0, 1.0], [1.0, 1.0, 1.0]],
            vec![p01, p00, [0.0, 0.0, 1.0], [0.0, 1.0, 1.0]],
            // The shared quad reversed, from another vertex.
            vec![p10, p00, p01, p11],
        ]);
        assert!(lower.volume() > 0.0 && upper.volume() > 0.0);
        let fans = lower.volume() + upper.volume() - 1.0;
        assert!(fans.abs() > 1e-5, "first-vertex fans disagree by {fans:e}");
        let tiled = lower.tiling_volume() + upper.tiling_volume() - 1.0;
        assert!(tiled.abs() <= 4.0 * f64::EPSILON, "tiling volumes miss by {tiled:e}");
        let cube = ConvexPolyhedron::cuboid(&[0.0; 3], &[1.0, 2.0, 3.0]);
        assert!((cube.tiling_volume() - cube.volume()).abs() <= 8.0 * f64::EPSILON * 6.0);
    }

    /// The hashing versions `vertices` and `check` had before they scanned and sorted.
    fn vertices_hashed(p: &ConvexPolyhedron) -> Vec<P3> {
        let mut seen = HashSet::new();
        let mut out = vec![];
        for f in &p.faces {
            for v in &f.verts {
                if seen.insert(key(v)) {
                    out.push(*v);
                }
            }
        }
        out
    }

    fn edge_verdict_hashed(p: &ConvexPolyhedron) -> Result<(), String> {
        let mut edges: HashMap<(Key, Key), u32> = HashMap::new();
        for (fi, f) in p.faces.iter().enumerate() {
            let n = f.verts.len();
            if n < 3 {
                return Err(format!("face {fi} has {n} vertices"));
            }
            for k in 0..n {
                let (a, b) = (key(&f.verts[k]), key(&f.verts[(k + 1) % n]));
                if a == b {
                    return Err(format!("face {fi} repeats vertex {:?}", f.verts[k]));
                }
                *edges.entry((a, b)).or_default() += 1;
            }
        }
        for f in &p.faces {
            let n = f.verts.len();
            for k in 0..n {
                let (a, b) = (key(&f.verts[k]), key(&f.verts[(k + 1) % n]));
                let c = edges[&(a, b)];
                if c != 1 {
                    return Err(format!("directed edge {a:?}->{b:?} used {c} times"));
                }
                if edges.get(&(b, a)) != Some(&1) {
                    return Err(format!("edge {a:?}->{b:?} has no reverse (open or T-junction)"));
                }
            }
        }
        Ok(())
    }

    #[test]
    fn scanned_vertices_and_sorted_edges_match_the_hashed_versions() {
        let tol = Tolerances::for_scale(3f64.sqrt());
        let mut rng = Rng::new(17);
        let (mut small, mut large) = (0, 0);
        for _ in 0..60 {
            let mut p =
                ConvexPolyhedron::tetrahedron(&[0.0, 0.0, 0.0], &[1.0, 0.0, 0.0], &[0.0, 1.0, 0.0], &[0.0, 0.0, 1.0]);
            for _ in 0..40 {
                let n = rng.unit();
                let c = [0.25 + 0.1 * rng.f64(), 0.25 + 0.1 * rng.f64(), 0.25 + 0.1 * rng.f64()];
                let plane = Plane::new(n, dot(&n, &c) + 0.02 + 0.1 * rng.f64());
                if let Some(sp) = p.split(&plane, &tol, 9) {
                    p = if rng.f64() < 0.5 { sp.front } else { sp.back };
                }
                let occ: usize = p.faces.iter().map(|f| f.verts.len()).sum();
                if occ <= SMALL_OCCURRENCES {
                    small += 1;
                } else {
                    large += 1;
                }
                assert_eq!(p.vertices(), vertices_hashed(&p));
                // `check`'s edge verdict equals the hashed one on the piece and on broken
                // copies: a face dropped, a face doubled, a face reversed.
                let edge_part = |q: &ConvexPolyhedron| match q.check(&tol) {
                    Err(e) if e.contains("edge") || e.contains("face ") => Err(e),
                    _ => Ok(()),
                };
                assert_eq!(edge_part(&p), edge_verdict_hashed(&p));
                let mut broken = vec![p.clone(), p.clone(), p.clone()];
                broken[0].faces.pop();
                broken[0].tags.pop();
                let f0 = broken[1].faces[0].clone();
                broken[1].faces.push(f0);
                broken[1].tags.push(0);
                broken[2].faces[0].verts.reverse();
                for b in &broken {
                    if b.faces.len() >= 4 {
                        assert_eq!(edge_part(b), edge_verdict_hashed(b));
                        assert!(edge_verdict_hashed(b).is_err());
                    }
                }
            }
        }
        // The hashing path is the old code; the scan must have run.
        assert!(small > 0, "the scanning path ran ({small} small, {large} large pieces)");
    }

    /// The small-cell path of `check` gives the general path's verdict, message included:
    /// on random cuts of a tetrahedron far from the origin and on broken copies (a face
    /// dropped, doubled or reversed, a vertex pushed out of or into the cell, a repeated
    /// vertex), so every error kind and the cheap convexity skip are exercised.
    #[test]
    fn small_cell_check_equals_the_general_check() {
        let mut rng = Rng::new(29);
        let (mut checked, mut errors, mut convexity) = (0, 0, 0);
        for round in 0..80 {
            let off = if round % 2 == 0 { 0.0 } else { 1e5 };
            let tol = Tolerances::for_scale(3f64.sqrt());
            let o = [off, -off, off];
            let at = |x: f64, y: f64, z: f64| [o[0] + x, o[1] + y, o[2] + z];
            let mut p = ConvexPolyhedron::tetrahedron(
                &at(0.0, 0.0, 0.0),
                &at(1.0, 0.0, 0.0),
                &at(0.0, 1.0, 0.0),
                &at(0.0, 0.0, 1.0),
            );
            for _ in 0..(round % 7) {
                let n = rng.unit();
                let c = at(0.25 + 0.1 * rng.f64(), 0.25 + 0.1 * rng.f64(), 0.25 + 0.1 * rng.f64());
                let plane = Plane::new(n, dot(&n, &c) + 0.02 + 0.1 * rng.f64());
                if let Some(sp) = p.split(&plane, &tol, 9) {
                    p = if rng.f64() < 0.5 { sp.front } else { sp.back };
                }
            }
            let mut variants = vec![p.clone(); 7];
            variants[1].faces.pop();
            variants[1].tags.pop();
            let f0 = variants[2].faces[0].clone();
            variants[2].faces.push(f0);
            variants[2].tags.push(0);
            variants[3].faces[0].verts.reverse();
            // Every occurrence of one vertex moved along a random direction: out of the
            // cell (convexity), or in (still convex) — consistently, so edges still match.
            for (k, scale) in [(4usize, 1e-3), (5, -1e-9)] {
                let v = variants[k].faces[0].verts[0];
                let d = rng.unit();
                let w = [v[0] + scale * d[0], v[1] + scale * d[1], v[2] + scale * d[2]];
                for f in &mut variants[k].faces {
                    for x in &mut f.verts {
                        if key(x) == key(&v) {
                            *x = w;
                        }
                    }
                }
            }
            let dup = variants[6].faces[0].verts[0];
            variants[6].faces[0].verts.insert(1, dup);
            for v in &variants {
                let occ: usize = v.faces.iter().map(|f| f.verts.len()).sum();
                if v.faces.len() < 4 || occ > SMALL_OCCURRENCES {
                    continue;
                }
                let (small, general) = (
                    check_small::<SMALL_OCCURRENCES>(&v.faces, &tol),
                    check_general(&v.faces, &tol),
                );
                assert_eq!(small, general, "round {round}");
                if occ <= 16 {
                    assert_eq!(check_small::<16>(&v.faces, &tol), general, "round {round}");
                }
                checked += 1;
                if let Err(e) = small {
                    errors += 1;
                    convexity += e.contains("in front of face") as usize;
                }
            }
        }
        assert!(
            checked > 300 && errors > 100 && convexity > 5,
            "{checked} {errors} {convexity}"
        );
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(1e-300)
    }

    fn assert_close(a: f64, b: f64, r: f64, what: &str) {
        assert!(rel(a, b) <= r, "{what}: {a} vs {b} (rel {:e})", rel(a, b));
    }

    fn cube(fr: &Frame) -> ConvexPolyhedron {
        // Built in local coordinates, then every vertex mapped (the same local corner
        // always maps to the same bits, so the B-rep stays conforming).
        let mut c = ConvexPolyhedron::cuboid(&[0.0; 3], &[1.0; 3]);
        for f in &mut c.faces {
            for v in &mut f.verts {
                *v = fr.apply(*v);
            }
        }
        c
    }

    fn tet(fr: &Frame) -> ConvexPolyhedron {
        let p = |x, y, z| fr.apply([x, y, z]);
        ConvexPolyhedron::tetrahedron(
            &p(0.0, 0.0, 0.0),
            &p(1.0, 0.0, 0.0),
            &p(0.0, 1.0, 0.0),
            &p(0.0, 0.0, 1.0),
        )
    }

    #[test]
    fn tetrahedron_basics() {
        for (fr, tol) in frames(2.0f64.sqrt()) {
            let t = tet(&fr);
            t.check(&tol).unwrap();
            assert_close(t.volume(), fr.volume(1.0 / 6.0), 1e-9, fr.name);
            let c = t.centroid();
            assert!(norm(&sub(&c, &fr.apply([0.25; 3]))) < 1e-9 * fr.scale, "{}", fr.name);
            assert_eq!(t.vertices().len(), 4);
            // Outward: the opposite vertex is behind each face; face k is opposite vertex k.
            let vs = [
                fr.apply([0.0; 3]),
                fr.apply([1.0, 0.0, 0.0]),
                fr.apply([0.0, 1.0, 0.0]),
                fr.apply([0.0, 0.0, 1.0]),
            ];
            for (k, pl) in t.planes().iter().enumerate() {
                assert!(pl.signed_distance(&vs[k]) < -0.5 * fr.scale);
            }
            assert!(t.contains(&c, &tol));
            assert!(t.contains(&vs[3], &tol));
            assert!(!t.contains(&fr.apply([0.5, 0.5, 0.5]), &tol));
            assert!(!t.contains(&fr.apply([-1e-6, 0.1, 0.1]), &tol));
            // Negatively oriented input is fixed.
            let neg = ConvexPolyhedron::tetrahedron(&vs[1], &vs[0], &vs[2], &vs[3]);
            neg.check(&tol).unwrap();
            assert_close(neg.volume(), fr.volume(1.0 / 6.0), 1e-9, fr.name);
            assert_close(t.surface_area(), fr.area(1.5 + 3f64.sqrt() / 2.0), 1e-9, fr.name);
        }
    }

    /// A diagonal plane a few plane tolerances (well inside the weld distance) off four
    /// vertices: `cut` takes the plane band; the alternatives hold the weld band's cut
    /// (those vertices On), each into valid pieces of the same volumes, and never the
    /// band `cut` chose.
    #[test]
    fn cut_alternatives_are_the_other_valid_bands() {
        let tol = Tolerances::for_scale(3f64.sqrt());
        let c = ConvexPolyhedron::cuboid(&[0.0; 3], &[1.0; 3]);
        // x − y = −d: the vertices (0,0,z) and (1,1,z) lie d/√2 in front.
        let d = 20.0 * tol.plane_abs();
        let pl = Plane::new([1.0, -1.0, 0.0], d);
        let Cut::Split(s) = c.cut(&pl, &tol, 9) else {
            panic!("not split")
        };
        assert_eq!(s.on_dist, tol.plane_abs());
        let alts = c.cut_alternatives(&pl, &tol, 9, s.on_dist);
        assert!(alts.iter().all(|a| a.on_dist != s.on_dist));
        let weld = alts
            .iter()
            .find(|a| a.on_dist == tol.snap_abs())
            .expect("the weld band's cut");
        for a in alts.iter().chain([&*s]) {
            for p in [&a.front, &a.back] {
                p.check(&tol).unwrap();
            }
            assert_close(a.front.volume() + a.back.volume(), 1.0, 1e-12, "volume");
            assert_close(a.back.volume(), 0.5, 1e-6, "back volume");
        }
        // The weld band puts the four near vertices on the plane: a section through
        // them, no crossing points beside them.
        assert_eq!(weld.section.verts.len(), 4);
    }

    #[test]
    fn cube_split_in_half() {
        for (fr, tol) in frames(3f64.sqrt()) {
            let c = cube(&fr);
            c.check(&tol).unwrap();
            assert_close(c.volume(), fr.volume(1.0), 1e-9, fr.name);
            assert_eq!(c.vertices().len(), 8);
            let pl = fr.plane([1.0, 0.0, 0.0], [0.5, 0.0, 0.0]);
            assert_eq!(c.classify(&pl, &tol), Classification::Straddles);
            let s = c.split(&pl, &tol, 99).expect("split");
            for (p, name) in [(&s.front, "front"), (&s.back, "back")] {
                p.check(&tol).unwrap_or_else(|e| panic!("{}: {name}: {e}", fr.name));
                assert_close(p.volume(), fr.volume(0.5), 1e-9, fr.name);
                assert_eq!(p.faces.len(), 6);
                assert_eq!(p.vertices().len(), 8);
                assert_eq!(*p.tags.last().unwrap(), 99);
            }
            assert_close(s.section.area(), fr.area(1.0), 1e-9, fr.name);
            assert!(dot(&s.section.normal(), &pl.unit_normal()) > 1.0 - 1e-12);
            assert_eq!(s.back.faces.last().unwrap(), &s.section);
            assert_eq!(s.front.faces.last().unwrap(), &s.section.reversed());
            // Front holds +x (tag 1) whole, back holds −x (tag 0); y/z faces are halved.
            assert!(s.front.tags.contains(&1) && !s.front.tags.contains(&0));
            assert!(s.back.tags.contains(&0) && !s.back.tags.contains(&1));
            assert_eq!(s.front_origin.len(), 6);
            assert_eq!(s.front_origin[5], None);
            for (k, o) in s.front_origin.iter().enumerate().take(5) {
                assert_eq!(s.front.tags[k], c.tags[o.unwrap()]);
            }
            // Centroids.
            assert!(norm(&sub(&s.front.centroid(), &fr.apply([0.75, 0.5, 0.5]))) < 1e-9 * fr.scale);
            assert!(norm(&sub(&s.back.centroid(), &fr.apply([0.25, 0.5, 0.5]))) < 1e-9 * fr.scale);
            // The section's vertices are exactly the pieces' vertices on the plane.
            for v in &s.section.verts {
                assert!(s.front.vertices().contains(v) && s.back.vertices().contains(v));
            }
            // Flipped plane swaps the pieces.
            let s2 = c.split(&pl.flipped(), &tol, 7).unwrap();
            assert_close(s2.front.volume(), fr.volume(0.5), 1e-9, fr.name);
            assert!(s2.front.tags.contains(&0));
        }
    }

    #[test]
    fn grazing_and_sliver_planes_do_not_split() {
        for (fr, tol) in frames(3f64.sqrt()) {
            let c = cube(&fr);
            let t = |n: P3, p: P3| c.cut(&fr.plane(n, p), &tol, 0);
            // Through a vertex, an edge, a face (both orientations), outside.
            assert_eq!(t([1.0, 1.0, 1.0], [0.0; 3]), Cut::Front, "{}", fr.name);
            assert_eq!(t([-1.0, -1.0, -1.0], [0.0; 3]), Cut::Back);
            assert_eq!(t([1.0, 1.0, 0.0], [1.0, 1.0, 0.0]), Cut::Back);
            assert_eq!(t([1.0, 0.0, 0.0], [1.0, 0.0, 0.0]), Cut::Back);
            assert_eq!(t([1.0, 0.0, 0.0], [0.0, 0.0, 0.0]), Cut::Front);
            assert_eq!(t([0.0, 0.0, 1.0], [0.0, 0.0, 5.0]), Cut::Back);
            assert_eq!(
                c.classify(&fr.plane([1.0, 1.0, 0.0], [1.0, 1.0, 0.0]), &tol),
                Classification::Back
            );
            // Within the plane tolerance of a face: grazing.
            assert_eq!(t([1.0, 0.0, 0.0], [1.0 - 1e-11, 0.0, 0.0]), Cut::Back);
            // Slab thinner than the weld distance (1e-7 · diag): refused, bulk side.
            assert_eq!(t([1.0, 0.0, 0.0], [1.0 - 1e-8, 0.0, 0.0]), Cut::Back, "{}", fr.name);
            assert_eq!(t([-1.0, 0.0, 0.0], [1.0 - 1e-8, 0.0, 0.0]), Cut::Front);
            // Thicker slab: split.
            let s = c
                .split(&fr.plane([1.0, 0.0, 0.0], [1.0 - 1e-5, 0.0, 0.0]), &tol, 0)
                .unwrap();
            assert_close(s.front.volume(), fr.volume(1e-5), 1e-4, fr.name);
            s.front.check(&tol).unwrap();
            s.back.check(&tol).unwrap();
            // Corner cap with legs 3e-4 (volume 4.5e-12 > min_volume ≈ 5.2e-15): split.
            let s = c
                .split(&fr.plane([1.0, 1.0, 1.0], [1.0 - 3e-4, 1.0, 1.0]), &tol, 0)
                .unwrap();
            assert_close(s.front.volume(), fr.volume(4.5e-12), 1e-3, fr.name);
            s.front.check(&tol).unwrap_or_else(|e| panic!("{}: {e}", fr.name));
            // Legs 3e-6: thick enough (1.7e-6 > weld) but volume 4.5e-18 < min_volume.
            assert!(3e-6 / 3f64.sqrt() > tol.weld_abs() / fr.scale);
            assert!(fr.volume(4.5e-18) < min_volume(&tol));
            assert_eq!(t([1.0, 1.0, 1.0], [1.0 - 3e-6, 1.0, 1.0]), Cut::Back, "{}", fr.name);
        }
    }

    #[test]
    fn split_through_vertices_and_edges() {
        for (fr, tol) in frames(3f64.sqrt()) {
            let c = cube(&fr);
            // Diagonal plane through two opposite edges: On vertices, no new points.
            let s = c.split(&fr.plane([1.0, -1.0, 0.0], [0.0; 3]), &tol, 6).unwrap();
            for p in [&s.front, &s.back] {
                p.check(&tol).unwrap_or_else(|e| panic!("{}: {e}", fr.name));
                assert_close(p.volume(), fr.volume(0.5), 1e-9, fr.name);
                assert_eq!(p.vertices().len(), 6);
            }
            assert_eq!(s.section.len(), 4);
            assert_close(s.section.area(), fr.area(2f64.sqrt()), 1e-9, fr.name);
            // Plane through three vertices: a corner tetrahedron.
            let s = c.split(&fr.plane([1.0, 1.0, 1.0], [1.0, 0.0, 0.0]), &tol, 6).unwrap();
            assert_close(s.back.volume(), fr.volume(1.0 / 6.0), 1e-9, fr.name);
            assert_eq!(s.back.vertices().len(), 4);
            s.front.check(&tol).unwrap();
            s.back.check(&tol).unwrap();
            // Hexagonal section through the centre.
            let s = c.split(&fr.plane([1.0, 1.0, 1.0], [0.5; 3]), &tol, 6).unwrap();
            assert_eq!(s.section.len(), 6);
            assert_close(s.section.area(), fr.area(3.0 * 3f64.sqrt() / 4.0), 1e-9, fr.name);
            assert!(s.section.is_convex(&tol));
        }
    }

    /// Repeatedly split every piece by random planes; returns the final pieces.
    fn shatter(
        p0: &ConvexPolyhedron,
        fr: &Frame,
        tol: &Tolerances,
        seed: u64,
        planes: usize,
        subdivide: bool,
    ) -> (Vec<ConvexPolyhedron>, f64) {
        let mut rng = Rng::new(seed);
        let mut pieces = vec![p0.clone()];
        let mut section_area = 0.0;
        let mut tag = 100;
        for _ in 0..planes {
            let n = rng.unit();
            let p = [rng.f64(), rng.f64(), rng.f64()];
            let p = if rng.f64() < 0.3 { [0.25, 0.25, 0.25] } else { p };
            let pl = fr.plane(n, p);
            let mut next = vec![];
            for piece in pieces {
                tag += 1;
                match piece.cut(&pl, tol, tag) {
                    Cut::Split(s) => {
                        section_area += s.section.area();
                        for q in [&s.front, &s.back] {
                            q.check(tol).unwrap_or_else(|e| panic!("{}: {e}", fr.name));
                        }
                        next.push(s.front);
                        next.push(s.back);
                    }
                    _ => next.push(piece),
                }
            }
            if subdivide {
                // Simulate neighbours splitting: subdivide a random face of some pieces.
                for q in &mut next {
                    if rng.f64() < 0.5 {
                        let fi = (rng.next_u64() % q.faces.len() as u64) as usize;
                        let c = q.faces[fi].centroid();
                        let pl = Plane::from_normal_point(fr.apply_vec(rng.unit()), &c);
                        let t = q.tags[fi];
                        q.split_face(fi, &pl, tol, t, t);
                        q.check(tol)
                            .unwrap_or_else(|e| panic!("{}: after split_face: {e}", fr.name));
                    }
                }
            }
            pieces = next;
        }
        (pieces, section_area)
    }

    fn shatter_checks(p0: &ConvexPolyhedron, fr: &Frame, tol: &Tolerances, subdivide: bool) {
        let v0 = p0.volume();
        let a0 = p0.surface_area();
        let c0 = p0.centroid();
        for seed in 1..=5 {
            let (pieces, sec) = shatter(p0, fr, tol, seed, 12, subdivide);
            assert!(pieces.len() > 10, "{}: only {} pieces", fr.name, pieces.len());
            let v: f64 = pieces.iter().map(|p| p.volume()).sum();
            assert_close(v, v0, 1e-9, fr.name);
            let a: f64 = pieces.iter().map(|p| p.surface_area()).sum();
            assert_close(a, a0 + 2.0 * sec, 1e-9, fr.name);
            let mut m = [0.0; 3];
            for p in &pieces {
                let vol = p.volume();
                assert!(vol >= min_volume(tol));
                m = add(&m, &scale(&sub(&p.centroid(), &c0), vol));
            }
            assert!(norm(&m) / v0 < 1e-9 * fr.scale, "{}: centroid drift {:?}", fr.name, m);
        }
    }

    #[test]
    fn repeated_random_splits_of_tetrahedron_preserve_volume() {
        for (fr, tol) in frames(2f64.sqrt()) {
            shatter_checks(&tet(&fr), &fr, &tol, false);
        }
    }

    #[test]
    fn repeated_random_splits_with_subdivided_faces() {
        for (fr, tol) in frames(3f64.sqrt()) {
            shatter_checks(&cube(&fr), &fr, &tol, true);
            shatter_checks(&tet(&fr), &fr, &tol, true);
        }
    }

    /// A unit cube whose top face holds a collinear T-vertex U 1e-7 from its corner Q on
    /// the edge Q–T, divided by a plane through Q that meets that edge at a shallow angle
    /// (1e-6): U and Q are both On, between a back and a front vertex. Without the chord
    /// (the cut cell's section, which ends at Q) both parts take the edge Q–U; along it, U
    /// goes with T to the front part and the cube stays valid.
    #[test]
    fn split_face_along_settles_a_run_of_on_vertices_at_the_chord_end() {
        let tol = Tolerances::for_scale(1.0);
        let (a, q, u, t, b) = (
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 1e-7, 1.0],
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 1.0],
        );
        let faces: Vec<ConvexPolygon> = [
            vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, 0.0]],
            vec![a, q, u, t, b],
            vec![[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 1.0], [0.0, 1.0, 0.0]],
            vec![[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], t, u, q],
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], q, a],
            vec![[0.0, 1.0, 0.0], b, t, [1.0, 1.0, 0.0]],
        ]
        .into_iter()
        .map(ConvexPolygon::new)
        .collect();
        let cube = ConvexPolyhedron::from_faces(faces, (0..6).collect());
        cube.check(&tol).expect("the cube with its T-vertex is valid");
        // x - 1 + 1e-6 y = 0: through Q, 1e-13 from U, 1e-6 in front at T.
        let mut plane = Plane::from_points(&q, &[1.0, 0.0, 0.0], &[1.0 - 1e-6, 1.0, 0.0]);
        if plane.eval(&t) < 0.0 {
            plane = plane.flipped();
        }
        let on = 1e-8;
        let mut plain = cube.clone();
        plain.split_face_within(1, &plane, on, 1, 6).expect("straddles");
        assert!(plain.check(&tol).is_err(), "the edge Q-U in both parts");
        let mut along = cube.clone();
        along.split_face_along(1, &plane, on, &[q], 1, 6).expect("straddles");
        along.check(&tol).unwrap_or_else(|e| panic!("{e}"));
        let front = &along.faces[1].verts;
        assert!(
            front.contains(&u) && front.contains(&t) && front.contains(&q),
            "{front:?}"
        );
        assert!(!along.faces[6].verts.contains(&u), "{:?}", along.faces[6].verts);
    }

    #[test]
    fn split_face_keeps_boundary_conforming() {
        for (fr, tol) in frames(3f64.sqrt()) {
            let mut c = cube(&fr);
            // Subdivide the +z face (index 5) along x = 0.5.
            let k = c
                .split_face(5, &fr.plane([1.0, 0.0, 0.0], [0.5, 0.0, 0.0]), &tol, 50, 51)
                .unwrap();
            assert_eq!((k, c.faces.len()), (6, 7));
            assert_eq!((c.tags[5], c.tags[6]), (50, 51));
            c.check(&tol).unwrap_or_else(|e| panic!("{}: {e}", fr.name));
            assert_eq!(c.vertices().len(), 10);
            // ±y faces got a T-vertex each.
            assert_eq!((c.faces[2].len(), c.faces[3].len()), (5, 5));
            assert_close(c.volume(), fr.volume(1.0), 1e-9, fr.name);
            // Face that does not straddle: nothing happens.
            assert_eq!(
                c.split_face(4, &fr.plane([0.0, 0.0, 1.0], [0.0, 0.0, 0.5]), &tol, 0, 0),
                None
            );
            // Split across the seam.
            let s = c.split(&fr.plane([0.0, 1.0, 0.0], [0.0, 0.3, 0.0]), &tol, 9).unwrap();
            s.front.check(&tol).unwrap();
            s.back.check(&tol).unwrap();
            assert_close(s.back.volume(), fr.volume(0.3), 1e-9, fr.name);
            assert_eq!(s.section.len(), 5); // includes the seam's crossing point
            for p in [&s.front, &s.back] {
                assert!(p.tags.contains(&50) && p.tags.contains(&51));
            }
            // Split along the seam: each piece gets exactly one patch.
            let s = c.split(&fr.plane([1.0, 0.0, 0.0], [0.5, 0.0, 0.0]), &tol, 9).unwrap();
            s.front.check(&tol).unwrap();
            s.back.check(&tol).unwrap();
            assert!(s.front.tags.contains(&50) && !s.front.tags.contains(&51));
            assert!(s.back.tags.contains(&51) && !s.back.tags.contains(&50));
            // The section uses the seam's T-vertices.
            assert_eq!(s.section.len(), 4);
            // Split parallel to the seam, crossing the T-vertices' edges.
            let s = c.split(&fr.plane([1.0, 0.0, 0.0], [0.7, 0.0, 0.0]), &tol, 9).unwrap();
            s.front.check(&tol).unwrap();
            s.back.check(&tol).unwrap();
            assert_close(s.front.volume(), fr.volume(0.3), 1e-9, fr.name);
        }
    }

    #[test]
    fn degenerate_plane_does_not_split() {
        let tol = Tolerances::for_scale(3f64.sqrt());
        let c = ConvexPolyhedron::cuboid(&[0.0; 3], &[1.0; 3]);
        let pl = Plane::new([0.0; 3], 0.0);
        assert!(matches!(c.cut(&pl, &tol, 0), Cut::Front | Cut::Back));
        assert_eq!(c.classify(&pl, &tol), Classification::Coplanar);
    }

    #[test]
    fn grid_of_wall_planes_and_repeated_planes() {
        // Axis-aligned "walls" at x, y, z = k/4 (in shuffled order, each twice): 64 equal
        // cells; the second pass of a plane never splits anything (all vertices On/one
        // side), nor does a copy shifted by half the plane tolerance.
        for (fr, tol) in frames(3f64.sqrt()) {
            let mut planes = vec![];
            for axis in 0..3 {
                for k in 1..4 {
                    let mut n = [0.0; 3];
                    n[axis] = 1.0;
                    let mut p = [0.0; 3];
                    p[axis] = k as f64 / 4.0;
                    planes.push((n, p));
                }
            }
            let mut rng = Rng::new(3);
            for i in (1..planes.len()).rev() {
                planes.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
            }
            let mut pieces = vec![cube(&fr)];
            for &(n, p) in &planes {
                for pass in 0..3 {
                    let mut pl = fr.plane(n, p);
                    if pass == 2 {
                        pl.d += 0.5 * tol.plane_abs() * super::super::vec::norm(&pl.n);
                    }
                    let mut next = vec![];
                    for q in pieces {
                        match q.cut(&pl, &tol, 0) {
                            Cut::Split(s) => {
                                assert_eq!(pass, 0, "{}: plane split again", fr.name);
                                s.front.check(&tol).unwrap();
                                s.back.check(&tol).unwrap();
                                next.push(s.front);
                                next.push(s.back);
                            }
                            _ => next.push(q),
                        }
                    }
                    pieces = next;
                }
            }
            assert_eq!(pieces.len(), 64);
            for q in &pieces {
                assert_close(q.volume(), fr.volume(1.0 / 64.0), 1e-8, fr.name);
                assert_eq!(q.vertices().len(), 8, "{}", fr.name);
            }
        }
    }

    #[test]
    fn planes_through_existing_vertices() {
        // Model polygon planes pass exactly through cell vertices: split by planes
        // through 1 or 3 vertices of the pieces (including earlier crossing points).
        for (fr, tol) in frames(2f64.sqrt()) {
            for seed in 0..5 {
                let t0 = tet(&fr);
                let v0 = t0.volume();
                let mut rng = Rng::new(100 + seed);
                let mut pieces = vec![t0];
                let mut splits = 0;
                for _ in 0..40 {
                    let q = &pieces[(rng.next_u64() % pieces.len() as u64) as usize];
                    let vs = q.vertices();
                    let pick = |r: &mut Rng| vs[(r.next_u64() % vs.len() as u64) as usize];
                    let pl = if rng.f64() < 0.5 {
                        Plane::from_normal_point(rng.unit(), &pick(&mut rng))
                    } else {
                        let (a, b, c) = (pick(&mut rng), pick(&mut rng), pick(&mut rng));
                        let pl = Plane::from_points(&a, &b, &c);
                        if pl.is_degenerate() {
                            continue;
                        }
                        pl
                    };
                    let mut next = vec![];
                    for q in pieces {
                        match q.cut(&pl, &tol, 0) {
                            Cut::Split(s) => {
                                splits += 1;
                                for r in [&s.front, &s.back] {
                                    r.check(&tol).unwrap_or_else(|e| panic!("{}: {e}", fr.name));
                                    assert!(s.section.is_convex(&tol) || s.section.area() < 1e-6 * fr.area(1.0));
                                }
                                next.push(s.front);
                                next.push(s.back);
                            }
                            _ => next.push(q),
                        }
                    }
                    pieces = next;
                }
                assert!(splits > 20, "{}: {splits}", fr.name);
                let v: f64 = pieces.iter().map(|p| p.volume()).sum();
                // Vertices within the weld distance of a plane are On (`Tolerances::snap_abs`),
                // so a section may be non-planar by up to that distance and a face later split
                // across it changes its fan volume by ~weld × area: 1e-8, not 1e-9.
                assert_close(v, v0, 1e-8, fr.name);
            }
        }
    }

    #[test]
    fn clip_polygon_to_cell() {
        for (fr, tol) in frames(3f64.sqrt()) {
            let c = cube(&fr);
            let p = |pts: &[[f64; 3]]| ConvexPolygon::new(pts.iter().map(|q| fr.apply(*q)).collect());
            // A big triangle in z = 0.5 crossing the cube: clipped to the unit square.
            let t = p(&[[-1.0, -1.0, 0.5], [4.0, -1.0, 0.5], [-1.0, 4.0, 0.5]]);
            let r = c.clip_polygon(&t, &tol).unwrap();
            assert_close(r.area(), fr.area(1.0), 1e-9, fr.name);
            assert!(dot(&r.normal(), &t.normal()) > 0.999_999);
            // Lying on the +z face (either orientation), partly outside: kept, clipped.
            for q in [
                p(&[[0.5, 0.5, 1.0], [2.0, 0.5, 1.0], [2.0, 2.0, 1.0], [0.5, 2.0, 1.0]]),
                p(&[[0.0, 0.5, 0.5], [0.0, 2.0, 0.5], [0.0, 2.0, 2.0], [0.0, 0.5, 2.0]]),
            ] {
                let r = c.clip_polygon(&q, &tol).unwrap();
                assert_close(r.area(), fr.area(0.25), 1e-9, fr.name);
                let r = c.clip_polygon(&q.reversed(), &tol).unwrap();
                assert_close(r.area(), fr.area(0.25), 1e-9, fr.name);
            }
            // In the +z face plane but outside the face; touching an edge; far away.
            assert!(
                c.clip_polygon(&p(&[[2.0, 2.0, 1.0], [3.0, 2.0, 1.0], [3.0, 3.0, 1.0]]), &tol)
                    .is_none()
            );
            assert!(
                c.clip_polygon(
                    &p(&[[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 1.0, 0.0], [1.0, 1.0, 0.0]]),
                    &tol
                )
                .is_none()
            );
            assert!(
                c.clip_polygon(&p(&[[0.0, 0.0, 3.0], [1.0, 0.0, 3.0], [0.0, 1.0, 3.0]]), &tol)
                    .is_none()
            );
            // Inside entirely: unchanged.
            let q = p(&[[0.2, 0.2, 0.2], [0.8, 0.2, 0.3], [0.5, 0.7, 0.6]]);
            assert_eq!(c.clip_polygon(&q, &tol), Some(q.clone()));
        }
    }
}
