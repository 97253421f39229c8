//! 3D Delaunay tetrahedralization by incremental Bowyer–Watson insertion.
//!
//! References: Bowyer (1981) and Watson (1981) for cavity insertion; Amenta, Choi & Rote,
//! "Incremental constructions con BRIO" (SoCG 2003) for the insertion order; Devillers,
//! Pion & Teillaud, "Walking in a triangulation" (2002) for the remembering stochastic walk;
//! Devillers & Teillaud (2011) for the symbolic perturbation of cospherical ties, the same
//! scheme CGAL uses; Marot, Pellerin & Remacle (2019) for the flat-array layout.
//!
//! Representation: flat arrays, 4 vertex slots and 4 neighbour slots per tetrahedron.
//! Neighbour `i` of a tetrahedron is across the face opposite vertex slot `i`, encoded as
//! `tet * 4 + face_in_neighbour`, so stepping across a face and back costs no search. An
//! infinite vertex ([`INFINITE`]) closes the hull: each hull face has an infinite
//! tetrahedron on its outer side, so every tetrahedron has exactly four neighbours.
//!
//! Invariants kept after [`Tetrahedralization::build`] (and checked by
//! [`Tetrahedralization::validate`]):
//! - every finite tetrahedron is positively oriented (exact [`orient3d`] > 0): no flat ones;
//! - adjacency is symmetric and neighbours agree on the shared face's three vertices;
//! - finite tetrahedra are numbered `0..num_tets()`, infinite ones after them;
//! - every distinct input point is a vertex; exact duplicates map to one representative;
//! - every interior face is locally Delaunay (exact insphere ≤ 0; ties are resolved by the
//!   symbolic perturbation, so the result is *a* Delaunay tetrahedralization, and the same
//!   one for any input order).

mod sort;
mod validate;

pub use validate::{ValidationError, ValidationReport};

use crate::base::hash::FxBuild;
use crate::base::mem::prefetch;
use crate::base::rng::SplitMix64;
use crate::base::vec::sub;
use crate::ids::{TetId, VertexId};
use crate::predicates::{
    LatticePoints, P3, in_filter_range, insphere, insphere_in_range, orient3d, orient3d_in_range, sos_tie,
};
use std::collections::HashMap;

/// The vertex slot value of the point at infinity.
pub const INFINITE: u32 = u32::MAX;
const DEAD: u32 = u32::MAX - 1;

/// Vertex slots of face `i` (opposite slot `i`), ordered counter-clockwise as seen from
/// outside the tetrahedron.
pub const FACE_SLOTS: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// Why a tetrahedralization cannot be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DelaunayError {
    /// An input coordinate is NaN or infinite.
    #[error("point {index} has a non-finite coordinate {point:?}; remove or fix it")]
    NonFinite {
        /// Input index of the point.
        index: usize,
        /// Its coordinates.
        point: P3,
    },
    /// Fewer than four distinct points.
    #[error("only {distinct} distinct points; a tetrahedralization needs at least 4 that are not coplanar")]
    TooFewPoints {
        /// Number of distinct points.
        distinct: usize,
    },
    /// All points lie on one line or one plane.
    #[error("all {distinct} distinct points are {what}; a 3D tetrahedralization needs 4 points that are not coplanar")]
    Degenerate {
        /// Number of distinct points.
        distinct: usize,
        /// "collinear" or "coplanar".
        what: &'static str,
    },
    /// More points than 32-bit indices can address.
    #[error("{0} points exceed the 32-bit index range")]
    TooMany(usize),
}

/// Statistics gathered while building, for reports and benchmarks.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct BuildStats {
    /// Input points.
    pub input_points: usize,
    /// Exact duplicates merged before insertion.
    pub duplicates: usize,
    /// Tetrahedra visited by point-location walks.
    pub walk_steps: u64,
    /// Tetrahedra removed in cavities (total over all insertions).
    pub cavity_tets: u64,
    /// The most vertices on one cavity's boundary (typically a few dozen; most of the
    /// points when a degenerate input makes one insertion's cavity hold most of them).
    pub largest_cavity_vertices: usize,
    /// Seconds spent ranking (lexicographic sort, duplicates), ordering (BRIO + Hilbert),
    /// inserting, compacting the arrays (and mapping vertex ids back to input indices), and
    /// renumbering canonically (0 when skipped).
    pub seconds: [f64; 5],
}

/// A Delaunay tetrahedralization of a point set, covering its convex hull.
#[derive(Clone, Debug)]
pub struct Tetrahedralization {
    points: Vec<P3>,
    /// Representative of each input point (itself unless it duplicates an earlier one).
    representative: Vec<u32>,
    /// Perturbation rank: position in lexicographic (x, y, z) order.
    rank: Vec<u32>,
    /// Vertices and encoded neighbours of each tetrahedron: finite first, then infinite.
    slots: Vec<TetSlot>,
    n_finite: usize,
    stats: BuildStats,
}

