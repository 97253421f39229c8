//! Stages 1–4: cells from tetrahedra, conforming polygons, splitting, sealing cracks.

use super::{Cell, CellComplex, ComplexStats, HULL, Occluder, Patch, PatchId, TetShape};
use crate::base::hash::FxBuild;
use crate::delaunay::{FACE_SLOTS, Tetrahedralization};
use crate::geom::{
    Classification, ConvexPolygon, ConvexPolyhedron, Cut, Plane, PolygonSplit, PolyhedronSplit, min_volume,
};
use crate::ids::{CellId, PolygonId, TetId, VertexId};
use crate::model::Model;
use crate::predicates::orient3d;
use rayon::prelude::*;
use std::collections::{HashMap, HashSet, VecDeque};
use std::time::Instant;
use thin_vec::ThinVec;

/// The first and the largest batch of polygons placed by dry runs on every core
/// ([`CellComplex::place_pending`]); only speed depends on them.
const DRY_BATCHES: (usize, usize) = (32, 2048);

impl CellComplex {
    /// Builds the complex of `model` over its tetrahedralization `tet` (which must be of
    /// `model.vertices`, in order): splitting, portal graph and exterior removal.
    pub fn build(model: &Model, tet: &Tetrahedralization) -> CellComplex {
        Self::build_with_progress(model, tet, &mut |_, _, _| {})
    }

