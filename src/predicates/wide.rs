//! Exact signs of orient3d and insphere by fixed-width integer arithmetic.
//!
//! Every finite `f64` is `m · 2^e` with an integer `m` of at most 53 bits. At the scale
//! `2^-E` of the smallest `e` among one predicate call's coordinates, all of them are
//! integers, and the determinant is evaluated exactly in integers of `L` 64-bit words.
//! Scaling by a power of two is exact, so the sign is that of the determinant of the
//! coordinates as given.
//!
//! Two widths:
//! - [`NARROW`] (640 bits) when the call's coordinates span at most 124 bits at their
//!   common scale: the exact ties of decimal input (box corners written as 123.4 are
//!   cospherical and coplanar, but not on a small binary lattice), at a few thousand
//!   instructions per call.
//! - [`ANY`] (10,624 bits) for every other finite input, down to subnormals beside 1e308:
//!   slow, but exact where expansion arithmetic is not (Shewchuk's expansions, like his
//!   filters, assume that no product underflows).
//!
//! Why not only the adaptive arithmetic: on an exact tie it runs to its last stage, whose
//! `robust` implementation zeroes about 190 KB of expansion buffers per call; on box corners
//! that dominated the whole tetrahedralization.

/// Words of the narrow width: enough for the insphere determinant (degree 5) of
/// differences below 2^125 (at most 5 · 125 + 7 bits).
pub(super) const NARROW: usize = 10;
/// Largest bit length of a scaled coordinate at the narrow width.
const NARROW_BITS: u32 = 124;
/// Words for any finite input: a scaled coordinate has at most 53 + 2045 bits (from 2^-1074
/// to below 2^1024), differences 2099, the insphere determinant at most 5 · 2099 + 7.
pub(super) const ANY: usize = 166;
const ANY_BITS: u32 = 2098;

/// A signed integer of up to `64 · L` bits: sign and little-endian magnitude.
#[derive(Clone, Copy, Debug)]
pub(super) struct Wide<const L: usize> {
    neg: bool,
    len: usize,
    m: [u64; L],
}

impl<const L: usize> Wide<L> {
    fn zero() -> Self {
        Wide {
            neg: false,
            len: 0,
            m: [0; L],
        }
    }

    /// `±m · 2^shift`.
    fn shifted(m: i64, shift: u32) -> Self {
        let mut r = Self::zero();
        let u = m.unsigned_abs();
        let (word, bit) = ((shift / 64) as usize, shift % 64);
        assert!(word + 1 < L, "Wide overflow");
        r.m[word] = u << bit;
        if bit > 0 {
            r.m[word + 1] = u >> (64 - bit);
        }
        r.len = word + 2;
        r.neg = m < 0;
        r.trim()
    }

    fn from_i128(x: i128) -> Self {
        let u = x.unsigned_abs();
        let mut r = Self::zero();
        r.m[0] = u as u64;
        r.m[1] = (u >> 64) as u64;
        r.len = 2;
        r.neg = x < 0;
        r.trim()
    }

    /// -1, 0 or +1.
    pub(super) fn signum(&self) -> i32 {
        if self.len == 0 {
            0
        } else if self.neg {
            -1
        } else {
            1
        }
    }

    fn trim(mut self) -> Self {
        while self.len > 0 && self.m[self.len - 1] == 0 {
            self.len -= 1;
        }
        if self.len == 0 {
            self.neg = false;
        }
        self
    }

    /// Magnitude comparison.
    fn cmp_mag(&self, o: &Self) -> std::cmp::Ordering {
        if self.len != o.len {
            return self.len.cmp(&o.len);
        }
        for k in (0..self.len).rev() {
            if self.m[k] != o.m[k] {
                return self.m[k].cmp(&o.m[k]);
            }
        }
        std::cmp::Ordering::Equal
    }

    fn add_signed(self, o: Self, o_neg: bool) -> Self {
        let mut r = Self::zero();
        if self.neg == o_neg {
            let n = self.len.max(o.len);
            let mut carry = 0u64;
            for k in 0..n {
                let (s1, c1) = self.m[k].overflowing_add(o.m[k]);
                let (s2, c2) = s1.overflowing_add(carry);
                r.m[k] = s2;
                carry = u64::from(c1) + u64::from(c2);
            }
            assert!(n < L || carry == 0, "Wide overflow");
            if n < L {
                r.m[n] = carry;
            }
            r.len = (n + 1).min(L);
            r.neg = self.neg;
        } else {
            // Subtract the smaller magnitude from the larger; the sign is the larger's.
            let (big, small, neg) = if self.cmp_mag(&o) != std::cmp::Ordering::Less {
                (&self, &o, self.neg)
            } else {
                (&o, &self, o_neg)
            };
            let mut borrow = 0u64;
            for k in 0..big.len {
                let (d1, b1) = big.m[k].overflowing_sub(small.m[k]);
                let (d2, b2) = d1.overflowing_sub(borrow);
                r.m[k] = d2;
                borrow = u64::from(b1) + u64::from(b2);
            }
            r.len = big.len;
            r.neg = neg;
        }
        r.trim()
    }
}

