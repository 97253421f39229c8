//! Stages 5–6: portal graph (patch minus occluders, joins across flat cells) and exterior
//! flood fill.

use super::{CellComplex, HULL, Leak, PatchId, Pieces, Portal};
use crate::geom::ConvexPolygon;
use crate::ids::CellId;
use rayon::prelude::*;
use std::collections::{HashMap, VecDeque};
use std::rc::Rc;

/// The open pieces of the patches the walks through flat cells met, by patch
/// ([`CellComplex::open_pieces`], computed once each; shared with the walk that reads them).
type OpenMemo = HashMap<u32, Rc<Vec<ConvexPolygon>>>;

/// The portal of each cell pair, by (lower id, higher id): looked up only, never iterated,
/// so its hasher (Fx, a multiply per id, instead of SipHash: millions of pairs at a million
/// triangles) changes nothing but time.
/// The portal of each cell pair, found from the pair's smaller cell: a list per cell
/// threaded through the portals (`first[cell]`, then `next[portal]`; `u32::MAX` ends a
/// list). Patch ids follow the tetrahedra, so the pairs' smaller cells come nearly in
/// order and a lookup reads memory the previous ones touched (a hash map of the 3M pairs
/// of a million triangles cost a cache miss per patch, half of this stage's time).
struct PairIndex {
    first: Vec<u32>,
    next: Vec<u32>,
}

impl PairIndex {
    fn new(cells: usize, portals: usize) -> Self {
        PairIndex {
            first: vec![u32::MAX; cells],
            next: Vec::with_capacity(portals),
        }
    }

    /// The portal of pair `key` (smaller id first) in `portals`, if any.
    fn get(&self, portals: &[Portal], key: (CellId, CellId)) -> Option<usize> {
        let mut k = self.first[key.0.idx()];
        while k != u32::MAX {
            if portals[k as usize].cells[1] == key.1 {
                return Some(k as usize);
            }
            k = self.next[k as usize];
        }
        None
    }

    /// Files portal `k`, the next one (`k` = the number filed so far), under its pair's
    /// smaller cell `a`.
    fn insert(&mut self, a: CellId, k: usize) {
        debug_assert_eq!(k, self.next.len());
        self.next.push(self.first[a.idx()]);
        self.first[a.idx()] = k as u32;
    }
}

/// What [`CellComplex::graph`] computes: the fields [`CellComplex::build_graph`] sets.
pub(crate) struct Graph {
    portals: Vec<Portal>,
    cracks: Vec<Portal>,
    hull_through: Vec<(CellId, [f64; 3])>,
    slivers: usize,
    sliver_area: f64,
}

/// A portal's pieces between cells `a` and `b`, oriented from the smaller id to the larger
/// (the key of the pair: the pieces reversed in place when `a > b`, the vertices of
/// [`ConvexPolygon::reversed`]), each with its area.
fn oriented(a: CellId, b: CellId, mut pieces: Vec<ConvexPolygon>) -> ((CellId, CellId), Vec<(ConvexPolygon, f64)>) {
    let key = if a < b {
        (a, b)
    } else {
        for p in &mut pieces {
            if p.verts.len() > 1 {
                p.verts[1..].reverse();
            }
        }
        (b, a)
    };
    let pieces = pieces
        .into_iter()
        .map(|p| {
            let area = p.area();
            (p, area)
        })
        .collect();
    (key, pieces)
}

/// Patches per block of the portal graph's parallel subtraction (see `build_graph`).
const GRAPH_BLOCK: usize = 1 << 14;

pub(super) fn perimeter(p: &ConvexPolygon) -> f64 {
    let n = p.verts.len();
    (0..n)
        .map(|i| {
            let (a, b) = (p.verts[i], p.verts[(i + 1) % n]);
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        })
        .sum()
}

/// A crack: a polygon below the area tolerance or narrower (twice the area over the
/// perimeter) than [`crate::Tolerances::sliver_width`]. Portal pieces like this are
/// discarded; cross-sections whose uncovered part is only cracks are sealed by splitting.
pub(super) fn is_sliver(q: &ConvexPolygon, tol: &crate::Tolerances) -> bool {
    let a = q.area();
    a < tol.area_abs() || 2.0 * a < tol.sliver_width() * perimeter(q)
}

