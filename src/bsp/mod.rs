//! The BSP baseline of the thesis's sections 4.1.3 and 4.3.3: a binary space partition
//! whose splitting planes are the model's polygon planes, chosen to split as few polygons
//! as possible (Teller's criterion), turned into a [`CellComplex`] with the same
//! semantics as the Delaunay path, so that the portal graph, the exterior flood fill,
//! decimation and evaluation run on it unchanged.
//!
//! # The tree
//!
//! The root region is the model's axis-aligned bounding box; its six faces are hull
//! patches (the other cell is [`HULL`]). Every model polygon starts as one *fragment*,
//! projected onto its support plane: nearly coplanar polygons (all vertices within
//! [`Tolerances::coplanar_abs`] of a larger polygon's plane) share one plane, exactly as in
//! the Delaunay complex, and [`CellComplex::polygon_planes`] holds the same planes. At a
//! node holding fragments:
//!
//! 1. **Candidates** are the distinct support planes among the node's fragments. When
//!    there are more than [`BspSettings::max_candidates`] (K), K are evaluated: the K/2
//!    with the largest fragment area in the node, and K − K/2 evenly spaced through the
//!    rest of that area order (ties by support index), so the choice is deterministic.
//! 2. **Choice** (Teller's criterion). For each candidate, every fragment of another
//!    support is classified against its plane with the tolerance `coplanar_abs`: on it,
//!    front, back, or split. The plane with the fewest splits wins; ties go to the better
//!    balance (smallest |front − back|), then to the larger fragment area on the plane,
//!    then to the lower support index. A candidate is dropped as soon as it splits more
//!    than the best so far.
//! 3. **Consumption.** The chosen support's fragments (the polygons coplanar with the
//!    plane within `coplanar_abs`, by the support grouping) are used up by the node: they
//!    become occluders on the node's plane. Fragments of other supports are never
//!    consumed, even when they lie within `coplanar_abs` of the plane: a small piece of a
//!    differently oriented polygon is that close to many planes, and placing it there
//!    would leave its polygon crossing a leaf.
//! 4. **Cut.** The node's region (a live cell) is cut by the plane
//!    ([`ConvexPolyhedron::cut`](crate::geom::ConvexPolyhedron::cut)). A region that
//!    straddles the plane but whose cut is refused as a sliver (section below the area
//!    tolerance, piece below the minimum volume) is cut with the sealing thresholds
//!    ([`Tolerances::sealing`]), as the Delaunay path seals cracks; only slabs thinner than
//!    the weld distance stay uncut. The cut is committed with the complex's own
//!    `CellComplex::commit_split`: the cross-section becomes a new patch between the two
//!    pieces, carrying the consumed fragments clipped to it, each facing the side its
//!    front looks to; patches of the region that the plane crosses are split in two (with
//!    their occluders), and the cell across each of them subdivides its face the same way
//!    ([`ConvexPolyhedron::split_face`](crate::geom::ConvexPolyhedron::split_face)). The
//!    other fragments are split by the plane with the plane tolerance and *without* the
//!    sliver rule ([`ConvexPolygon::split_exact`]): a sliver part dropped or sent to the
//!    wrong side would leave its polygon crossing a leaf. If the plane does not cut the
//!    region (it lies on the region's boundary, e.g. a wall on the bounding box, or the
//!    slab beyond it is thinner than the weld distance), the consumed fragments are
//!    attached to the region's faces where those lie on the plane: faces within 60° of it
//!    whose part under the fragment is within `coplanar + weld` of it (the Delaunay
//!    path's attachment distance; a face need not lie on the plane as a whole, so a wall
//!    polygon meeting a nearly coplanar neighbour at an edge is placed on the neighbour's
//!    face there, which closes the crack along their shared edge). The node then has one
//!    child, the unchanged region.
//! 5. **Leaves.** A node without fragments is a leaf: its region, a convex cell free of
//!    polygons.
//!
//! Fragments are clipped onto patches by clipping the fragment by the patch, never the
//! reverse (see `clip_onto`): [`ConvexPolygon::intersect_coplanar`] ignores clip edges
//! shorter than the weld distance, so a sliver fragment used as the clip would cover far
//! more than itself.
//!
//! This is qbsp's portalization done incrementally: pushing each node's plane polygon
//! down the tree and splitting it by the planes it meets gives the same leaf faces as
//! cutting the live cells one by one and subdividing the neighbours' faces, which is what
//! `commit_split` does. Each face of a leaf is one patch (its polygon counter-clockwise
//! seen from outside `cells[0]`, normal into `cells[1]`), shared with exactly one other
//! leaf or the hull.
//!
//! Depth is bounded by the number of support planes: a node consumes every fragment of its
//! plane's support in its region, so no descendant chooses it again.
//!
//! **Sealing thin leaves.** Walls made of nearly coplanar polygons on different support
//! planes leave thin wedge leaves between the planes that join the wall's two sides
//! through the crack where the polygons meet; [`seal_thin_leaves`] closes them (on e1m1
//! without it the map leaks).
//!
//! # Complex
//!
//! One [`Cell`] per leaf (`tet: None`, never flat); `hull_volume` is the bounding box's
//! volume. Then the complex's own portal graph and exterior removal stages run as
//! for the Delaunay complex, and [`CellComplex::validate`] checks the same invariants.

