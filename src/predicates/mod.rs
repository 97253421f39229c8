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

mod wide;

/// A point as stored everywhere in the crate.
pub type P3 = [f64; 3];

#[inline(always)]
fn c(p: &P3) -> Coord3D<f64> {
    Coord3D {
        x: p[0],
        y: p[1],
        z: p[2],
    }
}

/// Exact sign of `det[b-a, c-a, d-a]`: positive when `d` is above the counter-clockwise
/// triangle `abc`. Returns -1, 0 or +1.
#[inline]
pub fn orient3d(a: &P3, b: &P3, c_: &P3, d: &P3) -> i32 {
    if [a, b, c_, d].iter().all(|p| in_filter_range(p)) {
        orient3d_in_range(a, b, c_, d)
    } else {
        orient3d_exact(a, b, c_, d)
    }
}

/// Whether the floating-point filters' error bounds hold for a point: each coordinate is 0
/// or of magnitude in [2^-100, 2^101). Then every nonzero coordinate difference between
/// such points lies in [2^-152, 2^102), so no product of up to five of them (insphere's
/// degree) underflows or overflows, as Shewchuk's bounds assume. A subnormal product
/// breaks them: its rounding error is not relative. Outside the range the exact paths
/// decide alone.
#[inline(always)]
pub fn in_filter_range(p: &P3) -> bool {
    p.iter()
        .all(|&x| x == 0.0 || ((x.to_bits() >> 52) & 0x7ff).wrapping_sub(923) <= 200)
}

/// [`orient3d`] for points the caller has checked with [`in_filter_range`].
#[inline]
pub fn orient3d_in_range(a: &P3, b: &P3, c_: &P3, d: &P3) -> i32 {
    // Shewchuk's orient3d is positive when d is *below*; we negate.
    if let Some(s) = orient3d_filter(a, b, c_, d) {
        return -s;
    }
    orient3d_exact(a, b, c_, d)
}

#[cold]
fn orient3d_exact(a: &P3, b: &P3, c_: &P3, d: &P3) -> i32 {
    // Four points with one coordinate equal lie in an axis plane: coplanar, exactly. The
    // common degenerate case of architectural models (a floor's or a wall's points), where
    // the filter cannot decide and the wide integers would.
    if (0..3).any(|k| a[k] == b[k] && a[k] == c_[k] && a[k] == d[k]) {
        return 0;
    }
    if let Some(s) = lattice::orient3d(a, b, c_, d) {
        return s;
    }
    if let Some(s) = wide::orient3d(a, b, c_, d).or_else(|| wide::orient3d_any(a, b, c_, d)) {
        return s;
    }
    // Only non-finite coordinates get here.
    -sign(robust::orient3d(c(a), c(b), c(c_), c(d)))
}

/// Exact sign of the insphere determinant: +1 when `e` is strictly inside the sphere
/// through the positively oriented tetrahedron `(a, b, c, d)`, -1 outside, 0 on it.
#[inline]
pub fn insphere(a: &P3, b: &P3, c_: &P3, d: &P3, e: &P3) -> i32 {
    if [a, b, c_, d, e].iter().all(|p| in_filter_range(p)) {
        insphere_in_range(a, b, c_, d, e)
    } else {
        insphere_exact(a, b, c_, d, e)
    }
}

/// [`insphere`] for points the caller has checked with [`in_filter_range`].
#[inline]
pub fn insphere_in_range(a: &P3, b: &P3, c_: &P3, d: &P3, e: &P3) -> i32 {
    // Shewchuk requires his positive orientation, which is our negative: swapping a and b
    // makes our positive tetrahedron his positive one.
    if let Some(s) = insphere_filter(b, a, c_, d, e) {
        return s;
    }
    insphere_exact(a, b, c_, d, e)
}

#[cold]
fn insphere_exact(a: &P3, b: &P3, c_: &P3, d: &P3, e: &P3) -> i32 {
    if let Some(s) = lattice::insphere(b, a, c_, d, e) {
        return s;
    }
    if let Some(s) = wide::insphere_shewchuk(b, a, c_, d, e).or_else(|| wide::insphere_shewchuk_any(b, a, c_, d, e)) {
        return s;
    }
    // Only non-finite coordinates get here.
    sign(robust::insphere(c(b), c(a), c(c_), c(d), c(e)))
}

#[inline(always)]
fn sign(v: f64) -> i32 {
    if v > 0.0 {
        1
    } else if v < 0.0 {
        -1
    } else {
        0
    }
}

