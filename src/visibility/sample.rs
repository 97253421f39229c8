//! Conservativeness by sampling: random points in each cell (fixed seed; uniform in the
//! cell's convex pieces, by volume, however thin a piece is), random ray directions, first model polygon hit ([`RayCaster`]). A polygon hit from its front must
//! face some cell of the point's cell's PVS; one that does not is a *false invisible* (the
//! PVS would cull something a viewer sees). Hits on a polygon's back (only possible where
//! the model is not closed, or from a point on the wrong side of a wall) are counted apart,
//! as are rays that hit nothing (leaving the level).
//!
//! The polygons hit from a cell are a subset of what it sees, so `|PVS| / |sampled|` (in
//! triangles) bounds the PVS's overestimation from above; more rays tighten it.

use super::cost::{CellCost, CellPolygons};
use super::pvs::Pvs;
use super::raycast::RayCaster;
use crate::CellId;
use crate::base::rng::SplitMix64;
use crate::base::vec::P3;
use crate::complex::CellComplex;
use crate::model::Model;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Sampling settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SampleSettings {
    /// Seed of the generator.
    pub seed: u64,
    /// Points per cell.
    pub points_per_cell: usize,
    /// Rays per point.
    pub rays_per_point: usize,
}

impl Default for SampleSettings {
    fn default() -> Self {
        SampleSettings {
            seed: 1,
            points_per_cell: 16,
            rays_per_point: 64,
        }
    }
}

/// A ray that hit a polygon outside the PVS.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FalseInvisible {
    /// The cell of the ray's origin.
    pub cell: usize,
    /// The model polygon hit.
    pub polygon: u32,
    /// Ray origin.
    pub origin: P3,
    /// Unit direction.
    pub dir: P3,
    /// Distance to the hit.
    pub t: f64,
}

/// One cell's sampled figures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellSample {
    /// Distinct polygons hit from the front.
    pub polygons_hit: usize,
    /// Their triangles.
    pub triangles_hit: u64,
    /// PVS triangles / sampled triangles (`None` when nothing was hit).
    pub overestimation: Option<f64>,
}

/// The result of the sampling check.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SampleReport {
    /// Seed used.
    pub seed: u64,
    /// Points sampled.
    pub points: usize,
    /// Rays cast.
    pub rays: u64,
    /// Front hits outside the PVS (must be 0).
    pub false_invisible: u64,
    /// The first few of them.
    pub false_invisible_examples: Vec<FalseInvisible>,
    /// Rays that hit a polygon's back.
    pub back_hits: u64,
    /// Rays that hit nothing.
    pub escaped: u64,
    /// Mean over cells of PVS triangles / sampled triangles.
    pub overestimation_mean: f64,
    /// Median of the same.
    pub overestimation_median: f64,
    /// Largest.
    pub overestimation_max: f64,
    /// Volume-weighted mean of the sampled visible triangles (a lower bound of the exact E_T).
    pub expected_sampled_triangles: f64,
    /// Seconds.
    pub seconds: f64,
}

/// The tetrahedra of a convex polyhedron fanned from its vertex mean (one per fan triangle
/// of each face), with their volumes.
fn tetrahedra(poly: &crate::geom::ConvexPolyhedron) -> (Vec<[P3; 4]>, Vec<f64>) {
    use crate::base::vec::{cross, dot, sub};
    let c = crate::base::vec::mean(&poly.vertices());
    let mut tets = Vec::new();
    let mut vols = Vec::new();
    for f in &poly.faces {
        let v = &f.verts;
        for k in 1..v.len().saturating_sub(1) {
            let (a, b, d) = (v[0], v[k], v[k + 1]);
            let vol = dot(&sub(&a, &c), &cross(&sub(&b, &c), &sub(&d, &c))).abs() / 6.0;
            if vol > 0.0 && vol.is_finite() {
                tets.push([c, a, b, d]);
                vols.push(vol);
            }
        }
    }
    (tets, vols)
}