use std::collections::HashMap;
use std::time::Instant;
use thin_vec::ThinVec;

use serde::Serialize;

use crate::base::vec::{dist, dot, weighted_mean};
use crate::complex::{Cell, CellComplex, ComplexStats, HULL, Occluder, Patch, polygon_supports, project};
use crate::geom::{Classification, ConvexPolygon, ConvexPolyhedron, Cut, Plane, PolygonSplit};
use crate::ids::{CellId, PolygonId};
use crate::model::Model;
use crate::predicates::P3;
use crate::tolerances::Tolerances;

/// Default for [`BspSettings::max_candidates`].
pub const DEFAULT_MAX_CANDIDATES: usize = 64;

/// Parameters of the BSP.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BspSettings {
    /// At most this many candidate planes are evaluated per node (0: all of them). See the
    /// module docs for which ones. With [`DEFAULT_MAX_CANDIDATES`] the plane choice takes
    /// about 0.1 s on e1m1 (13,865 polygons on 712 support planes); on models where every
    /// polygon has its own plane (caverns, noisy) the full search grows with the number
    /// of planes times the number of fragments at each node.
    pub max_candidates: usize,
    /// The tree variant: 0 is Teller's criterion as documented (fewest splits, then
    /// balance, area, support index). Variant `v > 0` keeps the fewest splits but breaks
    /// ties by a hash of the support index and `v` ([`variant_rank`]): a different, equally
    /// deterministic tree, which the pipeline's ladder tries when every tolerance level of
    /// variant 0 leaves an invalid complex (near-degenerate cuts depend on the order of the
    /// planes, so another order usually avoids them).
    pub variant: u32,
}

impl Default for BspSettings {
    fn default() -> Self {
        BspSettings {
            max_candidates: DEFAULT_MAX_CANDIDATES,
            variant: 0,
        }
    }
}

fn is_zero(v: &u32) -> bool {
    *v == 0
}

/// The tie-break rank of support `s` in tree variant `v > 0` (SplitMix64 of both).
pub fn variant_rank(s: u32, v: u32) -> u64 {
    let mut z = ((v as u64) << 32 | s as u64).wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Counts and timings of a BSP build.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BspStats {
    /// The settings used.
    pub max_candidates: usize,
    /// The tree variant ([`BspSettings::variant`]; 0 unless the ladder needed another,
    /// and then absent from `result.json`).
    #[serde(skip_serializing_if = "is_zero")]
    pub variant: u32,
    /// Model polygons.
    pub polygons: usize,
    /// Their distinct support planes.
    pub support_planes: usize,
    /// Internal nodes (each chose one plane), including those whose plane did not cut
    /// the region.
    pub nodes: usize,
    /// Nodes whose plane cut the region in two.
    pub splitting_nodes: usize,
    /// Of those, cuts refused as slivers by the normal tolerances and made with the
    /// sealing thresholds ([`Tolerances::sealing`]).
    pub sealing_cuts: usize,
    /// Leaves (cells of the complex).
    pub leaves: usize,
    /// Distinct support planes chosen by some node.
    pub planes_used: usize,
    /// Polygon fragments split in two by a node's plane (each adds one fragment; slivers
    /// included): the "polygon splits" the plane choice minimises.
    pub polygon_splits: usize,
    /// Fragments consumed by nodes (placed on a node's plane).
    pub fragments_consumed: usize,
    /// Consumed fragments with area above the tolerance that found no patch to lie on.
    pub fragments_unplaced: usize,
    /// Leaves thinner than the sliver width whose faces got the occluders of their opposite
    /// faces (see [`seal_thin_leaves`]).
    pub thin_leaves_sealed: usize,
    /// Occluders added that way.
    pub sealing_occluders: usize,
    /// Deepest leaf (number of nodes above it).
    pub depth_max: usize,
    /// Mean leaf depth.
    pub depth_mean: f64,
    /// Candidate planes evaluated, over all nodes.
    pub candidates_evaluated: usize,
    /// Fragment-against-plane classifications done while choosing planes.
    pub classifications: u64,
    /// Stage timings in seconds, in order (also appended to the complex's timings).
    pub timings: Vec<(String, f64)>,
    /// Total seconds.
    pub seconds: f64,
}

/// A piece of a model polygon, on its support plane.
#[derive(Clone, Debug)]
struct Frag {
    poly: ConvexPolygon,
    source: PolygonId,
    support: u32,
    /// Bounding sphere, for quick classification.
    centre: P3,
    radius: f64,
    area: f64,
}

impl Frag {
    fn new(poly: ConvexPolygon, source: PolygonId, support: u32) -> Frag {
        let n = poly.verts.len() as f64;
        let mut c = [0.0; 3];
        for v in &poly.verts {
            for k in 0..3 {
                c[k] += v[k] / n;
            }
        }
        let radius = poly.verts.iter().map(|v| dist(v, &c)).fold(0.0, f64::max);
        let area = poly.area();
        Frag {
            poly,
            source,
            support,
            centre: c,
            radius,
            area,
        }
    }
}

/// Where a fragment lies relative to a plane, with tolerance `coplanar_abs`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Place {
    On,
    Front,
    Back,
    Split,
}

