//! Dynamic portal simplification (thesis 2.3.4): the window narrowed through a portal is
//! the portal's convex screen polygon, intersected along the chain and reduced to at most
//! `K` edges by edge removal. Removing an edge extends its two neighbours to their
//! intersection, which adds the triangle between the edge and that point; a heap removes the
//! edge that adds the least area first (O(n log n)), until at most `K` edges remain, the
//! polygon is a triangle, or no edge can be removed (its neighbours are parallel or diverge,
//! as in a parallelogram). Every step only adds area, so the result contains the exact
//! polygon: the window is conservative.
//!
//! Portals and triangles are first tested against the window's planes with their bounding
//! spheres (the thesis's pre-rejection): a sphere wholly outside one plane is rejected
//! without clipping.

use super::walk::{Camera, ExactWindow, Ops, Plane, Window, clip_tol};
use crate::base::vec::{P3, cross, dot, norm, sub};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// A screen point (tangent coordinates).
pub type P2 = [f64; 2];

fn cross2(o: &P2, a: &P2, b: &P2) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Signed area (positive: counter-clockwise).
pub fn area(p: &[P2]) -> f64 {
    let n = p.len();
    (0..n)
        .map(|i| {
            let j = (i + 1) % n;
            p[i][0] * p[j][1] - p[j][0] * p[i][1]
        })
        .sum::<f64>()
        * 0.5
}

/// Convex hull, counter-clockwise, without collinear points (Andrew's monotone chain).
pub fn hull(pts: &[P2], ops: &mut Ops) -> Vec<P2> {
    let mut p = pts.to_vec();
    ops.screen_ops += p.len() as u64;
    p.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let mut h: Vec<P2> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = h.len();
        let it: Box<dyn Iterator<Item = &P2>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for q in it {
            while h.len() >= start + 2 && cross2(&h[h.len() - 2], &h[h.len() - 1], q) <= 0.0 {
                h.pop();
            }
            h.push(*q);
        }
        h.pop();
    }
    h
}

/// The part of the convex polygon `s` inside the convex counter-clockwise polygon `w`
/// (Sutherland–Hodgman).
pub fn clip2(s: &[P2], w: &[P2], ops: &mut Ops) -> Vec<P2> {
    let mut cur = s.to_vec();
    for i in 0..w.len() {
        if cur.len() < 3 {
            break;
        }
        let (a, b) = (w[i], w[(i + 1) % w.len()]);
        ops.plane_clips += 1;
        ops.vertices += cur.len() as u64;
        let d: Vec<f64> = cur.iter().map(|p| cross2(&a, &b, p)).collect();
        if d.iter().all(|&x| x >= 0.0) {
            continue;
        }
        let mut next = Vec::with_capacity(cur.len() + 1);
        for k in 0..cur.len() {
            let l = (k + 1) % cur.len();
            if d[k] >= 0.0 {
                next.push(cur[k]);
            }
            if (d[k] > 0.0 && d[l] < 0.0) || (d[k] < 0.0 && d[l] > 0.0) {
                let t = d[k] / (d[k] - d[l]);
                next.push([
                    cur[k][0] + t * (cur[l][0] - cur[k][0]),
                    cur[k][1] + t * (cur[l][1] - cur[k][1]),
                ]);
            }
        }
        cur = next;
    }
    cur
}

/// The point where the edge `a → b` extended beyond `b` meets the edge `c → d` extended
/// before `c`, and the area of the triangle `b`, that point, `c`; `None` when the two
/// extensions do not meet (parallel or diverging).
fn extension(a: &P2, b: &P2, c: &P2, d: &P2) -> Option<(P2, f64)> {
    let u = [b[0] - a[0], b[1] - a[1]];
    let v = [d[0] - c[0], d[1] - c[1]];
    let den = u[0] * v[1] - u[1] * v[0];
    if den <= 0.0 {
        return None;
    }
    let w = [c[0] - b[0], c[1] - b[1]];
    // b + s u = c − t v with s, t ≥ 0.
    let s = (w[0] * v[1] - w[1] * v[0]) / den;
    let t = (u[0] * w[1] - u[1] * w[0]) / den;
    if !(s >= 0.0 && t >= 0.0 && s.is_finite()) {
        return None;
    }
    let x = [b[0] + s * u[0], b[1] + s * u[1]];
    let added = 0.5 * cross2(b, &x, c).abs();
    Some((x, added))
}

