//! `evaluation.json`: an experiment's counts in the thesis's terms and its scores against
//! the ground truth. Every definition is in `experiments/README.md`; in short:
//!
//! - **Point location.** Final cells are located with [`Locator`] on the run's
//!   `result.json` document (the test of `portalfind locate`: inside, within the plane
//!   tolerance, every face plane of one of the cell's convex pieces; on a shared boundary
//!   the lower cell id wins). The full decimation is followed at the level of the complex's
//!   cells: a sample belongs to the first active cell (lowest id) whose polyhedron contains
//!   it ([`crate::geom::ConvexPolyhedron::contains`]).
//! - **Room isolated**: all its samples lie in one final cell, and that cell holds no sample
//!   of another room.
//! - **Weight jump**: in the full decimation (stop `none`), the first collapse that joins
//!   cells holding samples of different rooms; its weight against the largest weight and
//!   the last weight before it.
//! - **Spike cells**: final cells holding no sample point (at the stop; and, in the full
//!   run, just before the first room-joining collapse).
//! - **Doorway matched**: a final portal joins the final cells holding most of the two
//!   rooms' samples, and either both rooms are isolated or the portal lies at the doorway.
//! - **Room-separation state** ([`Separation`]): the partition of the full run just before
//!   its first room-joining collapse (replayed with [`Decimation::replay`]; the full run's
//!   end when no collapse joins rooms). Its **separating portals** are the merged portals
//!   between two cells holding samples of different room sets; a doorway is matched at
//!   separation when a separating portal joins the cells holding most of its two rooms'
//!   samples, and matched by position when that portal's centroid also lies within
//!   [`SEPARATION_POSITION_TOLERANCE`] of the bounding-box diagonal of the doorway's centre.

use super::{CompareTo, Definition, Pipeline};
use crate::complex::CellComplex;
use crate::decimate::{Decimation, Partition, Step, StopRule};
use crate::geom::ConvexPolygon;
use crate::ids::CellId;
use crate::model::Model;
use crate::output::{Locator, ResultDoc};
use crate::predicates::P3;
use crate::thesis_models::GroundTruth;
use anyhow::Result;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use std::time::Instant;

/// Value of [`Evaluation::schema`].
pub const SCHEMA: &str = "portalfind-evaluation";
/// Value of [`Evaluation::schema_version`] (2: `rotation_checks` as a list,
/// `truth.separation`).
pub const SCHEMA_VERSION: u32 = 2;
/// Doorway position tolerance: at least this fraction of the model's bounding-box diagonal.
pub const DOORWAY_TOLERANCE: f64 = 0.02;
/// Doorway position tolerance at the room-separation state, as a fraction of the model's
/// bounding-box diagonal: loose, because a portal may sit anywhere along a corridor or
/// tunnel (the plane and axis distances say where).
pub const SEPARATION_POSITION_TOLERANCE: f64 = 0.10;

/// `evaluation.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Evaluation {
    /// Always [`SCHEMA`].
    pub schema: String,
    /// [`SCHEMA_VERSION`].
    pub schema_version: u32,
    /// The experiment's name.
    pub experiment: String,
    /// The definition file.
    pub definition: String,
    /// Its description.
    pub description: Option<String>,
    /// The model.
    pub model: ModelCounts,
    /// The settings.
    pub settings: SettingsEval,
    /// Cell-complex counts in the thesis's terms.
    pub complex: ComplexCounts,
    /// Statistics of the subdivision itself (Delaunay: tetrahedra, hull faces, seconds).
    pub subdivision_stats: Value,
    /// Decimation counts.
    pub decimation: DecimationCounts,
    /// Stage timings.
    pub timings: Timings,
    /// Scores against the ground truth (`null` without one).
    pub truth: Option<TruthEval>,
    /// The rotation checks, one per `compare_to` entry (empty without `compare_to`).
    #[serde(default)]
    pub rotation_checks: Vec<RotationCheck>,
    /// The thesis's figures, copied from the definition.
    pub thesis: Map<String, Value>,
    /// Intermediate states drawn as `cells_N.svg` (the definition's `snapshots`).
    #[serde(default)]
    pub snapshots: Vec<crate::output::Snapshot>,
}

/// Model counts.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModelCounts {
    /// `thesis:NAME` or the file path.
    pub source: String,
    /// Model name.
    pub name: String,
    /// Vertices after cleaning.
    pub vertices: usize,
    /// Polygons after cleaning.
    pub polygons: usize,
    /// Triangles (fan count).
    pub triangles: usize,
    /// Bounding-box diagonal (model units).
    pub bbox_diagonal: f64,
    /// Transforms applied.
    pub transforms: Vec<super::Transform>,
    /// Whether a ground truth was available.
    pub ground_truth: bool,
}

/// Settings.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SettingsEval {
    /// `delaunay` or `bsp`.
    pub subdivision: String,
    /// Heuristic.
    pub heuristic: String,
    /// Estimator.
    pub estimator: String,
    /// Stop rule.
    pub stop: String,
}