    /// [`CellComplex::build`], reporting `(stage, done, total)` during the long loops.
    pub fn build_with_progress(
        model: &Model,
        tet: &Tetrahedralization,
        progress: &mut dyn FnMut(&'static str, usize, usize),
    ) -> CellComplex {
        Self::build_beside(model, tet, progress, |_| ()).0
    }

    /// [`CellComplex::build_with_progress`], running `beside` on the complex once its
    /// cells are final (after splitting and sealing; portals, exterior flags and leaks
    /// not yet set) on the other threads while the portal graph is built: a reader of
    /// the cells' geometry, such as [`CellComplex::check_no_crossing`], then costs
    /// little wall time (the portal graph is mostly sequential). Returns its result.
    pub fn build_beside<R: Send>(
        model: &Model,
        tet: &Tetrahedralization,
        progress: &mut dyn FnMut(&'static str, usize, usize),
        beside: impl FnOnce(&CellComplex) -> R + Send,
    ) -> (CellComplex, R) {
        let t0 = Instant::now();
        let mut cx = CellComplex::from_tets(model, tet);
        cx.stats.polygons = model.polygons.len();
        cx.stats.stage("cells from tetrahedra", t0.elapsed().as_secs_f64());

        let t1 = Instant::now();
        let (supports, of, pending) = cx.conform(model, tet);
        cx.stats.stage("conforming polygons", t1.elapsed().as_secs_f64());

        let t2 = Instant::now();
        let mut placer = Placer::new(tet, cx.cells.len());
        let pending = placement_order(model, pending);
        cx.place_pending(
            model,
            tet,
            &mut placer,
            &pending,
            (&supports, &of),
            Some(DRY_BATCHES),
            progress,
        );
        cx.stats.polygons_clipped = pending.len();
        cx.stats.stage("splitting", t2.elapsed().as_secs_f64());

        let t25 = Instant::now();
        cx.seal_cracks(model, &mut placer, &supports, &of);
        cx.stats.cells_after_split = cx.cells.iter().filter(|c| c.alive).count();
        cx.stats.stage("sealing cracks", t25.elapsed().as_secs_f64());

        let t3 = Instant::now();
        let (graph, r) = rayon::join(|| cx.graph(), || beside(&cx));
        cx.set_graph(graph);
        cx.stats.stage("portal graph", t3.elapsed().as_secs_f64());

        let t4 = Instant::now();
        cx.remove_exterior();
        cx.stats.stage("exterior removal", t4.elapsed().as_secs_f64());

        let t5 = Instant::now();
        cx.shrink_storage();
        cx.stats.stage("compact storage", t5.elapsed().as_secs_f64());
        (cx, r)
    }

    /// Stage 2: the support planes of all polygons (also `polygon_planes`), then the
    /// polygons that conform to cell faces attached as occluders. Returns the supports,
    /// each polygon's support and flip, and the polygons left to place (in id order).
    fn conform(
        &mut self,
        model: &Model,
        tet: &Tetrahedralization,
    ) -> (Vec<Support>, Vec<(usize, bool)>, Vec<PolygonId>) {
        // Support planes over all polygons first: a polygon may skip geometry only if it
        // lies exactly on its support plane, so that one surface never mixes planes.
        let all: Vec<PolygonId> = (0..model.polygons.len() as u32).map(PolygonId).collect();
        let (supports, of) = support_planes(model, &all, &self.tol);
        self.stats.support_planes = supports.len();
        self.polygon_planes = of
            .iter()
            .map(|&(s, flipped)| {
                if flipped {
                    supports[s].plane.flipped()
                } else {
                    supports[s].plane
                }
            })
            .collect();
        let on_support: Vec<bool> = model
            .polygons
            .par_iter()
            .with_min_len(256)
            .zip(&of)
            .map(|(p, &(s, _))| {
                let [a, b, c] = supports[s].ids.map(|v| tet.point(v));
                p.verts.iter().all(|v| orient3d(a, b, c, tet.point(*v)) == 0)
            })
            .collect();
        let pending = self.attach_conforming(model, tet, &on_support);
        (supports, of, pending)
    }

    /// Stage 3: places the `pending` polygons (not conforming to cell faces), in order,
    /// each on its support plane (`supports`, with `of` the support and flip of each
    /// polygon): splits, attachments, deferred crossings. With `batches` = (first,
    /// largest), by dry runs on every core where they suffice (the same result; see
    /// below); `None`: one polygon after another by the serial search only.
    #[allow(clippy::too_many_arguments)]
    fn place_pending(
        &mut self,
        model: &Model,
        tet: &Tetrahedralization,
        placer: &mut Placer,
        pending: &[PolygonId],
        (supports, of): (&[Support], &[(usize, bool)]),
        batches: Option<(usize, usize)>,
        progress: &mut dyn FnMut(&'static str, usize, usize),
    ) {
        let place = |cx: &mut Self, placer: &mut Placer, p: PolygonId| {
            let (s, flipped) = of[p.idx()];
            cx.place_polygon(model, tet, placer, p, &supports[s], flipped);
        };
        let Some((first, largest)) = batches else {
            for (i, &p) in pending.iter().enumerate() {
                if i % 64 == 0 {
                    progress("splitting", i, pending.len());
                }
                place(self, placer, p);
            }
            return;
        };
        // Most polygons split nothing (none at all in a million-triangle building): their
        // placements are found on every core against the complex as it is at the start of
        // a batch (a dry run, which gives up at the first split to try) and applied in
        // order. A polygon whose dry run gave up is placed by the serial search; a split
        // there logs the cells it changes (`touched`), and a later dry run of the batch
        // that read one of them is not applied: that polygon too is placed by the serial
        // search. Attachments and deferrals change nothing a dry run reads, so the result
        // is the serial loop's, for any batch size
        // (`dry_runs_place_as_the_serial_search_does`).
        //
        // Where most polygons split cells (a real level's brushes cut the tetrahedra of
        // their neighbours), most dry runs give up or are found stale: after a batch that
        // applied less than three quarters of its dry runs, the next `serial` polygons (four
        // times the batch, doubled after each such batch in a row) are placed by the serial
        // search alone, then a small batch probes again.
        let mut i = 0;
        let (mut batch, mut serial) = (first, 4 * first);
        while i < pending.len() {
            let (start, end) = (i, (i + batch).min(pending.len()));
            let dry: Vec<Option<DryPlacement>> = pending[start..end]
                .par_iter()
                .with_max_len(1)
                .map(|&p| {
                    let (s, flipped) = of[p.idx()];
                    self.dry_place(model, tet, placer, p, &supports[s], flipped)
                })
                .collect();
            // Cells changed since the batch's dry runs were found.
            let mut changed: HashSet<u32, FxBuild> = HashSet::default();
            let mut applied = 0;
            self.touched = Some(Vec::new());
            for (d, &p) in dry.into_iter().zip(&pending[start..end]) {
                if i % 64 == 0 {
                    progress("splitting", i, pending.len());
                }
                i += 1;
                match d {
                    Some(d) if changed.is_empty() || !d.read.iter().any(|c| changed.contains(c)) => {
                        self.apply_dry(placer, p, d);
                        applied += 1;
                    }
                    _ => {
                        place(self, placer, p);
                        changed.extend(self.touched.as_mut().into_iter().flat_map(|t| t.drain(..)).map(|c| c.0));
                    }
                }
            }
            self.touched = None;
            if applied * 4 >= (end - start) * 3 {
                batch = (batch * 2).min(largest);
                serial = 4 * first;
            } else {
                for &p in &pending[i..(i + serial).min(pending.len())] {
                    if i % 64 == 0 {
                        progress("splitting", i, pending.len());
                    }
                    i += 1;
                    place(self, placer, p);
                }
                batch = first;
                serial = (serial * 2).min(largest);
            }
        }
    }

    /// Stage 1: one cell per finite tetrahedron, one patch per face.
    ///
    /// Patch ids follow the tetrahedra: a face belongs to the smaller of its two
    /// tetrahedra (or its only one, on the hull), and each tetrahedron's faces get
    /// consecutive ids in face order, after those of every smaller tetrahedron. So each
    /// tetrahedron's first id is a prefix sum of the counts, and patches and cells are
    /// built on every core (rayon) with the ids one thread gives.
    fn from_tets(model: &Model, tet: &Tetrahedralization) -> CellComplex {
        let nt = tet.num_tets();
        let owns = |t: usize, i: usize| tet.neighbor(TetId(t as u32), i).is_none_or(|(n, _)| n.idx() > t);
        let mut first: Vec<u32> = (0..nt)
            .into_par_iter()
            .with_min_len(4096)
            .map(|t| (0..4).filter(|&i| owns(t, i)).count() as u32)
            .collect();
        let mut acc = 0u32;
        for f in first.iter_mut() {
            let k = *f;
            *f = acc;
            acc += k;
        }
        let own_id = |t: usize, i: usize| first[t] + (0..i).filter(|&j| owns(t, j)).count() as u32;
        let face_patch: Vec<[u32; 4]> = (0..nt)
            .into_par_iter()
            .with_min_len(4096)
            .map(|t| {
                std::array::from_fn(|i| match tet.neighbor(TetId(t as u32), i) {
                    Some((n, j)) if n.idx() < t => own_id(n.idx(), j),
                    _ => own_id(t, i),
                })
            })
            .collect();
        // Indexed by patch id (the owning tetrahedron found by binary search in `first`),
        // so rayon collects straight into one exactly sized vector: a `flat_map` of
        // unknown length would collect per-thread lists first and copy them, holding the
        // patches twice at this stage's peak.
        let patches: Vec<Patch> = (0..acc)
            .into_par_iter()
            .with_min_len(1024)
            .map(|id| {
                let t = first.partition_point(|&f| f <= id) - 1;
                let i = (0..4)
                    .filter(|&i| owns(t, i))
                    .nth((id - first[t]) as usize)
                    .expect("patch ids are the owned faces' prefix sums");
                let tid = TetId(t as u32);
                let poly = ConvexPolygon::from_slice(&tet.face(tid, i).map(|v| *tet.point(v)));
                let other = tet.neighbor(tid, i).map_or(HULL, |(n, _)| CellId(n.0));
                Patch {
                    polygon: poly,
                    cells: [CellId(t as u32), other],
                    occluders: ThinVec::new(),
                    alive: true,
                }
            })
            .collect();
        // In tetrahedron order, so the sum's bits do not depend on the thread count.
        let hull_volume = tet.tets().fold(0.0, |v, (t, _)| v + tet.volume(t));
        let tol = &model.tolerances;
        let cells: Vec<Cell> = (0..nt)
            .into_par_iter()
            .with_min_len(1024)
            .map(|ti| {
                let t = TetId(ti as u32);
                // The patch polygon is oriented outward of cells[0]; reverse it where this
                // tetrahedron is cells[1].
                let faces = std::array::from_fn(|i| {
                    let p = &patches[face_patch[ti][i] as usize];
                    if p.cells[0] == CellId(t.0) {
                        p.polygon.clone()
                    } else {
                        p.polygon.reversed()
                    }
                });
                let faces: [ConvexPolygon; 4] = faces;
                // Near-flat tetrahedra (four nearly coplanar input points, e.g. the corners
                // of a wall quad after rotation) are valid Delaunay cells but hold no space.
                // Its thickness is its smallest height, 3V / (largest face area); thinner
                // than the weld distance (the same rule `cut` uses) means flat.
                let amax = faces.iter().map(|f| f.area()).fold(0.0, f64::max);
                let flat =
                    3.0 * tet.volume(t) < tol.weld_abs().max(tol.plane_abs()) * amax || tet.volume(t) < min_volume(tol);
                // Kept implicit: each face is the slot-order face rotated to the patch
                // polygon's start (always, as the patch is the same triangle, outward).
                let corners = tet.tet(t).map(|v| *tet.point(v));
                let start = |i: usize| {
                    (0..3u8).find(|&r| {
                        let s = FACE_SLOTS[i];
                        (0..3).all(|k| faces[i].verts[k] == corners[s[(r as usize + k) % 3]])
                    })
                };
                match [start(0), start(1), start(2), start(3)] {
                    [Some(a), Some(b), Some(c), Some(d)] => Cell::tetrahedron(
                        TetShape {
                            corners,
                            tags: face_patch[ti],
                            start: [a, b, c, d],
                        },
                        Some(t),
                        flat,
                    ),
                    _ => Cell::new(
                        ConvexPolyhedron::from_faces(faces.to_vec(), face_patch[ti].to_vec()),
                        Some(t),
                        flat,
                    ),
                }
            })
            .collect();
        let stats = ComplexStats {
            tetrahedra: nt,
            ..Default::default()
        };
        CellComplex {
            cells,
            patches,
            portals: Vec::new(),
            cracks: Vec::new(),
            leaks: Vec::new(),
            stats,
            tol: model.tolerances,
            hull_volume,
            polygon_planes: Vec::new(),
            hull_through: Vec::new(),
            neighbour_log: Vec::new(),
            touched: None,
            volumes: Vec::new(),
            conforming: Vec::new(),
        }
    }

    /// Stage 2: polygons whose fan triangles are all tetrahedron faces get occluders on
    /// those faces without any geometry. Returns the polygons left for stage 3.
    ///
    /// A fan triangle is found among the tetrahedra around its vertex of fewest (a star
    /// list built once, in place of a map of all wanted triangles): in a tetrahedralization
    /// a triangle is the face of at most two tetrahedra, both naming its one patch. Each
    /// polygon is decided on every core; the occluders are then added in polygon order.
    fn attach_conforming(&mut self, model: &Model, tet: &Tetrahedralization, on_support: &[bool]) -> Vec<PolygonId> {
        let (start, star) = tet_stars(tet);
        let star_of = |v: u32| &star[start[v as usize] as usize..start[v as usize + 1] as usize];
        // The patch whose face is the triangle `t`, if any (none for a triangle with a
        // repeated vertex, which no face is).
        let face_patch = |t: [u32; 3]| -> Option<PatchId> {
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return None;
            }
            let v = *t.iter().min_by_key(|&&v| star_of(v).len())?;
            star_of(v).iter().find_map(|&x| {
                let vs = tet.tet(TetId(x)).map(|w| w.0);
                if !t.iter().all(|w| vs.contains(w)) {
                    return None;
                }
                let i = vs.iter().position(|w| !t.contains(w))?;
                Some(PatchId(self.cells[x as usize].tags()[i]))
            })
        };
        let fans = |p: &[VertexId], start: usize| -> Vec<[u32; 3]> {
            let n = p.len();
            (1..n - 1)
                .map(|k| [p[start].0, p[(start + k) % n].0, p[(start + k + 1) % n].0])
                .collect()
        };
        // Per polygon: its first fan (start vertex) that is all patches, with the patches;
        // `None` for the polygons left to stage 3.
        let chosen: Vec<Option<(u8, Vec<PatchId>)>> = model
            .polygons
            .par_iter()
            .enumerate()
            .with_min_len(256)
            .map(|(k, poly)| {
                if !on_support[k] {
                    return None;
                }
                let starts = if poly.verts.len() > 3 { 2 } else { 1 };
                (0..starts).find_map(|s| {
                    fans(&poly.verts, s)
                        .into_iter()
                        .map(|t| {
                            // A flat tetrahedron beside the face means other faces lie on
                            // the polygon too: place it geometrically so all of them get
                            // occluders.
                            face_patch(t).filter(|p| {
                                self.patches[p.idx()]
                                    .cells
                                    .iter()
                                    .all(|&c| c == HULL || !self.cells[c.idx()].flat)
                            })
                        })
                        .collect::<Option<Vec<PatchId>>>()
                        .map(|ps| (s as u8, ps))
                })
            })
            .collect();
        drop((start, star));
        self.conforming = chosen.iter().map(Option::is_some).collect();
        // The occluders are made here, in polygon order, on one thread: their blocks then
        // lie in the heap in the order the field and the checks read them.
        let mut pending = Vec::new();
        for (k, c) in chosen.into_iter().enumerate() {
            let Some((s, patches)) = c else {
                pending.push(PolygonId(k as u32));
                continue;
            };
            self.stats.polygons_conforming += 1;
            let poly = &model.polygons[k];
            for (tri, pid) in fans(&poly.verts, s as usize).into_iter().zip(patches) {
                let patch = &mut self.patches[pid.idx()];
                let pv: Vec<P3Key> = patch.polygon.verts.iter().map(|p| p.map(f64::to_bits)).collect();
                let tv: Vec<P3Key> = tri
                    .iter()
                    .map(|&v| model.vertices[v as usize].map(f64::to_bits))
                    .collect();
                // Same cyclic order as the patch: the polygon's normal agrees with the patch
                // normal, which points into cells[1], so the polygon faces cells[1].
                let same = (0..3).any(|r| (0..3).all(|j| pv[(r + j) % 3] == tv[j]));
                // The triangle *is* the patch; occluders are stored in the patch's orientation.
                let polygon = patch.polygon.clone();
                // Nearly always the patch's only occluder: no growth slack (a first push
                // reserves four).
                if patch.occluders.is_empty() {
                    patch.occluders.reserve_exact(1);
                }
                patch.occluders.push(Occluder {
                    polygon,
                    source: PolygonId(k as u32),
                    faces: if same { 1 } else { 0 },
                });
            }
        }
        pending
    }

    /// Stage 3 for one polygon: visit the cells it touches; split straddled cells; attach
    /// occluders on faces it lies on.
    fn place_polygon(
        &mut self,
        model: &Model,
        tet: &Tetrahedralization,
        pl: &mut Placer,
        pid: PolygonId,
        support: &Support,
        flipped: bool,
    ) {
        let (polygon, plane, (lo, hi, slack), seeds) = self.placement_of(model, tet, pl, pid, support, flipped);
        let ids = support.ids;
        pl.queue.clear();
        pl.epoch += 1;
        let epoch = pl.epoch;
        for c in seeds {
            pl.mark(c, epoch);
            pl.queue.push_back(c);
        }
        // Refused splits are retried once the search is done if a split by this plane
        // succeeded after them: a split refused because a neighbour's subdivided face
        // would not be convex often succeeds once that neighbour has been cut by the same
        // plane (the shared face is then split by the same crossings), and the cells of a
        // tetrahedron fan around the plane are visited in search order, not in the order
        // that works. (cell, successful splits when it was refused, counted unplaced)
        let mut refused: Vec<(CellId, usize, bool)> = Vec::new();
        let mut splits = 0usize;
        let mut rounds = 0usize;
        loop {
            self.place_search(
                tet,
                pl,
                pid,
                &polygon,
                &plane,
                &ids,
                flipped,
                (lo, hi, slack),
                epoch,
                &mut refused,
                &mut splits,
            );
            rounds += 1;
            if rounds > MAX_RETRY_ROUNDS {
                break;
            }
            let retry: Vec<(CellId, usize, bool)> = refused
                .iter()
                .copied()
                .filter(|&(c, at, _)| at < splits && self.cells[c.idx()].alive)
                .collect();
            if retry.is_empty() {
                break;
            }
            refused.retain(|&(c, at, _)| !(at < splits && self.cells[c.idx()].alive));
            for (c, _, unplaced) in retry {
                if unplaced {
                    self.stats.unplaced_fragments -= 1;
                }
                pl.queue.push_back(c);
            }
        }
        self.stats.splits_refused += refused.iter().filter(|r| self.cells[r.0.idx()].alive).count();
    }

    /// What the search of polygon `pid` starts from: the polygon projected onto its support
    /// plane (a no-op for the representative), the plane oriented so that its front is the
    /// polygon's front, the polygon's box with the slack cells are visited within, and the
    /// live cells around its canonical first vertex.
    #[allow(clippy::type_complexity)]
    fn placement_of(
        &self,
        model: &Model,
        tet: &Tetrahedralization,
        pl: &Placer,
        pid: PolygonId,
        support: &Support,
        flipped: bool,
    ) -> (ConvexPolygon, Plane, ([f64; 3], [f64; 3], f64), Vec<CellId>) {
        let poly = &model.polygons[pid.idx()];
        let plane = if flipped {
            support.plane.flipped()
        } else {
            support.plane
        };
        let start = canonical_start(model, pid);
        // The corners only (`Model::is_corner`): the same region, clipped in O(corners).
        let verts: Vec<[f64; 3]> = corner_cycle(model, pid).iter().map(|v| support.project(v)).collect();
        let (lo, hi) = aabb(&verts);
        let polygon = ConvexPolygon::new(verts);
        // The projection moved the polygon by up to `coplanar` from where it is: cells
        // within that distance must be visited, so that faces lying where the polygon is
        // get it attached (`attach_on_faces` accepts faces that near the plane).
        let slack = self.near_eps() + self.tol.plane_abs() * 4.0;
        let seeds = pl.seed_cells(tet, poly.verts[start], &self.cells);
        (polygon, plane, (lo, hi, slack), seeds)
    }

    /// The breadth-first search of [`place_polygon`](Self::place_polygon) from the cells
    /// in `pl.queue`; refused significant splits are appended to `refused`, successful ones
    /// counted in `splits`.
    #[allow(clippy::too_many_arguments)]
    fn place_search(
        &mut self,
        tet: &Tetrahedralization,
        pl: &mut Placer,
        pid: PolygonId,
        polygon: &ConvexPolygon,
        plane: &Plane,
        ids: &[VertexId; 3],
        flipped: bool,
        (lo, hi, slack): ([f64; 3], [f64; 3], f64),
        epoch: u32,
        refused: &mut Vec<(CellId, usize, bool)>,
        splits: &mut usize,
    ) {
        let (polygon, plane, ids) = (polygon, *plane, *ids);
        while let Some(c) = pl.queue.pop_front() {
            let clip = match self.visit(tet, c, pid, polygon, &plane, &ids, flipped, (lo, hi, slack), &[]) {
                Visit::Skip => continue,
                Visit::Attach { adds, defer } => {
                    if let Some(t) = defer {
                        pl.defer(t, pid);
                    }
                    self.attach(adds);
                    self.queue_neighbours(c, &mut |n| pl.queue_new(n, epoch));
                    continue;
                }
                Visit::Split(clip) => clip,
            };
            let mut next: Vec<CellId> = Vec::new();
            match self.split_cell(c, &plane, clip, pid) {
                Some((f, b)) => {
                    *splits += 1;
                    // Neighbours cut together with c: their pieces are new cells
                    // of their tetrahedra, to be visited like any other.
                    for (o, fo, bo) in std::mem::take(&mut self.neighbour_log) {
                        pl.on_split(o, fo, bo, &self.cells);
                        for x in [fo, bo] {
                            if pl.mark(x, epoch) {
                                pl.queue.push_back(x);
                            }
                        }
                    }
                    // Faces of the pieces other than the section may lie within
                    // the attach distance of the plane too: a face nearly coplanar
                    // with it that the plane crossed at a shallow angle (a noisy
                    // floor's tetrahedron face). The pieces are marked, so they are
                    // not visited again: attach here, or that face stays open under
                    // the polygon (a leak through the wall).
                    self.attach_on_faces(f, polygon, &plane, pid, true);
                    self.attach_on_faces(b, polygon, &plane, pid, true);
                    pl.on_split(c, f, b, &self.cells);
                    next.push(f);
                    next.push(b);
                    pl.mark(f, epoch);
                    pl.mark(b, epoch);
                }
                None => {
                    // Remember the crossing: a later split may leave a piece whose
                    // section this polygon covers (see `seal_cracks`).
                    pl.defer(self.cells[c.idx()].tet.expect("a tetrahedron's cell"), pid);
                    // Within tolerance of the cell's boundary: the polygon lies on a
                    // face (or grazes the cell); attach it there.
                    let attached = self.attach_on_faces(c, polygon, &plane, pid, true);
                    // A significant fragment on the front side that found no face.
                    let unplaced =
                        !attached && self.cells[c.idx()].poly().classify(&plane, &self.tol) != Classification::Back;
                    if unplaced {
                        self.stats.unplaced_fragments += 1;
                    }
                    refused.push((c, *splits, unplaced));
                    next.push(c);
                }
            }
            for c in next {
                self.queue_neighbours(c, &mut |n| pl.queue_new(n, epoch));
            }
        }
    }

    /// What placing polygon `pid` does at cell `c` of its search (see [`Visit`]), read
    /// without changing the complex: the serial search applies it at once, the dry run
    /// ([`CellComplex::dry_place`]) records it. `pending` are the occluders the dry run
    /// has recorded for this polygon so far (each patch takes the polygon once).
    #[allow(clippy::too_many_arguments)]
    fn visit(
        &self,
        tet: &Tetrahedralization,
        c: CellId,
        pid: PolygonId,
        polygon: &ConvexPolygon,
        plane: &Plane,
        ids: &[VertexId; 3],
        flipped: bool,
        (lo, hi, slack): ([f64; 3], [f64; 3], f64),
        pending: &[(usize, Occluder)],
    ) -> Visit {
        if !self.cells[c.idx()].alive || !self.touches(c, polygon, plane, lo, hi, slack) {
            return Visit::Skip;
        }
        // Classify: exactly for unsplit tetrahedra, with tolerance otherwise.
        let mut defer = None;
        if self.classify(c, tet, ids, flipped, plane) == Classification::Straddles {
            let clip = clip_to_cell(polygon, &self.cells[c.idx()].poly(), &self.tol);
            match clip {
                Some(clip) if clip.area() >= self.tol.area_abs() => return Visit::Split(clip),
                // An insignificant section splits nothing; the crossing is remembered (a
                // later split may leave a piece whose section this polygon covers: see
                // `seal_cracks`), and the polygon attaches to faces within tolerance.
                _ => defer = Some(self.cells[c.idx()].tet.expect("a tetrahedron's cell")),
            }
        }
        let (_, adds) = self.faces_to_attach(c, polygon, plane, pid, true, pending);
        Visit::Attach { adds, defer }
    }

    /// Hands the cells across `c`'s patches (not the hull) to `queue`, in tag order (it
    /// queues those it has not marked yet).
    fn queue_neighbours(&self, c: CellId, queue: &mut dyn FnMut(CellId)) {
        for &t in self.cells[c.idx()].tags() {
            let n = self.across(PatchId(t), c);
            if n != HULL {
                queue(n);
            }
        }
    }

    /// [`place_polygon`](Self::place_polygon)'s effect, found without changing the complex
    /// (so on every core at once): the occluders it attaches (patch, occluder) and the
    /// tetrahedra it defers, in the order the serial search makes them; `None` when the
    /// search meets a significant section, i.e. a split to try, which only the serial
    /// search can make. Applied with [`CellComplex::apply_dry`] on the complex it was found
    /// on, or on one changed since only by attachments and deferrals (neither is read) and
    /// by splits that touched none of the cells in [`DryPlacement::read`], it leaves the
    /// complex and the placer as `place_polygon` would.
    fn dry_place(
        &self,
        model: &Model,
        tet: &Tetrahedralization,
        pl: &Placer,
        pid: PolygonId,
        support: &Support,
        flipped: bool,
    ) -> Option<DryPlacement> {
        let (polygon, plane, bounds, seeds) = self.placement_of(model, tet, pl, pid, support, flipped);
        let mut out = DryPlacement::default();
        let mut queue: VecDeque<CellId> = VecDeque::new();
        for c in seeds {
            out.read.insert(c.0);
            queue.push_back(c);
        }
        while let Some(c) = queue.pop_front() {
            match self.visit(tet, c, pid, &polygon, &plane, &support.ids, flipped, bounds, &out.adds) {
                Visit::Skip => continue,
                Visit::Split(_) => return None,
                Visit::Attach { adds, defer } => {
                    out.defers.extend(defer);
                    out.adds.extend(adds);
                }
            }
            let read = &mut out.read;
            self.queue_neighbours(c, &mut |n| {
                if read.insert(n.0) {
                    queue.push_back(n);
                }
            });
        }
        Some(out)
    }

    /// Applies a [`dry_place`](Self::dry_place) result of polygon `pid`.
    fn apply_dry(&mut self, pl: &mut Placer, pid: PolygonId, d: DryPlacement) {
        for t in d.defers {
            pl.defer(t, pid);
        }
        self.attach(d.adds);
    }

    /// Appends occluders to patches, in order.
    fn attach(&mut self, adds: Vec<(usize, Occluder)>) {
        for (t, o) in adds {
            self.patches[t].occluders.push(o);
        }
    }

    /// Stage 4: seal cracks left by refused or insignificant crossings.
    ///
    /// A polygon whose part inside a straddled cell is below the area tolerance does not
    /// split it. Later splits by other planes may cut that cell into pieces whose whole
    /// cross-section by the polygon's plane is covered by the polygon: such a piece joins
    /// the wall's two sides through a crack (e.g. a thin wedge of a sliver tetrahedron
    /// hugging one wall and passing behind the wall it meets at a corner), which the portal
    /// graph cannot see because it lies inside one cell. Every crossing that did not split
    /// was remembered per tetrahedron; here each live descendant is split by the support
    /// plane of those polygons when their union covers the section up to cracks (pieces
    /// the portal graph would discard as slivers), with the
    /// [`Tolerances::sealing`](crate::Tolerances::sealing) thresholds.
    ///
    /// A sealing split refused only because a neighbour's subdivided face would not be
    /// convex is retried after the pass when other sealing splits happened since (the
    /// neighbour may since have been cut by the same plane), up to `MAX_RETRY_ROUNDS`
    /// passes.
    fn seal_cracks(&mut self, model: &Model, pl: &mut Placer, supports: &[Support], of: &[(usize, bool)]) {
        let mut tets: Vec<TetId> = pl.deferred.keys().copied().collect();
        tets.sort_unstable();
        let deferred = std::mem::take(&mut pl.deferred);
        for _ in 0..MAX_RETRY_ROUNDS {
            let before = self.stats.cells_sealed;
            let refused = self.seal_tets(model, pl, supports, of, &tets, &deferred);
            if refused.is_empty() || self.stats.cells_sealed == before {
                break;
            }
            tets = refused;
        }
    }

    /// One sealing pass over the tetrahedra `tets`; returns those where a sealing split
    /// was refused by [`try_commit_split`](Self::try_commit_split).
    fn seal_tets(
        &mut self,
        model: &Model,
        pl: &mut Placer,
        supports: &[Support],
        of: &[(usize, bool)],
        tets: &[TetId],
        deferred: &HashMap<TetId, Vec<PolygonId>, FxBuild>,
    ) -> Vec<TetId> {
        let mut refused_in = Vec::new();
        for &t in tets {
            let mut polys = deferred.get(&t).cloned().unwrap_or_default();
            polys.sort_unstable();
            polys.dedup();
            // Group by support plane (sorted, so deterministic).
            let mut groups: Vec<(usize, Vec<PolygonId>)> = Vec::new();
            let mut by: Vec<(usize, PolygonId)> = polys.iter().map(|&p| (of[p.idx()].0, p)).collect();
            by.sort_unstable();
            for (s, p) in by {
                match groups.last_mut() {
                    Some((g, v)) if *g == s => v.push(p),
                    _ => groups.push((s, vec![p])),
                }
            }
            let mut work = pl.live_cells(t, &self.cells);
            while let Some(c) = work.pop() {
                let cell = &self.cells[c.idx()];
                if !cell.alive || cell.flat {
                    continue;
                }
                for (s, ps) in &groups {
                    let folds: Vec<Plane> = groups
                        .iter()
                        .filter(|(o, _)| o != s)
                        .map(|(o, _)| supports[*o].plane)
                        .collect();
                    let r = self.seal_split(model, c, &supports[*s], ps, of, &folds);
                    if r == Err(true) && refused_in.last() != Some(&t) {
                        refused_in.push(t);
                    }
                    if let Ok((f, b)) = r {
                        for (o, fo, bo) in std::mem::take(&mut self.neighbour_log) {
                            pl.on_split(o, fo, bo, &self.cells);
                            if self.cells[o.idx()].tet == Some(t) {
                                work.push(fo);
                                work.push(bo);
                            }
                        }
                        pl.on_split(c, f, b, &self.cells);
                        work.push(f);
                        work.push(b);
                        break;
                    }
                }
            }
        }
        refused_in
    }

    /// Splits `c` by the support plane when the group's polygons `ps` cover its section
    /// (at least half of it, the rest only cracks). Returns (front, back), else whether
    /// the split was refused only by [`try_commit_split`](Self::try_commit_split).
    fn seal_split(
        &mut self,
        model: &Model,
        c: CellId,
        support: &Support,
        ps: &[PolygonId],
        of: &[(usize, bool)],
        folds: &[Plane],
    ) -> Result<(CellId, CellId), bool> {
        self.seal_split_inner(model, c, support, ps, of, folds)
            .ok_or(false)?
            .ok_or(true)
    }

    fn seal_split_inner(
        &mut self,
        model: &Model,
        c: CellId,
        support: &Support,
        ps: &[PolygonId],
        of: &[(usize, bool)],
        folds: &[Plane],
    ) -> Option<Option<(CellId, CellId)>> {
        let plane = support.plane;
        let cell = &self.cells[c.idx()].poly();
        if cell.classify(&plane, &self.tol) != Classification::Straddles {
            return None;
        }
        let slack = self.tol.plane_abs() * 4.0 + self.tol.weld_abs();
        let holes: Vec<(PolygonId, ConvexPolygon)> = ps
            .iter()
            .map(|&p| {
                let verts: Vec<[f64; 3]> = corner_cycle(model, p).iter().map(|v| support.project(v)).collect();
                (p, ConvexPolygon::new(verts))
            })
            .filter(|(_, q)| {
                let (lo, hi) = aabb(&q.verts);
                self.touches(c, q, &plane, lo, hi, slack)
            })
            .collect();
        if holes.is_empty() {
            return None;
        }
        let relaxed = self.tol.sealing();
        let new_patch = self.patches.len() as u32;
        let Cut::Split(s) = self.cells[c.idx()].poly().cut_sealing(&plane, &relaxed, new_patch) else {
            return None;
        };
        let section = &s.section;
        let polys: Vec<ConvexPolygon> = holes.iter().map(|(_, q)| q.clone()).collect();
        // The section is sealed when the polygons cover it up to cracks; or, at a fold
        // (two walls meeting at a crease inside the cell, each crossing it too thinly to
        // split it: a ridge of a curved surface over a sliver tetrahedron's diagonal), when
        // they cover its part on one side of another crossing wall's plane: the piece cut
        // off there is then cut by that wall in turn, and the wedge behind both walls is
        // closed by the two of them (issue 16, caverns-3 under the centroid split).
        let covered = |part: &ConvexPolygon| {
            let (sa, open) = section_open(part, &plane.n, &polys, &relaxed, &self.tol);
            if open.iter().any(|&(_, sliver)| !sliver) {
                return false;
            }
            let open_area: f64 = open.iter().map(|(a, _)| a).sum();
            sa - open_area >= 0.5 * sa
        };
        let sealed = covered(section)
            || folds.iter().any(|f| {
                let (front, back) = section.split(f, &relaxed);
                matches!((&front, &back), (Some(_), Some(_))) && [front, back].iter().flatten().any(&covered)
            });
        if !sealed {
            return None;
        }
        // Occluders in the section's orientation (normal along the support plane, into the
        // front piece): a polygon agreeing with the support faces the front piece.
        let occluders: Vec<Occluder> = holes
            .iter()
            .filter_map(|(p, q)| {
                section.intersect_coplanar(q, &relaxed).map(|o| Occluder {
                    polygon: o,
                    source: *p,
                    faces: if of[p.idx()].1 { 0 } else { 1 },
                })
            })
            .collect();
        let r = self.try_commit_split_any(c, &plane, *s, occluders, &relaxed);
        if r.is_some() {
            self.stats.cells_sealed += 1;
        }
        Some(r)
    }

    /// Distance within which a face counts as lying on a support plane: the projection
    /// onto the support plane moves polygons by up to `coplanar`, and cuts refuse slabs
    /// thinner than `weld`.
    fn near_eps(&self) -> f64 {
        self.tol.coplanar_abs() + self.tol.weld_abs()
    }

    /// Conservative test: can the polygon intersect the closed cell?
    fn touches(
        &self,
        c: CellId,
        polygon: &ConvexPolygon,
        plane: &Plane,
        lo: [f64; 3],
        hi: [f64; 3],
        slack: f64,
    ) -> bool {
        let cell = &self.cells[c.idx()];
        let (clo, chi) = cell.aabb();
        if (0..3).any(|a| clo[a] > hi[a] + slack || chi[a] < lo[a] - slack) {
            return false;
        }
        let faces = cell.faces();
        let un = plane.normalized();
        // Every vertex beyond `slack` on one side: read from the faces as they are (a vertex
        // of several faces gives the same answer each time), stopping once both fail.
        let (mut above, mut below) = (true, true);
        for f in faces.iter() {
            for v in &f.verts {
                let d = un.eval(v);
                above &= d > slack;
                below &= d < -slack;
            }
            if !(above || below) {
                break;
            }
        }
        if above || below {
            return false;
        }
        // Separated by a face plane of the cell?
        for f in faces.iter().map(|f| f.plane()) {
            let f = f.normalized();
            if polygon.verts.iter().all(|v| f.eval(v) > slack) {
                return false;
            }
        }
        true
    }

    fn classify(
        &self,
        c: CellId,
        tet: &Tetrahedralization,
        ids: &[VertexId; 3],
        flipped: bool,
        plane: &Plane,
    ) -> Classification {
        let cell = &self.cells[c.idx()];
        if self.is_original_tet(c) {
            // All four vertices are input vertices: exact orientation against the
            // polygon's plane through three input vertices.
            let (a, b, cc) = (tet.point(ids[0]), tet.point(ids[1]), tet.point(ids[2]));
            let flip = if flipped { -1 } else { 1 };
            let sides = tet
                .tet(cell.tet.expect("a tetrahedron's cell"))
                .map(|v| flip * orient3d(a, b, cc, tet.point(v)));
            let (f, bk) = (sides.iter().any(|&s| s > 0), sides.iter().any(|&s| s < 0));
            return match (f, bk) {
                (true, true) => Classification::Straddles,
                (true, false) => Classification::Front,
                (false, true) => Classification::Back,
                _ => Classification::Coplanar,
            };
        }
        cell.poly().classify(plane, &self.tol)
    }

    /// Unsplit tetrahedra keep their four input vertices (faces may have gained collinear
    /// T-vertices from split neighbours, which lie on the same edges).
    fn is_original_tet(&self, c: CellId) -> bool {
        c.idx() < self.stats.tetrahedra && self.cells[c.idx()].alive
    }

    /// Attaches the overlap of `polygon` with each of `c`'s faces lying on its plane, when
    /// `c` is on the polygon's front side. With `near`, faces within tolerance of the plane
    /// also count (used when a split was refused as a sliver).
    fn attach_on_faces(
        &mut self,
        c: CellId,
        polygon: &ConvexPolygon,
        plane: &Plane,
        pid: PolygonId,
        near: bool,
    ) -> bool {
        let (attached, adds) = self.faces_to_attach(c, polygon, plane, pid, near, &[]);
        self.attach(adds);
        attached
    }

    /// [`attach_on_faces`](Self::attach_on_faces) without changing the complex: whether
    /// the polygon lies on a face of `c`, and the occluders to append (patch, occluder),
    /// none on a patch that already has one of `pid`, in the complex or in `pending`.
    fn faces_to_attach(
        &self,
        c: CellId,
        polygon: &ConvexPolygon,
        plane: &Plane,
        pid: PolygonId,
        near: bool,
        pending: &[(usize, Occluder)],
    ) -> (bool, Vec<(usize, Occluder)>) {
        let un = plane.normalized();
        let eps = if near { self.near_eps() } else { self.tol.plane_abs() };
        let mut attached = false;
        let cell = &self.cells[c.idx()];
        let mut adds: Vec<(usize, Occluder)> = Vec::new();
        // A cell thinner than the sliver width across the polygon's plane (every vertex
        // within it: the wedge between the planes of two triangles of one noisy quad, which
        // no cut can split further) holds the polygon *inside* it, not on a face. Such a
        // cell is a membrane, open where its two sides' open faces overlap, so its faces
        // nearly parallel to the polygon take the polygon's coverage too, or the wall
        // leaks through it (issue 16, noise 1e-5 of the diagonal).
        let sliver = self.tol.sliver_width();
        let mut thin: Option<bool> = None;
        for (fi, f) in cell.faces().iter().enumerate() {
            if !f.verts.iter().all(|v| un.eval(v).abs() <= eps) {
                if !near || !f.verts.iter().all(|v| un.eval(v).abs() <= sliver) {
                    continue;
                }
                let is_thin = *thin.get_or_insert_with(|| cell.vertices().iter().all(|v| un.eval(v).abs() <= sliver));
                let n = f.normal();
                let cos = (n[0] * un.n[0] + n[1] * un.n[1] + n[2] * un.n[2]).abs();
                if !is_thin || cos < THIN_ATTACH_COS {
                    continue;
                }
            }
            let Some(ov) = f.intersect_coplanar(polygon, &self.tol) else {
                continue;
            };
            if ov.area() < self.tol.area_abs() {
                continue;
            }
            let t = cell.tags()[fi] as usize;
            // The patch is visited from both of its cells: attach once per polygon.
            if self.patches[t].occluders.iter().any(|o| o.source == pid)
                || pending.iter().any(|(u, o)| *u == t && o.source == pid)
            {
                attached = true;
                continue;
            }
            let side = if self.patches[t].cells[0] == c { 0 } else { 1 };
            // The polygon's front faces this cell when this face's outward normal points
            // against the polygon's normal, else the cell across.
            let fnrm = f.normal();
            let d = fnrm[0] * un.n[0] + fnrm[1] * un.n[1] + fnrm[2] * un.n[2];
            let faces = if d < 0.0 { side } else { 1 - side };
            // Store in the patch's orientation (outward of cells[0]).
            let polygon = if side == 0 { ov } else { ov.reversed() };
            adds.push((
                t,
                Occluder {
                    polygon,
                    source: pid,
                    faces,
                },
            ));
            attached = true;
        }
        (attached, adds)
    }

    /// Splits cell `c` by `plane`; the clipped polygon becomes an occluder on the new patch
    /// facing the front piece. Returns (front, back), or `None` if the split was refused.
    fn split_cell(
        &mut self,
        c: CellId,
        plane: &Plane,
        clip: ConvexPolygon,
        pid: PolygonId,
    ) -> Option<(CellId, CellId)> {
        let new_patch = self.patches.len() as u32;
        let cut = self.cells[c.idx()].poly().cut(plane, &self.tol, new_patch);
        let Cut::Split(s) = cut else { return None };
        let clip = s.section.intersect_coplanar(&clip, &self.tol).unwrap_or(clip);
        let occ = Occluder {
            polygon: clip,
            source: pid,
            faces: 1,
        };
        let tol = self.tol;
        self.try_commit_split_any(c, plane, *s, vec![occ], &tol)
    }

    /// [`commit_split`](Self::commit_split) only if every neighbour across a patch the
    /// cut divides stays a valid polyhedron after subdividing its face the same way (the
    /// split is all-or-nothing); `None` changes nothing and the caller treats the split as
    /// refused.
    ///
    /// When subdividing a neighbour's face would leave that neighbour non-convex beyond
    /// tolerance (the part of the face on one side is a sliver whose plane, measured from
    /// constructed vertices a rounding error off the face's plane, tilts: a far vertex of
    /// the neighbour then lies in front of it), the neighbour is **cut by the same plane
    /// too** ([`joint_split`](Self::joint_split)): a cut by a plane keeps each piece convex
    /// (`cut` checks its pieces), the sliver face then lies in a piece whose vertices are
    /// all near it, and the crossings on the shared face are bit-identical because both
    /// cuts classify with the same On distance. Cut neighbours are appended to
    /// `neighbour_log` for the caller.
    pub(crate) fn try_commit_split(
        &mut self,
        c: CellId,
        plane: &Plane,
        s: PolyhedronSplit,
        occluders: Vec<Occluder>,
    ) -> Option<(CellId, CellId)> {
        let (plan, ok, bad) = self.plan_neighbours(c, plane, &s, &[], true);
        if ok {
            let mut split = Vec::new();
            return Some(self.apply_split(c, plane, s, occluders, plan, &mut split));
        }
        if bad.is_empty() {
            return None;
        }
        self.joint_split(c, plane, s, occluders, bad)
    }

    /// [`try_commit_split`](Self::try_commit_split) with the cut `s` (made with `tol`),
    /// and when that is refused, with each other valid cut of `c` by the same plane
    /// ([`ConvexPolyhedron::cut_alternatives`]: another On band) in turn, until one
    /// leaves every neighbour valid. The cut alone cannot know which band its neighbours
    /// need: a vertex of a shared face a hair off the plane is On for one band, so the
    /// face is divided through it, and on a side for another, so it is divided next to
    /// it; only one of the two may leave the neighbour a valid polyhedron (the "polygon
    /// crosses cell" stress variants under vertex noise). Each attempt is checked as a
    /// whole, so every committed split is consistent between the cells sharing a face.
    pub(crate) fn try_commit_split_any(
        &mut self,
        c: CellId,
        plane: &Plane,
        s: PolyhedronSplit,
        occluders: Vec<Occluder>,
        tol: &crate::Tolerances,
    ) -> Option<(CellId, CellId)> {
        let chosen = s.on_dist;
        let tag = *s.back.tags.last().expect("section");
        if let Some(r) = self.try_commit_split(c, plane, s, occluders.clone()) {
            return Some(r);
        }
        let alts = self.cells[c.idx()].poly().cut_alternatives(plane, tol, tag, chosen);
        for a in alts {
            if let Some(r) = self.try_commit_split(c, plane, a, occluders.clone()) {
                self.stats.alternative_cuts += 1;
                return Some(r);
            }
        }
        None
    }

    /// Splits `c` by `plane` (its cut `s`) together with the neighbours `bad` (and, if
    /// their own neighbours then fail, those too, up to [`MAX_JOINT_CUTS`] cells), each
    /// cut with `s.on_dist` and the sealing thresholds. All-or-nothing: applies the splits
    /// one after another (patches shared by two cut cells are split once, by the first,
    /// and the second's pieces take the two parts), checks every neighbour whose face was
    /// subdivided, and undoes everything when one fails or a cut is refused.
    fn joint_split(
        &mut self,
        c: CellId,
        plane: &Plane,
        s: PolyhedronSplit,
        occluders: Vec<Occluder>,
        mut bad: Vec<CellId>,
    ) -> Option<(CellId, CellId)> {
        let eps = s.on_dist;
        if eps.is_nan() || eps <= 0.0 {
            return None; // without an On band the shared crossings need not agree
        }
        let relaxed = self.tol.sealing();
        let mut members: Vec<CellId> = vec![c];
        loop {
            for o in bad.drain(..) {
                if members.len() >= MAX_JOINT_CUTS || members.contains(&o) || !self.cells[o.idx()].alive {
                    return None;
                }
                members.push(o);
            }
            // The members' cuts on their current polyhedra (the section tag is renumbered
            // when applied).
            let mut cuts: Vec<PolyhedronSplit> = vec![s.clone()];
            for &o in &members[1..] {
                match self.cells[o.idx()].poly().cut_with_eps(plane, &relaxed, 0, eps) {
                    Cut::Split(so) => cuts.push(*so),
                    _ => return None,
                }
            }
            // Undo information: the patches of the members' faces, the polyhedra of the
            // cells around them, the counts.
            let (ncells, npatches, stats) = (self.cells.len(), self.patches.len(), self.stats.clone());
            let mut saved_patches: Vec<(u32, Patch)> = Vec::new();
            let mut saved_cells: Vec<(CellId, Cell, bool)> = Vec::new();
            for &m in &members {
                for &t in self.cells[m.idx()].tags() {
                    if !saved_patches.iter().any(|(x, _)| *x == t) {
                        saved_patches.push((t, self.patches[t as usize].clone()));
                    }
                    let p = &self.patches[t as usize];
                    for n in p.cells {
                        if n != HULL && !saved_cells.iter().any(|(x, _, _)| *x == n) {
                            saved_cells.push((n, self.cells[n.idx()].clone(), self.cells[n.idx()].alive));
                        }
                    }
                }
            }
            let mut split: Vec<(u32, u32)> = Vec::new();
            let mut touched: Vec<CellId> = Vec::new();
            let mut pieces: Vec<(CellId, CellId)> = Vec::new();
            let mut failed = false;
            for (k, mut cut) in cuts.into_iter().enumerate() {
                let m = members[k];
                // Number the section as the next patch.
                let next = self.patches.len() as u32;
                *cut.front.tags.last_mut().expect("section") = next;
                *cut.back.tags.last_mut().expect("section") = next;
                // Faces on patches an earlier member split: the back part is that patch's
                // new back patch.
                let mut moved: Vec<u32> = Vec::new();
                for (t, t2) in &split {
                    if let Some(i) = cut.back.tags.iter().position(|x| x == t) {
                        cut.back.tags[i] = *t2;
                        moved.push(*t2);
                    }
                }
                // Check failures are collected after applying (below); a structural one
                // (a neighbour's face that does not straddle) fails the whole split.
                let (plan, ok, bad_here) = self.plan_neighbours(m, plane, &cut, &members, false);
                if !ok && bad_here.is_empty() {
                    failed = true;
                }
                touched.extend(plan.cells.iter().map(|(o, _)| *o));
                let occ = if k == 0 { occluders.clone() } else { Vec::new() };
                let (f, b) = self.apply_split(m, plane, cut, occ, plan, &mut split);
                for t2 in moved {
                    let p = &mut self.patches[t2 as usize];
                    match p.cells.iter().position(|&x| x == m) {
                        Some(side) => p.cells[side] = b,
                        None => failed = true,
                    }
                }
                pieces.push((f, b));
            }
            touched.sort_unstable();
            touched.dedup();
            let mut next_bad: Vec<CellId> = Vec::new();
            for &o in &touched {
                let cell = &self.cells[o.idx()];
                if cell.alive && !cell.flat && cell.check(&self.tol).is_err() {
                    next_bad.push(o);
                }
            }
            // Every face of the pieces must be on a patch that lists the piece.
            for &(f, b) in &pieces {
                for x in [f, b] {
                    for &t in self.cells[x.idx()].tags() {
                        if !self.patches[t as usize].cells.contains(&x) {
                            failed = true;
                        }
                    }
                }
            }
            // No patch the splits touched may still name a replaced cell.
            let named = saved_patches
                .iter()
                .map(|(t, _)| *t as usize)
                .chain(npatches..self.patches.len());
            for t in named {
                let p = &self.patches[t];
                if p.alive && p.cells.iter().any(|&x| x != HULL && !self.cells[x.idx()].alive) {
                    failed = true;
                }
            }
            if !failed && next_bad.is_empty() {
                self.stats.neighbour_cuts += members.len() - 1;
                for (k, &m) in members.iter().enumerate().skip(1) {
                    self.neighbour_log.push((m, pieces[k].0, pieces[k].1));
                }
                return Some(pieces[0]);
            }
            // Undo.
            self.cells.truncate(ncells);
            self.patches.truncate(npatches);
            self.stats = stats;
            for (t, p) in saved_patches {
                self.patches[t as usize] = p;
            }
            for (n, cell, alive) in saved_cells {
                self.cells[n.idx()] = cell;
                self.cells[n.idx()].alive = alive;
            }
            if failed || next_bad.is_empty() {
                return None;
            }
            bad = next_bad;
        }
    }

    /// The neighbours' polyhedra after subdividing their faces on the patches that the
    /// cut of `c` divides (tags numbered as [`apply_split`](Self::apply_split) will number
    /// the new patches), except across to the cells of `skip` (cut as well); whether all
    /// of them are valid (flat cells, exempt from the geometric check, only need the
    /// subdivision to happen); and the neighbours that subdivided but failed the check.
    /// With `cancel`, pillows (see [`Pillow`]) the division creates are cancelled in the
    /// plan (not in `joint_split`, whose undo restores only the members' patches).
    fn plan_neighbours(
        &self,
        c: CellId,
        plane: &Plane,
        s: &PolyhedronSplit,
        skip: &[CellId],
        cancel: bool,
    ) -> (Plan, bool, Vec<CellId>) {
        let mut plan: Vec<(CellId, ConvexPolyhedron)> = Vec::new();
        // The (neighbour, tag) of every face part this division creates.
        let mut parts: Vec<(CellId, u32)> = Vec::new();
        let mut ok = true;
        let mut structural = false;
        let mut next_patch = self.patches.len() as u32 + 1; // after the section's patch
        for &t in self.cells[c.idx()].tags() {
            if !(s.front.tags.contains(&t) && s.back.tags.contains(&t)) {
                continue;
            }
            let t2 = next_patch;
            next_patch += 1;
            let p = &self.patches[t as usize];
            let other = if p.cells[0] == c { p.cells[1] } else { p.cells[0] };
            if other == HULL || skip.contains(&other) {
                continue;
            }
            let k = match plan.iter().position(|(o, _)| *o == other) {
                Some(k) => k,
                None => {
                    plan.push((other, self.cells[other.idx()].poly().into_owned()));
                    plan.len() - 1
                }
            };
            let nb = &mut plan[k].1;
            match nb.tags.iter().position(|&x| x == t) {
                // The neighbour's face is reversed: its "front" along `plane` is the same
                // half-space, so the front part keeps tag t.
                Some(fi) => {
                    if nb
                        .split_face_along(fi, plane, s.on_dist, &s.section.verts, t, t2)
                        .is_none()
                    {
                        ok = false;
                        structural = true;
                    }
                    parts.extend([(other, t), (other, t2)]);
                }
                None => {
                    ok = false;
                    structural = true;
                }
            }
        }
        // Pillows: a part just created that is the exact reverse of another face of its
        // cell (see `Pillow`) is cancelled with that face.
        let mut pillows: Vec<Pillow> = Vec::new();
        if cancel && !structural {
            for (o, poly) in plan.iter_mut() {
                while let Some(p) = self.pillow(c, *o, poly, &parts) {
                    pillows.push(p);
                }
            }
        }
        let mut bad = Vec::new();
        for (o, poly) in &plan {
            if !self.cells[o.idx()].flat && poly.check(&self.tol).is_err() {
                ok = false;
                bad.push(*o);
            }
        }
        if structural {
            bad.clear();
        }
        (Plan { cells: plan, pillows }, ok, bad)
    }

    /// Finds in `poly` (neighbour `o`'s planned polyhedron) a face part created by the
    /// division (`parts`) whose vertex cycle is the exact reverse (bit for bit) of another
    /// face's, on a patch to a third cell that no part of this division is on, removes both
    /// faces and returns the pair.
    fn pillow(&self, c: CellId, o: CellId, poly: &mut ConvexPolyhedron, parts: &[(CellId, u32)]) -> Option<Pillow> {
        let n = poly.faces.len();
        for i in 0..n {
            let new = poly.tags[i];
            if !parts.contains(&(o, new)) {
                continue;
            }
            for j in 0..n {
                let old = poly.tags[j];
                if j == i || parts.iter().any(|&(_, t)| t == old) {
                    continue;
                }
                let cells = self.patches[old as usize].cells;
                if cells.contains(&HULL) || cells.contains(&c) || !cells.contains(&o) {
                    continue;
                }
                if reverse_cycles(&poly.faces[i].verts, &poly.faces[j].verts) {
                    let (hi, lo) = (i.max(j), i.min(j));
                    for k in [hi, lo] {
                        poly.faces.remove(k);
                        poly.tags.remove(k);
                    }
                    return Some(Pillow { cell: o, new, old });
                }
            }
        }
        None
    }

    /// Replaces cell `c` by the two pieces of `s` (its cut by `plane`, made with the tag
    /// of the next patch): the cross-section becomes a new patch carrying `occluders`
    /// (in the section's orientation: `faces == 1` faces the front piece), the old patches
    /// move to the piece they lie in or are split in two, and the neighbours across split
    /// patches subdivide their faces. Returns (front, back). Unlike
    /// [`try_commit_split`](Self::try_commit_split), commits even when a neighbour's face
    /// could not be subdivided validly and cutting the neighbours too failed (counted in
    /// `splits_refused`).
    pub(crate) fn commit_split(
        &mut self,
        c: CellId,
        plane: &Plane,
        s: PolyhedronSplit,
        occluders: Vec<Occluder>,
    ) -> (CellId, CellId) {
        if let Some(r) = self.try_commit_split(c, plane, s.clone(), occluders.clone()) {
            return r;
        }
        self.stats.splits_refused += 1;
        let (plan, _, _) = self.plan_neighbours(c, plane, &s, &[], true);
        let mut split = Vec::new();
        self.apply_split(c, plane, s, occluders, plan, &mut split)
    }

    fn apply_split(
        &mut self,
        c: CellId,
        plane: &Plane,
        s: PolyhedronSplit,
        occluders: Vec<Occluder>,
        plan: Plan,
        split: &mut Vec<(u32, u32)>,
    ) -> (CellId, CellId) {
        let (fid, bid) = (CellId(self.cells.len() as u32), CellId(self.cells.len() as u32 + 1));
        let tet = self.cells[c.idx()].tet;
        // The cells this split changes: `c`, every cell across its patches (their patches
        // are reassigned or divided), the neighbours reshaped by the plan (pillows' below).
        if let Some(log) = self.touched.as_mut() {
            log.push(c);
            for &t in self.cells[c.idx()].tags() {
                log.extend(self.patches[t as usize].cells.iter().filter(|&&x| x != HULL));
            }
            log.extend(plan.cells.iter().map(|(o, _)| *o));
        }
        // The cross-section patch: outward of the back piece, into the front piece.
        self.patches.push(Patch {
            polygon: s.section.clone(),
            cells: [bid, fid],
            occluders: occluders.into(),
            alive: true,
        });
        let mut front = s.front;
        let mut back = s.back;
        // Old patches: those wholly on one side move to that piece; those in both are split.
        let old_tags = self.cells[c.idx()].tags().to_vec();
        for &t in &old_tags {
            let in_f = front.tags.contains(&t);
            let in_b = back.tags.contains(&t);
            let t = t as usize;
            let side = if self.patches[t].cells[0] == c { 0 } else { 1 };
            match (in_f, in_b) {
                (true, false) => self.patches[t].cells[side] = fid,
                (false, true) => self.patches[t].cells[side] = bid,
                (true, true) => {
                    let t2 = self.patches.len() as u32;
                    split.push((t as u32, t2));
                    // Relabel the back piece's part of face t.
                    let k = back.tags.iter().position(|&x| x as usize == t).expect("in back");
                    back.tags[k] = t2;
                    let kf = front.tags.iter().position(|&x| x as usize == t).expect("in front");
                    let other = self.patches[t].cells[1 - side];
                    let mut occ_f = Vec::new();
                    let mut occ_b = Vec::new();
                    for o in std::mem::take(&mut self.patches[t].occluders) {
                        match o.polygon.split_exact(plane, &self.tol) {
                            PolygonSplit::Front | PolygonSplit::Coplanar => occ_f.push(o),
                            PolygonSplit::Back => occ_b.push(o),
                            PolygonSplit::Split(pf, pb) => {
                                occ_f.push(Occluder {
                                    polygon: pf,
                                    ..o.clone()
                                });
                                occ_b.push(Occluder { polygon: pb, ..o });
                            }
                        }
                    }
                    let orient = |p: &ConvexPolygon| if side == 0 { p.clone() } else { p.reversed() };
                    let pf = orient(&front.faces[kf]);
                    let pb = orient(&back.faces[k]);
                    let mut cells_b = self.patches[t].cells;
                    cells_b[side] = bid;
                    self.patches[t].cells[side] = fid;
                    self.patches[t].polygon = pf;
                    self.patches[t].occluders = occ_f.into();
                    self.patches.push(Patch {
                        polygon: pb,
                        cells: cells_b,
                        occluders: occ_b.into(),
                        alive: true,
                    });
                    // The neighbour across subdivides its face the same way (planned).
                    let _ = (other, t2);
                }
                (false, false) => {}
            }
        }
        // A pillow's new face lies on a piece (the part of a split patch it holds): that
        // piece now borders the pillow's third cell directly, over the old patch.
        for pw in &plan.pillows {
            let pid = match front.tags.iter().position(|&x| x == pw.new) {
                Some(k) => {
                    front.tags[k] = pw.old;
                    fid
                }
                None => {
                    let k = back.tags.iter().position(|&x| x == pw.new).expect("a pillow's part");
                    back.tags[k] = pw.old;
                    bid
                }
            };
            let slot = self.patches[pw.old as usize]
                .cells
                .iter()
                .position(|&x| x == pw.cell)
                .expect("named");
            let new_cells = self.patches[pw.new as usize].cells;
            if let Some(log) = self.touched.as_mut() {
                let old_cells = self.patches[pw.old as usize].cells;
                log.push(pw.cell);
                log.extend(old_cells.iter().chain(&new_cells).filter(|&&x| x != HULL));
            }
            // The new patch's occluders move over, facing the same cell (the piece, or
            // across the pillow the third cell instead of the pillow's).
            let moved: Vec<Occluder> = std::mem::take(&mut self.patches[pw.new as usize].occluders)
                .into_iter()
                .map(|o| {
                    let faced = new_cells[o.faces as usize];
                    let faces = if faced == pw.cell { 1 - slot } else { slot } as u8;
                    Occluder { faces, ..o }
                })
                .collect();
            let p = &mut self.patches[pw.old as usize];
            p.cells[slot] = pid;
            p.occluders.extend(moved);
            self.patches[pw.new as usize].alive = false;
        }
        // Cells change: volumes cached for final cells no longer hold.
        self.volumes = Vec::new();
        for (o, poly) in plan.cells {
            self.cells[o.idx()].set_poly(poly);
        }
        self.cells[c.idx()].alive = false;
        self.cells.push(Cell::new(front, tet, false));
        self.cells.push(Cell::new(back, tet, false));
        self.stats.cells_split += 1;
        (fid, bid)
    }
}

type P3Key = [u64; 3];

/// What placing a polygon does at one cell of its search ([`CellComplex::visit`]).
enum Visit {
    /// The cell is dead, or the polygon cannot touch it: nothing, and its neighbours are
    /// not queued from it.
    Skip,
    /// The polygon attaches `adds` (patch, occluder) to the cell's faces, and with `defer`
    /// straddles the cell's tetrahedron without a significant section (remembered for
    /// `seal_cracks`); the neighbours are queued.
    Attach {
        adds: Vec<(usize, Occluder)>,
        defer: Option<TetId>,
    },
    /// The polygon crosses the cell with this significant section: a split to try.
    Split(ConvexPolygon),
}

/// A polygon's placement found without changing the complex ([`CellComplex::dry_place`]).
#[derive(Default)]
struct DryPlacement {
    /// Occluders to append, in order.
    adds: Vec<(usize, Occluder)>,
    /// Tetrahedra the polygon straddles without a significant section, in order.
    defers: Vec<TetId>,
    /// Every cell the search read (those it queued): the placement still holds after a
    /// split that changed none of them.
    read: HashSet<u32, FxBuild>,
}

/// A neighbour's planned polyhedron after its faces were divided by a split, and the
/// pillows cancelled in it.
struct Plan {
    cells: Vec<(CellId, ConvexPolyhedron)>,
    pillows: Vec<Pillow>,
}

/// A zero-volume fold of a cell: two of its faces with the same vertices in reverse
/// order. It arises in a sliver cell between two nearly coplanar patches (the wedge
/// between the support planes of a noisy quad's two triangles): a split on one side
/// divides one patch through a chord and leaves, in the sliver, a flap lying on the other
/// patch's corner with the opposite orientation; when a later split divides the other
/// patch through the same chord, its corner part and the flap coincide, and the chord
/// edge is used twice (issue 16, four_room_distorted under noise 1e-5: every division of
/// cell 262 by its crack's plane was refused). The sliver has no extent there: both faces
/// leave it, the split piece holding the `new` part takes the `old` patch in the sliver's
/// place (the two faces are exact reverses, so the piece's face is the third cell's,
/// reversed), and the `new` patch dies, its occluders moved to the `old` one.
struct Pillow {
    /// The sliver cell.
    cell: CellId,
    /// The part just created by the division.
    new: u32,
    /// The face it cancels with, on a patch between `cell` and a third cell.
    old: u32,
}

/// Whether `b` is the cycle `a` reversed, bit for bit (any start).
fn reverse_cycles(a: &[[f64; 3]], b: &[[f64; 3]]) -> bool {
    let n = a.len();
    let bits = |p: &[f64; 3]| p.map(f64::to_bits);
    if n != b.len() || n < 3 {
        return false;
    }
    let Some(k) = b.iter().position(|p| bits(p) == bits(&a[0])) else {
        return false;
    };
    (0..n).all(|i| bits(&a[i]) == bits(&b[(k + n - i) % n]))
}

/// Faces of a cell thinner than the sliver width across a polygon's plane take the
/// polygon's coverage only when their normal is this close to the plane's (|cos| of the
/// angle; ~8°): the cell's two large sides, not its narrow rims.
const THIN_ATTACH_COS: f64 = 0.99;

/// Most searches of one polygon's placement and of the sealing pass: refused splits are
/// retried after later splits by the same plane (see `place_polygon`), a bounded number
/// of times.
const MAX_RETRY_ROUNDS: usize = 8;

/// Most cells one plane splits together in [`CellComplex::joint_split`] (the split cell
/// and the neighbours whose subdivided faces would not be convex), so a cascade is bounded.
const MAX_JOINT_CUTS: usize = 4;

/// What of a cut's cross-section `section` (of a plane with normal `n`) the polygons
/// `polys` leave open (subtracted with the thresholds `relaxed`): the section's area and
/// each open piece's area and whether it is a sliver by `tol` (below its area or narrower
/// than its sliver width), all measured in the plane. The sealing pass
/// and `validate` judge a section covered up to cracks by this one test.
///
/// In the plane, not in the section's own frame: the section keeps the vertices the cut
/// classified On, up to the weld distance off the plane, so the Newell normal of a section
/// thinner than that may point anywhere (see [`ConvexPolygon::subtract_along`]).
pub(crate) fn section_open(
    section: &ConvexPolygon,
    n: &[f64; 3],
    polys: &[ConvexPolygon],
    relaxed: &crate::Tolerances,
    tol: &crate::Tolerances,
) -> (f64, Vec<(f64, bool)>) {
    // A section below the area threshold in the plane (its area in 3D, which the cut
    // tested, is larger by its On vertices' offsets) is no section: not covered, and not
    // open beyond a crack (`subtract` would return no pieces, which reads as covered).
    let sa = section.area_along(n);
    if sa.is_nan() || sa < relaxed.area_abs() {
        return (sa, vec![(sa, true)]);
    }
    let open = section
        .subtract_along(n, polys, relaxed)
        .pieces
        .iter()
        .map(|q| {
            let a = q.area_along(n);
            (
                a,
                a < tol.area_abs() || 2.0 * a < tol.sliver_width() * super::graph::perimeter(q),
            )
        })
        .collect();
    (sa, open)
}

/// Orthogonal projection of `p` onto `plane`.
pub(crate) fn project(plane: &Plane, p: &[f64; 3]) -> [f64; 3] {
    let n = plane.n;
    let nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    let t = plane.eval(p) / nn;
    if t == 0.0 {
        *p
    } else {
        [p[0] - t * n[0], p[1] - t * n[1], p[2] - t * n[2]]
    }
}

/// A plane shared by nearly coplanar polygons: through three input vertices of the
/// largest polygon of its group, oriented like that polygon.
pub(super) struct Support {
    ids: [VertexId; 3],
    plane: Plane,
}

impl Support {
    /// Orthogonal projection onto the plane.
    fn project(&self, p: &[f64; 3]) -> [f64; 3] {
        project(&self.plane, p)
    }
}

/// The support planes of all of `model`'s polygons ([`support_planes`], as the complex
/// uses them): the supports' planes (unit normals, oriented like their largest polygon)
/// and, per polygon, its support and whether it faces against the support's orientation.
pub(crate) fn polygon_supports(model: &Model) -> (Vec<Plane>, Vec<(usize, bool)>) {
    let all: Vec<PolygonId> = (0..model.polygons.len() as u32).map(PolygonId).collect();
    let (supports, of) = support_planes(model, &all, &model.tolerances);
    (supports.into_iter().map(|s| s.plane).collect(), of)
}

/// The finite tetrahedra around each vertex of `tet`, as offsets into one list (vertex
/// `v`'s are `list[start[v]..start[v + 1]]`, ascending).
fn tet_stars(tet: &Tetrahedralization) -> (Vec<u32>, Vec<u32>) {
    let nv = tet.num_vertices();
    let mut start = vec![0u32; nv + 1];
    for (_, vs) in tet.tets() {
        for v in vs {
            start[v.idx() + 1] += 1;
        }
    }
    for i in 0..nv {
        start[i + 1] += start[i];
    }
    let mut fill = start[..nv].to_vec();
    let mut list = vec![0u32; start[nv] as usize];
    for (t, vs) in tet.tets() {
        for v in vs {
            list[fill[v.idx()] as usize] = t.0;
            fill[v.idx()] += 1;
        }
    }
    (start, list)
}

/// A polygon's plane triple (indices into its canonical cycle), its plane and its bucket
/// key in [`support_planes`].
type PlaneOf = ((usize, usize, usize), Plane, [i64; 4]);

/// Groups polygons whose vertices all lie within [`crate::Tolerances::coplanar_abs`] of a
/// larger polygon's plane (either orientation). Returns the supports and, per polygon,
/// its support and whether it faces against the support's orientation. Hash buckets on
/// (normal, offset) keep this near linear.
fn support_planes(model: &Model, pending: &[PolygonId], tol: &crate::Tolerances) -> (Vec<Support>, Vec<(usize, bool)>) {
    let tolc = tol.coplanar_abs();
    // Each polygon from its canonical start, and the largest first, ties in geometric
    // order: the supports do not depend on face order or face starts.
    let cycles: Vec<Vec<[f64; 3]>> = pending
        .par_iter()
        .with_min_len(256)
        .map(|&p| canonical_cycle(model, p))
        .collect();
    let mut order: Vec<usize> = (0..pending.len()).collect();
    let areas: Vec<f64> = cycles
        .par_iter()
        .with_min_len(256)
        .map(|c| ConvexPolygon::new(c.clone()).area())
        .collect();
    // A total order (ties by index), so the parallel sort gives the one order.
    order.par_sort_by(|&a, &b| {
        areas[b]
            .total_cmp(&areas[a])
            .then_with(|| cmp_cycles(&cycles[a], &cycles[b]))
            .then(a.cmp(&b))
    });
    let mut supports: Vec<Support> = Vec::new();
    let mut buckets: HashMap<[i64; 4], Vec<usize>, FxBuild> = HashMap::default();
    let mut of = vec![(0usize, false); pending.len()];
    // Buckets: normal in steps of 1/64, offset (measured from the model's centre, so a
    // slight tilt is not amplified by the distance to the origin) in steps of scale/64.
    // Neighbouring buckets are searched; the exact test is the vertex-distance check.
    let (lo, hi) = model.bbox();
    let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0, (lo[2] + hi[2]) / 2.0];
    let dstep = tol.scale / 64.0;
    let key = |n: [f64; 3], d: f64| -> [i64; 4] {
        let dc = d - (n[0] * centre[0] + n[1] * centre[1] + n[2] * centre[2]);
        [
            (n[0] * 64.0).round() as i64,
            (n[1] * 64.0).round() as i64,
            (n[2] * 64.0).round() as i64,
            (dc / dstep).round() as i64,
        ]
    };
    // Each polygon's plane (from its plane triple) and bucket, on every core.
    let planes: Vec<PlaneOf> = cycles
        .par_iter()
        .with_min_len(256)
        .map(|v| {
            let (i, j, l) = plane_triple(v);
            let plane = Plane::from_points(&v[i], &v[j], &v[l]).normalized();
            // Canonical orientation for bucketing: largest normal component positive.
            let n = plane.n;
            let a = (0..3).max_by(|&x, &y| n[x].abs().total_cmp(&n[y].abs())).unwrap_or(2);
            let s = if n[a] < 0.0 { -1.0 } else { 1.0 };
            let (cn, cd) = ([n[0] * s, n[1] * s, n[2] * s], plane.d * s);
            ((i, j, l), plane, key(cn, cd))
        })
        .collect();
    // The supports a polygon of bucket `b` may join, in the order they are tried: the 81
    // buckets around `b` (offsets -1..=1 in each of the four coordinates, the last
    // fastest), each bucket's supports in the order they were made.
    let near_keys = |b: [i64; 4]| {
        (0..81i64).map(move |o| {
            [
                b[0] + o / 27 - 1,
                b[1] + o / 9 % 3 - 1,
                b[2] + o / 3 % 3 - 1,
                b[3] + o % 3 - 1,
            ]
        })
    };
    let around = |b: [i64; 4], buckets: &HashMap<[i64; 4], Vec<usize>, FxBuild>| -> Vec<usize> {
        near_keys(b)
            .filter_map(|n| buckets.get(&n))
            .flatten()
            .copied()
            .collect()
    };
    // `around` of each bucket key met so far, dropped when a support is added to one of
    // its 81 buckets: most polygons share their key with many others.
    let mut near: HashMap<[i64; 4], Vec<usize>, FxBuild> = HashMap::default();
    // The polygon that founded each support (its own plane: projection moves none of
    // its vertices beyond rounding).
    let mut founder: Vec<usize> = Vec::new();
    for &k in &order {
        let pid = pending[k];
        let v = &cycles[k];
        let ((i, j, l), plane, base) = planes[k];
        let n = plane.n;
        let found = near
            .entry(base)
            .or_insert_with(|| around(base, &buckets))
            .iter()
            .find_map(|&si| {
                let sp = &supports[si].plane;
                v.iter().all(|p| sp.eval(p).abs() <= tolc).then(|| {
                    let agree = sp.n[0] * n[0] + sp.n[1] * n[1] + sp.n[2] * n[2] > 0.0;
                    (si, !agree)
                })
            });
        of[k] = match found {
            Some(f) => f,
            None => {
                let poly = &model.polygons[pid.idx()];
                let (start, n) = (canonical_start(model, pid), poly.verts.len());
                let id = |x: usize| poly.verts[(start + x) % n];
                supports.push(Support {
                    ids: [id(i), id(j), id(l)],
                    plane,
                });
                buckets.entry(base).or_default().push(supports.len() - 1);
                for n in near_keys(base) {
                    near.remove(&n);
                }
                founder.push(k);
                (supports.len() - 1, false)
            }
        };
    }
    // Seams. Projecting a polygon onto a shared support moves its vertices by up to
    // `coplanar`; a polygon through the same vertex on another support keeps it where its
    // own support puts it, so the two occluders no longer meet along their shared edge:
    // a crack of height `gap` (the distance between the vertex's two projections). Across
    // two supports at dihedral angle θ the crack's wedge reaches gap / sin θ into the
    // cells between the two planes; beyond the sliver width its openings are portals, and
    // a cell between the two planes (behind one, in front of the other) then holds both
    // sides of the surface, joined through the crack inside it (caverns-7 under noise
    // 1e-4: supports 0.22° apart, gap 5.9e-6, wedge 1.5e-3 wide). Unless the two planes
    // stay within the sliver width of each other over both polygons (a cell holding the
    // crack there is a membrane, as between the two triangles of a noisy quad), such a
    // polygon keeps its own plane instead (it then moves no vertex); repeated until no
    // seam opens that way.
    let sliver = tol.sliver_width();
    // The polygons at each vertex (ascending), as offsets into one list.
    let (vstart, vpolys) = {
        let mut start = vec![0u32; model.vertices.len() + 1];
        for &p in pending {
            for v in &model.polygons[p.idx()].verts {
                start[v.idx() + 1] += 1;
            }
        }
        for i in 0..model.vertices.len() {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut list = vec![0u32; start[model.vertices.len()] as usize];
        for (k, &p) in pending.iter().enumerate() {
            for v in &model.polygons[p.idx()].verts {
                list[fill[v.idx()] as usize] = k as u32;
                fill[v.idx()] += 1;
            }
        }
        (start, list)
    };
    let by_vertex = |v: VertexId| &vpolys[vstart[v.idx()] as usize..vstart[v.idx() + 1] as usize];
    // Distance between the projections of `y` onto two planes.
    let apart = |a: &Plane, b: &Plane, y: &[f64; 3]| {
        let (da, db) = (a.eval(y), b.eval(y));
        let g = [0, 1, 2].map(|i| da * a.n[i] - db * b.n[i]);
        (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt()
    };
    loop {
        // In the geometric order, so that the new supports' ids do not depend on face order.
        // Decided on every core (read only), kept in that order.
        let eject: Vec<usize> = order
            .par_iter()
            .with_min_len(256)
            .copied()
            .filter(|&k| {
                let s = of[k].0;
                if founder[s] == k {
                    return false;
                }
                let sp = &supports[s].plane;
                model.polygons[pending[k].idx()].verts.iter().any(|v| {
                    let x = model.vertices[v.idx()];
                    if sp.eval(&x).abs() <= tol.plane_abs() {
                        return false;
                    }
                    by_vertex(*v).iter().any(|&o| {
                        let o = o as usize;
                        let so = of[o].0;
                        if so == s {
                            return false;
                        }
                        let op = &supports[so].plane;
                        let c = sp.n[0] * op.n[0] + sp.n[1] * op.n[1] + sp.n[2] * op.n[2];
                        let sin = (1.0 - c * c).max(0.0).sqrt();
                        apart(sp, op, &x) > sin * sliver
                            && [k, o]
                                .iter()
                                .flat_map(|&q| model.polygons[pending[q].idx()].verts.iter())
                                .any(|w| apart(sp, op, &model.vertices[w.idx()]) > sliver)
                    })
                })
            })
            .collect();
        if eject.is_empty() {
            break;
        }
        for k in eject {
            let pid = pending[k];
            let ((i, j, l), plane, _) = planes[k];
            let poly = &model.polygons[pid.idx()];
            let (start, n) = (canonical_start(model, pid), poly.verts.len());
            let id = |x: usize| poly.verts[(start + x) % n];
            supports.push(Support {
                ids: [id(i), id(j), id(l)],
                plane,
            });
            founder.push(k);
            of[k] = (supports.len() - 1, false);
        }
    }
    (supports, of)
}

/// The order polygons are placed in: placement order matters (a refused cut, a sealed
/// crack), so it is the polygons' geometric order, not their order in the file.
fn placement_order(model: &Model, pending: Vec<PolygonId>) -> Vec<PolygonId> {
    // The cycles of the pending polygons only (a few percent of a large model's).
    let mut keyed: Vec<(Vec<[f64; 3]>, PolygonId)> = pending
        .into_par_iter()
        .with_min_len(256)
        .map(|p| (canonical_cycle(model, p), p))
        .collect();
    // A total order (ties by id), so the parallel sort gives the one order.
    keyed.par_sort_by(|a, b| cmp_cycles(&a.0, &b.0).then(a.1.cmp(&b.1)));
    keyed.into_iter().map(|(_, p)| p).collect()
}

/// Lexicographic order of points (coordinates compared by `total_cmp`).
fn cmp_points(a: &[f64; 3], b: &[f64; 3]) -> std::cmp::Ordering {
    a[0].total_cmp(&b[0])
        .then(a[1].total_cmp(&b[1]))
        .then(a[2].total_cmp(&b[2]))
}

/// The position in polygon `p`'s vertex list of its lexicographically smallest vertex
/// (by coordinates; the first such on ties): where the complex starts walking the polygon,
/// so that a polygon's rotated start or renumbered vertices change nothing.
fn canonical_start(model: &Model, p: PolygonId) -> usize {
    let v = &model.polygons[p.idx()].verts;
    (0..v.len())
        .min_by(|&a, &b| cmp_points(&model.vertices[v[a].idx()], &model.vertices[v[b].idx()]).then(a.cmp(&b)))
        .unwrap_or(0)
}

/// [`canonical_cycle`] without the straight-angle vertices ([`Model::is_corner`]): the
/// same region, as the splitting clips it.
fn corner_cycle(model: &Model, p: PolygonId) -> Vec<[f64; 3]> {
    let v = &model.polygons[p.idx()].verts;
    let s = canonical_start(model, p);
    (0..v.len())
        .map(|k| (s + k) % v.len())
        .filter(|&k| model.is_corner(p.idx(), k))
        .map(|k| model.vertices[v[k].idx()])
        .collect()
}

/// Polygon `p`'s vertex coordinates in cyclic order from [`canonical_start`].
fn canonical_cycle(model: &Model, p: PolygonId) -> Vec<[f64; 3]> {
    let v = &model.polygons[p.idx()].verts;
    let s = canonical_start(model, p);
    (0..v.len())
        .map(|k| model.vertices[v[(s + k) % v.len()].idx()])
        .collect()
}

/// Lexicographic order of canonical cycles (point by point, then length): the order in
/// which polygons are placed, independent of the input's face order.
fn cmp_cycles(a: &[[f64; 3]], b: &[[f64; 3]]) -> std::cmp::Ordering {
    a.iter()
        .zip(b)
        .map(|(p, q)| cmp_points(p, q))
        .find(|o| o.is_ne())
        .unwrap_or(a.len().cmp(&b.len()))
}

/// Indices of three polygon vertices spanning the largest-area triangle among those with
/// the first vertex, the vertex farthest from it, and any third.
fn plane_triple(v: &[[f64; 3]]) -> (usize, usize, usize) {
    let d2 = |a: &[f64; 3], b: &[f64; 3]| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>();
    let j = (1..v.len())
        .max_by(|&x, &y| d2(&v[0], &v[x]).total_cmp(&d2(&v[0], &v[y])))
        .unwrap_or(1);
    let area = |k: usize| {
        let (a, b, c) = (v[0], v[j], v[k]);
        let (u, w) = (
            [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
            [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
        );
        let x = [
            u[1] * w[2] - u[2] * w[1],
            u[2] * w[0] - u[0] * w[2],
            u[0] * w[1] - u[1] * w[0],
        ];
        x[0] * x[0] + x[1] * x[1] + x[2] * x[2]
    };
    let k = (1..v.len())
        .filter(|&k| k != j)
        .max_by(|&x, &y| area(x).total_cmp(&area(y)))
        .unwrap_or(2);
    // Keep the polygon's winding: the triple must appear in cyclic order 0 < j < k or 0 < k < j.
    if j < k { (0, j, k) } else { (0, k, j) }
}

fn aabb(v: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    crate::model::bbox_of(v.iter())
}

/// The polygon clipped to the closed cell (by every face plane), or `None`.
fn clip_to_cell(polygon: &ConvexPolygon, cell: &ConvexPolyhedron, tol: &crate::Tolerances) -> Option<ConvexPolygon> {
    let mut cur = polygon.clone();
    for f in cell.planes() {
        // Keep the part behind each outward face plane.
        let (_, back) = cur.split(&f, tol);
        cur = back?;
    }
    Some(cur)
}

/// Per-polygon search state: visit marks and the tetrahedron → live cells map.
struct Placer {
    queue: VecDeque<CellId>,
    marks: Vec<u32>,
    epoch: u32,
    /// Live cells descending from each tetrahedron (only for split tetrahedra).
    descendants: HashMap<TetId, Vec<CellId>, FxBuild>,
    /// One tetrahedron incident to each vertex.
    vertex_tet: Vec<u32>,
    /// Polygons that straddled a descendant of the tetrahedron without splitting it.
    deferred: HashMap<TetId, Vec<PolygonId>, FxBuild>,
}

impl Placer {
    fn new(tet: &Tetrahedralization, ncells: usize) -> Self {
        let mut vertex_tet = vec![u32::MAX; tet.points().len()];
        for (t, v) in tet.tets() {
            for x in v {
                vertex_tet[x.idx()] = t.0;
            }
        }
        Placer {
            queue: VecDeque::new(),
            marks: vec![0; ncells],
            epoch: 0,
            descendants: HashMap::default(),
            vertex_tet,
            deferred: HashMap::default(),
        }
    }

    fn defer(&mut self, t: TetId, p: PolygonId) {
        let list = self.deferred.entry(t).or_default();
        if list.last() != Some(&p) {
            list.push(p);
        }
    }

    /// Live cells descending from tetrahedron `t`.
    fn live_cells(&self, t: TetId, cells: &[Cell]) -> Vec<CellId> {
        match self.descendants.get(&t) {
            Some(list) => list.iter().copied().filter(|c| cells[c.idx()].alive).collect(),
            None => vec![CellId(t.0)],
        }
    }

    /// Marks a cell for this epoch; true if it was not marked yet.
    fn mark(&mut self, c: CellId, epoch: u32) -> bool {
        if c.idx() >= self.marks.len() {
            self.marks.resize(c.idx() + 1, 0);
        }
        let m = &mut self.marks[c.idx()];
        if *m == epoch {
            false
        } else {
            *m = epoch;
            true
        }
    }

    /// Queues `c` unless marked for this epoch (then marks it).
    fn queue_new(&mut self, c: CellId, epoch: u32) {
        if self.mark(c, epoch) {
            self.queue.push_back(c);
        }
    }

    fn on_split(&mut self, c: CellId, f: CellId, b: CellId, cells: &[Cell]) {
        let t = cells[c.idx()].tet.expect("a tetrahedron's cell");
        let list = self.descendants.entry(t).or_insert_with(|| vec![CellId(t.0)]);
        list.retain(|&x| x != c);
        list.push(f);
        list.push(b);
    }

    /// Live cells around vertex `v`: the descendants of the tetrahedra in its star.
    fn seed_cells(&self, tet: &Tetrahedralization, v: VertexId, cells: &[Cell]) -> Vec<CellId> {
        let v = tet.representative(v.idx());
        let start = self.vertex_tet[v.idx()];
        let mut out = Vec::new();
        if start == u32::MAX {
            return out;
        }
        let mut seen: HashSet<u32, FxBuild> = HashSet::default();
        let mut stack = vec![start];
        seen.insert(start);
        while let Some(t) = stack.pop() {
            match self.descendants.get(&TetId(t)) {
                Some(list) => out.extend(list.iter().copied().filter(|c| cells[c.idx()].alive)),
                None => out.push(CellId(t)),
            }
            let vs = tet.tet(TetId(t));
            for i in 0..4 {
                if vs[i] == v {
                    continue; // the face opposite v does not contain v
                }
                if let Some((n, _)) = tet.neighbor(TetId(t), i)
                    && seen.insert(n.0)
                {
                    stack.push(n.0);
                }
            }
        }
        let _ = FACE_SLOTS;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::super::Shape;
    use super::*;

    /// A section whose area in its cutting plane is below the subtraction's threshold,
    /// though its 3D area (from a vertex off the plane within the On band) is above it, is
    /// not covered by a polygon over it: the subtraction returns no pieces for it, which
    /// read as "covered" (a BSP fuzz case, seed 26 case 23617: "model polygon 14 crosses
    /// the interior of cell 88 (crossing area 3.788e-13)" once coverage was measured in
    /// the plane).
    #[test]
    fn a_section_degenerate_in_its_plane_is_not_covered() {
        let tol = crate::Tolerances::for_scale(1.0);
        let relaxed = tol.sealing();
        let n = [0.0, 0.0, 1.0];
        let section = ConvexPolygon::new(vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 1e-15, 1e-7]]);
        assert!(section.area() >= relaxed.area_abs(), "3D area {:e}", section.area());
        assert!(section.area_along(&n) < relaxed.area_abs());
        let wall = ConvexPolygon::new(vec![
            [-1.0, -1.0, 0.0],
            [2.0, -1.0, 0.0],
            [2.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ]);
        let (sa, open) = section_open(&section, &n, &[wall], &relaxed, &tol);
        let open_area: f64 = open.iter().map(|(a, _)| a).sum();
        assert!(open.iter().all(|&(_, sliver)| sliver));
        assert!(!(sa - open_area >= 0.5 * sa && sa - open_area > 0.0), "{sa:e} {open:?}");
    }

    /// The tetrahedra around each vertex are exactly those that have it, ascending.
    #[test]
    fn tet_stars_list_each_tetrahedron_at_its_four_vertices() {
        let soup = crate::generate::scenes::two_rooms();
        let m = crate::model::from_soup("t", soup.vertices, soup.polygons).expect("model");
        let tet = Tetrahedralization::build(&m.vertices).expect("tetrahedralization");
        let (start, list) = tet_stars(&tet);
        assert_eq!(start.len(), tet.num_vertices() + 1);
        assert_eq!(list.len(), 4 * tet.num_tets());
        for v in 0..tet.num_vertices() {
            let star = &list[start[v] as usize..start[v + 1] as usize];
            let want: Vec<u32> = tet
                .tets()
                .filter(|(_, vs)| vs.iter().any(|w| w.idx() == v))
                .map(|(t, _)| t.0)
                .collect();
            assert_eq!(star, &want[..], "vertex {v}");
        }
    }

    /// The splitting stage by dry runs on every core, in batches of any size, leaves the
    /// complex (cells, patches with their occluders, counters) and the deferred crossings
    /// exactly as the serial search polygon after polygon does, on models where some
    /// polygons split cells (a dry run gives up) and others do not (it is applied): a
    /// stale dry run applied after a split would differ.
    #[test]
    fn dry_runs_place_as_the_serial_search_does() {
        let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
        let mut models: Vec<Model> = Vec::new();
        let (grid, _) = crate::generate::scenes::room_grid(3, 2, 3);
        models.push(crate::model::from_soup("grid", grid.vertices.clone(), grid.polygons.clone()).unwrap());
        // The grid turned 7, 8 and 9 degrees: its walls no longer lie on tetrahedron faces.
        let turned: Vec<[f64; 3]> = grid
            .vertices
            .iter()
            .map(|&v| crate::base::rigid::rotate_789(v))
            .collect();
        models.push(crate::model::from_soup("turned", turned, grid.polygons).unwrap());
        for name in ["noisy", "four_room_distorted", "caverns_rotated"] {
            let path = root.join(format!("models/thesis/{name}.obj"));
            models.push(crate::model::load_model(&path).unwrap());
        }
        let (mut gave_up, mut applied, mut splits) = (0, 0, 0);
        for m in &models {
            let tet = Tetrahedralization::build(&m.vertices).expect("tetrahedralization");
            let mut start = CellComplex::from_tets(m, &tet);
            let (supports, of, pending) = start.conform(m, &tet);
            let pending = placement_order(m, pending);
            let placer = Placer::new(&tet, start.cells.len());
            for &p in &pending {
                let (s, flipped) = of[p.idx()];
                match start.dry_place(m, &tet, &placer, p, &supports[s], flipped) {
                    Some(_) => applied += 1,
                    None => gave_up += 1,
                }
            }
            let place = |batches: Option<(usize, usize)>| {
                let mut cx = start.clone();
                let mut pl = Placer::new(&tet, cx.cells.len());
                cx.place_pending(m, &tet, &mut pl, &pending, (&supports, &of), batches, &mut |_, _, _| {});
                let mut deferred: Vec<_> = pl.deferred.into_iter().collect();
                deferred.sort();
                let mut stats = cx.stats.clone();
                stats.timings.clear();
                (
                    format!("{:?}\n{:?}\n{:?}\n{:?}", cx.cells, cx.patches, stats, deferred),
                    cx.stats.cells_split,
                )
            };
            let (serial, split) = place(None);
            splits += split;
            for batches in [(1, 1), (2, 8), (5, 5), DRY_BATCHES] {
                assert!(
                    place(Some(batches)) == (serial.clone(), split),
                    "{}: batches {batches:?}",
                    m.name
                );
            }
        }
        assert!(gave_up > 0 && applied > 0 && splits > 0, "{gave_up} {applied} {splits}");
    }

    /// Stage 2 attaches a polygon exactly when the reference does: a map from every patch's
    /// vertex triple to the patch (the map stage 2 used to build), the first fan whose
    /// triangles are all patches beside no flat tetrahedron. On room grids (tessellated
    /// walls, T-junctions), the thesis models and the two rooms: the same polygons
    /// conforming, the same left for stage 3, and each patch's occluders from the same
    /// polygons in the same order.
    #[test]
    fn conforming_polygons_are_those_the_map_of_patch_triangles_finds() {
        let mut soups = vec![
            crate::generate::scenes::room_grid(3, 2, 2).0,
            crate::generate::scenes::room_grid(2, 2, 3).0,
            crate::generate::scenes::two_rooms(),
        ];
        for name in [
            "four_room_optimized",
            "four_room_tessellated",
            "four_room_distorted",
            "noisy",
        ] {
            soups.push(crate::generate::thesis::by_name(name).unwrap().soup);
        }
        let mut conforming_seen = 0;
        for soup in soups {
            let m = crate::model::from_soup("t", soup.vertices, soup.polygons).expect("model");
            let tet = Tetrahedralization::build(&m.vertices).expect("tetrahedralization");
            let mut cx = CellComplex::from_tets(&m, &tet);
            let all: Vec<PolygonId> = (0..m.polygons.len() as u32).map(PolygonId).collect();
            let (supports, of) = support_planes(&m, &all, &cx.tol);
            let on_support: Vec<bool> = m
                .polygons
                .iter()
                .zip(&of)
                .map(|(p, &(s, _))| {
                    let [a, b, c] = supports[s].ids.map(|v| tet.point(v));
                    p.verts.iter().all(|v| orient3d(a, b, c, tet.point(*v)) == 0)
                })
                .collect();
            // The reference.
            let key = |t: [u32; 3]| {
                let mut k = t;
                k.sort_unstable();
                k
            };
            let mut by_key: HashMap<[u32; 3], PatchId> = HashMap::new();
            for (pi, p) in cx.patches.iter().enumerate() {
                let t = p.cells[0];
                let i = cx.cells[t.idx()].tags().iter().position(|&x| x == pi as u32).unwrap();
                by_key.insert(key(tet.face(TetId(t.0), i).map(|v| v.0)), PatchId(pi as u32));
            }
            let mut want_sources: Vec<Vec<PolygonId>> = vec![Vec::new(); cx.patches.len()];
            let mut want_pending = Vec::new();
            for (k, poly) in m.polygons.iter().enumerate() {
                let n = poly.verts.len();
                let fan = |s: usize| -> Option<Vec<PatchId>> {
                    (1..n - 1)
                        .map(|j| {
                            let t = [
                                poly.verts[s].0,
                                poly.verts[(s + j) % n].0,
                                poly.verts[(s + j + 1) % n].0,
                            ];
                            let p = *by_key.get(&key(t))?;
                            cx.patches[p.idx()]
                                .cells
                                .iter()
                                .all(|&c| c == HULL || !cx.cells[c.idx()].flat)
                                .then_some(p)
                        })
                        .collect()
                };
                let starts = if n > 3 { 2 } else { 1 };
                match (0..starts).find_map(|s| on_support[k].then(|| fan(s)).flatten()) {
                    Some(ps) => ps
                        .into_iter()
                        .for_each(|p| want_sources[p.idx()].push(PolygonId(k as u32))),
                    None => want_pending.push(PolygonId(k as u32)),
                }
            }
            let pending = cx.attach_conforming(&m, &tet, &on_support);
            assert_eq!(pending, want_pending);
            for (k, &c) in cx.conforming.iter().enumerate() {
                assert_eq!(c, !want_pending.contains(&PolygonId(k as u32)), "polygon {k}");
            }
            for (pi, p) in cx.patches.iter().enumerate() {
                let got: Vec<PolygonId> = p.occluders.iter().map(|o| o.source).collect();
                assert_eq!(got, want_sources[pi], "patch {pi}");
            }
            conforming_seen += cx.conforming.iter().filter(|&&c| c).count();
        }
        assert!(conforming_seen > 100, "{conforming_seen} conforming polygons");
    }

    /// Uncut tetrahedra stay implicit, and everything read from one has the bits of its
    /// materialised polyhedron; `validate` checks their faces against their patches and
    /// refuses one whose face loop starts elsewhere.
    #[test]
    fn implicit_tetrahedra_read_as_their_polyhedra_and_are_validated() {
        for soup in [
            crate::generate::four_rooms::four_rooms(),
            crate::generate::scenes::two_rooms(),
        ] {
            let m = crate::model::from_soup("t", soup.vertices, soup.polygons).expect("model");
            let mut cx = crate::pipeline::complex_of_unchecked(&m).expect("complex");
            cx.validate(&m).expect("valid");
            let implicit: Vec<usize> = (0..cx.cells.len())
                .filter(|&i| cx.cells[i].alive && cx.cells[i].tet_shape().is_some())
                .collect();
            let explicit = cx.cells.iter().filter(|c| c.alive && c.tet_shape().is_none()).count();
            assert!(
                implicit.len() > 10 * explicit.max(1),
                "{} implicit, {explicit} explicit",
                implicit.len()
            );
            for &i in &implicit {
                let c = &cx.cells[i];
                let p = c.poly();
                assert_eq!(c.volume().to_bits(), p.volume().to_bits());
                assert_eq!(c.centroid().map(f64::to_bits), p.centroid().map(f64::to_bits));
                assert_eq!(c.surface_area().to_bits(), p.surface_area().to_bits());
                assert_eq!(c.aabb(), p.aabb());
                assert_eq!(c.vertices(), p.vertices());
                assert_eq!(c.tags(), &p.tags[..]);
                assert!(c.faces().iter().zip(&p.faces).all(|(a, b)| a == b));
                assert!(c.faces_cow().zip(&p.faces).all(|(a, b)| *a == *b));
                // Materialising changes nothing but the form.
                let mut d = c.clone();
                assert_eq!(*d.poly_mut(), *p);
                assert!(d.tet_shape().is_none());
            }
            let i = implicit[implicit.len() / 2];
            if let Shape::Tet(t) = &mut cx.cells[i].shape {
                t.start[0] = (t.start[0] + 1) % 3;
            }
            let e = cx.validate(&m).unwrap_err().to_string();
            assert!(
                e.contains("implicit tetrahedron's face is not its patch's polygon"),
                "{e}"
            );
        }
    }

    #[test]
    fn canonical_cycle_ignores_face_start_and_vertex_numbering() {
        let v = vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        let faces = vec![vec![0, 1, 2], vec![3, 1, 0], vec![2, 1, 3], vec![0, 2, 3]];
        let m = crate::model::from_soup("t", v.clone(), faces.clone()).expect("tetrahedron");
        // The same tetrahedron, vertices renumbered and faces rotated and reordered.
        let perm = [2usize, 0, 3, 1];
        let mut v2 = vec![[0.0; 3]; 4];
        for (i, &j) in perm.iter().enumerate() {
            v2[j] = v[i];
        }
        let faces2: Vec<Vec<u32>> = faces
            .iter()
            .rev()
            .enumerate()
            .map(|(k, f)| {
                let mut f: Vec<u32> = f.iter().map(|&x| perm[x as usize] as u32).collect();
                f.rotate_left(k % 3);
                f
            })
            .collect();
        let m2 = crate::model::from_soup("t", v2, faces2).expect("tetrahedron");
        let sorted = |m: &Model| {
            let mut c: Vec<Vec<[f64; 3]>> = (0..m.polygons.len() as u32)
                .map(|k| canonical_cycle(m, PolygonId(k)))
                .collect();
            c.sort_by(|a, b| cmp_cycles(a, b));
            c
        };
        assert_eq!(sorted(&m), sorted(&m2));
        // Each cycle starts at its smallest vertex; the order is lexicographic.
        let c = sorted(&m);
        assert!(c.iter().all(|f| f.iter().all(|p| cmp_points(&f[0], p).is_le())));
        assert!(c.windows(2).all(|w| cmp_cycles(&w[0], &w[1]).is_lt()));
        assert_eq!(cmp_cycles(&c[0][..2], &c[0]), std::cmp::Ordering::Less);
    }
}