/// Portal adjacency in compressed rows: cell `c`'s (neighbour, portal index) pairs are
/// `adj[c.idx()]`, in portal order, as in [`CellComplex::adjacency`].
#[derive(Clone, Debug, Default)]
pub struct Adjacency {
    /// Where each cell's row starts in `links` (one more entry than cells).
    first: Vec<usize>,
    links: Vec<(CellId, usize)>,
}

impl std::ops::Index<usize> for Adjacency {
    type Output = [(CellId, usize)];
    fn index(&self, c: usize) -> &[(CellId, usize)] {
        &self.links[self.first[c]..self.first[c + 1]]
    }
}

/// A portal piece joining two cells across flat cells, oriented from the first to the second.
type Link = (CellId, CellId, ConvexPolygon);

/// The crack links of [`CellComplex::cracks`] before the region test: the sliver openings
/// (`dropped`) between cell pairs that no portal joins (`by_pair`), grouped per pair and
/// oriented from the smaller cell id to the larger, in a fixed order.
fn crack_links(by_pair: &PairIndex, portals: &[Portal], dropped: Vec<Link>) -> Vec<Portal> {
    let mut cracks: std::collections::BTreeMap<(CellId, CellId), Portal> = Default::default();
    for (a, b, q) in dropped {
        let (key, q) = if a < b { ((a, b), q) } else { ((b, a), q.reversed()) };
        if by_pair.get(portals, key).is_some() {
            continue;
        }
        let p = cracks.entry(key).or_insert_with(|| Portal {
            cells: [key.0, key.1],
            pieces: Pieces::new(),
            area: 0.0,
        });
        p.area += q.area();
        p.pieces.push(q);
    }
    cracks.into_values().collect()
}

/// Area-weighted centroid of convex pieces (the first piece's centroid if all are empty).
fn area_centroid(pieces: &[ConvexPolygon]) -> [f64; 3] {
    crate::base::vec::weighted_mean(pieces.iter().map(|p| (p.area(), p.centroid())))
}

impl CellComplex {
    /// A cell that holds no space and is a membrane of the portal graph, not a node: a
    /// flat tetrahedron ([`super::Cell::flat`]), or a **slab thinner than the sliver
    /// width** — every vertex within [`crate::Tolerances::sliver_width`] of the plane of
    /// its largest face (e.g. the wedge between the support planes of the two triangles of
    /// one noisy floor quad). Such a cell is a crack: a path inside it, from where its
    /// upper face is open to where its lower face is open, runs along a step narrower
    /// than the sliver width that the portal graph would discard as a sliver if it were a
    /// portal. So, like a flat tetrahedron, it only joins the cells on its two sides over
    /// the overlap of their open faces (`through_flat`). Cells thinner than the sliver
    /// width in two directions (needles) have faces below the area tolerance or narrower
    /// than the sliver width, so their portals are slivers either way.
    pub fn is_membrane(&self, c: CellId) -> bool {
        let cell = &self.cells[c.idx()];
        if cell.flat {
            return true;
        }
        // Most tetrahedra are far thicker than the sliver width: no face needed to say so.
        if cell
            .tet_shape()
            .is_some_and(|t| t.surely_thicker_than(self.tol.sliver_width()))
        {
            return false;
        }
        let faces = cell.faces();
        let Some(big) = faces.iter().max_by(|a, b| a.area().total_cmp(&b.area())) else {
            return false;
        };
        let pl = big.plane().normalized();
        let w = self.tol.sliver_width();
        faces.iter().all(|f| f.verts.iter().all(|v| pl.eval(v).abs() < w))
    }

    /// Uncovered pieces of a patch: its polygon minus all occluders on it (either side).
    /// Returns (pieces, slivers, sliver area).
    /// Pieces below the area tolerance or narrower than [`crate::Tolerances::sliver_width`]
    /// are slivers: dropped and counted.
    pub fn open_pieces(&self, p: PatchId) -> (Vec<ConvexPolygon>, usize, f64) {
        let (keep, _, slivers, sliver_area) = self.open_and_sliver_pieces(p);
        (keep, slivers, sliver_area)
    }