/// Cell-complex counts.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ComplexCounts {
    /// Tetrahedra (thesis: "the Delaunay triangulation produces N tetrahedrons").
    pub tetrahedra: usize,
    /// Cells added by splitting (thesis: "split cells").
    pub cells_split: usize,
    /// Cells after splitting.
    pub cells_after_split: usize,
    /// Exterior cells removed by the flood fill.
    pub exterior_cells_removed: usize,
    /// Active cells.
    pub active_cells: usize,
    /// Portal pairs among active cells.
    pub portal_pairs: usize,
    /// Connected regions of active cells.
    pub interior_regions: usize,
    /// Leaks.
    pub leaks: usize,
    /// Summed volume of the active cells.
    pub active_volume: f64,
}

/// Decimation counts.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DecimationCounts {
    /// Active cells at the start.
    pub initial_cells: usize,
    /// Neighbouring pairs at the start.
    pub initial_pairs: usize,
    /// Connected regions (the fewest cells reachable).
    pub regions: usize,
    /// Collapses until the stop.
    pub collapses: usize,
    /// Final cells.
    pub final_cells: usize,
    /// Final portal pairs (pairs of final cells joined by portals).
    pub final_portal_pairs: usize,
    /// Why it stopped.
    pub stop_reason: String,
    /// Weight of the last collapse (`null` when none).
    pub last_weight: Option<f64>,
    /// Weight of the pair that would have been collapsed next (threshold stops only).
    pub next_weight: Option<f64>,
}

/// Timings.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Timings {
    /// `[stage, seconds]` in order.
    pub stages: Vec<(String, f64)>,
    /// Wall time of the whole experiment (loading to evaluation).
    pub total_seconds: f64,
}

/// Scores against the ground truth.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TruthEval {
    /// Rooms in the ground truth.
    pub rooms: usize,
    /// Sample points in all.
    pub samples: usize,
    /// Samples in no final cell (in a wall, a sliver gap, or removed space).
    pub unlocated_samples: usize,
    /// Rooms isolated at the stop.
    pub rooms_isolated: usize,
    /// True when every room is isolated.
    pub all_rooms_isolated: bool,
    /// Per room.
    pub per_room: Vec<RoomEval>,
    /// Final cells at the stop holding no sample point.
    pub spike_cells: SpikeCells,
    /// The first room-joining collapse of the full decimation (`null` when no collapse
    /// joins rooms, e.g. every room in its own connected region).
    pub weight_jump: Option<WeightJump>,
    /// Every collapse of the full decimation that joins rooms (the cells' room sets each
    /// have a room the other lacks).
    pub room_merges: Vec<RoomMerge>,
    /// Collapses of the full decimation (stop `none`).
    pub full_run_collapses: usize,
    /// True when the stopped run's collapses are the first collapses of the full run (they
    /// must be: the stop rule does not change the order).
    pub stopped_run_is_prefix: bool,
    /// Doorways in the ground truth.
    pub doorways: usize,
    /// Doorways matched by a final portal.
    pub doorways_matched: usize,
    /// Final portal pairs that match some doorway.
    pub portals_at_doorways: usize,
    /// Per doorway.
    pub per_doorway: Vec<DoorwayEval>,
    /// The room-separation state of the full run (`null` only in files of schema version 1).
    #[serde(default)]
    pub separation: Option<Separation>,
}

/// The room-separation state: the full run's partition just before its first
/// room-joining collapse, or its final partition when no collapse joins rooms.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Separation {
    /// `before first room join` or `end of the full run (no collapse joins rooms)`.
    pub state: String,
    /// Collapses of the full run replayed to reach it.
    pub collapses: usize,
    /// Cells.
    pub cells: usize,
    /// Rooms isolated: all samples in one cell, which holds no other room's samples.
    pub rooms_isolated: usize,
    /// Per room: the cell holding most of its samples (lowest id on ties; `null`: none
    /// located).
    pub room_cells: Vec<Option<u32>>,
    /// Cells holding no sample point.
    pub spike_cells: usize,
    /// Their volume as a fraction of the active volume.
    pub spike_volume_fraction: f64,
    /// Number of separating portals.
    pub separating_portals: usize,
    /// The separating portals (merged portals between cells with different room sets),
    /// sorted by cell pair.
    pub portals: Vec<SeparatingPortal>,
    /// Doorways whose two rooms' cells are joined by a separating portal.
    pub doorways_matched: usize,
    /// Of those, the ones whose portal centroid lies within `position_tolerance` of the
    /// doorway's centre.
    pub doorways_matched_by_position: usize,
    /// Absolute position tolerance: [`SEPARATION_POSITION_TOLERANCE`] × the bbox diagonal.
    pub position_tolerance: f64,
    /// Separating portals matched by some doorway.
    pub portals_at_doorways: usize,
    /// Per doorway.
    pub per_doorway: Vec<SeparationDoorway>,
}

/// A separating portal: all portal pieces between two cells holding different rooms.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SeparatingPortal {
    /// The two cells (ids, ascending).
    pub cells: [u32; 2],
    /// The rooms (indices) whose samples each cell holds.
    pub rooms: [Vec<usize>; 2],
    /// Summed area.
    pub area: f64,
    /// Area-weighted centroid of its pieces.
    pub centroid: P3,
    /// Unit mean normal, from `cells[0]` to `cells[1]`.
    pub normal: P3,
    /// Convex pieces.
    pub pieces: usize,
}

