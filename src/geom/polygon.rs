//! Convex planar polygons in 3D: split by a plane, coplanar intersection, subtraction.

use serde::{Deserialize, Serialize};

use super::plane::{Classification, Classifier, Plane, Side};
use super::vec::{add, axes, cross, dot, lex_less, norm, normalize, scale, sub};
use crate::predicates::P3;
use crate::tolerances::Tolerances;

/// A convex planar polygon; vertices counter-clockwise seen from the front (the side its
/// [`normal`](ConvexPolygon::normal) points to). Collinear vertices (T-vertices of a
/// subdivided boundary) are allowed; repeated consecutive vertices are not.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConvexPolygon {
    /// Vertices, counter-clockwise around the normal.
    pub verts: Verts,
}

/// Vertices held inline, without a heap block, up to this many.
pub const INLINE_VERTS: usize = 3;

/// A polygon's vertex list: up to [`INLINE_VERTS`] vertices inline (a triangle — every
/// face of an unsplit tetrahedron, its patches, conforming occluders and whole-patch
/// portal pieces — needs no heap block), more on the heap. 80 bytes either way, against
/// a `Vec`'s 24 plus a heap block of 16 + 24·capacity bytes (glibc), i.e. 104 for a
/// triangle. Derefs to `[P3]`; equality, `Debug` and serde are those of the vertex
/// slice, so nothing about the polygon's values depends on where they are held.
#[derive(Clone)]
pub struct Verts(VertsRepr);

#[derive(Clone)]
enum VertsRepr {
    Inline(u8, [P3; INLINE_VERTS]),
    Heap(Vec<P3>),
}

impl Verts {
    /// No vertices.
    pub const fn new() -> Self {
        Verts(VertsRepr::Inline(0, [[0.0; 3]; INLINE_VERTS]))
    }

    /// Room for `n` vertices (inline when `n <= INLINE_VERTS`).
    pub fn with_capacity(n: usize) -> Self {
        if n <= INLINE_VERTS {
            Self::new()
        } else {
            Verts(VertsRepr::Heap(Vec::with_capacity(n)))
        }
    }

    /// The vertices of `v` (inline when they fit; the heap block is then freed).
    pub fn from_vec(v: Vec<P3>) -> Self {
        if v.len() <= INLINE_VERTS {
            Self::from_slice(&v)
        } else {
            Verts(VertsRepr::Heap(v))
        }
    }

    /// A copy of `s`.
    pub fn from_slice(s: &[P3]) -> Self {
        if s.len() <= INLINE_VERTS {
            let mut a = [[0.0; 3]; INLINE_VERTS];
            a[..s.len()].copy_from_slice(s);
            Verts(VertsRepr::Inline(s.len() as u8, a))
        } else {
            Verts(VertsRepr::Heap(s.to_vec()))
        }
    }

    /// The vertices as a `Vec`.
    pub fn into_vec(self) -> Vec<P3> {
        match self.0 {
            VertsRepr::Inline(n, a) => a[..n as usize].to_vec(),
            VertsRepr::Heap(v) => v,
        }
    }

    /// The vertices as a slice.
    pub fn as_slice(&self) -> &[P3] {
        self
    }

    /// The vertices as a boxed slice.
    pub fn into_boxed_slice(self) -> Box<[P3]> {
        self.into_vec().into_boxed_slice()
    }

    /// True when the vertices are held without a heap block.
    pub fn is_inline(&self) -> bool {
        matches!(self.0, VertsRepr::Inline(..))
    }

    /// Appends a vertex (moving to the heap past [`INLINE_VERTS`]).
    pub fn push(&mut self, p: P3) {
        match &mut self.0 {
            VertsRepr::Inline(n, a) if (*n as usize) < INLINE_VERTS => {
                a[*n as usize] = p;
                *n += 1;
            }
            VertsRepr::Inline(n, a) => {
                let mut v = Vec::with_capacity(2 * INLINE_VERTS);
                v.extend_from_slice(&a[..*n as usize]);
                v.push(p);
                self.0 = VertsRepr::Heap(v);
            }
            VertsRepr::Heap(v) => v.push(p),
        }
    }

    /// Removes and returns the last vertex.
    pub fn pop(&mut self) -> Option<P3> {
        match &mut self.0 {
            VertsRepr::Inline(n, a) => {
                if *n == 0 {
                    return None;
                }
                *n -= 1;
                Some(a[*n as usize])
            }
            VertsRepr::Heap(v) => v.pop(),
        }
    }

    /// Inserts a vertex at `i` (`i <= len`).
    pub fn insert(&mut self, i: usize, p: P3) {
        assert!(i <= self.len(), "insertion index out of bounds");
        self.push(p);
        self[i..].rotate_right(1);
    }

    /// Removes the vertex at `i`.
    pub fn remove(&mut self, i: usize) -> P3 {
        let p = self[i];
        self[i..].rotate_left(1);
        self.pop();
        p
    }

    /// Drops spare heap capacity; moves inline when the vertices fit.
    pub fn shrink_to_fit(&mut self) {
        if let VertsRepr::Heap(v) = &mut self.0 {
            if v.len() <= INLINE_VERTS {
                *self = Self::from_slice(v);
            } else {
                v.shrink_to_fit();
            }
        }
    }
}

impl Default for Verts {
    fn default() -> Self {
        Self::new()
    }
}

impl std::ops::Deref for Verts {
    type Target = [P3];
    #[inline]
    fn deref(&self) -> &[P3] {
        match &self.0 {
            VertsRepr::Inline(n, a) => &a[..*n as usize],
            VertsRepr::Heap(v) => v,
        }
    }
}

impl std::ops::DerefMut for Verts {
    #[inline]
    fn deref_mut(&mut self) -> &mut [P3] {
        match &mut self.0 {
            VertsRepr::Inline(n, a) => &mut a[..*n as usize],
            VertsRepr::Heap(v) => v,
        }
    }
}

impl PartialEq for Verts {
    fn eq(&self, other: &Self) -> bool {
        self[..] == other[..]
    }
}

impl PartialEq<Vec<P3>> for Verts {
    fn eq(&self, other: &Vec<P3>) -> bool {
        self[..] == other[..]
    }
}

impl PartialEq<[P3]> for Verts {
    fn eq(&self, other: &[P3]) -> bool {
        self[..] == *other
    }
}

impl std::fmt::Debug for Verts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl From<Vec<P3>> for Verts {
    fn from(v: Vec<P3>) -> Self {
        Self::from_vec(v)
    }
}

impl From<&[P3]> for Verts {
    fn from(s: &[P3]) -> Self {
        Self::from_slice(s)
    }
}

impl<const N: usize> From<[P3; N]> for Verts {
    fn from(a: [P3; N]) -> Self {
        Self::from_slice(&a)
    }
}

impl FromIterator<P3> for Verts {
    fn from_iter<I: IntoIterator<Item = P3>>(iter: I) -> Self {
        let mut v = Verts::new();
        v.extend(iter);
        v
    }
}

impl Extend<P3> for Verts {
    fn extend<I: IntoIterator<Item = P3>>(&mut self, iter: I) {
        for p in iter {
            self.push(p);
        }
    }
}

impl<'a> IntoIterator for &'a Verts {
    type Item = &'a P3;
    type IntoIter = std::slice::Iter<'a, P3>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<'a> IntoIterator for &'a mut Verts {
    type Item = &'a mut P3;
    type IntoIter = std::slice::IterMut<'a, P3>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter_mut()
    }
}

impl IntoIterator for Verts {
    type Item = P3;
    type IntoIter = std::vec::IntoIter<P3>;
    fn into_iter(self) -> Self::IntoIter {
        self.into_vec().into_iter()
    }
}

