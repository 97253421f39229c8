//! The cell complex: tetrahedra split by model polygons, the portal graph between cells,
//! and the flood fill that removes the outside (Gjørup 1999, sections 4.2.1 and 4.2.2).
//!
//! Topology and geometry are kept apart: a [`Cell`] is a convex polyhedron (geometry, from
//! [`crate::geom`]) whose faces are tagged with [`PatchId`]s; a [`Patch`] is the topology —
//! one convex piece of boundary shared by exactly two cells (or a cell and the hull), with
//! the occluders (clipped model polygons) lying on it. Portals are computed from patches
//! as *patch minus occluders*, and grouped per cell pair.
//!
//! Stages ([`CellComplex::build`]):
//! 1. **Cells from tetrahedra.** One cell per finite tetrahedron, one patch per face.
//! 2. **Conforming polygons, no geometry.** A polygon whose fan triangles are all faces of
//!    the tetrahedralization already lies on cell boundaries: its triangles become occluders
//!    on those faces' patches, found by a hash lookup of vertex triples. The side it faces
//!    is decided combinatorially (cyclic vertex order), so exactly.
//! 3. **Splitting.** Every other polygon visits only the cells it touches, by a breadth-first
//!    search over patches starting at the cells around its first vertex. A straddled cell
//!    is split by the polygon's plane (the whole cell, so pieces stay convex); the clipped
//!    polygon becomes an occluder on the new patch, facing the front piece. A cell whose
//!    face lies on the polygon and that sees the polygon's front gets the overlap as an
//!    occluder. Tetrahedra (input vertices only) are classified against the polygon's plane
//!    with exact [`orient3d`](crate::predicates::orient3d); split cells with tolerances.
//!    The polygon is placed on its group's support plane, so the search reaches every cell
//!    within `coplanar` of it.
//! 4. **Sealing cracks.** A crossing that did not split (the polygon's part in the cell
//!    below the area tolerance) is remembered; after all polygons, every piece the cell
//!    was later cut into whose cross-section is covered by the polygons (up to cracks) is
//!    split with the [`Tolerances::sealing`] thresholds, however small the section: else
//!    the piece joins the wall's two sides (a sliver wedge passing behind a wall corner).
//! 5. **Portal graph.** Each patch between two cells, minus all its occluders (either
//!    side), gives convex portal pieces; pieces below the area tolerance or narrower than
//!    [`Tolerances::sliver_width`] are slivers (cracks), counted and dropped. Pieces are
//!    grouped per cell pair into [`Portal`]s. A sliver opening that is the only one between
//!    two cells is kept apart as a crack link ([`CellComplex::cracks`]; after stage 6 only
//!    those within one region), for visibility only. Flat cells (four nearly coplanar input
//!    points) and cells thinner than the sliver width are membranes, not nodes
//!    ([`CellComplex::is_membrane`]): the cells below and above one are joined over the
//!    overlap of their open faces.
//! 6. **Exterior removal.** Connected regions of the portal graph where no cell faces an
//!    occluder are removed (the outside; the inside of walls). Facing is in the crack
//!    sense ([`CellComplex::faces_occluder`]): sliver occluders and cells thinner than the
//!    sliver width do not count. A region that faces occluders *and* reaches the hull
//!    through an uncovered hull patch is a leak: reported, with the path
//!    ([`CellComplex::leak_pointfile`]), and kept.
//! 7. **Sealing holes** (optional, [`CellComplex::seal_holes`]): stage 6 again, with the
//!    openings of leaking regions narrower than a given size closed; what was sealed is
//!    reported ([`SealedOpening`]).
//!
//! Invariants (checked by [`CellComplex::validate`]): alive cells are convex with positive
//! volume and their face tags name live patches that list them; each patch's two cells
//! hold it; portals are symmetric; before removal, cell volumes sum to the hull volume;
//! every cell's boundary area equals its patches' area, and each patch's area is covered
//! by its occluders plus its portal pieces (plus discarded slivers); no model polygon
//! crosses a cell's interior, neither with a significant fragment nor by covering the
//! cell's whole cross-section (a crack crossing).

mod build;
mod graph;
mod seal;
mod validate;

pub(crate) use build::{polygon_supports, project};

pub use seal::{FRONT_SHARE, SealedOpening};
pub use validate::{ComplexError, ComplexValidation};

use std::borrow::Cow;

use crate::base::vec::{cross, dot, key, sub};
use crate::delaunay::FACE_SLOTS;
use crate::geom::{ConvexPolygon, ConvexPolyhedron, Plane, check_faces, contains_of, moments_of, vertices_of};
use crate::ids::{CellId, PolygonId, TetId};
use crate::predicates::P3;
use crate::tolerances::Tolerances;
use serde::Serialize;
use thin_vec::ThinVec;

/// The outside of the convex hull, as the second cell of a hull patch.
pub const HULL: CellId = CellId(u32::MAX);

/// Index of a [`Patch`] (the crate's one `PatchId`, from [`crate::ids`]).
pub use crate::ids::PatchId;

/// A clipped model polygon lying on a patch.
#[derive(Clone, Debug)]
pub struct Occluder {
    /// The fragment (inside the patch polygon, coplanar with it).
    pub polygon: ConvexPolygon,
    /// The model polygon it was clipped from.
    pub source: PolygonId,
    /// Which of the patch's two cells its front side faces (0 or 1).
    pub faces: u8,
}

/// One convex piece of boundary between two cells (or a cell and the hull).
#[derive(Clone, Debug)]
pub struct Patch {
    /// Counter-clockwise seen from outside `cells[0]`: its normal points into `cells[1]`.
    pub polygon: ConvexPolygon,
    /// The two cells; `cells[1]` is [`HULL`] on the convex hull.
    pub cells: [CellId; 2],
    /// Occluders lying on this patch (from either side). A [`ThinVec`]: 8 bytes in the
    /// patch (its length and capacity live in the heap block), since most patches of a
    /// large model carry none (a `Vec` would be 24).
    pub occluders: ThinVec<Occluder>,
    /// False once the patch was replaced (split in two).
    pub alive: bool,
}