/// One doorway at the room-separation state.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SeparationDoorway {
    /// The two rooms.
    pub rooms: [usize; 2],
    /// Their cells (see [`Separation::room_cells`]).
    pub cells: [Option<u32>; 2],
    /// A separating portal joins the two cells.
    pub matched: bool,
    /// And its centroid is within the position tolerance of the doorway's centre.
    pub matched_by_position: bool,
    /// That portal's index in [`Separation::portals`].
    pub portal: Option<usize>,
    /// Distance from the doorway's centre (vertex mean) to the portal's area-weighted
    /// centroid.
    pub distance: Option<f64>,
    /// Distance of the centroid from the doorway's plane (through its centre, normal: the
    /// polygon's Newell normal, i.e. along the corridor or tunnel axis).
    pub plane_distance: Option<f64>,
    /// Distance of the centroid from the doorway's axis (the line through its centre along
    /// that normal).
    pub axis_distance: Option<f64>,
    /// Angle in degrees between the portal's mean plane and the doorway's plane (0: the
    /// portal is orthogonal to the corridor axis, as a cross-section).
    pub tilt_deg: Option<f64>,
}

/// One room.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RoomEval {
    /// Room name.
    pub name: String,
    /// The final cell of each sample (`null`: in no cell).
    pub sample_cells: Vec<Option<u32>>,
    /// The final cell holding most of its samples (lowest id on ties).
    pub cell: Option<u32>,
    /// Isolated (see the module docs).
    pub isolated: bool,
}

/// Cells holding no sample point.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SpikeCells {
    /// How many.
    pub count: usize,
    /// Their summed volume.
    pub volume: f64,
    /// Their volume as a fraction of the active volume.
    pub volume_fraction: f64,
    /// Their ids (at most 100 listed).
    pub ids: Vec<u32>,
}

/// The weight jump.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct WeightJump {
    /// 1-based step of the first room-joining collapse in the full run.
    pub step: usize,
    /// Its position from the end of the full run (1: the last collapse).
    pub from_end: usize,
    /// Its weight ("at").
    pub weight: f64,
    /// The largest weight of all collapses before it.
    pub max_before: f64,
    /// The weight of the collapse just before it.
    pub last_before: f64,
    /// `weight / max_before`.
    pub ratio: f64,
    /// Cells just before it.
    pub cells_before: usize,
    /// Rooms isolated just before it (the best any stop rule could have done).
    pub rooms_isolated_before: usize,
    /// Of those cells, the ones holding no sample point (the spikes left when the rooms
    /// meet).
    pub spike_cells_before: usize,
    /// Their volume as a fraction of the active volume.
    pub spike_volume_fraction_before: f64,
    /// The room names on either side.
    pub rooms: [Vec<String>; 2],
    /// Whether the experiment's stop came before this collapse (so no rooms were joined).
    pub stop_before_jump: bool,
}

/// A room-joining collapse.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RoomMerge {
    /// 1-based step in the full run.
    pub step: usize,
    /// Its weight.
    pub weight: f64,
    /// Room indices on either side.
    pub rooms: [Vec<usize>; 2],
}

/// One doorway.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DoorwayEval {
    /// The two rooms.
    pub rooms: [usize; 2],
    /// Matched.
    pub matched: bool,
    /// `isolated rooms`, `position`, or `none`.
    pub by: String,
    /// The final portal between the rooms' cells, if any.
    pub portal: Option<[u32; 2]>,
    /// Distance from the doorway's centre (vertex mean) to the nearest centroid of that
    /// portal (its pieces' and its own area-weighted one).
    pub distance: Option<f64>,
    /// The position tolerance: the larger of 2% of the bbox diagonal and the doorway's
    /// radius (largest vertex distance from its centre).
    pub tolerance: f64,
}

/// The rotation check.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RotationCheck {
    /// The other experiment.
    pub against: String,
    /// Which portals were compared: `final` or `separating`.
    #[serde(default)]
    pub portals: super::PortalSet,
    /// Absolute centroid tolerance (fraction × the other model's bbox diagonal).
    pub distance_tolerance: f64,
    /// Relative area tolerance.
    pub area_tolerance: f64,
    /// Our final portals (mapped back) that match one of theirs.
    pub ours_matched: usize,
    /// Our final portals.
    pub ours_total: usize,
    /// Their final portals that match one of ours.
    pub theirs_matched: usize,
    /// Their final portals.
    pub theirs_total: usize,
    /// Same count and every portal matched both ways.
    pub identical: bool,
    /// Largest distance among the best matches of our portals (`null` when none matched).
    pub max_match_distance: Option<f64>,
}

/// A final portal reduced to what the rotation check compares.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PortalSummary {
    /// Area-weighted centroid of its polygons.
    pub centroid: P3,
    /// Summed area.
    pub area: f64,
}

/// Length of the diagonal of `[lo, hi]`.
pub fn diagonal(b: &[P3; 2]) -> f64 {
    dist(&b[0], &b[1])
}