    /// [`CellComplex::open_pieces`], also returning the sliver pieces it drops (those
    /// that the subtraction itself discards are only counted).
    fn open_and_sliver_pieces(&self, p: PatchId) -> (Vec<ConvexPolygon>, Vec<ConvexPolygon>, usize, f64) {
        let patch = &self.patches[p.idx()];
        let (pieces, mut slivers, mut sliver_area) = if patch.occluders.is_empty() {
            (vec![patch.polygon.clone()], 0, 0.0)
        } else {
            let holes: Vec<ConvexPolygon> = patch.occluders.iter().map(|o| o.polygon.clone()).collect();
            let s = patch.polygon.subtract(&holes, &self.tol);
            (s.pieces, s.slivers, s.sliver_area)
        };
        let mut keep = Vec::with_capacity(pieces.len());
        let mut dropped = Vec::new();
        for q in pieces {
            let a = q.area();
            if is_sliver(&q, &self.tol) {
                slivers += 1;
                sliver_area += a;
                if a > 0.0 && a.is_finite() {
                    dropped.push(q);
                }
            } else {
                keep.push(q);
            }
        }
        (keep, dropped, slivers, sliver_area)
    }

    /// Stage 5: portals between alive cells, grouped per cell pair.
    pub(crate) fn build_graph(&mut self) {
        let g = self.graph();
        self.set_graph(g);
    }

    /// Installs a graph [`CellComplex::graph`] computed.
    pub(crate) fn set_graph(&mut self, g: Graph) {
        self.cracks = g.cracks;
        self.hull_through = g.hull_through;
        self.portals = g.portals;
        self.stats.slivers_discarded = g.slivers;
        self.stats.sliver_area = g.sliver_area;
    }

    /// [`CellComplex::build_graph`]'s portals, cracks and hull joins, computed from the
    /// cells and patches only (so other readers of the complex can run beside it).
    pub(crate) fn graph(&self) -> Graph {
        let (mut slivers, mut sliver_area) = (0usize, 0.0f64);
        let membrane: Vec<bool> = (0..self.cells.len())
            .into_par_iter()
            .with_min_len(1024)
            .map(|i| self.cells[i].alive && self.is_membrane(CellId(i as u32)))
            .collect();
        let between = |pi: usize| {
            let patch = &self.patches[pi];
            let (a, b) = (patch.cells[0], patch.cells[1]);
            (patch.alive && b != HULL && self.cells[a.idx()].alive && self.cells[b.idx()].alive).then_some((a, b))
        };
        // The joins across membranes read only cells and patches; they are added after
        // the patches' portals, as before, but known first so that the portal list and
        // the pair map get their final size at once: grown by doubling, they would hold
        // up to twice their size, plus the old block while moving, at this stage's peak.
        let (links, hull) = self.through_flat(&membrane);
        let bound = (0..self.patches.len())
            .into_par_iter()
            .with_min_len(4096)
            .filter(|&pi| between(pi).is_some_and(|(a, b)| !membrane[a.idx()] && !membrane[b.idx()]))
            .count()
            + links.len();
        let mut by_pair = PairIndex::new(self.cells.len(), bound);
        let mut portals: Vec<Portal> = Vec::with_capacity(bound);
        // `pieces` oriented from `key.0` to `key.1` ([`oriented`]), each with its area.
        let mut add = |key: (CellId, CellId), pieces: Vec<(ConvexPolygon, f64)>| {
            let k = match by_pair.get(&portals, key) {
                Some(k) => k,
                None => {
                    portals.push(Portal {
                        cells: [key.0, key.1],
                        // Most pairs meet over one patch: held inline ([`Pieces`]).
                        pieces: Pieces::new(),
                        area: 0.0,
                    });
                    by_pair.insert(key.0, portals.len() - 1);
                    portals.len() - 1
                }
            };
            for (p, area) in pieces {
                portals[k].area += area;
                portals[k].pieces.push(p);
            }
        };
        // Sliver openings between two graph nodes, oriented from the first cell to the second.
        let mut dropped: Vec<Link> = Vec::new();
        // The subtraction per patch on every core (rayon), in blocks so that only one
        // block's pieces wait at a time; each block is consumed in patch order, so counts,
        // sums and portal order are those of one thread.
        for start in (0..self.patches.len()).step_by(GRAPH_BLOCK) {
            let block = start..(start + GRAPH_BLOCK).min(self.patches.len());
            // The pieces are also oriented and their areas taken here, on every core: the
            // sequential loop below only files them (the same polygons and sums as
            // orienting and measuring there).
            let open: Vec<_> = block
                .clone()
                .into_par_iter()
                .with_min_len(64)
                .map(|pi| {
                    between(pi).map(|(a, b)| {
                        let (pieces, sliver_pieces, s, sa) = self.open_and_sliver_pieces(PatchId(pi as u32));
                        // Whether a side is a membrane, read here too (random reads, which
                        // the sequential loop below then spares).
                        let flat = membrane[a.idx()] || membrane[b.idx()];
                        ((a, b, flat), oriented(a, b, pieces), sliver_pieces, s, sa)
                    })
                })
                .collect();
            for o in open {
                let Some(((a, b, flat), (key, pieces), sliver_pieces, s, sa)) = o else {
                    continue;
                };
                slivers += s;
                sliver_area += sa;
                // A membrane (flat or thinner than the sliver width) is not a room: see
                // `through_flat`.
                if flat {
                    continue;
                }
                dropped.extend(sliver_pieces.into_iter().map(|q| (a, b, q)));
                if !pieces.is_empty() {
                    add(key, pieces);
                }
            }
        }
        for (a, b, p) in links {
            let (key, pieces) = oriented(a, b, vec![p]);
            add(key, pieces);
        }
        Graph {
            cracks: crack_links(&by_pair, &portals, dropped),
            hull_through: hull,
            portals,
            slivers,
            sliver_area,
        }
    }

