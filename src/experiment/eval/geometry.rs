//! Small vector helpers of the evaluation, on plain points.

use crate::geom::ConvexPolygon;
use crate::predicates::P3;

/// Length of the diagonal of `[lo, hi]`.
pub fn diagonal(b: &[P3; 2]) -> f64 {
    dist(&b[0], &b[1])
}

/// Euclidean distance.
pub fn dist(a: &P3, b: &P3) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Area-weighted centroid of convex polygons (the first one's centroid when all are
/// degenerate).
pub fn weighted_centroid(polys: &[ConvexPolygon]) -> P3 {
    let mut c = [0.0; 3];
    let mut w = 0.0;
    for q in polys {
        let a = q.area();
        let m = q.centroid();
        for k in 0..3 {
            c[k] += a * m[k];
        }
        w += a;
    }
    if w > 0.0 {
        c.map(|x| x / w)
    } else {
        polys.first().map(|q| q.centroid()).unwrap_or([f64::NAN; 3])
    }
}

/// The mean of `ps`.
pub fn mean(ps: &[P3]) -> P3 {
    let mut c = [0.0; 3];
    for p in ps {
        for k in 0..3 {
            c[k] += p[k] / ps.len() as f64;
        }
    }
    c
}

/// Unit Newell normal of a (possibly non-planar) closed polygon; `None` when degenerate.
pub fn newell_normal(ps: &[P3]) -> Option<P3> {
    let mut n = [0.0; 3];
    for (i, a) in ps.iter().enumerate() {
        let b = &ps[(i + 1) % ps.len()];
        n[0] += (a[1] - b[1]) * (a[2] + b[2]);
        n[1] += (a[2] - b[2]) * (a[0] + b[0]);
        n[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    let l = dot(&n, &n).sqrt();
    (l > 0.0 && l.is_finite()).then(|| n.map(|x| x / l))
}

/// Dot product.
pub fn dot(a: &P3, b: &P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn helpers_on_a_unit_square() {
        let sq = vec![[0.0, 0.0, 1.0], [2.0, 0.0, 1.0], [2.0, 2.0, 1.0], [0.0, 2.0, 1.0]];
        assert_eq!(mean(&sq), [1.0, 1.0, 1.0]);
        assert_eq!(newell_normal(&sq), Some([0.0, 0.0, 1.0]));
        assert_eq!(newell_normal(&[[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]), None);
        assert_eq!(diagonal(&[[0.0; 3], [3.0, 4.0, 0.0]]), 5.0);
        // A big square and a small one: the centroid leans to the big one by area.
        let big = ConvexPolygon::new(sq.clone());
        let small = ConvexPolygon::new(vec![
            [10.0, 0.0, 1.0],
            [11.0, 0.0, 1.0],
            [11.0, 1.0, 1.0],
            [10.0, 1.0, 1.0],
        ]);
        let c = weighted_centroid(&[big, small]);
        assert!((c[0] - (4.0 * 1.0 + 1.0 * 10.5) / 5.0).abs() < 1e-12, "{c:?}");
    }
}