/// Classifies `f` against the unit-normal plane `pl`.
/// Fragments of other supports than the node's, sorted to the sides of `plane`:
/// (front, back, fragments split). By the plane tolerance, without the sliver rule
/// (`split_exact`): a sliver part dropped, or sent to the wrong side because it lies
/// within `coplanar` of the plane, would leave its polygon crossing a leaf. (A small piece
/// of a differently oriented polygon lies within `coplanar` of many planes, so only the
/// chosen support's fragments are consumed.)
fn sort_frags(frags: Vec<Frag>, plane: &Plane, tol: &Tolerances) -> (Vec<Frag>, Vec<Frag>, usize) {
    let (mut front, mut back, mut n) = (Vec::new(), Vec::new(), 0);
    for f in frags {
        match f.poly.split_exact(plane, tol) {
            PolygonSplit::Split(a, b) => {
                n += 1;
                front.push(Frag::new(a, f.source, f.support));
                back.push(Frag::new(b, f.source, f.support));
            }
            PolygonSplit::Front => front.push(f),
            PolygonSplit::Back => back.push(f),
            PolygonSplit::Coplanar => {
                if dot(&f.poly.area_vector(), &plane.n) >= 0.0 {
                    front.push(f)
                } else {
                    back.push(f)
                }
            }
        }
    }
    (front, back, n)
}

fn place(f: &Frag, pl: &Plane, eps: f64) -> Place {
    let d = pl.eval(&f.centre);
    if d - f.radius > eps {
        return Place::Front;
    }
    if d + f.radius < -eps {
        return Place::Back;
    }
    let (mut front, mut back) = (false, false);
    for v in &f.poly.verts {
        let d = pl.eval(v);
        front |= d > eps;
        back |= d < -eps;
    }
    match (front, back) {
        (false, false) => Place::On,
        (true, false) => Place::Front,
        (false, true) => Place::Back,
        (true, true) => Place::Split,
    }
}

/// Builds the BSP complex of `model` with the default settings.
pub fn build_complex(model: &Model) -> (CellComplex, BspStats) {
    build_complex_with(model, &BspSettings::default())
}

