//! Small vector helpers on `[f64; 3]` and a compensated dot product.
//!
//! Plain arrays keep the bit patterns of copied vertices untouched, which the B-rep relies
//! on (vertices are identified by exact coordinates), and every helper is one fixed
//! sequence of operations: call sites that switched to these from local copies produce
//! bit-identical results. `glam::DVec3` would do for the arithmetic (its `dot`, `cross`
//! and `length` have the same operation order), but the crate's geometry, the exact
//! predicates and the B-rep all store `[f64; 3]`, so a second type would only add
//! conversions.

// Negated float comparisons (`!(x > eps)`) are deliberate: they send NaN to the safe side.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

/// A point or vector in 3D: the crate's one coordinate type (the same type as
/// `crate::predicates::P3`).
pub type P3 = [f64; 3];

#[inline]
pub fn sub(a: &P3, b: &P3) -> P3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
pub fn add(a: &P3, b: &P3) -> P3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline]
pub fn scale(a: &P3, s: f64) -> P3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

#[inline]
pub fn dot(a: &P3, b: &P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
pub fn cross(a: &P3, b: &P3) -> P3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline]
pub fn norm(a: &P3) -> f64 {
    dot(a, a).sqrt()
}

/// `a / |a|`, or the zero vector when `a` is zero (or not finite).
#[inline]
pub fn normalize(a: &P3) -> P3 {
    let l = norm(a);
    if l > 0.0 && l.is_finite() {
        scale(a, 1.0 / l)
    } else {
        [0.0; 3]
    }
}

/// Hash key of a point: its exact bit pattern (with `-0.0` folded into `+0.0`).
pub type Key = [u64; 3];

#[inline]
pub fn key(p: &P3) -> Key {
    [(p[0] + 0.0).to_bits(), (p[1] + 0.0).to_bits(), (p[2] + 0.0).to_bits()]
}

/// Lexicographic `a < b` on coordinates (total order on bits for NaN-free input).
#[inline]
pub fn lex_less(a: &[f64], b: &[f64]) -> bool {
    for (x, y) in a.iter().zip(b) {
        if x < y {
            return true;
        }
        if x > y {
            return false;
        }
    }
    false
}

/// The axis to drop when projecting onto a coordinate plane (the dominant component of
/// `n`), and the two kept axes `(i, j)` ordered so that a polygon counter-clockwise seen
/// from `+n` stays counter-clockwise in `(i, j)` coordinates. Returns `None` when `n` is
/// zero or not finite.
pub fn axes(n: &P3) -> Option<(usize, usize, usize)> {
    let a = [n[0].abs(), n[1].abs(), n[2].abs()];
    let k = if a[0] >= a[1] && a[0] >= a[2] {
        0
    } else if a[1] >= a[2] {
        1
    } else {
        2
    };
    if !(a[k] > 0.0) || !a[k].is_finite() {
        return None;
    }
    // Cyclic (i, j, k) is right-handed: e_i × e_j = e_k.
    let (i, j) = ((k + 1) % 3, (k + 2) % 3);
    Some(if n[k] > 0.0 { (i, j, k) } else { (j, i, k) })
}

/// Euclidean distance `|a - b|`, as `sqrt(dx² + dy² + dz²)` with `powi(2)`.
#[inline]
pub fn dist(a: &P3, b: &P3) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Axis-aligned bounding box `(lo, hi)` of points (`lo` = +inf, `hi` = -inf for none).
pub fn bounds<'a>(points: impl IntoIterator<Item = &'a P3>) -> (P3, P3) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for v in points {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    (lo, hi)
}

/// `a (1 - t) + b t`: exactly `a` at `t = 0` and exactly `b` at `t = 1`, so grid points on
/// box corners and edges are bit-identical however they are reached.
#[inline]
pub fn lerp(a: &P3, b: &P3, t: f64) -> P3 {
    let s = 1.0 - t;
    [a[0] * s + b[0] * t, a[1] * s + b[1] * t, a[2] * s + b[2] * t]
}

/// The vertex mean: the points summed in order from zero, times `1 / len`.
pub fn mean(ps: &[P3]) -> P3 {
    let s = ps.iter().fold([0.0; 3], |acc, p| add(&acc, p));
    scale(&s, 1.0 / ps.len() as f64)
}