/// Number types the exact determinants are evaluated in (`i64`, `i128`, `wide::Wide`).
trait Exact: Copy + std::ops::Add<Output = Self> + std::ops::Sub<Output = Self> + std::ops::Mul<Output = Self> {}
impl<T: Copy + std::ops::Add<Output = T> + std::ops::Sub<Output = T> + std::ops::Mul<Output = T>> Exact for T {}

/// `det[u, v, w]`: the orientation determinant of three difference vectors, written once
/// for every exact number type.
#[inline(always)]
fn orient_det<T: Exact>(u: [T; 3], v: [T; 3], w: [T; 3]) -> T {
    u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0])
}

/// Shewchuk's insphere determinant of the differences `a, b, c, d` (each minus the query
/// point), in his sign convention, written once for every exact number type.
#[inline(always)]
fn insphere_det<T: Exact>(a: [T; 3], b: [T; 3], c: [T; 3], d: [T; 3]) -> T {
    let ab = a[0] * b[1] - b[0] * a[1];
    let bc = b[0] * c[1] - c[0] * b[1];
    let cd = c[0] * d[1] - d[0] * c[1];
    let da = d[0] * a[1] - a[0] * d[1];
    let ac = a[0] * c[1] - c[0] * a[1];
    let bd = b[0] * d[1] - d[0] * b[1];
    let abc = a[2] * bc - b[2] * ac + c[2] * ab;
    let bcd = b[2] * cd - c[2] * bd + d[2] * bc;
    let cda = c[2] * da + d[2] * ac + a[2] * cd;
    let dab = d[2] * ab + a[2] * bd + b[2] * da;
    let lift = |p: [T; 3]| p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
    (lift(d) * abc - lift(c) * dab) + (lift(b) * cda - lift(a) * bcd)
}

const EPS: f64 = f64::EPSILON / 2.0; // 2^-53, Shewchuk's epsilon
const O3D_BOUND: f64 = (7.0 + 56.0 * EPS) * EPS;
const ISP_BOUND: f64 = (16.0 + 224.0 * EPS) * EPS;

/// Shewchuk's orient3d floating-point stage with his a-priori error bound: the sign when
/// it is certain, `None` when the exact stage must decide. (Sign in Shewchuk's convention.)
#[inline(always)]
fn orient3d_filter(a: &P3, b: &P3, c_: &P3, d: &P3) -> Option<i32> {
    let (adx, ady, adz) = (a[0] - d[0], a[1] - d[1], a[2] - d[2]);
    let (bdx, bdy, bdz) = (b[0] - d[0], b[1] - d[1], b[2] - d[2]);
    let (cdx, cdy, cdz) = (c_[0] - d[0], c_[1] - d[1], c_[2] - d[2]);
    let (bdxcdy, cdxbdy) = (bdx * cdy, cdx * bdy);
    let (cdxady, adxcdy) = (cdx * ady, adx * cdy);
    let (adxbdy, bdxady) = (adx * bdy, bdx * ady);
    let det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
    let perm = (bdxcdy.abs() + cdxbdy.abs()) * adz.abs()
        + (cdxady.abs() + adxcdy.abs()) * bdz.abs()
        + (adxbdy.abs() + bdxady.abs()) * cdz.abs();
    let bound = O3D_BOUND * perm;
    if det > bound {
        Some(1)
    } else if -det > bound {
        Some(-1)
    } else {
        None
    }
}

/// The larger of two differences, in one `maxsd` (`f64::max`'s NaN rules cost several
/// instructions, on the hottest path of the tetrahedralization). It may drop a NaN, but a
/// NaN difference makes the determinant NaN too, and then no comparison certifies a sign.
#[inline(always)]
fn fmax(a: f64, b: f64) -> f64 {
    if a > b { a } else { b }
}

