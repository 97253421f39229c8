//! Accuracy of a partition against a [`SuiteTruth`] (issue 15, build item 2).
//!
//! - **Rooms isolated** (as in [`crate::experiment::eval`]): all of a room's samples lie in
//!   one final cell, and that cell holds no sample of another room. A sample is located in
//!   the lowest-id active complex cell whose polyhedron contains it, then in that cell's
//!   final cell.
//! - **Volumetric precision and recall** (Bormann, Jordan, Hampp and Hägele 2016, "Room
//!   segmentation: survey, implementation, and analysis", ICRA: for each segment the share
//!   of its area in its best-matching room, for each room the share of its area in its
//!   best-matching segment), carried to 3D: volume is measured by sampling points uniformly
//!   inside every active complex cell (each convex polyhedron cut into tetrahedra from one
//!   vertex; a fixed-seed generator per cell id; samples per cell proportional to its
//!   volume, at least [`MetricOptions::min_per_cell`]), each sample weighing its cell's
//!   volume over its cell's sample count and belonging to its cell's final cell and to the
//!   room [`Membership::room_of`](super::Membership::room_of) gives. Only volume inside some
//!   room counts: precision of a final cell = (its volume in its best room) / (its volume in
//!   any room), over final cells with volume in some room; recall of a room = (its volume in
//!   its best final cell) / (its volume), a room with no measured volume scoring 0. Micro
//!   averages weigh by volume (sums of numerators over sums of denominators), macro
//!   averages are plain means.
//! - **Spike cells**: final cells holding no truth sample, and their share of the active
//!   volume (exact polyhedron volumes).
//! - **Doorway matched**: the two rooms' final cells (the cell holding most of each room's
//!   samples, lowest index on ties) differ and a merged portal between them
//!   ([`Partition::portals`]) has a piece centroid, or its area-weighted centroid, within
//!   the tolerance of the doorway polygon's centre: the larger of
//!   [`MetricOptions::doorway_tolerance`] × the model's bounding-box diagonal and the
//!   polygon's radius (the experiments' position test, without their "both rooms isolated"
//!   shortcut).

use super::SuiteTruth;
use super::util::{Rng, dist, mean};
use crate::complex::CellComplex;
use crate::decimate::{Decimation, Partition, Step};
use crate::experiment::eval::locate_in_complex;
use crate::geom::ConvexPolygon;
use crate::ids::CellId;
use crate::predicates::P3;
use serde::Serialize;
use std::collections::HashMap;

/// Options of [`score`].
#[derive(Clone, Copy, Debug)]
pub struct MetricOptions {
    /// Seed of the volume sampling (mixed with each cell's id).
    pub seed: u64,
    /// Volume samples in all, spread in proportion to cell volume.
    pub samples: usize,
    /// At least this many samples in every active cell.
    pub min_per_cell: usize,
    /// Doorway position tolerance as a fraction of the bounding-box diagonal.
    pub doorway_tolerance: f64,
}

impl Default for MetricOptions {
    fn default() -> Self {
        MetricOptions {
            seed: 0x5017_E5A3,
            samples: 200_000,
            min_per_cell: 2,
            doorway_tolerance: crate::experiment::eval::DOORWAY_TOLERANCE,
        }
    }
}

/// One room's scores.
#[derive(Clone, Debug, Serialize)]
pub struct RoomScore {
    /// All samples in one final cell holding no other room's sample.
    pub isolated: bool,
    /// The final cell (index into the partition) holding most of its samples.
    pub cell: Option<usize>,
    /// Measured volume (in the active cells).
    pub volume: f64,
    /// Share of its volume in its best-matching final cell.
    pub recall: f64,
}

/// Scores of one partition.
#[derive(Clone, Debug, Serialize)]
pub struct Accuracy {
    /// Rooms of the truth.
    pub rooms: usize,
    /// Final cells.
    pub final_cells: usize,
    /// Rooms isolated.
    pub rooms_isolated: usize,
    /// Truth samples in no active cell.
    pub unlocated_samples: usize,
    /// Volume-weighted precision.
    pub precision_micro: f64,
    /// Mean precision over final cells with room volume.
    pub precision_macro: f64,
    /// Volume-weighted recall.
    pub recall_micro: f64,
    /// Mean recall over rooms.
    pub recall_macro: f64,
    /// Final cells holding no truth sample.
    pub spike_cells: usize,
    /// Their share of the active volume.
    pub spike_volume_share: f64,
    /// Doorways of the truth.
    pub doorways: usize,
    /// Doorways matched by a final portal.
    pub doorways_matched: usize,
    /// Final cells per room.
    pub cells_per_room: f64,
    /// Share of the active volume inside some room (by sampling).
    pub room_volume_share: f64,
    /// Volume samples drawn.
    pub volume_samples: usize,
    /// Per room.
    pub per_room: Vec<RoomScore>,
}