/// A convex cell.
///
/// Its geometry is held in one of two forms. A tetrahedron that no polygon has cut stays
/// **implicit** ([`TetShape`]: its four corners, and per face its patch and where the
/// face's vertex loop starts): 120 bytes and no heap block, against about 430 for the
/// same tetrahedron as a [`ConvexPolyhedron`] (four inline triangles and two heap
/// blocks). Most cells of a large model are never cut (every cell of a conforming
/// building), so this is most of the complex's memory. [`Cell::poly`] gives the
/// polyhedron either way: for an implicit tetrahedron, the very faces (vertex order,
/// starting vertex, tags) it would hold if materialised, so no result depends on the
/// form; [`Cell::poly_mut`] materialises it in place (the splitting stages).
#[derive(Clone, Debug)]
pub struct Cell {
    /// Geometry; face tags are [`PatchId`]s (see [`Cell::poly`], [`Cell::tags`]).
    shape: Shape,
    /// The tetrahedron it descends from; `None` for cells not built from a
    /// tetrahedralization (the leaves of [`crate::bsp`]).
    pub tet: Option<TetId>,
    /// False once split (replaced by its pieces).
    pub alive: bool,
    /// True once removed by the exterior flood fill.
    pub exterior: bool,
    /// An unsplit tetrahedron thinner than the weld distance (or with volume below
    /// [`crate::geom::min_volume`]): four nearly coplanar input points. It keeps the
    /// complex conforming but holds no space (thesis 4.2.1 discards such tetrahedra): it
    /// never counts as facing an occluder and has no portals of its own; the cells on its
    /// two sides are joined through it instead, and the flood fill removes it.
    pub flat: bool,
}

#[derive(Clone, Debug)]
enum Shape {
    Tet(TetShape),
    Poly(ConvexPolyhedron),
}

/// An uncut tetrahedron's geometry without its faces materialised.
///
/// Face `i` is the triangle of the corners [`FACE_SLOTS`]`[i]` (the tetrahedralization's
/// face `i`, outward), its loop rotated to start at its `start[i]`-th vertex, tagged
/// `tags[i]`: exactly the patch polygon `from_tets` gives that face (reversed where the
/// cell is the patch's second cell).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TetShape {
    /// The four corners, in the tetrahedralization's slot order.
    pub corners: [P3; 4],
    /// Face `i`'s patch.
    pub tags: [u32; 4],
    /// Where face `i`'s vertex loop starts (0, 1 or 2).
    pub start: [u8; 4],
}

impl TetShape {
    /// Face `i`'s loop.
    pub fn face(&self, i: usize) -> [P3; 3] {
        let [a, b, c] = FACE_SLOTS[i].map(|s| self.corners[s]);
        match self.start[i] {
            0 => [a, b, c],
            1 => [b, c, a],
            _ => [c, a, b],
        }
    }

    /// The four faces as inline triangles (no heap block).
    pub fn faces(&self) -> [ConvexPolygon; 4] {
        std::array::from_fn(|i| ConvexPolygon::from_slice(&self.face(i)))
    }

    /// The distinct corners in order of first appearance along faces `0..4`, deduplicated
    /// by [`key`] as [`vertices_of`] does: the same points in the same order as
    /// `vertices_of(&self.faces())`, without building the faces (the collapses ask for
    /// the vertices of thousands of cells per judgement on real levels).
    pub fn vertices(&self) -> Vec<P3> {
        let mut keys = [[0u64; 3]; 4];
        let mut out = Vec::with_capacity(4);
        for i in 0..4 {
            for v in self.face(i) {
                let k = key(&v);
                // At most four distinct keys: the corners.
                if !keys[..out.len()].contains(&k) {
                    keys[out.len()] = k;
                    out.push(v);
                }
            }
        }
        out
    }

    /// Whether each corner is surely farther than `w` from the plane of the opposite face,
    /// as any floating-point evaluation of that plane would place it: a sufficient test
    /// that needs no face. The height over a face is `6V / (2A)`, and no face of a
    /// tetrahedron in a box of diagonal `D` has area above `D^2 / 2`, so every height is at
    /// least `6V / D^2`; the test asks that bound to exceed `w` by margins far above the
    /// rounding of the volume's determinant (`~10 eps D^3`) and of a plane's evaluation
    /// (`eps (M + D)` for coordinates up to `M`, plus the normal's direction error
    /// `eps D^2 / 2A` times the way `D`, with `A >= 3V / D`).
    pub fn surely_thicker_than(&self, w: f64) -> bool {
        let [a, b, c, d] = self.corners;
        let (mut lo, mut hi) = (a, a);
        for p in [b, c, d] {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let d2 = (0..3).map(|k| (hi[k] - lo[k]) * (hi[k] - lo[k])).sum::<f64>();
        let m = (0..3).map(|k| lo[k].abs().max(hi[k].abs())).fold(0.0, f64::max);
        let (u, v, x) = (sub(&b, &a), sub(&c, &a), sub(&d, &a));
        let six_v = dot(&u, &cross(&v, &x)).abs();
        let eps = 64.0 * f64::EPSILON;
        let dd = d2.sqrt();
        // A lower bound of 6V, and with it of every height.
        let six_v_lo = six_v - eps * (m + dd) * d2;
        if !(six_v_lo > 0.0 && d2 > 0.0 && d2.is_finite()) {
            return false;
        }
        let height = six_v_lo / d2;
        let margin = eps * (m + dd) + eps * d2 * d2 / six_v_lo;
        height > w + margin
    }

    /// The materialised polyhedron (faces in order `0..4`, tags `tags`).
    pub fn polyhedron(&self) -> ConvexPolyhedron {
        ConvexPolyhedron::from_faces(self.faces().to_vec(), self.tags.to_vec())
    }
}

impl Cell {
    /// An alive, interior cell with the given geometry.
    pub fn new(poly: ConvexPolyhedron, tet: Option<TetId>, flat: bool) -> Cell {
        Cell {
            shape: Shape::Poly(poly),
            tet,
            alive: true,
            exterior: false,
            flat,
        }
    }

    /// An alive, interior cell that is an implicit tetrahedron.
    pub fn tetrahedron(shape: TetShape, tet: Option<TetId>, flat: bool) -> Cell {
        Cell {
            shape: Shape::Tet(shape),
            tet,
            alive: true,
            exterior: false,
            flat,
        }
    }

