//! The cleaning pipeline shared by all readers (see the module docs of [`crate::model`]).

use std::collections::HashMap;

use rayon::prelude::*;

use super::error::ModelError;
use super::report::CleaningReport;
use super::triangulate::{Shape, classify};
use super::{Model, Polygon, SourceRef, bbox_of, newell};
use crate::ids::VertexId;
use crate::predicates::{collinear, orient3d};
use crate::tolerances::Tolerances;

/// A polygon as read, before cleaning.
#[derive(Clone, Debug)]
pub(crate) struct RawPolygon {
    pub verts: Vec<u32>,
    pub source: SourceRef,
    pub material: Option<String>,
}

/// A polygon soup as read.
#[derive(Clone, Debug, Default)]
pub(crate) struct Soup {
    pub vertices: Vec<[f64; 3]>,
    pub polygons: Vec<RawPolygon>,
}

pub(crate) use crate::base::hash::FxBuild;

/// The rounding unit of coordinates up to `max_abs` in magnitude: `f64::EPSILON * max_abs`
/// (within a factor of two of the spacing of doubles there).
fn coordinate_unit(max_abs: f64) -> f64 {
    f64::EPSILON * max_abs
}

/// The spacing of doubles at `x` (its unit in the last place, a power of two): exact for
/// normal `x` of magnitude at least 2^-969, which covers every coordinate that needs
/// recentring (0 for `x == 0`).
fn ulp(x: f64) -> f64 {
    f64::from_bits(x.abs().to_bits() & 0x7ff0_0000_0000_0000) * f64::EPSILON
}

/// `(a + b, e)` with `a + b = s + e` exactly (Knuth's TwoSum): `e == 0` iff the rounded sum
/// is exact.
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bv = s - a;
    let av = s - bv;
    (s, (a - av) + (b - bv))
}

/// The candidate recentring of coordinates spanning `[lo, hi]`: per axis
/// `c_k = round(mid_k / U_k) * U_k` with `U_k` the ulp of the largest |coordinate| there (a
/// multiple of every coordinate's own ulp on that axis but those of smaller binades, which
/// [`first_inexact`] checks; division and multiplication by the power of two `U_k` are
/// exact), `U_k`, and whether the axis *needs* it (its rounding unit
/// `f64::EPSILON * max|x_k|` exceeds `plane`).
fn recentring(lo: [f64; 3], hi: [f64; 3], plane: f64) -> ([f64; 3], [f64; 3], [bool; 3]) {
    let mut c = [0.0; 3];
    let mut quantum = [0.0; 3];
    let mut needs = [false; 3];
    for k in 0..3 {
        let m = lo[k].abs().max(hi[k].abs());
        if m > 0.0 {
            let u = ulp(m);
            let mid = lo[k] + 0.5 * (hi[k] - lo[k]);
            c[k] = (mid / u).round() * u;
            quantum[k] = u;
            needs[k] = coordinate_unit(m) > plane;
        }
    }
    (c, quantum, needs)
}

/// The exact recentring of `pts` (those flagged by `check`), spanning `[lo, hi]`: the
/// candidates of [`recentring`] on every axis where they move every checked coordinate
/// exactly; an axis that does not need a translation and has no exact one keeps 0 (its
/// coordinates are fine enough as they are, e.g. an axis through the origin with fine
/// digits). `Err((vertex, axis))` when an axis that needs one has none. Translating the
/// axes that do not need it too keeps every coordinate small: at 5e7 on x and 3.4e7 on y,
/// y's unit 7.5e-9 is under a plane tolerance of 9.2e-9, but points constructed that near
/// the tolerance broke a fuzz find's volume sum when only x moved.
fn exact_recentring(
    pts: &[[f64; 3]],
    check: impl Fn(usize) -> bool,
    lo: [f64; 3],
    hi: [f64; 3],
    plane: f64,
) -> Result<([f64; 3], [f64; 3]), (usize, usize)> {
    let (mut c, mut quantum, needs) = recentring(lo, hi, plane);
    while let Some((v, k)) = first_inexact(pts.iter().enumerate().map(|(i, p)| (p, check(i))), c) {
        if needs[k] {
            return Err((v, k));
        }
        c[k] = 0.0;
        quantum[k] = 0.0;
    }
    Ok((c, quantum))
}

/// The first (vertex, axis) among the points flagged `true` whose coordinate minus `c`
/// is not exact (TwoSum's error term non-zero), or `None` when every subtraction is exact.
fn first_inexact<'a>(pts: impl Iterator<Item = (&'a [f64; 3], bool)>, c: [f64; 3]) -> Option<(usize, usize)> {
    for (i, (p, check)) in pts.enumerate() {
        if !check {
            continue;
        }
        for k in 0..3 {
            if c[k] != 0.0 && two_sum(p[k], -c[k]).1 != 0.0 {
                return Some((i, k));
            }
        }
    }
    None
}

