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

/// Rotation by `deg` (`sign > 0`) or its inverse, through the one rigid-transform module
/// (`rotate_deg [7, 8, 9]` of the caverns is bit-identical to the generated
/// `caverns_rotated`; `base::rigid`'s tests pin the formulas).
fn rot(p: P3, deg: [f64; 3], sign: f64) -> P3 {
    if sign > 0.0 {
        crate::base::rigid::rotate_xyz_deg(p, deg)
    } else {
        crate::base::rigid::rotate_xyz_deg_inverse(p, deg)
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
