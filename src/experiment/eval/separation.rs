//! The room-separation analysis: the full run followed with a union-find over the
//! complex's cells (weight jump, room merges), and the room-separation state just before
//! the first room-joining collapse (separating portals, doorways at separation).

use super::SEPARATION_POSITION_TOLERANCE;
use super::doorways::{majority, match_separation_doorways};
use super::geometry::weighted_centroid;
use super::types::{RoomMerge, SeparatingPortal, Separation, WeightJump};
use crate::complex::CellComplex;
use crate::decimate::{Partition, Step};
use crate::generate::thesis::GroundTruth;
use crate::ids::CellId;
use crate::predicates::P3;

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
pub fn locate_in_complex(cx: &CellComplex, pts: &[P3]) -> Vec<Option<CellId>> {
    let slack = cx.tol.plane_abs();
    let boxes: Vec<(CellId, P3, P3)> = cx
        .active_cells()
        .map(|(id, c)| {
            let (lo, hi) = c.aabb();
            (id, lo, hi)
        })
        .collect();
    pts.iter()
        .map(|p| {
            boxes
                .iter()
                .filter(|(_, lo, hi)| (0..3).all(|k| p[k] >= lo[k] - slack && p[k] <= hi[k] + slack))
                .find(|(id, _, _)| cx.cells[id.idx()].contains(p, &cx.tol))
                .map(|(id, _, _)| *id)
        })
        .collect()
}

fn difference_nonempty(a: &[usize], b: &[usize]) -> bool {
    a.iter().any(|r| !b.contains(r))
}

