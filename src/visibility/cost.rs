//! What a PVS costs to render: polygons per cell, triangles and area per PVS, the
//! volume-weighted expected cost of a partition and its culling ratio.
//!
//! A model polygon belongs to the cells it **faces**: those on whose boundary one of its
//! occluders lies with the occluder's front towards the cell ([`crate::complex::Occluder`]'s
//! `faces`). A polygon split across several cells belongs to each. A polygon that faces an
//! inactive cell *openly adjacent* to an active one — a membrane
//! ([`CellComplex::is_membrane`]: a flat or thin cell, never a node, removed by the flood
//! fill), e.g. the wedge between the two triangles of a noisy wall quad — is seen through
//! that membrane from the active cell, so it also belongs to the active cells on the
//! membrane's open faces (an exterior cell is never openly adjacent to an active one:
//! they would be one region). A polygon that faces no active cell this way either
//! (outward faces of the level's shell, unplaced fragments) belongs to none, is
//! never in a PVS and is counted apart (`triangles_in_no_cell`). A PVS's cost counts every
//! polygon once, however many of its cells it faces.

use super::pvs::{Pvs, PvsSettings, PvsStats};
use super::sample::SampleReport;
use super::{BitSet, PortalGraph};
use crate::complex::CellComplex;
use crate::decimate::Partition;
use crate::model::Model;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// The polygons each cell of a portal graph faces.
#[derive(Clone, Debug, PartialEq)]
pub struct CellPolygons {
    /// Per cell: model polygon indices, sorted, distinct.
    pub polygons: Vec<Vec<u32>>,
    /// Per model polygon: triangles (vertices − 2).
    pub triangles: Vec<u32>,
    /// Per model polygon: area.
    pub area: Vec<f64>,
    /// Per model polygon: whether it faces some cell.
    pub in_some_cell: Vec<bool>,
}

impl CellPolygons {
    /// Polygons of the cells of a partition (cell `i` = `partition.cells[i]`).
    pub fn from_partition(model: &Model, cx: &CellComplex, partition: &Partition) -> Self {
        Self::from_index(model, cx, partition.len(), |c| partition.cell_of(c).map(|i| i as u32))
    }

    /// Polygons of the cells of [`PortalGraph::from_complex`] (`index` as it returned).
    pub fn from_complex(model: &Model, cx: &CellComplex, index: &[u32]) -> Self {
        let n = index.iter().filter(|&&i| i != u32::MAX).count();
        Self::from_index(model, cx, n, |c| Some(index[c.idx()]).filter(|&i| i != u32::MAX))
    }

    fn from_index(
        model: &Model,
        cx: &CellComplex,
        cells: usize,
        cell_of: impl Fn(crate::CellId) -> Option<u32>,
    ) -> Self {
        let mut polygons: Vec<Vec<u32>> = vec![Vec::new(); cells];
        // Polygons facing inactive cells, and the active cells openly adjacent to those.
        let mut facing_inactive: std::collections::HashMap<crate::CellId, Vec<u32>> = Default::default();
        for p in cx.patches.iter().filter(|p| p.alive) {
            for o in &p.occluders {
                let c = p.cells[o.faces as usize];
                if c != crate::complex::HULL && !cx.cells[c.idx()].active() {
                    facing_inactive.entry(c).or_default().push(o.source.0);
                }
            }
        }
        if !facing_inactive.is_empty() {
            for (k, p) in cx.patches.iter().enumerate() {
                if !p.alive || p.cells[1] == crate::complex::HULL {
                    continue;
                }
                for s in 0..2 {
                    let (m, n) = (p.cells[s], p.cells[1 - s]);
                    let Some(ps) = facing_inactive.get(&m) else { continue };
                    if !cx.cells[n.idx()].active() {
                        continue;
                    }
                    let Some(i) = cell_of(n) else { continue };
                    if cx.open_pieces(crate::complex::PatchId(k as u32)).0.is_empty() {
                        continue;
                    }
                    polygons[i as usize].extend_from_slice(ps);
                }
            }
        }
        for (c, cell) in cx.active_cells() {
            let Some(i) = cell_of(c) else { continue };
            for &t in cell.tags() {
                let p = &cx.patches[t as usize];
                let side = if p.cells[0] == c { 0 } else { 1 };
                for o in &p.occluders {
                    if o.faces == side {
                        polygons[i as usize].push(o.source.0);
                    }
                }
            }
        }
        let mut in_some_cell = vec![false; model.polygons.len()];
        for ps in &mut polygons {
            ps.sort_unstable();
            ps.dedup();
            for &p in ps.iter() {
                in_some_cell[p as usize] = true;
            }
        }
        let triangles = model
            .polygons
            .iter()
            .map(|p| p.verts.len().saturating_sub(2) as u32)
            .collect();
        let area = (0..model.polygons.len())
            .map(|i| 0.5 * crate::base::vec::norm(&model.polygon_normal(crate::PolygonId(i as u32))))
            .collect();
        CellPolygons {
            polygons,
            triangles,
            area,
            in_some_cell,
        }
    }

    /// Triangles and area of the polygons facing any cell of `set` (each polygon once).
    /// `stamp` is scratch space of one entry per model polygon, all different from `mark`.
    pub fn cost_of(&self, set: &BitSet, stamp: &mut [u32], mark: u32) -> (u64, f64) {
        let (mut t, mut a) = (0u64, 0.0);
        for c in set.iter() {
            for &p in &self.polygons[c] {
                if stamp[p as usize] != mark {
                    stamp[p as usize] = mark;
                    t += self.triangles[p as usize] as u64;
                    a += self.area[p as usize];
                }
            }
        }
        (t, a)
    }
}