impl Serialize for Verts {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self[..].serialize(s)
    }
}

impl<'de> Deserialize<'de> for Verts {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Vec::<P3>::deserialize(d).map(Verts::from_vec)
    }
}

/// Result of [`ConvexPolygon::split_exact`].
#[derive(Clone, Debug, PartialEq)]
pub enum PolygonSplit {
    /// Entirely in front (vertices Front or On, at least one Front).
    Front,
    /// Entirely behind.
    Back,
    /// Every vertex within tolerance of the plane.
    Coplanar,
    /// Genuinely crossed: `(front part, back part)`, each with at least one strict vertex.
    Split(ConvexPolygon, ConvexPolygon),
}

/// Result of [`ConvexPolygon::subtract`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Subtraction {
    /// Disjoint convex pieces (interiors disjoint), each with area `>= tol.area_abs()`,
    /// oriented like the input polygon, lying on its plane.
    pub pieces: Vec<ConvexPolygon>,
    /// Number of remainder pieces dropped because their area was below `tol.area_abs()`.
    pub slivers: usize,
    /// Total area of the dropped pieces.
    pub sliver_area: f64,
}

/// Walk a vertex cycle and distribute it by precomputed sides: On vertices go to both
/// parts, crossing points (`cross(i, j)` for a strict Front/Back edge `i → j`) are
/// inserted in both. Orientation is preserved.
pub(crate) fn walk_split<T: Clone>(
    verts: &[T],
    sides: &[Side],
    mut cross: impl FnMut(usize, usize) -> T,
) -> (Vec<T>, Vec<T>) {
    let n = verts.len();
    let mut f = Vec::with_capacity(n + 2);
    let mut b = Vec::with_capacity(n + 2);
    for i in 0..n {
        let j = if i + 1 == n { 0 } else { i + 1 };
        match sides[i] {
            Side::On => {
                f.push(verts[i].clone());
                b.push(verts[i].clone());
            }
            Side::Front => f.push(verts[i].clone()),
            Side::Back => b.push(verts[i].clone()),
        }
        if matches!(
            (sides[i], sides[j]),
            (Side::Front, Side::Back) | (Side::Back, Side::Front)
        ) {
            let x = cross(i, j);
            f.push(x.clone());
            b.push(x);
        }
    }
    (f, b)
}

/// Where the segment `pq` crosses the plane, given the signed distances of its endpoints
/// (of strictly opposite signs). Canonical: the endpoints are ordered lexicographically
/// first, so the same edge yields the same bits whichever face (direction) asks.
#[inline]
pub(crate) fn crossing(p: &P3, dp: f64, q: &P3, dq: f64) -> P3 {
    let (a, da, b, db) = if lex_less(q, p) { (q, dq, p, dp) } else { (p, dp, q, dq) };
    let t = da / (da - db);
    [
        a[0] + t * (b[0] - a[0]),
        a[1] + t * (b[1] - a[1]),
        a[2] + t * (b[2] - a[2]),
    ]
}

impl ConvexPolygon {
    /// Polygon with the given vertices (not checked).
    pub fn new(verts: Vec<P3>) -> Self {
        ConvexPolygon {
            verts: Verts::from_vec(verts),
        }
    }

    /// Polygon with the given vertices (not checked), without a heap block when they fit
    /// inline.
    pub fn from_slice(verts: &[P3]) -> Self {
        ConvexPolygon {
            verts: Verts::from_slice(verts),
        }
    }

    /// Number of vertices.
    pub fn len(&self) -> usize {
        self.verts.len()
    }

    /// True when there are no vertices.
    pub fn is_empty(&self) -> bool {
        self.verts.is_empty()
    }

    /// Vector area: `area * normal` (Newell's formula, evaluated relative to the first
    /// vertex so that far-from-origin coordinates lose nothing to cancellation).
    pub fn area_vector(&self) -> [f64; 3] {
        let v = &self.verts;
        if v.len() < 3 {
            return [0.0; 3];
        }
        let o = &v[0];
        let mut s = [0.0; 3];
        let mut prev = sub(&v[1], o);
        for p in &v[2..] {
            let cur = sub(p, o);
            s = add(&s, &cross(&prev, &cur));
            prev = cur;
        }
        scale(&s, 0.5)
    }

    /// Unit normal (Newell); the zero vector for a degenerate polygon.
    pub fn normal(&self) -> [f64; 3] {
        normalize(&self.area_vector())
    }

    /// How far the vertex loop is from a convex polygon, as an area: the area of the
    /// convex hull of its vertices minus the loop's own (signed) area, both in the
    /// projection along its Newell normal's dominant axis and scaled to the plane. Zero
    /// (up to rounding) for a convex loop in counter-clockwise order, and for every
    /// triangle; positive for a reflex vertex, a loop that crosses itself (a "bowtie":
    /// its lobes cancel in the signed area) or one that winds twice. The cell check
    /// ([`crate::geom::polyhedron::check_faces`]) bounds it by the face's perimeter times
    /// the sliver width, the slack of the coverage invariant, so a face whose loop is
    /// convex only up to that can never make an open piece larger than its patch.
    pub fn convexity_defect(&self) -> f64 {
        if self.verts.len() <= 3 {
            return 0.0;
        }
        // The projection: along the Newell normal, unless one triangle of the fan from the
        // first vertex is larger than the whole loop, which no convex loop allows (its fan
        // triangles all have the loop's orientation and sum to it): then the lobes cancel
        // and the Newell normal may be rounding noise (a symmetric bowtie has none), so
        // project along that largest fan triangle's normal (none: all collinear).
        let v = &self.verts;
        let fan = (1..v.len() - 1)
            .map(|k| cross(&sub(&v[k], &v[0]), &sub(&v[k + 1], &v[0])))
            .max_by(|a, b| norm(a).total_cmp(&norm(b)))
            .unwrap_or([0.0; 3]);
        let newell = scale(&self.area_vector(), 2.0);
        let n = if norm(&newell) >= norm(&fan) { newell } else { fan };
        let Some((i, j, k)) = axes(&n) else { return 0.0 };
        let fr = Frame2 {
            o: v[0],
            i,
            j,
            area_factor: norm(&n) / n[k].abs(),
        };
        if fr.convex_ccw(self) {
            return 0.0;
        }
        let pts: Vec<[f64; 2]> = self.verts.iter().map(|p| fr.proj(p)).collect();
        let own = area2(pts.iter().copied());
        let hull = area2(hull2(pts).into_iter());
        ((hull - own.abs()) * fr.area_factor).max(0.0)
    }

    /// Area.
    pub fn area(&self) -> f64 {
        norm(&self.area_vector())
    }

    /// Area centroid (vertex average for a degenerate polygon).
    pub fn centroid(&self) -> P3 {
        let v = &self.verts;
        if v.is_empty() {
            return [f64::NAN; 3];
        }
        let o = &v[0];
        let nv = self.area_vector();
        let mut w = 0.0;
        let mut c = [0.0; 3];
        if v.len() >= 3 {
            let mut prev = sub(&v[1], o);
            for p in &v[2..] {
                let cur = sub(p, o);
                let wi = dot(&cross(&prev, &cur), &nv);
                c = add(&c, &scale(&add(&prev, &cur), wi / 3.0));
                w += wi;
                prev = cur;
            }
        }
        if w > 0.0 && w.is_finite() {
            add(o, &scale(&c, 1.0 / w))
        } else {
            let mut s = [0.0; 3];
            for p in v {
                s = add(&s, &sub(p, o));
            }
            add(o, &scale(&s, 1.0 / v.len() as f64))
        }
    }