fn dist(a: &P3, b: &P3) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn weighted_centroid(polys: &[ConvexPolygon]) -> P3 {
    let mut c = [0.0; 3];
    let mut w = 0.0;
    for q in polys {
        let a = q.area();
        let m = q.centroid();
        for k in 0..3 {
            c[k] += a * m[k];
        }
        w += a;
    }
    if w > 0.0 {
        c.map(|x| x / w)
    } else {
        polys.first().map(|q| q.centroid()).unwrap_or([f64::NAN; 3])
    }
}

/// The final portals of a result document.
pub fn portal_summaries(doc: &ResultDoc) -> Vec<PortalSummary> {
    doc.portals
        .iter()
        .map(|p| {
            let polys: Vec<ConvexPolygon> = p.polygons.iter().map(|v| ConvexPolygon::new(v.clone())).collect();
            PortalSummary {
                centroid: weighted_centroid(&polys),
                area: p.area,
            }
        })
        .collect()
}

/// True when two portals match: centroids closer than `dist_tol`, areas within
/// `area_rel` of the larger one.
pub fn portals_match(a: &PortalSummary, b: &PortalSummary, dist_tol: f64, area_rel: f64) -> bool {
    dist(&a.centroid, &b.centroid) <= dist_tol && (a.area - b.area).abs() <= area_rel * a.area.max(b.area)
}

/// How many of `ours` match some portal of `theirs`.
pub fn match_portals(ours: &[PortalSummary], theirs: &[PortalSummary], dist_tol: f64, area_rel: f64) -> usize {
    ours.iter()
        .filter(|a| theirs.iter().any(|b| portals_match(a, b, dist_tol, area_rel)))
        .count()
}

/// Maps portals by the inverse of `ts` (centroids; areas by the inverse scale squared).
pub fn map_back(ps: &[PortalSummary], ts: &[super::Transform]) -> Vec<PortalSummary> {
    let f = super::length_factor(ts);
    ps.iter()
        .map(|p| PortalSummary {
            centroid: super::invert_all(ts, p.centroid),
            area: p.area / (f * f),
        })
        .collect()
}

/// The separating portals of an evaluation (`None` without a ground truth).
pub fn separating_summaries(e: &Evaluation) -> Option<Vec<PortalSummary>> {
    let s = e.truth.as_ref()?.separation.as_ref()?;
    Some(
        s.portals
            .iter()
            .map(|p| PortalSummary {
                centroid: p.centroid,
                area: p.area,
            })
            .collect(),
    )
}

/// The rotation check of `ours` (this experiment's final or separating portals) against `theirs`, whose
/// model has bounding-box diagonal `their_diagonal`.
pub fn rotation_check(
    c: &CompareTo,
    ours: &[PortalSummary],
    theirs: &[PortalSummary],
    their_diagonal: f64,
) -> RotationCheck {
    let back = map_back(ours, &c.transform_inverse_of);
    let tol = c.distance_tolerance * their_diagonal;
    let ours_matched = match_portals(&back, theirs, tol, c.area_tolerance);
    let theirs_matched = match_portals(theirs, &back, tol, c.area_tolerance);
    let max_match_distance = back
        .iter()
        .filter_map(|a| {
            theirs
                .iter()
                .filter(|b| portals_match(a, b, tol, c.area_tolerance))
                .map(|b| dist(&a.centroid, &b.centroid))
                .min_by(f64::total_cmp)
        })
        .max_by(f64::total_cmp);
    RotationCheck {
        against: c.experiment.clone(),
        portals: c.portals,
        distance_tolerance: tol,
        area_tolerance: c.area_tolerance,
        ours_matched,
        ours_total: ours.len(),
        theirs_matched,
        theirs_total: theirs.len(),
        identical: ours.len() == theirs.len() && ours_matched == ours.len() && theirs_matched == theirs.len(),
        max_match_distance,
    }
}

/// Union-find over complex cells, with the rooms and volume of each set.
struct Sets {
    parent: Vec<u32>,
    rooms: Vec<Vec<usize>>,
    volume: Vec<f64>,
}

impl Sets {
    fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let p = self.parent[x as usize];
            self.parent[x as usize] = self.parent[p as usize];
            x = p;
        }
        x
    }
}

/// Samples located in the complex's active cells (lowest containing id).
fn locate_in_complex(cx: &CellComplex, pts: &[P3]) -> Vec<Option<u32>> {
    let slack = cx.tol.plane_abs();
    let boxes: Vec<(u32, P3, P3)> = cx
        .active_cells()
        .map(|(id, c)| {
            let (lo, hi) = c.poly.aabb();
            (id.0, lo, hi)
        })
        .collect();
    pts.iter()
        .map(|p| {
            boxes
                .iter()
                .filter(|(_, lo, hi)| (0..3).all(|k| p[k] >= lo[k] - slack && p[k] <= hi[k] + slack))
                .find(|(id, _, _)| cx.cells[*id as usize].poly.contains(p, &cx.tol))
                .map(|(id, _, _)| *id)
        })
        .collect()
}

fn difference_nonempty(a: &[usize], b: &[usize]) -> bool {
    a.iter().any(|r| !b.contains(r))
}