    /// Alive and not removed as exterior.
    pub fn active(&self) -> bool {
        self.alive && !self.exterior
    }

    /// The geometry as a polyhedron: borrowed, or built (no heap block per face) for an
    /// implicit tetrahedron. Prefer [`Cell::faces`], [`Cell::tags`], [`Cell::volume`] and
    /// friends where they serve: they build nothing.
    pub fn poly(&self) -> Cow<'_, ConvexPolyhedron> {
        match &self.shape {
            Shape::Tet(t) => Cow::Owned(t.polyhedron()),
            Shape::Poly(p) => Cow::Borrowed(p),
        }
    }

    /// The geometry for changing it: an implicit tetrahedron is materialised first.
    pub fn poly_mut(&mut self) -> &mut ConvexPolyhedron {
        if let Shape::Tet(t) = &self.shape {
            self.shape = Shape::Poly(t.polyhedron());
        }
        match &mut self.shape {
            Shape::Poly(p) => p,
            Shape::Tet(_) => unreachable!("materialised above"),
        }
    }

    /// Replaces the geometry.
    pub fn set_poly(&mut self, poly: ConvexPolyhedron) {
        self.shape = Shape::Poly(poly);
    }

    /// The implicit tetrahedron, while the cell is one.
    pub fn tet_shape(&self) -> Option<&TetShape> {
        match &self.shape {
            Shape::Tet(t) => Some(t),
            Shape::Poly(_) => None,
        }
    }

    /// One tag per face: the faces' patches.
    pub fn tags(&self) -> &[u32] {
        match &self.shape {
            Shape::Tet(t) => &t.tags,
            Shape::Poly(p) => &p.tags,
        }
    }

    /// The faces, in the order of [`Cell::tags`]: borrowed, or an implicit tetrahedron's
    /// four inline triangles built once on the stack (no heap block).
    pub fn faces(&self) -> FaceList<'_> {
        match &self.shape {
            Shape::Tet(t) => FaceList::Tet(t.faces()),
            Shape::Poly(p) => FaceList::Poly(&p.faces),
        }
    }

    /// The faces one by one, borrowed or owned (for callers that keep them).
    pub fn faces_cow(&self) -> impl Iterator<Item = Cow<'_, ConvexPolygon>> + '_ {
        let (tet, poly) = match &self.shape {
            Shape::Tet(t) => (Some(t), &[][..]),
            Shape::Poly(p) => (None, &p.faces[..]),
        };
        let n = if tet.is_some() { 4 } else { 0 };
        (0..n)
            .map(move |i| Cow::Owned(ConvexPolygon::from_slice(&tet.expect("n is 0 without one").face(i))))
            .chain(poly.iter().map(Cow::Borrowed))
    }

    /// Number of faces (0 once the geometry was released).
    pub fn num_faces(&self) -> usize {
        self.tags().len()
    }

    /// `(volume, centroid)`, the bits of `poly().volume()` and `poly().centroid()`.
    fn moments(&self) -> (f64, P3) {
        match &self.shape {
            Shape::Tet(t) => {
                let f: [[P3; 3]; 4] = std::array::from_fn(|i| t.face(i));
                moments_of(f.iter().map(|v| &v[..]))
            }
            Shape::Poly(p) => moments_of(p.faces.iter().map(|f| &f.verts[..])),
        }
    }

    /// Volume (the bits of [`ConvexPolyhedron::volume`]).
    pub fn volume(&self) -> f64 {
        self.moments().0
    }

    /// Volume centroid (the bits of [`ConvexPolyhedron::centroid`]).
    pub fn centroid(&self) -> P3 {
        self.moments().1
    }

    /// Total boundary area (the bits of [`ConvexPolyhedron::surface_area`]).
    pub fn surface_area(&self) -> f64 {
        self.faces().iter().map(|f| f.area()).sum()
    }

    /// Axis-aligned bounding box (as [`ConvexPolyhedron::aabb`]).
    pub fn aabb(&self) -> (P3, P3) {
        match &self.shape {
            Shape::Tet(t) => crate::base::vec::bounds(&t.corners),
            Shape::Poly(p) => p.aabb(),
        }
    }

    /// Whether `p` lies in the cell (as [`ConvexPolyhedron::contains`]).
    pub fn contains(&self, p: &P3, tol: &Tolerances) -> bool {
        contains_of(&self.faces(), p, tol)
    }

    /// [`ConvexPolyhedron::check`] of the geometry (an implicit tetrahedron is checked
    /// on its stack-built faces, the same tests and messages).
    pub fn check(&self, tol: &Tolerances) -> Result<(), String> {
        match &self.shape {
            Shape::Tet(t) => check_faces(&t.faces(), 4, tol),
            Shape::Poly(p) => p.check(tol),
        }
    }

    /// Distinct vertices, in order of first appearance (as [`ConvexPolyhedron::vertices`]).
    pub fn vertices(&self) -> Vec<P3> {
        match &self.shape {
            Shape::Tet(t) => t.vertices(),
            Shape::Poly(p) => vertices_of(&p.faces),
        }
    }

    /// Frees the geometry (no faces, no tags); ids and flags stay.
    pub(crate) fn release(&mut self) {
        self.shape = Shape::Poly(ConvexPolyhedron::from_faces(Vec::new(), Vec::new()));
    }
}

/// A cell's faces ([`Cell::faces`]): derefs to `[ConvexPolygon]`. A short-lived stack
/// value, so the tetrahedron's 320 bytes inline are the point (no heap block), not waste.
#[allow(clippy::large_enum_variant)]
pub enum FaceList<'a> {
    /// An implicit tetrahedron's faces, built on the stack.
    Tet([ConvexPolygon; 4]),
    /// A polyhedron's faces.
    Poly(&'a [ConvexPolygon]),
}

impl std::ops::Deref for FaceList<'_> {
    type Target = [ConvexPolygon];
    fn deref(&self) -> &[ConvexPolygon] {
        match self {
            FaceList::Tet(f) => f,
            FaceList::Poly(f) => f,
        }
    }
}

