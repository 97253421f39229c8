//! Doorway matching: at the stop (a final portal between the cells holding most of the
//! two rooms' samples, accepted when both rooms are isolated or the portal lies at the
//! doorway) and at the room-separation state (a separating portal between the rooms'
//! cells, and how far it lies from the doorway).

use super::DOORWAY_TOLERANCE;
use super::geometry::{dist, dot, mean, newell_normal, weighted_centroid};
use super::types::{DoorwayEval, RoomEval, SeparatingPortal, SeparationDoorway};
use crate::geom::ConvexPolygon;
use crate::ids::CellId;
use crate::output::PortalDoc;
use crate::thesis_models::Doorway;

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