/// Shewchuk's insphere floating-point stage with his a-priori error bound (his convention).
#[inline(always)]
fn insphere_filter(a: &P3, b: &P3, c_: &P3, d: &P3, e: &P3) -> Option<i32> {
    let (aex, aey, aez) = (a[0] - e[0], a[1] - e[1], a[2] - e[2]);
    let (bex, bey, bez) = (b[0] - e[0], b[1] - e[1], b[2] - e[2]);
    let (cex, cey, cez) = (c_[0] - e[0], c_[1] - e[1], c_[2] - e[2]);
    let (dex, dey, dez) = (d[0] - e[0], d[1] - e[1], d[2] - e[2]);
    let (aexbey, bexaey) = (aex * bey, bex * aey);
    let ab = aexbey - bexaey;
    let (bexcey, cexbey) = (bex * cey, cex * bey);
    let bc = bexcey - cexbey;
    let (cexdey, dexcey) = (cex * dey, dex * cey);
    let cd = cexdey - dexcey;
    let (dexaey, aexdey) = (dex * aey, aex * dey);
    let da = dexaey - aexdey;
    let (aexcey, cexaey) = (aex * cey, cex * aey);
    let ac = aexcey - cexaey;
    let (bexdey, dexbey) = (bex * dey, dex * bey);
    let bd = bexdey - dexbey;
    let abc = aez * bc - bez * ac + cez * ab;
    let bcd = bez * cd - cez * bd + dez * bc;
    let cda = cez * da + dez * ac + aez * cd;
    let dab = dez * ab + aez * bd + bez * da;
    let alift = aex * aex + aey * aey + aez * aez;
    let blift = bex * bex + bey * bey + bez * bez;
    let clift = cex * cex + cey * cey + cez * cez;
    let dlift = dex * dex + dey * dey + dez * dez;
    let det = (dlift * abc - clift * dab) + (blift * cda - alift * bcd);
    // Semi-static stage (as CGAL's static filters): bound the permanent by the largest
    // coordinate differences, permanent <= 24 mx my mz (mx² + my² + mz²). Cheaper than the
    // permanent itself and decisive for almost every call; the slack factor covers the
    // rounding of this product.
    let mx = fmax(fmax(aex.abs(), bex.abs()), fmax(cex.abs(), dex.abs()));
    let my = fmax(fmax(aey.abs(), bey.abs()), fmax(cey.abs(), dey.abs()));
    let mz = fmax(fmax(aez.abs(), bez.abs()), fmax(cez.abs(), dez.abs()));
    let semi = ISP_BOUND * (24.0 * (1.0 + 1e-10)) * (mx * my * mz) * (mx * mx + my * my + mz * mz);
    if det > semi {
        return Some(1);
    } else if -det > semi {
        return Some(-1);
    }
    let (az, bz, cz, dz) = (aez.abs(), bez.abs(), cez.abs(), dez.abs());
    let perm =
        ((cexdey.abs() + dexcey.abs()) * bz + (dexbey.abs() + bexdey.abs()) * cz + (bexcey.abs() + cexbey.abs()) * dz)
            * alift
            + ((dexaey.abs() + aexdey.abs()) * cz
                + (aexcey.abs() + cexaey.abs()) * dz
                + (cexdey.abs() + dexcey.abs()) * az)
                * blift
            + ((aexbey.abs() + bexaey.abs()) * dz
                + (bexdey.abs() + dexbey.abs()) * az
                + (dexaey.abs() + aexdey.abs()) * bz)
                * clift
            + ((bexcey.abs() + cexbey.abs()) * az
                + (cexaey.abs() + aexcey.abs()) * bz
                + (aexbey.abs() + bexaey.abs()) * cz)
                * dlift;
    let bound = ISP_BOUND * perm;
    if det > bound {
        Some(1)
    } else if -det > bound {
        Some(-1)
    } else {
        None
    }
}

/// Exact integer arithmetic for inputs on a small binary lattice — the architectural case
/// (integer or half-unit coordinates, regular grids) where exact ties are common and the
/// adaptive expansion arithmetic would otherwise run to its last stage on every tie.
///
/// Applies when every coordinate times 2^8 is an integer of magnitude at most 2^22 (that is
/// |x| ≤ 16384 in steps of 1/256). Differences then fit in 24 bits, and the insphere
/// determinant (degree 5) in well under 127 bits, so `i128` evaluation is exact. Scaling by
/// a power of two is exact, so the answer is the sign for the coordinates as given.
mod lattice {
    use super::P3;

    const SCALE: f64 = 256.0;
    const LIMIT: f64 = (1u64 << 22) as f64;

    #[inline]
    fn to_int(p: &P3) -> Option<[i64; 3]> {
        let mut r = [0i64; 3];
        for k in 0..3 {
            let s = p[k] * SCALE;
            let i = s as i64; // saturating; NaN -> 0
            if s.abs() > LIMIT || i as f64 != s {
                return None;
            }
            r[k] = i;
        }
        Some(r)
    }

    fn sub(a: [i64; 3], b: [i64; 3]) -> [i128; 3] {
        [(a[0] - b[0]) as i128, (a[1] - b[1]) as i128, (a[2] - b[2]) as i128]
    }

