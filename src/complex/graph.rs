//! Stages 4–5: portal graph (patch minus occluders) and exterior flood fill.

use super::{CellComplex, HULL, Leak, PatchId, Portal};
use crate::geom::ConvexPolygon;
use crate::ids::CellId;
use std::collections::{HashMap, VecDeque};

fn perimeter(p: &ConvexPolygon) -> f64 {
    let n = p.verts.len();
    (0..n)
        .map(|i| {
            let (a, b) = (p.verts[i], p.verts[(i + 1) % n]);
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        })
        .sum()
}

impl CellComplex {
    /// Uncovered pieces of a patch: its polygon minus all occluders on it (either side).
    /// Returns (pieces, slivers, sliver area).
    /// Pieces below the area tolerance or narrower than [`crate::Tolerances::sliver_width`]
    /// are slivers: dropped and counted.
    pub fn open_pieces(&self, p: PatchId) -> (Vec<ConvexPolygon>, usize, f64) {
        let patch = &self.patches[p.idx()];
        let (pieces, mut slivers, mut sliver_area) = if patch.occluders.is_empty() {
            (vec![patch.polygon.clone()], 0, 0.0)
        } else {
            let holes: Vec<ConvexPolygon> = patch.occluders.iter().map(|o| o.polygon.clone()).collect();
            let s = patch.polygon.subtract(&holes, &self.tol);
            (s.pieces, s.slivers, s.sliver_area)
        };
        let (amin, wmin) = (self.tol.area_abs(), self.tol.sliver_width());
        let mut keep = Vec::with_capacity(pieces.len());
        for q in pieces {
            let a = q.area();
            if a < amin || 2.0 * a < wmin * perimeter(&q) {
                slivers += 1;
                sliver_area += a;
            } else {
                keep.push(q);
            }
        }
        (keep, slivers, sliver_area)
    }

    /// Stage 4: portals between alive cells, grouped per cell pair.
    pub(super) fn build_graph(&mut self) {
        let mut by_pair: HashMap<(CellId, CellId), usize> = HashMap::new();
        let mut portals: Vec<Portal> = Vec::new();
        let (mut slivers, mut sliver_area) = (0usize, 0.0f64);
        for (pi, patch) in self.patches.iter().enumerate() {
            if !patch.alive || patch.cells[1] == HULL {
                continue;
            }
            let (a, b) = (patch.cells[0], patch.cells[1]);
            if !self.cells[a.idx()].alive || !self.cells[b.idx()].alive {
                continue;
            }
            let (pieces, s, sa) = self.open_pieces(PatchId(pi as u32));
            slivers += s;
            sliver_area += sa;
            if pieces.is_empty() {
                continue;
            }
            // Orient from the smaller cell id to the larger.
            let (key, pieces) = if a < b {
                ((a, b), pieces)
            } else {
                ((b, a), pieces.iter().map(|p| p.reversed()).collect())
            };
            let k = *by_pair.entry(key).or_insert_with(|| {
                portals.push(Portal {
                    cells: [key.0, key.1],
                    pieces: Vec::new(),
                    area: 0.0,
                });
                portals.len() - 1
            });
            for p in pieces {
                portals[k].area += p.area();
                portals[k].pieces.push(p);
            }
        }
        self.portals = portals;
        self.stats.slivers_discarded = slivers;
        self.stats.sliver_area = sliver_area;
    }

    /// Portal adjacency: for each cell, (neighbour, portal index).
    pub fn adjacency(&self) -> Vec<Vec<(CellId, usize)>> {
        let mut adj = vec![Vec::new(); self.cells.len()];
        for (k, p) in self.portals.iter().enumerate() {
            adj[p.cells[0].idx()].push((p.cells[1], k));
            adj[p.cells[1].idx()].push((p.cells[0], k));
        }
        adj
    }