/// All portal pieces between one pair of cells.
#[derive(Clone, Debug, Serialize)]
pub struct Portal {
    /// The two cells, `cells[0] < cells[1]`.
    pub cells: [CellId; 2],
    /// Convex pieces, each oriented with its normal pointing from `cells[0]` to `cells[1]`.
    #[serde(skip)]
    pub pieces: Pieces,
    /// Sum of the pieces' areas.
    pub area: f64,
}

/// A portal's pieces: one held inline (most cell pairs meet over one patch: a portal of
/// a large model is then one 96-byte value with no heap block, against 40 bytes plus a
/// 96-byte block for a `Vec` of one), more in a `Vec`. Derefs to `[ConvexPolygon]`;
/// equality and `Debug` are those of the slice, so no value depends on the form.
#[derive(Clone, Default)]
pub struct Pieces(PiecesRepr);

#[derive(Clone)]
enum PiecesRepr {
    One(ConvexPolygon),
    Many(Vec<ConvexPolygon>),
}

impl Default for PiecesRepr {
    fn default() -> Self {
        PiecesRepr::Many(Vec::new())
    }
}

impl Pieces {
    /// No pieces.
    pub const fn new() -> Self {
        Pieces(PiecesRepr::Many(Vec::new()))
    }

    /// Appends a piece.
    pub fn push(&mut self, p: ConvexPolygon) {
        match &mut self.0 {
            PiecesRepr::Many(v) if v.is_empty() && v.capacity() == 0 => self.0 = PiecesRepr::One(p),
            PiecesRepr::Many(v) => v.push(p),
            PiecesRepr::One(_) => {
                let PiecesRepr::One(first) = std::mem::take(&mut self.0) else {
                    unreachable!("matched One")
                };
                self.0 = PiecesRepr::Many(vec![first, p]);
            }
        }
    }

    /// The pieces as a `Vec`.
    pub fn into_vec(self) -> Vec<ConvexPolygon> {
        match self.0 {
            PiecesRepr::One(p) => vec![p],
            PiecesRepr::Many(v) => v,
        }
    }

    /// Drops growth slack (one piece moves inline).
    pub fn shrink_to_fit(&mut self) {
        if let PiecesRepr::Many(v) = &mut self.0 {
            if v.len() == 1 {
                let p = v.pop().expect("one piece");
                self.0 = PiecesRepr::One(p);
            } else {
                v.shrink_to_fit();
            }
        }
    }
}

impl std::ops::Deref for Pieces {
    type Target = [ConvexPolygon];
    fn deref(&self) -> &[ConvexPolygon] {
        match &self.0 {
            PiecesRepr::One(p) => std::slice::from_ref(p),
            PiecesRepr::Many(v) => v,
        }
    }
}

impl std::ops::DerefMut for Pieces {
    fn deref_mut(&mut self) -> &mut [ConvexPolygon] {
        match &mut self.0 {
            PiecesRepr::One(p) => std::slice::from_mut(p),
            PiecesRepr::Many(v) => v,
        }
    }
}

impl PartialEq for Pieces {
    fn eq(&self, other: &Self) -> bool {
        **self == **other
    }
}

impl std::fmt::Debug for Pieces {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        (**self).fmt(f)
    }
}

impl From<Vec<ConvexPolygon>> for Pieces {
    fn from(mut v: Vec<ConvexPolygon>) -> Self {
        if v.len() == 1 {
            Pieces(PiecesRepr::One(v.pop().expect("one piece")))
        } else {
            Pieces(PiecesRepr::Many(v))
        }
    }
}

impl FromIterator<ConvexPolygon> for Pieces {
    fn from_iter<I: IntoIterator<Item = ConvexPolygon>>(iter: I) -> Self {
        iter.into_iter().collect::<Vec<_>>().into()
    }
}

impl Extend<ConvexPolygon> for Pieces {
    fn extend<I: IntoIterator<Item = ConvexPolygon>>(&mut self, iter: I) {
        for p in iter {
            self.push(p);
        }
    }
}

impl IntoIterator for Pieces {
    type Item = ConvexPolygon;
    type IntoIter = std::vec::IntoIter<ConvexPolygon>;
    fn into_iter(self) -> Self::IntoIter {
        self.into_vec().into_iter()
    }
}

