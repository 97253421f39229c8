//! Invariant checker for [`CellComplex`]. Tests call it after building.

use super::{CellComplex, HULL, PatchId};
use crate::geom::{Classification, ConvexPolygon, ConvexPolyhedron, Cut, Plane};
use crate::ids::CellId;
use crate::model::Model;

/// The first violated invariant of a cell complex.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ComplexError {
    /// A cell's polyhedron is not closed, convex and of positive volume.
    #[error("cell {cell} is not a valid convex polyhedron: {why}")]
    BadCell {
        /// The cell.
        cell: u32,
        /// What the geometry check said.
        why: String,
    },
    /// A cell's face names a patch that does not list the cell, or vice versa.
    #[error("cell {cell} and patch {patch} disagree: {why}")]
    Topology {
        /// The cell.
        cell: u32,
        /// The patch.
        patch: u32,
        /// What is inconsistent.
        why: &'static str,
    },
    /// A patch's area is not accounted for by its occluders and portal pieces.
    #[error("patch {patch}: area {area:.6e} but open {open:.6e} + occluders {occluded:.6e} + slivers {slivers:.6e}")]
    Coverage {
        /// The patch.
        patch: u32,
        /// Its area.
        area: f64,
        /// Uncovered area (portal pieces).
        open: f64,
        /// Sum of occluder areas (may exceed the covered area when they overlap).
        occluded: f64,
        /// Discarded slivers.
        slivers: f64,
    },
    /// A portal pair is listed twice or joins an inactive cell.
    #[error("portal between cells {a} and {b}: {why}")]
    Portal {
        /// One cell.
        a: u32,
        /// The other.
        b: u32,
        /// What is wrong.
        why: &'static str,
    },
    /// The cells do not fill the convex hull.
    #[error("cell volumes sum to {sum:.9e}, the hull's volume is {hull:.9e}")]
    Volume {
        /// Sum of alive cell volumes.
        sum: f64,
        /// Hull volume.
        hull: f64,
    },
    /// A model polygon crosses the interior of a cell (so a portal may cross it, or the
    /// cell itself joins the polygon's two sides through a crack).
    #[error("model polygon {polygon} crosses the interior of cell {cell} (crossing area {area:.3e})")]
    Crossing {
        /// The polygon.
        polygon: u32,
        /// The cell.
        cell: u32,
        /// Area of the polygon inside the cell.
        area: f64,
    },
}

/// What a successful validation counted.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ComplexValidation {
    /// Alive cells checked.
    pub cells: usize,
    /// Alive patches checked.
    pub patches: usize,
    /// Relative difference between the sum of cell volumes and the hull volume.
    pub volume_rel_error: f64,
    /// Largest relative coverage error over patches.
    pub max_coverage_rel_error: f64,
}

impl CellComplex {
    /// The structural part of [`validate`](Self::validate), cheap enough for every build
    /// (linear in the total size of the alive cells; no model needed): every alive cell is
    /// a valid convex polyhedron (flat ones exempt), cells and patches name each other,
    /// and the cell volumes sum to the hull volume. A complex that fails it must not be
    /// used: callers (`run`, `complex`, experiments) should turn the error into a failure.
    ///
    /// Also (one pass over the patches and one hash-set pass over the portals): every
    /// alive patch's cells are alive and hold it, and the portal list is consistent (each
    /// pair once, ordered, between active cells), so `run` never decimates a complex that
    /// `validate` would reject for its topology or its portals.
    pub fn check_valid(&self) -> Result<(), ComplexError> {
        self.check_cells()?;
        self.check_patch_cells()?;
        self.check_portals()
    }

    /// Every alive patch names alive cells (or the hull) that hold it (part of
    /// [`check_valid`](Self::check_valid)).
    pub fn check_patch_cells(&self) -> Result<(), ComplexError> {
        for (pi, p) in self.patches.iter().enumerate() {
            if !p.alive {
                continue;
            }
            for &c in &p.cells {
                if c == HULL {
                    continue;
                }
                let cell = &self.cells[c.idx()];
                if !cell.alive || !cell.poly.tags.contains(&(pi as u32)) {
                    return Err(ComplexError::Topology {
                        cell: c.0,
                        patch: pi as u32,
                        why: "cell does not hold the patch",
                    });
                }
            }
        }
        Ok(())
    }