    /// Portals across membranes ([`CellComplex::is_membrane`]). A flat tetrahedron (four nearly coplanar input points)
    /// holds no space: the thesis (4.2.1) discards it, which glues its two sides together.
    /// As a node of the portal graph it would also join cells on the *same* side of it,
    /// through its zero-thickness body, e.g. the cells above and below a floor that meets
    /// the flat tetrahedron's plane. So it gets no portals of its own; instead each cell
    /// below it is joined to each cell above it over the overlap of their open faces
    /// (patch minus occluders on both sides), through stacks of flat cells if need be.
    /// Cells thinner than the sliver width are treated the same way: a wedge between two
    /// nearly coplanar occluders then conducts only where both of its sides are open.
    /// Returns the joins (oriented from the first cell to the second) and the cells that
    /// reach the hull this way, with a point there.
    fn through_flat(&self, membrane: &[bool]) -> (Vec<Link>, Vec<(CellId, [f64; 3])>) {
        let (mut links, mut hull) = (Vec::new(), Vec::new());
        let max_depth = membrane.iter().filter(|&&m| m).count() + 1;
        // A patch's open pieces are a function of the patch; the walks meet the same faces
        // again and again (every membrane of a stack from every cell below it: a real level's
        // overlapping floors spent 19 s subtracting the same occluders), so each is computed
        // once here.
        let mut open_of: OpenMemo = HashMap::new();
        for (f, cell) in self.alive_cells().filter(|(c, _)| membrane[c.idx()]) {
            let Some(n) = cell
                .faces()
                .iter()
                .max_by(|a, b| a.area().total_cmp(&b.area()))
                .map(|g| g.normal())
            else {
                continue;
            };
            for (t, _) in self.flat_faces(f, n, false) {
                let x = self.across(PatchId(t), f);
                if x != HULL && membrane[x.idx()] {
                    continue;
                }
                let open = self.open_cached(t, &mut open_of);
                self.rise(membrane, f, n, &open, x, max_depth, &mut links, &mut hull, &mut open_of);
            }
        }
        (links, hull)
    }

    /// [`CellComplex::open_pieces`] of patch `t`, once per patch in `memo`.
    fn open_cached(&self, t: u32, memo: &mut OpenMemo) -> Rc<Vec<ConvexPolygon>> {
        memo.entry(t)
            .or_insert_with(|| Rc::new(self.open_pieces(PatchId(t)).0))
            .clone()
    }

    /// Faces of flat cell `f` whose outward normal points along `n` (`up`) or against it,
    /// by more than 60°, with area above the tolerance: (patch tag, face index).
    fn flat_faces(&self, f: CellId, n: [f64; 3], up: bool) -> Vec<(u32, usize)> {
        let cell = &self.cells[f.idx()];
        cell.faces()
            .iter()
            .enumerate()
            .filter(|(_, g)| {
                let m = g.normal();
                let d = m[0] * n[0] + m[1] * n[1] + m[2] * n[2];
                (if up { d > 0.5 } else { d < -0.5 }) && g.area() >= self.tol.area_abs()
            })
            .map(|(i, _)| (cell.tags()[i], i))
            .collect()
    }

