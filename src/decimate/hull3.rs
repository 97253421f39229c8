//! Incremental 3D convex hull with exact orientation tests, used to keep a merged cell's
//! vertex set small (its convex hull vertices) and to merge two such sets cheaply.
//!
//! Faces are triangles, counter-clockwise seen from outside, so a point `p` sees face
//! `abc` iff [`orient3d`]`(a, b, c, p) > 0` — decided exactly. A point that sees no face is
//! inside or on the hull and is not inserted, so inserting points that add nothing leaves
//! the hull *bit for bit* unchanged; [`Hull3::insert_all`] reports whether anything changed.
//! Coplanar neighbouring triangles are allowed; a vertex set may then hold a few points
//! that are not strictly extreme (e.g. on a facet), which changes no projection.
//!
//! Cost: inserting one point scans all faces (O(h) for h hull vertices) and rebuilds the
//! visible cap; merging a hull of `k` vertices into one of `h` is O(k·h). Cells here have
//! hulls of tens to a few hundred vertices.

use crate::predicates::{P3, in_filter_range, orient3d, orient3d_in_range};
use std::collections::{HashMap, HashSet};

/// A convex hull: points and outward triangles over them.
#[derive(Clone, Debug, Default)]
pub struct Hull3 {
    /// Hull vertices (after [`Hull3::compact`]: exactly those used by `faces`).
    pub pts: Vec<P3>,
    /// Triangles, counter-clockwise from outside. Empty when the points are coplanar
    /// (a degenerate hull); then `pts` holds all distinct input points.
    faces: Vec<[u32; 3]>,
}

use crate::base::vec::{cross, dot, sub};

fn bits(p: &P3) -> [u64; 3] {
    [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()]
}

impl Hull3 {
    /// Convex hull of a point set.
    pub fn new(points: &[P3]) -> Self {
        let mut pts: Vec<P3> = Vec::with_capacity(points.len());
        let mut seen = std::collections::HashSet::with_capacity(points.len());
        for p in points {
            if seen.insert(bits(p)) {
                pts.push(*p);
            }
        }
        let Some(simplex) = initial_simplex(&pts) else {
            return Hull3 { pts, faces: Vec::new() };
        };
        let [a, b, c, d] = simplex;
        let mut h = Hull3 {
            pts: vec![pts[a], pts[b], pts[c], pts[d]],
            // (a, b, c, d) positively oriented: outward faces as in
            // `ConvexPolyhedron::tetrahedron`.
            faces: vec![[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]],
        };
        for (i, p) in pts.iter().enumerate() {
            if i != a && i != b && i != c && i != d {
                h.insert(p);
            }
        }
        h.compact();
        h
    }

    /// True when the hull is flat (all points coplanar) and has no faces.
    pub fn is_flat(&self) -> bool {
        self.faces.is_empty()
    }

    /// Inserts one point; returns whether the hull changed (the point saw some face).
    fn insert(&mut self, p: &P3) -> bool {
        let mut visible = vec![false; self.faces.len()];
        let mut any = false;
        // The filters' range check once per point rather than once per face (it was a
        // quarter of the time of a large hull's scan); the same exact answers.
        let in_range = in_filter_range(p) && self.pts.iter().all(in_filter_range);
        for (k, f) in self.faces.iter().enumerate() {
            let (a, b, c) = (
                &self.pts[f[0] as usize],
                &self.pts[f[1] as usize],
                &self.pts[f[2] as usize],
            );
            let o = if in_range {
                orient3d_in_range(a, b, c, p)
            } else {
                orient3d(a, b, c, p)
            };
            if o > 0 {
                visible[k] = true;
                any = true;
            }
        }
        if !any {
            return false;
        }
        // Directed edges of the visible faces; an edge whose twin is not among them is on
        // the horizon. The visible region of a convex hull is a topological disc.
        let mut vis_edges: HashMap<(u32, u32), (), crate::base::hash::FxBuild> = HashMap::default();
        for (k, f) in self.faces.iter().enumerate() {
            if visible[k] {
                for e in 0..3 {
                    vis_edges.insert((f[e], f[(e + 1) % 3]), ());
                }
            }
        }
        let pi = self.pts.len() as u32;
        self.pts.push(*p);
        let mut kept = Vec::with_capacity(self.faces.len() + 4);
        let mut cone = Vec::new();
        for (k, f) in self.faces.iter().enumerate() {
            if !visible[k] {
                kept.push(*f);
                continue;
            }
            for e in 0..3 {
                let (u, v) = (f[e], f[(e + 1) % 3]);
                if !vis_edges.contains_key(&(v, u)) {
                    cone.push([u, v, pi]);
                }
            }
        }
        kept.extend(cone);
        self.faces = kept;
        true
    }