struct Builder<'a> {
    pts: &'a [P3],
    rank: &'a [u32],
    /// Integer coordinates when the input lies on a small binary lattice.
    lat: Option<&'a LatticePoints>,
    /// Every point is within the floating-point filters' range (no per-call check).
    in_range: bool,
    /// Vertices and neighbours side by side: one cache line fetch per tetrahedron visited.
    t: Vec<TetSlot>,
    mark: Vec<u32>,
    epoch: u32,
    free: Vec<u32>,
    last: u32,
    rng: SplitMix64,
    // Scratch buffers reused across insertions.
    stack: Vec<u32>,
    cavity: Vec<u32>,
    /// The cavity's boundary faces as the new tetrahedra they become.
    boundary: Vec<NewTet>,
    /// Per-vertex `(epoch, local number)` during one insertion: cavity vertices get small
    /// numbers so the faces through the new point pair up by a direct table lookup.
    local: Vec<(u32, u32)>,
    /// Pairing table indexed by the triangular number of an edge's two local numbers,
    /// below [`PAIR_TABLE_CAP`] (a cavity of up to about 360 vertices).
    table: Vec<u32>,
    /// Pairing entries of the keys at or above the cap: a degenerate input can make one
    /// cavity hold most of the points (a box corner inserted after 100,000 cocircular
    /// points on a face), and a table of its `k²/2` keys took 2.1 GB for that one
    /// insertion. Empty between insertions (every face through the new point pairs up).
    wide: HashMap<usize, u32, FxBuild>,
    stats: BuildStats,
}

/// Entries of the direct pairing table (256 KB): a cavity whose keys could reach past it
/// pairs its faces through a hash map instead. The pairing is the same either way (each
/// key is seen exactly twice).
const PAIR_TABLE_CAP: usize = 1 << 16;

/// How [`Builder::star`] pairs the new faces through the new point: `pair` stores face
/// `here` (tetrahedron slot × 4 + face) under its edge key and returns `u32::MAX`, or
/// returns the face stored there before (and forgets it).
trait Pairing {
    fn pair(b: &mut Builder<'_>, key: usize, here: u32) -> u32;
}

/// The direct table (a cavity of up to about 360 vertices: every insertion of a
/// non-degenerate input).
struct TablePairing;

impl Pairing for TablePairing {
    #[inline(always)]
    fn pair(b: &mut Builder<'_>, key: usize, here: u32) -> u32 {
        if key >= b.table.len() {
            b.table.resize((key + 1).next_power_of_two(), u32::MAX);
        }
        let g = b.table[key];
        b.table[key] = if g == u32::MAX { here } else { u32::MAX };
        g
    }
}

/// The hash map (a huge cavity).
struct WidePairing;

impl Pairing for WidePairing {
    #[inline(always)]
    fn pair(b: &mut Builder<'_>, key: usize, here: u32) -> u32 {
        match b.wide.remove(&key) {
            Some(g) => g,
            None => {
                b.wide.insert(key, here);
                u32::MAX
            }
        }
    }
}

/// A tetrahedron about to be created from a cavity boundary face: the face's tetrahedron
/// with the new point in slot `i`, and the encoded neighbour outside the cavity across
/// that slot's face.
#[derive(Clone, Copy)]
struct NewTet {
    v: [u32; 4],
    outer: u32,
    i: u8,
}

/// For a new tetrahedron with the new point in slot `i`, its face `j` (j ≠ i) contains the
/// new point and the edge between slots `EDGE[i][j]`; the face is shared with the new
/// tetrahedron on the other side of that edge.
const EDGE: [[(usize, usize); 4]; 4] = [
    [(0, 0), (2, 3), (1, 3), (1, 2)],
    [(2, 3), (0, 0), (0, 3), (0, 2)],
    [(1, 3), (0, 3), (0, 0), (0, 1)],
    [(1, 2), (0, 2), (0, 1), (0, 0)],
];

impl Tetrahedralization {
    /// Builds the Delaunay tetrahedralization of `points` with a fixed insertion seed.
    pub fn build(points: &[P3]) -> Result<Self, DelaunayError> {
        Self::build_with_seed(points, 0x5eed)
    }

    /// As [`Tetrahedralization::build`], with the seed of the randomized insertion order.
    /// The result does not depend on the seed (ties are broken symbolically); only the
    /// running time does.
    pub fn build_with_seed(points: &[P3], seed: u64) -> Result<Self, DelaunayError> {
        Self::build_with_progress(points, seed, true, &mut |_, _| {})
    }

