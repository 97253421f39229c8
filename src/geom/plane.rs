//! Oriented planes and point/plane classification.

use serde::{Deserialize, Serialize};

use super::vec::{cross, dot_minus, norm, scale, sub};
use crate::predicates::P3;
use crate::tolerances::Tolerances;

/// Oriented plane `n·x = d`; `n` need not be unit length. The *front* (positive) side is
/// where `n·x > d`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plane {
    /// Normal (any non-zero length).
    pub n: [f64; 3],
    /// Offset: the plane is `n·x = d`.
    pub d: f64,
}

/// Position of a point relative to a plane, decided with tolerance
/// [`Tolerances::plane_abs`] on the (normalized) signed distance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Side {
    /// Signed distance `> plane_abs`.
    Front,
    /// Signed distance `< -plane_abs`.
    Back,
    /// `|signed distance| <= plane_abs` (also: degenerate plane or non-finite distance).
    On,
}

/// Position of a point set (polygon, polyhedron) relative to a plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Classification {
    /// Some point strictly front, none strictly back (the rest [`Side::On`]).
    Front,
    /// Some point strictly back, none strictly front.
    Back,
    /// Every point [`Side::On`].
    Coplanar,
    /// Some point strictly front and some strictly back.
    Straddles,
}

impl Classification {
    /// Fold the sides of a point set.
    pub fn from_sides(sides: impl IntoIterator<Item = Side>) -> Self {
        let (mut f, mut b) = (false, false);
        for s in sides {
            match s {
                Side::Front => f = true,
                Side::Back => b = true,
                Side::On => {}
            }
        }
        match (f, b) {
            (true, true) => Classification::Straddles,
            (true, false) => Classification::Front,
            (false, true) => Classification::Back,
            (false, false) => Classification::Coplanar,
        }
    }
}

impl Plane {
    /// Plane with normal `n` and offset `d`.
    pub fn new(n: [f64; 3], d: f64) -> Self {
        Plane { n, d }
    }

    /// Plane through `a, b, c` with `n = (b-a)×(c-a)`: the front side is where `a, b, c`
    /// appear counter-clockwise, i.e. `orient3d(a, b, c, p) > 0` ⇔ `p` in front (up to
    /// rounding). Degenerate (zero normal) when the points are collinear.
    pub fn from_points(a: &P3, b: &P3, c: &P3) -> Self {
        let n = cross(&sub(b, a), &sub(c, a));
        Plane {
            n,
            d: dot_minus(&n, a, 0.0),
        }
    }

    /// Plane with normal `n` through `p`.
    pub fn from_normal_point(n: [f64; 3], p: &P3) -> Self {
        Plane {
            n,
            d: dot_minus(&n, p, 0.0),
        }
    }

    /// `n·p - d`, unnormalized (compensated evaluation).
    #[inline]
    pub fn eval(&self, p: &P3) -> f64 {
        dot_minus(&self.n, p, self.d)
    }

    /// Euclidean signed distance of `p` (positive in front). NaN for a degenerate plane.
    #[inline]
    pub fn signed_distance(&self, p: &P3) -> f64 {
        self.eval(p) / norm(&self.n)
    }

    /// Same plane, opposite orientation.
    pub fn flipped(&self) -> Self {
        Plane {
            n: [-self.n[0], -self.n[1], -self.n[2]],
            d: -self.d,
        }
    }

    /// Same plane with a unit normal (unchanged if degenerate).
    pub fn normalized(&self) -> Self {
        let l = norm(&self.n);
        if l > 0.0 && l.is_finite() {
            Plane {
                n: scale(&self.n, 1.0 / l),
                d: self.d / l,
            }
        } else {
            *self
        }
    }

    /// Unit normal (zero if degenerate).
    pub fn unit_normal(&self) -> [f64; 3] {
        super::vec::normalize(&self.n)
    }

    /// True when the normal is zero or not finite (such a plane classifies everything On).
    pub fn is_degenerate(&self) -> bool {
        let l = norm(&self.n);
        !(l > 0.0 && l.is_finite() && self.d.is_finite())
    }