/// The weight jump, room merges and spike cells at the jump, from the full run's steps.
fn full_run_analysis(
    cx: &CellComplex,
    truth: &GroundTruth,
    located: &[Vec<Option<u32>>],
    steps: &[Step],
    initial_cells: usize,
    active_volume: f64,
    stop_steps: usize,
) -> (Option<WeightJump>, Vec<RoomMerge>) {
    let n = cx.cells.len();
    let mut s = Sets {
        parent: (0..n as u32).collect(),
        rooms: vec![Vec::new(); n],
        volume: vec![0.0; n],
    };
    for (id, c) in cx.active_cells() {
        s.volume[id.idx()] = c.poly.volume();
    }
    for (r, cells) in located.iter().enumerate() {
        for &c in cells.iter().flatten() {
            let v = &mut s.rooms[c as usize];
            if !v.contains(&r) {
                v.push(r);
            }
        }
    }
    let mut jump = None;
    let mut merges = Vec::new();
    for (i, st) in steps.iter().enumerate() {
        let (a, b) = (s.find(st.a.0), s.find(st.b.0));
        if a == b {
            continue;
        }
        let (ra, rb) = (s.rooms[a as usize].clone(), s.rooms[b as usize].clone());
        if difference_nonempty(&ra, &rb) && difference_nonempty(&rb, &ra) {
            merges.push(RoomMerge {
                step: i + 1,
                weight: st.weight,
                rooms: [ra.clone(), rb.clone()],
            });
            if jump.is_none() {
                let cells_before = if i == 0 {
                    initial_cells
                } else {
                    steps[i - 1].cells_remaining
                };
                // Sets holding samples right now (all roots with rooms).
                let mut holders = 0usize;
                let mut held_volume = 0.0;
                for x in 0..n as u32 {
                    if s.parent[x as usize] == x && !s.rooms[x as usize].is_empty() {
                        holders += 1;
                        held_volume += s.volume[x as usize];
                    }
                }
                // Before the first room-joining collapse no set holds two rooms, so a room
                // is isolated when all its samples are located in one set.
                let mut rooms_isolated_before = 0;
                for cells in located {
                    let roots: Vec<Option<u32>> = cells.iter().map(|c| c.map(|c| s.find(c))).collect();
                    if !roots.is_empty() && roots.iter().all(|r| r.is_some() && *r == roots[0]) {
                        rooms_isolated_before += 1;
                    }
                }
                let before = &steps[..i];
                let names = |v: &[usize]| v.iter().map(|&r| truth.rooms[r].name.clone()).collect();
                jump = Some(WeightJump {
                    step: i + 1,
                    from_end: steps.len() - i,
                    weight: st.weight,
                    max_before: before
                        .iter()
                        .map(|x| x.weight)
                        .fold(f64::NEG_INFINITY, f64::max)
                        .max(0.0),
                    last_before: before.last().map_or(0.0, |x| x.weight),
                    ratio: 0.0,
                    cells_before,
                    rooms_isolated_before,
                    spike_cells_before: cells_before.saturating_sub(holders),
                    // Rounding noise of the two sums is not a spike volume.
                    spike_volume_fraction_before: match (active_volume - held_volume) / active_volume {
                        f if f.is_finite() && f > 1e-12 => f,
                        _ => 0.0,
                    },
                    rooms: [names(&ra), names(&rb)],
                    stop_before_jump: stop_steps <= i,
                });
            }
        }
        // Merge b into a (volumes and rooms follow the root).
        s.parent[b as usize] = a;
        let rb = std::mem::take(&mut s.rooms[b as usize]);
        for r in rb {
            if !s.rooms[a as usize].contains(&r) {
                s.rooms[a as usize].push(r);
            }
        }
        s.rooms[a as usize].sort_unstable();
        s.volume[a as usize] += s.volume[b as usize];
    }
    if let Some(j) = &mut jump {
        j.ratio = if j.max_before > 0.0 {
            j.weight / j.max_before
        } else {
            f64::INFINITY
        };
        if !j.ratio.is_finite() {
            j.ratio = 0.0;
        }
    }
    (jump, merges)
}

fn mean(ps: &[P3]) -> P3 {
    let mut c = [0.0; 3];
    for p in ps {
        for k in 0..3 {
            c[k] += p[k] / ps.len() as f64;
        }
    }
    c
}