/// A uniform point in the tetrahedron `t` (Rocchini and Cignoni's folding).
fn point_in_tet(t: &[P3; 4], rng: &mut Rng) -> P3 {
    let (mut s, mut u, mut v) = (rng.f(), rng.f(), rng.f());
    if s + u > 1.0 {
        s = 1.0 - s;
        u = 1.0 - u;
    }
    if u + v > 1.0 {
        let tmp = v;
        v = 1.0 - s - u;
        u = 1.0 - tmp;
    } else if s + u + v > 1.0 {
        let tmp = v;
        v = s + u + v - 1.0;
        s = 1.0 - u - tmp;
    }
    let a = 1.0 - s - u - v;
    [0, 1, 2].map(|k| a * t[0][k] + s * t[1][k] + u * t[2][k] + v * t[3][k])
}

fn tet_volume(t: &[P3; 4]) -> f64 {
    let d = |i: usize| [0, 1, 2].map(|k| t[i][k] - t[0][k]);
    let (a, b, c) = (d(1), d(2), d(3));
    (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])).abs()
        / 6.0
}

/// The convex polyhedron's faces as tetrahedra from its first vertex.
fn tetrahedra(faces: &[ConvexPolygon]) -> Vec<[P3; 4]> {
    let Some(apex) = faces.first().and_then(|f| f.verts.first()).copied() else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for f in faces {
        if f.verts.contains(&apex) {
            continue;
        }
        for i in 1..f.verts.len().saturating_sub(1) {
            out.push([apex, f.verts[0], f.verts[i], f.verts[i + 1]]);
        }
    }
    out
}

/// `n` uniform points in the convex polyhedron with these faces.
pub(crate) fn sample_polyhedron(faces: &[ConvexPolygon], n: usize, rng: &mut Rng) -> Vec<P3> {
    let tets = tetrahedra(faces);
    let vols: Vec<f64> = tets.iter().map(tet_volume).collect();
    let total: f64 = vols.iter().sum();
    if tets.is_empty() || total.is_nan() || total <= 0.0 {
        return Vec::new();
    }
    (0..n)
        .map(|_| {
            let mut x = rng.f() * total;
            let mut i = 0;
            while i + 1 < tets.len() && x >= vols[i] {
                x -= vols[i];
                i += 1;
            }
            point_in_tet(&tets[i], rng)
        })
        .collect()
}

/// The most frequent value (lowest on ties).
fn majority(cells: &[Option<usize>]) -> Option<usize> {
    let mut counts: Vec<(usize, usize)> = Vec::new();
    for c in cells.iter().flatten() {
        match counts.iter_mut().find(|(id, _)| id == c) {
            Some(e) => e.1 += 1,
            None => counts.push((*c, 1)),
        }
    }
    counts.sort_by_key(|&(id, n)| (std::cmp::Reverse(n), id));
    counts.first().map(|e| e.0)
}

/// A partition of the complex's active cells into the given groups (every active cell not
/// named stays alone), rebuilt with [`Decimation::replay`]: for hand-made partitions.
pub fn partition_from_groups(cx: &CellComplex, groups: &[Vec<CellId>]) -> Partition {
    let mut steps = Vec::new();
    for g in groups {
        let mut g = g.clone();
        g.sort_unstable();
        g.dedup();
        for &b in &g[1.min(g.len())..] {
            steps.push(Step {
                a: g[0],
                b,
                weight: 0.0,
                cells_remaining: 0,
                portal_area: 0.0,
                projected: [0.0; 2],
            });
        }
    }
    Decimation::replay(cx, &steps).expect("groups of distinct active cells")
}