    /// Each portal pair is listed once, ordered, and joins two active cells (part of
    /// [`check_valid`](Self::check_valid)).
    pub fn check_portals(&self) -> Result<(), ComplexError> {
        let mut seen = std::collections::HashSet::with_capacity(self.portals.len());
        for p in &self.portals {
            let [a, b] = p.cells;
            if !seen.insert((a, b)) {
                return Err(ComplexError::Portal {
                    a: a.0,
                    b: b.0,
                    why: "pair listed twice",
                });
            }
            if a >= b || !self.cells[a.idx()].active() || !self.cells[b.idx()].active() {
                return Err(ComplexError::Portal {
                    a: a.0,
                    b: b.0,
                    why: "unordered pair or inactive cell",
                });
            }
        }
        Ok(())
    }

    fn check_cells(&self) -> Result<(usize, f64), ComplexError> {
        let tol = &self.tol;
        let mut count = 0;
        let mut vol = 0.0;
        // Rounding bound of the volume sum (see `volume_rounding`).
        let mut rounding = 0.0;
        for (i, c) in self.cells.iter().enumerate() {
            if !c.alive {
                continue;
            }
            count += 1;
            // Flat cells are exact, positively oriented tetrahedra (checked by the
            // tetrahedralization's validation) too thin for a floating-point check.
            if !c.flat {
                c.poly
                    .check(tol)
                    .map_err(|why| ComplexError::BadCell { cell: i as u32, why })?;
            }
            vol += c.poly.volume();
            rounding += volume_rounding(&c.poly);
            // Each face is its own patch (the `union` estimator keys boundary faces by patch).
            let mut tags = c.poly.tags.clone();
            tags.sort_unstable();
            if let Some(w) = tags.windows(2).find(|w| w[0] == w[1]) {
                return Err(ComplexError::Topology {
                    cell: i as u32,
                    patch: w[0],
                    why: "two faces of the cell name the same patch",
                });
            }
            for &t in &c.poly.tags {
                let p = &self.patches[t as usize];
                if !p.alive {
                    return Err(ComplexError::Topology {
                        cell: i as u32,
                        patch: t,
                        why: "face names a dead patch",
                    });
                }
                if !p.cells.contains(&CellId(i as u32)) {
                    return Err(ComplexError::Topology {
                        cell: i as u32,
                        patch: t,
                        why: "patch does not list the cell",
                    });
                }
            }
        }
        let rel = (vol - self.hull_volume).abs() / self.hull_volume;
        // Cells fill the hull when the sums agree to 1e-9 relative, or within the rounding
        // of the floating-point volumes themselves (twice: the hull volume is a sum of
        // tetrahedron volumes of the same size). The latter matters for flat models,
        // whose volume is far below their diameter cubed (a hull of 1.85e-10 from points
        // of size ~1 differs by 2e-19 from its cells, 1e-9 relative: pure rounding).
        if (vol - self.hull_volume).abs() > 1e-9 * self.hull_volume + 2.0 * rounding {
            return Err(ComplexError::Volume {
                sum: vol,
                hull: self.hull_volume,
            });
        }
        Ok((count, rel))
    }

    /// Checks every invariant listed in the module docs (the model is needed for the
    /// "no portal crosses a model polygon" check).
    pub fn validate(&self, model: &Model) -> Result<ComplexValidation, ComplexError> {
        let tol = &self.tol;
        let mut v = ComplexValidation::default();
        let (cells, rel) = self.check_cells()?;
        v.cells = cells;
        v.volume_rel_error = rel;
        self.check_patch_cells()?;
        for (pi, p) in self.patches.iter().enumerate() {
            if !p.alive {
                continue;
            }
            v.patches += 1;
            let area = p.polygon.area();
            let (pieces, _, slivers) = self.open_pieces(PatchId(pi as u32));
            let open: f64 = pieces.iter().map(|q| q.area()).sum();
            let occluded: f64 = p.occluders.iter().map(|o| o.polygon.area()).sum();
            // Subtraction may drop strips narrower than the sliver width along any edge, so
            // the unaccounted area is bounded by perimeter x sliver width.
            let per: f64 = {
                let n = p.polygon.verts.len();
                (0..n)
                    .map(|i| {
                        let (a, b) = (p.polygon.verts[i], p.polygon.verts[(i + 1) % n]);
                        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
                    })
                    .sum()
            };
            let slack = 4.0 * tol.area_abs() + per * tol.sliver_width() + 1e-9 * area;
            // Portals never exceed the patch, and occluders cover what is not open.
            let err = if open > area + slack {
                open - area
            } else if open + occluded + slivers < area - slack {
                area - open - occluded - slivers
            } else {
                0.0
            };
            if err > 0.0 {
                return Err(ComplexError::Coverage {
                    patch: pi as u32,
                    area,
                    open,
                    occluded,
                    slivers,
                });
            }
            if area > 0.0 {
                v.max_coverage_rel_error = v
                    .max_coverage_rel_error
                    .max(((open + occluded.min(area - open)) - area).abs() / area);
            }
        }
        self.check_portals()?;
        self.check_no_crossing(model)?;
        Ok(v)
    }

