//! The report types of `evaluation.json` (every field is described in
//! `experiments/README.md`). Cell ids are [`CellId`]s (serialized as plain numbers).

use crate::experiment::PortalSet;
use crate::ids::CellId;
use crate::predicates::P3;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

/// `evaluation.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Evaluation {
    /// Always [`SCHEMA`](super::SCHEMA).
    pub schema: String,
    /// [`SCHEMA_VERSION`](super::SCHEMA_VERSION).
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
    /// Stage timings: machine-dependent, so not written to `evaluation.json` (the
    /// experiment runner writes them to `timings.json`, which git ignores).
    #[serde(skip, default)]
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
    /// The visibility of the final partition (only when the experiment was evaluated:
    /// definition field `evaluate`, or `experiment --evaluate`; absent otherwise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub visibility: Option<VisibilitySummary>,
}

/// The visibility figures of an evaluated experiment (the full figures are in its
/// `visibility.json`, written by [`crate::evaluate`]); no timings (those go to
/// `timings.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VisibilitySummary {
    /// Cells of the portal graph (the final partition).
    pub cells: usize,
    /// Portals (cell pairs).
    pub portals: usize,
    /// Mean PVS size in cells.
    pub pvs_mean_cells: f64,
    /// Largest PVS size in cells.
    pub pvs_max_cells: usize,
    /// Model triangles.
    pub total_triangles: u64,
    /// Expected triangles drawn, `E_T`.
    pub expected_triangles: f64,
    /// PVS area fraction.
    pub area_fraction: f64,
    /// `1 − E_T / total_triangles`.
    pub culling_ratio: f64,
    /// Flow steps of the PVS (a machine-independent measure of its work).
    pub pvs_chains: u64,
    /// Sampling check: rays cast (0 when skipped).
    pub rays: u64,
    /// Sampling check: false invisibles (must be 0).
    pub false_invisible: u64,
    /// Sampling check: median overestimation (PVS triangles / sampled).
    pub overestimation_median: Option<f64>,
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
    pub transforms: Vec<crate::experiment::Transform>,
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
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
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
    pub room_cells: Vec<Option<CellId>>,
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
    /// Absolute position tolerance: [`SEPARATION_POSITION_TOLERANCE`](super::SEPARATION_POSITION_TOLERANCE) × the bbox diagonal.
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
    pub cells: [CellId; 2],
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
    pub cells: [Option<CellId>; 2],
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
    pub sample_cells: Vec<Option<CellId>>,
    /// The final cell holding most of its samples (lowest id on ties).
    pub cell: Option<CellId>,
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
    pub ids: Vec<CellId>,
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
    pub portal: Option<[CellId; 2]>,
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
    pub portals: PortalSet,
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