/// Validates, cleans and reports. `name` is the model name, `file` the name used in errors.
pub(crate) fn clean(name: &str, file: &str, soup: Soup) -> Result<Model, ModelError> {
    let Soup { mut vertices, polygons } = soup;
    let nv = vertices.len();
    let mut report = CleaningReport {
        input_vertices: nv,
        input_polygons: polygons.len(),
        ..Default::default()
    };

    // Validation (the readers have done it with line numbers already; this covers from_soup).
    for (i, p) in vertices.iter().enumerate() {
        if p.iter().any(|c| !c.is_finite()) {
            return Err(ModelError::NonFinite {
                file: file.into(),
                line: None,
                vertex: i,
                coords: *p,
            });
        }
    }
    for p in &polygons {
        if p.verts.len() < 3 {
            return Err(ModelError::TooFewVertices {
                file: file.into(),
                line: p.source.line,
                polygon: p.source.element,
                count: p.verts.len(),
            });
        }
        if let Some(&bad) = p.verts.iter().find(|&&v| v as usize >= nv) {
            return Err(ModelError::IndexOutOfRange {
                file: file.into(),
                line: p.source.line,
                polygon: p.source.element,
                index: bad as i64,
                vertex_count: nv,
                convention: "indices are 0-based",
            });
        }
    }
    if nv == 0 || polygons.is_empty() {
        return Err(ModelError::Empty {
            file: file.into(),
            reason: format!("the input has {nv} vertices and {} polygons", polygons.len()),
        });
    }

    // 1. Tolerances from the referenced vertices.
    let mut referenced = vec![false; nv];
    for p in &polygons {
        for &v in &p.verts {
            referenced[v as usize] = true;
        }
    }
    let (lo, hi) = bbox_of(vertices.iter().zip(&referenced).filter(|(_, r)| **r).map(|(p, _)| p));
    let diag = ((0..3).map(|k| (hi[k] - lo[k]) * (hi[k] - lo[k])).sum::<f64>()).sqrt();
    // Exact predicates and tolerances relative to the model's size need the coordinates
    // and their products to stay far from overflow and underflow.
    let max_abs = (0..3).map(|k| lo[k].abs().max(hi[k].abs())).fold(0.0, f64::max);
    let in_range = max_abs <= 1e15 && diag >= 1e-9 && diag.is_finite();
    if !in_range {
        // The range check has to come before cleaning: welding and the zero-area test use the
        // tolerances, which are relative to `diag`. But a model whose every polygon has zero
        // area whatever the tolerances (e.g. `f 1 1 1`, whose bounding box is a point) would
        // be empty at any scale: report that, as cleaning would, rather than a range that a
        // rescaling could not fix.
        if polygons
            .iter()
            .all(|p| zero_area_at_any_scale(&vertices, &p.verts, max_abs))
        {
            report.zero_area_polygons_dropped = polygons.len();
            return Err(all_dropped(file, &report));
        }
        return Err(ModelError::CoordinateRange {
            file: file.into(),
            max_abs,
            diag,
        });
    }
    let tolerances = Tolerances::for_scale(diag);
    let unit = coordinate_unit(max_abs);
    let (mut lo, mut hi) = (lo, hi);
    let mut origin = [0.0; 3];
    if unit > tolerances.plane_abs() {
        // Exact recentring (module docs of `crate::model`, step 1).
        let plane = tolerances.plane_abs();
        let refuse = |reason: String| ModelError::Precision {
            file: file.into(),
            max_abs,
            unit,
            plane,
            diag,
            reason,
        };
        // Referenced vertices, and the others a referenced vertex could be welded into.
        let margin = 2.0 * tolerances.weld_abs();
        let near = |p: &[f64; 3]| (0..3).all(|k| p[k] >= lo[k] - margin && p[k] <= hi[k] + margin);
        let check = |i: usize| referenced[i] || near(&vertices[i]);
        let (c, quantum) = match exact_recentring(&vertices, check, lo, hi, plane) {
            Ok(cq) => cq,
            Err((v, k)) => {
                let (c, _, _) = recentring(lo, hi, plane);
                return Err(refuse(format!(
                    "vertex {v} (0-based) has coordinate {:?} on axis {}, which the translation by {:?} there \
                     cannot move exactly (magnitudes too different along that axis)",
                    vertices[v][k],
                    ["x", "y", "z"][k],
                    c[k]
                )));
            }
        };
        for p in vertices.iter_mut() {
            for k in 0..3 {
                p[k] -= c[k];
            }
        }
        for k in 0..3 {
            lo[k] -= c[k];
            hi[k] -= c[k];
        }
        let after = (0..3).map(|k| lo[k].abs().max(hi[k].abs())).fold(0.0, f64::max);
        if coordinate_unit(after) > plane {
            return Err(refuse(format!(
                "recentred by {c:?}, the largest |coordinate| is still {after:e}"
            )));
        }
        origin = c;
        report.translation = Some(super::Translation {
            by: c,
            max_abs,
            unit,
            plane,
            quantum,
        });
    }

    // 2. Weld.
    let (weld_map, welded) = weld(&vertices, lo, tolerances.weld_abs());
    report.welded_vertices = nv - welded.len();

    // 3. Degenerate polygons: each remapped in place and tested on its own, in parallel
    // (rayon); `kept` lists the survivors in input order.
    let mut polygons = polygons;
    let area2_min = 2.0 * tolerances.area_abs();
    let normals: Vec<Option<[f64; 3]>> = polygons
        .par_iter_mut()
        .map(|rp| {
            // Remap in place, dropping consecutive repeats (cyclically).
            let vs = &mut rp.verts;
            let mut w = 0;
            for r in 0..vs.len() {
                let x = weld_map[vs[r] as usize];
                if w == 0 || vs[w - 1] != x {
                    vs[w] = x;
                    w += 1;
                }
            }
            vs.truncate(w);
            while vs.len() > 1 && vs.first() == vs.last() {
                vs.pop();
            }
            let nrm = newell(vs.iter().map(|&v| &welded[v as usize]));
            let len = (nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]).sqrt();
            let degenerate =
                !has_three_distinct(vs) || all_collinear(&welded, vs) || len.is_nan() || len < area2_min || len <= 0.0;
            (!degenerate).then_some(nrm)
        })
        .collect();
    let kept: Vec<u32> = (0..polygons.len() as u32)
        .filter(|&i| normals[i as usize].is_some())
        .collect();
    report.zero_area_polygons_dropped += polygons.len() - kept.len();
    let verts_of = |k: usize| polygons[kept[k] as usize].verts.as_slice();

    // 4. Duplicates: sort the polygons by their canonical rotation; in each group of equal
    // ones the first in input order survives. The canonical rotations are found in
    // parallel, and sorting by (rotation, index), a total order, gives the same order on
    // any number of threads.
    let starts: Vec<u32> = (0..kept.len())
        .into_par_iter()
        .map(|k| canonical_start(verts_of(k)) as u32)
        .collect();
    let mut arena: Vec<u32> = Vec::with_capacity((0..kept.len()).map(|k| verts_of(k).len()).sum());
    let mut off: Vec<usize> = Vec::with_capacity(kept.len() + 1);
    off.push(0);
    for (k, &s) in starts.iter().enumerate() {
        let vs = verts_of(k);
        arena.extend_from_slice(&vs[s as usize..]);
        arena.extend_from_slice(&vs[..s as usize]);
        off.push(arena.len());
    }
    drop(starts);
    let key = |i: u32| &arena[off[i as usize]..off[i as usize + 1]];
    let mut order: Vec<u32> = (0..kept.len() as u32).collect();
    order.par_sort_unstable_by(|&a, &b| key(a).cmp(key(b)).then(a.cmp(&b)));
    let mut dup = vec![false; kept.len()];
    for w in order.windows(2) {
        if key(w[0]) == key(w[1]) {
            dup[w[1] as usize] = true;
        }
    }
    report.duplicate_polygons_dropped += dup.iter().filter(|&&d| d).count();
    // Two-sided pairs: counted per polygon in parallel (a sum of counts). A polygon's
    // reversed rotation starts with its least vertex `m` as its own does, so it can only
    // equal keys in `order`'s block of keys starting with `m` (`block[m]..block[m + 1]`;
    // the partition point there is the partition point in all of `order`).
    let mut block = vec![0u32; welded.len() + 1];
    for &k in &order {
        block[key(k)[0] as usize + 1] += 1;
    }
    for m in 0..welded.len() {
        block[m + 1] += block[m];
    }
    report.two_sided_pairs += (0..kept.len())
        .into_par_iter()
        .map_init(
            || (Vec::new(), Vec::new()),
            |(rev, rev_key), i| {
                if dup[i] {
                    return 0;
                }
                rev.clear();
                rev.extend(verts_of(i).iter().rev());
                rev_key.clear();
                write_canonical(rev, rev_key);
                let m = rev_key[0] as usize;
                let (a, b) = (block[m] as usize, block[m + 1] as usize);
                let pos = a + order[a..b].partition_point(|&j| key(j) < rev_key.as_slice());
                match order[..b].get(pos) {
                    Some(&j) if key(j) == rev_key.as_slice() && (j as usize) < i => 1,
                    _ => 0,
                }
            },
        )
        .sum::<usize>();
    drop((arena, off, order, block));
    let kept: Vec<u32> = kept.iter().zip(dup).filter(|(_, d)| !d).map(|(&k, _)| k).collect();

    // 5. Planarity / convexity, classified in parallel (rayon); then, in input order, the
    // counts, the first refused polygon, and
    // 6. unused vertices: the vertices are numbered by first use.
    let shapes: Vec<Shape> = kept
        .par_iter()
        .map(|&pi| {
            let nrm = normals[pi as usize].unwrap_or_default();
            classify(&welded, &polygons[pi as usize].verts, nrm)
        })
        .collect();
    drop(normals);
    let mut remap = vec![u32::MAX; welded.len()];
    let mut final_vertices: Vec<[f64; 3]> = Vec::new();
    let mut final_polys: Vec<Polygon> = Vec::with_capacity(kept.len());
    let mut number = |vs: &[u32]| -> Vec<VertexId> {
        vs.iter()
            .map(|&v| {
                let r = &mut remap[v as usize];
                if *r == u32::MAX {
                    *r = final_vertices.len() as u32;
                    final_vertices.push(welded[v as usize]);
                }
                VertexId(*r)
            })
            .collect()
    };
    for (&pi, shape) in kept.iter().zip(shapes) {
        let rp = &mut polygons[pi as usize];
        match shape {
            Shape::Keep => final_polys.push(Polygon {
                verts: number(&rp.verts),
                source: rp.source,
                material: rp.material.take(),
            }),
            Shape::Triangulated {
                tris,
                nonplanar,
                fallback,
                min_area,
            } => {
                // A non-planar polygon whose outline crosses itself in projection has no
                // meaningful triangulation: a best-effort one is a fan of crossing slivers
                // (a face of 1000 random vertex indices gave ~300 triangles and ~190k cells),
                // so refuse it, naming it, rather than pay for garbage. (A planar polygon
                // touching itself, e.g. a keyhole around a hole, is still triangulated
                // best-effort.)
                if fallback && nonplanar {
                    return Err(ModelError::Malformed {
                        file: file.into(),
                        line: rp.source.line.unwrap_or(0),
                        element: format!("face {} (0-based)", rp.source.element),
                        expected: "a simple polygon (its outline must not cross itself; split it into \
                                   simple polygons)"
                            .into(),
                        found: format!(
                            "{} non-coplanar vertices whose outline crosses itself in projection \
                             (up to {} such vertices are triangulated by minimum area in 3D)",
                            rp.verts.len(),
                            super::triangulate::MIN_AREA_MAX_VERTICES
                        ),
                    });
                }
                report.nonplanar_or_nonconvex_triangulated += 1;
                report.nonplanar_polygons += nonplanar as usize;
                report.triangulation_fallbacks += fallback as usize;
                report.min_area_triangulated += min_area as usize;
                report.triangles_from_triangulation += tris.len();
                for t in tris {
                    final_polys.push(Polygon {
                        verts: number(&t),
                        source: rp.source,
                        material: rp.material.clone(),
                    });
                }
            }
        }
    }
    if final_polys.is_empty() {
        return Err(all_dropped(file, &report));
    }
    drop((polygons, kept));
    report.unused_vertices = welded.len() - final_vertices.len();
    report.final_vertices = final_vertices.len();
    report.final_polygons = final_polys.len();

    // 7. Diagnostics.
    let edges = undirected_edges(&final_polys);
    let mut i = 0;
    let mut unique: Vec<(u32, u32)> = Vec::with_capacity(edges.len() / 2 + 1);
    while i < edges.len() {
        let mut j = i;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        match j - i {
            1 => report.open_edges += 1,
            2 => {}
            _ => report.non_manifold_edges += 1,
        }
        unique.push(edges[i]);
        i = j;
    }
    report.t_junctions = count_t_junctions(&final_vertices, &unique);

    // Degeneracy: at least 4 affinely independent vertices, among the used ones (unused
    // vertices were dropped in step 6).
    let independent = affine_rank(&final_vertices);
    if independent < 4 {
        let shape = match independent {
            0 | 1 => "coincident",
            2 => "collinear",
            _ => "coplanar",
        };
        return Err(ModelError::Degenerate {
            file: file.into(),
            independent,
            shape,
        });
    }

    Ok(Model {
        name: name.to_string(),
        vertices: final_vertices,
        polygons: final_polys,
        report,
        tolerances,
        origin,
    })
}