    /// No model polygon (where it was placed: projected onto its support plane) crosses the
    /// interior of an alive cell, neither with a fragment above the area tolerance nor by
    /// covering the cell's whole cross-section up to cracks (`crack_crossing`), whatever
    /// its size. Uses a uniform grid over polygon bounding boxes. The pipeline runs it after
    /// [`check_valid`](Self::check_valid) on every build, so `run` refuses such a complex.
    pub fn check_no_crossing(&self, model: &Model) -> Result<(), ComplexError> {
        let tol = &self.tol;
        let (lo, hi) = model.bbox();
        let n = model.polygons.len().max(1);
        let k = ((n as f64).cbrt().ceil() as usize).clamp(1, 64);
        let size: Vec<f64> = (0..3).map(|a| ((hi[a] - lo[a]) / k as f64).max(1e-300)).collect();
        let cell_of = |p: &[f64; 3], a: usize| (((p[a] - lo[a]) / size[a]).floor().max(0.0) as usize).min(k - 1);
        let mut grid: Vec<Vec<u32>> = vec![Vec::new(); k * k * k];
        // Each polygon where it was placed: projected onto its support plane.
        let planes: Vec<Plane> = (0..model.polygons.len())
            .map(|i| match self.polygon_planes.get(i) {
                Some(pl) => pl.normalized(),
                None => {
                    let v = &model.polygons[i].verts;
                    let p = |k: usize| model.vertices[v[k].idx()];
                    Plane::from_points(&p(0), &p(1), &p(2)).normalized()
                }
            })
            .collect();
        let polys: Vec<ConvexPolygon> = model
            .polygons
            .iter()
            .zip(&planes)
            .map(|(p, pl)| {
                ConvexPolygon::new(
                    p.verts
                        .iter()
                        .map(|v| super::build::project(pl, &model.vertices[v.idx()]))
                        .collect(),
                )
            })
            .collect();
        for (i, p) in polys.iter().enumerate() {
            let (a, b) = bbox(&p.verts);
            for x in cell_of(&a, 0)..=cell_of(&b, 0) {
                for y in cell_of(&a, 1)..=cell_of(&b, 1) {
                    for z in cell_of(&a, 2)..=cell_of(&b, 2) {
                        grid[(x * k + y) * k + z].push(i as u32);
                    }
                }
            }
        }
        let mut stamp = vec![u32::MAX; polys.len()];
        for (ci, c) in self.cells.iter().enumerate() {
            // Flat cells have no interior to cross.
            if !c.alive || c.flat {
                continue;
            }
            let (a, b) = c.poly.aabb();
            // Once per cell, not per candidate polygon.
            let verts = c.poly.vertices();
            let face_planes = c.poly.planes();
            for x in cell_of(&a, 0)..=cell_of(&b, 0) {
                for y in cell_of(&a, 1)..=cell_of(&b, 1) {
                    for z in cell_of(&a, 2)..=cell_of(&b, 2) {
                        for &pi in &grid[(x * k + y) * k + z] {
                            if stamp[pi as usize] == ci as u32 {
                                continue;
                            }
                            stamp[pi as usize] = ci as u32;
                            let poly = &polys[pi as usize];
                            let plane = planes[pi as usize];
                            // Only a cut deeper than the snapping tolerances on both sides is a
                            // crossing: polygons are placed on shared support planes (within
                            // `coplanar`) and slabs thinner than `weld` are never split.
                            let thick = tol.coplanar_abs().max(tol.weld_abs());
                            let ds: Vec<f64> = verts.iter().map(|v| plane.eval(v)).collect();
                            let (front, back) = ds.iter().fold((0.0f64, 0.0f64), |(f, b), &d| (f.max(d), b.max(-d)));
                            if front <= thick
                                || back <= thick
                                || c.poly.classify(&plane, tol) != Classification::Straddles
                            {
                                continue;
                            }
                            let mut cur = Some(poly.clone());
                            for f in &face_planes {
                                cur = cur.and_then(|q| q.split(f, tol).1);
                            }
                            if let Some(q) = cur {
                                // The fragment crosses the interior only if its centroid lies
                                // deeper than the snapping tolerance inside every face plane.
                                let area = q.area();
                                let ctr = q.centroid();
                                let depth = face_planes
                                    .iter()
                                    .map(|f| -f.normalized().eval(&ctr))
                                    .fold(f64::INFINITY, f64::min);
                                // Fragments narrower than the sliver width can only open
                                // cracks that the portal graph discards as slivers.
                                let n = q.verts.len();
                                let per: f64 = (0..n)
                                    .map(|i| {
                                        let (a, b) = (q.verts[i], q.verts[(i + 1) % n]);
                                        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
                                    })
                                    .sum();
                                let wide = 2.0 * area >= tol.sliver_width() * per;
                                if area > 16.0 * tol.area_abs() && depth > thick && wide {
                                    return Err(ComplexError::Crossing {
                                        polygon: pi,
                                        cell: ci as u32,
                                        area,
                                    });
                                }
                            }
                            if let Some(area) = crack_crossing(&c.poly, &plane, poly, tol) {
                                return Err(ComplexError::Crossing {
                                    polygon: pi,
                                    cell: ci as u32,
                                    area,
                                });
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

/// A crossing through a crack: the cell reaches across the polygon's plane (checked by
/// the caller) and the polygon covers at least half of the cell's cross-section, the rest
/// being only cracks, so the cell joins the polygon's two sides however small the section
/// is (a thin wedge passing behind a wall). `build` seals these by splitting; returns the
/// covered area. Sections are taken with the [`Tolerances::sealing`](crate::Tolerances::sealing)
/// thresholds, like the sealing splits.
fn crack_crossing(
    cell: &ConvexPolyhedron,
    plane: &Plane,
    poly: &ConvexPolygon,
    tol: &crate::Tolerances,
) -> Option<f64> {
    // Separated by a face plane: no contact at all.
    let slack = tol.plane_abs() * 4.0 + tol.weld_abs();
    if cell
        .planes()
        .iter()
        .any(|f| poly.verts.iter().all(|v| f.signed_distance(v) > slack))
    {
        return None;
    }
    let relaxed = tol.sealing();
    let Cut::Split(s) = cell.cut(plane, &relaxed, 0) else {
        return None;
    };
    let sa = s.section.area();
    let open = s.section.subtract(std::slice::from_ref(poly), &relaxed).pieces;
    if open.iter().any(|q| !super::graph::is_sliver(q, tol)) {
        return None;
    }
    let covered = sa - open.iter().map(|q| q.area()).sum::<f64>();
    (covered >= 0.5 * sa && covered > 0.0).then_some(covered)
}

/// An upper bound of the rounding error of [`ConvexPolyhedron::volume`]: the volume is a
/// sum over each face's fan triangles of `a · (b × c) / 6` with `a`, `b`, `c` relative to
/// a reference vertex, each at most the cell's bounding-box diagonal `d` long; each term
/// is off by at most ~`4 ε d³`, so the bound is `8 ε d³ / 6` per fan triangle (a factor
/// two of slack).
fn volume_rounding(p: &ConvexPolyhedron) -> f64 {
    let (lo, hi) = p.aabb();
    let d = crate::base::vec::dist(&lo, &hi);
    let triangles: usize = p.faces.iter().map(|f| f.verts.len().saturating_sub(2)).sum();
    8.0 * f64::EPSILON * d * d * d * triangles as f64 / 6.0
}

fn bbox(v: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    crate::model::bbox_of(v.iter())
}
