//! The one rigid-transform module: rotations by angles in degrees about the fixed
//! coordinate axes, and the 7°/8°/9° stress rotation used by the tests, the benchmarks and
//! the `caverns_rotated` model.
//!
//! The formulas are written once here because several outputs must agree bit for bit: the
//! experiment transform `rotate_deg [7, 8, 9]` of the caverns must give exactly the
//! generated `caverns_rotated`, which the benchmark's `urot` input also uses. Each is
//! a fixed sequence of operations; do not reorder them.

use super::vec::P3;

/// Rotation by `deg[0]`, `deg[1]`, `deg[2]` degrees about x, then y, then z (fixed axes).
#[inline]
pub fn rotate_xyz_deg(p: P3, deg: [f64; 3]) -> P3 {
    let (sx, cx) = deg[0].to_radians().sin_cos();
    let (sy, cy) = deg[1].to_radians().sin_cos();
    let (sz, cz) = deg[2].to_radians().sin_cos();
    let [x, y, z] = p;
    let (y, z) = (cx * y - sx * z, sx * y + cx * z);
    let (x, z) = (cy * x + sy * z, -sy * x + cy * z);
    [cz * x - sz * y, sz * x + cz * y, z]
}

/// The inverse of [`rotate_xyz_deg`]: about z, then y, then x, by the negated angles.
#[inline]
pub fn rotate_xyz_deg_inverse(p: P3, deg: [f64; 3]) -> P3 {
    let (sx, cx) = (-deg[0]).to_radians().sin_cos();
    let (sy, cy) = (-deg[1]).to_radians().sin_cos();
    let (sz, cz) = (-deg[2]).to_radians().sin_cos();
    let [x, y, z] = p;
    let (x, y) = (cz * x - sz * y, sz * x + cz * y);
    let (x, z) = (cy * x + sy * z, -sy * x + cy * z);
    [x, cx * y - sx * z, sx * y + cx * z]
}

/// Rotation by `deg` degrees about z.
#[inline]
pub fn rotate_z_deg(p: P3, deg: f64) -> P3 {
    let (s, c) = deg.to_radians().sin_cos();
    [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]]
}

/// Rotation by 7°, 8°, 9° about x, y and z (in that order), as used throughout the tests.
#[inline]
pub fn rotate_789(p: P3) -> P3 {
    rotate_xyz_deg(p, [7.0, 8.0, 9.0])
}

/// The stress transform used throughout the tests and benchmarks: [`rotate_789`], then a
/// shift by 1e6 on every axis (a georeferenced copy far from the origin).
#[inline]
pub fn rotate_789_offset(p: P3) -> P3 {
    let r = rotate_789(p);
    [r[0] + 1e6, r[1] + 1e6, r[2] + 1e6]
}

/// The rotation matrix of the unit quaternion `[w, x, y, z]` (rows; the caller normalises).
pub fn quaternion_matrix([w, x, y, z]: [f64; 4]) -> [[f64; 3]; 3] {
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::rng::SplitMix64;

    /// The three formulas this module replaces, verbatim: `bench::rotate_789`,
    /// `thesis_models::rot_xyz` (with its `rot_z`) and `experiment::rot`.
    fn old_bench_789(p: P3) -> P3 {
        let (sx, cx) = 7f64.to_radians().sin_cos();
        let (sy, cy) = 8f64.to_radians().sin_cos();
        let (sz, cz) = 9f64.to_radians().sin_cos();
        let [x, y, z] = p;
        let (y, z) = (cx * y - sx * z, sx * y + cx * z);
        let (x, z) = (cy * x + sy * z, -sy * x + cy * z);
        (cz * x - sz * y, sz * x + cz * y, z).into()
    }
    fn old_rot_z(p: P3, deg: f64) -> P3 {
        let (s, c) = deg.to_radians().sin_cos();
        [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]]
    }
    fn old_thesis_xyz(p: P3, deg: [f64; 3]) -> P3 {
        let (sx, cx) = deg[0].to_radians().sin_cos();
        let (sy, cy) = deg[1].to_radians().sin_cos();
        let [x, y, z] = p;
        let (y, z) = (cx * y - sx * z, sx * y + cx * z);
        let (x, z) = (cy * x + sy * z, -sy * x + cy * z);
        old_rot_z([x, y, z], deg[2])
    }
    fn old_experiment_rot(p: P3, deg: [f64; 3], sign: f64) -> P3 {
        let (sx, cx) = (sign * deg[0]).to_radians().sin_cos();
        let (sy, cy) = (sign * deg[1]).to_radians().sin_cos();
        let (sz, cz) = (sign * deg[2]).to_radians().sin_cos();
        let [mut x, mut y, mut z] = p;
        if sign > 0.0 {
            (y, z) = (cx * y - sx * z, sx * y + cx * z);
            (x, z) = (cy * x + sy * z, -sy * x + cy * z);
            [cz * x - sz * y, sz * x + cz * y, z]
        } else {
            (x, y) = (cz * x - sz * y, sz * x + cz * y);
            (x, z) = (cy * x + sy * z, -sy * x + cy * z);
            [x, cx * y - sx * z, sx * y + cx * z]
        }
    }

    fn bits(p: P3) -> [u64; 3] {
        p.map(f64::to_bits)
    }

    #[test]
    fn bit_identical_to_the_formulas_it_replaces() {
        let mut r = SplitMix64(789);
        for i in 0..20_000 {
            let s = [1.0, 1e3, 1e6][i % 3];
            let p = [r.signed_unit() * s, r.signed_unit() * s, r.signed_unit() * s];
            let deg = [r.signed_unit() * 90.0, r.signed_unit() * 90.0, r.signed_unit() * 90.0];
            assert_eq!(bits(rotate_789(p)), bits(old_bench_789(p)));
            assert_eq!(bits(rotate_789(p)), bits(old_experiment_rot(p, [7.0, 8.0, 9.0], 1.0)));
            assert_eq!(bits(rotate_xyz_deg(p, deg)), bits(old_thesis_xyz(p, deg)));
            assert_eq!(bits(rotate_xyz_deg(p, deg)), bits(old_experiment_rot(p, deg, 1.0)));
            assert_eq!(
                bits(rotate_xyz_deg_inverse(p, deg)),
                bits(old_experiment_rot(p, deg, -1.0))
            );
            assert_eq!(bits(rotate_z_deg(p, deg[2])), bits(old_rot_z(p, deg[2])));
            let o = rotate_789_offset(p);
            let q = old_bench_789(p);
            assert_eq!(bits(o), bits([q[0] + 1e6, q[1] + 1e6, q[2] + 1e6]));
        }
    }

    #[test]
    fn inverse_undoes_the_rotation() {
        let p = [1.0, -2.0, 3.0];
        let q = rotate_xyz_deg_inverse(rotate_xyz_deg(p, [10.0, -20.0, 30.0]), [10.0, -20.0, 30.0]);
        for k in 0..3 {
            assert!((p[k] - q[k]).abs() < 1e-12);
        }
    }
}
