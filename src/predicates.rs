//! Exact geometric predicates: the only module whose answers decide combinatorics.
//!
//! Everything that decides *which side* — tetrahedralization, conforming checks, point
//! location, plane classification against polygons through input vertices — asks this
//! module. The predicates are Shewchuk's adaptive-precision ones (crate [`robust`]): a fast
//! floating-point filter, falling back to exact expansion arithmetic only when the filter
//! cannot certify the sign. They see the coordinates exactly as given; nothing here rounds,
//! shifts or scales.
//!
//! Sign conventions (ours, not Shewchuk's — his `orient3d` has the opposite sign):
//! - [`orient3d`]`(a, b, c, d) > 0` iff `d` lies on the side of plane `abc` from which `a, b, c`
//!   appear counter-clockwise, i.e. `det[b-a, c-a, d-a] > 0`. A tetrahedron `(a,b,c,d)` is
//!   *positively oriented* when this is positive.
//! - [`insphere`]`(a, b, c, d, e) > 0` iff `e` lies strictly inside the sphere through a
//!   positively oriented `(a, b, c, d)`.
//!
//! Ties (five cospherical points) are broken by [`insphere_sos`], a symbolic perturbation
//! (Devillers & Teillaud, "Perturbations for Delaunay and weighted Delaunay 3D
//! triangulations", CGTA 44(3), 2011): the lifted coordinate of each point is perturbed by
//! an infinitesimal whose size grows with the point's rank. The ranks we use are vertex
//! indices, and the tetrahedralization numbers vertices in lexicographic `(x, y, z)` order,
//! so the perturbation is the same as CGAL's and does not depend on input order.

use robust::Coord3D;

/// A point as stored everywhere in the crate.
pub type P3 = [f64; 3];

#[inline(always)]
fn c(p: &P3) -> Coord3D<f64> {
    Coord3D { x: p[0], y: p[1], z: p[2] }
}

/// Exact sign of `det[b-a, c-a, d-a]`: positive when `d` is above the counter-clockwise
/// triangle `abc`. Returns -1, 0 or +1.
#[inline]
pub fn orient3d(a: &P3, b: &P3, c_: &P3, d: &P3) -> i32 {
    let v = robust::orient3d(c(a), c(b), c(c_), c(d));
    // Shewchuk's orient3d is positive when d is *below*; negate.
    if v < 0.0 {
        1
    } else if v > 0.0 {
        -1
    } else {
        0
    }
}

/// Exact sign of the insphere determinant: +1 when `e` is strictly inside the sphere
/// through the positively oriented tetrahedron `(a, b, c, d)`, -1 outside, 0 on it.
#[inline]
pub fn insphere(a: &P3, b: &P3, c_: &P3, d: &P3, e: &P3) -> i32 {
    // Shewchuk requires his positive orientation, which is our negative: swapping a and b
    // makes our positive tetrahedron his positive one.
    let v = robust::insphere(c(b), c(a), c(c_), c(d), c(e));
    if v > 0.0 {
        1
    } else if v < 0.0 {
        -1
    } else {
        0
    }
}

/// [`insphere`] with symbolic perturbation: never returns 0.
///
/// `ranks` are the perturbation ranks of `a, b, c, d, e` (distinct; a higher rank gets a
/// larger perturbation of its lifted coordinate, which pushes it *outside* spheres). The
/// tetrahedron `(a, b, c, d)` must be positively oriented (non-degenerate).
#[inline]
pub fn insphere_sos(pts: [&P3; 5], ranks: [u32; 5]) -> i32 {
    let s = insphere(pts[0], pts[1], pts[2], pts[3], pts[4]);
    if s != 0 {
        return s;
    }
    insphere_tie(pts, ranks)
}

#[cold]
fn insphere_tie(pts: [&P3; 5], ranks: [u32; 5]) -> i32 {
    // Order the five points by decreasing rank. The leading term of the perturbed
    // determinant belongs to the highest-ranked point: its coefficient is the orientation of
    // the other four (with the query point substituted in that point's slot). If it is zero
    // (those four are coplanar), the next term decides. Two terms always suffice
    // (Devillers & Teillaud, Lemma 3), because (a, b, c, d) is non-degenerate.
    let mut order = [0usize, 1, 2, 3, 4];
    order.sort_unstable_by(|&i, &j| ranks[j].cmp(&ranks[i]));
    let [a, b, cc, d, e] = pts;
    for &i in &order[..4] {
        let o = match i {
            4 => return -1, // the query itself is the most perturbed: pushed outside
            3 => orient3d(a, b, cc, e),
            2 => orient3d(a, b, e, d),
            1 => orient3d(a, e, cc, d),
            _ => orient3d(e, b, cc, d),
        };
        if o != 0 {
            // Same case analysis as CGAL's `side_of_oriented_sphere` with perturbation:
            // the coefficient is the orientation with the query in point i's slot.
            return o;
        }
    }
    unreachable!("insphere_sos: tetrahedron is degenerate")
}