    /// Stage 5: remove regions that face no occluder; report leaks.
    pub(super) fn remove_exterior(&mut self) {
        let adj = self.adjacency();
        let n = self.cells.len();
        let mut region = vec![u32::MAX; n];
        let mut regions: Vec<Vec<CellId>> = Vec::new();
        for s in 0..n {
            if !self.cells[s].alive || region[s] != u32::MAX {
                continue;
            }
            let r = regions.len() as u32;
            let mut members = vec![CellId(s as u32)];
            region[s] = r;
            let mut k = 0;
            while k < members.len() {
                let c = members[k];
                k += 1;
                for &(m, _) in &adj[c.idx()] {
                    if region[m.idx()] == u32::MAX {
                        region[m.idx()] = r;
                        members.push(m);
                    }
                }
            }
            regions.push(members);
        }
        // Open hull patches per cell (hull faces not fully covered by occluders).
        let mut hull_open: HashMap<CellId, [f64; 3]> = HashMap::new();
        for (pi, p) in self.patches.iter().enumerate() {
            if p.alive && p.cells[1] == HULL && self.cells[p.cells[0].idx()].alive {
                let (pieces, _, _) = self.open_pieces(PatchId(pi as u32));
                if let Some(q) = pieces.first() {
                    hull_open.entry(p.cells[0]).or_insert_with(|| q.centroid());
                }
            }
        }
        let mut removed = 0;
        let mut leaks = Vec::new();
        for members in &regions {
            let facing = members.iter().any(|&c| self.faces_occluder(c));
            if !facing {
                self.stats.exterior_regions += 1;
                for &c in members {
                    self.cells[c.idx()].exterior = true;
                }
                removed += members.len();
                continue;
            }
            self.stats.interior_regions += 1;
            if members.iter().any(|c| hull_open.contains_key(c)) {
                leaks.push(self.trace_leak(members, &adj, &hull_open));
            }
        }
        self.stats.exterior_cells_removed = removed;
        self.stats.active_cells = self.cells.iter().filter(|c| c.active()).count();
        self.portals
            .retain(|p| !self.cells[p.cells[0].idx()].exterior && !self.cells[p.cells[1].idx()].exterior);
        self.stats.portal_pairs = self.portals.len();
        self.stats.portal_polygons = self.portals.iter().map(|p| p.pieces.len()).sum();
        self.stats.leaks = leaks.len();
        self.leaks = leaks;
    }

    /// Multi-source BFS from the cells with open hull faces; the occluder-facing cell
    /// farthest from the hull starts the reported path.
    fn trace_leak(
        &self,
        members: &[CellId],
        adj: &[Vec<(CellId, usize)>],
        hull_open: &HashMap<CellId, [f64; 3]>,
    ) -> Leak {
        let mut dist: HashMap<CellId, (u32, Option<(CellId, usize)>)> = HashMap::new();
        let mut q = VecDeque::new();
        for &c in members {
            if hull_open.contains_key(&c) {
                dist.insert(c, (0, None));
                q.push_back(c);
            }
        }
        while let Some(c) = q.pop_front() {
            let d = dist[&c].0;
            for &(m, k) in &adj[c.idx()] {
                if let std::collections::hash_map::Entry::Vacant(e) = dist.entry(m) {
                    e.insert((d + 1, Some((c, k))));
                    q.push_back(m);
                }
            }
        }
        let from = members
            .iter()
            .copied()
            .filter(|&c| self.faces_occluder(c))
            .max_by_key(|c| (dist.get(c).map_or(0, |d| d.0), std::cmp::Reverse(c.0)))
            .unwrap_or(members[0]);
        let mut path = vec![from];
        let mut first_portal = None;
        let mut c = from;
        while let Some(&(_, Some((prev, k)))) = dist.get(&c) {
            if first_portal.is_none() {
                first_portal = Some(k);
            }
            path.push(prev);
            c = prev;
        }
        let first_portal_point = match first_portal {
            Some(k) => self.portals[k].pieces.first().map_or([f64::NAN; 3], |p| p.centroid()),
            None => hull_open[&from],
        };
        Leak {
            region_cells: members.len(),
            from_cell: from,
            hull_point: hull_open[&c],
            path,
            first_portal_point,
        }
    }
}