/// Scores of the stopped run against the ground truth; runs the full decimation when the
/// experiment's stop rule is not `none`.
fn truth_eval(p: &mut Pipeline, truth: &GroundTruth, diag: f64) -> TruthEval {
    let doc = &p.doc;
    let loc = Locator::new(doc);
    let active_volume: f64 = doc.cells.iter().map(|c| c.volume).sum::<f64>() + 0.0;
    let mut per_room: Vec<RoomEval> = truth
        .rooms
        .iter()
        .map(|r| {
            let sample_cells: Vec<Option<u32>> = r.samples.iter().map(|s| loc.locate(s)).collect();
            let mut counts: Vec<(u32, usize)> = Vec::new();
            for c in sample_cells.iter().flatten() {
                match counts.iter_mut().find(|(id, _)| id == c) {
                    Some(e) => e.1 += 1,
                    None => counts.push((*c, 1)),
                }
            }
            counts.sort_by_key(|&(id, n)| (std::cmp::Reverse(n), id));
            RoomEval {
                name: r.name.clone(),
                cell: counts.first().map(|e| e.0),
                isolated: !sample_cells.is_empty() && counts.len() == 1 && sample_cells.iter().all(|c| c.is_some()),
                sample_cells,
            }
        })
        .collect();
    // A room's cell must not hold another room's samples.
    for i in 0..per_room.len() {
        if !per_room[i].isolated {
            continue;
        }
        let c = per_room[i].cell;
        let shared = per_room
            .iter()
            .enumerate()
            .any(|(j, r)| j != i && r.sample_cells.contains(&c));
        if shared {
            per_room[i].isolated = false;
        }
    }
    let held: Vec<u32> = per_room
        .iter()
        .flat_map(|r| r.sample_cells.iter().flatten().copied())
        .collect();
    let spikes: Vec<&crate::output::CellDoc> = doc.cells.iter().filter(|c| !held.contains(&c.id)).collect();
    let spike_volume: f64 = spikes.iter().map(|c| c.volume).sum::<f64>() + 0.0; // not -0.0 when empty
    let spike_cells = SpikeCells {
        count: spikes.len(),
        volume: spike_volume,
        volume_fraction: if active_volume > 0.0 {
            spike_volume / active_volume
        } else {
            0.0
        },
        ids: spikes.iter().take(100).map(|c| c.id).collect(),
    };
    // Doorways.
    let mut per_doorway = Vec::new();
    let mut used_portals: Vec<[u32; 2]> = Vec::new();
    for d in &truth.doorways {
        let centre = mean(&d.polygon);
        let radius = d.polygon.iter().map(|q| dist(q, &centre)).fold(0.0, f64::max);
        let tolerance = (DOORWAY_TOLERANCE * diag).max(radius);
        let (ri, rj) = (&per_room[d.rooms[0]], &per_room[d.rooms[1]]);
        let mut e = DoorwayEval {
            rooms: d.rooms,
            matched: false,
            by: "none".into(),
            portal: None,
            distance: None,
            tolerance,
        };
        if let (Some(ci), Some(cj)) = (ri.cell, rj.cell)
            && ci != cj
        {
            let key = [ci.min(cj), ci.max(cj)];
            if let Some(pd) = doc.portals.iter().find(|q| q.cells == key) {
                let polys: Vec<ConvexPolygon> = pd.polygons.iter().map(|v| ConvexPolygon::new(v.clone())).collect();
                let distance = polys
                    .iter()
                    .map(|q| q.centroid())
                    .chain(std::iter::once(weighted_centroid(&polys)))
                    .map(|c| dist(&c, &centre))
                    .fold(f64::INFINITY, f64::min);
                e.portal = Some(key);
                e.distance = Some(distance);
                if ri.isolated && rj.isolated {
                    e.matched = true;
                    e.by = "isolated rooms".into();
                } else if distance <= tolerance {
                    e.matched = true;
                    e.by = "position".into();
                }
                if e.matched && !used_portals.contains(&key) {
                    used_portals.push(key);
                }
            }
        }
        per_doorway.push(e);
    }
    // The full decimation, for the weight jump.
    let full_owned;
    let full: &Decimation = if p.dec.settings.stop == StopRule::None {
        &p.dec
    } else {
        let t = Instant::now();
        let settings = crate::decimate::Settings {
            stop: StopRule::None,
            ..p.dec.settings
        };
        full_owned = Decimation::run(&p.cx, &settings);
        p.stages.push((
            "decimation: full run for the weight jump".into(),
            t.elapsed().as_secs_f64(),
        ));
        &full_owned
    };
    let stopped = &p.dec.steps;
    let stopped_run_is_prefix = stopped.len() <= full.steps.len() && full.steps[..stopped.len()] == stopped[..];
    let located: Vec<Vec<Option<u32>>> = truth
        .rooms
        .iter()
        .map(|room| locate_in_complex(&p.cx, &room.samples))
        .collect();
    let (weight_jump, room_merges) = full_run_analysis(
        &p.cx,
        truth,
        &located,
        &full.steps,
        full.stats.initial_cells,
        active_volume,
        stopped.len(),
    );
    // The room-separation state: replay up to the first room-joining collapse.
    let replayed;
    let (partition, collapses, state) = match &weight_jump {
        Some(j) => {
            replayed =
                Decimation::replay(&p.cx, &full.steps[..j.step - 1]).expect("a prefix of a recorded run replays");
            (&replayed, j.step - 1, "before first room join")
        }
        None => (
            &full.partition,
            full.steps.len(),
            "end of the full run (no collapse joins rooms)",
        ),
    };
    let separation = separation_state(&p.cx, truth, &located, partition, collapses, state, active_volume, diag);
    let rooms_isolated = per_room.iter().filter(|r| r.isolated).count();
    TruthEval {
        rooms: truth.rooms.len(),
        samples: truth.rooms.iter().map(|r| r.samples.len()).sum(),
        unlocated_samples: per_room
            .iter()
            .map(|r| r.sample_cells.iter().filter(|c| c.is_none()).count())
            .sum(),
        rooms_isolated,
        all_rooms_isolated: rooms_isolated == truth.rooms.len(),
        per_room,
        spike_cells,
        weight_jump,
        room_merges,
        full_run_collapses: full.steps.len(),
        stopped_run_is_prefix,
        doorways: truth.doorways.len(),
        doorways_matched: per_doorway.iter().filter(|d| d.matched).count(),
        portals_at_doorways: used_portals.len(),
        per_doorway,
        separation: Some(separation),
    }
}