    /// Supporting plane: unit normal, through the centroid.
    pub fn plane(&self) -> Plane {
        Plane::from_normal_point(self.normal(), &self.centroid())
    }

    /// Same polygon, opposite orientation (first vertex kept).
    pub fn reversed(&self) -> Self {
        let mut v = self.verts.clone();
        if v.len() > 1 {
            v[1..].reverse();
        }
        ConvexPolygon { verts: v }
    }

    /// Classify the vertices against `plane` with tolerance `tol.plane_abs()`.
    pub fn classify(&self, plane: &Plane, tol: &Tolerances) -> Classification {
        let c = Classifier::new(plane, tol);
        Classification::from_sides(self.verts.iter().map(|p| c.side_of(c.dist(p))))
    }

    /// Split by `plane` using only the per-vertex tolerance (vertices within
    /// `tol.plane_abs()` are On and go to both parts); no area test. Crossing points are
    /// canonical per edge (see module docs), so adjacent polygons split by the same plane
    /// get bit-identical new vertices.
    pub fn split_exact(&self, plane: &Plane, tol: &Tolerances) -> PolygonSplit {
        let c = Classifier::new(plane, tol);
        let d: Vec<f64> = self.verts.iter().map(|p| c.dist(p)).collect();
        let sides: Vec<Side> = d.iter().map(|&x| c.side_of(x)).collect();
        match Classification::from_sides(sides.iter().copied()) {
            Classification::Front => PolygonSplit::Front,
            Classification::Back => PolygonSplit::Back,
            Classification::Coplanar => PolygonSplit::Coplanar,
            Classification::Straddles => {
                let v = &self.verts;
                let (f, b) = walk_split(v, &sides, |i, j| crossing(&v[i], d[i], &v[j], d[j]));
                PolygonSplit::Split(ConvexPolygon::new(f), ConvexPolygon::new(b))
            }
        }
    }

    /// Split by `plane` into `(front part, back part)`.
    ///
    /// - Vertices within `tol.plane_abs()` are On; if no vertex is strictly on one side,
    ///   the whole polygon (a clone) goes to the other side.
    /// - No slivers: if a part would have area `< tol.area_abs()`, the whole polygon goes
    ///   to the other side (to the larger part's side when both are that small).
    /// - A polygon coplanar with the plane (all vertices On) goes to the front when its
    ///   normal agrees with `plane.n` (non-negative dot product), else to the back.
    pub fn split(&self, plane: &Plane, tol: &Tolerances) -> (Option<ConvexPolygon>, Option<ConvexPolygon>) {
        match self.split_exact(plane, tol) {
            PolygonSplit::Front => (Some(self.clone()), None),
            PolygonSplit::Back => (None, Some(self.clone())),
            PolygonSplit::Coplanar => {
                if dot(&self.area_vector(), &plane.n) >= 0.0 {
                    (Some(self.clone()), None)
                } else {
                    (None, Some(self.clone()))
                }
            }
            PolygonSplit::Split(f, b) => {
                let (af, ab) = (f.area(), b.area());
                let min = tol.area_abs();
                if af < min || ab < min {
                    if af >= ab {
                        (Some(self.clone()), None)
                    } else {
                        (None, Some(self.clone()))
                    }
                } else {
                    (Some(f), Some(b))
                }
            }
        }
    }

    /// True when `p` (assumed on the polygon's plane) is inside or within
    /// `tol.plane_abs()` of the boundary. Edges shorter than `tol.weld_abs()` are ignored
    /// (false if all are).
    pub fn contains_point(&self, p: &P3, tol: &Tolerances) -> bool {
        let n = self.normal();
        let eps = tol.plane_abs();
        let v = &self.verts;
        let mut tested = false;
        for i in 0..v.len() {
            let a = &v[i];
            let b = &v[(i + 1) % v.len()];
            let e = sub(b, a);
            let l = norm(&e);
            if !(l > tol.weld_abs()) {
                continue;
            }
            tested = true;
            if dot(&cross(&e, &sub(p, a)), &n) / l < -eps {
                return false;
            }
        }
        tested
    }

    /// Convexity and orientation check (for assertions): every vertex is on the inner side
    /// of every edge line, within `tol.plane_abs()`, and (if the area is at least
    /// `tol.area_abs()`) within `tol.plane_abs()` plus rounding allowance of the supporting
    /// plane. Edges shorter than `tol.weld_abs()` are skipped (their direction is noise).
    /// Polygons with fewer than 3 vertices fail.
    pub fn is_convex(&self, tol: &Tolerances) -> bool {
        if self.verts.len() < 3 {
            return false;
        }
        if let Some(fp) = FacePlane::new(self, tol)
            && self.verts.iter().any(|p| fp.test(p, tol).0.abs() > fp.test(p, tol).1)
        {
            return false;
        }
        self.verts.iter().all(|p| self.contains_point(p, tol))
    }

    /// Intersection with `other`, a convex polygon lying (approximately) in the same plane;
    /// `other`'s orientation does not matter. The result lies on `self`'s plane, is
    /// oriented like `self`, and is `None` when its area is below `tol.area_abs()`
    /// (disjoint, touching along an edge or at a point, or a sliver overlap).
    pub fn intersect_coplanar(&self, other: &ConvexPolygon, tol: &Tolerances) -> Option<ConvexPolygon> {
        let fr = Frame2::new(self)?;
        if other.verts.len() < 3 {
            return None;
        }
        let eps = tol.plane_abs();
        let clip = fr.ccw(other);
        let mut cur = fr.lift_poly(self);
        for k in 0..clip.len() {
            let (a, b) = (clip[k], clip[(k + 1) % clip.len()]);
            cur = split2(cur, a, b, eps, tol.weld_abs()).0?;
        }
        let poly = ConvexPolygon::new(cur.into_iter().map(|v| v.p).collect());
        (poly.area() >= tol.area_abs()).then_some(poly)
    }

    /// `self` minus the union of `holes` (all approximately coplanar with `self`; their
    /// orientation does not matter): disjoint convex pieces covering the remainder.
    ///
    /// Done in 2D (dropping the dominant normal axis, orientation kept): each hole is cut
    /// out of every remaining piece by successive splits along its edge lines; the parts
    /// outside an edge line are kept, the part inside all of them is discarded. Every new
    /// vertex is interpolated in 3D along an edge of `self` or of an earlier piece, so the
    /// pieces lie on `self`'s plane and keep `self`'s original vertices bit-for-bit.
    ///
    /// After each hole, pieces with area `< tol.area_abs()` are dropped and counted in
    /// `slivers` / `sliver_area`. Holes with area `< tol.area_abs()` are ignored. A
    /// degenerate `self` (area `< tol.area_abs()`) yields no pieces and one sliver.
    pub fn subtract(&self, holes: &[ConvexPolygon], tol: &Tolerances) -> Subtraction {
        self.subtract_in(Frame2::new(self), self.area(), holes, tol)
    }

    /// The area of `self` projected onto a plane with normal `n` (any length): the area
    /// a polygon lying on that plane within tolerance has in it.
    pub fn area_along(&self, n: &P3) -> f64 {
        let l = norm(n);
        if !(l > 0.0) {
            return 0.0;
        }
        dot(&self.area_vector(), n).abs() / l
    }