/// One cell's figures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellCost {
    /// Volume.
    pub volume: f64,
    /// Cells in its PVS (itself included).
    pub pvs_cells: usize,
    /// Triangles of the polygons it faces.
    pub own_triangles: u64,
    /// Triangles of the polygons facing its PVS.
    pub pvs_triangles: u64,
    /// Their area.
    pub pvs_area: f64,
}

/// The visibility figures of a partition (or of a PRT leaf graph, without the costs).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct VisibilityReport {
    /// Cells.
    pub cells: usize,
    /// Portals (cell pairs).
    pub portals: usize,
    /// Convex portal pieces.
    pub portal_pieces: usize,
    /// Mean PVS size in cells (unweighted).
    pub pvs_mean_cells: f64,
    /// Largest PVS size in cells.
    pub pvs_max_cells: usize,
    /// Model triangles (all polygons fanned).
    pub total_triangles: u64,
    /// Model surface area.
    pub total_area: f64,
    /// Triangles of polygons that face no active cell (never in any PVS).
    pub triangles_in_no_cell: u64,
    /// `E_T = Σ vol(c)·T(PVS(c)) / Σ vol(c)`: expected triangles drawn from a uniformly
    /// random viewpoint.
    pub expected_triangles: f64,
    /// Volume-weighted mean PVS area.
    pub expected_area: f64,
    /// `expected_area / total_area` (tessellation-independent).
    pub area_fraction: f64,
    /// `1 − E_T / total_triangles`.
    pub culling_ratio: f64,
    /// Volume-weighted mean PVS size in cells.
    pub expected_pvs_cells: f64,
    /// PVS counters and timings.
    pub pvs: PvsStats,
    /// Seconds for the PVS (base + flow).
    pub pvs_seconds: f64,
    /// Seconds for the costs.
    pub cost_seconds: f64,
    /// The sampling check, when run.
    pub sampling: Option<SampleReport>,
}

/// Costs of every cell and the report's cost figures.
pub fn evaluate(pvs: &Pvs, polys: &CellPolygons, volumes: &[f64]) -> (VisibilityReport, Vec<CellCost>) {
    let t0 = Instant::now();
    let n = pvs.sets.len();
    let mut stamp = vec![u32::MAX; polys.triangles.len()];
    let mut cells = Vec::with_capacity(n);
    let (mut vol, mut et, mut ea, mut ec) = (0.0, 0.0, 0.0, 0.0);
    for c in 0..n {
        let (t, a) = polys.cost_of(&pvs.sets[c], &mut stamp, c as u32);
        let own = polys.polygons[c]
            .iter()
            .map(|&p| polys.triangles[p as usize] as u64)
            .sum();
        let v = volumes.get(c).copied().unwrap_or(0.0);
        let k = pvs.sets[c].count();
        vol += v;
        et += v * t as f64;
        ea += v * a;
        ec += v * k as f64;
        cells.push(CellCost {
            volume: v,
            pvs_cells: k,
            own_triangles: own,
            pvs_triangles: t,
            pvs_area: a,
        });
    }
    let total_triangles: u64 = polys.triangles.iter().map(|&t| t as u64).sum();
    let total_area: f64 = polys.area.iter().sum();
    let triangles_in_no_cell = polys
        .triangles
        .iter()
        .zip(&polys.in_some_cell)
        .filter(|(_, i)| !**i)
        .map(|(&t, _)| t as u64)
        .sum();
    let w = |x: f64| if vol > 0.0 { x / vol } else { 0.0 };
    let expected_triangles = w(et);
    let expected_area = w(ea);
    let report = VisibilityReport {
        cells: n,
        portals: pvs.stats.portals,
        portal_pieces: pvs.stats.directed_portals / 2 + pvs.stats.degenerate_pieces,
        pvs_mean_cells: pvs.mean_size(),
        pvs_max_cells: pvs.max_size(),
        total_triangles,
        total_area,
        triangles_in_no_cell,
        expected_triangles,
        expected_area,
        area_fraction: if total_area > 0.0 {
            expected_area / total_area
        } else {
            0.0
        },
        culling_ratio: if total_triangles > 0 {
            1.0 - expected_triangles / total_triangles as f64
        } else {
            0.0
        },
        expected_pvs_cells: w(ec),
        pvs: pvs.stats.clone(),
        pvs_seconds: pvs.stats.base_seconds + pvs.stats.flow_seconds,
        cost_seconds: t0.elapsed().as_secs_f64(),
        sampling: None,
    };
    (report, cells)
}

/// Everything about the visibility of one partition.
#[derive(Clone, Debug)]
pub struct PartitionVisibility {
    /// The portal graph (cell `i` = `partition.cells[i]`).
    pub graph: PortalGraph,
    /// The PVS.
    pub pvs: Pvs,
    /// Polygons per cell.
    pub polygons: CellPolygons,
    /// Per-cell figures.
    pub cells: Vec<CellCost>,
    /// The summary.
    pub report: VisibilityReport,
}

impl PartitionVisibility {
    /// Portal graph, PVS and costs of a partition of `cx` (built from `model`).
    pub fn compute(model: &Model, cx: &CellComplex, partition: &Partition, settings: &PvsSettings) -> Self {
        let graph = PortalGraph::from_partition(cx, partition);
        let pvs = super::pvs::compute(&graph, settings);
        let polygons = CellPolygons::from_partition(model, cx, partition);
        let volumes: Vec<f64> = partition.cells.iter().map(|c| c.volume).collect();
        let (report, cells) = evaluate(&pvs, &polygons, &volumes);
        PartitionVisibility {
            graph,
            pvs,
            polygons,
            cells,
            report,
        }
    }
}
