//! Doorway matching: at the stop (a final portal between the cells holding most of the
//! two rooms' samples, accepted when both rooms are isolated or the portal lies at the
//! doorway) and at the room-separation state (a separating portal between the rooms'
//! cells, and how far it lies from the doorway).

use super::DOORWAY_TOLERANCE;
use super::geometry::{dist, dot, mean, newell_normal, weighted_centroid};
use super::types::{DoorwayEval, RoomEval, SeparatingPortal, SeparationDoorway};
use crate::generate::thesis::Doorway;
use crate::geom::ConvexPolygon;
use crate::ids::CellId;
use crate::output::PortalDoc;

/// The cell holding most of `cells` (lowest id on ties).
pub fn majority(cells: &[Option<CellId>]) -> Option<CellId> {
    let mut counts: Vec<(CellId, usize)> = Vec::new();
    for c in cells.iter().flatten() {
        match counts.iter_mut().find(|(id, _)| id == c) {
            Some(e) => e.1 += 1,
            None => counts.push((*c, 1)),
        }
    }
    counts.sort_by_key(|&(id, n)| (std::cmp::Reverse(n), id));
    counts.first().map(|e| e.0)
}

/// Each doorway matched against the final portals (`portals`, of the result document) at
/// the stop, given the rooms' evaluation (`per_room`: their majority cells and whether they
/// are isolated) and the model's bounding-box diagonal `diag`. Also returns how many
/// distinct portals matched a doorway.
pub fn match_doorways(
    doorways: &[Doorway],
    portals: &[PortalDoc],
    per_room: &[RoomEval],
    diag: f64,
) -> (Vec<DoorwayEval>, usize) {
    let mut per_doorway = Vec::new();
    let mut used_portals: Vec<[CellId; 2]> = Vec::new();
    for d in doorways {
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
            if let Some(pd) = portals.iter().find(|q| q.cells == key.map(|c| c.0)) {
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
    let used = used_portals.len();
    (per_doorway, used)
}

/// Each doorway matched against the separating portals at the room-separation state:
/// `room_cells` are the rooms' majority cells there; a doorway is matched by position when
/// the portal's centroid lies within `position_tolerance` of the doorway's centre. Also
/// returns how many distinct portals matched a doorway.
pub fn match_separation_doorways(
    doorways: &[Doorway],
    room_cells: &[Option<CellId>],
    portals: &[SeparatingPortal],
    position_tolerance: f64,
) -> (Vec<SeparationDoorway>, usize) {
    let mut used: Vec<usize> = Vec::new();
    let per_doorway: Vec<SeparationDoorway> = doorways
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
    (per_doorway, used.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1 m × 2 m doorway in the plane x = 4 between rooms 0 and 1; centre (4, 1.5, 1).
    fn door() -> Doorway {
        Doorway {
            rooms: [0, 1],
            polygon: vec![[4.0, 1.0, 0.0], [4.0, 2.0, 0.0], [4.0, 2.0, 2.0], [4.0, 1.0, 2.0]],
        }
    }

    fn room(cell: u32, isolated: bool) -> RoomEval {
        RoomEval {
            name: format!("room in cell {cell}"),
            sample_cells: vec![Some(CellId(cell)); 3],
            cell: Some(CellId(cell)),
            isolated,
        }
    }

    /// A final portal between `cells`, a 1 × 2 rectangle in the plane x = `x`.
    fn portal(cells: [u32; 2], x: f64) -> PortalDoc {
        PortalDoc {
            cells,
            area: 2.0,
            mean_normal: [1.0, 0.0, 0.0],
            polygons: vec![vec![[x, 1.0, 0.0], [x, 2.0, 0.0], [x, 2.0, 2.0], [x, 1.0, 2.0]]],
        }
    }

    #[test]
    fn doorway_at_the_stop_matched_by_isolated_rooms_or_by_position() {
        let d = [door()];
        // Both rooms isolated: any portal between their cells matches, wherever it is.
        let (e, used) = match_doorways(&d, &[portal([2, 5], 9.0)], &[room(5, true), room(2, true)], 10.0);
        assert!(e[0].matched && e[0].by == "isolated rooms", "{e:?}");
        assert_eq!(e[0].portal, Some([CellId(2), CellId(5)]));
        assert!((e[0].distance.unwrap() - 5.0).abs() < 1e-12);
        assert_eq!(used, 1);
        // Not isolated: only a portal at the doorway (within the doorway's radius) matches.
        let rooms = [room(5, false), room(2, true)];
        let (e, _) = match_doorways(&d, &[portal([2, 5], 4.0)], &rooms, 10.0);
        assert!(e[0].matched && e[0].by == "position", "{e:?}");
        let (e, used) = match_doorways(&d, &[portal([2, 5], 9.0)], &rooms, 10.0);
        assert!(!e[0].matched && e[0].by == "none" && e[0].portal.is_some(), "{e:?}");
        assert_eq!(used, 0);
        // The tolerance is the larger of 2% of the diagonal and the doorway's radius.
        assert!((e[0].tolerance - 1.25f64.sqrt()).abs() < 1e-12);
        // No portal between the rooms' cells, or both rooms in one cell: unmatched.
        let (e, _) = match_doorways(&d, &[portal([2, 7], 4.0)], &rooms, 10.0);
        assert!(!e[0].matched && e[0].portal.is_none());
        let (e, _) = match_doorways(&d, &[portal([2, 5], 4.0)], &[room(5, false), room(5, false)], 10.0);
        assert!(!e[0].matched && e[0].portal.is_none());
    }

    #[test]
    fn majority_cell_with_lowest_id_on_ties() {
        let c = |i| Some(CellId(i));
        assert_eq!(majority(&[c(3), c(1), c(3), None]), c(3));
        assert_eq!(majority(&[c(4), c(2), None]), c(2));
        assert_eq!(majority(&[None, None]), None);
    }

    fn separating(cells: [u32; 2], centroid: [f64; 3], normal: [f64; 3]) -> SeparatingPortal {
        SeparatingPortal {
            cells: cells.map(CellId),
            rooms: [vec![0], vec![1]],
            area: 2.0,
            centroid,
            normal,
            pieces: 1,
        }
    }

    #[test]
    fn doorway_at_separation_distances_along_the_plane_and_axis() {
        let d = [door()];
        let cells = [Some(CellId(7)), Some(CellId(3))];
        // 0.3 off the doorway's plane, 0.4 along it: 0.5 from the centre.
        let s = [
            separating([1, 2], [0.0; 3], [1.0, 0.0, 0.0]),
            separating([3, 7], [4.3, 1.9, 1.0], [1.0, 0.0, 0.0]),
        ];
        let (e, used) = match_separation_doorways(&d, &cells, &s, 0.6);
        let e = &e[0];
        assert!(e.matched && e.matched_by_position);
        assert_eq!(e.portal, Some(1));
        assert_eq!(e.cells, cells);
        assert!((e.distance.unwrap() - 0.5).abs() < 1e-12);
        assert!((e.plane_distance.unwrap() - 0.3).abs() < 1e-12);
        assert!((e.axis_distance.unwrap() - 0.4).abs() < 1e-12);
        assert!(e.tilt_deg.unwrap().abs() < 1e-6);
        assert_eq!(used, 1);
        // A tighter tolerance: matched by the cells, not by position.
        let (e, _) = match_separation_doorways(&d, &cells, &s, 0.4);
        assert!(e[0].matched && !e[0].matched_by_position);
        // A portal tilted by 60°.
        let tilted = [separating([3, 7], [4.0, 1.5, 1.0], [0.5, 0.75f64.sqrt(), 0.0])];
        let (e, _) = match_separation_doorways(&d, &cells, &tilted, 0.4);
        assert!((e[0].tilt_deg.unwrap() - 60.0).abs() < 1e-9);
        // A room without a cell, or no portal between the rooms' cells: unmatched.
        let (e, used) = match_separation_doorways(&d, &[Some(CellId(7)), None], &s, 1.0);
        assert!(!e[0].matched && e[0].portal.is_none() && used == 0);
        let (e, _) = match_separation_doorways(&d, &[Some(CellId(7)), Some(CellId(1))], &s, 1.0);
        assert!(!e[0].matched);
    }
}
