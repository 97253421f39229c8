//! Insertion order: BRIO (biased randomized insertion order, Amenta, Choi & Rote 2003)
//! with each round sorted along a 3D Hilbert curve (Skilling, "Programming the Hilbert
//! curve", 2004). Consecutive points are close in space, so the walking point location
//! from the previous insertion is short, while the random rounds keep the expected cost of
//! randomized incremental construction.

use crate::base::rng::SplitMix64;
use crate::predicates::P3;

/// Bits per axis of the Hilbert key: 16 levels of the curve (65536³ cells) order
/// any round far more finely than the walk can notice; ties keep the random order.
const BITS: u32 = 16;

/// Hilbert index of a quantized point (Skilling's transpose algorithm, branch-free: the
/// bits are random for random points, so branches would mispredict half the time).
fn hilbert_key(mut x: [u32; 3]) -> u64 {
    // Inverse undo excess work (AxesToTranspose).
    let mut q = 1u32 << (BITS - 1);
    while q > 1 {
        let p = q - 1;
        for i in 0..3 {
            let m = 0u32.wrapping_sub(u32::from(x[i] & q != 0));
            let t = (x[0] ^ x[i]) & p & !m;
            x[0] ^= (p & m) | t;
            x[i] ^= t;
        }
        q >>= 1;
    }
    // Gray encode.
    x[1] ^= x[0];
    x[2] ^= x[1];
    let mut t = 0;
    let mut q = 1u32 << (BITS - 1);
    while q > 1 {
        t ^= (q - 1) & 0u32.wrapping_sub(u32::from(x[2] & q != 0));
        q >>= 1;
    }
    // Interleave the transposed bits, most significant first (x[0] highest in each triple).
    (spread3(x[0] ^ t) << 2) | (spread3(x[1] ^ t) << 1) | spread3(x[2] ^ t)
}