/// Unit Newell normal of a (possibly non-planar) closed polygon; `None` when degenerate.
fn newell_normal(ps: &[P3]) -> Option<P3> {
    let mut n = [0.0; 3];
    for (i, a) in ps.iter().enumerate() {
        let b = &ps[(i + 1) % ps.len()];
        n[0] += (a[1] - b[1]) * (a[2] + b[2]);
        n[1] += (a[2] - b[2]) * (a[0] + b[0]);
        n[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    let l = dot(&n, &n).sqrt();
    (l > 0.0 && l.is_finite()).then(|| n.map(|x| x / l))
}

fn dot(a: &P3, b: &P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The cell holding most of `cells` (lowest id on ties).
fn majority(cells: &[Option<u32>]) -> Option<u32> {
    let mut counts: Vec<(u32, usize)> = Vec::new();
    for c in cells.iter().flatten() {
        match counts.iter_mut().find(|(id, _)| id == c) {
            Some(e) => e.1 += 1,
            None => counts.push((*c, 1)),
        }
    }
    counts.sort_by_key(|&(id, n)| (std::cmp::Reverse(n), id));
    counts.first().map(|e| e.0)
}

/// Separating portals and doorways at the room-separation state `partition` (reached after
/// `collapses` collapses of the full run); `located`: each room's samples in the complex's
/// cells.
#[allow(clippy::too_many_arguments)]
fn separation_state(
    cx: &CellComplex,
    truth: &GroundTruth,
    located: &[Vec<Option<u32>>],
    partition: &Partition,
    collapses: usize,
    state: &str,
    active_volume: f64,
    diag: f64,
) -> Separation {
    // Each sample's merged cell (its id), and each merged cell's rooms.
    let sample_cells: Vec<Vec<Option<u32>>> = located
        .iter()
        .map(|cells| {
            cells
                .iter()
                .map(|c| {
                    c.and_then(|c| partition.cell_of(CellId(c)))
                        .map(|i| partition.cells[i].id.0)
                })
                .collect()
        })
        .collect();
    let mut rooms_of: Vec<Vec<usize>> = vec![Vec::new(); partition.len()];
    for (r, cells) in located.iter().enumerate() {
        for &c in cells.iter().flatten() {
            if let Some(i) = partition.cell_of(CellId(c))
                && !rooms_of[i].contains(&r)
            {
                rooms_of[i].push(r);
            }
        }
    }
    for v in &mut rooms_of {
        v.sort_unstable();
    }
    let index_of = |id: CellId| {
        partition
            .cell_of(id)
            .expect("a partition cell's name is one of its pieces")
    };
    let room_cells: Vec<Option<u32>> = sample_cells.iter().map(|c| majority(c)).collect();
    let rooms_isolated = sample_cells
        .iter()
        .zip(&room_cells)
        .filter(|(cells, cell)| {
            !cells.is_empty()
                && cells.iter().all(|c| c.is_some() && c == *cell)
                && cell.is_some_and(|id| rooms_of[index_of(CellId(id))].len() == 1)
        })
        .count();
    let (mut spikes, mut spike_volume) = (0, 0.0);
    for (c, rooms) in partition.cells.iter().zip(&rooms_of) {
        if rooms.is_empty() {
            spikes += 1;
            spike_volume += c.volume;
        }
    }
    let portals: Vec<SeparatingPortal> = partition
        .portals(cx)
        .into_iter()
        .filter_map(|mp| {
            let r = mp.cells.map(|c| rooms_of[index_of(c)].clone());
            if r[0].is_empty() || r[1].is_empty() || r[0] == r[1] {
                return None;
            }
            Some(SeparatingPortal {
                cells: mp.cells.map(|c| c.0),
                rooms: r,
                area: mp.area,
                centroid: weighted_centroid(&mp.pieces),
                normal: mp.mean_normal,
                pieces: mp.pieces.len(),
            })
        })
        .collect();
    let position_tolerance = SEPARATION_POSITION_TOLERANCE * diag;
    let mut used: Vec<usize> = Vec::new();
    let per_doorway: Vec<SeparationDoorway> = truth
        .doorways
        .iter()
        .map(|d| {
            let cells = d.rooms.map(|r| room_cells[r]);
            let mut e = SeparationDoorway {
                rooms: d.rooms,
                cells,
                matched: false,
                matched_by_position: false,
                portal: None,
                distance: None,
                plane_distance: None,
                axis_distance: None,
                tilt_deg: None,
            };
            let (Some(a), Some(b)) = (cells[0], cells[1]) else {
                return e;
            };
            let key = [a.min(b), a.max(b)];
            let Some(k) = portals.iter().position(|p| p.cells == key) else {
                return e;
            };
            let p = &portals[k];
            let centre = mean(&d.polygon);
            let off = [0, 1, 2].map(|i| p.centroid[i] - centre[i]);
            let distance = dot(&off, &off).sqrt();
            e.matched = true;
            e.portal = Some(k);
            e.distance = Some(distance);
            e.matched_by_position = distance <= position_tolerance;
            if let Some(n) = newell_normal(&d.polygon) {
                let along = dot(&off, &n);
                e.plane_distance = Some(along.abs());
                e.axis_distance = Some((distance * distance - along * along).max(0.0).sqrt());
                e.tilt_deg = Some(dot(&p.normal, &n).abs().min(1.0).acos().to_degrees());
            }
            if !used.contains(&k) {
                used.push(k);
            }
            e
        })
        .collect();
    Separation {
        state: state.into(),
        collapses,
        cells: partition.len(),
        rooms_isolated,
        room_cells,
        spike_cells: spikes,
        spike_volume_fraction: match spike_volume / active_volume {
            f if f.is_finite() && f > 1e-12 => f,
            _ => 0.0,
        },
        separating_portals: portals.len(),
        doorways_matched: per_doorway.iter().filter(|d| d.matched).count(),
        doorways_matched_by_position: per_doorway.iter().filter(|d| d.matched_by_position).count(),
        position_tolerance,
        portals_at_doorways: used.len(),
        per_doorway,
        portals,
    }
}

/// The evaluation of a finished pipeline (`t0`: when the experiment started).
pub fn evaluate(
    def: &Definition,
    model: &Model,
    truth: Option<&GroundTruth>,
    p: &mut Pipeline,
    t0: Instant,
) -> Result<Evaluation> {
    let diag = diagonal(&p.doc.model.bbox);
    let truth_eval = truth.map(|t| truth_eval(p, t, diag));
    let s = &p.cx.stats;
    let doc = &p.doc;
    let (next_weight, stop_reason) = match p.dec.stop {
        crate::decimate::StopReason::Threshold { next_weight, .. } => (Some(next_weight), p.dec.stop.to_string()),
        r => (None, r.to_string()),
    };
    Ok(Evaluation {
        schema: SCHEMA.into(),
        schema_version: SCHEMA_VERSION,
        experiment: def.name.clone(),
        definition: def.file.display().to_string(),
        description: def.description.clone(),
        model: ModelCounts {
            source: def.model.to_string(),
            name: model.name.clone(),
            vertices: model.vertices.len(),
            polygons: model.polygons.len(),
            triangles: model.triangle_count(),
            bbox_diagonal: diag,
            transforms: def.transforms.clone(),
            ground_truth: truth.is_some(),
        },
        settings: SettingsEval {
            subdivision: def.subdivision.to_string(),
            heuristic: def.settings.heuristic.to_string(),
            estimator: def.settings.estimator.to_string(),
            stop: def.settings.stop.to_string(),
        },
        complex: ComplexCounts {
            tetrahedra: s.tetrahedra,
            cells_split: s.cells_split,
            cells_after_split: s.cells_after_split,
            exterior_cells_removed: s.exterior_cells_removed,
            active_cells: s.active_cells,
            portal_pairs: s.portal_pairs,
            interior_regions: s.interior_regions,
            leaks: s.leaks,
            active_volume: doc.cells.iter().map(|c| c.volume).sum::<f64>() + 0.0,
        },
        subdivision_stats: p.subdivision_stats.clone(),
        decimation: DecimationCounts {
            initial_cells: p.dec.stats.initial_cells,
            initial_pairs: p.dec.stats.initial_pairs,
            regions: p.dec.stats.regions,
            collapses: p.dec.steps.len(),
            final_cells: doc.cells.len(),
            final_portal_pairs: doc.portals.len(),
            stop_reason,
            last_weight: p.dec.steps.last().map(|s| s.weight),
            next_weight,
        },
        timings: Timings {
            stages: p.stages.clone(),
            total_seconds: t0.elapsed().as_secs_f64(),
        },
        truth: truth_eval,
        rotation_checks: Vec::new(),
        thesis: def.thesis.clone(),
        snapshots: Vec::new(),
    })
}

/// A one-line summary for the log.
pub fn one_line(e: &Evaluation) -> String {
    let mut s = format!(
        "{}: {} vertices, {} triangles, {} tets, {} split, {} exterior, {} active -> {} cells, {} portal pairs",
        e.experiment,
        e.model.vertices,
        e.model.triangles,
        e.complex.tetrahedra,
        e.complex.cells_split,
        e.complex.exterior_cells_removed,
        e.complex.active_cells,
        e.decimation.final_cells,
        e.decimation.final_portal_pairs
    );
    if let Some(t) = &e.truth {
        s += &format!(
            "; rooms isolated {}/{}, spike cells {}, doorways {}/{}",
            t.rooms_isolated, t.rooms, t.spike_cells.count, t.doorways_matched, t.doorways
        );
        if let Some(j) = &t.weight_jump {
            s += &format!("; jump {:.3} -> {:.3} at step {}", j.max_before, j.weight, j.step);
        }
    }
    s + &format!(" ({:.2} s)", e.timings.total_seconds)
}