impl<'a> IntoIterator for &'a Pieces {
    type Item = &'a ConvexPolygon;
    type IntoIter = std::slice::Iter<'a, ConvexPolygon>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

/// A leak: a region that faces occluders but reaches the convex hull (qbsp's sense).
#[derive(Clone, Debug, Serialize)]
pub struct Leak {
    /// Cells in the region.
    pub region_cells: usize,
    /// The interior cell the path starts from (one facing occluders, farthest from the hull).
    pub from_cell: CellId,
    /// The cells of a shortest path from `from_cell` to a cell with an open hull face.
    pub path: Vec<CellId>,
    /// A point on the first portal of that path (its centroid).
    pub first_portal_point: [f64; 3],
    /// A point on the uncovered hull face where the path leaves the model.
    pub hull_point: [f64; 3],
}

fn is_zero(x: &u32) -> bool {
    *x == 0
}

fn is_zero_usize(x: &usize) -> bool {
    *x == 0
}

fn is_zero_f64(x: &f64) -> bool {
    *x == 0.0
}

/// Counts and timings in the thesis's terms.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ComplexStats {
    /// Finite tetrahedra of the Delaunay tetrahedralization.
    pub tetrahedra: usize,
    /// Model polygons.
    pub polygons: usize,
    /// Polygons whose triangles were already tetrahedron faces (no geometry done).
    pub polygons_conforming: usize,
    /// Polygons placed by clipping and splitting.
    pub polygons_clipped: usize,
    /// Distinct support planes among them (nearly coplanar polygons share one).
    pub support_planes: usize,
    /// Cell splits performed (each adds one cell).
    pub cells_split: usize,
    /// Splits refused because a piece would have been a sliver (the polygon was attached
    /// to the nearby face instead, or left unplaced).
    pub splits_refused: usize,
    /// Neighbours cut by the splitting plane together with the split cell, because
    /// subdividing their face would have left them non-convex beyond tolerance (see
    /// `try_commit_split`).
    pub neighbour_cuts: usize,
    /// Splits committed with another On band than the cut's first choice, because the
    /// first left a neighbour invalid (see `try_commit_split_any`).
    pub alternative_cuts: usize,
    /// Splits that sealed a crack: a cell whose section by a support plane is covered by
    /// that plane's polygons up to cracks, split after placement (see `seal_cracks`).
    pub cells_sealed: usize,
    /// Polygon fragments that could be neither split on nor attached (area in model units²).
    pub unplaced_fragments: usize,
    /// Cells after splitting.
    pub cells_after_split: usize,
    /// Cells removed by the exterior flood fill.
    pub exterior_cells_removed: usize,
    /// Cells left.
    pub active_cells: usize,
    /// Cell pairs joined by portals (among active cells).
    pub portal_pairs: usize,
    /// Convex portal polygons (among active cells).
    pub portal_polygons: usize,
    /// Portal pieces discarded as slivers (area below tolerance).
    pub slivers_discarded: usize,
    /// Their total area.
    pub sliver_area: f64,
    /// Regions removed as exterior.
    pub exterior_regions: usize,
    /// Cells removed as exterior that face a polygon's front but are thinner than
    /// [`crate::Tolerances::sliver_width`] (or flat), so they count as facing nothing
    /// ([`CellComplex::faces_occluder`]) and, having no portals of their own when they are
    /// membranes, make regions of their own. Normally a few wedges between nearly
    /// coincident copies of a wall (a tiny volume); a large volume means the model has
    /// detail below the sliver width (e.g. a floor of triangles narrower than it, whose
    /// vertices make every tetrahedron above it a sliver) and its rooms lost that volume.
    /// Not serialized when 0.
    #[serde(skip_serializing_if = "is_zero_usize")]
    pub thin_removed_cells: usize,
    /// Their volume (model units³). `run` and `complex` warn when it exceeds 1% of the
    /// volume kept ([`CellComplex::thin_loss_warning`]). Not serialized when 0.
    #[serde(skip_serializing_if = "is_zero_f64")]
    pub thin_removed_volume: f64,
    /// Regions kept.
    pub interior_regions: usize,
    /// Leaks found.
    pub leaks: usize,
    /// Openings sealed by [`CellComplex::seal_holes`] (holes, each of one or more portals).
    pub openings_sealed: usize,
    /// The polygons appear to face the wrong way: the exterior flood fill kept no region
    /// that stays inside (every kept region leaks, or none was kept), while with every
    /// polygon's winding reversed some region would be kept and none would leak (the
    /// regions, portals and hull openings do not depend on the winding, so this is what
    /// the reversed model's flood fill gives, sealing aside). Typically a model whose every
    /// face was exported reversed: the rooms face only back sides and are removed, the
    /// space around the model faces the outer walls' fronts and leaks. Not serialized.
    #[serde(skip)]
    pub faces_reversed: bool,
    /// The fallback level of the tolerances this complex was built with
    /// ([`crate::Tolerances::fallback`]; 0: the model's own). Set by
    /// [`crate::pipeline::build_cells`] when the complex at the lower levels failed its
    /// checks. Not serialized when 0.
    #[serde(skip_serializing_if = "is_zero")]
    pub tolerance_level: u32,
    /// Why the lower levels were rejected, one line each (`level K: <violated
    /// invariant>`); empty (and not serialized) at level 0.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub rejected_levels: Vec<String>,
    /// Stage timings in seconds, in order.
    pub timings: Vec<(String, f64)>,
    /// The process's peak resident memory (MiB, Linux `VmHWM`) at the end of each stage of
    /// [`CellComplex::build`], named like `timings` (empty where it cannot be read). Not
    /// serialized: like timings, a property of the machine and the process.
    #[serde(skip)]
    pub memory: Vec<(String, f64)>,
}

use crate::base::mem::peak_rss_mib;

impl ComplexStats {
    /// Records a finished stage: its seconds in `timings`, the peak memory in `memory`.
    pub(crate) fn stage(&mut self, name: &str, secs: f64) {
        self.timings.push((name.to_string(), secs));
        if let Some(m) = peak_rss_mib() {
            self.memory.push((name.to_string(), m));
        }
    }
}

/// The cell complex with its portal graph.
#[derive(Clone, Debug)]
pub struct CellComplex {
    /// All cells ever created (dead ones stay, so ids are stable).
    pub cells: Vec<Cell>,
    /// All patches ever created.
    pub patches: Vec<Patch>,
    /// Portals between active cells, after [`CellComplex::build`].
    pub portals: Vec<Portal>,
    /// **Crack links**: openings dropped as slivers (uncovered patch pieces below the area
    /// tolerance or narrower than [`Tolerances::sliver_width`]) that are the *only*
    /// connection between two cells, kept as (tiny) portals that only visibility uses
    /// ([`crate::visibility::PortalGraph`]): a sight line may pass such an opening. Not in
    /// [`CellComplex::portals`], so the flood fill, leaks, sealing and the decimation do
    /// not see them. Invariant: both cells are active, are not joined by a portal, and lie
    /// in the same region of the portal graph (a crack never joins two regions, so it
    /// cannot re-open a leak that dropping slivers closed: a noisy wall's seams between
    /// the room and the inside of the wall or the outside are dropped as before).
    pub cracks: Vec<Portal>,
    /// Leaks found by the flood fill.
    pub leaks: Vec<Leak>,
    /// Counts and timings.
    pub stats: ComplexStats,
    /// The tolerances used.
    pub tol: Tolerances,
    /// Volume of the region the cells fill: the convex hull (sum of tetrahedron volumes),
    /// or the bounding box for a BSP complex ([`crate::bsp`]).
    pub hull_volume: f64,
    /// The support plane each model polygon was placed on, oriented like the polygon
    /// (nearly coplanar polygons share one; see `Tolerances::coplanar`).
    pub polygon_planes: Vec<Plane>,
    /// Cells that reach an open hull face through flat cells, with a point there (found by
    /// the portal graph stage, used by the exterior flood fill).
    hull_through: Vec<(CellId, [f64; 3])>,
    /// Neighbours cut together with a split cell (`try_commit_split`): (old cell, front
    /// piece, back piece), appended by each committed split and drained by the caller
    /// (the Delaunay placer and the BSP tree track live cells).
    pub(crate) neighbour_log: Vec<(CellId, CellId, CellId)>,
    /// While `Some` (the splitting stage's dry runs): every cell a split may have changed
    /// (killed, reshaped, or whose patches now lead elsewhere), appended by each split,
    /// undone ones too; drained by the caller.
    pub(crate) touched: Option<Vec<CellId>>,
    /// Each cell's volume, once the cells are final ([`CellComplex::cache_volumes`]; NaN
    /// for a dead cell; empty: not cached). A split clears it.
    volumes: Vec<f64>,
    /// Per model polygon: attached without geometry because its fan triangles are faces of
    /// the tetrahedralization (`attach_conforming`; empty when not built from one). Such a
    /// polygon cannot cross the interior of a tetrahedron of that tetrahedralization, so
    /// [`CellComplex::check_no_crossing`] does not test it against implicit tetrahedra.
    pub(crate) conforming: Vec<bool>,
}