/// Builds the BSP complex of `model`: the tree, its leaves as cells, the portal graph and
/// the exterior removal (see the module docs).
pub fn build_complex_with(model: &Model, settings: &BspSettings) -> (CellComplex, BspStats) {
    let t0 = Instant::now();
    let tol = model.tolerances;
    let (planes, of) = polygon_supports(model);
    let polygon_planes: Vec<Plane> = of
        .iter()
        .map(|&(s, flipped)| if flipped { planes[s].flipped() } else { planes[s] })
        .collect();
    let frags: Vec<Frag> = model
        .polygons
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let s = of[i].0;
            let verts = p
                .verts
                .iter()
                .map(|v| project(&planes[s], &model.vertices[v.idx()]))
                .collect();
            Frag::new(ConvexPolygon::new(verts), PolygonId(i as u32), s as u32)
        })
        .collect();
    let (lo, hi) = model.bbox();
    let root = ConvexPolyhedron::cuboid(&lo, &hi);
    let hull_volume = root.volume();
    let patches: Vec<Patch> = root
        .faces
        .iter()
        .map(|f| Patch {
            polygon: f.clone(),
            cells: [CellId(0), HULL],
            occluders: ThinVec::new(),
            alive: true,
        })
        .collect();
    let cells = vec![Cell::new(root, None, false)];
    let cstats = ComplexStats {
        polygons: model.polygons.len(),
        polygons_clipped: model.polygons.len(),
        support_planes: planes.len(),
        ..Default::default()
    };
    let mut cx = CellComplex::from_parts(cells, patches, tol, hull_volume, polygon_planes, cstats);
    let mut stats = BspStats {
        max_candidates: settings.max_candidates,
        variant: settings.variant,
        polygons: model.polygons.len(),
        support_planes: planes.len(),
        ..Default::default()
    };
    let setup = t0.elapsed().as_secs_f64();

    let mut b = Builder {
        tol,
        planes: &planes,
        settings,
        stats: &mut stats,
        used: vec![false; planes.len()],
        choose_seconds: 0.0,
    };
    let t1 = Instant::now();
    let mut depth_sum = 0usize;
    let mut stack: Vec<(CellId, Vec<Frag>, usize)> = vec![(CellId(0), frags, 0)];
    // Regions cut as a neighbour of a node's cut (`try_commit_split` cuts a neighbour by
    // the node's plane when subdividing its face would leave it non-convex): the plane and
    // the pieces, so a pending region's fragments follow its pieces.
    let mut replaced: HashMap<CellId, (u32, CellId, CellId)> = HashMap::new();
    while let Some((c, frags, depth)) = stack.pop() {
        if !cx.cells[c.idx()].alive {
            let Some(&(s, f, bk)) = replaced.get(&c) else {
                continue;
            };
            let plane = planes[s as usize];
            let (fr, bf, _) = sort_frags(frags, &plane, &tol);
            stack.push((bk, bf, depth));
            stack.push((f, fr, depth));
            continue;
        }
        if frags.is_empty() {
            b.stats.leaves += 1;
            b.stats.depth_max = b.stats.depth_max.max(depth);
            depth_sum += depth;
            continue;
        }
        let s = b.choose(&frags);
        for (child, fr) in b.node(&mut cx, c, s, frags) {
            stack.push((child, fr, depth + 1));
        }
        for (o, f, bk) in std::mem::take(&mut cx.neighbour_log) {
            if !stack.iter().any(|(x, _, _)| *x == o) {
                // A finished leaf: its two pieces are leaves.
                b.stats.leaves += 1;
            }
            replaced.insert(o, (s, f, bk));
        }
    }
    let choose = b.choose_seconds;
    let planes_used = b.used.iter().filter(|&&u| u).count();
    stats.planes_used = planes_used;
    stats.depth_mean = depth_sum as f64 / stats.leaves.max(1) as f64;
    let tree = t1.elapsed().as_secs_f64();
    cx.stats.cells_after_split = cx.cells.iter().filter(|c| c.alive).count();
    cx.stats.unplaced_fragments = stats.fragments_unplaced;
    cx.stats.cells_sealed = stats.sealing_cuts;

    let ts = Instant::now();
    let (sealed, added) = seal_thin_leaves(&mut cx);
    stats.thin_leaves_sealed = sealed;
    stats.sealing_occluders = added;
    let sealing = ts.elapsed().as_secs_f64();

    let t2 = Instant::now();
    cx.build_graph();
    let graph = t2.elapsed().as_secs_f64();
    let t3 = Instant::now();
    cx.remove_exterior();
    let exterior = t3.elapsed().as_secs_f64();
    let timings = vec![
        ("bsp: support planes and root".to_string(), setup),
        ("bsp: choosing planes".to_string(), choose),
        ("bsp: cutting cells and placing occluders".to_string(), tree - choose),
        ("bsp: sealing thin leaves".to_string(), sealing),
        ("portal graph".to_string(), graph),
        ("exterior removal".to_string(), exterior),
    ];
    cx.stats.timings.extend(timings.iter().cloned());
    stats.timings = timings;
    stats.seconds = t0.elapsed().as_secs_f64();
    (cx, stats)
}

