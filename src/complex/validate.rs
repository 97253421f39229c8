//! Invariant checker for [`CellComplex`]. Tests call it after building.

use super::{CellComplex, HULL, PatchId, Portal};
use crate::base::hash::FxBuild;
use crate::geom::{Classification, ConvexPolygon, ConvexPolyhedron, Cut, Plane};
use crate::ids::CellId;
use crate::model::Model;
use rayon::prelude::*;
use std::collections::HashMap;

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
        // On every core; `find_map_first` returns the violation of the smallest patch id,
        // as the sequential loop did.
        let first = (0..self.patches.len())
            .into_par_iter()
            .with_min_len(1024)
            .find_map_first(|pi| {
                let p = &self.patches[pi];
                if !p.alive {
                    return None;
                }
                p.cells.iter().find_map(|&c| {
                    if c == HULL {
                        return None;
                    }
                    let cell = &self.cells[c.idx()];
                    (!cell.alive || !cell.tags().contains(&(pi as u32))).then_some(ComplexError::Topology {
                        cell: c.0,
                        patch: pi as u32,
                        why: "cell does not hold the patch",
                    })
                })
            });
        first.map_or(Ok(()), Err)
    }

    /// Each portal pair is listed once, ordered, and joins two active cells (part of
    /// [`check_valid`](Self::check_valid)).
    pub fn check_portals(&self) -> Result<(), ComplexError> {
        // Which portals repeat an earlier pair: the portals grouped by their first cell
        // (a counting sort, in list order within a group), each group's few second cells
        // compared (a set of all pairs was a third of the check at a million triangles).
        let n = self.cells.len();
        let first = |p: &Portal| p.cells[0].idx().min(n);
        let mut start = vec![0u32; n + 2];
        for p in &self.portals {
            start[first(p) + 1] += 1;
        }
        for i in 0..=n {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut group = vec![0u32; self.portals.len()];
        for (k, p) in self.portals.iter().enumerate() {
            let a = first(p);
            group[fill[a] as usize] = k as u32;
            fill[a] += 1;
        }
        let mut repeat = vec![false; self.portals.len()];
        for w in start.windows(2) {
            let g = &group[w[0] as usize..w[1] as usize];
            for (j, &k) in g.iter().enumerate() {
                let b = self.portals[k as usize].cells;
                repeat[k as usize] = g[..j].iter().any(|&e| self.portals[e as usize].cells == b);
            }
        }
        for (k, p) in self.portals.iter().enumerate() {
            let [a, b] = p.cells;
            if repeat[k] {
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

    /// The per-cell part of [`check_cells`](Self::check_cells) for alive cell `i`: the
    /// first violation in the order of the sequential checks (geometry, duplicate tags,
    /// dead patch, patch not listing the cell).
    fn check_cell(&self, i: usize) -> Option<ComplexError> {
        let c = &self.cells[i];
        // Flat cells are exact, positively oriented tetrahedra (checked by the
        // tetrahedralization's validation) too thin for a floating-point check.
        if !c.flat
            && let Err(why) = c.check(&self.tol)
        {
            return Some(ComplexError::BadCell { cell: i as u32, why });
        }
        // Each face is its own patch (the `union` estimator keys boundary faces by patch).
        // The smallest repeated tag, as a sort would find it, without allocating.
        let tags = c.tags();
        let dup = tags
            .iter()
            .enumerate()
            .filter(|&(k, t)| tags[..k].contains(t))
            .map(|(_, &t)| t)
            .min();
        if let Some(t) = dup {
            return Some(ComplexError::Topology {
                cell: i as u32,
                patch: t,
                why: "two faces of the cell name the same patch",
            });
        }
        for &t in tags {
            let p = &self.patches[t as usize];
            if !p.alive {
                return Some(ComplexError::Topology {
                    cell: i as u32,
                    patch: t,
                    why: "face names a dead patch",
                });
            }
            if !p.cells.contains(&CellId(i as u32)) {
                return Some(ComplexError::Topology {
                    cell: i as u32,
                    patch: t,
                    why: "patch does not list the cell",
                });
            }
        }
        // An implicit tetrahedron's faces are its patches' polygons, outward, vertex for
        // vertex (a patch that was subdivided must have made the cell explicit).
        if let Some(shape) = c.tet_shape() {
            for (k, &t) in shape.tags.iter().enumerate() {
                let p = &self.patches[t as usize];
                let face = ConvexPolygon::from_slice(&shape.face(k));
                let own = if p.cells[0] == CellId(i as u32) {
                    p.polygon.clone()
                } else {
                    p.polygon.reversed()
                };
                if face != own {
                    return Some(ComplexError::Topology {
                        cell: i as u32,
                        patch: t,
                        why: "an implicit tetrahedron's face is not its patch's polygon",
                    });
                }
            }
        }
        None
    }

    fn check_cells(&self) -> Result<(usize, f64), ComplexError> {
        // The per-cell checks on every core; `find_map_first` returns the violation of the
        // smallest cell id, as the sequential loop did, whatever the thread count.
        let first = (0..self.cells.len())
            .into_par_iter()
            .with_min_len(256)
            .filter(|&i| self.cells[i].alive)
            .find_map_first(|i| self.check_cell(i));
        if let Some(e) = first {
            return Err(e);
        }
        // The volume sum in cell order (cheap next to the checks), so its bits do not
        // depend on the thread count either.
        let mut count = 0;
        let mut vol = 0.0;
        // Rounding bound of the volume sum (see `volume_rounding`).
        let mut rounding = 0.0;
        // Each cell's terms on every core, a block at a time, added in cell order.
        const BLOCK: usize = 1 << 16;
        for start in (0..self.cells.len()).step_by(BLOCK) {
            let terms: Vec<(f64, f64)> = (start..(start + BLOCK).min(self.cells.len()))
                .into_par_iter()
                .with_min_len(256)
                .filter(|&i| self.cells[i].alive)
                .map(|i| {
                    let cell = &self.cells[i];
                    // An implicit tetrahedron: four triangles, nothing built (its box is
                    // its polyhedron's, `implicit_tetrahedra_read_as_their_polyhedra_...`).
                    if cell.tet_shape().is_some() {
                        return (self.cell_volume(CellId(i as u32)), rounding_of(cell.aabb(), 4));
                    }
                    let poly = cell.poly();
                    // Cells with a face of four or more vertices (possibly non-planar)
                    // count the volume their neighbours agree on (`tiling_volume`); a
                    // cell of triangles has one volume whatever the fans.
                    let v = if poly.faces.iter().any(|f| f.verts.len() > 3) {
                        poly.tiling_volume()
                    } else {
                        self.cell_volume(CellId(i as u32))
                    };
                    (v, volume_rounding(&poly))
                })
                .collect();
            for (v, r) in terms {
                count += 1;
                vol += v;
                rounding += r;
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
    /// its size. The pipeline runs it after [`check_valid`](Self::check_valid) on every
    /// build, so `run` refuses such a complex.
    ///
    /// An implicit tetrahedron (an uncut tetrahedron of the tetrahedralization) is tested
    /// only against the polygons placed by geometry: a polygon attached because its fan
    /// triangles are faces of that tetrahedralization ([`CellComplex`]'s `conforming`)
    /// meets no tetrahedron's interior, which the tetrahedralization's own exact
    /// validation guarantees; on a conforming building that is most pairs (1M triangles:
    /// 2.1 -> 0.4 s). `model` must be the model the complex was built from (polygons
    /// appended after its own are tested against every cell).
    ///
    /// Candidates come from a uniform grid over the polygons' bounding boxes
    /// ([`PolygonGrid`]), or for a cell with many of them from a tree over the same boxes
    /// ([`BoxTree`]) culled by the cell's face planes; cells are checked in parallel (rayon) and the error is the one of
    /// the smallest cell id, and for that cell of the smallest polygon id, whatever the
    /// thread count.
    pub fn check_no_crossing(&self, model: &Model) -> Result<(), ComplexError> {
        let tol = &self.tol;
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
            .enumerate()
            .map(|(i, (p, pl))| {
                // The corners only, like the splitting (`Model::is_corner`).
                ConvexPolygon::new(
                    p.verts
                        .iter()
                        .enumerate()
                        .filter(|&(k, _)| model.is_corner(i, k))
                        .map(|(_, v)| super::build::project(pl, &model.vertices[v.idx()]))
                        .collect(),
                )
            })
            .collect();
        let boxes: Vec<([f64; 3], [f64; 3])> = polys.iter().map(|p| bbox(&p.verts)).collect();
        let grid = PolygonGrid::new(&boxes);
        // Built by the first cell with more than `FEW` candidates (none on many models).
        let tree: std::sync::OnceLock<BoxTree> = std::sync::OnceLock::new();
        // Only a cut deeper than the snapping tolerances on both sides is a crossing:
        // polygons are placed on shared support planes (within `coplanar`) and slabs
        // thinner than `weld` are never split.
        let thick = tol.coplanar_abs().max(tol.weld_abs());
        // How far outside a cell's bounding box a polygon's box may lie and still meet the
        // cell in either test below. Both report only a polygon that meets the cell: the
        // fragment test a fragment whose centroid lies deeper than `thick` inside every
        // face plane (so inside the cell and its box) and, being a convex combination of
        // points of the polygon, inside the polygon's box up to rounding; the crack test
        // a polygon that covers part of the cell's section (subtraction decides overlap
        // within the plane tolerance; contacts within `slack` of a face plane count). A
        // polygon whose box is farther than this from the cell's box on some axis
        // therefore fires neither, and is skipped before any geometry. (Such a polygon
        // could fire the crack test only through a section below the sealing area
        // tolerance, which the subtraction drops whatever the polygon: a false report.)
        let reach = thick + 4.0 * tol.plane_abs() + tol.weld_abs();
        // The plane test (`front`, `back` beyond `thick`) implies `Straddles` for the
        // polyhedron's own classification whenever `thick` exceeds the plane tolerance
        // by the rounding of a normalized plane's length (a factor 2 is ample); the
        // classification is kept for tolerances where it does not.
        let classify = thick <= 2.0 * tol.plane_abs();
        // The plane tests of one cell: a list, and past `LINEAR` entries also an index by
        // the plane's bits (a cell spanning a room meets thousands of distinct wall planes,
        // and a linear search per candidate made the check quadratic in them). Equal
        // planes (`==`) give the same test whichever finds them: the test is a function of
        // the plane's value, and planes equal but for the sign of a zero evaluate alike.
        const LINEAR: usize = 32;
        type Tested = (Vec<(Plane, bool)>, HashMap<[u64; 4], bool, FxBuild>);
        let key = |p: &Plane| [p.n[0].to_bits(), p.n[1].to_bits(), p.n[2].to_bits(), p.d.to_bits()];
        // Polygons attached as tetrahedron faces (`CellComplex::conforming`) are not tested
        // against implicit tetrahedra (see above). The others, and a grid of theirs for
        // implicit tetrahedra when some polygons are left out:
        let conforming = |pi: u32| self.conforming.get(pi as usize) == Some(&true);
        let placed: Vec<u32> = (0..model.polygons.len() as u32).filter(|&pi| !conforming(pi)).collect();
        let any_placed = !placed.is_empty();
        let placed_grid = (placed.len() < boxes.len()).then(|| {
            let b: Vec<([f64; 3], [f64; 3])> = placed.iter().map(|&pi| boxes[pi as usize]).collect();
            PolygonGrid::new(&b)
        });
        let cell_check = |(cand, (tested, index)): &mut (Vec<u32>, Tested), ci: usize| -> Option<ComplexError> {
            let c = &self.cells[ci];
            // Flat cells have no interior to cross.
            if !c.alive || c.flat {
                return None;
            }
            let tet = c.tet_shape().is_some();
            if tet && !any_placed {
                return None;
            }
            let (a, b) = c.aabb();
            let (lo, hi) = (a.map(|x| x - reach), b.map(|x| x + reach));
            cand.clear();
            // The cell's face planes, outward and normalized: a box farther than `cull`
            // (plus the rounding of evaluating a plane at its corner) in front of one of
            // them holds no point within `reach` of the cell, so no polygon inside it can
            // fire either test (the argument for `reach` above, per face plane instead of
            // per axis). A cell meeting few boxes is not worth its planes (most are small
            // tetrahedra): the grid gathers up to `FEW` candidates and stops past them; then
            // the gathering restarts in the box tree with culling: tree nodes beyond a face
            // plane are not walked, which keeps a long cell from visiting every polygon of
            // its bounding box. (`FEW` = 128: on 40×40 rooms 129k of 2.3M cells have more
            // than 32 candidates and the culled path cost them more than it saved, +0.4 s
            // at 1M; at 128 the check takes the grid-only time within 3%, and the star-cap
            // prism keeps its gain.)
            const FEW: usize = 128;
            let in_box = |pi: u32| {
                let (pa, pb) = &boxes[pi as usize];
                (0..3).all(|k| pa[k] <= hi[k] && pb[k] >= lo[k]) && !(tet && conforming(pi))
            };
            let mut gather = |pi: u32| {
                if in_box(pi) && !cand.contains(&pi) {
                    cand.push(pi);
                }
                cand.len() <= FEW
            };
            let all = match (&placed_grid, tet) {
                (Some(g), true) => g.visit_while(&lo, &hi, |j| gather(placed[j as usize])),
                _ => grid.visit_while(&lo, &hi, gather),
            };
            if !all {
                let tree = tree.get_or_init(|| BoxTree::new(&boxes));
                cand.clear();
                let outward: Vec<Plane> = c.poly().planes().iter().map(|f| f.normalized()).collect();
                let cull = 2.0 * reach;
                let beyond = |f: &Plane, p: &[f64; 3]| {
                    let (mut m, mut mag) = (-f.d, f.d.abs());
                    for k in 0..3 {
                        let t = f.n[k] * p[k];
                        m += t;
                        mag += t.abs();
                    }
                    m > cull + 8.0 * f64::EPSILON * mag
                };
                let far = |a: &[f64; 3], b: &[f64; 3]| {
                    outward.iter().any(|f| {
                        let corner: [f64; 3] = std::array::from_fn(|k| if f.n[k] >= 0.0 { a[k] } else { b[k] });
                        beyond(f, &corner)
                    })
                };
                tree.visit(&lo, &hi, &far, |pi| {
                    if in_box(pi)
                        && !outward
                            .iter()
                            .any(|f| polys[pi as usize].verts.iter().all(|v| beyond(f, v)))
                    {
                        cand.push(pi);
                    }
                });
            }
            if cand.is_empty() {
                return None;
            }
            // Ascending polygon order: the first crossing reported per cell does not
            // depend on the tree.
            cand.sort_unstable();
            // Once per cell, not per candidate polygon.
            let verts = c.vertices();
            let mut face_planes: Option<Vec<Plane>> = None;
            // The plane test per distinct plane (polygons on one support plane share it).
            tested.clear();
            index.clear();
            for &pi in cand.iter() {
                let poly = &polys[pi as usize];
                let plane = planes[pi as usize];
                let known = if tested.len() <= LINEAR {
                    tested.iter().find(|(p, _)| *p == plane).map(|&(_, d)| d)
                } else {
                    index.get(&key(&plane)).copied()
                };
                let deep = match known {
                    Some(deep) => deep,
                    None => {
                        let (mut front, mut back) = (0.0f64, 0.0f64);
                        for v in &verts {
                            let d = plane.eval(v);
                            front = front.max(d);
                            back = back.max(-d);
                        }
                        let deep = front > thick
                            && back > thick
                            && !(classify && c.poly().classify(&plane, tol) != Classification::Straddles);
                        tested.push((plane, deep));
                        if tested.len() > LINEAR {
                            if index.is_empty() {
                                index.extend(tested.iter().map(|(p, d)| (key(p), *d)));
                            } else {
                                index.insert(key(&plane), deep);
                            }
                        }
                        deep
                    }
                };
                if !deep {
                    continue;
                }
                let face_planes = face_planes.get_or_insert_with(|| c.poly().planes());
                let mut cur = Some(poly.clone());
                for f in face_planes.iter() {
                    cur = cur.and_then(|q| q.split(f, tol).1);
                }
                if let Some(q) = cur {
                    // The fragment crosses the interior only if its centroid lies deeper
                    // than the snapping tolerance inside every face plane.
                    let area = q.area();
                    let ctr = q.centroid();
                    let depth = face_planes
                        .iter()
                        .map(|f| -f.normalized().eval(&ctr))
                        .fold(f64::INFINITY, f64::min);
                    // Fragments narrower than the sliver width can only open cracks that
                    // the portal graph discards as slivers.
                    let n = q.verts.len();
                    let per: f64 = (0..n)
                        .map(|i| {
                            let (a, b) = (q.verts[i], q.verts[(i + 1) % n]);
                            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
                        })
                        .sum();
                    let wide = 2.0 * area >= tol.sliver_width() * per;
                    if area > 16.0 * tol.area_abs() && depth > thick && wide {
                        return Some(ComplexError::Crossing {
                            polygon: pi,
                            cell: ci as u32,
                            area,
                        });
                    }
                }
                if let Some(area) = crack_crossing(&c.poly(), &plane, poly, tol) {
                    return Some(ComplexError::Crossing {
                        polygon: pi,
                        cell: ci as u32,
                        area,
                    });
                }
            }
            None
        };
        let first = (0..self.cells.len())
            .into_par_iter()
            .with_min_len(256)
            .map_init(Default::default, cell_check)
            .find_map_first(|e| e);
        match first {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

/// A uniform grid of cubic buckets over axis-aligned boxes, in compressed rows (one
/// offset per bucket, no `Vec` per bucket): about one bucket per box, dimensions in
/// proportion to the boxes' extent (a flat building gets a flat grid), at most
/// [`PolygonGrid::MAX_DIM`] per axis.
struct PolygonGrid {
    lo: [f64; 3],
    size: [f64; 3],
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl PolygonGrid {
    const MAX_DIM: usize = 1024;

    fn new(boxes: &[([f64; 3], [f64; 3])]) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for (a, b) in boxes {
            for k in 0..3 {
                lo[k] = lo[k].min(a[k]);
                hi[k] = hi[k].max(b[k]);
            }
        }
        if boxes.is_empty() || !(0..3).all(|k| lo[k].is_finite() && hi[k].is_finite()) {
            lo = [0.0; 3];
            hi = [0.0; 3];
        }
        let ext: [f64; 3] = std::array::from_fn(|k| hi[k] - lo[k]);
        let emax = ext.iter().fold(0.0f64, |m, &e| m.max(e));
        let target = boxes.len().max(1) as f64;
        // Bucket side: the cube root of the (floored) volume per box.
        let e: [f64; 3] = ext.map(|x| x.max(emax / Self::MAX_DIM as f64));
        let h = (e[0] * e[1] * e[2] / target).cbrt();
        let dims: [usize; 3] = std::array::from_fn(|k| {
            if h > 0.0 && h.is_finite() {
                ((ext[k] / h).ceil() as usize).clamp(1, Self::MAX_DIM)
            } else {
                1
            }
        });
        let size: [f64; 3] = std::array::from_fn(|k| (ext[k] / dims[k] as f64).max(1e-300));
        let mut g = PolygonGrid {
            lo,
            size,
            dims,
            start: Vec::new(),
            items: Vec::new(),
        };
        let n = dims[0] * dims[1] * dims[2];
        let mut count = vec![0u32; n + 1];
        for (a, b) in boxes {
            g.buckets(a, b, |q| count[q] += 1);
        }
        let mut acc = 0u32;
        for c in count.iter_mut() {
            let k = *c;
            *c = acc;
            acc += k;
        }
        let mut items = vec![0u32; acc as usize];
        let mut next = count.clone();
        for (i, (a, b)) in boxes.iter().enumerate() {
            g.buckets(a, b, |q| {
                items[next[q] as usize] = i as u32;
                next[q] += 1;
            });
        }
        g.start = count;
        g.items = items;
        g
    }

    fn bucket_of(&self, p: &[f64; 3], k: usize) -> usize {
        (((p[k] - self.lo[k]) / self.size[k]).floor().max(0.0) as usize).min(self.dims[k] - 1)
    }

    /// Calls `f` with every bucket index meeting the box `[a, b]`.
    fn buckets(&self, a: &[f64; 3], b: &[f64; 3], mut f: impl FnMut(usize)) {
        let [_, ny, nz] = self.dims;
        for x in self.bucket_of(a, 0)..=self.bucket_of(b, 0) {
            for y in self.bucket_of(a, 1)..=self.bucket_of(b, 1) {
                for z in self.bucket_of(a, 2)..=self.bucket_of(b, 2) {
                    f((x * ny + y) * nz + z);
                }
            }
        }
    }

    /// Calls `f` with every item in a bucket meeting the box `[a, b]` (an item once per
    /// bucket, so possibly several times) until `f` returns `false`; returns whether it
    /// went through all of them.
    fn visit_while(&self, a: &[f64; 3], b: &[f64; 3], mut f: impl FnMut(u32) -> bool) -> bool {
        let [_, ny, nz] = self.dims;
        for x in self.bucket_of(a, 0)..=self.bucket_of(b, 0) {
            for y in self.bucket_of(a, 1)..=self.bucket_of(b, 1) {
                for z in self.bucket_of(a, 2)..=self.bucket_of(b, 2) {
                    let q = (x * ny + y) * nz + z;
                    for &i in &self.items[self.start[q] as usize..self.start[q + 1] as usize] {
                        if !f(i) {
                            return false;
                        }
                    }
                }
            }
        }
        true
    }
}

/// A bounding-volume tree over axis-aligned boxes (median splits on the widest axis of
/// the boxes' centres, leaves of at most [`BoxTree::LEAF`] items), queried by a box and a
/// culling predicate on node boxes, for the cells with many candidates. It adapts to
/// where the boxes are: the uniform grid put hundreds of thin wall boxes in each bucket at
/// the rim of a round room, and every long cell ending there walked them all (the
/// star-cap prism of `bench degenerate` was quadratic); here a node is skipped as soon as
/// its box lies beyond one of the cell's face planes.
struct BoxTree {
    nodes: Vec<BoxNode>,
    /// Item indices; a leaf holds a contiguous range.
    items: Vec<u32>,
}

/// A node: its box, and either a leaf's item range (`count > 0`) or, for an inner node,
/// its children (the left one follows it, the right one is `right`).
struct BoxNode {
    lo: [f64; 3],
    hi: [f64; 3],
    start: u32,
    count: u32,
    right: u32,
}

impl BoxTree {
    const LEAF: usize = 16;
    /// Median splits keep the depth at most log2(n) + 1 < 40 for `u32` items.
    const STACK: usize = 64;

    fn new(boxes: &[([f64; 3], [f64; 3])]) -> Self {
        let mut items: Vec<u32> = (0..boxes.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * boxes.len() / Self::LEAF + 1);
        if !boxes.is_empty() {
            Self::build(boxes, &mut items, 0, &mut nodes);
        }
        BoxTree { nodes, items }
    }

    fn build(boxes: &[([f64; 3], [f64; 3])], items: &mut [u32], start: usize, nodes: &mut Vec<BoxNode>) -> usize {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        let (mut clo, mut chi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for &i in items.iter() {
            let (a, b) = &boxes[i as usize];
            for k in 0..3 {
                lo[k] = lo[k].min(a[k]);
                hi[k] = hi[k].max(b[k]);
                let c = 0.5 * (a[k] + b[k]);
                clo[k] = clo[k].min(c);
                chi[k] = chi[k].max(c);
            }
        }
        let me = nodes.len();
        nodes.push(BoxNode {
            lo,
            hi,
            start: start as u32,
            count: items.len() as u32,
            right: 0,
        });
        if items.len() <= Self::LEAF {
            return me;
        }
        let axis = (0..3).fold(0, |m, k| if chi[k] - clo[k] > chi[m] - clo[m] { k } else { m });
        let mid = items.len() / 2;
        let key = |i: &u32| {
            let (a, b) = &boxes[*i as usize];
            a[axis] + b[axis]
        };
        items.select_nth_unstable_by(mid, |x, y| key(x).total_cmp(&key(y)).then(x.cmp(y)));
        let (l, r) = items.split_at_mut(mid);
        nodes[me].count = 0;
        Self::build(boxes, l, start, nodes);
        let right = Self::build(boxes, r, start + mid, nodes);
        nodes[me].right = right as u32;
        me
    }

    /// Calls `f` with every item of a leaf whose box meets `[a, b]` and which no culled
    /// node contains (a node is culled when its box does not meet `[a, b]` or satisfies
    /// `far`); each item at most once.
    fn visit(&self, a: &[f64; 3], b: &[f64; 3], far: &impl Fn(&[f64; 3], &[f64; 3]) -> bool, mut f: impl FnMut(u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = [0u32; Self::STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let id = stack[top];
            let n = &self.nodes[id as usize];
            if !(0..3).all(|k| n.lo[k] <= b[k] && n.hi[k] >= a[k]) || far(&n.lo, &n.hi) {
                continue;
            }
            if n.count > 0 {
                for &i in &self.items[n.start as usize..(n.start + n.count) as usize] {
                    f(i);
                }
            } else {
                stack[top] = n.right;
                stack[top + 1] = id + 1;
                top += 2;
            }
        }
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
    let Cut::Split(s) = cell.cut_sealing(plane, &relaxed, 0) else {
        return None;
    };
    // In the cutting plane's projection, with areas in that plane: the same coverage test
    // as the sealing pass (`build::section_covered`).
    let (sa, open) = super::build::section_open(&s.section, &plane.n, std::slice::from_ref(poly), &relaxed, tol);
    if open.iter().any(|&(_, sliver)| !sliver) {
        return None;
    }
    let covered = sa - open.iter().map(|(a, _)| a).sum::<f64>();
    (covered >= 0.5 * sa && covered > 0.0).then_some(covered)
}

/// An upper bound of the rounding error of the volume a cell adds to the volume sum
/// ([`ConvexPolyhedron::volume`], or [`ConvexPolyhedron::tiling_volume`] for cells with
/// larger faces, whose fans have one triangle per edge): the volume is a
/// sum over each face's fan triangles of `a · (b × c) / 6` with `a`, `b`, `c` relative to
/// a reference vertex, each at most the cell's bounding-box diagonal `d` long; each term
/// is off by at most ~`4 ε d³` from the arithmetic, so the bound is `8 ε d³ / 6` per fan
/// triangle (a factor two of slack). Far from the origin the differences themselves round:
/// a coordinate of magnitude `M` (the cell's largest) is only known to `ε M`, and a
/// constructed vertex rounded there leaves a face non-planar by as much, so the fans of its
/// two cells (from different reference vertices) disagree by up to ~`ε M d²` per
/// triangle: the bound uses `d²·(d + M)` for `d³` (a small model at 1e5, fuzz find
/// `delaunay_validate_..._occl-98269067`: cell volumes 3e-9 relative off the hull's).
fn volume_rounding(p: &ConvexPolyhedron) -> f64 {
    // Fan triangles: one per triangle, one per edge of a larger face (`tiling_volume`).
    let triangles: usize = p
        .faces
        .iter()
        .map(|f| match f.verts.len() {
            0..=2 => 0,
            3 => 1,
            n => n,
        })
        .sum();
    rounding_of(p.aabb(), triangles)
}

/// [`volume_rounding`] of a cell with box `(lo, hi)` and `triangles` fan triangles.
fn rounding_of((lo, hi): ([f64; 3], [f64; 3]), triangles: usize) -> f64 {
    let d = crate::base::vec::dist(&lo, &hi);
    let m = (0..3).map(|k| lo[k].abs().max(hi[k].abs())).fold(0.0, f64::max);
    8.0 * f64::EPSILON * d * d * (d + m) * triangles as f64 / 6.0
}

fn bbox(v: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    crate::model::bbox_of(v.iter())
}

#[cfg(test)]
mod box_tree_tests {
    use super::BoxTree;

    /// The tree without culling visits exactly the items whose box meets the query box,
    /// each once; with a culling predicate it skips only items inside culled boxes.
    #[test]
    fn box_tree_visits_what_brute_force_finds() {
        let mut s = 0x9e3779b97f4a7c15u64;
        let mut r = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for n in [0usize, 1, 3, 4, 5, 17, 300, 2000] {
            let boxes: Vec<([f64; 3], [f64; 3])> = (0..n)
                .map(|_| {
                    let a = [r() * 10.0, r() * 10.0, r() * 3.0];
                    let e = [r() * r() * 4.0, r() * 0.2, r() * 3.0];
                    (a, [a[0] + e[0], a[1] + e[1], a[2] + e[2]])
                })
                .collect();
            let tree = BoxTree::new(&boxes);
            for _ in 0..50 {
                let a = [r() * 10.0, r() * 10.0, r() * 3.0];
                let b = [a[0] + r() * 3.0, a[1] + r() * 3.0, a[2] + r()];
                let meets = |(p, q): &([f64; 3], [f64; 3])| (0..3).all(|k| p[k] <= b[k] && q[k] >= a[k]);
                let mut got = Vec::new();
                tree.visit(&a, &b, &|_: &[f64; 3], _: &[f64; 3]| false, |i| got.push(i));
                let mut want: Vec<u32> = (0..n as u32).filter(|&i| meets(&boxes[i as usize])).collect();
                // Leaves may hand out items whose own box misses the query; none twice.
                let mut all = got.clone();
                all.sort_unstable();
                all.dedup();
                assert_eq!(all.len(), got.len(), "an item visited twice");
                all.retain(|&i| meets(&boxes[i as usize]));
                want.sort_unstable();
                assert_eq!(all, want);
                // Culling the half-space x > 5: every item with a point at x <= 5 that
                // meets the query is still visited.
                let mut culled = Vec::new();
                tree.visit(&a, &b, &|lo: &[f64; 3], _: &[f64; 3]| lo[0] > 5.0, |i| culled.push(i));
                for i in want {
                    if boxes[i as usize].0[0] <= 5.0 {
                        assert!(culled.contains(&i), "item {i} lost to culling");
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::generate::scenes;
    use crate::model::from_soup;

    /// The portal check finds a repeated pair wherever it is (next to its twin, at the
    /// end, far apart in a group of many), and a reversed pair, and reports the first
    /// violation in list order.
    #[test]
    fn a_repeated_portal_pair_is_found_anywhere() {
        let soup = scenes::room_grid(2, 2, 8).0;
        let m = from_soup("g", soup.vertices, soup.polygons).unwrap();
        let cx = crate::pipeline::complex_of_unchecked(&m).unwrap();
        assert!(cx.portals.len() > 100);
        cx.check_portals().expect("valid");
        let twice = |e: Result<(), super::ComplexError>| e.unwrap_err().to_string();
        let mut next = cx.clone();
        next.portals.insert(8, next.portals[7].clone());
        assert!(twice(next.check_portals()).contains("pair listed twice"));
        let mut end = cx.clone();
        end.portals.push(end.portals[3].clone());
        assert!(twice(end.check_portals()).contains("pair listed twice"));
        let mut reversed = cx.clone();
        reversed.portals[5].cells.reverse();
        assert!(twice(reversed.check_portals()).contains("unordered pair"));
        // The first violation in list order: a reversed pair before a repeat, and after.
        let mut both = cx.clone();
        both.portals[2].cells.reverse();
        both.portals.push(both.portals[9].clone());
        assert!(twice(both.check_portals()).contains("unordered pair"));
        let mut both = cx.clone();
        both.portals.insert(1, both.portals[0].clone());
        both.portals[6].cells.reverse();
        let e = twice(both.check_portals());
        assert!(e.contains("pair listed twice"), "{e}");
        // Every pair of a busy cell, then one of them again last.
        let busy = (0..cx.cells.len())
            .max_by_key(|&c| cx.portals.iter().filter(|p| p.cells[0].idx() == c).count())
            .unwrap();
        let of_busy: Vec<usize> = (0..cx.portals.len())
            .filter(|&k| cx.portals[k].cells[0].idx() == busy)
            .collect();
        assert!(of_busy.len() >= 3);
        let mut late = cx.clone();
        late.portals.push(late.portals[of_busy[of_busy.len() / 2]].clone());
        assert!(twice(late.check_portals()).contains("pair listed twice"));
    }

    /// Leaving the conforming polygons out for implicit tetrahedra changes no verdict: on
    /// models of many conforming polygons (a tessellated room grid, the thesis models), and
    /// with a wall added through their cells (placed, so still tested), the check gives
    /// the same result with `CellComplex::conforming` as with it cleared (every polygon
    /// tested against every cell).
    #[test]
    fn conforming_polygons_left_out_for_tetrahedra_change_no_verdict() {
        let mut soups = vec![
            ("grid".to_string(), scenes::room_grid(2, 2, 3).0),
            ("box".into(), scenes::box_room()),
        ];
        for name in ["four_room_optimized", "four_room_tessellated", "noisy"] {
            let tm = crate::generate::thesis::by_name(name).unwrap();
            soups.push((name.into(), tm.soup.clone()));
        }
        for (name, s) in soups {
            let m = from_soup(&name, s.vertices.clone(), s.polygons.clone()).unwrap();
            let mut cx = crate::pipeline::complex_of(&m).unwrap();
            let conforming = cx.conforming.iter().filter(|&&c| c).count();
            assert!(conforming > 0, "{name}: no conforming polygon to leave out");
            // A wall across the middle of the model, through its cells.
            let (lo, hi) = m.bbox();
            let f = |k: usize, t: f64| lo[k] + t * (hi[k] - lo[k]);
            let mut vs = s.vertices.clone();
            let k = vs.len() as u32;
            let x = f(0, 0.43);
            vs.extend([
                [x, f(1, 0.1), f(2, 0.1)],
                [x, f(1, 0.9), f(2, 0.1)],
                [x, f(1, 0.9), f(2, 0.9)],
                [x, f(1, 0.1), f(2, 0.9)],
            ]);
            let mut ps = s.polygons.clone();
            ps.push(vec![k, k + 1, k + 2, k + 3]);
            let crossed = from_soup(&name, vs, ps).unwrap();
            let with = [cx.check_no_crossing(&m), cx.check_no_crossing(&crossed)];
            assert!(with[0].is_ok(), "{name}: {:?}", with[0]);
            assert!(with[1].is_err(), "{name}: the added wall crosses cells");
            cx.conforming.clear();
            let without = [cx.check_no_crossing(&m), cx.check_no_crossing(&crossed)];
            assert_eq!(with, without, "{name}");
        }
    }
}
