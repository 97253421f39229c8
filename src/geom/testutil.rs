//! Test helpers: deterministic random numbers and the frames every test is repeated in.

use super::plane::Plane;
use crate::predicates::P3;
use crate::tolerances::Tolerances;

/// xorshift64* — deterministic, no dependency.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [0, 1).
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [-r, r)^3.
    pub fn point(&mut self, r: f64) -> P3 {
        [
            (2.0 * self.f64() - 1.0) * r,
            (2.0 * self.f64() - 1.0) * r,
            (2.0 * self.f64() - 1.0) * r,
        ]
    }
    /// Random unit vector.
    pub fn unit(&mut self) -> P3 {
        loop {
            let p = self.point(1.0);
            let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            if l > 0.1 && l <= 1.0 {
                return [p[0] / l, p[1] / l, p[2] / l];
            }
        }
    }
}

/// A similarity transform `x ↦ off + R (scale x)`.
pub struct Frame {
    pub name: &'static str,
    pub rot: [[f64; 3]; 3],
    pub off: P3,
    pub scale: f64,
}

impl Frame {
    pub fn apply(&self, p: P3) -> P3 {
        let v = self.apply_vec(p);
        [self.off[0] + v[0], self.off[1] + v[1], self.off[2] + v[2]]
    }
    /// Rotation and scaling only (for directions and lengths).
    pub fn apply_vec(&self, p: P3) -> P3 {
        let r = &self.rot;
        let s = self.scale;
        [
            s * (r[0][0] * p[0] + r[0][1] * p[1] + r[0][2] * p[2]),
            s * (r[1][0] * p[0] + r[1][1] * p[1] + r[1][2] * p[2]),
            s * (r[2][0] * p[0] + r[2][1] * p[1] + r[2][2] * p[2]),
        ]
    }
    /// The image of the local plane with normal `n` through `p`.
    pub fn plane(&self, n: P3, p: P3) -> Plane {
        Plane::from_normal_point(self.apply_vec(n), &self.apply(p))
    }
    pub fn area(&self, a: f64) -> f64 {
        a * self.scale * self.scale
    }
    pub fn volume(&self, v: f64) -> f64 {
        v * self.scale * self.scale * self.scale
    }
}

fn rotation(ax: f64, ay: f64, az: f64) -> [[f64; 3]; 3] {
    let (sx, cx) = ax.to_radians().sin_cos();
    let (sy, cy) = ay.to_radians().sin_cos();
    let (sz, cz) = az.to_radians().sin_cos();
    let rx = [[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]];
    let ry = [[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]];
    let rz = [[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]];
    let mul = |a: [[f64; 3]; 3], b: [[f64; 3]; 3]| {
        let mut m = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
            }
        }
        m
    };
    mul(rz, mul(ry, rx))
}

/// The frames every geometric test runs in, each with `Tolerances::for_scale` of the
/// transformed object's diagonal (`local_diag` is the diagonal in local coordinates):
/// identity; rotation (7°, 8°, 9°) + offset 1e6 at unit size (the harsh case: plane
/// tolerance ~10 ulps of the coordinates); and scaled to ~1e3, rotated, offset 1e6.
pub fn frames(local_diag: f64) -> Vec<(Frame, Tolerances)> {
    let id = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let rot = rotation(7.0, 8.0, 9.0);
    let off = [1e6, -1e6, 1e6];
    let fs = vec![
        Frame {
            name: "identity",
            rot: id,
            off: [0.0; 3],
            scale: 1.0,
        },
        Frame {
            name: "rot+1e6",
            rot,
            off,
            scale: 1.0,
        },
        Frame {
            name: "x1000+rot+1e6",
            rot,
            off,
            scale: 1000.0,
        },
    ];
    fs.into_iter()
        .map(|f| {
            let t = Tolerances::for_scale(local_diag * f.scale);
            (f, t)
        })
        .collect()
}