/// The weight jump, room merges and spike cells at the jump, from the full run's steps.
///
/// `volumes`: each complex cell's volume (0 for inactive ones); `room_names`: the ground
/// truth's rooms; `located`: each room's samples in the complex's cells; `steps`: the full
/// run; `stop_steps`: how many collapses the stopped run made.
pub fn full_run_analysis(
    volumes: Vec<f64>,
    room_names: &[String],
    located: &[Vec<Option<CellId>>],
    steps: &[Step],
    initial_cells: usize,
    active_volume: f64,
    stop_steps: usize,
) -> (Option<WeightJump>, Vec<RoomMerge>) {
    let n = volumes.len();
    let mut s = Sets {
        parent: (0..n as u32).collect(),
        rooms: vec![Vec::new(); n],
        volume: volumes,
    };
    for (r, cells) in located.iter().enumerate() {
        for &c in cells.iter().flatten() {
            let v = &mut s.rooms[c.idx()];
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
                    let roots: Vec<Option<u32>> = cells.iter().map(|c| c.map(|c| s.find(c.0))).collect();
                    if !roots.is_empty() && roots.iter().all(|r| r.is_some() && *r == roots[0]) {
                        rooms_isolated_before += 1;
                    }
                }
                let before = &steps[..i];
                let names = |v: &[usize]| v.iter().map(|&r| room_names[r].clone()).collect();
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

/// Separating portals and doorways at the room-separation state `partition` (reached after
/// `collapses` collapses of the full run); `located`: each room's samples in the complex's
/// cells.
#[allow(clippy::too_many_arguments)]
pub fn separation_state(
    cx: &CellComplex,
    truth: &GroundTruth,
    located: &[Vec<Option<CellId>>],
    partition: &Partition,
    collapses: usize,
    state: &str,
    active_volume: f64,
    diag: f64,
) -> Separation {
    // Each sample's merged cell (its id), and each merged cell's rooms.
    let sample_cells: Vec<Vec<Option<CellId>>> = located
        .iter()
        .map(|cells| {
            cells
                .iter()
                .map(|c| c.and_then(|c| partition.cell_of(c)).map(|i| partition.cells[i].id))
                .collect()
        })
        .collect();
    let mut rooms_of: Vec<Vec<usize>> = vec![Vec::new(); partition.len()];
    for (r, cells) in located.iter().enumerate() {
        for &c in cells.iter().flatten() {
            if let Some(i) = partition.cell_of(c)
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
    let room_cells: Vec<Option<CellId>> = sample_cells.iter().map(|c| majority(c)).collect();
    let rooms_isolated = sample_cells
        .iter()
        .zip(&room_cells)
        .filter(|(cells, cell)| {
            !cells.is_empty()
                && cells.iter().all(|c| c.is_some() && c == *cell)
                && cell.is_some_and(|id| rooms_of[index_of(id)].len() == 1)
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
                cells: mp.cells,
                rooms: r,
                area: mp.area,
                centroid: weighted_centroid(&mp.pieces),
                normal: mp.mean_normal,
                pieces: mp.pieces.len(),
            })
        })
        .collect();
    let position_tolerance = SEPARATION_POSITION_TOLERANCE * diag;
    let (per_doorway, portals_at_doorways) =
        match_separation_doorways(&truth.doorways, &room_cells, &portals, position_tolerance);
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
        portals_at_doorways,
        per_doorway,
        portals,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step(a: u32, b: u32, weight: f64, cells_remaining: usize) -> Step {
        Step {
            a: CellId(a),
            b: CellId(b),
            weight,
            cells_remaining,
            portal_area: 1.0,
            projected: [1.0, 1.0],
        }
    }

    fn names() -> Vec<String> {
        vec!["west".into(), "east".into()]
    }

    /// Five cells of volume 1: room 0's samples in cells 0 and 1, room 1's in cell 3, cells
    /// 2 and 4 empty (spikes). The run joins 0+1, 3+4, 1+2, then the rooms (0+3).
    fn run() -> (Vec<Vec<Option<CellId>>>, Vec<Step>) {
        let located = vec![vec![Some(CellId(0)), Some(CellId(1))], vec![Some(CellId(3)), None]];
        let steps = vec![
            step(0, 1, 0.5, 4),
            step(3, 4, 1.0, 3),
            step(1, 2, 0.25, 2),
            step(0, 3, 9.0, 1),
        ];
        (located, steps)
    }

    #[test]
    fn weight_jump_at_the_first_collapse_joining_rooms() {
        let (located, steps) = run();
        let (jump, merges) = full_run_analysis(vec![1.0; 5], &names(), &located, &steps, 5, 5.0, 2);
        let j = jump.expect("the last collapse joins the rooms");
        assert_eq!((j.step, j.from_end, j.weight), (4, 1, 9.0));
        assert_eq!((j.max_before, j.last_before, j.ratio), (1.0, 0.25, 9.0));
        assert_eq!(j.cells_before, 2);
        // Room 1 has an unlocated sample, so only room 0 is isolated before the join.
        assert_eq!(j.rooms_isolated_before, 1);
        // Both sets hold samples just before: no spike cell, no spike volume.
        assert_eq!((j.spike_cells_before, j.spike_volume_fraction_before), (0, 0.0));
        assert_eq!(j.rooms, [vec!["west".to_string()], vec!["east".to_string()]]);
        assert!(j.stop_before_jump, "the stopped run (2 collapses) ends before step 4");
        assert_eq!(merges.len(), 1);
        assert_eq!(merges[0].rooms, [vec![0], vec![1]]);
        // A stopped run of all four collapses went past the jump.
        let (jump, _) = full_run_analysis(vec![1.0; 5], &names(), &located, &steps, 5, 5.0, 4);
        assert!(!jump.unwrap().stop_before_jump);
    }

    #[test]
    fn no_jump_when_no_collapse_joins_rooms_and_spikes_counted_before_it() {
        let (located, steps) = run();
        let (jump, merges) = full_run_analysis(vec![1.0; 5], &names(), &located, &steps[..3], 5, 5.0, 3);
        assert!(jump.is_none() && merges.is_empty());
        // Stop before the third collapse: cell 2 is still a spike when the rooms meet.
        let steps = vec![
            step(0, 1, 0.5, 4),
            step(3, 4, 1.0, 3),
            step(0, 3, 2.0, 2),
            step(1, 2, 0.25, 1),
        ];
        let (jump, _) = full_run_analysis(vec![1.0; 5], &names(), &located, &steps, 5, 5.0, 2);
        let j = jump.unwrap();
        assert_eq!((j.step, j.cells_before, j.spike_cells_before), (3, 3, 1));
        assert!((j.spike_volume_fraction_before - 0.2).abs() < 1e-12);
        assert!(j.stop_before_jump);
    }
}