struct Builder<'a> {
    tol: Tolerances,
    planes: &'a [Plane],
    settings: &'a BspSettings,
    stats: &'a mut BspStats,
    used: Vec<bool>,
    choose_seconds: f64,
}

impl Builder<'_> {
    /// The support plane the node splits by (see the module docs).
    fn choose(&mut self, frags: &[Frag]) -> u32 {
        let t = Instant::now();
        // Candidates: distinct supports with their fragment area in the node.
        let mut by: Vec<(u32, f64)> = frags.iter().map(|f| (f.support, f.area)).collect();
        by.sort_by_key(|c| c.0);
        let mut cands: Vec<(u32, f64)> = Vec::new();
        for (s, a) in by {
            match cands.last_mut() {
                Some((t, sum)) if *t == s => *sum += a,
                _ => cands.push((s, a)),
            }
        }
        cands.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        let k = self.settings.max_candidates;
        if k > 0 && cands.len() > k {
            let top = k / 2;
            let rest = &cands[top..];
            let m = k - top;
            let mut pick: Vec<(u32, f64)> = cands[..top].to_vec();
            // Evenly spaced through the rest (first and last included when m > 1).
            for i in 0..m {
                let j = if m == 1 { 0 } else { i * (rest.len() - 1) / (m - 1) };
                pick.push(rest[j]);
            }
            pick.dedup_by_key(|c| c.0);
            cands = pick;
        }
        let eps = self.tol.coplanar_abs();
        // (splits, imbalance, -area, support)
        let mut best: Option<(usize, usize, f64, u32)> = None;
        for &(s, area) in &cands {
            self.stats.candidates_evaluated += 1;
            let pl = &self.planes[s as usize];
            let (mut splits, mut front, mut back) = (0usize, 0usize, 0usize);
            let bound = best.map_or(usize::MAX, |b| b.0);
            let mut pruned = false;
            for f in frags {
                if f.support == s {
                    continue;
                }
                self.stats.classifications += 1;
                match place(f, pl, eps) {
                    Place::On => {}
                    Place::Front => front += 1,
                    Place::Back => back += 1,
                    Place::Split => {
                        splits += 1;
                        front += 1;
                        back += 1;
                        if splits > bound {
                            pruned = true;
                            break;
                        }
                    }
                }
            }
            if pruned {
                continue;
            }
            let key = (splits, front.abs_diff(back), -area, s);
            let v = self.settings.variant;
            let better = match best {
                None => true,
                Some(b) if v > 0 => (key.0, variant_rank(key.3, v)) < (b.0, variant_rank(b.3, v)),
                Some(b) => (key.0, key.1)
                    .cmp(&(b.0, b.1))
                    .then(key.2.total_cmp(&b.2))
                    .then(key.3.cmp(&b.3))
                    .is_lt(),
            };
            if better {
                best = Some(key);
            }
        }
        self.choose_seconds += t.elapsed().as_secs_f64();
        best.map(|b| b.3).unwrap_or(frags[0].support)
    }

    /// Splits (or not) cell `c` by support plane `s`, places the consumed fragments and
    /// returns the children with their fragments.
    fn node(&mut self, cx: &mut CellComplex, c: CellId, s: u32, frags: Vec<Frag>) -> Vec<(CellId, Vec<Frag>)> {
        self.stats.nodes += 1;
        self.used[s as usize] = true;
        let plane = self.planes[s as usize];
        let tol = self.tol;
        let (mut on, mut rest) = (Vec::new(), Vec::new());
        for f in frags {
            if f.support == s {
                on.push(f);
            } else {
                rest.push(f);
            }
        }
        let (mut front, back, n_split) = sort_frags(rest, &plane, &tol);
        self.stats.polygon_splits += n_split;
        self.stats.fragments_consumed += on.len();
        let new_patch = cx.patches.len() as u32;
        let region = &cx.cells[c.idx()].poly();
        // The cut with the normal tolerances, then (a region that straddles the plane but
        // whose cut was refused as a sliver: section below the area tolerance, or a piece
        // below the minimum volume) with the sealing thresholds, as the Delaunay path seals
        // cracks; slabs thinner than the weld distance stay refused. A cut whose
        // neighbours cannot subdivide their faces validly (`try_commit_split`: the plane
        // crosses a neighbour's face where its vertices are a hair apart) is retried with
        // the sealing thresholds; only the last candidate is committed anyway (a node's
        // polygons must not cross a leaf), which `check_valid` then reports.
        let mut cuts: Vec<(Cut, Tolerances)> = vec![(region.cut(&plane, &tol, new_patch), tol)];
        if region.classify(&plane, &tol) == Classification::Straddles {
            let relaxed = tol.sealing();
            cuts.push((region.cut_sealing(&plane, &relaxed, new_patch), relaxed));
        }
        cuts.retain(|(c, _)| matches!(c, Cut::Split(_)));
        let n_cuts = cuts.len();
        for (k, (cut, clip_tol)) in cuts.into_iter().enumerate() {
            let Cut::Split(sp) = cut else { continue };
            let (occ, unplaced) = section_occluders(&on, &sp.section, &plane, &clip_tol);
            let r = match cx.try_commit_split_any(c, &plane, (*sp).clone(), occ.clone(), &clip_tol) {
                Some(r) => Some(r),
                None if k + 1 == n_cuts => Some(cx.commit_split(c, &plane, *sp, occ)),
                None => None,
            };
            if let Some((fid, bid)) = r {
                for i in unplaced {
                    self.unplaced(&on[i]);
                }
                if clip_tol != tol {
                    self.stats.sealing_cuts += 1;
                }
                self.stats.splitting_nodes += 1;
                return vec![(bid, back), (fid, front)];
            }
        }
        for f in &on {
            if !attach_on_faces(cx, c, f, &plane) {
                self.unplaced(f);
            }
        }
        front.extend(back);
        vec![(c, front)]
    }

    fn unplaced(&mut self, f: &Frag) {
        if f.area >= self.tol.area_abs() {
            self.stats.fragments_unplaced += 1;
        }
    }
}