/// The error for a model none of whose polygons survived cleaning.
fn all_dropped(file: &str, report: &CleaningReport) -> ModelError {
    ModelError::Empty {
        file: file.into(),
        reason: format!(
            "all {} polygons were dropped ({} zero-area, {} duplicate)",
            report.input_polygons, report.zero_area_polygons_dropped, report.duplicate_polygons_dropped
        ),
    }
}

/// True when the polygon `vs` has zero area in the exact input coordinates (fewer than 3
/// distinct points, or all collinear), so that cleaning drops it whatever the tolerances.
/// Used only when the coordinates are out of the supported range (`max_abs` is the largest
/// |coordinate| of the referenced vertices), where the predicates could overflow or
/// underflow: the points are first scaled by a power of two bringing `max_abs` near 1, which
/// is exact (but for coordinates more than ~2^-1000 times smaller than `max_abs`, which
/// become subnormal) and does not change collinearity.
fn zero_area_at_any_scale(pts: &[[f64; 3]], vs: &[u32], max_abs: f64) -> bool {
    if !has_three_distinct(vs) || max_abs == 0.0 || !max_abs.is_finite() {
        return true;
    }
    // 2^k for |k| <= 1023, exactly.
    let pow2 = |k: i32| f64::from_bits(((1023 + k) as u64) << 52);
    // max_abs = m * 2^e with m in [1, 2); scale by 2^-e in two halves, each in range even
    // for subnormal `max_abs` (e down to -1074).
    let e = max_abs.log2().floor() as i32;
    let (k1, k2) = (-e / 2, -e - (-e / 2));
    let scaled: Vec<[f64; 3]> = vs
        .iter()
        .map(|&v| pts[v as usize].map(|x| x * pow2(k1) * pow2(k2)))
        .collect();
    let idx: Vec<u32> = (0..scaled.len() as u32).collect();
    all_collinear(&scaled, &idx)
}

/// True when all vertices of `vs` are exactly collinear (or coincide).
fn all_collinear(pts: &[[f64; 3]], vs: &[u32]) -> bool {
    let a = &pts[vs[0] as usize];
    let Some(b) = vs.iter().map(|&v| &pts[v as usize]).find(|p| *p != a) else {
        return true;
    };
    vs.iter().all(|&v| collinear(a, b, &pts[v as usize]))
}

/// True when `vs` has at least 3 distinct entries.
fn has_three_distinct(vs: &[u32]) -> bool {
    let Some(&a) = vs.first() else { return false };
    let Some(&b) = vs.iter().find(|&&x| x != a) else {
        return false;
    };
    vs.iter().any(|&x| x != a && x != b)
}

/// Appends the lexicographically smallest rotation of the cyclic sequence `vs` to `out`.
fn write_canonical(vs: &[u32], out: &mut Vec<u32>) {
    let s = canonical_start(vs);
    out.extend_from_slice(&vs[s..]);
    out.extend_from_slice(&vs[..s]);
}

/// The start of the lexicographically smallest rotation of the cyclic sequence `vs` (the
/// first such start; 0 for an empty one).
fn canonical_start(vs: &[u32]) -> usize {
    let n = vs.len();
    let min = vs.iter().copied().min().unwrap_or(0);
    let mut best: Option<usize> = None;
    for s in (0..n).filter(|&s| vs[s] == min) {
        best = Some(match best {
            None => s,
            Some(b) => {
                let cur = (0..n).map(|i| vs[(s + i) % n]);
                let old = (0..n).map(|i| vs[(b + i) % n]);
                if cur.lt(old) { s } else { b }
            }
        });
    }
    best.unwrap_or(0)
}

/// Coarse cells of the parallel weld are `WELD_COARSE` weld cells (of size `2d`) per axis,
/// shifted by half of that so that a vertex on the bounding box's low face (weld cell 0,
/// its box reaching cell -1) is inside one: the weld box of a vertex then lies in one coarse
/// cell on an axis unless it straddles the coarse boundary (about 1 in 256).
const WELD_COARSE: i64 = 256;

/// A coarse cell holding more vertices than this is resolved by the sequential pass of
/// [`weld`] (its cost is quadratic in the cell, as for its neighbours).
const WELD_MAX_RUN: usize = 64;

/// Coarse cells are clamped to `2^21` per axis (three in a `u64`); clamping is monotone, so
/// far stray vertices only share the extreme coarse cells.
const WELD_KEY_BITS: u32 = 21;

/// The weld grid's cell of `x` on axis `k` (cell size `h = 2d`, relative to `origin`); `as`
/// saturates, so coordinates far outside the bounding box share extreme cells. The same
/// expression as [`weld_sequential`]'s, so both see the same cells.
fn weld_cell(x: f64, k: usize, origin: [f64; 3], h: f64) -> i64 {
    ((x - origin[k]) / h).floor() as i64
}

/// The weld cell of `p` and the box of cells its search covers (`p - d ..= p + d`).
fn weld_box(p: &[f64; 3], origin: [f64; 3], d: f64) -> ([i64; 3], [i64; 3], [i64; 3]) {
    let h = 2.0 * d;
    let c = std::array::from_fn(|k| weld_cell(p[k], k, origin, h));
    let lo = std::array::from_fn(|k| weld_cell(p[k] - d, k, origin, h));
    let hi = std::array::from_fn(|k| weld_cell(p[k] + d, k, origin, h));
    (c, lo, hi)
}

/// The coarse cell of weld cell `c` on one axis: a monotone (non-decreasing) function of `c`,
/// in `0..2^WELD_KEY_BITS`.
fn weld_coarse1(c: i64) -> u64 {
    let half = 1i64 << (WELD_KEY_BITS - 1);
    (c.saturating_add(WELD_COARSE / 2)
        .div_euclid(WELD_COARSE)
        .clamp(-half, half - 1)
        + half) as u64
}

/// The coarse cell of a weld cell, packed so that numeric order is lexicographic order.
fn weld_coarse(c: [i64; 3]) -> u64 {
    (weld_coarse1(c[0]) << (2 * WELD_KEY_BITS)) | (weld_coarse1(c[1]) << WELD_KEY_BITS) | weld_coarse1(c[2])
}

/// The squared distance of the weld, in [`weld_sequential`]'s operation order.
fn weld_dist2(p: &[f64; 3], q: &[f64; 3]) -> f64 {
    (0..3).map(|k| (p[k] - q[k]) * (p[k] - q[k])).sum()
}

/// Welds vertices closer than `d`: the result of [`weld_sequential`] (each vertex, in input
/// order, merges into the nearest earlier survivor within `d`, ties to the lower survivor
/// index, else survives), computed mostly in parallel (rayon), the same for any thread count.
/// Returns the map input index -> survivor index and the survivors' coordinates.
///
/// Write `c(j)` for the weld cell of vertex `j`, `B(i)` for the box of cells
/// `weld_cell(p_i - d) ..= weld_cell(p_i + d)` that the sequential weld searches for vertex
/// `i`, and `R(i, j)` for "`c(j)` lies in `B(i)` and `weld_dist2(p_i, p_j) < d²`". The
/// sequential weld stores a survivor under its cell and scans exactly the cells of `B(i)`, so
/// it keeps `i` when no earlier survivor `j` has `R(i, j)`, and otherwise merges it into the
/// minimum of those by `(dist2, survivor index)`, i.e. by `(dist2, j)`: survivor indices
/// are counted in input order. So `i`'s fate depends only on the fates of the `j < i` with
/// `R(i, j)`. Here:
///
/// 1. The vertices are sorted (in parallel) by coarse cell ([`weld_coarse`], a monotone
///    function of the weld cell: `R(i, j)` puts `j`'s coarse cell in the coarse box of
///    `B(i)`), then by index; a coarse cell's vertices are a run of the sorted array.
/// 2. A run whose every vertex's coarse box is the run's own cell is *closed*: every `j` with
///    `R(i, j)` for a vertex `i` of it is in the run. Each closed run (of at most
///    [`WELD_MAX_RUN`] vertices) is welded on its own, in parallel, in index order, by the
///    sequential rule over its earlier survivors. By induction in index order, each of its
///    vertices gets the sequential weld's fate (the candidates are the same vertices with
///    the same fates, and the minimum is over the same `(dist2, j)`).
/// 3. The other vertices (about 1% of them) are *pending*; their candidates `j < i` with
///    `R(i, j)` are listed in parallel from the runs of their coarse box, and one
///    sequential pass in input order resolves each by the same rule over the listed `j`
///    that survived. A listed `j` is in a closed run (fate final after step 2) or pending and
///    earlier (resolved before `i`), so by induction in input order each pending vertex gets
///    the sequential weld's fate too.
/// 4. Survivors are numbered in input order, as the sequential weld numbers them.
///
/// Should listing the pending vertices' candidates cost more than a few times the vertex
/// count (thousands of copies of one point, which the sequential weld merges in linear time
/// into their one survivor), [`weld_sequential`] runs instead.
fn weld(pts: &[[f64; 3]], origin: [f64; 3], d: f64) -> (Vec<u32>, Vec<[f64; 3]>) {
    match weld_targets(pts, origin, d, WELD_MAX_RUN, 32 * pts.len() + 65_536) {
        Some(target) => number_survivors(pts, &target),
        None => weld_sequential(pts, origin, d),
    }
}