impl CellComplex {
    /// A complex over cells and patches built elsewhere (the leaves of [`crate::bsp`]),
    /// with the same invariants as [`CellComplex::build`]'s before its portal graph stage:
    /// the caller may still split cells ([`CellComplex::commit_split`]) and add occluders,
    /// then runs [`CellComplex::build_graph`] and [`CellComplex::remove_exterior`].
    /// `hull_volume` is the volume the cells fill (checked by [`CellComplex::validate`]).
    pub(crate) fn from_parts(
        cells: Vec<Cell>,
        patches: Vec<Patch>,
        tol: Tolerances,
        hull_volume: f64,
        polygon_planes: Vec<Plane>,
        stats: ComplexStats,
    ) -> CellComplex {
        CellComplex {
            cells,
            patches,
            portals: Vec::new(),
            cracks: Vec::new(),
            leaks: Vec::new(),
            stats,
            tol,
            hull_volume,
            polygon_planes,
            hull_through: Vec::new(),
            neighbour_log: Vec::new(),
            touched: None,
            volumes: Vec::new(),
            conforming: Vec::new(),
        }
    }

    /// Computes every alive cell's volume once, on every core, for
    /// [`CellComplex::cell_volume`]: the checks, the decimation (both passes) and the
    /// outputs each read every active cell's volume, and a split cell's is a polyhedron's
    /// moment (8 B per cell). For a complex whose cells are final: the pipeline calls it
    /// after the build, before the checks; a later split clears it.
    pub fn cache_volumes(&mut self) {
        use rayon::prelude::*;
        self.volumes = self
            .cells
            .par_iter()
            .with_min_len(1024)
            .map(|c| if c.alive { c.volume() } else { f64::NAN })
            .collect();
    }

    /// The volume of cell `c`: the bits of `cells[c].volume()`, read from the cache when
    /// [`CellComplex::cache_volumes`] filled it.
    pub fn cell_volume(&self, c: CellId) -> f64 {
        match self.volumes.get(c.idx()) {
            Some(&v) if !v.is_nan() => v,
            _ => self.cells[c.idx()].volume(),
        }
    }

    /// Frees the geometry that only the build needed, once it is done and checked: the
    /// polyhedra of cells that are not active (split, or removed as exterior — about a
    /// third of the tetrahedra of a closed building), the polygons and occluders of dead
    /// (replaced) patches, and the polygons of live patches with no active cell on either
    /// side. Kept: every id, flag and count, the live patches' cells and occluders (the
    /// clearance field is over all of them), the portals, leaks, and everything about
    /// active cells — so the decimation and the outputs, which read only active cells,
    /// their patches and the portals, do not change (`tests/release.rs`). Afterwards the
    /// whole-complex checks ([`CellComplex::validate`]'s volume sum) no longer apply: the
    /// pipeline calls this after its checks, before the decimation, so that the
    /// decimation's memory reuses what the removed cells held. Returns the number of
    /// cells and patches whose geometry was freed.
    pub fn release_inactive(&mut self) -> (usize, usize) {
        let (mut cells, mut patches) = (0, 0);
        for c in self.cells.iter_mut().filter(|c| !c.active()) {
            if c.num_faces() > 0 {
                c.release();
                cells += 1;
            }
        }
        let active = |c: CellId| c != HULL && self.cells[c.idx()].active();
        let release: Vec<(bool, bool)> = self
            .patches
            .iter()
            .map(|p| (!p.alive, !p.alive || !(active(p.cells[0]) || active(p.cells[1]))))
            .collect();
        for (p, (dead, unused)) in self.patches.iter_mut().zip(release) {
            if unused && !p.polygon.verts.is_empty() {
                p.polygon = ConvexPolygon::new(Vec::new());
                patches += 1;
            }
            if dead {
                p.occluders = ThinVec::new();
            }
        }
        self.cells.shrink_to_fit();
        self.patches.shrink_to_fit();
        self.portals.shrink_to_fit();
        self.cracks.shrink_to_fit();
        (cells, patches)
    }

    /// Drops the growth slack of the build's vectors (a `Vec` pushed once holds room for
    /// four): occluders and their polygons, patch polygons, alive cells' faces and tags,
    /// portal and crack pieces. Contents, ids and order are unchanged. The build calls it
    /// last, so the checks and the decimation run on the smaller heap.
    pub(crate) fn shrink_storage(&mut self) {
        use rayon::prelude::*;
        fn poly(p: &mut ConvexPolygon) {
            p.verts.shrink_to_fit();
        }
        self.patches.par_iter_mut().with_min_len(1024).for_each(|p| {
            if p.alive {
                poly(&mut p.polygon);
            }
            p.occluders.shrink_to_fit();
            p.occluders.iter_mut().for_each(|o| poly(&mut o.polygon));
        });
        self.cells.par_iter_mut().with_min_len(1024).for_each(|c| {
            if c.alive
                && let Shape::Poly(p) = &mut c.shape
            {
                p.faces.shrink_to_fit();
                p.tags.shrink_to_fit();
                p.faces.iter_mut().for_each(poly);
            }
        });
        for list in [&mut self.portals, &mut self.cracks] {
            list.par_iter_mut().with_min_len(1024).for_each(|p| {
                p.pieces.shrink_to_fit();
                p.pieces.iter_mut().for_each(poly);
            });
            list.shrink_to_fit();
        }
    }