    /// [`subtract`](Self::subtract) in the projection along `n`, the normal of the plane
    /// `self` lies on (within tolerance), instead of along `self`'s own Newell normal.
    ///
    /// A cell's cross-section keeps the vertices the cut classified On, which lie up to
    /// the weld distance off the cutting plane: a section thinner than that (a thin cell
    /// cut across) has a Newell normal dominated by those offsets (greedy-1 under noise
    /// 1e-7: a 1.0e-6 strip in the plane y = 6.4 whose normal pointed along z), and
    /// subtracting in that normal's projection judges coverage in the wrong plane.
    /// Areas (the threshold and the dropped slivers) are those in the plane.
    pub fn subtract_along(&self, n: &P3, holes: &[ConvexPolygon], tol: &Tolerances) -> Subtraction {
        // Oriented like `self` in the projection, as `subtract` has it.
        let n = &if dot(&self.area_vector(), n) < 0.0 {
            scale(n, -1.0)
        } else {
            *n
        };
        let fr = axes(n).filter(|_| !self.verts.is_empty()).map(|(i, j, k)| Frame2 {
            o: self.verts[0],
            i,
            j,
            area_factor: norm(n) / n[k].abs(),
        });
        self.subtract_in(fr, self.area_along(n), holes, tol)
    }

    fn subtract_in(&self, fr: Option<Frame2>, area: f64, holes: &[ConvexPolygon], tol: &Tolerances) -> Subtraction {
        let min = tol.area_abs();
        let fr = match fr {
            Some(fr) if area >= min => fr,
            _ => {
                return Subtraction {
                    pieces: vec![],
                    slivers: 1,
                    sliver_area: area,
                };
            }
        };
        let eps = tol.plane_abs();
        let mut out = Subtraction::default();
        let mut pieces = vec![fr.lift_poly(self)];
        for hole in holes {
            if hole.verts.len() < 3 || hole.area() < min {
                continue;
            }
            let h = fr.ccw(hole);
            let (lo, hi) = bbox2(h.iter().copied());
            let mut next = Vec::with_capacity(pieces.len() + h.len());
            for piece in pieces {
                let (plo, phi) = bbox2(piece.iter().map(|v| v.uv));
                let apart = (0..2).any(|k| plo[k] > hi[k] - eps || phi[k] < lo[k] + eps);
                if apart {
                    next.push(piece);
                    continue;
                }
                let mut rem = Some(piece);
                for k in 0..h.len() {
                    let Some(r) = rem.take() else { break };
                    let (a, b) = (h[k], h[(k + 1) % h.len()]);
                    let (inside, outside) = split2(r, a, b, eps, tol.weld_abs());
                    next.extend(outside);
                    rem = inside;
                }
                // `rem`, if any, lies inside the hole: discarded.
            }
            pieces = Vec::with_capacity(next.len());
            for p in next {
                let a = fr.area3(&p);
                if a >= min {
                    pieces.push(p);
                } else {
                    out.slivers += 1;
                    out.sliver_area += a;
                }
            }
        }
        out.pieces = pieces
            .into_iter()
            .map(|p| ConvexPolygon::new(p.into_iter().map(|v| v.p).collect()))
            .collect();
        out
    }
}

/// A polygon's plane with its rounding-error allowance: with coordinate rounding unit
/// `u = ε·max|coord|` and width `w = 2·area/perimeter`, the Newell normal is uncertain by
/// ~`u/w`, so a point `p` may appear up to `8u(1 + |p − centroid|/w)` off the plane beyond
/// the geometric tolerance `plane_abs()`.
pub(crate) struct FacePlane {
    plane: Plane,
    c: P3,
    u: f64,
    inv_w: f64,
}

impl FacePlane {
    /// `None` for faces with area below `tol.area_abs()`.
    pub(crate) fn new(f: &ConvexPolygon, tol: &Tolerances) -> Option<Self> {
        let area = f.area();
        if !(area >= tol.area_abs()) {
            return None;
        }
        let n = f.verts.len();
        let per: f64 = (0..n).map(|k| norm(&sub(&f.verts[(k + 1) % n], &f.verts[k]))).sum();
        let m = f
            .verts
            .iter()
            .flat_map(|v| v.iter())
            .fold(0.0f64, |m, x| m.max(x.abs()));
        let c = f.centroid();
        Some(FacePlane {
            plane: Plane::from_normal_point(f.normal(), &c),
            c,
            u: f64::EPSILON * m,
            inv_w: per / (2.0 * area),
        })
    }

    /// `(signed distance, allowed distance)` of `p`.
    pub(crate) fn test(&self, p: &P3, tol: &Tolerances) -> (f64, f64) {
        let d = self.plane.signed_distance(p);
        let slack = tol.snap_abs() + 8.0 * self.u * (1.0 + norm(&sub(p, &self.c)) * self.inv_w);
        (d, slack)
    }

    /// [`test`](Self::test)'s pair only when `p` is farther in front than allowed. The
    /// allowance is at least `snap_abs + 8u` (its distance term is never negative), so a
    /// point within that needs no distance to the centroid: same answer, fewer roots.
    #[inline]
    pub(crate) fn violation(&self, p: &P3, tol: &Tolerances) -> Option<(f64, f64)> {
        let d = self.plane.signed_distance(p);
        if d <= tol.snap_abs() + 8.0 * self.u {
            return None;
        }
        let (_, slack) = self.test(p, tol);
        (d > slack).then_some((d, slack))
    }
}

/// A vertex in the 2D working frame, carrying its 3D position.
#[derive(Clone, Copy, Debug)]
struct V2 {
    uv: [f64; 2],
    p: P3,
}

/// Projection onto a coordinate plane (dominant normal axis dropped, orientation kept),
/// relative to an origin on the polygon to avoid cancellation far from the world origin.
struct Frame2 {
    o: P3,
    i: usize,
    j: usize,
    /// 2D area × this = 3D area.
    area_factor: f64,
}

impl Frame2 {
    fn new(poly: &ConvexPolygon) -> Option<Self> {
        let n = poly.area_vector();
        let (i, j, k) = axes(&n)?;
        Some(Frame2 {
            o: poly.verts[0],
            i,
            j,
            area_factor: norm(&n) / n[k].abs(),
        })
    }

    #[inline]
    fn proj(&self, p: &P3) -> [f64; 2] {
        [p[self.i] - self.o[self.i], p[self.j] - self.o[self.j]]
    }

    fn lift_poly(&self, poly: &ConvexPolygon) -> Vec<V2> {
        poly.verts
            .iter()
            .map(|p| V2 {
                uv: self.proj(p),
                p: *p,
            })
            .collect()
    }

    /// Projected vertices of `poly`, counter-clockwise, without zero-length edges.
    fn ccw(&self, poly: &ConvexPolygon) -> Vec<[f64; 2]> {
        let mut h: Vec<[f64; 2]> = poly.verts.iter().map(|p| self.proj(p)).collect();
        h.dedup();
        while h.len() > 1 && h.first() == h.last() {
            h.pop();
        }
        if area2(h.iter().copied()) < 0.0 {
            h.reverse();
        }
        h
    }

    /// Whether `poly`'s projected loop is convex and counter-clockwise for certain: every
    /// turn is to the left or straight, and each coordinate changes direction at most
    /// twice around the loop (which rules out a loop that winds more than once). No
    /// allocation: the fast path of [`ConvexPolygon::convexity_defect`].
    fn convex_ccw(&self, poly: &ConvexPolygon) -> bool {
        let v = &poly.verts;
        let n = v.len();
        let p = |k: usize| self.proj(&v[k % n]);
        let mut flips = [0usize; 2];
        let mut last = [0.0f64; 2];
        for k in 0..=n {
            let (a, b, c) = (p(k), p(k + 1), p(k + 2));
            let (e, f) = ([b[0] - a[0], b[1] - a[1]], [c[0] - b[0], c[1] - b[1]]);
            if e[0] * f[1] - e[1] * f[0] < 0.0 {
                return false;
            }
            for d in 0..2 {
                if e[d] != 0.0 {
                    if last[d] != 0.0 && (e[d] > 0.0) != (last[d] > 0.0) {
                        flips[d] += 1;
                    }
                    last[d] = e[d];
                }
            }
        }
        // The loop is walked once plus one edge, so a direction change at the start is
        // seen once: a convex loop changes each coordinate's direction exactly twice.
        flips[0] <= 2 && flips[1] <= 2
    }