    /// [`Tetrahedralization::build_with_seed`], reporting `(inserted, total)` every 16384
    /// insertions. With `canonical` false the canonical renumbering is skipped: the
    /// tetrahedralization is the same, but tetrahedron and face ids depend on the insertion
    /// process. That is the work CGAL's construction does, and what `bench` times.
    pub fn build_with_progress(
        points: &[P3],
        seed: u64,
        canonical: bool,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Self, DelaunayError> {
        let n = points.len();
        if n >= DEAD as usize {
            return Err(DelaunayError::TooMany(n));
        }
        if let Some((index, p)) = points
            .iter()
            .enumerate()
            .find(|(_, p)| p.iter().any(|c| !c.is_finite()))
        {
            return Err(DelaunayError::NonFinite { index, point: *p });
        }
        // Lexicographic order gives the perturbation ranks and finds exact duplicates.
        let t_start = std::time::Instant::now();
        // Sort by order-preserving integer keys (the same order as `f64::total_cmp`):
        // sequential memory instead of a comparator chasing point indices.
        // -0.0 is mapped to 0.0 first, so equal coordinates get equal keys.
        let tkey = |x: f64| {
            let b = (x + 0.0).to_bits();
            if b >> 63 == 1 { !b } else { b | (1 << 63) }
        };
        let mut keyed: Vec<([u64; 3], u32)> = points
            .iter()
            .enumerate()
            .map(|(i, p)| ([tkey(p[0]), tkey(p[1]), tkey(p[2])], i as u32))
            .collect();
        keyed.sort_unstable();
        // Equal keys are equal points: the first (smallest index) represents them.
        let mut rank = vec![0u32; n];
        let mut representative: Vec<u32> = (0..n as u32).collect();
        for r in 0..n {
            let (k, i) = keyed[r];
            rank[i as usize] = r as u32;
            if r > 0 && keyed[r - 1].0 == k {
                representative[i as usize] = representative[keyed[r - 1].1 as usize];
            }
        }
        drop(keyed);
        // Distinct points in input order (sequential reads for the ordering below).
        let unique: Vec<u32> = (0..n as u32).filter(|&i| representative[i as usize] == i).collect();
        let distinct = unique.len();
        let stats = BuildStats {
            input_points: n,
            duplicates: n - distinct,
            ..Default::default()
        };
        if distinct < 4 {
            return Err(DelaunayError::TooFewPoints { distinct });
        }
        let t_rank = t_start.elapsed().as_secs_f64();
        let (ins, storage) = sort::brio_hilbert_with_storage(points, unique, seed);
        let t_sort = t_start.elapsed().as_secs_f64();
        // The builder works on a copy of the distinct points stored in Hilbert order and
        // numbered 0..m: a point's neighbours then lie nearby in memory, whichever BRIO
        // round inserted them (input order is arbitrary; insertion order scatters each
        // neighbourhood over the rounds). Vertex ids are mapped back to input indices after
        // compaction. Ranks travel with the points, so the symbolic perturbation is unchanged.
        let local_pts: Vec<P3> = storage.iter().map(|&i| points[i as usize]).collect();
        let local_rank: Vec<u32> = storage.iter().map(|&i| rank[i as usize]).collect();
        let mut local_of = vec![0u32; n];
        for (j, &i) in storage.iter().enumerate() {
            local_of[i as usize] = j as u32;
        }
        let local_ins: Vec<u32> = ins.iter().map(|&i| local_of[i as usize]).collect();
        drop(local_of);
        let lattice = LatticePoints::detect(&local_pts);
        let mut b = Builder::new(&local_pts, &local_rank, lattice.as_ref(), seed, stats);
        let start = b.initial(&local_ins)?;
        for (k, &p) in local_ins.iter().enumerate() {
            if k % 16384 == 0 {
                progress(k, ins.len());
            }
            if start.contains(&k) {
                continue;
            }
            b.insert(p);
        }
        let t_insert = t_start.elapsed().as_secs_f64();
        let (mut slots, n_finite) = b.compact();
        let t_compact = t_start.elapsed().as_secs_f64();
        if canonical {
            // Canonical order in the builder's vertex ids (Hilbert order: neighbouring
            // tetrahedra stay near each other in memory), then back to input ids.
            slots = canonical_numbering(slots, n_finite, storage.len());
        }
        let t_canonical = t_start.elapsed().as_secs_f64();
        for s in &mut slots {
            s.v = s.v.map(|x| if x >= DEAD { x } else { storage[x as usize] });
        }
        b.stats.seconds = [
            t_rank,
            t_sort - t_rank,
            t_insert - t_sort,
            t_compact - t_insert + (t_start.elapsed().as_secs_f64() - t_canonical),
            t_canonical - t_compact,
        ];
        let stats = std::mem::take(&mut b.stats);
        drop(b);
        Ok(Tetrahedralization {
            points: points.to_vec(),
            representative,
            rank,
            slots,
            n_finite,
            stats,
        })
    }

    /// The input points, indexed by [`VertexId`] (vertex ids are input indices).
    pub fn points(&self) -> &[P3] {
        &self.points
    }
    /// Position of a vertex.
    pub fn point(&self, v: VertexId) -> &P3 {
        &self.points[v.idx()]
    }
    /// The vertex that stands for input point `i`: `i` itself, or the earlier exact duplicate.
    pub fn representative(&self, i: usize) -> VertexId {
        VertexId(self.representative[i])
    }
    /// Number of finite tetrahedra.
    pub fn num_tets(&self) -> usize {
        self.n_finite
    }
    /// Number of hull faces (= number of infinite tetrahedra).
    pub fn num_hull_faces(&self) -> usize {
        self.slots.len() - self.n_finite
    }
    /// Number of distinct vertices.
    pub fn num_vertices(&self) -> usize {
        self.points.len() - self.stats.duplicates
    }
    /// Build statistics.
    pub fn stats(&self) -> &BuildStats {
        &self.stats
    }
    /// Vertices of a finite tetrahedron, positively oriented.
    #[inline]
    pub fn tet(&self, t: TetId) -> [VertexId; 4] {
        self.slots[t.idx()].v.map(VertexId)
    }
    /// All finite tetrahedra.
    pub fn tets(&self) -> impl Iterator<Item = (TetId, [VertexId; 4])> + '_ {
        self.slots[..self.n_finite]
            .iter()
            .enumerate()
            .map(|(i, s)| (TetId(i as u32), s.v.map(VertexId)))
    }
    /// The finite tetrahedron across face `face` (opposite vertex slot `face`) of `t`, and
    /// the index of the shared face in it; `None` on the convex hull.
    #[inline]
    pub fn neighbor(&self, t: TetId, face: usize) -> Option<(TetId, usize)> {
        let a = self.slots[t.idx()].n[face];
        let n = (a >> 2) as usize;
        (n < self.n_finite).then_some((TetId(n as u32), (a & 3) as usize))
    }
    /// The three vertices of face `face` of `t`, counter-clockwise seen from outside `t`.
    #[inline]
    pub fn face(&self, t: TetId, face: usize) -> [VertexId; 3] {
        let v = self.slots[t.idx()].v;
        FACE_SLOTS[face].map(|s| VertexId(v[s]))
    }
    /// Hull faces: (finite tetrahedron, face index) pairs whose outside is the unbounded region.
    pub fn hull_faces(&self) -> impl Iterator<Item = (TetId, usize)> + '_ {
        self.slots[self.n_finite..].iter().map(move |slot| {
            let s = slot.v.iter().position(|&x| x == INFINITE).expect("infinite tet");
            let a = slot.n[s];
            (TetId(a >> 2), (a & 3) as usize)
        })
    }
    /// Signed volume of a finite tetrahedron (positive; computed in floating point).
    pub fn volume(&self, t: TetId) -> f64 {
        let [a, b, c, d] = self.slots[t.idx()].v.map(|v| self.points[v as usize]);
        let u = sub(&b, &a);
        let v = sub(&c, &a);
        let w = sub(&d, &a);
        (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0]))
            / 6.0
    }
    /// Every finite tetrahedron as its sorted vertex ids, sorted: the combinatorics alone,
    /// to compare two tetrahedralizations of the same input (vertex ids are input indices).
    pub fn sorted_tets(&self) -> Vec<[u32; 4]> {
        let mut v: Vec<[u32; 4]> = self.slots[..self.n_finite]
            .iter()
            .map(|s| {
                let mut k = s.v;
                k.sort_unstable();
                k
            })
            .collect();
        v.sort_unstable();
        v
    }
    /// The same triangulation with its vertices moved to `points` (indexed like the input,
    /// e.g. the input after a rotation). Used to separate what a rigid motion changes in the
    /// Delaunay tetrahedralization (cospherical ties, broken by a perturbation keyed to the
    /// lexicographic order, which a rotation changes; near-ties that rounding decides) from
    /// what it changes downstream: the cell complex built on the moved triangulation sees the
    /// moved coordinates but the unmoved combinatorics. `None` when the lengths differ, a
    /// point is not finite, or a tetrahedron is not positively oriented at its moved
    /// vertices (exact `orient3d`): then it is not a triangulation of the moved points. The
    /// result is a triangulation (every tetrahedron positive, the same face pairing) but not
    /// necessarily Delaunay, and its hull may be non-convex by rounding where hull points
    /// were coplanar.
    pub fn moved(&self, points: &[P3]) -> Option<Self> {
        if points.len() != self.points.len() || points.iter().flatten().any(|c| !c.is_finite()) {
            return None;
        }
        let positive = self.slots[..self.n_finite].iter().all(|s| {
            let [a, b, c, d] = s.v.map(|v| &points[v as usize]);
            crate::predicates::orient3d(a, b, c, d) > 0
        });
        positive.then(|| Tetrahedralization {
            points: points.to_vec(),
            ..self.clone()
        })
    }
    /// Bytes held by this structure's arrays (excluding the allocator's overhead).
    pub fn heap_bytes(&self) -> usize {
        self.points.capacity() * 24
            + self.representative.capacity() * 4
            + self.rank.capacity() * 4
            + self.slots.capacity() * 32
    }
}