    /// Alive cells (not split), including exterior ones.
    pub fn alive_cells(&self) -> impl Iterator<Item = (CellId, &Cell)> {
        self.cells
            .iter()
            .enumerate()
            .filter(|(_, c)| c.alive)
            .map(|(i, c)| (CellId(i as u32), c))
    }
    /// Active cells (alive, not exterior).
    pub fn active_cells(&self) -> impl Iterator<Item = (CellId, &Cell)> {
        self.cells
            .iter()
            .enumerate()
            .filter(|(_, c)| c.active())
            .map(|(i, c)| (CellId(i as u32), c))
    }
    /// The other cell of a patch, seen from `c`.
    pub fn across(&self, p: PatchId, c: CellId) -> CellId {
        let cs = self.patches[p.idx()].cells;
        if cs[0] == c { cs[1] } else { cs[0] }
    }
    /// Whether any occluder on the cell's patches faces the cell, in the crack sense:
    /// occluders that are cracks themselves (below the area tolerance or narrower than
    /// [`Tolerances::sliver_width`], e.g. the strip a polygon's edge leaves on a patch it
    /// only grazes) do not count, just as portal pieces like that do not connect; and a
    /// cell that is itself a crack ([`CellComplex::is_thin`]) faces nothing, like a flat
    /// tetrahedron.
    pub fn faces_occluder(&self, c: CellId) -> bool {
        self.faced_by(c, true)
    }

    /// [`CellComplex::faces_occluder`] with every polygon's winding reversed: whether some
    /// occluder on the cell's patches turns its back side to the cell (same crack rules).
    pub fn faces_occluder_back(&self, c: CellId) -> bool {
        self.faced_by(c, false)
    }

    /// The warning for volume lost to the sliver rules
    /// ([`ComplexStats::thin_removed_volume`] above 1% of the volume kept), or `None`.
    /// The volume kept is only summed when the removed volume is not negligible against
    /// the hull's, so a normal model pays nothing.
    pub fn thin_loss_warning(&self) -> Option<String> {
        let lost = self.stats.thin_removed_volume;
        if lost.is_nan() || lost <= 1e-4 * self.hull_volume {
            return None;
        }
        let kept: f64 = self.active_cells().map(|(_, c)| c.volume()).sum();
        if lost <= 0.01 * kept {
            return None;
        }
        let w = self.tol.sliver_width();
        let share = if kept > 0.0 {
            format!("{:.1}% of the {kept:.4e} kept", 100.0 * lost / kept)
        } else {
            "nothing else was kept".to_string()
        };
        Some(format!(
            "warning: {} cells of volume {lost:.4e} ({share}) face polygons but were removed \
             as exterior because each is thinner than the sliver width {w:.3e} (1e-5 of the bounding-box \
             diagonal): the model has detail below that width (e.g. polygons or vertex spacings narrower \
             than it), so the rooms there lost that volume. \
             Merge or remesh the thin polygons (e.g. Blender's Decimate > Planar or Limited Dissolve)",
            self.stats.thin_removed_cells,
        ))
    }

    /// Whether some occluder's front faces the cell, sliver occluders and thin or flat
    /// cells included: what [`CellComplex::faces_occluder`] would say without its sliver
    /// rules (see [`ComplexStats::thin_removed_cells`]).
    pub fn faces_any_front(&self, c: CellId) -> bool {
        let cell = &self.cells[c.idx()];
        cell.tags().iter().any(|&t| {
            let p = &self.patches[t as usize];
            let side = if p.cells[0] == c { 0 } else { 1 };
            p.occluders.iter().any(|o| o.faces == side)
        })
    }

    /// Whether an occluder's front (`front`) or back side faces the cell, in the sense of
    /// [`CellComplex::faces_occluder`].
    fn faced_by(&self, c: CellId, front: bool) -> bool {
        let cell = &self.cells[c.idx()];
        let facing = cell.tags().iter().any(|&t| {
            let p = &self.patches[t as usize];
            let side = if p.cells[0] == c { 0 } else { 1 };
            p.occluders
                .iter()
                .any(|o| (o.faces == side) == front && !graph::is_sliver(&o.polygon, &self.tol))
        });
        facing && !cell.flat && !self.is_thin(c)
    }

