//! Arbitrary portals (Lowe & Datta, seed 001): a merged portal between two final cells is one
//! surface of several convex pieces, generally not coplanar and not convex as a whole. Its
//! window is a **per-pixel mask** of its projection, rasterised at the camera's mask
//! resolution ([`Camera::mask_px`]) — the software analogue of Lowe & Datta's fragment
//! culling: a triangle behind the portal is drawn only where the mask covers it.
//!
//! **Conservative rasterisation.** A pixel is set when the closed projection meets the
//! closed pixel square (not only its centre), widened by [`SLACK`] pixels against rounding:
//! per pixel row, the x-extent of the convex polygon within the row's strip, every column it
//! meets. If a sight line through screen point `s` passes every portal of a chain and meets
//! a triangle, the pixel holding `s` is set in every mask along the chain and in the
//! triangle's raster, so the triangle is drawn: the mask never culls what the exact per-piece
//! windows see. Polygons are first clipped (leniently, within `Camera::tol`) to the near
//! plane and the viewport's four planes, so every projected point is finite and on screen.
//!
//! [`MaskWindow<true>`] narrows through all of a portal's pieces at once (the union of their
//! rasters, intersected with the parent mask); [`MaskWindow<false>`] narrows piece by piece,
//! like the other windows, for comparison.

use super::walk::{Camera, ExactWindow, Ops, Plane, Window, clip_tol};
use crate::base::vec::P3;

/// Widening of every raster, in pixels (rounding of projected coordinates is far below it).
pub const SLACK: f64 = 1e-6;

/// A bit mask over the camera's pixel grid, row-major, `words` 64-bit words per row.
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Words per row.
    pub words: usize,
    /// Bits, `height × words`.
    pub bits: Vec<u64>,
    /// Rows that may hold set bits: `rows.0 ≤ r < rows.1` (empty when `rows.0 ≥ rows.1`).
    pub rows: (usize, usize),
}

impl Mask {
    /// An empty mask.
    pub fn empty(width: usize, height: usize) -> Self {
        let words = width.div_ceil(64);
        Mask {
            width,
            height,
            words,
            bits: vec![0; words * height],
            rows: (height, 0),
        }
    }

    /// Every pixel set.
    pub fn full(width: usize, height: usize) -> Self {
        let mut m = Mask::empty(width, height);
        for r in 0..height {
            m.set_span(r, 0, width - 1);
        }
        m
    }

    /// Whether pixel `(col, row)` is set.
    pub fn get(&self, col: usize, row: usize) -> bool {
        self.bits[row * self.words + col / 64] >> (col % 64) & 1 == 1
    }