/// The low 21 bits of `v` moved to every third bit (bit `b` to bit `3b`).
fn spread3(v: u32) -> u64 {
    let mut x = u64::from(v) & 0x1f_ffff;
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// Bits of the sort key: the round (3 bits) above the 48-bit Hilbert key.
const KEY_BITS: u32 = 3 * BITS + 3;
/// Radix digit width (5 passes over 51-bit keys; the 4096-entry histogram fits in L1).
const DIGIT: u32 = 12;

/// A sort key and a point index.
type Keyed = (u64, u32);

/// Stable LSD radix sort by the key's bits `lo..hi`.
fn radix_sort(v: &mut [Keyed], scratch: &mut Vec<Keyed>, lo: u32, hi: u32) {
    let bits = |e: &Keyed| (e.0 >> lo) & ((1u64 << (hi - lo)) - 1);
    if v.len() <= 64 {
        v.sort_by_key(bits);
        return;
    }
    scratch.clear();
    scratch.resize(v.len(), (0, 0));
    let mut count = vec![0usize; 1 << DIGIT];
    let mut src_is_v = true;
    for pass in 0..(hi - lo).div_ceil(DIGIT) {
        let shift = lo + pass * DIGIT;
        let mask = (1u64 << DIGIT.min(hi - shift)) - 1;
        let (src, dst): (&[Keyed], &mut [Keyed]) = if src_is_v {
            (&*v, &mut scratch[..])
        } else {
            (&scratch[..], &mut *v)
        };
        count.iter_mut().for_each(|c| *c = 0);
        for e in src {
            count[((e.0 >> shift) & mask) as usize] += 1;
        }
        let mut sum = 0;
        for c in count.iter_mut() {
            let k = *c;
            *c = sum;
            sum += k;
        }
        for e in src {
            let d = ((e.0 >> shift) & mask) as usize;
            dst[count[d]] = *e;
            count[d] += 1;
        }
        src_is_v = !src_is_v;
    }
    if !src_is_v {
        v.copy_from_slice(scratch);
    }
}

/// Returns the indices `ids` in BRIO order with Hilbert-sorted rounds. Deterministic for a
/// given seed.
#[cfg(test)]
pub fn brio_hilbert(points: &[P3], ids: Vec<u32>, seed: u64) -> Vec<u32> {
    brio_hilbert_with_storage(points, ids, seed).0
}

/// [`brio_hilbert`], and also the same indices in plain Hilbert order (no rounds): the
/// order to *store* points in, so that a point's neighbours lie nearby in memory whatever
/// round they were inserted in.
pub fn brio_hilbert_with_storage(points: &[P3], ids: Vec<u32>, seed: u64) -> (Vec<u32>, Vec<u32>) {
    if ids.len() < 2 {
        return (ids.clone(), ids);
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &i in &ids {
        let p = points[i as usize];
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    // One scale for all axes keeps the curve's cells cubic.
    let ext = (0..3).map(|a| hi[a] - lo[a]).fold(0.0f64, f64::max);
    let s = if ext > 0.0 {
        ((1u64 << BITS) - 1) as f64 / ext
    } else {
        0.0
    };
    // When the extent is so small that its reciprocal overflows (subnormal coordinates),
    // divide instead: (p - lo) / ext lies in [0, 1] at any scale.
    let finite = s.is_finite();
    let key = |p: &P3| {
        let q = |a: usize| {
            let t = if finite {
                (p[a] - lo[a]) * s
            } else {
                (p[a] - lo[a]) / ext * ((1u64 << BITS) - 1) as f64
            };
            (t as u32).min((1 << BITS) - 1)
        };
        hilbert_key([q(0), q(1), q(2)])
    };
    // BRIO rounds by independent coin flips (Amenta, Choi & Rote's construction): a point
    // joins round `last - k` with probability about 7/8 · 8^-k (k = the number of leading
    // zero triples of a random word, capped), so the last round holds about 7/8 of the
    // points, the one before 7/8 of the rest, and so on down to rounds of about 64 points.
    // One radix sort by (round, Hilbert key) then orders everything; ties keep input order.
    let mut rounds = 0u32;
    while (ids.len() >> (3 * rounds)) > 64 && rounds < 7 {
        rounds += 1;
    }
    let mut rng = SplitMix64(seed);
    let mut keyed: Vec<(u64, u32)> = ids
        .iter()
        .map(|&i| {
            let k = (rng.next_u64().leading_zeros() / 3).min(rounds) as u64;
            (((rounds as u64 - k) << (3 * BITS)) | key(&points[i as usize]), i)
        })
        .collect();
    // Storage order first: Hilbert key only, stable from input order, so that ties (points
    // in one cell of the curve) never depend on the seed; the canonical numbering of the
    // tetrahedra is by these ids. Then the insertion order: a stable sort of that sequence
    // by round, so each round is in Hilbert order.
    let mut scratch = Vec::new();
    radix_sort(&mut keyed, &mut scratch, 0, 3 * BITS);
    let storage: Vec<u32> = keyed.iter().map(|e| e.1).collect();
    radix_sort(&mut keyed, &mut scratch, 3 * BITS, KEY_BITS);
    (keyed.into_iter().map(|e| e.1).collect(), storage)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hilbert_is_a_bijection_on_a_small_grid_and_continuous() {
        // Keys of a 4x4x4 grid at the top bits must be distinct, and consecutive keys must
        // be grid neighbours (the defining property of the Hilbert curve).
        let shift = BITS - 2;
        let mut v: Vec<(u64, [u32; 3])> = Vec::new();
        for x in 0..4u32 {
            for y in 0..4u32 {
                for z in 0..4u32 {
                    let k = hilbert_key([x << shift, y << shift, z << shift]);
                    v.push((k, [x, y, z]));
                }
            }
        }
        v.sort();
        v.dedup_by_key(|e| e.0);
        assert_eq!(v.len(), 64);
        for w in v.windows(2) {
            let d: u32 = (0..3).map(|a| w[0].1[a].abs_diff(w[1].1[a])).sum();
            assert_eq!(d, 1, "{:?} -> {:?}", w[0].1, w[1].1);
        }
    }

    #[test]
    fn brio_is_a_permutation_and_deterministic() {
        let mut rng = SplitMix64(7);
        let pts: Vec<P3> = (0..1000)
            .map(|_| [rng.below(100) as f64, rng.below(100) as f64, rng.below(100) as f64])
            .collect();
        let a = brio_hilbert(&pts, (0..1000).collect(), 1);
        let b = brio_hilbert(&pts, (0..1000).collect(), 1);
        assert_eq!(a, b);
        let mut s = a.clone();
        s.sort();
        assert_eq!(s, (0..1000).collect::<Vec<u32>>());
    }
}
