//! Transforms of a model's vertices and its ground truth's points (`transforms` of a
//! definition), and their inverses (the rotation check maps portals back).

use crate::predicates::P3;
use serde::{Deserialize, Serialize};

/// A transform of the model's vertices and the ground truth's points.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Transform {
    /// Rotation by these angles in degrees about x, then y, then z (the axes are fixed).
    RotateDeg([f64; 3]),
    /// Translation.
    Translate([f64; 3]),
    /// Uniform scaling about the origin (positive).
    Scale(f64),
}

fn rot(p: P3, deg: [f64; 3], sign: f64) -> P3 {
    let (sx, cx) = (sign * deg[0]).to_radians().sin_cos();
    let (sy, cy) = (sign * deg[1]).to_radians().sin_cos();
    let (sz, cz) = (sign * deg[2]).to_radians().sin_cos();
    let [mut x, mut y, mut z] = p;
    if sign > 0.0 {
        // The same expressions as `bench::rotate_789`, so `rotate_deg [7, 8, 9]` of the
        // caverns is bit-identical to the generated `caverns_rotated`.
        (y, z) = (cx * y - sx * z, sx * y + cx * z);
        (x, z) = (cy * x + sy * z, -sy * x + cy * z);
        [cz * x - sz * y, sz * x + cz * y, z]
    } else {
        // The inverse: about z, then y, then x, by the negated angles.
        (x, y) = (cz * x - sz * y, sz * x + cz * y);
        (x, z) = (cy * x + sy * z, -sy * x + cy * z);
        [x, cx * y - sx * z, sx * y + cx * z]
    }
}

impl Transform {
    /// The transformed point.
    pub fn apply(&self, p: P3) -> P3 {
        match *self {
            Transform::RotateDeg(d) => rot(p, d, 1.0),
            Transform::Translate(t) => [p[0] + t[0], p[1] + t[1], p[2] + t[2]],
            Transform::Scale(s) => [p[0] * s, p[1] * s, p[2] * s],
        }
    }

    /// The point mapped by the inverse transform.
    pub fn apply_inverse(&self, p: P3) -> P3 {
        match *self {
            Transform::RotateDeg(d) => rot(p, d, -1.0),
            Transform::Translate(t) => [p[0] - t[0], p[1] - t[1], p[2] - t[2]],
            Transform::Scale(s) => [p[0] / s, p[1] / s, p[2] / s],
        }
    }

    /// Factor by which lengths change.
    pub fn length_factor(&self) -> f64 {
        match *self {
            Transform::Scale(s) => s,
            _ => 1.0,
        }
    }
}

/// Applies `ts` in order.
pub fn apply_all(ts: &[Transform], p: P3) -> P3 {
    ts.iter().fold(p, |q, t| t.apply(q))
}

/// Undoes `ts` (the inverses in reverse order).
pub fn invert_all(ts: &[Transform], p: P3) -> P3 {
    ts.iter().rev().fold(p, |q, t| t.apply_inverse(q))
}

/// Product of the transforms' length factors.
pub fn length_factor(ts: &[Transform]) -> f64 {
    ts.iter().map(Transform::length_factor).product()
}