    /// Number of set pixels.
    pub fn count(&self) -> usize {
        self.bits.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// Sets columns `c0..=c1` of row `r`.
    fn set_span(&mut self, r: usize, c0: usize, c1: usize) {
        let row = &mut self.bits[r * self.words..(r + 1) * self.words];
        for (w, word) in row.iter_mut().enumerate().take(c1 / 64 + 1).skip(c0 / 64) {
            *word |= span_bits(w, c0, c1);
        }
        self.rows = (self.rows.0.min(r), self.rows.1.max(r + 1));
    }

    /// Whether any of columns `c0..=c1` of row `r` is set; counts the words read.
    fn any_span(&self, r: usize, c0: usize, c1: usize, ops: &mut Ops) -> bool {
        let row = &self.bits[r * self.words..(r + 1) * self.words];
        for (w, word) in row.iter().enumerate().take(c1 / 64 + 1).skip(c0 / 64) {
            ops.mask_words += 1;
            if word & span_bits(w, c0, c1) != 0 {
                return true;
            }
        }
        false
    }

    /// Keeps only the bits also set in `other`; returns whether any is left.
    fn and(&mut self, other: &Mask, ops: &mut Ops) -> bool {
        let lo = self.rows.0.max(other.rows.0);
        let hi = self.rows.1.min(other.rows.1);
        let (mut first, mut last) = (self.height, 0);
        for r in 0..self.height {
            let row = r * self.words..(r + 1) * self.words;
            if r < lo || r >= hi {
                if r >= self.rows.0 && r < self.rows.1 {
                    self.bits[row].fill(0);
                }
                continue;
            }
            let mut any = false;
            for (a, b) in self.bits[row.clone()].iter_mut().zip(&other.bits[row]) {
                ops.mask_words += 1;
                *a &= b;
                any |= *a != 0;
            }
            if any {
                first = first.min(r);
                last = r + 1;
            }
        }
        self.rows = (first, last);
        first < last
    }

    /// Rasterises the convex polygon `p` (pixel coordinates) conservatively: `visit(row, c0,
    /// c1)` for every row the polygon meets, with the columns it meets there, within rows
    /// `rows.0..rows.1`. Counts the pixels spanned.
    fn raster(
        &self,
        p: &[[f64; 2]],
        rows: (usize, usize),
        pixels: &mut u64,
        mut visit: impl FnMut(usize, usize, usize) -> bool,
    ) -> bool {
        if p.is_empty() {
            return false;
        }
        let (w, h) = (self.width as f64, self.height as f64);
        let ymin = p.iter().map(|q| q[1]).fold(f64::INFINITY, f64::min) - SLACK;
        let ymax = p.iter().map(|q| q[1]).fold(f64::NEG_INFINITY, f64::max) + SLACK;
        if !(ymax >= 0.0 && ymin <= h) {
            return false;
        }
        let r0 = (ymin.floor().max(0.0) as usize).max(rows.0);
        let r1 = ((ymax.floor().max(0.0) as usize).min(self.height - 1) + 1).min(rows.1);
        for r in r0..r1 {
            let (s0, s1) = (r as f64 - SLACK, r as f64 + 1.0 + SLACK);
            let (mut xmin, mut xmax) = (f64::INFINITY, f64::NEG_INFINITY);
            for i in 0..p.len() {
                let (a, b) = (p[i], p[(i + 1) % p.len()]);
                // The part of edge a–b with y in [s0, s1].
                let (lo, hi) = if a[1] <= b[1] { (a, b) } else { (b, a) };
                if hi[1] < s0 || lo[1] > s1 {
                    continue;
                }
                let dy = hi[1] - lo[1];
                let at = |y: f64| -> f64 {
                    if dy <= 0.0 {
                        return lo[0];
                    }
                    let t = ((y - lo[1]) / dy).clamp(0.0, 1.0);
                    lo[0] + t * (hi[0] - lo[0])
                };
                let (xa, xb) = if dy <= 0.0 {
                    (lo[0], hi[0])
                } else {
                    (at(lo[1].max(s0)), at(hi[1].min(s1)))
                };
                xmin = xmin.min(xa.min(xb));
                xmax = xmax.max(xa.max(xb));
            }
            let (xmin, xmax) = (xmin - SLACK, xmax + SLACK);
            if !(xmax >= 0.0 && xmin <= w) {
                continue;
            }
            let c0 = xmin.floor().max(0.0) as usize;
            let c1 = (xmax.floor().max(0.0) as usize).min(self.width - 1);
            if c0 > c1 {
                continue;
            }
            *pixels += (c1 - c0 + 1) as u64;
            if visit(r, c0, c1) {
                return true;
            }
        }
        false
    }
}

/// Bits of columns `c0..=c1` that fall in word `w`.
fn span_bits(w: usize, c0: usize, c1: usize) -> u64 {
    let lo = (w * 64).max(c0) - w * 64;
    let hi = ((w * 64 + 63).min(c1)) - w * 64;
    let n = hi - lo + 1;
    if n == 64 { u64::MAX } else { ((1u64 << n) - 1) << lo }
}

/// The view frustum's planes (near and the viewport's four).
fn view_planes(cam: &Camera) -> Vec<Plane> {
    ExactWindow::view(cam).planes
}

/// Pixel coordinates of the world polygon `poly` (clipped leniently to the view frustum
/// first; `None` when nothing is left).
pub fn project(cam: &Camera, poly: &[P3], ops: &mut Ops) -> Option<Vec<[f64; 2]>> {
    let q = clip_tol(poly, &view_planes(cam), -cam.tol, ops)?;
    let [w, h] = cam.mask_px;
    Some(
        q.iter()
            .map(|p| {
                let s = cam.screen(p);
                [
                    (s[0] + cam.tan_x) / (2.0 * cam.tan_x) * w as f64,
                    (s[1] + cam.tan_y) / (2.0 * cam.tan_y) * h as f64,
                ]
            })
            .collect(),
    )
}

/// The mask of the pieces' projections (union), conservatively rasterised.
pub fn portal_mask(cam: &Camera, pieces: &[&[P3]], ops: &mut Ops) -> Mask {
    let [w, h] = cam.mask_px;
    let mut m = Mask::empty(w, h);
    for piece in pieces {
        if let Some(p) = project(cam, piece, ops) {
            let mut spans = Vec::new();
            let mut px = 0;
            m.raster(&p, (0, h), &mut px, |r, c0, c1| {
                spans.push((r, c0, c1));
                false
            });
            ops.mask_pixels += px;
            for (r, c0, c1) in spans {
                m.set_span(r, c0, c1);
            }
        }
    }
    m
}

/// The per-pixel mask window; `M`: narrowed through a whole merged portal at once.
#[derive(Clone, Debug, PartialEq)]
pub struct MaskWindow<const M: bool> {
    /// The mask.
    pub mask: Mask,
}

impl<const M: bool> MaskWindow<M> {
    fn narrow_all(&self, cam: &Camera, pieces: &[&[P3]], ops: &mut Ops) -> Option<Self> {
        ops.narrows += 1;
        let mut m = portal_mask(cam, pieces, ops);
        m.and(&self.mask, ops).then_some(MaskWindow { mask: m })
    }
}

impl<const M: bool> Window for MaskWindow<M> {
    const NAME: &'static str = if M { "mask" } else { "mask_pieces" };
    const MERGED: bool = M;

