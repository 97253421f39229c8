//! Insertion order: BRIO (biased randomized insertion order, Amenta, Choi & Rote 2003)
//! with each round sorted along a 3D Hilbert curve (Skilling, "Programming the Hilbert
//! curve", 2004). Consecutive points are close in space, so the walking point location
//! from the previous insertion is short, while the random rounds keep the expected cost of
//! randomized incremental construction.

use crate::predicates::P3;

/// Bits per axis of the Hilbert key (3 * 21 = 63 bits).
const BITS: u32 = 21;

/// Hilbert index of a quantized point (Skilling's transpose algorithm).
fn hilbert_key(mut x: [u32; 3]) -> u64 {
    // Inverse undo excess work (AxesToTranspose).
    let m = 1u32 << (BITS - 1);
    let mut q = m;
    while q > 1 {
        let p = q - 1;
        for i in 0..3 {
            if x[i] & q != 0 {
                x[0] ^= p;
            } else {
                let t = (x[0] ^ x[i]) & p;
                x[0] ^= t;
                x[i] ^= t;
            }
        }
        q >>= 1;
    }
    // Gray encode.
    for i in 1..3 {
        x[i] ^= x[i - 1];
    }
    let mut t = 0;
    let mut q = m;
    while q > 1 {
        if x[2] & q != 0 {
            t ^= q - 1;
        }
        q >>= 1;
    }
    for v in x.iter_mut() {
        *v ^= t;
    }
    // Interleave the transposed bits, most significant first.
    let mut key = 0u64;
    for b in (0..BITS).rev() {
        for v in &x {
            key = (key << 1) | ((v >> b) & 1) as u64;
        }
    }
    key
}

/// A small, fast, seedable generator (SplitMix64) so insertion order is reproducible.
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// Next 64 random bits.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `0..n` (n > 0).
    #[inline]
    pub fn below(&mut self, n: usize) -> usize {
        (((self.next_u64() >> 11) as u128 * n as u128) >> 53) as usize
    }
}

/// Returns the indices `ids` in BRIO order with Hilbert-sorted rounds. Deterministic for a
/// given seed.
pub fn brio_hilbert(points: &[P3], mut ids: Vec<u32>, seed: u64) -> Vec<u32> {
    if ids.len() < 2 {
        return ids;
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
    let key = |i: u32| {
        let p = points[i as usize];
        let q = |a: usize| (((p[a] - lo[a]) * s) as u32).min((1 << BITS) - 1);
        hilbert_key([q(0), q(1), q(2)])
    };
    // Fisher–Yates shuffle, then rounds: the last 7/8 of the points form the last round, the
    // last 7/8 of the rest the round before, and so on (CGAL's multiscale ratio 1/8).
    let mut rng = SplitMix64(seed);
    for i in (1..ids.len()).rev() {
        let j = rng.below(i + 1);
        ids.swap(i, j);
    }
    let mut keyed: Vec<(u64, u32)> = ids.iter().map(|&i| (key(i), i)).collect();
    let mut end = keyed.len();
    loop {
        let start = if end > 64 { end / 8 } else { 0 };
        keyed[start..end].sort_unstable_by_key(|e| e.0);
        if start == 0 {
            break;
        }
        end = start;
    }
    keyed.into_iter().map(|e| e.1).collect()
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