/// Exact sign of the 2D orientation of the projections of `a, b, c` onto the coordinate
/// plane that drops axis `drop` (0 = x, 1 = y, 2 = z).
#[inline]
pub fn orient2d_proj(a: &P3, b: &P3, c_: &P3, drop: usize) -> i32 {
    let (i, j) = match drop {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    };
    let v = robust::orient2d(
        robust::Coord { x: a[i], y: a[j] },
        robust::Coord { x: b[i], y: b[j] },
        robust::Coord { x: c_[i], y: c_[j] },
    );
    if v > 0.0 {
        1
    } else if v < 0.0 {
        -1
    } else {
        0
    }
}

/// True when `a, b, c` are exactly collinear (all three coordinate projections degenerate).
pub fn collinear(a: &P3, b: &P3, c_: &P3) -> bool {
    (0..3).all(|d| orient2d_proj(a, b, c_, d) == 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    const O: P3 = [0.0, 0.0, 0.0];
    const X: P3 = [1.0, 0.0, 0.0];
    const Y: P3 = [0.0, 1.0, 0.0];
    const Z: P3 = [0.0, 0.0, 1.0];

    #[test]
    fn orientation_convention() {
        assert_eq!(orient3d(&O, &X, &Y, &Z), 1);
        assert_eq!(orient3d(&O, &Y, &X, &Z), -1);
        assert_eq!(orient3d(&O, &X, &Y, &[3.0, 7.0, 0.0]), 0);
    }

    #[test]
    fn insphere_convention() {
        assert_eq!(insphere(&O, &X, &Y, &Z, &[0.2, 0.2, 0.2]), 1);
        assert_eq!(insphere(&O, &X, &Y, &Z, &[5.0, 5.0, 5.0]), -1);
        // (1,1,1) is cospherical with the unit corner tetrahedron.
        assert_eq!(insphere(&O, &X, &Y, &Z, &[1.0, 1.0, 1.0]), 0);
    }

    #[test]
    fn exact_near_degenerate() {
        // A point off the plane by one ulp at 1e6 offset is still detected.
        let off: f64 = 1e6;
        let a = [off, off, off];
        let b = [off + 1.0, off, off];
        let c_ = [off, off + 1.0, off];
        let d = [off + 0.5, off + 0.5, f64::from_bits(off.to_bits() + 1)];
        assert_eq!(orient3d(&a, &b, &c_, &d), 1);
        let d0 = [off + 0.5, off + 0.5, off];
        assert_eq!(orient3d(&a, &b, &c_, &d0), 0);
    }

    #[test]
    fn sos_is_antisymmetric_on_cube() {
        // Cube corners are cospherical. For two tetrahedra sharing a face, the perturbed
        // answers for the opposite corner must be consistent: exactly one of the two
        // tetrahedra of a cospherical pair may "contain" the fifth point.
        let p: Vec<P3> = (0..8)
            .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
            .collect();
        // Tetrahedron (0,1,2,4) is positive; query 7.
        assert_eq!(orient3d(&p[0], &p[1], &p[2], &p[4]), 1);
        let s = insphere_sos([&p[0], &p[1], &p[2], &p[4], &p[7]], [0, 1, 2, 4, 7]);
        assert_eq!(s, -1, "highest-ranked query is outside");
        // Query a lower-ranked point against a tetrahedron containing 7.
        let t = [3usize, 5, 6, 7];
        let (a, b, cc, d) = (&p[t[0]], &p[t[1]], &p[t[2]], &p[t[3]]);
        let (a, b) = if orient3d(a, b, cc, d) > 0 { (a, b) } else { (b, a) };
        let s2 = insphere_sos([a, b, cc, d, &p[0]], [3, 5, 6, 7, 0]);
        assert_ne!(s2, 0);
    }

    #[test]
    fn collinearity() {
        assert!(collinear(&O, &X, &[2.0, 0.0, 0.0]));
        assert!(!collinear(&O, &X, &Y));
        assert!(collinear(&[1.0, 1.0, 1.0], &[2.0, 2.0, 2.0], &[3.0, 3.0, 3.0]));
    }
}