/// The node's fragments `on` clipped onto the cut's `section` as occluders (the section's
/// normal is the plane's, pointing into the front piece, `cells[1]`: a fragment whose front
/// agrees faces side 1), and the indices of those that found no part there.
fn section_occluders(
    on: &[Frag],
    section: &ConvexPolygon,
    plane: &Plane,
    tol: &Tolerances,
) -> (Vec<Occluder>, Vec<usize>) {
    let (mut occ, mut unplaced) = (Vec::new(), Vec::new());
    for (i, f) in on.iter().enumerate() {
        match clip_onto(&f.poly, section, tol) {
            Some(o) => occ.push(Occluder {
                polygon: o,
                source: f.source,
                faces: if dot(&f.poly.area_vector(), &plane.n) > 0.0 {
                    1
                } else {
                    0
                },
            }),
            None => unplaced.push(i),
        }
    }
    (occ, unplaced)
}

/// `poly` clipped to `target` (coplanar with it up to tolerance), moved onto `target`'s
/// plane and oriented like it; `None` below the area tolerance. The polygon is clipped by
/// the target, not the other way round: [`ConvexPolygon::intersect_coplanar`] ignores clip
/// edges shorter than the weld distance, so clipping by a sliver fragment could give
/// far more than the fragment; this way the result always lies inside `poly`.
fn clip_onto(poly: &ConvexPolygon, target: &ConvexPolygon, tol: &Tolerances) -> Option<ConvexPolygon> {
    clip_onto_within(poly, target, tol, f64::INFINITY)
}

/// [`clip_onto`], `None` unless every vertex of the clipped part lies within `max_dist`
/// of `target`'s plane before it is moved there.
fn clip_onto_within(
    poly: &ConvexPolygon,
    target: &ConvexPolygon,
    tol: &Tolerances,
    max_dist: f64,
) -> Option<ConvexPolygon> {
    let q = poly.intersect_coplanar(target, tol)?;
    let pl = target.plane();
    if !q.verts.iter().all(|v| pl.eval(v).abs() <= max_dist) {
        return None;
    }
    let q = ConvexPolygon::new(q.verts.iter().map(|v| project(&pl, v)).collect());
    Some(if dot(&q.area_vector(), &target.area_vector()) < 0.0 {
        q.reversed()
    } else {
        q
    })
}

