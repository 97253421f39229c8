//! Small helpers shared by the suite's generators: vectors, a seeded uniform generator,
//! axis-aligned boxes and the similarity transform of the rotated family.

use crate::base::rng::SplitMix64;
use crate::predicates::P3;
use serde::Serialize;

pub(crate) fn add(a: P3, b: P3) -> P3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub(crate) fn sub(a: P3, b: P3) -> P3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(crate) fn scale(a: P3, s: f64) -> P3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub(crate) fn dot(a: P3, b: P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(crate) fn cross(a: P3, b: P3) -> P3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub(crate) fn norm(a: P3) -> f64 {
    dot(a, a).sqrt()
}
pub(crate) fn dist(a: P3, b: P3) -> f64 {
    norm(sub(a, b))
}
pub(crate) fn mean(ps: &[P3]) -> P3 {
    let mut c = [0.0; 3];
    for p in ps {
        for k in 0..3 {
            c[k] += p[k] / ps.len() as f64;
        }
    }
    c
}

/// A seeded generator with uniform reals (SplitMix64 underneath).
pub(crate) struct Rng(SplitMix64);

impl Rng {
    pub(crate) fn new(seed: u64) -> Self {
        Rng(SplitMix64(seed))
    }
    /// Uniform in `[0, 1)`.
    pub(crate) fn f(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in `[a, b)`.
    pub(crate) fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.f()
    }
    /// Uniform in `0..n` (n > 0).
    pub(crate) fn below(&mut self, n: usize) -> usize {
        self.0.below(n)
    }
    /// True with probability `p`.
    pub(crate) fn chance(&mut self, p: f64) -> bool {
        self.f() < p
    }
    /// One of `xs`.
    pub(crate) fn pick<T: Copy>(&mut self, xs: &[T]) -> T {
        xs[self.below(xs.len())]
    }
}

/// An axis-aligned box `[lo, hi]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Aabb {
    /// Lower corner.
    pub lo: P3,
    /// Upper corner.
    pub hi: P3,
}

impl Aabb {
    /// The box with these corners.
    pub fn new(lo: P3, hi: P3) -> Self {
        Aabb { lo, hi }
    }
    /// Closed containment.
    pub fn contains(&self, p: P3) -> bool {
        (0..3).all(|k| p[k] >= self.lo[k] && p[k] <= self.hi[k])
    }
    /// Volume.
    pub fn volume(&self) -> f64 {
        (0..3).map(|k| (self.hi[k] - self.lo[k]).max(0.0)).product()
    }
    /// The point at fractions `f` of each side.
    pub fn at(&self, f: [f64; 3]) -> P3 {
        [0, 1, 2].map(|k| self.lo[k] + f[k] * (self.hi[k] - self.lo[k]))
    }
    /// Grown by `d` on every side.
    pub fn grown(&self, d: f64) -> Aabb {
        Aabb::new(self.lo.map(|x| x - d), self.hi.map(|x| x + d))
    }
}

/// `p ↦ s R p + t` (a rotation, a uniform scale and an offset).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Similarity {
    /// Rotation matrix, rows.
    pub rot: [P3; 3],
    /// Uniform scale.
    pub scale: f64,
    /// Offset.
    pub offset: P3,
}

impl Default for Similarity {
    fn default() -> Self {
        Similarity::IDENTITY
    }
}

impl Similarity {
    /// The identity.
    pub const IDENTITY: Similarity = Similarity {
        rot: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        scale: 1.0,
        offset: [0.0; 3],
    };

    /// A uniformly random rotation (from a random unit quaternion), with the given scale
    /// and offset.
    pub(crate) fn random(rng: &mut Rng, scale: f64, offset: P3) -> Similarity {
        // Shoemake's uniform quaternion.
        let (u1, u2, u3) = (rng.f(), rng.f(), rng.f());
        let tau = 2.0 * std::f64::consts::PI;
        let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
        let (w, x, y, z) = (
            a * (tau * u2).sin(),
            a * (tau * u2).cos(),
            b * (tau * u3).sin(),
            b * (tau * u3).cos(),
        );
        let rot = crate::base::rigid::quaternion_matrix([w, x, y, z]);
        Similarity { rot, scale, offset }
    }

    /// Maps a point of the generator's frame into the model's frame.
    pub fn apply(&self, p: P3) -> P3 {
        let r = [dot(self.rot[0], p), dot(self.rot[1], p), dot(self.rot[2], p)];
        add(scale(r, self.scale), self.offset)
    }

    /// Maps a point of the model's frame back into the generator's frame.
    pub fn inverse(&self, p: P3) -> P3 {
        let q = scale(sub(p, self.offset), 1.0 / self.scale);
        let c = |k: usize| self.rot[0][k] * q[0] + self.rot[1][k] * q[1] + self.rot[2][k] * q[2];
        [c(0), c(1), c(2)]
    }

    /// True for the identity (no work to do).
    pub fn is_identity(&self) -> bool {
        *self == Similarity::IDENTITY
    }
}