/// A uniform point in a convex polyhedron: a tetrahedron of its fan ([`tetrahedra`]) by
/// volume, then uniform barycentric coordinates in it (Rocchini & Cignoni's folding of the
/// unit cube). A convex combination of the piece's vertices, so it lies in the piece however
/// thin it is (no margin, no fallback to the centroid); the vertex mean when the fan has no
/// volume at all.
fn point_in(poly: &crate::geom::ConvexPolyhedron, rng: &mut SplitMix64) -> P3 {
    let (tets, vols) = tetrahedra(poly);
    let total: f64 = vols.iter().sum();
    if tets.is_empty() || total <= 0.0 {
        return crate::base::vec::mean(&poly.vertices());
    }
    let mut x = rng.unit() * total;
    let mut k = 0;
    while k + 1 < tets.len() && x >= vols[k] {
        x -= vols[k];
        k += 1;
    }
    let w = barycentric(rng.unit(), rng.unit(), rng.unit());
    let t = &tets[k];
    std::array::from_fn(|i| w[0] * t[0][i] + w[1] * t[1][i] + w[2] * t[2][i] + w[3] * t[3][i])
}

/// Uniform barycentric coordinates in a tetrahedron from three uniform numbers in [0, 1)
/// (Rocchini & Cignoni 2000): non-negative, summing to 1.
fn barycentric(mut s: f64, mut t: f64, mut u: f64) -> [f64; 4] {
    if s + t > 1.0 {
        s = 1.0 - s;
        t = 1.0 - t;
    }
    if t + u > 1.0 {
        let tmp = u;
        u = 1.0 - s - t;
        t = 1.0 - tmp;
    } else if s + t + u > 1.0 {
        let tmp = u;
        u = s + t + u - 1.0;
        s = 1.0 - t - tmp;
    }
    [(1.0 - s - t - u).max(0.0), s, t, u]
}

/// A uniform unit vector.
fn direction(rng: &mut SplitMix64) -> P3 {
    loop {
        let v = [rng.signed_unit(), rng.signed_unit(), rng.signed_unit()];
        let l2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        if l2 > 1e-6 && l2 <= 1.0 {
            let l = l2.sqrt();
            return [v[0] / l, v[1] / l, v[2] / l];
        }
    }
}

/// Samples every cell (`pieces[i]`: the complex cells making up graph cell `i`) and checks
/// the hits against `pvs`; `costs` gives the PVS triangles for the overestimation.
pub fn check(
    model: &Model,
    cx: &CellComplex,
    pieces: &[Vec<CellId>],
    pvs: &Pvs,
    polys: &CellPolygons,
    costs: &[CellCost],
    settings: &SampleSettings,
) -> (SampleReport, Vec<CellSample>) {
    let t0 = Instant::now();
    let rc = RayCaster::new(model);
    let mut rng = SplitMix64(settings.seed);
    // Which cells each polygon faces.
    let mut faces_of: Vec<Vec<u32>> = vec![Vec::new(); model.polygons.len()];
    for (c, ps) in polys.polygons.iter().enumerate() {
        for &p in ps {
            faces_of[p as usize].push(c as u32);
        }
    }
    let mut rep = SampleReport {
        seed: settings.seed,
        ..Default::default()
    };
    let mut out = Vec::with_capacity(pieces.len());
    let mut stamp = vec![u32::MAX; model.polygons.len()];
    let (mut vol, mut est) = (0.0, 0.0);
    let mut ratios = Vec::new();
    for (c, ps) in pieces.iter().enumerate() {
        let vols: Vec<f64> = ps.iter().map(|p| cx.cells[p.idx()].volume()).collect();
        let total: f64 = vols.iter().sum();
        let (mut hit_polys, mut hit_tris) = (0usize, 0u64);
        for _ in 0..settings.points_per_cell {
            if ps.is_empty() {
                break;
            }
            // A piece by volume, then a point in it.
            let mut x = rng.unit() * total;
            let mut k = 0;
            while k + 1 < ps.len() && x >= vols[k] {
                x -= vols[k];
                k += 1;
            }
            let o = point_in(&cx.cells[ps[k].idx()].poly(), &mut rng);
            rep.points += 1;
            for _ in 0..settings.rays_per_point {
                let d = direction(&mut rng);
                rep.rays += 1;
                let Some(h) = rc.cast(o, d, 0.0) else {
                    rep.escaped += 1;
                    continue;
                };
                if !h.front {
                    rep.back_hits += 1;
                    continue;
                }
                let p = h.polygon as usize;
                if stamp[p] != c as u32 {
                    stamp[p] = c as u32;
                    hit_polys += 1;
                    hit_tris += polys.triangles[p] as u64;
                }
                if !faces_of[p].iter().any(|&q| pvs.sets[c].contains(q as usize)) {
                    rep.false_invisible += 1;
                    if rep.false_invisible_examples.len() < 16 {
                        rep.false_invisible_examples.push(FalseInvisible {
                            cell: c,
                            polygon: h.polygon,
                            origin: o,
                            dir: d,
                            t: h.t,
                        });
                    }
                }
            }
        }
        let pvs_t = costs.get(c).map(|k| k.pvs_triangles).unwrap_or(0);
        let over = (hit_tris > 0).then(|| pvs_t as f64 / hit_tris as f64);
        if let Some(r) = over {
            ratios.push(r);
        }
        vol += total;
        est += total * hit_tris as f64;
        out.push(CellSample {
            polygons_hit: hit_polys,
            triangles_hit: hit_tris,
            overestimation: over,
        });
    }
    ratios.sort_by(f64::total_cmp);
    if !ratios.is_empty() {
        rep.overestimation_mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        rep.overestimation_median = ratios[ratios.len() / 2];
        rep.overestimation_max = *ratios.last().unwrap();
    }
    rep.expected_sampled_triangles = if vol > 0.0 { est / vol } else { 0.0 };
    rep.seconds = t0.elapsed().as_secs_f64();
    (rep, out)
}