    /// Our orient3d convention: sign of det[b-a, c-a, d-a].
    pub fn orient3d(a: &P3, b: &P3, c: &P3, d: &P3) -> Option<i32> {
        let (a, b, c, d) = (to_int(a)?, to_int(b)?, to_int(c)?, to_int(d)?);
        Some(super::orient_det(sub(b, a), sub(c, a), sub(d, a)).signum() as i32)
    }

    /// Shewchuk's insphere convention (positive inside for his positive orientation).
    pub fn insphere(a: &P3, b: &P3, c: &P3, d: &P3, e: &P3) -> Option<i32> {
        let e = to_int(e)?;
        let d3 = |p: &P3| -> Option<[i64; 3]> {
            let q = to_int(p)?;
            Some([q[0] - e[0], q[1] - e[1], q[2] - e[2]])
        };
        let (a, b, c, d) = (d3(a)?, d3(b)?, d3(c)?, d3(d)?);
        let m = [a, b, c, d].iter().flatten().map(|x| x.abs()).max().unwrap_or(0);
        // Differences below 2^10: every term fits in i64 (|det| < 2^57). Otherwise i128.
        Some(if m < 1 << 10 {
            det::<i64>(a, b, c, d)
        } else {
            det::<i128>(a, b, c, d)
        })
    }

    pub(super) fn det<T: From<i64> + Ord + Default + super::Exact>(
        a: [i64; 3],
        b: [i64; 3],
        c: [i64; 3],
        d: [i64; 3],
    ) -> i32 {
        let [a, b, c, d] = [a, b, c, d].map(|p| p.map(T::from));
        let det = super::insphere_det(a, b, c, d);
        let zero = T::default();
        (det > zero) as i32 - (det < zero) as i32
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
    sos_tie(ranks, |q| orient3d(pts[q[0]], pts[q[1]], pts[q[2]], pts[q[3]]))
}

/// The symbolic-perturbation case analysis for a cospherical tie among points 0..5 (point
/// 4 is the query), given an exact orientation oracle on local indices.
///
/// Order the five points by decreasing rank. The leading term of the perturbed
/// determinant belongs to the highest-ranked point: its coefficient is the orientation of
/// the other four (with the query point substituted in that point's slot). If it is zero
/// (those four are coplanar), the next term decides. Two terms always suffice
/// (Devillers & Teillaud, Lemma 3), because (a, b, c, d) is non-degenerate. Same case
/// analysis as CGAL's `side_of_oriented_sphere` with perturbation.
#[inline]
pub fn sos_tie(ranks: [u32; 5], orient: impl Fn([usize; 4]) -> i32) -> i32 {
    let mut order = [0usize, 1, 2, 3, 4];
    order.sort_unstable_by(|&i, &j| ranks[j].cmp(&ranks[i]));
    for &i in &order[..4] {
        let o = match i {
            4 => return -1, // the query itself is the most perturbed: pushed outside
            3 => orient([0, 1, 2, 4]),
            2 => orient([0, 1, 4, 3]),
            1 => orient([0, 4, 2, 3]),
            _ => orient([4, 1, 2, 3]),
        };
        if o != 0 {
            return o;
        }
    }
    unreachable!("insphere_sos: tetrahedron is degenerate")
}

/// Exact predicates by point index for point sets on a small binary lattice: every
/// coordinate times 2^k (one k ≤ 8 for the whole set) is an integer of magnitude ≤ 2^22.
/// Architectural and grid inputs (integer or half-unit coordinates) qualify; for them exact
/// ties are the common case, and integer arithmetic answers them without any filter:
/// `i64` when every coordinate range is below 2^10 (insphere terms stay below 2^57), `i128`
/// otherwise (below 2^122). Scaling by 2^k is exact, so the signs are those of the input.
#[derive(Clone, Debug)]
pub struct LatticePoints {
    pts: Vec<[i64; 3]>,
    small: bool,
}

impl LatticePoints {
    /// The lattice representation of `points`, if they qualify.
    pub fn detect(points: &[P3]) -> Option<Self> {
        const LIMIT: f64 = (1u64 << 22) as f64;
        'k: for k in 0..=8 {
            let s = (1u32 << k) as f64;
            let mut pts = Vec::with_capacity(points.len());
            let mut lo = [i64::MAX; 3];
            let mut hi = [i64::MIN; 3];
            for p in points {
                let mut q = [0i64; 3];
                for a in 0..3 {
                    let x = p[a] * s;
                    let i = x as i64;
                    if x.abs() > LIMIT || i as f64 != x {
                        if x.abs() > LIMIT {
                            return None;
                        }
                        continue 'k;
                    }
                    q[a] = i;
                    lo[a] = lo[a].min(i);
                    hi[a] = hi[a].max(i);
                }
                pts.push(q);
            }
            let small = (0..3).all(|a| hi[a].saturating_sub(lo[a]) < 1 << 10);
            return Some(LatticePoints { pts, small });
        }
        None
    }