    /// Drops points no face uses (keeps the order of the rest).
    fn compact(&mut self) {
        if self.faces.is_empty() {
            return;
        }
        let mut map = vec![u32::MAX; self.pts.len()];
        let mut pts = Vec::new();
        for f in &mut self.faces {
            for v in f.iter_mut() {
                let m = &mut map[*v as usize];
                if *m == u32::MAX {
                    *m = pts.len() as u32;
                    pts.push(self.pts[*v as usize]);
                }
                *v = *m;
            }
        }
        self.pts = pts;
    }

    /// Inserts every point of `other` (the hull of the union); returns whether this hull
    /// changed. When it did not, `self` is untouched.
    pub fn insert_all(&mut self, other: &Hull3) -> bool {
        if other.is_flat() {
            return self.rebuild_with(&other.pts);
        }
        self.insert_points(&other.pts)
    }

    /// Inserts `points` (the hull of the union); returns whether this hull changed. When
    /// it did not, `self` is untouched.
    pub fn insert_points(&mut self, points: &[P3]) -> bool {
        if self.is_flat() {
            return self.rebuild_with(points);
        }
        // A point inside the hull of a few of the hull's own points is inside the hull,
        // where `insert` would change nothing: skipped after at most a few dozen exact
        // tests instead of one per face (a large component's members are mostly inside
        // the hull of its extremes: on OpenArena maps a scan of every face for each new
        // member vertex was 12% of a run).
        let inner = (points.len() >= INNER_MIN_POINTS && self.faces.len() >= INNER_MIN_FACES)
            .then(|| self.inner())
            .flatten();
        // A point equal (bit for bit) to one already met — a hull point, or one inserted
        // or skipped before it in this call — is inside or on the hull, which only grows:
        // `insert` would change nothing. Neighbouring cells share vertices, so many of an
        // absorbed member's vertices are already hull points, and on a wall off the axis
        // planes (exactly coplanar, which no filter decides) every face through them took
        // the exact path.
        let mut known: HashSet<[u64; 3], crate::base::hash::FxBuild> = self.pts.iter().map(bits).collect();
        let mut changed = false;
        for p in points {
            if !known.insert(bits(p)) || inner.as_ref().is_some_and(|h| h.holds(p)) {
                continue;
            }
            changed |= self.insert(p);
        }
        if changed {
            self.compact();
        }
        changed
    }

    /// The hull of this hull's extreme points along the axes and the cube's diagonals (a
    /// polytope inside this hull, which only grows), or `None` when they are coplanar.
    fn inner(&self) -> Option<Hull3> {
        const DIRS: [[f64; 3]; 7] = [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
            [1.0, -1.0, 1.0],
            [1.0, 1.0, -1.0],
            [1.0, -1.0, -1.0],
        ];
        let mut ids = Vec::with_capacity(2 * DIRS.len());
        for d in &DIRS {
            for sign in [1.0, -1.0] {
                let at = |i: usize| sign * dot(d, &self.pts[i]);
                let best = (0..self.pts.len()).fold(0, |b, i| if at(i) > at(b) { i } else { b });
                ids.push(best);
            }
        }
        ids.sort_unstable();
        ids.dedup();
        let pts: Vec<P3> = ids.iter().map(|&i| self.pts[i]).collect();
        let h = Hull3::new(&pts);
        (!h.is_flat()).then_some(h)
    }

    /// `p` is inside or on the hull (exact).
    fn holds(&self, p: &P3) -> bool {
        self.faces.iter().all(|f| {
            orient3d(
                &self.pts[f[0] as usize],
                &self.pts[f[1] as usize],
                &self.pts[f[2] as usize],
                p,
            ) <= 0
        })
    }

    /// The hull of this one's points and `points`, built anew (a flat hull has no faces to
    /// insert into).
    fn rebuild_with(&mut self, points: &[P3]) -> bool {
        let mut all = self.pts.clone();
        all.extend_from_slice(points);
        let h = Hull3::new(&all);
        let changed = !same_set(&h.pts, &self.pts);
        if changed {
            *self = h;
        }
        changed
    }

    /// Enclosed volume (0 for a flat hull).
    #[cfg(test)]
    pub fn volume(&self) -> f64 {
        let Some(r) = self.pts.first() else { return 0.0 };
        let mut v6 = 0.0;
        for f in &self.faces {
            let a = sub(&self.pts[f[0] as usize], r);
            let b = sub(&self.pts[f[1] as usize], r);
            let c = sub(&self.pts[f[2] as usize], r);
            v6 += dot(&a, &cross(&b, &c));
        }
        v6 / 6.0
    }

    /// Number of triangles.
    #[cfg(test)]
    pub fn num_faces(&self) -> usize {
        self.faces.len()
    }