/// The fuzzer's differential check of [`weld`]: every path of the parallel weld (runs of at
/// most `max_run` closed, the rest pending) against [`weld_sequential`], bit for bit, at
/// weld distance `d` from `origin`. `Err` names the first disagreement.
pub(crate) fn weld_paths_agree(pts: &[[f64; 3]], origin: [f64; 3], d: f64, max_run: usize) -> Result<(), String> {
    let (map0, surv0) = weld_sequential(pts, origin, d);
    let bits = |s: &[[f64; 3]]| s.iter().map(|p| p.map(f64::to_bits)).collect::<Vec<_>>();
    let mut paths = vec![("weld".to_string(), weld(pts, origin, d))];
    if let Some(target) = weld_targets(pts, origin, d, max_run, usize::MAX) {
        paths.push((format!("max_run {max_run}"), number_survivors(pts, &target)));
    }
    for (how, (map, surv)) in paths {
        if map != map0 || bits(&surv) != bits(&surv0) {
            return Err(format!(
                "the parallel weld ({how}, d = {d:e}) differs from the sequential weld on {} vertices",
                pts.len()
            ));
        }
    }
    Ok(())
}

/// Steps 1 to 3 of [`weld`]: for each vertex, the input index of the vertex it merges into,
/// or its own index when it survives. Runs longer than `max_run` are pending; `None` when
/// listing the pending vertices' candidates would scan more than `budget` vertices.
fn weld_targets(pts: &[[f64; 3]], origin: [f64; 3], d: f64, max_run: usize, budget: usize) -> Option<Vec<u32>> {
    use std::sync::atomic::{AtomicU32, Ordering::Relaxed};
    const PENDING: u32 = u32::MAX;
    let n = pts.len();
    let d2 = d * d;
    // 1. (coarse cell, index), sorted.
    let mut sorted: Vec<u128> = pts
        .par_iter()
        .enumerate()
        .map(|(i, p)| ((weld_coarse(weld_box(p, origin, d).0) as u128) << 32) | i as u128)
        .collect();
    sorted.par_sort_unstable();
    let key = |e: u128| (e >> 32) as u64;
    let idx = |e: u128| e as u32;
    let starts: Vec<usize> = (0..n)
        .into_par_iter()
        .filter(|&r| r == 0 || key(sorted[r]) != key(sorted[r - 1]))
        .collect();
    let run_end = |ri: usize| starts.get(ri + 1).copied().unwrap_or(n);

    // 2. Closed runs, each on its own.
    let target: Vec<AtomicU32> = (0..n).into_par_iter().map(|_| AtomicU32::new(PENDING)).collect();
    (0..starts.len()).into_par_iter().for_each(|ri| {
        let run = &sorted[starts[ri]..run_end(ri)];
        if run.len() > max_run.min(WELD_MAX_RUN) {
            return;
        }
        let own = key(run[0]);
        let mut survivors = [(0u32, [0i64; 3]); WELD_MAX_RUN];
        let mut ns = 0;
        let mut fates = [0u32; WELD_MAX_RUN];
        for (m, &e) in run.iter().enumerate() {
            let i = idx(e);
            let p = &pts[i as usize];
            let (c, lo, hi) = weld_box(p, origin, d);
            if weld_coarse(lo) != own || weld_coarse(hi) != own {
                return; // not closed: every vertex of the run stays pending
            }
            let mut best: Option<(f64, u32)> = None;
            for &(j, cj) in &survivors[..ns] {
                if (0..3).all(|k| lo[k] <= cj[k] && cj[k] <= hi[k]) {
                    let dist2 = weld_dist2(p, &pts[j as usize]);
                    if dist2 < d2 && best.is_none_or(|(bd, bj)| dist2 < bd || (dist2 == bd && j < bj)) {
                        best = Some((dist2, j));
                    }
                }
            }
            fates[m] = match best {
                Some((_, j)) => j,
                None => {
                    survivors[ns] = (i, c);
                    ns += 1;
                    i
                }
            };
        }
        for (&e, &f) in run.iter().zip(&fates) {
            target[idx(e) as usize].store(f, Relaxed);
        }
    });
    let mut target: Vec<u32> = target.into_iter().map(AtomicU32::into_inner).collect();

    // 3. Pending vertices: candidates in parallel, fates in input order.
    let mut pending: Vec<u32> = sorted
        .par_iter()
        .map(|&e| idx(e))
        .filter(|&i| target[i as usize] == PENDING)
        .collect();
    pending.par_sort_unstable();
    // The runs of the coarse cells of `i`'s box.
    let runs_of = |i: u32| {
        let (_, lo, hi) = weld_box(&pts[i as usize], origin, d);
        let (clo, chi) = (lo.map(weld_coarse1), hi.map(weld_coarse1));
        let mut ranges = Vec::new();
        for x in clo[0]..=chi[0] {
            for y in clo[1]..=chi[1] {
                for z in clo[2]..=chi[2] {
                    let k = (x << (2 * WELD_KEY_BITS)) | (y << WELD_KEY_BITS) | z;
                    let a = sorted.partition_point(|&e| key(e) < k);
                    let b = a + sorted[a..].partition_point(|&e| key(e) == k);
                    ranges.push((a, b));
                }
            }
        }
        (lo, hi, ranges)
    };
    let cost: usize = pending
        .par_iter()
        .map(|&i| runs_of(i).2.iter().map(|(a, b)| b - a).sum::<usize>())
        .sum();
    if cost > budget {
        return None;
    }
    let candidates: Vec<Vec<u32>> = pending
        .par_iter()
        .map(|&i| {
            let (lo, hi, ranges) = runs_of(i);
            let p = &pts[i as usize];
            let mut out = Vec::new();
            for (a, b) in ranges {
                for &e in &sorted[a..b] {
                    let j = idx(e);
                    if j >= i {
                        continue;
                    }
                    let q = &pts[j as usize];
                    let (cj, _, _) = weld_box(q, origin, d);
                    if (0..3).all(|k| lo[k] <= cj[k] && cj[k] <= hi[k]) && weld_dist2(p, q) < d2 {
                        out.push(j);
                    }
                }
            }
            out
        })
        .collect();
    for (&i, cands) in pending.iter().zip(&candidates) {
        let p = &pts[i as usize];
        let mut best: Option<(f64, u32)> = None;
        for &j in cands {
            if target[j as usize] != j {
                continue; // merged
            }
            let dist2 = weld_dist2(p, &pts[j as usize]);
            if best.is_none_or(|(bd, bj)| dist2 < bd || (dist2 == bd && j < bj)) {
                best = Some((dist2, j));
            }
        }
        target[i as usize] = best.map_or(i, |(_, j)| j);
    }
    Some(target)
}

/// Step 4 of [`weld`]: survivors (`target[i] == i`) numbered in input order; the map input
/// index -> survivor index (`target[i] < i` for the others) and the survivors' coordinates.
fn number_survivors(pts: &[[f64; 3]], target: &[u32]) -> (Vec<u32>, Vec<[f64; 3]>) {
    let mut map: Vec<u32> = Vec::with_capacity(pts.len());
    let mut survivors: Vec<[f64; 3]> = Vec::new();
    for (i, &t) in target.iter().enumerate() {
        if t as usize == i {
            map.push(survivors.len() as u32);
            survivors.push(pts[i]);
        } else {
            let s = map[t as usize];
            map.push(s);
        }
    }
    (map, survivors)
}