    /// Carries `region` (open pieces on the lower side of flat cell `f`, reached from cell
    /// `from` below) up through `f` to the cells above it, and on through stacks of
    /// membranes of any height (a stack of thin plates is one membrane per gap). A
    /// depth-first walk on an explicit stack, visiting faces in the order a recursion
    /// would: a stack of thousands of membranes must neither overflow the thread's stack
    /// nor be cut short (cutting it splits the room above from the room below). A walk
    /// longer than the number of membranes repeats a cell (membranes can overlap
    /// cyclically in depth, like three mutually overlapping triangles), so it stops there.
    #[allow(clippy::too_many_arguments)]
    fn rise(
        &self,
        membrane: &[bool],
        f: CellId,
        n: [f64; 3],
        region: &[ConvexPolygon],
        from: CellId,
        max_depth: usize,
        links: &mut Vec<Link>,
        hull: &mut Vec<(CellId, [f64; 3])>,
        open_of: &mut OpenMemo,
    ) {
        // Frames: (membrane, region reaching it, its faces up, next face to visit).
        let mut stack = vec![(f, region.to_vec(), self.flat_faces(f, n, true), 0usize)];
        while let Some(top) = stack.last_mut() {
            let (f, _, faces, next) = top;
            let Some(&(t, _)) = faces.get(*next) else {
                stack.pop();
                continue;
            };
            *next += 1;
            let f = *f;
            let z = self.across(PatchId(t), f);
            let open = self.open_cached(t, open_of);
            let mut pieces = Vec::new();
            for a in &top.1 {
                for b in open.iter() {
                    if let Some(o) = a.intersect_coplanar(b, &self.tol)
                        && !is_sliver(&o, &self.tol)
                    {
                        let m = o.normal();
                        // Oriented from below (`from`) to above (`z`).
                        pieces.push(if m[0] * n[0] + m[1] * n[1] + m[2] * n[2] < 0.0 {
                            o.reversed()
                        } else {
                            o
                        });
                    }
                }
            }
            if pieces.is_empty() || z == from {
                continue;
            }
            if z != HULL && membrane[z.idx()] {
                if stack.len() < max_depth {
                    let up = self.flat_faces(z, n, true);
                    stack.push((z, pieces, up, 0));
                }
            } else if z == HULL {
                if from != HULL {
                    hull.push((from, pieces[0].centroid()));
                }
            } else if from == HULL {
                hull.push((z, pieces[0].centroid()));
            } else {
                links.extend(pieces.into_iter().map(|p| (from, z, p)));
            }
        }
    }