impl<const L: usize> std::ops::Add for Wide<L> {
    type Output = Wide<L>;
    fn add(self, o: Wide<L>) -> Wide<L> {
        let n = o.neg;
        self.add_signed(o, n)
    }
}

impl<const L: usize> std::ops::Sub for Wide<L> {
    type Output = Wide<L>;
    fn sub(self, o: Wide<L>) -> Wide<L> {
        let n = !o.neg;
        self.add_signed(o, n)
    }
}

impl<const L: usize> std::ops::Mul for Wide<L> {
    type Output = Wide<L>;
    fn mul(self, o: Wide<L>) -> Wide<L> {
        if self.len == 0 || o.len == 0 {
            return Self::zero();
        }
        let mut r = Self::zero();
        assert!(self.len + o.len <= L, "Wide overflow");
        for i in 0..self.len {
            let mut carry = 0u128;
            for j in 0..o.len {
                let t = u128::from(r.m[i + j]) + u128::from(self.m[i]) * u128::from(o.m[j]) + carry;
                r.m[i + j] = t as u64;
                carry = t >> 64;
            }
            r.m[i + o.len] = carry as u64;
        }
        r.len = self.len + o.len;
        r.neg = self.neg != o.neg;
        r.trim()
    }
}

/// Each coordinate as `(m, e - E)`: its odd integer significand and its exponent above
/// the smallest exponent `E` of the call, if each is finite and its bit length at that
/// scale stays within `max_bits`.
fn decompose<const N: usize>(pts: [&[f64; 3]; N], max_bits: u32) -> Option<[[(i64, u32); 3]; N]> {
    let mut parts = [[(0i64, 0i32); 3]; N];
    let mut e_min = i32::MAX;
    for (k, p) in pts.iter().enumerate() {
        for a in 0..3 {
            let x = p[a];
            if !x.is_finite() {
                return None;
            }
            if x == 0.0 {
                continue;
            }
            let bits = x.to_bits();
            let field = ((bits >> 52) & 0x7ff) as i32;
            let frac = bits & ((1u64 << 52) - 1);
            let (mut m, mut e) = if field == 0 {
                (frac, -1074)
            } else {
                (frac | (1u64 << 52), field - 1075)
            };
            let tz = m.trailing_zeros();
            m >>= tz;
            e += tz as i32;
            parts[k][a] = (if x < 0.0 { -(m as i64) } else { m as i64 }, e);
            e_min = e_min.min(e);
        }
    }
    let mut out = [[(0i64, 0u32); 3]; N];
    for k in 0..N {
        for a in 0..3 {
            let (m, e) = parts[k][a];
            if m != 0 {
                let shift = (e - e_min) as u32;
                if 64 - m.unsigned_abs().leading_zeros() + shift > max_bits {
                    return None;
                }
                out[k][a] = (m, shift);
            }
        }
    }
    Some(out)
}

/// The differences `p - o` of scaled coordinates, as `Wide` integers. At the narrow width
/// the scaled coordinates fit in `i128` (at most 124 bits), so they are subtracted there.
fn diffs<const N: usize, const L: usize>(parts: [[(i64, u32); 3]; N], o: usize) -> [[Wide<L>; 3]; N] {
    if L == NARROW {
        let v = |k: usize, a: usize| i128::from(parts[k][a].0) << parts[k][a].1;
        std::array::from_fn(|k| [0, 1, 2].map(|a| Wide::from_i128(v(k, a) - v(o, a))))
    } else {
        let v = |k: usize, a: usize| match parts[k][a] {
            (0, _) => Wide::zero(),
            (m, sh) => Wide::shifted(m, sh),
        };
        std::array::from_fn(|k| [0, 1, 2].map(|a| v(k, a) - v(o, a)))
    }
}

fn orient3d_in<const L: usize>(pts: [&[f64; 3]; 4], max_bits: u32) -> Option<i32> {
    let [_, u, v, w] = diffs::<4, L>(decompose(pts, max_bits)?, 0);
    Some(super::orient_det(u, v, w).signum())
}

fn insphere_in<const L: usize>(pts: [&[f64; 3]; 5], max_bits: u32) -> Option<i32> {
    let [a, b, c, d, _] = diffs::<5, L>(decompose(pts, max_bits)?, 4);
    Some(super::insphere_det(a, b, c, d).signum())
}

/// Exact sign of `det[b-a, c-a, d-a]` (the crate's orient3d convention) at the narrow
/// width, or `None` when the coordinates span too many binary orders of magnitude.
pub(super) fn orient3d(a: &[f64; 3], b: &[f64; 3], c: &[f64; 3], d: &[f64; 3]) -> Option<i32> {
    orient3d_in::<NARROW>([a, b, c, d], NARROW_BITS)
}