    fn area3(&self, p: &[V2]) -> f64 {
        area2(p.iter().map(|v| v.uv)).abs() * self.area_factor
    }
}

/// Signed area of a 2D polygon (positive counter-clockwise).
fn area2(pts: impl Iterator<Item = [f64; 2]> + Clone) -> f64 {
    let mut it = pts.clone();
    let Some(o) = it.next() else { return 0.0 };
    let mut s = 0.0;
    let mut prev: Option<[f64; 2]> = None;
    for p in it {
        if let Some(q) = prev {
            s += (q[0] - o[0]) * (p[1] - o[1]) - (q[1] - o[1]) * (p[0] - o[0]);
        }
        prev = Some(p);
    }
    0.5 * s
}

/// Convex hull of 2D points, counter-clockwise (Andrew's monotone chain; collinear
/// points dropped).
fn hull2(mut pts: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    pts.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let turn = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    let mut h: Vec<[f64; 2]> = Vec::with_capacity(2 * pts.len());
    // Lower chain left to right, then upper chain right to left; each drops its last
    // point (the next chain's first).
    for chain in [pts.clone(), pts.into_iter().rev().collect()] {
        let start = h.len();
        for p in chain {
            while h.len() >= start + 2 && turn(h[h.len() - 2], h[h.len() - 1], p) <= 0.0 {
                h.pop();
            }
            h.push(p);
        }
        h.pop();
    }
    h
}