    #[inline(always)]
    fn d(&self, p: u32, o: [i64; 3]) -> [i64; 3] {
        let q = self.pts[p as usize];
        [q[0] - o[0], q[1] - o[1], q[2] - o[2]]
    }

    /// Our orient3d convention (sign of det[b-a, c-a, d-a]) by index.
    #[inline]
    pub fn orient3d(&self, a: u32, b: u32, c: u32, d: u32) -> i32 {
        let o = self.pts[a as usize];
        let (u, v, w) = (self.d(b, o), self.d(c, o), self.d(d, o));
        if self.small {
            det3::<i64>(u, v, w)
        } else {
            det3::<i128>(u, v, w)
        }
    }

    /// Our insphere convention (positive inside a positively oriented tetrahedron) by index.
    #[inline]
    pub fn insphere(&self, a: u32, b: u32, c: u32, d: u32, e: u32) -> i32 {
        let o = self.pts[e as usize];
        // Shewchuk's convention is positive for his positive orientation = our negative:
        // swap a and b.
        let (pa, pb, pc, pd) = (self.d(b, o), self.d(a, o), self.d(c, o), self.d(d, o));
        if self.small {
            lattice::det::<i64>(pa, pb, pc, pd)
        } else {
            lattice::det::<i128>(pa, pb, pc, pd)
        }
    }

    /// [`LatticePoints::insphere`] with the symbolic perturbation of [`insphere_sos`].
    #[inline]
    pub fn insphere_sos(&self, v: [u32; 5], ranks: impl Fn(u32) -> u32) -> i32 {
        let s = self.insphere(v[0], v[1], v[2], v[3], v[4]);
        if s != 0 {
            return s;
        }
        sos_tie(v.map(ranks), |q| self.orient3d(v[q[0]], v[q[1]], v[q[2]], v[q[3]]))
    }
}