/// The sequential definition of [`weld`] (and its fallback for clustered input): vertices are
/// visited in order; each merges into the nearest earlier survivor within `d` (ties: the lower
/// survivor index), else survives. Returns the map input index -> survivor index and the
/// survivors' coordinates.
///
/// Survivors are hashed in a grid of cell size `2d`: the ball of radius `d` around a point
/// meets at most 2 cells per axis (found with the same monotone cell function, so the search
/// is conservative), i.e. at most 8 lookups per vertex.
fn weld_sequential(pts: &[[f64; 3]], origin: [f64; 3], d: f64) -> (Vec<u32>, Vec<[f64; 3]>) {
    let mut map = Vec::with_capacity(pts.len());
    let mut survivors: Vec<[f64; 3]> = Vec::new();
    // Cell -> head of a linked list of survivors through `link`.
    let mut grid: HashMap<[i64; 3], u32, FxBuild> = HashMap::default();
    grid.reserve(pts.len());
    let mut link: Vec<u32> = Vec::new();
    let d2 = d * d;
    let h = 2.0 * d;
    // `as` saturates: coordinates far outside the bbox just share extreme cells.
    let cell1 = |x: f64, k: usize| ((x - origin[k]) / h).floor() as i64;
    for p in pts {
        let c: [i64; 3] = std::array::from_fn(|k| cell1(p[k], k));
        let lo: [i64; 3] = std::array::from_fn(|k| cell1(p[k] - d, k));
        let hi: [i64; 3] = std::array::from_fn(|k| cell1(p[k] + d, k));
        let mut best: Option<(f64, u32)> = None;
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    let mut s = grid.get(&[x, y, z]).copied().unwrap_or(u32::MAX);
                    while s != u32::MAX {
                        let q = &survivors[s as usize];
                        let dist2: f64 = (0..3).map(|k| (p[k] - q[k]) * (p[k] - q[k])).sum();
                        if dist2 < d2 && best.is_none_or(|(bd, bs)| dist2 < bd || (dist2 == bd && s < bs)) {
                            best = Some((dist2, s));
                        }
                        s = link[s as usize];
                    }
                }
            }
        }
        match best {
            Some((_, s)) => map.push(s),
            None => {
                let s = survivors.len() as u32;
                survivors.push(*p);
                let head = grid.entry(c).or_insert(u32::MAX);
                link.push(*head);
                *head = s;
                map.push(s);
            }
        }
    }
    (map, survivors)
}

/// All polygon edges as sorted `(min, max)` pairs, sorted.
fn undirected_edges(polys: &[Polygon]) -> Vec<(u32, u32)> {
    let mut edges: Vec<(u32, u32)> = polys
        .par_iter()
        .flat_map_iter(|p| {
            let n = p.verts.len();
            (0..n).map(move |i| {
                let (a, b) = (p.verts[i].0, p.verts[(i + 1) % n].0);
                (a.min(b), a.max(b))
            })
        })
        .collect();
    // (The order of the pairs, as numbers.)
    edges.par_sort_unstable_by_key(|&(a, b)| (u64::from(a) << 32) | u64::from(b));
    edges
}

/// Counts (vertex, edge) pairs where the vertex lies exactly on the edge, strictly between its
/// endpoints. A uniform grid (about 2 vertices per cell) holds the vertices. Each edge is cut
/// into pieces no longer than a cell; the cells met by each piece's bounding box, slightly
/// enlarged to absorb the rounding of the cut points, are searched. The cell function is
/// monotone, so a vertex on the edge is always in a searched cell.
fn count_t_junctions(pts: &[[f64; 3]], edges: &[(u32, u32)]) -> usize {
    if pts.is_empty() || edges.is_empty() {
        return 0;
    }
    let (lo, hi) = bbox_of(pts.iter());
    let ext: [f64; 3] = std::array::from_fn(|k| hi[k] - lo[k]);
    let max_ext = ext.iter().copied().fold(0.0f64, f64::max);
    if max_ext <= 0.0 {
        return 0;
    }
    let target = (pts.len() as f64 / 2.0).max(1.0);
    let cells_for = |h: f64| -> f64 { ext.iter().map(|e| (e / h).floor() + 1.0).product() };
    let mut h = max_ext / target.cbrt();
    for _ in 0..200 {
        let c = cells_for(h);
        if c > 4.0 * target {
            h *= 1.25;
        } else if c < target / 4.0 && h > max_ext * 1e-6 {
            h /= 1.25;
        } else {
            break;
        }
    }
    let dims: [usize; 3] = std::array::from_fn(|k| ((ext[k] / h).floor() as usize + 1).max(1));
    let ncell = dims[0] * dims[1] * dims[2];
    let mut grid = TGrid {
        h,
        dims,
        lo,
        start: vec![0u32; ncell + 1],
        items: vec![0u32; pts.len()],
        // Slack for the rounding of interpolated cut points.
        eps: 1e-9 * max_ext,
    };

    // CSR grid.
    let vcell: Vec<usize> = pts
        .par_iter()
        .map(|p| grid.lin(std::array::from_fn(|k| grid.cell1(p[k], k))))
        .collect();
    for &c in &vcell {
        grid.start[c + 1] += 1;
    }
    for i in 0..ncell {
        grid.start[i + 1] += grid.start[i];
    }
    let mut fill = grid.start.clone();
    for (v, &c) in vcell.iter().enumerate() {
        grid.items[fill[c] as usize] = v as u32;
        fill[c] += 1;
    }
    drop((fill, vcell));

    // Edges in parallel (rayon), each with its own stamp (its index) in a stamp array per
    // task, so a cell is searched once per edge whichever edges a task saw before; the
    // count is a sum of counts per edge.
    edges
        .par_iter()
        .enumerate()
        .with_min_len(1024)
        .map_init(
            || vec![u32::MAX; ncell],
            |cell_stamp, (ei, &(a, b))| t_junctions_on_edge(pts, (a, b), ei as u32, cell_stamp, &grid),
        )
        .sum()
}

/// The grid of [`count_t_junctions`]: cell size, cells per axis, bounding box's low corner,
/// the vertices of each cell (CSR: `items[start[c]..start[c + 1]]`) and the slack of cut
/// points.
struct TGrid {
    h: f64,
    dims: [usize; 3],
    lo: [f64; 3],
    start: Vec<u32>,
    items: Vec<u32>,
    eps: f64,
}

impl TGrid {
    fn cell1(&self, x: f64, k: usize) -> usize {
        let c = ((x - self.lo[k]) / self.h).floor();
        if c.is_nan() || c < 0.0 {
            0
        } else {
            (c as usize).min(self.dims[k] - 1)
        }
    }

    fn lin(&self, c: [usize; 3]) -> usize {
        (c[0] * self.dims[1] + c[1]) * self.dims[2] + c[2]
    }
}