/// Reduces the strictly convex counter-clockwise polygon `p` to at most `k` edges (`k ≥ 3`)
/// by edge removal (see the module docs). The result contains `p`.
pub fn simplify(p: &[P2], k: usize, ops: &mut Ops) -> Vec<P2> {
    let n = p.len();
    if n <= k.max(3) {
        return p.to_vec();
    }
    let mut pts = p.to_vec();
    let mut next: Vec<usize> = (0..n).map(|i| (i + 1) % n).collect();
    let mut prev: Vec<usize> = (0..n).map(|i| (i + n - 1) % n).collect();
    let mut alive = vec![true; n];
    let mut version = vec![0u32; n];
    let mut left = n;
    // Heap of (added area, edge start, version); an entry is stale when its version moved.
    let mut heap: BinaryHeap<Reverse<(OrdF, usize, u32)>> = BinaryHeap::new();
    let cost = |v: usize, pts: &[P2], next: &[usize], prev: &[usize]| {
        let (a, b) = (prev[v], v);
        let (c, d) = (next[v], next[next[v]]);
        extension(&pts[a], &pts[b], &pts[c], &pts[d])
    };
    for v in 0..n {
        ops.screen_ops += 1;
        if let Some((_, area)) = cost(v, &pts, &next, &prev) {
            heap.push(Reverse((OrdF(area), v, 0)));
        }
    }
    while left > k.max(3) {
        let Some(Reverse((_, v, ver))) = heap.pop() else { break };
        ops.screen_ops += 1;
        if !alive[v] || version[v] != ver {
            continue;
        }
        let Some((x, _)) = cost(v, &pts, &next, &prev) else {
            continue;
        };
        // Edge v → w goes: v moves to x, w disappears.
        let w = next[v];
        pts[v] = x;
        alive[w] = false;
        next[v] = next[w];
        let nw = next[w];
        prev[nw] = v;
        left -= 1;
        let pv = prev[v];
        for u in [prev[pv], pv, v, nw] {
            version[u] += 1;
            ops.screen_ops += 1;
            if let Some((_, area)) = cost(u, &pts, &next, &prev) {
                heap.push(Reverse((OrdF(area), u, version[u])));
            }
        }
    }
    let start = (0..n).find(|&i| alive[i]).unwrap_or(0);
    let mut out = vec![pts[start]];
    let mut v = next[start];
    while v != start {
        out.push(pts[v]);
        v = next[v];
    }
    out
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct OrdF(f64);
impl Eq for OrdF {}
impl PartialOrd for OrdF {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for OrdF {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}

/// The planes through the eye and the edges of the counter-clockwise screen polygon `p`
/// (inside: the polygon), with the near plane first.
///
/// Each normal is `e × d_i`, with `d_i` the ray through the edge's first vertex and
/// `e = (Δx) right + (Δy) up` the edge's direction built from its screen differences: no
/// cancellation however short the edge (hulls of merged portals have edges of 1e-16 between
/// points that rounding split), and no orientation test — for a counter-clockwise polygon
/// (`right × up = −forward`) it points inside. Zero-length edges give no plane.
pub fn planes_of(cam: &Camera, p: &[P2]) -> Vec<Plane> {
    let mut planes = vec![cam.near_plane()];
    for i in 0..p.len() {
        let j = (i + 1) % p.len();
        let (dx, dy) = (p[j][0] - p[i][0], p[j][1] - p[i][1]);
        if dx == 0.0 && dy == 0.0 {
            continue;
        }
        let e: P3 = std::array::from_fn(|k| dx * cam.right[k] + dy * cam.up[k]);
        let n = cross(&e, &cam.dir(&p[i]));
        if norm(&n) <= 1e-300 {
            continue;
        }
        planes.push(Plane {
            n,
            d: dot(&n, &cam.eye),
        });
    }
    planes
}

/// Whether the sphere (`c`, `r`) lies wholly outside one of the planes (by more than `tol`).
fn sphere_outside(planes: &[Plane], c: &P3, r: f64, tol: f64) -> bool {
    planes.iter().any(|pl| {
        let nl = norm(&pl.n).max(f64::MIN_POSITIVE);
        (dot(&pl.n, c) - pl.d) / nl < -r - tol
    })
}

fn sphere(ps: &[P3]) -> (P3, f64) {
    let c = crate::base::vec::mean(ps);
    let r = ps.iter().map(|p| norm(&sub(p, &c))).fold(0.0, f64::max);
    (c, r)
}

/// Whether a triangle meets the screen-polygon window of `planes` (lenient by `Camera::tol`),
/// after the bounding-sphere pre-rejection: the triangle test of [`KgonWindow`] and
/// [`HullWindow`].
fn sees_through(planes: &[Plane], cam: &Camera, tri: &[P3; 3], ops: &mut Ops) -> bool {
    ops.triangle_tests += 1;
    let (c, r) = sphere(tri);
    if sphere_outside(planes, &c, r, cam.tol) {
        ops.sphere_rejects += 1;
        return false;
    }
    clip_tol(tri, planes, -cam.tol, ops).is_some()
}

/// The planes of a narrowed screen-polygon window: [`planes_of`] the polygon, then the
/// viewport's four planes (edge removal may reach past the screen; the viewport still clips
/// there).
fn window_planes(cam: &Camera, p: &[P2]) -> Vec<Plane> {
    let mut planes = planes_of(cam, p);
    planes.extend(ExactWindow::view(cam).planes[1..].iter().copied());
    planes
}

/// The window as a convex screen polygon of at most `K` edges.
#[derive(Clone, Debug, PartialEq)]
pub struct KgonWindow<const K: usize> {
    /// Counter-clockwise screen polygon (tangent coordinates).
    pub poly: Vec<P2>,
    /// Near plane, the planes through the eye and its edges, and (below the view) the
    /// viewport's four planes, since edge removal may reach past the screen.
    pub planes: Vec<Plane>,
}

impl<const K: usize> Window for KgonWindow<K> {
    const NAME: &'static str = match K {
        4 => "kgon4",
        6 => "kgon6",
        8 => "kgon8",
        _ => "kgon",
    };

    fn view(cam: &Camera) -> Self {
        let (x, y) = (cam.tan_x, cam.tan_y);
        let poly = vec![[-x, -y], [x, -y], [x, y], [-x, y]];
        let planes = planes_of(cam, &poly);
        KgonWindow { poly, planes }
    }

    fn narrow(&self, cam: &Camera, portal: &[P3], ops: &mut Ops) -> Option<Self> {
        ops.narrows += 1;
        narrow_screen(&self.poly, &self.planes, cam, &[portal], Some(K), ops)
            .map(|(poly, planes)| KgonWindow { poly, planes })
    }

    fn sees(&self, cam: &Camera, tri: &[P3; 3], ops: &mut Ops) -> bool {
        sees_through(&self.planes, cam, tri, ops)
    }
}

/// Narrows the screen-polygon window (`poly`, `planes`) through the pieces of a portal: each
/// piece is pre-rejected by bounding sphere and clipped leniently to the window, the
/// projections' convex hull is intersected with `poly` and, with `k`, reduced to at most `k`
/// edges. `None` when no piece is seen; the window unchanged when a kept piece touches the
/// near plane or the projection is edge-on (conservative).
fn narrow_screen(
    poly: &[P2],
    planes: &[Plane],
    cam: &Camera,
    pieces: &[&[P3]],
    k: Option<usize>,
    ops: &mut Ops,
) -> Option<(Vec<P2>, Vec<Plane>)> {
    let mut s: Vec<P2> = Vec::new();
    for portal in pieces {
        let (c, r) = sphere(portal);
        if sphere_outside(planes, &c, r, cam.tol) {
            ops.sphere_rejects += 1;
            continue;
        }
        let Some(q) = clip_tol(portal, planes, -cam.tol, ops) else {
            continue;
        };
        if q.iter().any(|p| cam.depth(p) < 0.5 * cam.near) {
            // Kept by the lenient clip while touching the near plane: stay as we are.
            return Some((poly.to_vec(), planes.to_vec()));
        }
        s.extend(q.iter().map(|p| cam.screen(p)));
    }
    if s.is_empty() {
        return None;
    }
    let h = hull(&s, ops);
    if h.len() < 3 {
        // Seen edge-on: the exact window is a sliver; keep ours (conservative).
        return Some((poly.to_vec(), planes.to_vec()));
    }
    let mut i = clip2(&h, poly, ops);
    if i.len() < 3 || area(&i) <= 0.0 {
        // Only touching our polygon (rounding): keep the projection itself.
        i = h;
    }
    let i = hull(&i, ops);
    let out = match k {
        Some(k) => simplify(&i, k, ops),
        None => i,
    };
    let planes = window_planes(cam, &out);
    Some((out, planes))
}

/// The conservative convex screen-space hull of a portal's projection (issue 14's window
/// (d)): the convex hull of the projections of the portal's pieces (all of a merged portal's
/// pieces at once with `M`, else piece by piece), intersected along the chain, with the
/// k-gon windows' bounding-sphere pre-rejection. It contains every piece's exact window.
#[derive(Clone, Debug, PartialEq)]
pub struct HullWindow<const M: bool> {
    /// Counter-clockwise screen polygon (tangent coordinates).
    pub poly: Vec<P2>,
    /// Near plane, the planes through the eye and its edges, and the viewport's planes.
    pub planes: Vec<Plane>,
}

impl<const M: bool> Window for HullWindow<M> {
    const NAME: &'static str = if M { "hull" } else { "hull_pieces" };
    const MERGED: bool = M;

    fn view(cam: &Camera) -> Self {
        let k = KgonWindow::<4>::view(cam);
        HullWindow {
            poly: k.poly,
            planes: k.planes,
        }
    }

    fn narrow(&self, cam: &Camera, portal: &[P3], ops: &mut Ops) -> Option<Self> {
        self.narrow_portal(cam, &[portal], ops)
    }

    fn narrow_portal(&self, cam: &Camera, pieces: &[&[P3]], ops: &mut Ops) -> Option<Self> {
        ops.narrows += 1;
        narrow_screen(&self.poly, &self.planes, cam, pieces, None, ops)
            .map(|(poly, planes)| HullWindow { poly, planes })
    }

    fn sees(&self, cam: &Camera, tri: &[P3; 3], ops: &mut Ops) -> bool {
        sees_through(&self.planes, cam, tri, ops)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn regular(n: usize, r: f64) -> Vec<P2> {
        (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                [r * a.cos(), r * a.sin()]
            })
            .collect()
    }

    /// Every point of `inner` lies inside (or on) the convex counter-clockwise `outer`.
    fn contains(outer: &[P2], inner: &[P2]) -> bool {
        let scale = outer.iter().map(|p| p[0].abs().max(p[1].abs())).fold(1.0, f64::max);
        inner.iter().all(|p| {
            (0..outer.len()).all(|i| cross2(&outer[i], &outer[(i + 1) % outer.len()], p) >= -1e-12 * scale * scale)
        })
    }

    #[test]
    fn hexagon_to_quadrilateral() {
        let h = regular(6, 1.0);
        let mut ops = Ops::default();
        let q = simplify(&h, 4, &mut ops);
        assert_eq!(q.len(), 4);
        assert!(contains(&q, &h));
        assert!(area(&q) >= area(&h));
        assert!(area(&q) > 0.0);
    }

    #[test]
    fn stops_at_a_triangle() {
        let h = regular(12, 2.0);
        let mut ops = Ops::default();
        let t = simplify(&h, 3, &mut ops);
        assert_eq!(t.len(), 3);
        assert!(contains(&t, &h));
        // A parallelogram has no removable edge: asked for 3, it stays a 4-gon.
        let p = vec![[0.0, 0.0], [2.0, 0.0], [3.0, 1.0], [1.0, 1.0]];
        assert_eq!(simplify(&p, 3, &mut ops), p);
    }

    #[test]
    fn random_polygons_contained_at_most_k() {
        let mut rng = crate::base::rng::SplitMix64(14);
        for _ in 0..300 {
            let n = 3 + (rng.next_u64() % 30) as usize;
            let pts: Vec<P2> = (0..n).map(|_| [rng.signed_unit(), 0.5 * rng.signed_unit()]).collect();
            let mut ops = Ops::default();
            let h = hull(&pts, &mut ops);
            if h.len() < 3 {
                continue;
            }
            for k in [4, 6, 8] {
                let s = simplify(&h, k, &mut ops);
                // From 5 edges on, some edge's neighbours turn by less than π together.
                assert!(s.len() <= k, "{} edges for k {k}", s.len());
                assert!(contains(&s, &h), "k {k}: {s:?} does not contain {h:?}");
                assert!(area(&s) >= area(&h) * (1.0 - 1e-12));
            }
        }
    }
}
