//! Gaps of a cleaned model's surface: its open edges (used by exactly one polygon) and the
//! **widest gap** between them, the size a leak's cracks have. Noise on a model with
//! T-junctions moves each T-vertex off the edge it lay on and opens a crack about as wide
//! as the noise; the stress table (`suite::stress`) showed that sealing openings up to four
//! widest gaps (`--seal-holes`) closes every such leak. `run` and `complex` print the
//! widest gap beside a leak warning, so the user knows what size to try.
//!
//! Cost: near-linear. The open edges go into a uniform grid (at most 64 cells per axis,
//! each edge in every cell its bounding box meets); each query point searches rings of
//! cells outwards and stops when the next ring cannot hold a nearer edge.

use super::Model;
use crate::base::vec::{P3, dist, dot, lerp, sub};

/// The open edges (used by exactly one polygon) of a cleaned model, as segments, in
/// increasing order of their (smaller, larger) vertex ids.
pub fn open_edges(m: &Model) -> Vec<[P3; 2]> {
    let mut edges: Vec<(u32, u32)> = Vec::new();
    for p in &m.polygons {
        let n = p.verts.len();
        for i in 0..n {
            let (a, b) = (p.verts[i].0, p.verts[(i + 1) % n].0);
            edges.push((a.min(b), a.max(b)));
        }
    }
    edges.sort_unstable();
    let mut out = Vec::new();
    let mut i = 0;
    while i < edges.len() {
        let mut j = i;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        if j - i == 1 {
            let (a, b) = edges[i];
            out.push([m.vertices[a as usize], m.vertices[b as usize]]);
        }
        i = j;
    }
    out
}