/// Attaches fragment `f` (on `plane`) to the faces of cell `c` where they lie on the plane
/// (within `coplanar + weld` under the fragment), as occluders in the patches' orientation facing the side its
/// front looks to. True if some part was attached.
fn attach_on_faces(cx: &mut CellComplex, c: CellId, f: &Frag, plane: &Plane) -> bool {
    let tol = cx.tol;
    let eps = tol.coplanar_abs() + tol.weld_abs();
    let fnorm = f.poly.area_vector();
    let mut adds: Vec<(usize, Occluder)> = Vec::new();
    let cell = &cx.cells[c.idx()];
    let un = plane.unit_normal();
    for (fi, face) in cell.poly().faces.iter().enumerate() {
        // Faces within 60° of the plane (as the portal graph's flat-cell rule) whose part
        // under the fragment lies within `eps` of it: the face need not lie on the plane
        // as a whole (a face on a nearly coplanar neighbour's plane, diverging from it
        // away from their shared edge, still takes the fragment where they meet).
        if dot(&face.normal(), &un).abs() < 0.5 {
            continue;
        }
        let Some(ov) = clip_onto_within(&f.poly, face, &tol, eps) else {
            continue;
        };
        let t = cell.tags()[fi] as usize;
        let side = if cx.patches[t].cells[0] == c { 0 } else { 1 };
        // The fragment faces this cell when the face's outward normal opposes its front.
        let faces = if dot(&face.normal(), &fnorm) < 0.0 {
            side
        } else {
            1 - side
        };
        let polygon = if side == 0 { ov } else { ov.reversed() };
        adds.push((
            t,
            Occluder {
                polygon,
                source: f.source,
                faces: faces as u8,
            },
        ));
    }
    let any = !adds.is_empty();
    for (t, o) in adds {
        cx.patches[t].occluders.push(o);
    }
    any
}

/// Seals cracks between nearly coplanar walls. Two wall polygons on slightly different
/// support planes A and B (further apart than `coplanar` somewhere, so not grouped) that
/// meet at an edge leave, after projection onto their planes, a crack at that edge; the
/// BSP cuts by both planes, and the thin wedge leaf between A and B reaches the open part
/// of A on one side of the junction and the open part of B on the other, joining the
/// wall's two sides through the crack. A leaf thinner than the sliver width
/// ([`CellComplex::is_thin`], the portal graph's own crack criterion) holds no space, so
/// the wall it lies in is taken to cover both of its sides: each face gets, as occluders,
/// the occluders of the opposite faces (outward normals opposed) whose vertices all lie
/// within the sliver width of the face's plane, clipped to the face. Each keeps its source
/// polygon and the side its front looks to. Returns (leaves that got occluders,
/// occluders added).
pub fn seal_thin_leaves(cx: &mut CellComplex) -> (usize, usize) {
    let tol = cx.tol;
    let w = tol.sliver_width();
    let mut adds: Vec<(usize, Occluder)> = Vec::new();
    let mut sealed = 0;
    for (c, cell) in cx.alive_cells() {
        if !cx.is_thin(c) {
            continue;
        }
        let before = adds.len();
        for (fi, f) in cell.poly().faces.iter().enumerate() {
            if f.area() < tol.area_abs() {
                continue;
            }
            let (nf, pf) = (f.normal(), f.plane());
            let tf = cell.tags()[fi] as usize;
            let patch_f = &cx.patches[tf];
            let pn_f = patch_f.polygon.normal();
            for (gi, g) in cell.poly().faces.iter().enumerate() {
                if gi == fi || dot(&nf, &g.normal()) >= 0.0 {
                    continue;
                }
                let patch_g = &cx.patches[cell.tags()[gi] as usize];
                let pn_g = patch_g.polygon.normal();
                for o in &patch_g.occluders {
                    if !o.polygon.verts.iter().all(|v| pf.eval(v).abs() <= w) {
                        continue;
                    }
                    let Some(ov) = clip_onto(&o.polygon, &patch_f.polygon, &tol) else {
                        continue;
                    };
                    // The occluder's front normal: the patch normal points into cells[1].
                    let front = if o.faces == 1 {
                        dot(&pn_g, &pn_f)
                    } else {
                        -dot(&pn_g, &pn_f)
                    };
                    adds.push((
                        tf,
                        Occluder {
                            polygon: ov,
                            source: o.source,
                            faces: if front > 0.0 { 1 } else { 0 },
                        },
                    ));
                }
            }
        }
        if adds.len() > before {
            sealed += 1;
        }
    }
    let n = adds.len();
    for (t, o) in adds {
        cx.patches[t].occluders.push(o);
    }
    (sealed, n)
}

/// Area-weighted centroid of convex pieces (e.g. a merged portal's).
pub fn pieces_centroid(pieces: &[ConvexPolygon]) -> P3 {
    weighted_mean(pieces.iter().map(|p| (p.area(), p.centroid())))
}