    /// Side of `p` with tolerance `tol.plane_abs()`.
    pub fn side(&self, p: &P3, tol: &Tolerances) -> Side {
        Classifier::new(self, tol).side_of(self.signed_distance(p))
    }
}

/// The relative floor below which a classifier's distance is 0 (8 ε = 2⁻⁵⁰, times
/// Σ|nᵢpᵢ| + |d|): a point whose exact position is on the plane lies off it, once rounded
/// to doubles, by up to about ε Σ|nᵢpᵢ|, and the plane's own coefficients are rounded by
/// ε|d|; below that bound the sign of the distance says nothing about the geometry. (A
/// crossing of a long edge can lie farther off, its interpolation error growing with the
/// edge; the plane and weld bands above the floor cover that.) Every On band, even 0 (the fallback cuts of
/// [`crate::geom::ConvexPolyhedron::cut`]), keeps such a point On, so a cut never puts a
/// crossing within rounding of an existing vertex (the 1-ulp edges, needle and folded
/// faces that made greedy-4 under noise 1e-5 invalid at every level, session 25). The
/// floor is relative to the point's own magnitude, not to the model's size, so it is no
/// model tolerance and changes nothing for points the plane tolerance already puts On.
pub(crate) const ROUNDING_FLOOR: f64 = 8.0 * f64::EPSILON / 2.0;

/// A plane prepared for many distance queries with one tolerance.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Classifier {
    plane: Plane,
    inv_len: f64,
    pub(crate) eps: f64,
}

impl Classifier {
    pub(crate) fn new(plane: &Plane, tol: &Tolerances) -> Self {
        let l = norm(&plane.n);
        let inv_len = if l > 0.0 && l.is_finite() { 1.0 / l } else { f64::NAN };
        Classifier {
            plane: *plane,
            inv_len,
            eps: tol.plane_abs(),
        }
    }

    /// For cutting polyhedra: points within [`Tolerances::snap_abs`] (the weld distance)
    /// of the plane are On, so a cut never creates a vertex closer than that to the
    /// endpoints of the edge it crosses (no sliver edges or faces).
    pub(crate) fn snapping(plane: &Plane, tol: &Tolerances) -> Self {
        Classifier {
            eps: tol.snap_abs(),
            ..Classifier::new(plane, tol)
        }
    }

    /// With an explicit On distance.
    pub(crate) fn with_eps(plane: &Plane, eps: f64) -> Self {
        let l = norm(&plane.n);
        let inv_len = if l > 0.0 && l.is_finite() { 1.0 / l } else { f64::NAN };
        Classifier {
            plane: *plane,
            inv_len,
            eps,
        }
    }

    /// Signed distance (NaN for a degenerate plane); exactly 0 when `p` lies on the
    /// plane to within the rounding of its own coordinates and of the plane's
    /// coefficients ([`ROUNDING_FLOOR`]).
    #[inline]
    pub(crate) fn dist(&self, p: &P3) -> f64 {
        let e = self.plane.eval(p);
        let n = &self.plane.n;
        let mag = (n[0] * p[0]).abs() + (n[1] * p[1]).abs() + (n[2] * p[2]).abs() + self.plane.d.abs();
        if e.abs() <= ROUNDING_FLOOR * mag {
            return 0.0;
        }
        e * self.inv_len
    }