/// The complex cells of each cell of a partition (for [`check`]).
pub fn pieces_of_partition(partition: &crate::decimate::Partition) -> Vec<Vec<CellId>> {
    partition.cells.iter().map(|c| c.pieces.clone()).collect()
}

/// The complex's active cells, one per graph cell, in the order of
/// [`super::PortalGraph::from_complex`].
pub fn pieces_of_complex(cx: &CellComplex) -> Vec<Vec<CellId>> {
    cx.active_cells().map(|(c, _)| vec![c]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::ConvexPolyhedron;

    #[test]
    fn barycentric_coordinates_are_a_partition_of_one() {
        let mut rng = SplitMix64(7);
        for _ in 0..1000 {
            let w = barycentric(rng.unit(), rng.unit(), rng.unit());
            assert!(w.iter().all(|&x| x >= 0.0), "{w:?}");
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{w:?}");
        }
    }

    /// A slab far thinner than any margin gets points spread over it, all inside (the old
    /// sampler fell back to the centroid for every point of such a piece).
    #[test]
    fn thin_pieces_are_sampled_inside_and_spread() {
        let h = 1e-9;
        let poly = ConvexPolyhedron::cuboid(&[0.0, 0.0, 0.0], &[2.0, 1.0, h]);
        let mut rng = SplitMix64(1);
        let pts: Vec<P3> = (0..200).map(|_| point_in(&poly, &mut rng)).collect();
        for p in &pts {
            assert!((-1e-12..=2.0 + 1e-12).contains(&p[0]), "{p:?}");
            assert!((-1e-12..=1.0 + 1e-12).contains(&p[1]), "{p:?}");
            assert!((-1e-21..=h + 1e-21).contains(&p[2]), "{p:?}");
        }
        // Spread: both halves along x hold points, none is the centroid for all.
        assert!(pts.iter().any(|p| p[0] < 0.5) && pts.iter().any(|p| p[0] > 1.5));
        let mean_x = pts.iter().map(|p| p[0]).sum::<f64>() / pts.len() as f64;
        assert!((mean_x - 1.0).abs() < 0.15, "uniform: mean x {mean_x}");
    }

    #[test]
    fn points_of_a_tetrahedron_are_uniform() {
        let poly =
            ConvexPolyhedron::tetrahedron(&[0.0, 0.0, 0.0], &[1.0, 0.0, 0.0], &[0.0, 1.0, 0.0], &[0.0, 0.0, 1.0]);
        let mut rng = SplitMix64(3);
        let n = 4000;
        let mut below = 0;
        for _ in 0..n {
            let p = point_in(&poly, &mut rng);
            assert!(
                p.iter().all(|&x| x >= -1e-15) && p.iter().sum::<f64>() <= 1.0 + 1e-12,
                "{p:?}"
            );
            // The corner tetrahedron x + y + z < 1/2 holds 1/8 of the volume.
            below += (p.iter().sum::<f64>() < 0.5) as usize;
        }
        let f = below as f64 / n as f64;
        assert!((f - 0.125).abs() < 0.03, "fraction {f}");
    }
}