impl<'a> Builder<'a> {
    fn new(pts: &'a [P3], rank: &'a [u32], lat: Option<&'a LatticePoints>, seed: u64, stats: BuildStats) -> Self {
        let cap = pts.len() * 7;
        Builder {
            pts,
            rank,
            lat,
            in_range: pts.iter().all(in_filter_range),
            t: Vec::with_capacity(cap),
            mark: Vec::with_capacity(cap),
            epoch: 0,
            free: Vec::new(),
            last: 0,
            rng: SplitMix64(seed ^ 0xA5A5_5A5A),
            stack: Vec::new(),
            cavity: Vec::new(),
            boundary: Vec::new(),
            local: vec![(0, 0); pts.len() + 1],
            table: Vec::new(),
            wide: HashMap::default(),
            stats,
        }
    }

    #[inline]
    fn p(&self, v: u32) -> &'a P3 {
        &self.pts[v as usize]
    }

    /// Finds four affinely independent points among the first insertion candidates, builds
    /// the first tetrahedron and its four infinite neighbours. Returns the positions (in
    /// `ins`) of the points used.
    fn initial(&mut self, ins: &[u32]) -> Result<[usize; 4], DelaunayError> {
        let distinct = ins.len();
        let i0 = 0;
        let i1 = 1;
        let (a, b) = (self.p(ins[i0]), self.p(ins[i1]));
        let i2 = (2..ins.len())
            .find(|&k| !crate::predicates::collinear(a, b, self.p(ins[k])))
            .ok_or(DelaunayError::Degenerate {
                distinct,
                what: "collinear",
            })?;
        let c = self.p(ins[i2]);
        let (i3, o) = (2..ins.len())
            .filter(|&k| k != i2)
            .map(|k| (k, orient3d(a, b, c, self.p(ins[k]))))
            .find(|&(_, o)| o != 0)
            .ok_or(DelaunayError::Degenerate {
                distinct,
                what: "coplanar",
            })?;
        let mut v = [ins[i0], ins[i1], ins[i2], ins[i3]];
        if o < 0 {
            v.swap(0, 1);
        }
        // Finite tetrahedron 0 and one infinite tetrahedron per face.
        let slot = |v| TetSlot { v, n: [u32::MAX; 4] };
        self.t.push(slot(v));
        for f in FACE_SLOTS {
            self.t.push(slot([v[f[0]], v[f[1]], v[f[2]], INFINITE]));
        }
        self.mark = vec![0; 5];
        // Pair faces by their vertex sets (only five tetrahedra: quadratic is fine).
        for t in 0..5 {
            for i in 0..4 {
                if self.t[t].n[i] != u32::MAX {
                    continue;
                }
                let key = face_key(&self.t[t].v, i);
                'search: for u in 0..5 {
                    if u == t {
                        continue;
                    }
                    for j in 0..4 {
                        if face_key(&self.t[u].v, j) == key {
                            self.t[t].n[i] = (u * 4 + j) as u32;
                            self.t[u].n[j] = (t * 4 + i) as u32;
                            break 'search;
                        }
                    }
                }
            }
        }
        self.last = 0;
        Ok([i0, i1, i2, i3])
    }

    /// Orientation of tetrahedron `t` with vertex slot `s` replaced by point `q`.
    /// For infinite tetrahedra the infinite vertex must not be at slot `s`... unless it is
    /// being replaced, in which case this is the plain orientation of the finite face and q.
    #[inline]
    fn orient_with(&self, v: &[u32; 4], s: usize, p: u32) -> i32 {
        let mut w = *v;
        w[s] = p;
        if let Some(l) = self.lat {
            return l.orient3d(w[0], w[1], w[2], w[3]);
        }
        self.orient(self.p(w[0]), self.p(w[1]), self.p(w[2]), self.p(w[3]))
    }

    /// Exact orientation, without the per-call range check when every point passed it.
    #[inline(always)]
    fn orient(&self, a: &P3, b: &P3, c: &P3, d: &P3) -> i32 {
        if self.in_range {
            orient3d_in_range(a, b, c, d)
        } else {
            orient3d(a, b, c, d)
        }
    }

    #[inline(always)]
    fn insphere_finite(&self, v: &[u32; 4], p: u32) -> i32 {
        let r = self.rank;
        if let Some(l) = self.lat {
            return l.insphere_sos([v[0], v[1], v[2], v[3], p], |x| r[x as usize]);
        }
        let pts = [self.p(v[0]), self.p(v[1]), self.p(v[2]), self.p(v[3]), self.p(p)];
        let s = if self.in_range {
            insphere_in_range(pts[0], pts[1], pts[2], pts[3], pts[4])
        } else {
            insphere(pts[0], pts[1], pts[2], pts[3], pts[4])
        };
        if s != 0 {
            return s;
        }
        sos_tie([v[0], v[1], v[2], v[3], p].map(|x| r[x as usize]), |q| {
            self.orient(pts[q[0]], pts[q[1]], pts[q[2]], pts[q[3]])
        })
    }

    /// Whether point `p` conflicts with tetrahedron `t` (lies inside its circumsphere, or
    /// for an infinite tetrahedron, strictly outside its hull face, or on the face's plane
    /// inside its circumcircle — decided as for the finite neighbour, so both agree).
    #[inline(always)]
    fn in_conflict(&self, t: u32, p: u32) -> bool {
        let v = &self.t[t as usize].v;
        if let Some(k) = v.iter().position(|&x| x == INFINITE) {
            let o = self.orient_with(v, k, p);
            if o != 0 {
                return o > 0;
            }
            let n = self.t[t as usize].n[k] >> 2;
            self.insphere_finite(&self.t[n as usize].v, p) > 0
        } else {
            self.insphere_finite(v, p) > 0
        }
    }

    /// Remembering stochastic walk from the last created tetrahedron to one whose closure
    /// contains `p`, or to an infinite tetrahedron whose hull face `p` is strictly beyond.
    /// Also says whether `p` is strictly inside the finite tetrahedron found (every face's
    /// orientation positive; the face the walk came through is positive because it was
    /// crossed), in which case it is certainly in conflict with it.
    fn locate(&mut self, p: u32) -> (u32, bool) {
        let mut t = self.last;
        let mut prev = u32::MAX;
        loop {
            let v = self.t[t as usize].v;
            if v.contains(&INFINITE) {
                return (t, false);
            }
            let r = (self.rng.next_u64() & 3) as usize;
            let mut next = None;
            let mut on_face = false;
            for j in 0..4 {
                let i = (r + j) & 3;
                let n = self.t[t as usize].n[i] >> 2;
                if n == prev {
                    continue;
                }
                let o = self.orient_with(&v, i, p);
                if o < 0 {
                    next = Some(n);
                    break;
                }
                on_face |= o == 0;
            }
            self.stats.walk_steps += 1;
            match next {
                Some(n) => {
                    prev = t;
                    t = n;
                }
                None => return (t, !on_face),
            }
        }
    }

    /// `p` lies on the boundary of `t` but is not in conflict with it: the conflicting
    /// tetrahedron is among those sharing the face, edge or vertex `p` lies on. Searches
    /// across the faces of `t` whose plane contains `p`.
    #[cold]
    fn seed_on_boundary(&mut self, t0: u32, p: u32) -> u32 {
        let no = 2 * self.epoch + 1;
        self.stack.clear();
        self.stack.push(t0);
        self.mark[t0 as usize] = no;
        while let Some(t) = self.stack.pop() {
            let v = self.t[t as usize].v;
            if v.contains(&INFINITE) {
                continue;
            }
            for i in 0..4 {
                let n = self.t[t as usize].n[i] >> 2;
                if self.mark[n as usize] == no || self.orient_with(&v, i, p) != 0 {
                    continue;
                }
                if self.in_conflict(n, p) {
                    return n;
                }
                self.mark[n as usize] = no;
                self.stack.push(n);
            }
        }
        unreachable!("a point is in conflict with some tetrahedron whose closure contains it")
    }

    fn insert(&mut self, p: u32) {
        let (seed, inside) = self.locate(p);
        self.grow_cavity(seed, inside, p);
        self.star();
    }

    /// Collects the tetrahedra in conflict with `p` (depth-first from the located one)
    /// into `cavity`, and the cavity's boundary faces, already turned into the new
    /// tetrahedra with `p` at the face's opposite slot, into `boundary`.
    #[inline(never)] // a phase of its own in profiles
    fn grow_cavity(&mut self, mut seed: u32, inside: bool, p: u32) {
        // Marks: 2*epoch = in cavity, 2*epoch+1 = tested and not in conflict. Marks of
        // earlier insertions are smaller, so none need clearing, until the epoch wraps.
        if self.epoch >= u32::MAX / 2 - 2 {
            self.mark.iter_mut().for_each(|m| *m = 0);
            self.local.iter_mut().for_each(|l| *l = (0, 0));
            self.epoch = 0;
        }
        self.epoch += 1;
        // A point strictly inside the located tetrahedron is inside its circumsphere.
        if !inside && !self.in_conflict(seed, p) {
            seed = self.seed_on_boundary(seed, p);
            self.epoch += 1;
        }
        let (yes, no) = (2 * self.epoch, 2 * self.epoch + 1);
        self.cavity.clear();
        self.boundary.clear();
        self.stack.clear();
        self.mark[seed as usize] = yes;
        self.stack.push(seed);
        while let Some(t) = self.stack.pop() {
            self.cavity.push(t);
            let slot = self.t[t as usize];
            // The four neighbours' marks and slots are scattered in memory: request them
            // all before testing the first (two dependent cache misses each otherwise).
            for a in slot.n {
                let n = (a >> 2) as usize;
                prefetch(&self.mark[n]);
                prefetch(&self.t[n]);
            }
            for (i, a) in slot.n.into_iter().enumerate() {
                let n = a >> 2;
                let m = self.mark[n as usize];
                if m == yes {
                    continue;
                }
                if m != no && self.in_conflict(n, p) {
                    self.mark[n as usize] = yes;
                    self.stack.push(n);
                } else {
                    self.mark[n as usize] = no;
                    let mut v = slot.v;
                    v[i] = p;
                    self.boundary.push(NewTet {
                        v,
                        outer: a,
                        i: i as u8,
                    });
                }
            }
        }
        self.stats.cavity_tets += self.cavity.len() as u64;
    }

    /// Replaces the cavity by the star of the new point over its boundary: one new tetrahedron per
    /// boundary face, in the cavity's own slots first. Each is linked to the outer
    /// neighbour of its face, and its three faces through the new point are paired with the other
    /// new tetrahedra by the edge opposite the point (each such face is shared by exactly two).
    #[inline(never)] // a phase of its own in profiles
    fn star(&mut self) {
        // A closed triangulated surface of F faces has F/2 + 2 vertices, so the keys stay
        // below the direct table's cap when (F/2 + 2)² / 2 does.
        let v = self.boundary.len() / 2 + 2;
        if v * v / 2 < PAIR_TABLE_CAP {
            self.star_with::<TablePairing>()
        } else {
            self.star_with::<WidePairing>()
        }
    }

    #[inline(always)]
    fn star_with<P: Pairing>(&mut self) {
        let stamp = self.epoch;
        let inf_local = self.pts.len();
        let mut k = 0u32;
        let mut created_finite = u32::MAX;
        let boundary = std::mem::take(&mut self.boundary);
        for (c, f) in boundary.iter().enumerate() {
            let u = if let Some(&u) = self.cavity.get(c) {
                u
            } else if let Some(u) = self.free.pop() {
                u
            } else {
                self.t.push(TetSlot {
                    v: [DEAD; 4],
                    n: [u32::MAX; 4],
                });
                self.mark.push(0);
                (self.t.len() - 1) as u32
            };
            let i = f.i as usize;
            self.t[u as usize].v = f.v;
            self.t[u as usize].n[i] = f.outer;
            self.t[(f.outer >> 2) as usize].n[(f.outer & 3) as usize] = u * 4 + i as u32;
            if created_finite == u32::MAX && !f.v.contains(&INFINITE) {
                created_finite = u;
            }
            // Local numbers of the three vertices of the boundary face.
            let mut l = [0u32; 4];
            for s in 0..4 {
                if s != i {
                    let e = &mut self.local[(f.v[s] as usize).min(inf_local)];
                    if e.0 != stamp {
                        *e = (stamp, k);
                        k += 1;
                    }
                    l[s] = e.1;
                }
            }
            for j in 0..4 {
                if j == i {
                    continue;
                }
                let (s1, s2) = EDGE[i][j];
                let (lo, hi) = (l[s1].min(l[s2]) as usize, l[s1].max(l[s2]) as usize);
                let key = hi * (hi - 1) / 2 + lo;
                let here = u * 4 + j as u32;
                let g = P::pair(self, key, here);
                if g != u32::MAX {
                    self.t[u as usize].n[j] = g;
                    self.t[(g >> 2) as usize].n[(g & 3) as usize] = here;
                }
            }
        }
        self.stats.largest_cavity_vertices = self.stats.largest_cavity_vertices.max(k as usize);
        // Cavity slots the star did not need (only when it has fewer tetrahedra than the
        // cavity) are freed.
        for c in boundary.len()..self.cavity.len() {
            let t = self.cavity[c];
            self.t[t as usize].v = [DEAD; 4];
            self.free.push(t);
        }
        self.boundary = boundary;
        self.last = created_finite;
    }

    /// Renumbers so finite tetrahedra come first and drops dead slots. Only the few slots
    /// that must move are touched: every hole below the finite count (a dead or infinite
    /// slot) takes a finite slot from above it, and the infinite slots go after the finite
    /// ones; then the moved slots' references and their neighbours' back-references are
    /// rewritten. Cost: one sequential scan plus work in the number of moved slots (the
    /// hull and the unused free list), not a remap of every reference.
    fn compact(&mut self) -> (Vec<TetSlot>, usize) {
        let is_finite = |s: &TetSlot| s.v[0] != DEAD && !s.v.contains(&INFINITE);
        let n_finite = self.t.iter().filter(|s| is_finite(s)).count();
        let mut infinite: Vec<u32> = Vec::new();
        let mut holes: Vec<u32> = Vec::new();
        let mut movers: Vec<u32> = Vec::new();
        for (t, s) in self.t.iter().enumerate() {
            let fin = is_finite(s);
            if s.v[0] != DEAD && !fin {
                infinite.push(t as u32);
            }
            if t < n_finite && !fin {
                holes.push(t as u32);
            } else if t >= n_finite && fin {
                movers.push(t as u32);
            }
        }
        debug_assert_eq!(holes.len(), movers.len());
        // Old index -> new index + 1 of every moved slot, 0 for the others (a zeroed
        // allocation: pages never written cost nothing).
        let mut moved_to = vec![0u32; self.t.len()];
        let mut moved: Vec<u32> = Vec::with_capacity(movers.len() + infinite.len());
        for (&from, &to) in movers.iter().zip(&holes) {
            moved_to[from as usize] = to + 1;
            moved.push(from);
        }
        for (k, &from) in infinite.iter().enumerate() {
            moved_to[from as usize] = (n_finite + k) as u32 + 1;
            moved.push(from);
        }
        let remap = |a: u32| match moved_to[(a >> 2) as usize] {
            0 => a,
            t => (t - 1) * 4 + (a & 3),
        };
        // New contents of the moved slots, read before anything is overwritten.
        let placed: Vec<(u32, TetSlot)> = moved
            .iter()
            .map(|&from| {
                let s = self.t[from as usize];
                (
                    moved_to[from as usize] - 1,
                    TetSlot {
                        v: s.v,
                        n: s.n.map(remap),
                    },
                )
            })
            .collect();
        let mut slots = std::mem::take(&mut self.t);
        slots.truncate(n_finite);
        slots.resize(
            n_finite + infinite.len(),
            TetSlot {
                v: [DEAD; 4],
                n: [0; 4],
            },
        );
        for &(to, s) in &placed {
            slots[to as usize] = s;
        }
        // Neighbours still name the moved slots' old indices.
        for &(to, s) in &placed {
            for (i, &a) in s.n.iter().enumerate() {
                slots[(a >> 2) as usize].n[(a & 3) as usize] = to * 4 + i as u32;
            }
        }
        // No shrink_to_fit: the spare capacity is the insertion's head room (a few percent),
        // and shrinking copies the whole array.
        self.mark = Vec::new();
        (slots, n_finite)
    }
}