/// Twice the area vector of a polygon, as the sum of the cross products of its fan from
/// the first vertex, `(p_i - p_0) × (p_{i+1} - p_0)`, wrapping around (the last term is
/// zero). Its direction is the normal from which the vertices look counter-clockwise.
pub fn fan_normal(ps: &[P3]) -> P3 {
    let mut n = [0.0; 3];
    for i in 0..ps.len() {
        let (a, b) = (sub(&ps[i], &ps[0]), sub(&ps[(i + 1) % ps.len()], &ps[0]));
        n[0] += a[1] * b[2] - a[2] * b[1];
        n[1] += a[2] * b[0] - a[0] * b[2];
        n[2] += a[0] * b[1] - a[1] * b[0];
    }
    n
}

/// The weighted mean of points, `Σ w_i p_i / Σ w_i` (sums in order from zero), e.g. the
/// area-weighted centroid of polygons from `(area, centroid)` pairs. When the weights do
/// not sum to a positive number, the first point; for no items, NaN.
pub fn weighted_mean(items: impl IntoIterator<Item = (f64, P3)>) -> P3 {
    let (mut c, mut w) = ([0.0; 3], 0.0);
    let mut first = None;
    for (a, q) in items {
        first.get_or_insert(q);
        for k in 0..3 {
            c[k] += a * q[k];
        }
        w += a;
    }
    if w > 0.0 {
        c.map(|x| x / w)
    } else {
        first.unwrap_or([f64::NAN; 3])
    }
}

// Error-free transformations (Dekker / Knuth), no FMA needed.
#[inline]
fn split(a: f64) -> (f64, f64) {
    let c = 134_217_729.0 * a; // 2^27 + 1
    let hi = c - (c - a);
    (hi, a - hi)
}

#[inline]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    let (ah, al) = split(a);
    let (bh, bl) = split(b);
    let e = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
    (p, e)
}

#[inline]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// `n·p - d`, evaluated as if in twice the working precision and rounded once (Ogita,
/// Rump & Oishi's Dot2). Keeps the plane test accurate for coordinates ~1e6 where the
/// naive form loses ~1e-10 to cancellation.
#[inline]
pub fn dot_minus(n: &P3, p: &P3, d: f64) -> f64 {
    let (p0, e0) = two_prod(n[0], p[0]);
    let (p1, e1) = two_prod(n[1], p[1]);
    let (p2, e2) = two_prod(n[2], p[2]);
    let (s1, f1) = two_sum(p0, p1);
    let (s2, f2) = two_sum(s1, p2);
    let (s3, f3) = two_sum(s2, -d);
    s3 + (((e0 + e1) + (e2 + f1)) + (f2 + f3))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dot_minus_is_compensated() {
        // Built so that the naive sum cancels catastrophically.
        let n = [1.0, 1.0, 1.0];
        let p = [1e16, 1.0, -1e16];
        assert_eq!(dot_minus(&n, &p, 0.0), 1.0);
        assert_eq!(dot(&n, &p), 0.0); // naive evaluation loses it
    }

    #[test]
    fn axes_keep_orientation() {
        for n in [
            [1.0, 0.1, 0.2],
            [-1.0, 0.1, 0.2],
            [0.1, 2.0, 0.0],
            [0.0, -2.0, 0.1],
            [0.0, 0.0, 3.0],
            [0.1, 0.0, -3.0],
        ] {
            let (i, j, k) = axes(&n).unwrap();
            let mut ei = [0.0; 3];
            ei[i] = 1.0;
            let mut ej = [0.0; 3];
            ej[j] = 1.0;
            let c = cross(&ei, &ej);
            assert!(c[k] * n[k] > 0.0, "n={n:?}");
        }
        assert!(axes(&[0.0, 0.0, 0.0]).is_none());
    }

    #[test]
    fn key_folds_negative_zero() {
        assert_eq!(key(&[-0.0, 1.0, 2.0]), key(&[0.0, 1.0, 2.0]));
        assert_ne!(key(&[1.0, 1.0, 2.0]), key(&[1.0 + f64::EPSILON, 1.0, 2.0]));
    }
}
