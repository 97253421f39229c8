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
//!
//! Files: `types.rs` (the report types), `separation.rs` (the full run and the
//! room-separation state), `doorways.rs` (doorway matching), `portals.rs` (portal matching
//! for the rotation check), `geometry.rs` (vector helpers).

mod doorways;
mod geometry;
mod portals;
mod separation;
mod types;

pub use geometry::diagonal;
pub use portals::{map_back, match_portals, portal_summaries, portals_match, rotation_check, separating_summaries};
pub use separation::locate_in_complex;
pub use types::*;

use super::Definition;
use crate::decimate::{Decimation, StopRule};
use crate::generate::thesis::GroundTruth;
use crate::ids::CellId;
use crate::model::Model;
use crate::output::Locator;
use crate::pipeline::Run;
use doorways::match_doorways;
use separation::{full_run_analysis, separation_state};
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

/// Scores of the stopped run against the ground truth; `full` is the full decimation (stop
/// `none`) when the experiment's stop rule is not `none` (run here if not given).
fn truth_eval(p: &mut Run, truth: &GroundTruth, diag: f64, full: Option<&Decimation>) -> TruthEval {
    let doc = &p.doc;
    let loc = Locator::new(doc);
    let active_volume: f64 = doc.cells.iter().map(|c| c.volume).sum::<f64>() + 0.0;
    let mut per_room: Vec<RoomEval> = truth
        .rooms
        .iter()
        .map(|r| {
            let sample_cells: Vec<Option<CellId>> = r.samples.iter().map(|s| loc.locate(s)).collect();
            let mut counts: Vec<(CellId, usize)> = Vec::new();
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
    let held: Vec<CellId> = per_room
        .iter()
        .flat_map(|r| r.sample_cells.iter().flatten().copied())
        .collect();
    let spikes: Vec<&crate::output::CellDoc> = doc.cells.iter().filter(|c| !held.contains(&CellId(c.id))).collect();
    let spike_volume: f64 = spikes.iter().map(|c| c.volume).sum::<f64>() + 0.0; // not -0.0 when empty
    let spike_cells = SpikeCells {
        count: spikes.len(),
        volume: spike_volume,
        volume_fraction: if active_volume > 0.0 {
            spike_volume / active_volume
        } else {
            0.0
        },
        ids: spikes.iter().take(100).map(|c| CellId(c.id)).collect(),
    };
    let (per_doorway, portals_at_doorways) = match_doorways(&truth.doorways, &doc.portals, &per_room, diag);
    // The full decimation, for the weight jump.
    let full_owned;
    let full: &Decimation = if p.dec.settings.stop == StopRule::None {
        &p.dec
    } else if let Some(f) = full {
        f
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
    let located: Vec<Vec<Option<CellId>>> = truth
        .rooms
        .iter()
        .map(|room| locate_in_complex(&p.cx, &room.samples))
        .collect();
    let mut volumes = vec![0.0; p.cx.cells.len()];
    for (id, c) in p.cx.active_cells() {
        volumes[id.idx()] = c.volume();
    }
    let room_names: Vec<String> = truth.rooms.iter().map(|r| r.name.clone()).collect();
    let (weight_jump, room_merges) = full_run_analysis(
        volumes,
        &room_names,
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
        portals_at_doorways,
        per_doorway,
        separation: Some(separation),
    }
}

/// The evaluation of a finished pipeline run (`t0`: when the experiment started; `full`:
/// the full decimation, stop `none`, if the caller ran it already).
pub fn evaluate(
    def: &Definition,
    model: &Model,
    truth: Option<&GroundTruth>,
    p: &mut Run,
    full: Option<&Decimation>,
    t0: Instant,
) -> Evaluation {
    let diag = diagonal(&p.doc.model.bbox);
    let mut truth_eval = truth.map(|t| truth_eval(p, t, diag, full));
    // Evaluated in the model's frame (the truth was moved into it on loading); the
    // separating portals' centroids go out in the input's.
    for sp in truth_eval
        .iter_mut()
        .filter_map(|t| t.separation.as_mut())
        .flat_map(|s| s.portals.iter_mut())
    {
        sp.centroid = model.to_user(sp.centroid);
    }
    let s = &p.cx.stats;
    let doc = &p.doc;
    let (next_weight, stop_reason) = match p.dec.stop {
        crate::decimate::StopReason::Threshold { next_weight, .. } => (Some(next_weight), p.dec.stop.to_string()),
        r => (None, r.to_string()),
    };
    Evaluation {
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
        subdivision_stats: {
            // Machine-dependent figures stay out of evaluation.json (see `Timings`).
            let mut v = p.subdivision_stats.to_json();
            crate::output::strip_timings_json(&mut v);
            v
        },
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
        visibility: None,
    }
}

/// The timing stage of an evaluated experiment's PVS (in `timings.json`, not in
/// `evaluation.json`).
pub const VISIBILITY_PVS_STAGE: &str = "visibility: PVS (base + flow)";

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
    if let Some(v) = &e.visibility {
        s += &format!(
            "; E_T {:.1} of {} triangles (culling {:.3}), false invisibles {}",
            v.expected_triangles, v.total_triangles, v.culling_ratio, v.false_invisible
        );
        if let Some((_, secs)) = e.timings.stages.iter().find(|(n, _)| n == VISIBILITY_PVS_STAGE) {
            s += &format!(", PVS {secs:.2} s");
        }
    }
    s + &format!(" ({:.2} s)", e.timings.total_seconds)
}