    /// Side for a distance; NaN maps to On.
    #[inline]
    pub(crate) fn side_of(&self, d: f64) -> Side {
        if d > self.eps {
            Side::Front
        } else if d < -self.eps {
            Side::Back
        } else {
            Side::On
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::testutil::{Rng, frames};
    use super::*;
    use crate::predicates::orient3d;

    /// A point an ulp (per coordinate) from a point exactly on the plane is On for every
    /// band, even 0: its distance is below the rounding floor (the 1-ulp pairs the
    /// fallback cuts used to make). A point 1e-9 off is still on its side with band 0.
    #[test]
    fn points_an_ulp_off_the_plane_are_on_for_every_band() {
        let mut rng = Rng::new(11);
        let up = |x: f64| f64::from_bits(if x > 0.0 { x.to_bits() + 1 } else { x.to_bits() - 1 });
        for _ in 0..2000 {
            // Small integer normal and dyadic point: d = n·x exactly.
            let n = [0, 1, 2].map(|_| (rng.point(8.0)[0]).round());
            let x = rng.point(20.0).map(|c| (c * 1024.0).round() / 1024.0);
            if n == [0.0; 3] || x.contains(&0.0) {
                continue;
            }
            let pl = Plane::new(n, n[0] * x[0] + n[1] * x[1] + n[2] * x[2]);
            assert_eq!(pl.eval(&x), 0.0);
            let cl = Classifier::with_eps(&pl, 0.0);
            let y = [up(x[0]), up(x[1]), up(x[2])];
            assert_eq!(cl.side_of(cl.dist(&y)), Side::On, "{y:?} on {pl:?}: {:e}", pl.eval(&y));
            let u = pl.unit_normal();
            let z = [x[0] + 1e-9 * u[0], x[1] + 1e-9 * u[1], x[2] + 1e-9 * u[2]];
            assert_eq!(cl.side_of(cl.dist(&z)), Side::Front);
        }
    }

    #[test]
    fn orientation_matches_orient3d() {
        let mut rng = Rng::new(7);
        for _ in 0..2000 {
            let a = rng.point(10.0);
            let b = rng.point(10.0);
            let c = rng.point(10.0);
            let p = rng.point(10.0);
            let pl = Plane::from_points(&a, &b, &c);
            let o = orient3d(&a, &b, &c, &p);
            let s = pl.signed_distance(&p);
            if s.abs() > 1e-9 {
                assert_eq!(o, if s > 0.0 { 1 } else { -1 });
            }
        }
    }

    #[test]
    fn distance_is_normalized_and_flip_negates() {
        let pl = Plane::from_points(&[0.0, 0.0, 2.0], &[3.0, 0.0, 2.0], &[0.0, 5.0, 2.0]);
        assert_eq!(pl.n, [0.0, 0.0, 15.0]);
        assert_eq!(pl.signed_distance(&[7.0, -3.0, 5.0]), 3.0);
        assert_eq!(pl.flipped().signed_distance(&[7.0, -3.0, 5.0]), -3.0);
        assert_eq!(pl.normalized().n, [0.0, 0.0, 1.0]);
        assert_eq!(pl.normalized().d, 2.0);
        let tol = Tolerances::for_scale(1.0);
        assert_eq!(pl.side(&[1.0, 1.0, 2.0 + 1e-12], &tol), Side::On);
        assert_eq!(pl.side(&[1.0, 1.0, 2.0 + 1e-6], &tol), Side::Front);
        assert_eq!(pl.flipped().side(&[1.0, 1.0, 2.0 + 1e-6], &tol), Side::Back);
        let deg = Plane::from_points(&[0.0; 3], &[1.0, 1.0, 1.0], &[2.0, 2.0, 2.0]);
        assert!(deg.is_degenerate());
        assert_eq!(deg.side(&[5.0, 0.0, 0.0], &tol), Side::On);
    }

    #[test]
    fn on_plane_points_stay_on_in_every_frame() {
        // Points of a unit-square grid lie on the plane through three of its corners, in
        // every frame (rotation by 7°, 8°, 9° and offset 1e6 included); points lifted by
        // 10 plane tolerances are Front.
        for (fr, tol) in frames(2.0f64.sqrt()) {
            let c = |x: f64, y: f64, z: f64| fr.apply([x, y, z]);
            let pl = Plane::from_points(&c(0.0, 0.0, 0.0), &c(1.0, 0.0, 0.0), &c(0.0, 1.0, 0.0));
            let lift = 10.0 * tol.plane_abs() / fr.scale;
            for i in 0..=8 {
                for j in 0..=8 {
                    let (x, y) = (i as f64 / 8.0, j as f64 / 8.0);
                    assert_eq!(pl.side(&c(x, y, 0.0), &tol), Side::On, "{}", fr.name);
                    assert_eq!(pl.side(&c(x, y, lift), &tol), Side::Front, "{}", fr.name);
                    assert_eq!(pl.side(&c(x, y, -lift), &tol), Side::Back, "{}", fr.name);
                }
            }
        }
    }
}