/// The vertices of `grid` lying exactly on edge `(a, b)`, strictly between its endpoints;
/// `cell_stamp[c] == stamp` marks the cells searched for this edge already.
fn t_junctions_on_edge(
    pts: &[[f64; 3]],
    (a, b): (u32, u32),
    stamp: u32,
    cell_stamp: &mut [u32],
    grid: &TGrid,
) -> usize {
    let (h, eps) = (grid.h, grid.eps);
    let cell1 = |x: f64, k: usize| grid.cell1(x, k);
    let lin = |c: [usize; 3]| grid.lin(c);
    let (start, items) = (&grid.start, &grid.items);
    let mut count = 0usize;
    let (pa, pb) = (&pts[a as usize], &pts[b as usize]);
    let len = (0..3).map(|k| (pb[k] - pa[k]) * (pb[k] - pa[k])).sum::<f64>().sqrt();
    let pieces = ((len / h).ceil() as usize).max(1);
    // Axis of the largest extent, for the strictly-between test.
    let ax = (0..3)
        .max_by(|&i, &j| {
            (pb[i] - pa[i])
                .abs()
                .partial_cmp(&(pb[j] - pa[j]).abs())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .unwrap_or(0);
    let (lo_ax, hi_ax) = if pa[ax] < pb[ax] {
        (pa[ax], pb[ax])
    } else {
        (pb[ax], pa[ax])
    };
    let at = |i: usize| -> [f64; 3] {
        if i == 0 {
            *pa
        } else if i == pieces {
            *pb
        } else {
            let t = i as f64 / pieces as f64;
            std::array::from_fn(|k| pa[k] + (pb[k] - pa[k]) * t)
        }
    };
    let mut s0 = at(0);
    for pi in 0..pieces {
        let s1 = at(pi + 1);
        let slack = if pieces == 1 { 0.0 } else { eps };
        let c0: [usize; 3] = std::array::from_fn(|k| cell1(s0[k].min(s1[k]) - slack, k));
        let c1: [usize; 3] = std::array::from_fn(|k| cell1(s0[k].max(s1[k]) + slack, k));
        for x in c0[0]..=c1[0] {
            for y in c0[1]..=c1[1] {
                for z in c0[2]..=c1[2] {
                    let ci = lin([x, y, z]);
                    if cell_stamp[ci] == stamp {
                        continue;
                    }
                    cell_stamp[ci] = stamp;
                    for &v in &items[start[ci] as usize..start[ci + 1] as usize] {
                        if v == a || v == b {
                            continue;
                        }
                        let q = &pts[v as usize];
                        if q[ax] > lo_ax && q[ax] < hi_ax && collinear(pa, pb, q) {
                            count += 1;
                        }
                    }
                }
            }
        }
        s0 = s1;
    }
    count
}

/// Size (0 to 4) of the largest affinely independent subset found greedily (exact).
fn affine_rank(pts: &[[f64; 3]]) -> usize {
    let Some(a) = pts.first() else { return 0 };
    let Some(b) = pts.iter().find(|p| *p != a) else {
        return 1;
    };
    let Some(c) = pts.iter().find(|p| !collinear(a, b, p)) else {
        return 2;
    };
    if pts.iter().any(|p| orient3d(a, b, c, p) != 0) {
        4
    } else {
        3
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn soup(vertices: Vec<[f64; 3]>, polys: Vec<Vec<u32>>) -> Soup {
        Soup {
            vertices,
            polygons: polys
                .into_iter()
                .enumerate()
                .map(|(i, verts)| RawPolygon {
                    verts,
                    source: SourceRef { line: None, element: i },
                    material: None,
                })
                .collect(),
        }
    }

    #[test]
    fn far_models_are_recentred_exactly_and_near_ones_untouched() {
        // A unit cube (diagonal √3, plane tolerance 1.7e-9): at offset 1e6 the rounding
        // unit is 2.2e-10 (no translation), at 1e7 2.2e-9 and at 1e9 2.2e-7 (translated).
        for (offset, moved) in [(0.0, false), (1e6, false), (1e7, true), (1e9, true), (1e12, true)] {
            let (mut v, f) = cube();
            for p in &mut v {
                for (k, x) in p.iter_mut().enumerate() {
                    *x += [offset, -0.7 * offset, 0.3 * offset][k];
                }
            }
            let m = clean("c", "c", soup(v.clone(), f)).unwrap();
            assert_eq!(m.report.translation.is_some(), moved, "offset {offset:e}");
            assert_eq!(m.origin != [0.0; 3], moved, "offset {offset:e}");
            // Every vertex is the input point, moved exactly: adding the origin back gives
            // the input's bits.
            // (Cleaning renumbers the vertices by first use.)
            assert_eq!(m.vertices.len(), v.len());
            for a in &m.vertices {
                let b = m.to_user(*a);
                assert!(v.contains(&b), "offset {offset:e}: {b:?}");
                assert_eq!(m.from_user(b), *a, "offset {offset:e}");
            }
            if let Some(t) = &m.report.translation {
                let s = m.report.to_string();
                assert!(s.contains("translated by [") && s.contains("exactly"), "{s}");
                assert!(t.unit > t.plane && t.by == m.origin, "{t:?}");
                // Every axis moves, also y at 1e7 (|y| = 7e6, unit 1.6e-9, would pass).
                for k in 0..3 {
                    assert!(t.quantum[k] > 0.0 && t.by[k] != 0.0, "{t:?}");
                    assert_eq!((t.by[k] / t.quantum[k]).fract(), 0.0, "{t:?}");
                }
                let after = m.vertices.iter().flatten().fold(0.0f64, |a, x| a.max(x.abs()));
                assert!(coordinate_unit(after) <= m.tolerances.plane_abs());
            }
        }
        assert_eq!(coordinate_unit(1.0), f64::EPSILON);
        assert_eq!(
            (ulp(1.0), ulp(1.5), ulp(-3.0), ulp(0.0)),
            (f64::EPSILON, f64::EPSILON, 2.0 * f64::EPSILON, 0.0)
        );
    }

    /// The exact value of `x - c` against the rounded one, in integers at the finest of
    /// their units (an oracle independent of TwoSum).
    fn exact_difference(x: f64, c: f64) -> bool {
        let q = [ulp(x), ulp(c), ulp(x - c)]
            .into_iter()
            .filter(|&u| u > 0.0)
            .fold(f64::INFINITY, f64::min);
        if q == f64::INFINITY {
            return true; // x = c = 0
        }
        let int = |y: f64| (y / q) as i128; // y is a multiple of q below 2^100 q
        int(x) - int(c) == int(x - c)
    }

    #[test]
    fn recentring_is_exact_over_random_models_at_offsets_1e3_to_1e12() {
        let mut rng = crate::base::rng::SplitMix64(16);
        let mut translated = 0;
        for trial in 0..4000 {
            let offset = 10f64.powf(3.0 + 9.0 * rng.unit());
            let size = 10f64.powf(-1.0 + 3.0 * rng.unit());
            let dir: [f64; 3] = std::array::from_fn(|_| rng.signed_unit());
            let pts: Vec<[f64; 3]> = (0..20)
                .map(|_| std::array::from_fn(|k| offset * dir[k] + size * rng.signed_unit()))
                .collect();
            let (lo, hi) = bbox_of(pts.iter());
            let diag = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
            let plane = Tolerances::for_scale(diag).plane_abs();
            if (0..3).all(|k| coordinate_unit(lo[k].abs().max(hi[k].abs())) <= plane) {
                continue; // `clean` translates only when some axis needs it
            }
            let (c, quantum) = exact_recentring(&pts, |_| true, lo, hi, plane).unwrap();
            translated += 1;
            assert_eq!(first_inexact(pts.iter().map(|p| (p, true)), c), None, "trial {trial}");
            for p in &pts {
                for k in 0..3 {
                    assert!(exact_difference(p[k], c[k]), "trial {trial}: {} - {}", p[k], c[k]);
                    if c[k] != 0.0 {
                        assert_eq!((c[k] / quantum[k]).fract(), 0.0);
                        // The translated coordinate meets the plane tolerance.
                        assert!(coordinate_unit((p[k] - c[k]).abs()) <= plane, "trial {trial}");
                    } else {
                        assert!(coordinate_unit(p[k].abs()) <= plane, "trial {trial}");
                    }
                }
            }
        }
        assert!(translated > 1000, "{translated}");
    }

    #[test]
    fn recentring_needs_multiples_of_the_unit_on_wide_axes() {
        // Forced (plane 0) on a lattice of step U spanning [-M/2, M] on every axis: x - c
        // reaches 1.5 M, exact only when c is a multiple of U (an odd multiple of U/2, the
        // rounding to half the unit, would need one more bit). This is the test that fails
        // if `recentring` rounds to half the unit.
        let mut rng = crate::base::rng::SplitMix64(7);
        let (mut inexact_trials, mut off_unit) = (0, 0);
        for trial in 0..500 {
            let e = 20 + rng.below(20) as i32;
            let u = 2f64.powi(e - 52);
            let m = 2f64.powi(e) * (1.0 + 0.99 * rng.unit());
            let lattice = |x: f64| (x / u).round() * u;
            let mut pts: Vec<[f64; 3]> = (0..30)
                .map(|_| std::array::from_fn(|_| lattice(m * (0.25 + 0.75 * rng.signed_unit()))))
                .collect();
            pts.push([lattice(-0.5 * m); 3]);
            pts.push([lattice(m); 3]);
            let (lo, hi) = bbox_of(pts.iter());
            let (c, quantum, _) = recentring(lo, hi, 0.0);
            let inexact = first_inexact(pts.iter().map(|p| (p, true)), c).is_some();
            assert_eq!(
                inexact,
                !pts.iter().all(|p| (0..3).all(|k| exact_difference(p[k], c[k]))),
                "trial {trial}: TwoSum and the integer oracle disagree"
            );
            inexact_trials += inexact as usize;
            for k in 0..3 {
                assert_eq!(quantum[k], ulp(lo[k].abs().max(hi[k].abs())));
                off_unit += ((c[k] / quantum[k]).fract() != 0.0) as usize;
            }
        }
        assert_eq!(inexact_trials, 0, "of 500");
        assert_eq!(off_unit, 0);
    }

    #[test]
    fn mixed_magnitudes_have_no_exact_translation_and_the_refusal_is_honest() {
        // Along x, 1e9 and 0.1 (a fine digit far below the unit of 1e9): no translation by a
        // multiple of that unit moves both exactly. Through `clean` this cannot happen (an
        // axis needing the translation has all its coordinates in one or two binades), so
        // the check is exercised here directly.
        let pts = [[1e9, 0.0, 0.0], [0.1, 0.0, 0.0], [5e8, 0.0, 0.0]];
        let (lo, hi) = bbox_of(pts.iter());
        let (c, _, _) = recentring(lo, hi, 0.0);
        assert!(c[0] != 0.0);
        assert_eq!(first_inexact(pts.iter().map(|p| (p, true)), c), Some((1, 0)));
        assert_eq!(exact_recentring(&pts, |_| true, lo, hi, 0.0), Err((1, 0)));
        // An axis that does not need a translation and has no exact one keeps 0: x through
        // the origin with fine digits, beside a z far away.
        let pts = [[0.1, 0.0, 1e9], [-5.0, 1.0, 1e9 + 3.0], [9.0, 2.0, 1e9 + 1.0]];
        let (lo, hi) = bbox_of(pts.iter());
        let (c, q) = exact_recentring(&pts, |_| true, lo, hi, 1e-8).unwrap();
        assert_eq!((c[0], q[0]), (0.0, 0.0));
        assert!(c[1] == 1.0 && c[2] != 0.0, "{c:?}");
        // Unflagged points are not checked.
        assert_eq!(first_inexact(pts.iter().map(|p| (p, p[0] != 0.1)), c), None);
        let e = ModelError::Precision {
            file: "m.obj".into(),
            max_abs: 1e9,
            unit: 2.2e-7,
            plane: 1.5e-8,
            diag: 15.0,
            reason: "vertex 1".into(),
        };
        let s = e.to_string();
        assert!(!s.contains("  "), "{s}");
        assert!(
            s.contains("rounding unit 2.2e-7") && s.contains("cannot restore digits"),
            "{s}"
        );
        assert!(!s.contains("translate the model nearer"), "{s}");
    }

    #[test]
    fn unreferenced_far_vertices_do_not_block_the_translation() {
        // A stray unused vertex at the origin (0.1 has digits the unit of 1e9 cannot hold):
        // it cannot be a weld target of the model's vertices, so it is not checked, and it
        // is dropped as unused.
        let (mut v, f) = cube();
        for p in &mut v {
            for x in p.iter_mut() {
                *x += 1e9;
            }
        }
        v.push([0.1, 0.1, 0.1]);
        let m = clean("c", "c", soup(v, f)).unwrap();
        assert!(m.report.translation.is_some());
        assert_eq!((m.report.unused_vertices, m.vertices.len()), (1, 8));
    }

    fn cube() -> (Vec<[f64; 3]>, Vec<Vec<u32>>) {
        let v = (0..8)
            .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
            .collect();
        // Outward-facing CCW quads.
        let f = vec![
            vec![0, 2, 3, 1],
            vec![4, 5, 7, 6],
            vec![0, 1, 5, 4],
            vec![2, 6, 7, 3],
            vec![0, 4, 6, 2],
            vec![1, 3, 7, 5],
        ];
        (v, f)
    }

    #[test]
    fn canonical_rotation() {
        let canonical = |vs: &[u32]| {
            let mut out = vec![7];
            write_canonical(vs, &mut out);
            out
        };
        assert_eq!(canonical(&[3, 1, 2]), vec![7, 1, 2, 3]);
        assert_eq!(canonical(&[2, 0, 5, 0, 1]), vec![7, 0, 1, 2, 0, 5]);
        assert!(has_three_distinct(&[1, 2, 1, 3]));
        assert!(!has_three_distinct(&[1, 2, 1, 2]));
        assert!(!has_three_distinct(&[]));
    }

    #[test]
    fn weld_merges_close_points_only() {
        let pts = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1e-9, 0.0, 0.0],
            [1.0, 1e-9, 0.0],
            [1.0, 3e-7, 0.0],
        ];
        let (map, surv) = weld(&pts, [0.0; 3], 1e-7);
        assert_eq!(map, vec![0, 1, 0, 1, 2]);
        assert_eq!(surv.len(), 3);
        // Survivors keep their exact coordinates.
        assert_eq!(surv[1], [1.0, 0.0, 0.0]);
    }

    #[test]
    fn weld_across_cell_boundary() {
        let d = 1.0;
        let pts = [[0.999, 0.0, 0.0], [1.001, 0.0, 0.0], [-0.5, -0.5, -0.5]];
        let (map, _) = weld(&pts, [-0.5; 3], d);
        assert_eq!(map[0], map[1]);
        assert_ne!(map[0], map[2]);
    }

    /// Clustered points for the weld tests: clusters around `centres` of up to 8 points each,
    /// exact copies, offsets on a lattice of `d / 4` (distances of exactly `d` and exact
    /// ties between survivors) and random offsets up to `1.5 d`, shuffled.
    fn weld_cloud(rng: &mut crate::base::rng::SplitMix64, centres: &[[f64; 3]], d: f64) -> Vec<[f64; 3]> {
        let mut pts: Vec<[f64; 3]> = Vec::new();
        for c in centres {
            let first = pts.len();
            for _ in 0..1 + rng.below(8) {
                let r = rng.unit();
                let p = if r < 0.25 && pts.len() > first {
                    pts[first + rng.below(pts.len() - first)]
                } else if r < 0.65 {
                    std::array::from_fn(|k| c[k] + d * (rng.below(13) as f64 - 6.0) / 4.0)
                } else {
                    std::array::from_fn(|k| c[k] + 1.5 * d * rng.signed_unit())
                };
                pts.push(p);
            }
        }
        for i in (1..pts.len()).rev() {
            pts.swap(i, rng.below(i + 1));
        }
        pts
    }

    /// `weld` against its sequential definition, bit for bit.
    fn assert_weld_matches(pts: &[[f64; 3]], origin: [f64; 3], d: f64, what: &str) {
        let (map0, surv0) = weld_sequential(pts, origin, d);
        let bits = |s: &[[f64; 3]]| s.iter().map(|p| p.map(f64::to_bits)).collect::<Vec<_>>();
        let check = |(map, surv): (Vec<u32>, Vec<[f64; 3]>), how: &str| {
            assert_eq!(map, map0, "{what}: {how}");
            assert_eq!(bits(&surv), bits(&surv0), "{what}: {how}");
        };
        check(weld(pts, origin, d), "weld");
        // Every path of the parallel weld on its own: all runs closed where possible, short
        // runs only, every vertex pending; and the fallback.
        for max_run in [WELD_MAX_RUN, 2, 0] {
            let target = weld_targets(pts, origin, d, max_run, usize::MAX).unwrap();
            check(number_survivors(pts, &target), &format!("max_run {max_run}"));
        }
        assert!(weld_targets(pts, origin, d, 0, 0).is_none() || pts.is_empty(), "{what}");
    }

    #[test]
    fn parallel_weld_equals_the_sequential_definition() {
        let mut rng = crate::base::rng::SplitMix64(17);
        let mut merged = 0;
        for trial in 0..60 {
            // d = 1 and 0.75 keep the lattice offsets exact (exact ties); 1e-3 does not.
            let d = [1.0, 0.75, 1e-3][trial % 3];
            let origin: [f64; 3] = std::array::from_fn(|_| d * (rng.below(9) as f64 - 4.0) / 2.0);
            // Centres on a lattice of d/2, some dense enough that clusters touch (chains of
            // welds), some on the coarse grid's boundary (fine cell 128 + 256 m, so the
            // closed-run and pending paths meet), some far out (clamped coarse cells).
            let spread = [4.0, 20.0, 200.0][trial / 3 % 3];
            let centres: Vec<[f64; 3]> = (0..40 + rng.below(200))
                .map(|_| {
                    let u = rng.unit();
                    std::array::from_fn(|k| {
                        let base = if u < 0.3 {
                            2.0 * d * (128.0 + 256.0 * (rng.below(3) as f64 - 1.0))
                        } else if u < 0.35 {
                            d * 1e9 * rng.signed_unit()
                        } else {
                            0.0
                        };
                        origin[k] + base + d * (rng.unit() * spread * 2.0).round() / 2.0
                    })
                })
                .collect();
            let pts = weld_cloud(&mut rng, &centres, d);
            merged += pts.len() - weld_sequential(&pts, origin, d).1.len();
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                pool.install(|| assert_weld_matches(&pts, origin, d, &format!("trial {trial}, {threads} threads")));
            }
        }
        assert!(merged > 3000, "{merged}");
    }

    #[test]
    fn parallel_weld_with_long_runs_and_heavy_clusters() {
        let mut rng = crate::base::rng::SplitMix64(29);
        let d = 1.0;
        // A cluster of ~270 points in one coarse cell with ~440 sparse ones: one run, too
        // long to be closed; over the budget in `weld` (sequential), listed when forced.
        let mut centres = vec![[10.0, 10.0, 10.0]; 60];
        centres.extend((0..100).map(|_| std::array::from_fn(|_| (rng.unit() * 60.0).round())));
        let pts = weld_cloud(&mut rng, &centres, d);
        assert_weld_matches(&pts, [0.0; 3], d, "long run");
        // 5000 copies of one point: over the budget, the sequential weld runs.
        let mut pts = vec![[3.0, 4.0, 5.0]; 5000];
        pts.push([3.5, 4.0, 5.0]);
        pts.push([0.0, 0.0, 0.0]);
        assert!(weld_targets(&pts, [0.0; 3], d, WELD_MAX_RUN, 32 * pts.len() + 65_536).is_none());
        assert_weld_matches(&pts, [0.0; 3], d, "copies");
        // Nothing, and a single point.
        assert_weld_matches(&[], [0.0; 3], d, "empty");
        assert_weld_matches(&[[1.0, 2.0, 3.0]], [0.0; 3], d, "single");
    }

    #[test]
    fn closed_cube_is_clean() {
        let (v, f) = cube();
        let m = clean("cube", "cube", soup(v, f)).unwrap();
        let r = &m.report;
        assert_eq!((r.final_vertices, r.final_polygons), (8, 6));
        assert_eq!((r.open_edges, r.non_manifold_edges, r.t_junctions), (0, 0, 0));
        assert_eq!(r.nonplanar_or_nonconvex_triangulated, 0);
        assert_eq!(m.triangle_count(), 12);
    }

    #[test]
    fn duplicates_and_two_sided() {
        let (v, mut f) = cube();
        f.push(vec![2, 3, 1, 0]); // same as face 0, rotated: duplicate
        f.push(vec![1, 3, 2, 0]); // reversed face 0: two-sided, kept
        let m = clean("c", "c", soup(v, f)).unwrap();
        assert_eq!(m.report.duplicate_polygons_dropped, 1);
        assert_eq!(m.report.two_sided_pairs, 1);
        assert_eq!(m.report.final_polygons, 7);
        // The two-sided face makes its 4 edges used 3 times.
        assert_eq!(m.report.non_manifold_edges, 4);
    }

    #[test]
    fn t_junction_and_open_edges() {
        // Two squares side by side in z=0, the right one split at its left edge's midpoint,
        // plus an apex to make it 3D.
        let v = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 1.0, 0.0],
            [1.0, 0.5, 0.0],
            [0.5, 0.5, 1.0],
        ];
        let f = vec![vec![0, 1, 2, 3], vec![1, 4, 5, 2, 6], vec![0, 1, 7]];
        let m = clean("t", "t", soup(v, f)).unwrap();
        // Vertex 6 lies inside edge 1-2 of the left square.
        assert_eq!(m.report.t_junctions, 1);
        // Edges: left square 4 (0-1 shared with the triangle), right pentagon 5, triangle 3.
        // All 12 edge uses are distinct edges except 0-1 (used twice): 11 edges, 10 open.
        assert_eq!(m.report.open_edges, 10);
        assert_eq!(m.report.nonplanar_or_nonconvex_triangulated, 0);
    }

    #[test]
    fn degenerate_polygons_dropped() {
        let (mut v, mut f) = cube();
        v.push([0.5, 0.0, 0.0]); // 8: on edge 0-1
        v.push([1e-12, 0.0, 0.0]); // 9: welds to 0
        f.push(vec![0, 8, 1]); // collinear
        f.push(vec![0, 9, 2]); // two distinct after welding
        f.push(vec![0, 0, 2, 2]); // two distinct
        let m = clean("d", "d", soup(v, f)).unwrap();
        let r = &m.report;
        assert_eq!(r.zero_area_polygons_dropped, 3);
        assert_eq!(r.welded_vertices, 1);
        assert_eq!(r.unused_vertices, 1); // vertex 8
        assert_eq!(r.final_vertices, 8);
        assert_eq!(
            r.final_vertices,
            r.input_vertices - r.welded_vertices - r.unused_vertices
        );
    }

    #[test]
    fn flat_model_is_degenerate() {
        let v = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        let e = clean("f", "f", soup(v, vec![vec![0, 1, 2, 3]])).unwrap_err();
        assert!(matches!(e, ModelError::Degenerate { independent: 3, .. }), "{e}");
    }

    #[test]
    fn all_dropped_is_empty() {
        let v = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        let e = clean("e", "e", soup(v, vec![vec![0, 1, 2]])).unwrap_err();
        assert!(matches!(e, ModelError::Empty { .. }), "{e}");
    }

    #[test]
    fn t_junctions_on_long_diagonal_edges() {
        // A long diagonal edge with many vertices exactly on it, and a grid of others.
        let mut v: Vec<[f64; 3]> = Vec::new();
        for i in 0..10 {
            for j in 0..10 {
                for k in 0..10 {
                    v.push([i as f64 * 10.0 + 0.3, j as f64 * 10.0 + 0.7, k as f64 * 10.0 + 0.1]);
                }
            }
        }
        let base = v.len() as u32;
        for i in 0..=64 {
            let t = i as f64;
            v.push([t, t, t]); // exactly on the diagonal from (0,0,0) to (64,64,64)
        }
        let mut f: Vec<Vec<u32>> = vec![vec![base, base + 64, 0]];
        // Reference every vertex in some triangle so none is dropped.
        for i in 0..1000u32 {
            f.push(vec![i, (i + 1) % 1000, (i + 17) % 1000]);
        }
        for i in 1..64u32 {
            f.push(vec![base + i, 5, 900]);
        }
        let m = clean("l", "l", soup(v, f)).unwrap();
        assert!(m.report.t_junctions >= 63, "{}", m.report.t_junctions);
    }

    /// A messy soup: a grid of unit cubes, each face a quad, with welds (copies moved by
    /// less than the weld distance), zero-area faces, duplicates, reversed (two-sided)
    /// faces, non-planar and non-convex faces to triangulate, materials, T-junctions.
    fn messy_soup(seed: u64) -> Soup {
        let mut rng = crate::base::rng::SplitMix64(seed);
        let (cube_v, cube_f) = cube();
        let mut vertices: Vec<[f64; 3]> = Vec::new();
        let mut polys: Vec<Vec<u32>> = Vec::new();
        for c in 0..60 {
            let o = [(c % 5) as f64, (c / 5 % 4) as f64, (c / 20) as f64];
            for f in &cube_f {
                let base = vertices.len() as u32;
                for &v in f {
                    let p = cube_v[v as usize];
                    let jitter = if rng.below(4) == 0 {
                        1e-9 * rng.signed_unit()
                    } else {
                        0.0
                    };
                    vertices.push(std::array::from_fn(|k| o[k] + p[k] + jitter));
                }
                let mut q: Vec<u32> = (base..base + 4).collect();
                match rng.below(12) {
                    0 => q.rotate_left(1 + rng.below(3)),
                    1 => {
                        polys.push(q.clone()); // duplicate below
                    }
                    2 => polys.push(q.iter().rev().copied().collect()), // two-sided
                    3 => q = vec![q[0], q[1], q[1]],                    // zero area
                    4 => {
                        // A non-convex pentagon: a dent at the face's centre.
                        let (a, b) = (vertices[q[0] as usize], vertices[q[2] as usize]);
                        vertices.push(std::array::from_fn(|k| 0.5 * (a[k] + b[k])));
                        q.insert(2, vertices.len() as u32 - 1);
                    }
                    5 => {
                        // Non-planar: one corner lifted along the face's normal a little.
                        let i = q[3] as usize;
                        vertices[i] = std::array::from_fn(|k| vertices[i][k] + 0.01 * rng.signed_unit());
                    }
                    6 => {
                        // A T-junction: the midpoint of the face's first edge, as a vertex.
                        let (a, b) = (vertices[q[0] as usize], vertices[q[1] as usize]);
                        vertices.push(std::array::from_fn(|k| 0.5 * (a[k] + b[k])));
                        q.insert(1, vertices.len() as u32 - 1);
                    }
                    _ => {}
                }
                polys.push(q);
            }
        }
        let mut s = soup(vertices, polys);
        for (i, p) in s.polygons.iter_mut().enumerate() {
            p.material = (i % 7 == 0).then(|| format!("m{}", i % 3));
        }
        s
    }

    #[test]
    fn cleaning_is_the_same_on_any_number_of_threads() {
        for seed in 0..6 {
            let results: Vec<String> = [1, 2, 3]
                .into_iter()
                .map(|threads| {
                    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                    let m = pool.install(|| clean("m", "m", messy_soup(seed))).unwrap();
                    format!("{:?} {:?} {:?} {:?}", m.vertices, m.polygons, m.report, m.origin)
                })
                .collect();
            assert!(results.iter().all(|r| *r == results[0]), "seed {seed}");
            let m = clean("m", "m", messy_soup(seed)).unwrap();
            let r = &m.report;
            assert!(
                r.welded_vertices > 0
                    && r.zero_area_polygons_dropped > 0
                    && r.duplicate_polygons_dropped > 0
                    && r.two_sided_pairs > 0
                    && r.nonplanar_or_nonconvex_triangulated > 0
                    && r.t_junctions > 0,
                "seed {seed}: {r:?}"
            );
        }
    }

    #[test]
    fn the_first_refused_polygon_is_named() {
        // Non-planar outlines of 65 vertices crossing themselves (a star of 65 points, every
        // second one): refused; the error names the first in input order, on any number of
        // threads.
        let mut s = messy_soup(1);
        let n = crate::model::triangulate::MIN_AREA_MAX_VERTICES + 1;
        let faces = s.polygons.len();
        for (copy, z) in [(0, 10.0), (1, 20.0), (2, 30.0)] {
            let base = s.vertices.len() as u32;
            s.vertices.extend((0..n).map(|k| {
                let t = std::f64::consts::TAU * (2 * k) as f64 / n as f64;
                [t.cos(), t.sin(), z + 0.01 * (k % 3) as f64]
            }));
            s.polygons.push(RawPolygon {
                verts: (base..base + n as u32).collect(),
                source: SourceRef {
                    line: Some(1000 + copy),
                    element: faces + copy,
                },
                material: None,
            });
        }
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let e = pool.install(|| clean("m", "m", s.clone())).unwrap_err();
            assert!(
                matches!(&e, ModelError::Malformed { line: 1000, element, .. } if *element == format!("face {faces} (0-based)")),
                "{e}"
            );
        }
    }
}
