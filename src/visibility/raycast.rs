//! First-hit ray casting against a model's polygons: a bounding-volume hierarchy over their
//! fan triangles (median splits on the longest centroid axis, as in
//! [`crate::geom::clearance`]), Möller–Trumbore intersection, nearest hit first.

use crate::base::vec::{P3, cross, dot, sub};
use crate::model::Model;

const LEAF: usize = 4;

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: P3,
    hi: P3,
    /// Leaf: `first..first + count`; inner: `first` is the right child, `count == 0`.
    first: u32,
    count: u32,
}

/// A ray hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter (distance along a unit direction).
    pub t: f64,
    /// Index of the model polygon.
    pub polygon: u32,
    /// True when the ray hit the polygon's front (free-space) side.
    pub front: bool,
}

/// A ray caster over a model's polygons.
#[derive(Clone, Debug)]
pub struct RayCaster {
    tris: Vec<[P3; 3]>,
    owner: Vec<u32>,
    nodes: Vec<Node>,
}

fn bounds(tris: &[[P3; 3]]) -> (P3, P3) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for t in tris {
        for v in t {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
    }
    (lo, hi)
}

impl RayCaster {
    /// Builds the hierarchy over the fan triangles of every polygon.
    pub fn new(model: &Model) -> Self {
        let mut tris = Vec::new();
        let mut owner = Vec::new();
        for (i, p) in model.polygons.iter().enumerate() {
            let v: Vec<P3> = p.verts.iter().map(|v| model.vertices[v.idx()]).collect();
            for k in 1..v.len().saturating_sub(1) {
                tris.push([v[0], v[k], v[k + 1]]);
                owner.push(i as u32);
            }
        }
        let mut idx: Vec<u32> = (0..tris.len() as u32).collect();
        let mut nodes = Vec::new();
        if !tris.is_empty() {
            build(&tris, &mut idx, 0, &mut nodes);
        }
        RayCaster {
            tris: idx.iter().map(|&i| tris[i as usize]).collect(),
            owner: idx.iter().map(|&i| owner[i as usize]).collect(),
            nodes,
        }
    }

    /// The nearest hit with `t > t_min` along `origin + t · dir`.
    pub fn cast(&self, origin: P3, dir: P3, t_min: f64) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let inv = [1.0 / dir[0], 1.0 / dir[1], 1.0 / dir[2]];
        let mut best: Option<Hit> = None;
        let mut best_t = f64::INFINITY;
        let mut stack = vec![0u32];
        while let Some(ni) = stack.pop() {
            let nd = &self.nodes[ni as usize];
            if slab(&origin, &inv, &nd.lo, &nd.hi, best_t).is_none() {
                continue;
            }
            if nd.count > 0 {
                for k in nd.first..nd.first + nd.count {
                    if let Some((t, front)) = tri_hit(&origin, &dir, &self.tris[k as usize])
                        && t > t_min
                        && t < best_t
                    {
                        best_t = t;
                        best = Some(Hit {
                            t,
                            polygon: self.owner[k as usize],
                            front,
                        });
                    }
                }
            } else {
                let (l, r) = (ni + 1, nd.first);
                let tl = slab(
                    &origin,
                    &inv,
                    &self.nodes[l as usize].lo,
                    &self.nodes[l as usize].hi,
                    best_t,
                );
                let tr = slab(
                    &origin,
                    &inv,
                    &self.nodes[r as usize].lo,
                    &self.nodes[r as usize].hi,
                    best_t,
                );
                match (tl, tr) {
                    (Some(a), Some(b)) => {
                        if a <= b {
                            stack.push(r);
                            stack.push(l);
                        } else {
                            stack.push(l);
                            stack.push(r);
                        }
                    }
                    (Some(_), None) => stack.push(l),
                    (None, Some(_)) => stack.push(r),
                    (None, None) => {}
                }
            }
        }
        best
    }
}

fn build(tris: &[[P3; 3]], idx: &mut [u32], offset: u32, nodes: &mut Vec<Node>) -> u32 {
    let me = nodes.len() as u32;
    let sel: Vec<[P3; 3]> = idx.iter().map(|&i| tris[i as usize]).collect();
    let (lo, hi) = bounds(&sel);
    nodes.push(Node {
        lo,
        hi,
        first: offset,
        count: idx.len() as u32,
    });
    if idx.len() <= LEAF {
        return me;
    }
    let c = |i: u32, k: usize| {
        let t = &tris[i as usize];
        t[0][k] + t[1][k] + t[2][k]
    };
    let (mut clo, mut chi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for &i in idx.iter() {
        for k in 0..3 {
            clo[k] = clo[k].min(c(i, k));
            chi[k] = chi[k].max(c(i, k));
        }
    }
    let axis = (0..3)
        .max_by(|&a, &b| (chi[a] - clo[a]).total_cmp(&(chi[b] - clo[b])))
        .unwrap_or(0);
    let mid = idx.len() / 2;
    idx.select_nth_unstable_by(mid, |&a, &b| c(a, axis).total_cmp(&c(b, axis)).then(a.cmp(&b)));
    let (left, right) = idx.split_at_mut(mid);
    build(tris, left, offset, nodes);
    let r = build(tris, right, offset + mid as u32, nodes);
    nodes[me as usize].first = r;
    nodes[me as usize].count = 0;
    me
}

/// Entry parameter of the ray into the box, if it enters before `t_max`.
#[inline]
fn slab(o: &P3, inv: &P3, lo: &P3, hi: &P3, t_max: f64) -> Option<f64> {
    let (mut t0, mut t1) = (0.0f64, t_max);
    for k in 0..3 {
        let a = (lo[k] - o[k]) * inv[k];
        let b = (hi[k] - o[k]) * inv[k];
        let (a, b) = if a <= b { (a, b) } else { (b, a) };
        // NaN (0 * inf on a slab face) keeps the box: max/min ignore NaN.
        t0 = t0.max(a);
        t1 = t1.min(b);
        if t0 > t1 * (1.0 + 4.0 * f64::EPSILON) {
            return None;
        }
    }
    Some(t0)
}

/// Möller–Trumbore: `(t, front)` for a hit of the triangle's interior or boundary.
#[inline]
fn tri_hit(o: &P3, d: &P3, t: &[P3; 3]) -> Option<(f64, bool)> {
    let e1 = sub(&t[1], &t[0]);
    let e2 = sub(&t[2], &t[0]);
    let p = cross(d, &e2);
    let det = dot(&e1, &p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub(o, &t[0]);
    let u = dot(&s, &p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = cross(&s, &e1);
    let v = dot(d, &q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let tt = dot(&e2, &q) * inv;
    // det = -d · (e1 × e2): positive when the ray travels against the normal (front hit).
    Some((tt, det > 0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::from_soup;

    #[test]
    fn hits_the_nearest_wall_from_inside_a_room() {
        let s = crate::generate::scenes::box_room();
        let m = from_soup("room", s.vertices, s.polygons).unwrap();
        let rc = RayCaster::new(&m);
        let h = rc.cast([1.0, 2.0, 1.5], [-1.0, 0.0, 0.0], 0.0).unwrap();
        assert!((h.t - 1.0).abs() < 1e-12 && h.front);
        let h = rc.cast([1.0, 2.0, 1.5], [0.0, 0.0, 1.0], 0.0).unwrap();
        assert!((h.t - 1.5).abs() < 1e-12 && h.front);
        // From outside, the back of a wall.
        let h = rc.cast([-1.0, 2.0, 1.5], [1.0, 0.0, 0.0], 0.0).unwrap();
        assert!((h.t - 1.0).abs() < 1e-12 && !h.front);
    }
}