/// The even permutations of four slots, each as `new slot k takes old slot PERM[..][k]`.
const EVEN: [[usize; 4]; 12] = [
    [0, 1, 2, 3],
    [0, 2, 3, 1],
    [0, 3, 1, 2],
    [1, 0, 3, 2],
    [1, 2, 0, 3],
    [1, 3, 2, 0],
    [2, 0, 1, 3],
    [2, 1, 3, 0],
    [2, 3, 0, 1],
    [3, 0, 2, 1],
    [3, 1, 0, 2],
    [3, 2, 1, 0],
];

/// Renumbers tetrahedra and their slots canonically, in the builder's vertex ids (the
/// Hilbert storage order, ties by input order): within each tetrahedron the smallest such
/// id first, then the smallest of the rest (an even permutation, so orientation is kept);
/// finite tetrahedra, then infinite ones, in increasing order of their id quadruples.
/// Tetrahedron and face ids then depend only on the input, points and their order (the
/// Delaunay tetrahedralization with symbolic perturbation is unique), not on the insertion
/// order, the seed or the builder's slot reuse, so everything built on them (cells, patches, the
/// order of equal-weight collapses) is reproducible across versions of this module.
/// Cost: a counting sort by smallest vertex, short sorts within each bucket, and one pass
/// over the neighbour references.
fn canonical_numbering(slots: Vec<TetSlot>, n_finite: usize, n_vertices: usize) -> Vec<TetSlot> {
    let n = slots.len();
    // INV[k][old slot] = new slot under EVEN[k].
    const INV: [[u8; 4]; 12] = {
        let mut inv = [[0u8; 4]; 12];
        let mut k = 0;
        while k < 12 {
            let mut s = 0;
            while s < 4 {
                inv[k][EVEN[k][s]] = s as u8;
                s += 1;
            }
            k += 1;
        }
        inv
    };
    // The even permutation that puts each tetrahedron in canonical slot order: the rows of
    // EVEN starting with the smallest vertex's slot are 3m..3m+3; of those, the one whose
    // second slot holds the smallest of the other three vertices.
    let perm: Vec<u8> = slots
        .iter()
        .map(|s| {
            let v = s.v;
            let m = (0..4).min_by_key(|&k| v[k]).expect("four slots");
            (3 * m..3 * m + 3).min_by_key(|&r| v[EVEN[r][1]]).expect("three rows") as u8
        })
        .collect();
    let key = |t: usize| EVEN[perm[t] as usize].map(|o| slots[t].v[o]);
    // Counting sort by the smallest vertex (INFINITE is never smallest), per class, then
    // short sorts within each bucket.
    let mut order: Vec<u32> = Vec::with_capacity(n);
    let mut start = vec![0u32; n_vertices + 1];
    for range in [0..n_finite, n_finite..n] {
        start.iter_mut().for_each(|x| *x = 0);
        for t in range.clone() {
            start[slots[t].v[EVEN[perm[t] as usize][0]] as usize + 1] += 1;
        }
        for k in 0..n_vertices {
            start[k + 1] += start[k];
        }
        let base = order.len();
        order.resize(base + range.len(), 0);
        let mut fill = start.clone();
        for t in range.clone() {
            let b = &mut fill[slots[t].v[EVEN[perm[t] as usize][0]] as usize];
            order[base + *b as usize] = t as u32;
            *b += 1;
        }
        for k in 0..n_vertices {
            let (a, b) = (base + start[k] as usize, base + start[k + 1] as usize);
            if b - a > 1 {
                order[a..b].sort_unstable_by_key(|&t| key(t as usize));
            }
        }
    }
    let mut new_of = vec![0u32; n];
    for (k, &t) in order.iter().enumerate() {
        new_of[t as usize] = k as u32;
    }
    order
        .iter()
        .map(|&t| {
            let t = t as usize;
            let p = EVEN[perm[t] as usize];
            let s = slots[t];
            TetSlot {
                v: p.map(|o| s.v[o]),
                n: p.map(|o| {
                    let a = s.n[o];
                    let (m, f) = ((a >> 2) as usize, (a & 3) as usize);
                    new_of[m] * 4 + u32::from(INV[perm[m] as usize][f])
                }),
            }
        })
        .collect()
}

#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
struct TetSlot {
    v: [u32; 4],
    n: [u32; 4],
}

fn face_key(v: &[u32; 4], i: usize) -> [u32; 3] {
    let mut k = FACE_SLOTS[i].map(|s| v[s]);
    k.sort_unstable();
    k
}

#[cfg(test)]
mod tests;