/// The distance from `p` to the segment `s`.
pub fn point_segment(p: &P3, s: &[P3; 2]) -> f64 {
    let d = sub(&s[1], &s[0]);
    let dd = dot(&d, &d);
    let t = if dd > 0.0 {
        (dot(&sub(p, &s[0]), &d) / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    dist(p, &lerp(&s[0], &s[1], t))
}

/// An estimate of the widest gap of a cleaned model's surface (model units): the largest
/// distance from a point of an open edge (its quarter points) to the nearest *other* open
/// edge, or 0 without open edges. Across a crack that noise opened at a T-junction (the
/// long edge on one side, the two short edges through the moved T-vertex on the other)
/// this is the crack's width at its widest, up to the sampling; for a wide hole bounded by
/// one loop of open edges it is about half the hole's width (the distance from an edge's
/// middle to its neighbours). An edge with no other open edge within the model's
/// bounding-box diagonal (a lone open edge) counts as that far.
pub fn widest_gap(m: &Model) -> f64 {
    let (lo, hi) = m.bbox();
    widest_gap_of(&open_edges(m), dist(&lo, &hi))
}

/// [`widest_gap`] of the segments `edges`, capped at `cap`.
pub fn widest_gap_of(edges: &[[P3; 2]], cap: f64) -> f64 {
    if edges.is_empty() {
        return 0.0;
    }
    let grid = Grid::new(edges);
    let mut widest = 0.0f64;
    for (i, s) in edges.iter().enumerate() {
        for t in [0.25, 0.5, 0.75] {
            let p = lerp(&s[0], &s[1], t);
            widest = widest.max(grid.nearest_other(edges, i, &p, cap));
        }
    }
    widest
}

/// A uniform grid over the segments' bounding box: cell `c` lists, in `items[start[c]..
/// start[c + 1]]`, every segment whose bounding box meets it.
struct Grid {
    lo: P3,
    h: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Grid {
    const MAX_DIM: usize = 64;

    fn new(edges: &[[P3; 2]]) -> Grid {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for s in edges {
            for p in s {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f64, f64::max);
        // About one segment per cell along the longest axis, at most MAX_DIM cells.
        let per_axis = ((edges.len() as f64).cbrt().ceil() as usize).clamp(1, Self::MAX_DIM);
        let h = if extent > 0.0 { extent / per_axis as f64 } else { 1.0 };
        let dims = [0, 1, 2].map(|k| (((hi[k] - lo[k]) / h).floor() as usize + 1).min(Self::MAX_DIM));
        let mut g = Grid {
            lo,
            h,
            dims,
            start: Vec::new(),
            items: Vec::new(),
        };
        let ncells = dims[0] * dims[1] * dims[2];
        let mut count = vec![0u32; ncells + 1];
        let ranges: Vec<([usize; 3], [usize; 3])> = edges
            .iter()
            .map(|s| {
                let a = g.cell_of(&[0, 1, 2].map(|k| s[0][k].min(s[1][k])));
                let b = g.cell_of(&[0, 1, 2].map(|k| s[0][k].max(s[1][k])));
                (a, b)
            })
            .collect();
        for (a, b) in &ranges {
            g.for_cells(*a, *b, |c| count[c + 1] += 1);
        }
        for c in 0..ncells {
            count[c + 1] += count[c];
        }
        let mut fill = count.clone();
        let mut items = vec![0u32; count[ncells] as usize];
        for (i, (a, b)) in ranges.iter().enumerate() {
            g.for_cells(*a, *b, |c| {
                items[fill[c] as usize] = i as u32;
                fill[c] += 1;
            });
        }
        g.start = count;
        g.items = items;
        g
    }

    fn cell_of(&self, p: &P3) -> [usize; 3] {
        [0, 1, 2].map(|k| (((p[k] - self.lo[k]) / self.h).floor().max(0.0) as usize).min(self.dims[k] - 1))
    }

    fn index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    fn for_cells(&self, a: [usize; 3], b: [usize; 3], mut f: impl FnMut(usize)) {
        for z in a[2]..=b[2] {
            for y in a[1]..=b[1] {
                for x in a[0]..=b[0] {
                    f(self.index([x, y, z]));
                }
            }
        }
    }

    /// The distance from `p` to the nearest segment other than `skip`, at most `cap`.
    fn nearest_other(&self, edges: &[[P3; 2]], skip: usize, p: &P3, cap: f64) -> f64 {
        let c = self.cell_of(p);
        let mut best = cap;
        let max_ring = self.dims.iter().copied().max().unwrap_or(1);
        for r in 0..=max_ring {
            // Every cell of ring r + 1 is at least r · h from p (p lies in cell c, or
            // outside the grid only by clamping, which only moves it nearer), so ring r
            // is the last that can hold a nearer segment once best ≤ r · h.
            let lo = [0, 1, 2].map(|k| c[k].saturating_sub(r));
            let hi = [0, 1, 2].map(|k| (c[k] + r).min(self.dims[k] - 1));
            let mut visit = |x: usize, y: usize, z: usize| {
                let cell = self.index([x, y, z]);
                for &j in &self.items[self.start[cell] as usize..self.start[cell + 1] as usize] {
                    if j as usize != skip {
                        best = best.min(point_segment(p, &edges[j as usize]));
                    }
                }
            };
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    if z.abs_diff(c[2]) == r || y.abs_diff(c[1]) == r {
                        (lo[0]..=hi[0]).for_each(|x| visit(x, y, z));
                    } else {
                        // Only the two x ends of this row are on ring r (when inside).
                        if c[0] >= r {
                            visit(c[0] - r, y, z);
                        }
                        if r > 0 && c[0] + r < self.dims[0] {
                            visit(c[0] + r, y, z);
                        }
                    }
                }
            }
            if best <= r as f64 * self.h {
                break;
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::rng::SplitMix64;

    fn brute(edges: &[[P3; 2]], cap: f64) -> f64 {
        let mut widest = 0.0f64;
        for (i, s) in edges.iter().enumerate() {
            for t in [0.25, 0.5, 0.75] {
                let p = lerp(&s[0], &s[1], t);
                let best = edges
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| j != i)
                    .map(|(_, o)| point_segment(&p, o))
                    .fold(cap, f64::min);
                widest = widest.max(best);
            }
        }
        widest
    }

    /// The grid search finds what the quadratic scan finds: random short and long
    /// segments, clustered and spread, and a lone segment far from the rest (the cap).
    #[test]
    fn grid_search_equals_the_quadratic_scan() {
        let mut r = SplitMix64(7);
        for case in 0..40 {
            let n = 2 + r.below(300);
            let spread = [1.0, 10.0, 1000.0][case % 3];
            let mut edges: Vec<[P3; 2]> = (0..n)
                .map(|_| {
                    let a: P3 = [0; 3].map(|_| r.signed_unit() * spread);
                    let len = if r.below(4) == 0 { spread } else { spread * 0.01 };
                    let b: P3 = [0, 1, 2].map(|k| a[k] + r.signed_unit() * len);
                    [a, b]
                })
                .collect();
            if case % 5 == 0 {
                edges.push([[50.0 * spread; 3], [50.0 * spread + 1.0, 50.0 * spread, 50.0 * spread]]);
            }
            let cap = 20.0 * spread;
            let (g, b) = (widest_gap_of(&edges, cap), brute(&edges, cap));
            assert_eq!(g, b, "case {case}: grid {g} brute {b}");
        }
        assert_eq!(widest_gap_of(&[], 1.0), 0.0);
        let one = [[[0.0; 3], [1.0, 0.0, 0.0]]];
        assert_eq!(widest_gap_of(&one, 3.0), 3.0);
    }
}