fn det3<T: From<i64> + Ord + Default + Exact>(u: [i64; 3], v: [i64; 3], w: [i64; 3]) -> i32 {
    let [u, v, w] = [u, v, w].map(|p| p.map(T::from));
    let det = orient_det(u, v, w);
    let zero = T::default();
    (det > zero) as i32 - (det < zero) as i32
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
    if ![a, b, c_].iter().all(|p| in_filter_range(p)) {
        // Outside the filters' range: the 2D determinant is the 3D one of the projected
        // points lifted to z = 0 against the apex (0, 0, 1), decided exactly.
        let lift = |p: &P3| [p[i], p[j], 0.0];
        return orient3d_exact(&lift(a), &lift(b), &lift(c_), &[0.0, 0.0, 1.0]);
    }
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

    /// Four points on an axis plane are coplanar: the shortcut's answer is the wide
    /// integers' (over magnitudes from 1e-300 to 1e300, on each axis), and a point just
    /// off the plane still gets its sign from the exact stages.
    #[test]
    fn points_on_an_axis_plane_are_coplanar_as_the_exact_stage_says() {
        let mut r = crate::base::rng::SplitMix64(77);
        let mut f = |scale: f64| ((r.next_u64() >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * scale;
        for scale in [1e-300, 1e-20, 1.0, 3.0e7, 1e20, 1e300] {
            for k in 0..3 {
                for _ in 0..50 {
                    let plane = f(scale);
                    let mut p = [[0.0; 3]; 4];
                    for q in &mut p {
                        *q = [f(scale), f(scale), f(scale)];
                        q[k] = plane;
                    }
                    let [a, b, c, d] = p;
                    assert_eq!(orient3d(&a, &b, &c, &d), 0);
                    assert_eq!(
                        wide::orient3d(&a, &b, &c, &d).or_else(|| wide::orient3d_any(&a, &b, &c, &d)),
                        Some(0)
                    );
                    // Off the plane by one ulp: the same sign as the exact stages give.
                    let mut e = d;
                    e[k] = f64::from_bits(plane.to_bits() + 1);
                    let want = wide::orient3d(&a, &b, &c, &e).or_else(|| wide::orient3d_any(&a, &b, &c, &e));
                    assert_eq!(Some(orient3d(&a, &b, &c, &e)), want);
                }
            }
        }
    }

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
    fn filters_and_lattice_agree_with_robust() {
        // Random small-lattice points (many ties) and random reals: every path must give
        // robust's exact sign.
        let mut r = crate::base::rng::SplitMix64(9);
        for round in 0..20_000 {
            let pt = |r: &mut crate::base::rng::SplitMix64| -> P3 {
                if round % 2 == 0 {
                    [0; 3].map(|_| (r.below(5) as f64) * 0.5)
                } else {
                    [0; 3].map(|_| (r.next_u64() >> 11) as f64 / (1u64 << 53) as f64 * 1e3 + 1e6)
                }
            };
            let (a, b, cc, d, e) = (pt(&mut r), pt(&mut r), pt(&mut r), pt(&mut r), pt(&mut r));
            let want_o = -sign(robust::orient3d(c(&a), c(&b), c(&cc), c(&d)));
            assert_eq!(orient3d(&a, &b, &cc, &d), want_o);
            assert_eq!(orient3d_exact(&a, &b, &cc, &d), want_o);
            let want_s = sign(robust::insphere(c(&b), c(&a), c(&cc), c(&d), c(&e)));
            assert_eq!(insphere(&a, &b, &cc, &d, &e), want_s);
            assert_eq!(insphere_exact(&a, &b, &cc, &d, &e), want_s);
        }
    }

    #[test]
    fn lattice_kernel_agrees_with_float_kernel() {
        let mut r = crate::base::rng::SplitMix64(5);
        for scale in [1.0, 0.5, 100.0] {
            let pts: Vec<P3> = (0..200).map(|_| [0; 3].map(|_| r.below(6) as f64 * scale)).collect();
            let lat = LatticePoints::detect(&pts).expect("lattice");
            for _ in 0..5000 {
                let i = [0; 5].map(|_| r.below(pts.len()) as u32);
                let p = i.map(|k| &pts[k as usize]);
                assert_eq!(lat.orient3d(i[0], i[1], i[2], i[3]), orient3d(p[0], p[1], p[2], p[3]));
                assert_eq!(
                    lat.insphere(i[0], i[1], i[2], i[3], i[4]),
                    insphere(p[0], p[1], p[2], p[3], p[4])
                );
            }
        }
        assert!(LatticePoints::detect(&[[0.1, 0.0, 0.0]]).is_none());
        assert!(LatticePoints::detect(&[[1e9, 0.0, 0.0]]).is_none());
    }

    #[test]
    fn signs_survive_power_of_two_scaling_into_subnormals_and_huge_values() {
        // Scaling every coordinate by 2^k is exact and multiplies the determinants by a
        // positive power of two, so the signs must not change, even where the products
        // underflow (2^-1060: subnormal coordinates) or would overflow (2^900).
        let mut r = crate::base::rng::SplitMix64(21);
        for _ in 0..3000 {
            let q = [0; 5].map(|_| [0; 3].map(|_| r.below(7) as f64));
            let want_o = orient3d(&q[0], &q[1], &q[2], &q[3]);
            let want_s = insphere(&q[0], &q[1], &q[2], &q[3], &q[4]);
            for k in [-1060, -600, 900] {
                let f = 2f64.powi(k);
                let s = q.map(|p| p.map(|x| x * f));
                assert_eq!(orient3d(&s[0], &s[1], &s[2], &s[3]), want_o, "2^{k} {q:?}");
                assert_eq!(insphere(&s[0], &s[1], &s[2], &s[3], &s[4]), want_s, "2^{k} {q:?}");
            }
        }
        // A subnormal beside 1: the determinant is t² > 0, which underflows in floating point.
        let t = f64::from_bits(1);
        assert_eq!(orient3d(&O, &[t, 0.0, 0.0], &[0.0, t, 0.0], &Z), 1);
        assert!(!in_filter_range(&[t, 0.0, 0.0]) && in_filter_range(&[1.0, -0.0, 1e30]));
    }

    #[test]
    fn collinearity() {
        assert!(collinear(&O, &X, &[2.0, 0.0, 0.0]));
        assert!(!collinear(&O, &X, &Y));
        assert!(collinear(&[1.0, 1.0, 1.0], &[2.0, 2.0, 2.0], &[3.0, 3.0, 3.0]));
    }
}