    /// Every point of `pts` is inside or on the hull (exact).
    #[cfg(test)]
    pub fn contains_all(&self, pts: &[P3]) -> bool {
        pts.iter().all(|p| self.holds(p))
    }
}

/// [`Hull3::insert_points`] tests each point against an inner hull first when at least
/// this many points are inserted...
const INNER_MIN_POINTS: usize = 8;
/// ...into a hull of at least this many faces (an inner hull has up to 24).
const INNER_MIN_FACES: usize = 48;

fn same_set(a: &[P3], b: &[P3]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    let mut x: Vec<[u64; 3]> = a.iter().map(bits).collect();
    let mut y: Vec<[u64; 3]> = b.iter().map(bits).collect();
    x.sort_unstable();
    y.sort_unstable();
    x == y
}

/// Four points spanning a positively oriented tetrahedron, or `None` when all are coplanar.
fn initial_simplex(pts: &[P3]) -> Option<[usize; 4]> {
    if pts.len() < 4 {
        return None;
    }
    let a = 0;
    let d2 = |p: &P3| {
        let d = sub(p, &pts[a]);
        dot(&d, &d)
    };
    let b = (0..pts.len()).max_by(|&i, &j| d2(&pts[i]).total_cmp(&d2(&pts[j])))?;
    if d2(&pts[b]) == 0.0 {
        return None;
    }
    let ab = sub(&pts[b], &pts[a]);
    let ar = |p: &P3| {
        let c = cross(&ab, &sub(p, &pts[a]));
        dot(&c, &c)
    };
    let mut c = (0..pts.len()).max_by(|&i, &j| ar(&pts[i]).total_cmp(&ar(&pts[j])))?;
    if ar(&pts[c]) == 0.0 {
        // Rounding may hide a tiny area: look for any exactly non-collinear point.
        c = (0..pts.len()).find(|&i| !crate::predicates::collinear(&pts[a], &pts[b], &pts[i]))?;
    }
    let n = cross(&ab, &sub(&pts[c], &pts[a]));
    let vol = |p: &P3| dot(&n, &sub(p, &pts[a])).abs();
    let mut d = (0..pts.len()).max_by(|&i, &j| vol(&pts[i]).total_cmp(&vol(&pts[j])))?;
    if orient3d(&pts[a], &pts[b], &pts[c], &pts[d]) == 0 {
        d = (0..pts.len()).find(|&i| orient3d(&pts[a], &pts[b], &pts[c], &pts[i]) != 0)?;
    }
    if orient3d(&pts[a], &pts[b], &pts[c], &pts[d]) > 0 {
        Some([a, b, c, d])
    } else {
        Some([b, a, c, d])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::rng::SplitMix64;

    #[test]
    fn cube_with_inner_points_keeps_eight_corners() {
        let mut pts = Vec::new();
        for i in 0..8 {
            pts.push([(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64]);
        }
        let mut r = SplitMix64(7);
        for _ in 0..200 {
            pts.push([r.unit(), r.unit(), r.unit()]);
        }
        // Points on faces and edges (coplanar/collinear with the hull).
        pts.push([0.5, 0.5, 0.0]);
        pts.push([0.5, 0.0, 0.0]);
        pts.push([1.0, 0.25, 0.75]);
        // Shuffle so corners are not first.
        pts.rotate_left(100);
        let h = Hull3::new(&pts);
        assert!(h.contains_all(&pts));
        assert!((h.volume() - 1.0).abs() < 1e-12, "{}", h.volume());
        assert!(h.pts.len() >= 8 && h.pts.len() <= 11, "{}", h.pts.len());
        assert_eq!(h.num_faces(), 2 * h.pts.len() - 4);
    }

    /// Outside the filters' range (huge or tiny coordinates) the scan takes the
    /// checked predicate, inside it the unchecked one: the same hull either way, scaled.
    #[test]
    fn hulls_outside_the_filter_range_are_the_scaled_hulls() {
        let mut r = SplitMix64(3);
        let pts: Vec<P3> = (0..300).map(|_| [r.unit(), r.unit(), r.unit()]).collect();
        let base = Hull3::new(&pts);
        for s in [2f64.powi(400), 2f64.powi(-500), 1.0] {
            let scaled: Vec<P3> = pts.iter().map(|p| p.map(|x| x * s)).collect();
            let h = Hull3::new(&scaled);
            let back: Vec<P3> = h.pts.iter().map(|p| p.map(|x| x / s)).collect();
            assert!(same_set(&back, &base.pts), "scale {s:e}");
        }
    }

    /// A hull with more points inserted is the hull of the union: it contains every point,
    /// its volume is the one built at once, and a flat hull (a floor's points) grows into a
    /// solid one; inserting points already inside changes nothing.
    #[test]
    fn inserting_points_gives_the_hull_of_the_union() {
        let mut r = SplitMix64(29);
        for round in 0..20 {
            let flat = round % 4 == 0;
            let a: Vec<P3> = (0..50)
                .map(|_| [r.unit(), r.unit(), if flat { 0.0 } else { r.unit() }])
                .collect();
            let b: Vec<P3> = (0..80).map(|_| [r.unit() * 1.5, r.unit(), r.unit() * 2.0]).collect();
            let mut h = Hull3::new(&a);
            assert!(h.insert_points(&b));
            let all: Vec<P3> = a.iter().chain(&b).copied().collect();
            let whole = Hull3::new(&all);
            assert!(h.contains_all(&all));
            assert!(
                (h.volume() - whole.volume()).abs() <= 1e-12 * whole.volume(),
                "round {round}"
            );
            let before = h.clone();
            assert!(!h.insert_points(&a));
            assert_eq!(h.pts, before.pts);
        }
    }

    /// Points inserted in a batch (tested against the inner hull first, and skipped when
    /// equal to one met before) give the hull of inserting them one by one, bit for bit:
    /// random clouds, points on the hull's faces and edges, copies of its vertices and of
    /// the batch's own points; and the inner hull skips most of them.
    #[test]
    fn inner_hull_skips_only_points_that_change_nothing() {
        let mut r = SplitMix64(53);
        let mut skipped = 0;
        for round in 0..30 {
            let a: Vec<P3> = (0..400)
                .map(|_| {
                    let (u, v, w) = (r.unit() - 0.5, r.unit() - 0.5, r.unit() - 0.5);
                    let l = (u * u + v * v + w * w).sqrt().max(1e-9);
                    // A ball's surface (many faces), a few points inside.
                    let s = if round % 3 == 0 { r.unit() } else { 1.0 };
                    [u / l * s * 3.0, v / l * s * 2.0, w / l * s]
                })
                .collect();
            let h0 = Hull3::new(&a);
            let mut b: Vec<P3> = (0..200)
                .map(|_| [(r.unit() - 0.5) * 7.0, (r.unit() - 0.5) * 4.5, (r.unit() - 0.5) * 2.3])
                .collect();
            b.extend(h0.pts.iter().take(20).copied());
            for f in h0.faces.iter().take(20) {
                let [p, q, s] = [f[0], f[1], f[2]].map(|i| h0.pts[i as usize]);
                b.push([0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1]), 0.5 * (p[2] + q[2])]);
                b.push([
                    (p[0] + q[0] + s[0]) / 3.0,
                    (p[1] + q[1] + s[1]) / 3.0,
                    (p[2] + q[2] + s[2]) / 3.0,
                ]);
            }
            // Copies of points met earlier in the same batch (inserted or not).
            let again: Vec<P3> = b.iter().step_by(7).copied().collect();
            b.extend(again);
            let mut one_by_one = h0.clone();
            let mut changed = false;
            for p in &b {
                changed |= one_by_one.insert(p);
            }
            if changed {
                one_by_one.compact();
            }
            let inner = h0.inner().expect("a solid hull");
            skipped += b.iter().filter(|p| inner.holds(p)).count();
            let mut batch = h0.clone();
            assert_eq!(batch.insert_points(&b), changed, "round {round}");
            let key = |h: &Hull3| (h.pts.iter().map(bits).collect::<Vec<_>>(), h.faces.clone());
            assert_eq!(key(&batch), key(&one_by_one), "round {round}");
        }
        assert!(skipped > 1000, "{skipped}");
    }

    #[test]
    fn merge_reports_change_exactly() {
        let mut r = SplitMix64(11);
        let a: Vec<P3> = (0..300)
            .map(|_| [r.unit() * 4.0, r.unit() * 4.0, r.unit() * 3.0])
            .collect();
        let mut h = Hull3::new(&a);
        let before = h.pts.clone();
        let inside = Hull3::new(&[[1.0, 1.0, 1.0], [2.0, 1.0, 1.0], [1.0, 2.0, 1.0], [1.0, 1.0, 2.0]]);
        assert!(!h.insert_all(&inside));
        assert_eq!(h.pts, before);
        let outside = Hull3::new(&[[5.0, 1.0, 1.0], [6.0, 1.0, 1.0], [5.0, 2.0, 1.0], [5.0, 1.0, 2.0]]);
        assert!(h.insert_all(&outside));
        let mut all = a.clone();
        all.extend_from_slice(&outside.pts);
        assert!(h.contains_all(&all));
        let direct = Hull3::new(&all);
        assert!((h.volume() - direct.volume()).abs() < 1e-9 * direct.volume());
    }

    #[test]
    fn flat_points_give_flat_hull() {
        let h = Hull3::new(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]]);
        assert!(h.is_flat());
        assert_eq!(h.pts.len(), 4);
        assert_eq!(h.volume(), 0.0);
    }
}