/// [`orient3d`] for any finite coordinates (`None` only for NaN or infinite ones).
pub(super) fn orient3d_any(a: &[f64; 3], b: &[f64; 3], c: &[f64; 3], d: &[f64; 3]) -> Option<i32> {
    orient3d_in::<ANY>([a, b, c, d], ANY_BITS)
}

/// Exact sign of Shewchuk's insphere determinant (positive when `e` is inside the sphere
/// through `a, b, c, d` in *his* positive orientation) at the narrow width, or `None` as
/// for [`orient3d`].
pub(super) fn insphere_shewchuk(a: &[f64; 3], b: &[f64; 3], c: &[f64; 3], d: &[f64; 3], e: &[f64; 3]) -> Option<i32> {
    insphere_in::<NARROW>([a, b, c, d, e], NARROW_BITS)
}

/// [`insphere_shewchuk`] for any finite coordinates (`None` only for NaN or infinite ones).
pub(super) fn insphere_shewchuk_any(
    a: &[f64; 3],
    b: &[f64; 3],
    c: &[f64; 3],
    d: &[f64; 3],
    e: &[f64; 3],
) -> Option<i32> {
    insphere_in::<ANY>([a, b, c, d, e], ANY_BITS)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn w(x: i128) -> Wide<NARROW> {
        Wide::from_i128(x)
    }

    #[test]
    fn arithmetic_matches_i128_where_it_fits() {
        let mut r = crate::base::rng::SplitMix64(3);
        for _ in 0..20_000 {
            let x = (r.next_u64() as i64 >> (r.below(60) as u32)) as i128;
            let y = (r.next_u64() as i64 >> (r.below(60) as u32)) as i128;
            assert_eq!((w(x) + w(y)).signum(), (x + y).signum() as i32);
            assert_eq!((w(x) - w(y)).signum(), (x - y).signum() as i32);
            assert_eq!((w(x) * w(y)).signum(), (x * y).signum() as i32);
            // (x*y) - (x*y) is zero, (x*y + 1) - x*y is one: carries across limbs.
            let p = w(x) * w(y);
            assert_eq!((p - w(x) * w(y)).signum(), 0);
            assert_eq!((p + w(1) - p).signum(), 1);
        }
        // Squares of 2^126 - 1 carry through every limb of the product.
        let big = w((1i128 << 126) - 1);
        let sq = big * big;
        assert_eq!((sq * big * big - sq * sq).signum(), 0);
        assert_eq!((sq * big * big + w(-1) - sq * sq).signum(), -1);
    }

    #[test]
    fn decimal_ties_are_exact_zeros_and_signs_agree_with_robust() {
        // Box corners in decimal steps: cospherical and coplanar quintuples everywhere.
        let mut r = crate::base::rng::SplitMix64(11);
        let mut zeros = 0;
        for _ in 0..20_000 {
            let base = [0; 3].map(|_| r.below(5000) as f64 * 0.1);
            let size = [0; 3].map(|_| 0.1 * (1 + r.below(60)) as f64);
            let corner = |r: &mut crate::base::rng::SplitMix64| {
                let k = r.below(8);
                [0, 1, 2].map(|a| base[a] + if k >> a & 1 == 1 { size[a] } else { 0.0 })
            };
            let q = [0; 5].map(|_| corner(&mut r));
            let cc = |p: &[f64; 3]| robust::Coord3D {
                x: p[0],
                y: p[1],
                z: p[2],
            };
            let want = robust::insphere(cc(&q[0]), cc(&q[1]), cc(&q[2]), cc(&q[3]), cc(&q[4]));
            let got = insphere_shewchuk(&q[0], &q[1], &q[2], &q[3], &q[4]).expect("in range");
            assert_eq!(got, (want > 0.0) as i32 - (want < 0.0) as i32, "{q:?}");
            zeros += usize::from(got == 0);
            let want_o = -robust::orient3d(cc(&q[0]), cc(&q[1]), cc(&q[2]), cc(&q[3]));
            let got_o = orient3d(&q[0], &q[1], &q[2], &q[3]).expect("in range");
            assert_eq!(got_o, (want_o > 0.0) as i32 - (want_o < 0.0) as i32, "{q:?}");
        }
        assert!(zeros > 1000, "the test must exercise ties: {zeros}");
    }

    #[test]
    fn wide_ranges_are_declined() {
        let a = [1e-30, 0.0, 0.0];
        let b = [1e3, 0.0, 0.0];
        assert!(orient3d(&a, &b, &[0.0, 1.0, 0.0], &[0.0, 0.0, 1.0]).is_none());
        assert!(orient3d(&[f64::NAN, 0.0, 0.0], &b, &b, &b).is_none());
        // Subnormals on their own are fine: one scale covers them.
        let t = f64::from_bits(1);
        assert_eq!(
            orient3d(&[0.0; 3], &[t, 0.0, 0.0], &[0.0, t, 0.0], &[0.0, 0.0, t]),
            Some(1)
        );
    }
}