/// Scores `partition` (of `cx`'s active cells) against `truth`.
pub fn score(cx: &CellComplex, partition: &Partition, truth: &SuiteTruth, opts: &MetricOptions) -> Accuracy {
    let nf = partition.len();
    let nr = truth.rooms.len();
    // Truth samples in final cells.
    let sample_cells: Vec<Vec<Option<usize>>> = truth
        .rooms
        .iter()
        .map(|r| {
            locate_in_complex(cx, &r.samples)
                .into_iter()
                .map(|c| c.and_then(|c| partition.cell_of(c)))
                .collect()
        })
        .collect();
    let unlocated_samples = sample_cells.iter().flatten().filter(|c| c.is_none()).count();
    let room_cell: Vec<Option<usize>> = sample_cells.iter().map(|s| majority(s)).collect();
    let isolated: Vec<bool> = (0..nr)
        .map(|i| {
            let s = &sample_cells[i];
            let c = room_cell[i];
            !s.is_empty()
                && s.iter().all(|x| x.is_some() && *x == c)
                && !(0..nr).any(|j| j != i && sample_cells[j].contains(&c))
        })
        .collect();
    // Volume sampling.
    let active: Vec<(CellId, f64)> = cx.active_cells().map(|(id, c)| (id, c.volume())).collect();
    let active_volume: f64 = active.iter().map(|a| a.1).sum();
    let mut vol: HashMap<(usize, usize), f64> = HashMap::new();
    let mut cell_room = vec![0.0; nf];
    let mut room_vol = vec![0.0; nr];
    let mut in_rooms = 0.0;
    let mut drawn = 0;
    for &(id, v) in &active {
        let Some(f) = partition.cell_of(id) else { continue };
        if v.is_nan() || v <= 0.0 {
            continue;
        }
        let n = ((opts.samples as f64 * v / active_volume).round() as usize).max(opts.min_per_cell.max(1));
        let mut rng = Rng::new(opts.seed ^ (id.0 as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let pts = sample_polyhedron(&cx.cells[id.idx()].poly().faces, n, &mut rng);
        if pts.is_empty() {
            continue;
        }
        let w = v / pts.len() as f64;
        drawn += pts.len();
        for p in pts {
            if let Some(r) = truth.membership.room_of(p) {
                *vol.entry((f, r)).or_insert(0.0) += w;
                cell_room[f] += w;
                room_vol[r] += w;
                in_rooms += w;
            }
        }
    }
    let mut best_of_cell = vec![0.0f64; nf];
    let mut best_of_room = vec![0.0f64; nr];
    for (&(f, r), &v) in &vol {
        best_of_cell[f] = best_of_cell[f].max(v);
        best_of_room[r] = best_of_room[r].max(v);
    }
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { 0.0 };
    let with_room: Vec<usize> = (0..nf).filter(|&f| cell_room[f] > 0.0).collect();
    let precision_micro = ratio(with_room.iter().map(|&f| best_of_cell[f]).sum(), in_rooms);
    let precision_macro = ratio(
        with_room.iter().map(|&f| best_of_cell[f] / cell_room[f]).sum(),
        with_room.len() as f64,
    );
    let recall: Vec<f64> = (0..nr).map(|r| ratio(best_of_room[r], room_vol[r])).collect();
    let recall_micro = ratio(best_of_room.iter().sum(), room_vol.iter().sum());
    let recall_macro = ratio(recall.iter().sum(), nr as f64);
    // Spike cells.
    let mut holds = vec![false; nf];
    for c in sample_cells.iter().flatten().flatten() {
        holds[*c] = true;
    }
    let total_volume: f64 = partition.cells.iter().map(|c| c.volume).sum();
    let spike_volume: f64 = (0..nf).filter(|&f| !holds[f]).map(|f| partition.cells[f].volume).sum();
    // Doorways.
    let portals = if truth.doorways.is_empty() {
        Vec::new()
    } else {
        partition.portals(cx)
    };
    let diag = cx.tol.scale;
    let doorways_matched = truth
        .doorways
        .iter()
        .filter(|d| {
            let (Some(ci), Some(cj)) = (room_cell[d.rooms[0]], room_cell[d.rooms[1]]) else {
                return false;
            };
            if ci == cj {
                return false;
            }
            let key = [partition.cells[ci.min(cj)].id, partition.cells[ci.max(cj)].id];
            let centre = mean(&d.polygon);
            let radius = d.polygon.iter().map(|q| dist(*q, centre)).fold(0.0, f64::max);
            let tolerance = (opts.doorway_tolerance * diag).max(radius);
            portals.iter().filter(|p| p.cells == key).any(|p| {
                let area: f64 = p.pieces.iter().map(|q| q.area()).sum();
                let mut wc = [0.0; 3];
                for q in &p.pieces {
                    let (c, a) = (q.centroid(), q.area());
                    for k in 0..3 {
                        wc[k] += c[k] * a / area.max(f64::MIN_POSITIVE);
                    }
                }
                p.pieces
                    .iter()
                    .map(|q| q.centroid())
                    .chain(std::iter::once(wc))
                    .any(|c| dist(c, centre) <= tolerance)
            })
        })
        .count();
    Accuracy {
        rooms: nr,
        final_cells: nf,
        rooms_isolated: isolated.iter().filter(|&&b| b).count(),
        unlocated_samples,
        precision_micro,
        precision_macro,
        recall_micro,
        recall_macro,
        spike_cells: holds.iter().filter(|&&h| !h).count(),
        spike_volume_share: ratio(spike_volume, total_volume),
        doorways: truth.doorways.len(),
        doorways_matched,
        cells_per_room: ratio(nf as f64, nr as f64),
        room_volume_share: ratio(in_rooms, active_volume),
        volume_samples: drawn,
        per_room: (0..nr)
            .map(|r| RoomScore {
                isolated: isolated[r],
                cell: room_cell[r],
                volume: room_vol[r],
                recall: recall[r],
            })
            .collect(),
    }
}