/// How many points of `a` match a point of `b` within distance `tol`, one-to-one: all
/// pairs within `tol` are taken closest first (ties by index), each point used once.
pub fn match_portals(a: &[P3], b: &[P3], tol: f64) -> usize {
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, p) in a.iter().enumerate() {
        for (j, q) in b.iter().enumerate() {
            let d = dist(p, q);
            if d <= tol {
                pairs.push((d, i, j));
            }
        }
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let (mut ua, mut ub) = (vec![false; a.len()], vec![false; b.len()]);
    let mut n = 0;
    for (_, i, j) in pairs {
        if !ua[i] && !ub[j] {
            ua[i] = true;
            ub[j] = true;
            n += 1;
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::scenes;
    use crate::model::from_soup;

    fn model(s: &scenes::Soup) -> Model {
        from_soup("t", s.vertices.clone(), s.polygons.clone()).expect("model")
    }

    #[test]
    fn match_portals_is_one_to_one() {
        let a = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [5.0, 0.0, 0.0]];
        let b = [[0.05, 0.0, 0.0], [0.02, 0.0, 0.0], [1.08, 0.0, 0.0]];
        assert_eq!(match_portals(&a, &b, 0.1), 2);
        assert_eq!(match_portals(&a, &b, 0.01), 0);
        assert_eq!(match_portals(&a[..1], &b, 0.1), 1);
        assert_eq!(match_portals(&[], &b, 1.0), 0);
    }

    #[test]
    fn place_classifies_with_coplanar_tolerance() {
        let tol = Tolerances::for_scale(1.0);
        let sq = |z: f64, dz: f64| {
            Frag::new(
                ConvexPolygon::new(vec![
                    [0.0, 0.0, z],
                    [1.0, 0.0, z],
                    [1.0, 1.0, z + dz],
                    [0.0, 1.0, z + dz],
                ]),
                PolygonId(0),
                0,
            )
        };
        let pl = Plane::new([0.0, 0.0, 1.0], 0.5);
        let e = tol.coplanar_abs();
        assert_eq!(place(&sq(0.5, 0.0), &pl, e), Place::On);
        assert_eq!(place(&sq(0.5 + 0.5e-6, 0.0), &pl, e), Place::On);
        assert_eq!(place(&sq(0.5 + 2e-6, 0.0), &pl, e), Place::Front);
        assert_eq!(place(&sq(0.2, 0.0), &pl, e), Place::Back);
        assert_eq!(place(&sq(0.4, 0.2), &pl, e), Place::Split);
        assert_eq!(place(&sq(0.5, 0.2), &pl, e), Place::Front);
    }

    #[test]
    fn box_room_is_one_leaf_with_covered_hull() {
        let m = model(&scenes::box_room());
        let (cx, st) = build_complex(&m);
        cx.validate(&m).unwrap_or_else(|e| panic!("{e}"));
        // Every wall lies on the bounding box: six nodes, none cuts, one leaf.
        assert_eq!((st.nodes, st.splitting_nodes, st.leaves), (6, 0, 1));
        assert_eq!(st.polygon_splits, 0);
        assert_eq!(cx.stats.active_cells, 1);
        assert_eq!(cx.stats.leaks, 0);
        // Each hull patch is covered by its wall, facing the cell (side 0).
        for p in cx.patches.iter().filter(|p| p.alive) {
            assert_eq!(p.cells, [CellId(0), HULL]);
            assert_eq!(p.occluders.len(), 1);
            assert_eq!(p.occluders[0].faces, 0);
            assert!((p.occluders[0].polygon.area() - p.polygon.area()).abs() < 1e-9);
        }
    }

    #[test]
    fn floating_box_in_a_room_is_cut_out() {
        // A room with an outward-facing box floating in the middle: the box's six faces cut
        // the room (no polygon is split: the room's walls are used first, on the bounding
        // box); the box's inside is a leaf that faces no polygon, removed as exterior.
        let mut s = scenes::box_room();
        s.boxed([1.5, 1.5, 1.0], [2.5, 2.5, 2.0], false);
        let m = model(&s);
        let (cx, st) = build_complex(&m);
        cx.validate(&m).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((st.nodes, st.splitting_nodes, st.leaves), (12, 6, 7), "{st:?}");
        assert_eq!(st.polygon_splits, 0);
        assert_eq!(cx.stats.exterior_cells_removed, 1);
        assert_eq!(cx.stats.active_cells, 6);
        let vol: f64 = cx.active_cells().map(|(_, c)| c.volume()).sum();
        assert!((vol - (48.0 - 1.0)).abs() < 1e-9, "{vol}");
        assert_eq!(cx.stats.interior_regions, 1);
    }
}