    fn view(cam: &Camera) -> Self {
        let [w, h] = cam.mask_px;
        MaskWindow { mask: Mask::full(w, h) }
    }

    fn narrow(&self, cam: &Camera, portal: &[P3], ops: &mut Ops) -> Option<Self> {
        self.narrow_all(cam, &[portal], ops)
    }

    fn narrow_portal(&self, cam: &Camera, pieces: &[&[P3]], ops: &mut Ops) -> Option<Self> {
        self.narrow_all(cam, pieces, ops)
    }

    fn sees(&self, cam: &Camera, tri: &[P3; 3], ops: &mut Ops) -> bool {
        ops.triangle_tests += 1;
        let Some(p) = project(cam, tri, ops) else {
            return false;
        };
        let m = &self.mask;
        let mut px = 0;
        let hit = m.raster(&p, m.rows, &mut px, |r, c0, c1| m.any_span(r, c0, c1, ops));
        ops.mask_pixels += px;
        hit
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn span_bits_cover_the_columns() {
        assert_eq!(span_bits(0, 0, 63), u64::MAX);
        assert_eq!(span_bits(0, 3, 5), 0b111000);
        assert_eq!(span_bits(1, 60, 70), 0b111_1111);
        assert_eq!(span_bits(0, 60, 70), 0xF << 60);
    }

    #[test]
    fn raster_meets_every_pixel_the_polygon_meets() {
        // A thin sliver and a triangle: every pixel whose closed square the polygon meets
        // (checked on a fine grid of points of the polygon) is visited, and no pixel is
        // visited whose square lies farther than one pixel from it.
        let m = Mask::empty(32, 24);
        let mut px = 0;
        for poly in [
            vec![[1.3, 2.2], [30.7, 20.1], [30.71, 20.3]],
            vec![[4.5, 4.5], [20.0, 6.0], [8.0, 19.0]],
            vec![[-10.0, -3.0], [50.0, 5.0], [5.0, 40.0]],
        ] {
            let mut set = vec![false; 32 * 24];
            m.raster(&poly, (0, 24), &mut px, |r, c0, c1| {
                for c in c0..=c1 {
                    set[r * 32 + c] = true;
                }
                false
            });
            for i in 0..=200 {
                for j in 0..=200 - i {
                    let (u, v) = (i as f64 / 200.0, j as f64 / 200.0);
                    let x = poly[0][0] + u * (poly[1][0] - poly[0][0]) + v * (poly[2][0] - poly[0][0]);
                    let y = poly[0][1] + u * (poly[1][1] - poly[0][1]) + v * (poly[2][1] - poly[0][1]);
                    if (0.0..32.0).contains(&x) && (0.0..24.0).contains(&y) {
                        assert!(set[y as usize * 32 + x as usize], "{poly:?}: ({x}, {y}) not set");
                    }
                }
            }
        }
    }

    fn camera(width: usize) -> Camera {
        Camera::looking([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], 2, 90.0, 0.75, 1e-6).with_mask_width(width)
    }

    /// An L-shaped, non-planar merged portal seen from the origin along +x: piece A is the
    /// square `y ∈ [-1, 0], z ∈ [-1, 1]` on x = 4; piece B is bent back from A's edge y = 0
    /// to x = 5, y = 1, over the lower half `z ∈ [-1, 0]` only.
    fn bent_portal() -> [Vec<P3>; 2] {
        [
            vec![[4.0, -1.0, -1.0], [4.0, 0.0, -1.0], [4.0, 0.0, 1.0], [4.0, -1.0, 1.0]],
            vec![[4.0, 0.0, -1.0], [5.0, 1.0, -1.0], [5.0, 1.0, 0.0], [4.0, 0.0, 0.0]],
        ]
    }

    #[test]
    fn mask_of_a_non_planar_portal_is_its_conservative_raster() {
        let cam = camera(64);
        let [w, h] = cam.mask_px;
        assert_eq!([w, h], [64, 48]);
        let pieces = bent_portal();
        let refs: Vec<&[P3]> = pieces.iter().map(|p| p.as_slice()).collect();
        let mut ops = Ops::default();
        let m = portal_mask(&cam, &refs, &mut ops);
        let proj: Vec<Vec<[f64; 2]>> = pieces.iter().map(|p| project(&cam, p, &mut ops).unwrap()).collect();
        // A pixel is set exactly when its square, grown by `g` (set) or shrunk by `g` (not
        // set), meets a piece's projection with positive area.
        let meets = |c: usize, r: usize, g: f64| {
            let sq = [
                [c as f64 - g, r as f64 - g],
                [c as f64 + 1.0 + g, r as f64 - g],
                [c as f64 + 1.0 + g, r as f64 + 1.0 + g],
                [c as f64 - g, r as f64 + 1.0 + g],
            ];
            proj.iter().any(|p| {
                let mut o = Ops::default();
                let q = super::super::kgon::clip2(p, &sq, &mut o);
                // Projections may be clockwise on screen: the area's sign is not the test.
                q.len() >= 3 && super::super::kgon::area(&q).abs() > 0.0
            })
        };
        let mut set = 0;
        for r in 0..h {
            for c in 0..w {
                if m.get(c, r) {
                    set += 1;
                    assert!(meets(c, r, 1e-3), "pixel ({c}, {r}) set but not met");
                } else {
                    assert!(!meets(c, r, -1e-3), "pixel ({c}, {r}) met but not set");
                }
            }
        }
        assert_eq!(set, m.count());
        // The union is not convex: the notch (upper right, where B does not reach) is empty
        // in the mask, while the convex hull of the projection covers it.
        let sn = cam.screen(&[20.0, 1.1, 1.1]);
        let notch = [
            (sn[0] + cam.tan_x) / (2.0 * cam.tan_x) * w as f64,
            (sn[1] + cam.tan_y) / (2.0 * cam.tan_y) * h as f64,
        ];
        assert!(!m.get(notch[0] as usize, notch[1] as usize));
        // Through the mask window: a triangle far behind piece A is drawn, one behind the
        // notch is not; the merged hull window draws both.
        let tri = |y: f64, z: f64| -> [P3; 3] { [[20.0, y, z], [20.0, y + 0.2, z], [20.0, y, z + 0.2]] };
        let behind_a = tri(-2.0, 0.5);
        let behind_notch = tri(1.0, 1.0);
        let mw = MaskWindow::<true>::view(&cam)
            .narrow_portal(&cam, &refs, &mut ops)
            .expect("seen");
        assert!(mw.sees(&cam, &behind_a, &mut ops));
        assert!(!mw.sees(&cam, &behind_notch, &mut ops));
        let hw = super::super::kgon::HullWindow::<true>::view(&cam)
            .narrow_portal(&cam, &refs, &mut ops)
            .expect("seen");
        assert!(hw.sees(&cam, &behind_a, &mut ops));
        assert!(hw.sees(&cam, &behind_notch, &mut ops));
        // Piece by piece, the exact windows see the first and not the second either.
        for (t, want) in [(&behind_a, true), (&behind_notch, false)] {
            let seen = pieces.iter().any(|p| {
                ExactWindow::view(&cam)
                    .narrow(&cam, p, &mut ops)
                    .is_some_and(|x| x.sees(&cam, t, &mut ops))
            });
            assert_eq!(seen, want);
        }
    }

    #[test]
    fn merged_hull_contains_every_pieces_projection() {
        use super::super::kgon::{HullWindow, P2};
        let cam = camera(64);
        let mut rng = crate::base::rng::SplitMix64(1401);
        let mut checked = 0;
        for _ in 0..300 {
            // Two to four random quads in front of the camera, sharing nothing.
            let n = 2 + (rng.next_u64() % 3) as usize;
            let pieces: Vec<Vec<P3>> = (0..n)
                .map(|_| {
                    let c = [2.0 + 3.0 * rng.unit(), 3.0 * rng.signed_unit(), 2.0 * rng.signed_unit()];
                    let u = [0.5 * rng.signed_unit(), rng.signed_unit(), 0.3 * rng.signed_unit()];
                    let v = [0.5 * rng.signed_unit(), 0.3 * rng.signed_unit(), rng.signed_unit()];
                    let at = |a: f64, b: f64| -> P3 { std::array::from_fn(|k| c[k] + a * u[k] + b * v[k]) };
                    vec![at(-1.0, -1.0), at(1.0, -1.0), at(1.0, 1.0), at(-1.0, 1.0)]
                })
                .collect();
            let refs: Vec<&[P3]> = pieces.iter().map(|p| p.as_slice()).collect();
            let mut ops = Ops::default();
            let Some(hw) = HullWindow::<true>::view(&cam).narrow_portal(&cam, &refs, &mut ops) else {
                // Nothing on screen: no piece is either.
                for p in &pieces {
                    assert!(ExactWindow::view(&cam).narrow(&cam, p, &mut ops).is_none());
                }
                continue;
            };
            let poly: &[P2] = &hw.poly;
            for p in &pieces {
                let Some(q) = clip_tol(p, &view_planes(&cam), -cam.tol, &mut ops) else {
                    continue;
                };
                for v in &q {
                    let s = cam.screen(v);
                    for i in 0..poly.len() {
                        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
                        let c = (b[0] - a[0]) * (s[1] - a[1]) - (b[1] - a[1]) * (s[0] - a[0]);
                        assert!(c >= -1e-9, "vertex {s:?} of a piece outside the hull {poly:?}");
                    }
                }
                checked += 1;
            }
            // And the hull's area is at least each piece's projected area.
            let mut o = Ops::default();
            let ha = super::super::kgon::area(poly);
            for p in &pieces {
                if let Some(q) = clip_tol(p, &view_planes(&cam), -cam.tol, &mut o) {
                    let s: Vec<P2> = q.iter().map(|v| cam.screen(v)).collect();
                    let pa = super::super::kgon::area(&super::super::kgon::hull(&s, &mut o));
                    assert!(ha >= pa * (1.0 - 1e-12), "hull {ha} below a piece {pa}");
                }
            }
        }
        assert!(checked > 300, "{checked} pieces checked");
    }
}