    /// [`CellComplex::adjacency`] in two flat arrays ([`Adjacency`]): the same lists in
    /// the same order, without a heap block per cell (at 2.3M tetrahedra the exterior
    /// flood fill's lists took ~100 B per cell that way).
    pub(crate) fn adjacency_flat(&self) -> Adjacency {
        let n = self.cells.len();
        let mut first = vec![0usize; n + 1];
        for p in &self.portals {
            first[p.cells[0].idx() + 1] += 1;
            first[p.cells[1].idx() + 1] += 1;
        }
        for i in 0..n {
            first[i + 1] += first[i];
        }
        let mut next = first.clone();
        let mut links = vec![(HULL, 0usize); first[n]];
        for (k, p) in self.portals.iter().enumerate() {
            for (a, b) in [(p.cells[0], p.cells[1]), (p.cells[1], p.cells[0])] {
                links[next[a.idx()]] = (b, k);
                next[a.idx()] += 1;
            }
        }
        Adjacency { first, links }
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

    /// The leak's path as points, in the manner of a qbsp pointfile: the centroid of each
    /// cell of [`Leak::path`], with the centroid of the portal to the next cell between
    /// them, and finally [`Leak::hull_point`] where the path leaves the model. Consecutive
    /// points are joined by segments that stay inside the path's (convex) cells and portals,
    /// so the polyline can be drawn in a viewer to find the hole.
    pub fn leak_pointfile(&self, leak: &Leak) -> Vec<[f64; 3]> {
        let pairs: HashMap<(CellId, CellId), usize> = self
            .portals
            .iter()
            .enumerate()
            .map(|(k, p)| ((p.cells[0], p.cells[1]), k))
            .collect();
        let mut pts = Vec::with_capacity(2 * leak.path.len() + 1);
        for (i, &c) in leak.path.iter().enumerate() {
            pts.push(self.cells[c.idx()].centroid());
            if let Some(&d) = leak.path.get(i + 1) {
                let key = if c < d { (c, d) } else { (d, c) };
                if let Some(&k) = pairs.get(&key) {
                    pts.push(area_centroid(&self.portals[k].pieces));
                }
            }
        }
        pts.push(leak.hull_point);
        pts
    }

    /// Stage 6: remove regions that face no occluder; report leaks.
    pub(crate) fn remove_exterior(&mut self) {
        self.remove_exterior_with(None);
    }

    /// Connected regions of the portal graph over alive cells: (region of each cell,
    /// members of each region).
    pub(super) fn regions(&self, adj: &Adjacency) -> (Vec<u32>, Vec<Vec<CellId>>) {
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
        (region, regions)
    }

    /// Open hull openings per cell: the uncovered pieces of its hull patches (empty for
    /// a cell that reaches the hull through flat cells) and a point there.
    pub(super) fn hull_openings(&self) -> HashMap<CellId, (Vec<ConvexPolygon>, [f64; 3])> {
        let mut hull_open: HashMap<CellId, (Vec<ConvexPolygon>, [f64; 3])> = HashMap::new();
        for &(c, q) in &self.hull_through {
            hull_open.entry(c).or_insert((Vec::new(), q));
        }
        // Each hull patch's open pieces on every core, inserted in patch order (as one
        // thread would).
        let open: Vec<(CellId, Vec<ConvexPolygon>)> = self
            .patches
            .par_iter()
            .with_min_len(1024)
            .enumerate()
            .filter_map(|(pi, p)| {
                if !(p.alive && p.cells[1] == HULL && self.cells[p.cells[0].idx()].alive)
                    || self.is_membrane(p.cells[0])
                {
                    return None;
                }
                let (pieces, _, _) = self.open_pieces(PatchId(pi as u32));
                (!pieces.is_empty()).then_some((p.cells[0], pieces))
            })
            .collect();
        for (c, pieces) in open {
            let q = pieces[0].centroid();
            hull_open.entry(c).or_insert((Vec::new(), q)).0.extend(pieces);
        }
        hull_open
    }

    /// Stage 6, optionally sealing narrow openings of leaking regions (see
    /// [`CellComplex::seal_holes`]); returns the sealed openings.
    pub(super) fn remove_exterior_with(
        &mut self,
        mut sealer: Option<&mut super::seal::Sealer>,
    ) -> Vec<super::seal::SealedOpening> {
        let adj = self.adjacency_flat();
        let (region, regions) = self.regions(&adj);
        let hull_open_pieces = self.hull_openings();
        let hull_open: HashMap<CellId, [f64; 3]> = hull_open_pieces.iter().map(|(c, (_, q))| (*c, *q)).collect();
        let mut removed = 0;
        let mut leaks = Vec::new();
        let mut sealed = Vec::new();
        // For `faces_reversed`: kept regions that do not leak.
        let mut inside_kept = 0usize;
        for members in &regions {
            // Read only, on every core (the outside's region is most of the cells, and a
            // region that faces nothing is read to its end).
            let facing = members.par_iter().with_min_len(4096).any(|&c| self.faces_occluder(c));
            if !facing {
                self.stats.exterior_regions += 1;
                // The thin cells removed, found on every core and counted in member order
                // (the volumes' sum has one order). The tag scan first: most removed cells
                // (the outside, the insides of walls) face no front, and `is_thin` sums a
                // volume and an area.
                let thin: Vec<CellId> = members
                    .par_iter()
                    .with_min_len(4096)
                    .copied()
                    .filter(|&c| self.faces_any_front(c) && (self.cells[c.idx()].flat || self.is_thin(c)))
                    .collect();
                for &c in members {
                    self.cells[c.idx()].exterior = true;
                }
                removed += members.len();
                for c in thin {
                    self.stats.thin_removed_cells += 1;
                    self.stats.thin_removed_volume += self.cells[c.idx()].volume();
                }
                continue;
            }
            if !members.iter().any(|c| hull_open.contains_key(c)) {
                self.stats.interior_regions += 1;
                inside_kept += 1;
                continue;
            }
            if let Some(s) = sealer.as_deref_mut()
                && let Some(split) = s.split_region(self, members, &adj, &hull_open_pieces)
            {
                for &c in &split.exterior {
                    self.cells[c.idx()].exterior = true;
                }
                removed += split.exterior.len();
                self.stats.exterior_regions += split.exterior_regions;
                self.stats.interior_regions += split.interior_regions;
                inside_kept += split.interior_regions;
                sealed.extend(split.sealed);
                continue;
            }
            self.stats.interior_regions += 1;
            leaks.push(self.trace_leak(members, &adj, &hull_open));
        }
        // Only when nothing stays inside (a normal model never pays for it: the test scans
        // every cell of a region that no back side faces, i.e. all of a model's rooms):
        // the regions the reversed model would keep, and whether one of them would leak
        // (regions, portals and hull openings do not depend on the winding).
        self.stats.faces_reversed = inside_kept == 0 && {
            let (mut kept_reversed, mut leak_reversed) = (0usize, false);
            for members in &regions {
                if members.iter().any(|&c| self.faces_occluder_back(c)) {
                    kept_reversed += 1;
                    leak_reversed |= members.iter().any(|c| hull_open.contains_key(c));
                }
            }
            kept_reversed > 0 && !leak_reversed
        };
        self.stats.exterior_cells_removed = removed;
        self.stats.active_cells = self.cells.iter().filter(|c| c.active()).count();
        self.portals
            .retain(|p| !self.cells[p.cells[0].idx()].exterior && !self.cells[p.cells[1].idx()].exterior);
        // A crack joins two active cells of one region only (see `CellComplex::cracks`).
        self.cracks.retain(|p| {
            let [a, b] = p.cells;
            self.cells[a.idx()].active() && self.cells[b.idx()].active() && region[a.idx()] == region[b.idx()]
        });
        self.stats.portal_pairs = self.portals.len();
        self.stats.portal_polygons = self.portals.iter().map(|p| p.pieces.len()).sum();
        self.stats.leaks = leaks.len();
        self.leaks = leaks;
        sealed
    }

    /// Multi-source BFS from the cells with open hull faces; the occluder-facing cell
    /// farthest from the hull starts the reported path.
    fn trace_leak(&self, members: &[CellId], adj: &Adjacency, hull_open: &HashMap<CellId, [f64; 3]>) -> Leak {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::complex::{Cell, ComplexStats, Occluder, Patch};
    use crate::geom::ConvexPolyhedron;
    use crate::ids::PolygonId;
    use crate::tolerances::Tolerances;

    /// Width of the crack: below the sliver width of a model of diagonal 3 (3e-5).
    const W: f64 = 1e-5;

    fn quad(v: [[f64; 3]; 4]) -> ConvexPolygon {
        ConvexPolygon::new(v.to_vec())
    }

    /// Cells A = [0,1]×[0,1], B = [1,2]×[0,1], C = [0,2]×[1,2] (z in [0, 1]), every outer
    /// face a wall facing its cell. A|B (x = 1) is a wall with an uncovered strip of width
    /// `W` along its top (its own patch, no occluder): the only opening between A and B.
    /// A|C is open; B|C is open when `bc_open`, else a wall, so that B is a closed room
    /// of its own that only the crack reaches.
    fn scene(bc_open: bool) -> CellComplex {
        let tol = Tolerances::for_scale(3.0);
        let boxes = [
            ([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]),
            ([1.0, 0.0, 0.0], [2.0, 1.0, 1.0]),
            ([0.0, 1.0, 0.0], [2.0, 2.0, 1.0]),
        ];
        let mut patches: Vec<Patch> = Vec::new();
        let mut faces: Vec<Vec<(ConvexPolygon, u32)>> = vec![Vec::new(); 3];
        // A patch out of cell `i` (polygon `f`, counter-clockwise seen from outside `i`)
        // into `j` (or the hull), with walls facing the listed sides.
        let mut add = |i: usize, j: Option<usize>, f: ConvexPolygon, walls: &[u8]| {
            let id = patches.len() as u32;
            patches.push(Patch {
                polygon: f.clone(),
                cells: [CellId(i as u32), j.map_or(HULL, |j| CellId(j as u32))],
                occluders: walls
                    .iter()
                    .map(|&s| Occluder {
                        polygon: f.clone(),
                        source: PolygonId(0),
                        faces: s,
                    })
                    .collect(),
                alive: true,
            });
            faces[i].push((f.clone(), id));
            if let Some(j) = j {
                faces[j].push((f.reversed(), id));
            }
        };
        // A|B: the wall below z = 1 - W, the crack above it (normal +x, out of A).
        add(
            0,
            Some(1),
            quad([
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [1.0, 1.0, 1.0 - W],
                [1.0, 0.0, 1.0 - W],
            ]),
            &[0, 1],
        );
        add(
            0,
            Some(1),
            quad([
                [1.0, 0.0, 1.0 - W],
                [1.0, 1.0, 1.0 - W],
                [1.0, 1.0, 1.0],
                [1.0, 0.0, 1.0],
            ]),
            &[],
        );
        // A|C and B|C at y = 1 (normal +y, out of A and B).
        add(
            0,
            Some(2),
            quad([[0.0, 1.0, 0.0], [0.0, 1.0, 1.0], [1.0, 1.0, 1.0], [1.0, 1.0, 0.0]]),
            &[],
        );
        let bc = quad([[1.0, 1.0, 0.0], [1.0, 1.0, 1.0], [2.0, 1.0, 1.0], [2.0, 1.0, 0.0]]);
        add(1, Some(2), bc, if bc_open { &[] } else { &[0, 1] });
        // Outer faces: walls on the hull. Cuboid faces are −x, +x, −y, +y, −z, +z.
        for (i, (lo, hi)) in boxes.iter().enumerate() {
            let cube = ConvexPolyhedron::cuboid(lo, hi);
            let inner: &[usize] = match i {
                0 => &[1, 3],
                1 => &[0, 3],
                _ => &[2],
            };
            for (k, f) in cube.faces.into_iter().enumerate() {
                if !inner.contains(&k) {
                    add(i, None, f, &[0]);
                }
            }
        }
        let cells = faces
            .into_iter()
            .map(|fs| {
                let (f, t): (Vec<_>, Vec<_>) = fs.into_iter().unzip();
                Cell::new(ConvexPolyhedron::from_faces(f, t), None, false)
            })
            .collect();
        let mut cx = CellComplex::from_parts(cells, patches, tol, 4.0, Vec::new(), ComplexStats::default());
        cx.build_graph();
        cx.remove_exterior();
        cx
    }

    /// The flat adjacency holds the per-cell lists, in the same order, on a complex built
    /// from a tetrahedralization (the exterior flood fill and the sealer walk it).
    #[test]
    fn flat_adjacency_equals_the_per_cell_lists() {
        let s = crate::generate::four_rooms::four_rooms();
        let m = crate::model::from_soup("four_rooms", s.vertices, s.polygons).expect("model");
        let cx = crate::pipeline::complex_of_unchecked(&m).expect("complex");
        assert!(cx.portals.len() > 100);
        let (lists, flat) = (cx.adjacency(), cx.adjacency_flat());
        assert_eq!(flat.first.len(), cx.cells.len() + 1);
        for (c, l) in lists.iter().enumerate() {
            assert_eq!(&flat[c], &l[..], "cell {c}");
        }
        let (lists, flat) = (scene(true).adjacency(), scene(true).adjacency_flat());
        assert!((0..3).all(|c| flat[c] == lists[c][..]));
    }

    /// Two cells joined only through a sliver opening: no portal, but a crack link when
    /// they lie in one region (A and B, both joined to C), which visibility follows; none
    /// when the crack is all that joins two regions (B closed off from C).
    #[test]
    fn sliver_opening_is_a_crack_link_within_a_region_only() {
        let (a, b, c) = (CellId(0), CellId(1), CellId(2));
        let pair = |cx: &CellComplex, x: CellId, y: CellId| cx.portals.iter().any(|p| p.cells == [x, y]);

        let cx = scene(true);
        assert_eq!(cx.stats.slivers_discarded, 1);
        assert_eq!(cx.stats.leaks, 0);
        assert!(pair(&cx, a, c) && pair(&cx, b, c) && !pair(&cx, a, b));
        assert_eq!(cx.cracks.len(), 1);
        assert_eq!(cx.cracks[0].cells, [a, b]);
        assert!((cx.cracks[0].area - W).abs() < 1e-12);
        // Oriented from A into B (+x).
        assert!(cx.cracks[0].pieces[0].normal()[0] > 0.99);
        // Visibility carries it: a portal piece between A and B.
        let (g, index) = crate::visibility::PortalGraph::from_complex(&cx);
        let (ga, gb) = (index[0], index[1]);
        assert!(g.portals.iter().any(|p| p.cells == [ga, gb] || p.cells == [gb, ga]));
        assert_eq!(g.pieces(), 3);

        // B walled off from C: A|C and B's room are two regions; the crack would join
        // them, so it is dropped (the flood fill and leaks never see cracks either).
        let cx = scene(false);
        assert_eq!(cx.stats.interior_regions, 2);
        assert!(pair(&cx, a, c) && !pair(&cx, b, c) && !pair(&cx, a, b));
        assert!(cx.cracks.is_empty());
        let (g, _) = crate::visibility::PortalGraph::from_complex(&cx);
        assert_eq!(g.pieces(), 1);
    }
}