fn bbox2(pts: impl Iterator<Item = [f64; 2]>) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in pts {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// Split a 2D convex polygon by the directed line `a → b` into (left = inside,
/// right = outside) parts, vertices within `eps` of the line being On. A line shorter
/// than `min_len` (direction is noise) constrains nothing: everything is inside.
#[allow(clippy::type_complexity)]
fn split2(poly: Vec<V2>, a: [f64; 2], b: [f64; 2], eps: f64, min_len: f64) -> (Option<Vec<V2>>, Option<Vec<V2>>) {
    let e = [b[0] - a[0], b[1] - a[1]];
    let len = e[0].hypot(e[1]);
    if !(len > min_len) {
        return (Some(poly), None);
    }
    let inv = 1.0 / len;
    let d: Vec<f64> = poly
        .iter()
        .map(|q| (e[0] * (q.uv[1] - a[1]) - e[1] * (q.uv[0] - a[0])) * inv)
        .collect();
    let left = d.iter().any(|&x| x > eps);
    let right = d.iter().any(|&x| x < -eps);
    if !right {
        return (Some(poly), None);
    }
    if !left {
        return (None, Some(poly));
    }
    let sides: Vec<Side> = d
        .iter()
        .map(|&x| {
            if x > eps {
                Side::Front
            } else if x < -eps {
                Side::Back
            } else {
                Side::On
            }
        })
        .collect();
    let (l, r) = walk_split(&poly, &sides, |i, j| {
        let (p, dp, q, dq) = (&poly[i], d[i], &poly[j], d[j]);
        let (a, da, b, db) = if lex_less(&q.uv, &p.uv) {
            (q, dq, p, dp)
        } else {
            (p, dp, q, dq)
        };
        let t = da / (da - db);
        V2 {
            uv: [a.uv[0] + t * (b.uv[0] - a.uv[0]), a.uv[1] + t * (b.uv[1] - a.uv[1])],
            p: [
                a.p[0] + t * (b.p[0] - a.p[0]),
                a.p[1] + t * (b.p[1] - a.p[1]),
                a.p[2] + t * (b.p[2] - a.p[2]),
            ],
        }
    });
    (Some(l), Some(r))
}

#[cfg(test)]
mod tests {
    use super::super::testutil::{Frame, Rng, frames};
    use super::*;

    fn poly(fr: &Frame, pts: &[[f64; 2]]) -> ConvexPolygon {
        ConvexPolygon::new(pts.iter().map(|p| fr.apply([p[0], p[1], 0.0])).collect())
    }

    fn square(fr: &Frame, x0: f64, y0: f64, x1: f64, y1: f64) -> ConvexPolygon {
        poly(fr, &[[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    }

    #[test]
    fn convexity_defect_is_zero_on_convex_loops_and_the_missing_area_otherwise() {
        for (fr, _) in &frames(1.0) {
            let s2 = fr.scale * fr.scale;
            // Convex, also with a straight vertex and a repeated-direction run.
            for pts in [
                &[[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]][..],
                &[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]][..],
                &[[0.0, 0.0], [3.0, 0.0], [4.0, 1.0], [3.0, 2.0], [1.0, 2.0], [-1.0, 1.0]][..],
            ] {
                let q = poly(fr, pts);
                assert!(
                    q.convexity_defect() <= 1e-8 * s2,
                    "{}: {}",
                    fr.name,
                    q.convexity_defect()
                );
            }
            // Reflex vertex: the notch's area is missing.
            let notch = poly(fr, &[[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [1.0, 1.0], [0.0, 2.0]]);
            assert!((notch.convexity_defect() / s2 - 1.0).abs() < 1e-6, "{}", fr.name);
            // A bowtie (the loop crosses itself): hull 1, signed area 0 (no Newell normal).
            let bowtie = poly(fr, &[[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]]);
            assert!((bowtie.convexity_defect() / s2 - 1.0).abs() < 1e-6, "{}", fr.name);
            // An uneven bowtie (the fuzz find's face): hull 2, lobes 1.125 and -0.125.
            let bowtie = poly(fr, &[[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 0.5]]);
            let d = bowtie.convexity_defect() / s2;
            assert!(d > 0.5, "{}: {d}", fr.name);
            // A pentagram: every turn to the left, yet it winds twice.
            let star: Vec<[f64; 2]> = (0..5)
                .map(|k| {
                    let t = std::f64::consts::TAU * (2 * k) as f64 / 5.0;
                    [t.cos(), t.sin()]
                })
                .collect();
            let star = poly(fr, &star);
            assert!(
                star.convexity_defect() > 0.1 * s2,
                "{}: {}",
                fr.name,
                star.convexity_defect()
            );
        }
    }

    #[test]
    fn verts_inline_up_to_three_and_behave_like_a_vec() {
        assert_eq!(std::mem::size_of::<ConvexPolygon>(), 80);
        let pts: Vec<P3> = (0..7).map(|k| [k as f64, -(k as f64), 0.5 * k as f64]).collect();
        for n in 0..pts.len() {
            let v = Verts::from_vec(pts[..n].to_vec());
            assert_eq!(v.is_inline(), n <= INLINE_VERTS, "{n} vertices");
            assert_eq!(&v[..], &pts[..n]);
            // The same values whichever way they are held: equality, serde, Debug.
            let heap = Verts(VertsRepr::Heap(pts[..n].to_vec()));
            assert_eq!(v, heap);
            let json = serde_json::to_string(&v).unwrap();
            assert_eq!(json, serde_json::to_string(&pts[..n].to_vec()).unwrap());
            assert_eq!(serde_json::from_str::<Verts>(&json).unwrap(), v);
            assert_eq!(format!("{v:?}"), format!("{:?}", &pts[..n]));
            let mut h = heap.clone();
            h.shrink_to_fit();
            assert_eq!(h.is_inline(), n <= INLINE_VERTS);
            assert_eq!(h, v);
            assert_eq!(v.clone().into_vec(), pts[..n].to_vec());
        }
        // Mutation across the inline/heap boundary, against a Vec.
        let (mut v, mut w) = (Verts::new(), Vec::new());
        for (k, p) in pts.iter().enumerate() {
            v.push(*p);
            w.push(*p);
            if k % 3 == 2 {
                v.insert(1, [9.0; 3]);
                w.insert(1, [9.0; 3]);
            }
            assert_eq!(v, w);
        }
        while !w.is_empty() {
            assert_eq!(v.remove(w.len() / 2), w.remove(w.len() / 2));
            assert_eq!(v.pop(), w.pop());
            assert_eq!(v, w);
        }
        assert_eq!(v.pop(), None);
        let c: Verts = pts.iter().copied().collect();
        assert_eq!(c, pts);
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(1e-300)
    }

    fn assert_close(a: f64, b: f64, r: f64, what: &str) {
        assert!(rel(a, b) <= r, "{what}: {a} vs {b} (rel {:e})", rel(a, b));
    }

    /// All pieces convex, on the plane of `base`, oriented like it, pairwise disjoint.
    fn check_pieces(base: &ConvexPolygon, pieces: &[ConvexPolygon], tol: &Tolerances, name: &str) {
        let n = base.normal();
        let pl = base.plane();
        for (k, p) in pieces.iter().enumerate() {
            assert!(p.is_convex(tol), "{name}: piece {k} not convex: {p:?}");
            assert!(dot(&p.normal(), &n) > 0.999_999, "{name}: piece {k} flipped");
            for v in &p.verts {
                assert!(
                    pl.signed_distance(v).abs() <= tol.plane_abs(),
                    "{name}: piece {k} off plane"
                );
            }
            for q in &pieces[k + 1..] {
                assert!(p.intersect_coplanar(q, tol).is_none(), "{name}: pieces overlap");
            }
        }
    }

    #[test]
    fn area_normal_centroid() {
        for (fr, tol) in frames(2.0f64.sqrt()) {
            let sq = square(&fr, 0.0, 0.0, 1.0, 1.0);
            assert_close(sq.area(), fr.area(1.0), 1e-9, fr.name);
            let n = sq.normal();
            let nz = fr.apply_vec([0.0, 0.0, 1.0 / fr.scale]);
            assert!((dot(&n, &nz) - 1.0).abs() < 1e-12);
            let c = sq.centroid();
            let e = fr.apply([0.5, 0.5, 0.0]);
            assert!(norm(&sub(&c, &e)) < 1e-12 * fr.scale + 1e-9, "{}", fr.name);
            let tri = poly(&fr, &[[0.0, 0.0], [3.0, 0.0], [0.0, 3.0]]);
            assert_close(tri.area(), fr.area(4.5), 1e-9, fr.name);
            assert!(norm(&sub(&tri.centroid(), &fr.apply([1.0, 1.0, 0.0]))) < 1e-9 * fr.scale);
            // A collinear (T-)vertex changes nothing.
            let t = poly(&fr, &[[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
            assert_close(t.area(), fr.area(1.0), 1e-9, fr.name);
            assert!(t.is_convex(&tol));
            assert!(
                sq.reversed()
                    .normal()
                    .iter()
                    .zip(&n)
                    .all(|(a, b)| (a + b).abs() < 1e-12)
            );
        }
    }

    #[test]
    fn split_preserves_area() {
        // A regular hexagon, split by random planes through random interior points.
        for (fr, tol) in frames(2.0) {
            let hex: Vec<[f64; 2]> = (0..6)
                .map(|k| {
                    let a = k as f64 * std::f64::consts::PI / 3.0;
                    [a.cos(), a.sin()]
                })
                .collect();
            let h = poly(&fr, &hex);
            let total = h.area();
            let mut rng = Rng::new(11);
            let mut crossed = 0;
            for _ in 0..300 {
                let n = rng.unit();
                let p = [rng.f64() - 0.5, rng.f64() - 0.5, 0.0];
                let pl = fr.plane(n, p);
                let (f, b) = h.split(&pl, &tol);
                let af = f.as_ref().map_or(0.0, |x| x.area());
                let ab = b.as_ref().map_or(0.0, |x| x.area());
                assert_close(af + ab, total, 1e-9, fr.name);
                if let (Some(f), Some(b)) = (&f, &b) {
                    crossed += 1;
                    assert!(f.is_convex(&tol) && b.is_convex(&tol), "{}", fr.name);
                    for v in &f.verts {
                        assert!(pl.signed_distance(v) >= -tol.plane_abs());
                    }
                    for v in &b.verts {
                        assert!(pl.signed_distance(v) <= tol.plane_abs());
                    }
                    // Both parts share the two new vertices bit-for-bit.
                    let shared = f.verts.iter().filter(|v| b.verts.contains(v)).count();
                    assert_eq!(shared, 2);
                }
            }
            assert!(crossed > 100, "{}: only {crossed} crossings", fr.name);
        }
    }

    #[test]
    fn split_grazing_sliver_and_coplanar() {
        for (fr, tol) in frames(2.0f64.sqrt()) {
            let sq = square(&fr, 0.0, 0.0, 1.0, 1.0);
            // Through a vertex only: x + y = 0 touches (0,0).
            let pl = fr.plane([1.0, 1.0, 0.0], [0.0, 0.0, 0.0]);
            assert_eq!(sq.split_exact(&pl, &tol), PolygonSplit::Front);
            assert_eq!(sq.split(&pl, &tol), (Some(sq.clone()), None));
            // Along an edge: x = 1, polygon behind.
            let pl = fr.plane([1.0, 0.0, 0.0], [1.0, 0.0, 0.0]);
            assert_eq!(sq.split(&pl, &tol), (None, Some(sq.clone())), "{}", fr.name);
            // Cuts a corner of area 0.5e-12 (< area_abs = 2e-10 · scale²): no sliver.
            let pl = fr.plane([1.0, 1.0, 0.0], [1.0 - 1e-6, 1.0, 0.0]);
            assert!(
                matches!(sq.split_exact(&pl, &tol), PolygonSplit::Split(..)),
                "{}",
                fr.name
            );
            assert_eq!(sq.split(&pl, &tol), (None, Some(sq.clone())), "{}", fr.name);
            // Coplanar: goes where its normal points.
            let pl = fr.plane([0.0, 0.0, 1.0], [0.3, 0.3, 0.0]);
            assert_eq!(sq.split_exact(&pl, &tol), PolygonSplit::Coplanar);
            assert_eq!(sq.split(&pl, &tol), (Some(sq.clone()), None));
            assert_eq!(sq.split(&pl.flipped(), &tol), (None, Some(sq.clone())));
            // A real split through two opposite vertices: both triangles, shared diagonal.
            let pl = fr.plane([1.0, -1.0, 0.0], [0.0, 0.0, 0.0]);
            let (f, b) = sq.split(&pl, &tol);
            let (f, b) = (f.unwrap(), b.unwrap());
            assert_eq!((f.len(), b.len()), (3, 3));
            assert_close(f.area(), fr.area(0.5), 1e-9, fr.name);
            assert_close(b.area(), fr.area(0.5), 1e-9, fr.name);
        }
    }

    #[test]
    fn intersect_coplanar_cases() {
        for (fr, tol) in frames(2.0f64.sqrt()) {
            let a = square(&fr, 0.0, 0.0, 1.0, 1.0);
            let b = square(&fr, 0.5, 0.5, 1.5, 1.5);
            let i = a.intersect_coplanar(&b, &tol).unwrap();
            assert_close(i.area(), fr.area(0.25), 1e-9, fr.name);
            assert!(i.is_convex(&tol));
            assert!(dot(&i.normal(), &a.normal()) > 0.999_999);
            // Other orientation of `other` does not matter.
            let i2 = a.intersect_coplanar(&b.reversed(), &tol).unwrap();
            assert_close(i2.area(), fr.area(0.25), 1e-9, fr.name);
            // Oriented like self.
            let i3 = a.reversed().intersect_coplanar(&b, &tol).unwrap();
            assert!(dot(&i3.normal(), &a.normal()) < -0.999_999);
            // Touching along an edge / at a corner / disjoint: None.
            assert!(a.intersect_coplanar(&square(&fr, 1.0, 0.0, 2.0, 1.0), &tol).is_none());
            assert!(a.intersect_coplanar(&square(&fr, 1.0, 1.0, 2.0, 2.0), &tol).is_none());
            assert!(a.intersect_coplanar(&square(&fr, 3.0, 0.0, 4.0, 1.0), &tol).is_none());
            // Contained: the smaller one.
            let s = square(&fr, 0.25, 0.25, 0.75, 0.5);
            let i = a.intersect_coplanar(&s, &tol).unwrap();
            assert_close(i.area(), fr.area(0.125), 1e-9, fr.name);
            let i = s.intersect_coplanar(&a, &tol).unwrap();
            assert_close(i.area(), fr.area(0.125), 1e-9, fr.name);
            // Triangle × square.
            let t = poly(&fr, &[[-1.0, -1.0], [2.0, -1.0], [-1.0, 2.0]]);
            let i = a.intersect_coplanar(&t, &tol).unwrap();
            assert_close(i.area(), fr.area(0.5), 1e-9, fr.name);
            let t = poly(&fr, &[[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]]);
            let i = a.intersect_coplanar(&t, &tol).unwrap();
            assert_close(i.area(), fr.area(1.0), 1e-9, fr.name);
            let t = poly(&fr, &[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
            let i = a.intersect_coplanar(&t, &tol).unwrap();
            assert_close(i.area(), fr.area(0.5), 1e-9, fr.name);
            let t = poly(&fr, &[[0.5, -0.25], [1.25, 0.5], [0.5, 1.25], [-0.25, 0.5]]);
            let i = a.intersect_coplanar(&t, &tol).unwrap();
            assert_close(i.area(), fr.area(1.0 - 4.0 * 0.03125), 1e-9, fr.name);
            assert_eq!(i.len(), 8);
        }
    }

    /// Point-sampling check that `pieces` cover exactly `base` minus `holes` (away from
    /// boundaries) in local coordinates of `fr`.
    fn check_cover(fr: &Frame, pieces: &[ConvexPolygon], holes: &[[f64; 4]], tol: &Tolerances) {
        let m = 1e-6;
        let grid = 37;
        for i in 0..grid {
            for j in 0..grid {
                let (x, y) = ((i as f64 + 0.5) / grid as f64, (j as f64 + 0.5) / grid as f64);
                let near = |h: &[f64; 4]| {
                    (x - h[0]).abs() < m || (x - h[2]).abs() < m || (y - h[1]).abs() < m || (y - h[3]).abs() < m
                };
                if holes.iter().any(near) {
                    continue;
                }
                let in_hole = holes.iter().any(|h| x > h[0] && x < h[2] && y > h[1] && y < h[3]);
                let p = fr.apply([x, y, 0.0]);
                let count = pieces.iter().filter(|q| q.contains_point(&p, tol)).count();
                assert!(count <= 1, "{}: ({x}, {y}) in {count} pieces", fr.name);
                assert_eq!(count > 0, !in_hole, "{}: ({x}, {y}) covered {count} times", fr.name);
            }
        }
    }

    #[test]
    fn subtract_cases() {
        for (fr, tol) in frames(2.0f64.sqrt()) {
            let sq = square(&fr, 0.0, 0.0, 1.0, 1.0);
            let a = |x: f64| fr.area(x);
            let sum = |s: &Subtraction| s.pieces.iter().map(|p| p.area()).sum::<f64>();

            // No holes: itself.
            let s = sq.subtract(&[], &tol);
            assert_eq!(s.pieces, vec![sq.clone()]);

            // Centred smaller square.
            let hole = [0.25, 0.25, 0.75, 0.75];
            let h = square(&fr, hole[0], hole[1], hole[2], hole[3]);
            let s = sq.subtract(std::slice::from_ref(&h), &tol);
            assert_close(sum(&s), a(0.75), 1e-9, fr.name);
            assert_eq!((s.slivers, s.pieces.len()), (0, 4));
            check_pieces(&sq, &s.pieces, &tol, fr.name);
            check_cover(&fr, &s.pieces, &[hole], &tol);
            // Original corners kept bit-for-bit.
            for v in &sq.verts {
                assert!(s.pieces.iter().any(|p| p.verts.contains(v)));
            }
            // Hole orientation does not matter.
            let s2 = sq.subtract(&[h.reversed()], &tol);
            assert_close(sum(&s2), a(0.75), 1e-9, fr.name);

            // Minus itself (and a larger one): empty, no slivers.
            let s = sq.subtract(std::slice::from_ref(&sq), &tol);
            assert!(s.pieces.is_empty() && s.slivers == 0, "{}: {s:?}", fr.name);
            let s = sq.subtract(&[square(&fr, -1.0, -1.0, 2.0, 2.0)], &tol);
            assert!(s.pieces.is_empty() && s.slivers == 0);

            // Two overlapping holes: union area 0.25 + 0.25 - 0.0625.
            let h1 = [0.1, 0.1, 0.6, 0.6];
            let h2 = [0.35, 0.35, 0.85, 0.85];
            let hs = [
                square(&fr, h1[0], h1[1], h1[2], h1[3]),
                square(&fr, h2[0], h2[1], h2[2], h2[3]),
            ];
            let s = sq.subtract(&hs, &tol);
            assert_close(sum(&s), a(1.0 - (0.25 + 0.25 - 0.0625)), 1e-9, fr.name);
            assert_eq!(s.slivers, 0);
            check_pieces(&sq, &s.pieces, &tol, fr.name);
            check_cover(&fr, &s.pieces, &[h1, h2], &tol);

            // Hole sticking out, hole disjoint, hole sharing an edge.
            let h3 = [0.5, -0.5, 1.5, 0.5];
            let s = sq.subtract(
                &[square(&fr, h3[0], h3[1], h3[2], h3[3]), square(&fr, 2.0, 2.0, 3.0, 3.0)],
                &tol,
            );
            assert_close(sum(&s), a(0.75), 1e-9, fr.name);
            check_pieces(&sq, &s.pieces, &tol, fr.name);
            check_cover(&fr, &s.pieces, &[h3], &tol);
            let s = sq.subtract(&[square(&fr, 1.0, 0.0, 2.0, 1.0)], &tol);
            assert_eq!(s.pieces.len(), 1);
            assert_close(sum(&s), a(1.0), 1e-9, fr.name);

            // A hole leaving a strip of width 1e-4 keeps it. Tolerances (local units):
            // plane 1.4e-9, area 2e-10. A second hole cutting the strip down to
            // 1e-8 × 0.01 (area 1e-10) makes it a counted sliver.
            let s = sq.subtract(&[square(&fr, -1.0, -1.0, 1.0 - 1e-4, 2.0)], &tol);
            assert_eq!((s.pieces.len(), s.slivers), (1, 0));
            assert_close(sum(&s), a(1e-4), 1e-5, fr.name);
            let hs = [
                square(&fr, -1.0, -1.0, 1.0 - 1e-8, 2.0),
                square(&fr, 0.5, -1.0, 2.0, 0.99),
            ];
            let s = sq.subtract(&hs[..1], &tol);
            assert_eq!((s.pieces.len(), s.slivers), (1, 0), "{}", fr.name);
            let s = sq.subtract(&hs, &tol);
            assert!(s.pieces.is_empty(), "{}: {s:?}", fr.name);
            assert_eq!(s.slivers, 1, "{}", fr.name);
            assert_close(s.sliver_area, a(1e-10), 0.05, fr.name);

            // A rotated (diamond) hole.
            let d = poly(&fr, &[[0.5, 0.2], [0.8, 0.5], [0.5, 0.8], [0.2, 0.5]]);
            let s = sq.subtract(std::slice::from_ref(&d), &tol);
            assert_close(sum(&s), a(1.0 - 0.18), 1e-9, fr.name);
            check_pieces(&sq, &s.pieces, &tol, fr.name);
        }
    }

    #[test]
    fn subtract_random_holes_area_matches_sampling() {
        // Random axis-aligned holes; the remainder's area is compared with the area of
        // the complement of the union computed on the exact arrangement grid.
        for (fr, tol) in frames(2.0f64.sqrt()) {
            let mut rng = Rng::new(5);
            for _ in 0..20 {
                let mut rects = vec![];
                for _ in 0..4 {
                    let (x0, y0) = (rng.f64() * 1.2 - 0.1, rng.f64() * 1.2 - 0.1);
                    let (w, h) = (0.05 + 0.4 * rng.f64(), 0.05 + 0.4 * rng.f64());
                    rects.push([x0, y0, x0 + w, y0 + h]);
                }
                let sq = square(&fr, 0.0, 0.0, 1.0, 1.0);
                let holes: Vec<_> = rects.iter().map(|r| square(&fr, r[0], r[1], r[2], r[3])).collect();
                let s = sq.subtract(&holes, &tol);
                // Exact uncovered area via the coordinate arrangement.
                let mut xs = vec![0.0, 1.0];
                let mut ys = vec![0.0, 1.0];
                for r in &rects {
                    xs.extend([r[0].clamp(0.0, 1.0), r[2].clamp(0.0, 1.0)]);
                    ys.extend([r[1].clamp(0.0, 1.0), r[3].clamp(0.0, 1.0)]);
                }
                xs.sort_by(f64::total_cmp);
                ys.sort_by(f64::total_cmp);
                let mut free = 0.0;
                for i in 0..xs.len() - 1 {
                    for j in 0..ys.len() - 1 {
                        let (cx, cy) = ((xs[i] + xs[i + 1]) / 2.0, (ys[j] + ys[j + 1]) / 2.0);
                        if !rects.iter().any(|r| cx > r[0] && cx < r[2] && cy > r[1] && cy < r[3]) {
                            free += (xs[i + 1] - xs[i]) * (ys[j + 1] - ys[j]);
                        }
                    }
                }
                let got: f64 = s.pieces.iter().map(|p| p.area()).sum::<f64>() + s.sliver_area;
                assert!(
                    (got - fr.area(free)).abs() <= 1e-9 * fr.area(1.0),
                    "{}: {got} vs {free}",
                    fr.name
                );
                check_pieces(&sq, &s.pieces, &tol, fr.name);
                check_cover(&fr, &s.pieces, &rects, &tol);
            }
        }
    }
    /// A cell's cross-section thinner than the weld distance whose On vertices lie off the
    /// cutting plane (greedy-1 under noise 1e-7: plane y ≈ 6.4, a strip 1.25 long and
    /// ~1e-6 high in z, one vertex 1.8e-6 off the plane in y), and the wall below it whose
    /// top edge the strip lies above. The strip's Newell normal points along z, so the
    /// subtraction in its own frame projects along z and finds the strip covered; along
    /// the plane's normal it stays open, with its area in the plane.
    #[test]
    fn subtract_along_the_cutting_plane_of_a_thin_section() {
        let tol = Tolerances::for_scale(22.9).sealing();
        let n = [-3.136701611753323e-7, 0.9999999999997726, 5.969635219290914e-7];
        let section = ConvexPolygon::new(vec![
            [11.250001642860228, 6.399997716012294, 3.2999991338684707],
            [11.24999638092013, 6.399997716029253, 3.299999133859099],
            [10.750000465528286, 6.399999327497567, 3.2999982433772073],
            [10.003568869148847, 6.399997325042456, 3.300000923422182],
            [10.017754727421469, 6.399997329492136, 3.3000009252266675],
        ]);
        let wall = ConvexPolygon::new(vec![
            [7.1500008298088105, 6.399996429963556, 3.300000509891153],
            [10.75000046552884, 6.3999975591773755, 3.2999982433761517],
            [10.749999852123404, 6.39999952915519, 9.480539597802764e-7],
        ]);
        let av = section.area_vector();
        assert!(
            av[2].abs() > av[1].abs(),
            "the section's own normal must point along z: {av:?}"
        );
        let own = section.subtract(std::slice::from_ref(&wall), &tol);
        let own_open: f64 = own.pieces.iter().map(|q| q.area()).sum();
        assert!(
            own_open < 0.5 * section.area(),
            "in its own frame the strip looks covered"
        );
        let along = section.subtract_along(&n, std::slice::from_ref(&wall), &tol);
        let sa = section.area_along(&n);
        assert!((sa - 1.0161e-6).abs() < 1e-9, "area in the plane {sa:e}");
        let open: f64 = along.pieces.iter().map(|q| q.area_along(&n)).sum();
        assert!(open > 0.99 * sa, "open {open:e} of {sa:e}");
        // Either orientation of the normal gives the same pieces.
        let back = section.subtract_along(&scale(&n, -1.0), std::slice::from_ref(&wall), &tol);
        assert_eq!(back.pieces, along.pieces);
    }

    #[test]
    fn adjacent_polygons_get_identical_crossing_points() {
        // Two squares sharing the edge x = 1 (traversed in opposite directions) split by
        // random planes: the point on the shared edge is bit-identical in both.
        for (fr, tol) in frames(5f64.sqrt()) {
            let a = square(&fr, 0.0, 0.0, 1.0, 1.0);
            let b = square(&fr, 1.0, 0.0, 2.0, 1.0);
            let mut rng = Rng::new(9);
            let mut checked = 0;
            for _ in 0..200 {
                let pl = fr.plane(rng.unit(), [1.0, rng.f64(), 0.0]);
                let (PolygonSplit::Split(af, _), PolygonSplit::Split(bf, _)) =
                    (a.split_exact(&pl, &tol), b.split_exact(&pl, &tol))
                else {
                    continue;
                };
                let on_edge = |p: &ConvexPolygon| -> Vec<P3> {
                    p.verts
                        .iter()
                        .filter(|v| !a.verts.contains(v) && !b.verts.contains(v))
                        .copied()
                        .collect()
                };
                let common = on_edge(&af).iter().filter(|v| on_edge(&bf).contains(v)).count();
                assert_eq!(common, 1, "{}", fr.name);
                checked += 1;
            }
            assert!(checked > 50);
        }
    }

    #[test]
    fn degenerate_inputs() {
        let tol = Tolerances::for_scale(1.0);
        let e = ConvexPolygon::new(vec![]);
        assert_eq!(e.reversed(), e);
        assert_eq!(e.area(), 0.0);
        let tiny = ConvexPolygon::new(vec![[0.0; 3], [1e-9, 0.0, 0.0], [0.0, 1e-9, 0.0]]);
        assert!(!tiny.contains_point(&[5.0, 5.0, 0.0], &tol));
        let s = tiny.subtract(&[], &tol);
        assert!(s.pieces.is_empty() && s.slivers == 1);
        let line = ConvexPolygon::new(vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]);
        assert_eq!(line.normal(), [0.0; 3]);
        assert!(line.intersect_coplanar(&line, &tol).is_none());
    }
}