    /// A cell thinner than [`Tolerances::sliver_width`]: twice its volume over its surface
    /// area (a lower bound of its width, exact for a slab) is below it. Such cells arise
    /// as wedges between nearly coincident planes where one wall is placed twice (on its
    /// support plane and, by near attachment, on a tetrahedron face a hair away); the
    /// wedge lies inside the wall, so it must not make its region count as interior.
    pub fn is_thin(&self, c: CellId) -> bool {
        let cell = &self.cells[c.idx()];
        2.0 * cell.volume() < self.tol.sliver_width() * cell.surface_area()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `is_membrane`'s answer from the faces alone (the biggest face's plane, every
    /// vertex within `w`), without the thickness pre-test.
    fn membrane_by_faces(faces: &[ConvexPolygon], w: f64) -> bool {
        let big = faces.iter().max_by(|a, b| a.area().total_cmp(&b.area())).unwrap();
        let pl = big.plane().normalized();
        faces.iter().all(|f| f.verts.iter().all(|v| pl.eval(v).abs() < w))
    }

    /// A tetrahedron the pre-test calls thick is never a membrane by the faces: on every
    /// tetrahedron of the thesis models (noisy, distorted) and on random tetrahedra whose
    /// apex stands 0.2 to 50 sliver widths over their base, at offsets up to 1e9 and
    /// scales 1e-4 to 1e4, the sliver width 1e-6 of the size; and the test spares most
    /// tetrahedra of a model their faces.
    #[test]
    fn a_surely_thick_tetrahedron_is_no_membrane() {
        let mut passed = 0usize;
        let mut tets = 0usize;
        for name in ["noisy", "four_room_distorted", "caverns"] {
            let tm = crate::generate::thesis::by_name(name).unwrap();
            let m = crate::model::from_soup(tm.name, tm.soup.vertices.clone(), tm.soup.polygons.clone()).unwrap();
            let cx = crate::pipeline::complex_of_unchecked(&m).unwrap();
            let w = cx.tol.sliver_width();
            for c in &cx.cells {
                let Some(t) = c.tet_shape() else { continue };
                tets += 1;
                if t.surely_thicker_than(w) {
                    passed += 1;
                    assert!(!membrane_by_faces(&t.faces(), w), "{name}: {t:?}");
                }
            }
        }
        assert!(passed * 10 > tets * 9, "{passed} of {tets} tetrahedra spared");
        let mut rng = crate::base::rng::SplitMix64(5);
        let mut near = 0usize;
        for i in 0..20000 {
            let scale = [1e-4, 1.0, 1e4][i % 3];
            let offset = [0.0, 1e3, 1e6, 1e9][(i / 3) % 4];
            let w = 1e-6 * scale;
            let mut p = || [rng.unit(), rng.unit(), 0.0];
            let (a, b, c) = (p(), p(), p());
            let h = w * (0.2 + 49.8 * rng.unit());
            let apex = [rng.unit(), rng.unit(), h / scale];
            let at = |q: [f64; 3]| q.map(|x| offset + x * scale);
            let t = TetShape {
                corners: [at(a), at(b), at(c), at(apex)],
                tags: [0, 1, 2, 3],
                start: [0; 4],
            };
            if t.surely_thicker_than(w) {
                assert!(!membrane_by_faces(&t.faces(), w), "case {i}: {t:?}");
                near += usize::from(h < 10.0 * w);
            }
        }
        // Some tetrahedra within ten widths are still told apart by the test.
        assert!(near > 0);
    }

    /// The cached volumes are each cell's own bits.
    #[test]
    fn cached_volumes_have_the_cells_bits() {
        let tm = crate::generate::thesis::by_name("four_room_distorted").unwrap();
        let m = crate::model::from_soup(tm.name, tm.soup.vertices.clone(), tm.soup.polygons.clone()).unwrap();
        let mut cx = crate::pipeline::complex_of(&m).unwrap();
        cx.volumes = Vec::new();
        let alive: Vec<CellId> = (0..cx.cells.len() as u32)
            .map(CellId)
            .filter(|c| cx.cells[c.idx()].alive)
            .collect();
        assert!(alive.len() > 100);
        let own: Vec<u64> = alive.iter().map(|c| cx.cells[c.idx()].volume().to_bits()).collect();
        cx.cache_volumes();
        assert_eq!(cx.volumes.len(), cx.cells.len());
        let read: Vec<u64> = alive.iter().map(|&c| cx.cell_volume(c).to_bits()).collect();
        assert_eq!(read, own);
    }

    /// An implicit tetrahedron's vertices are `vertices_of` its faces, bit for bit and in
    /// order: every cell of a complex, and tetrahedra with signed zeros (one key) in every
    /// corner slot and loop start.
    #[test]
    fn tet_vertices_equal_the_vertices_of_its_faces() {
        let bits = |v: &[P3]| v.iter().map(|p| p.map(f64::to_bits)).collect::<Vec<_>>();
        let tm = crate::generate::thesis::by_name("four_room_distorted").unwrap();
        let m = crate::model::from_soup(tm.name, tm.soup.vertices.clone(), tm.soup.polygons.clone()).unwrap();
        let cx = crate::pipeline::complex_of(&m).unwrap();
        let mut tets = 0;
        for c in cx.cells.iter().filter(|c| c.alive) {
            let (fast, slow) = (c.vertices(), vertices_of(&c.faces()));
            assert_eq!(bits(&fast), bits(&slow));
            tets += matches!(c.shape, Shape::Tet(_)) as usize;
        }
        assert!(tets > 100, "{tets}");
        let corners = [[0.0, 0.0, 0.0], [-0.0, 1.0, 0.0], [1.0, -0.0, 0.0], [0.0, 0.0, -1.0]];
        for rot in 0..4 {
            for start in 0..81u32 {
                let t = TetShape {
                    corners: std::array::from_fn(|i| corners[(i + rot) % 4]),
                    tags: [0, 1, 2, 3],
                    start: std::array::from_fn(|i| (start / 3u32.pow(i as u32) % 3) as u8),
                };
                let faces = t.faces();
                assert_eq!(bits(&t.vertices()), bits(&vertices_of(&faces)), "{rot} {start}");
            }
        }
    }

    /// The compact forms are what they claim: an implicit tetrahedron's cell and a
    /// one-piece portal hold no heap block, and a patch's occluder list is one pointer,
    /// in the sizes the docs give.
    #[test]
    fn cells_and_portals_are_compact() {
        assert!(std::mem::size_of::<Cell>() <= 144, "{}", std::mem::size_of::<Cell>());
        assert_eq!(std::mem::size_of::<Pieces>(), std::mem::size_of::<ConvexPolygon>());
        assert!(std::mem::size_of::<Portal>() <= 96, "{}", std::mem::size_of::<Portal>());
        assert!(std::mem::size_of::<Patch>() <= 104, "{}", std::mem::size_of::<Patch>());
    }

    /// `Pieces` reads as the slice of what was pushed, whatever its form.
    #[test]
    fn pieces_hold_what_was_pushed_in_order() {
        let tri = |x: f64| ConvexPolygon::from_slice(&[[x, 0.0, 0.0], [x, 1.0, 0.0], [x, 0.0, 1.0]]);
        let mut p = Pieces::new();
        assert!(p.is_empty());
        p.push(tri(0.0));
        assert_eq!(&*p, &[tri(0.0)][..]);
        p.push(tri(1.0));
        p.extend([tri(2.0)]);
        assert_eq!(&*p, &[tri(0.0), tri(1.0), tri(2.0)][..]);
        assert_eq!(p.clone().into_vec(), vec![tri(0.0), tri(1.0), tri(2.0)]);
        let one: Pieces = vec![tri(3.0)].into();
        let mut many = Pieces::from(vec![tri(3.0), tri(4.0)]);
        many.shrink_to_fit();
        assert_eq!(one.len(), 1);
        assert_eq!(one, Pieces::from_iter([tri(3.0)]));
        assert_ne!(one, many);
        assert_eq!(many.iter().count(), 2);
    }
}
