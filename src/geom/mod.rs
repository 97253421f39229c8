//! Convex geometry kernel for the cell complex: planes, convex polygons ("patches",
//! "occluders", "portals") and convex polyhedra ("cells") as split-friendly B-reps.
//!
//! Gjørup's method (thesis ch. 4) needs three operations on convex pieces: split a cell
//! by a model polygon's plane ([`ConvexPolyhedron::cut`]), clip a model polygon to a cell
//! ([`ConvexPolyhedron::clip_polygon`], giving an occluder on a patch), and subtract the
//! occluders from a patch ([`ConvexPolygon::subtract`], giving the portal pieces).
//!
//! # Conventions
//!
//! - [`Plane`] is `n·x = d`, `n` of any non-zero length. [`Plane::from_points`]`(a, b, c)`
//!   uses `n = (b−a)×(c−a)`: the front is where `a, b, c` look counter-clockwise, matching
//!   [`crate::predicates::orient3d`]`(a, b, c, p) > 0`.
//! - A [`ConvexPolygon`]'s vertices are counter-clockwise seen from the side its Newell
//!   normal points to.
//! - A [`ConvexPolyhedron`]'s faces have outward normals; inside is where every face
//!   plane's signed distance is `<= 0`.
//! - [`PolyhedronSplit::section`] has normal along the cutting plane's `n`: it is the
//!   *back* piece's new face (pointing to the front); the front piece holds it reversed.
//!
//! # Tolerances
//!
//! Every threshold comes from a [`Tolerances`](crate::Tolerances) argument (all relative
//! to the model size `scale`); this module defines no epsilon of its own.
//!
//! | decision                                               | threshold                   |
//! |--------------------------------------------------------|-----------------------------|
//! | vertex Front / Back / On a plane (or an edge line, 2D)   | `plane_abs()`               |
//! | polygon split part, intersection, clip result, subtraction piece, cross-section too small | `area_abs()` |
//! | vertex Front / Back / On a plane that cuts a polyhedron: first `plane_abs()`; if that gives no valid pieces, `snap_abs()` = `max(weld_abs(), plane_abs())` (neighbours' faces are subdivided with the same one) | `plane_abs()`, then `snap_abs()` |
//! | convexity allowance of a polyhedron or polygon (`check`, `is_convex`, `contains`) | `snap_abs()` + rounding |
//! | polyhedron piece too small                             | [`min_volume`] = `(area·scale)³` |
//! | edges ignored in point-in-polygon / convexity checks     | shorter than `weld_abs()`   |
//!
//! Decisions are made on floating-point distances with these tolerances, not with the
//! exact predicates (those decide the tetrahedralization; here the inputs are constructed
//! points anyway). Distances are evaluated with a compensated dot product and all
//! polygon/polyhedron formulas work relative to a vertex of the object, so coordinates
//! ~1e6 away from the origin cost nothing beyond their own rounding.
//!
//! # Invariants of [`ConvexPolyhedron`] (checked by [`ConvexPolyhedron::check`])
//!
//! 1. `tags.len() == faces.len()`; every face has ≥ 3 vertices, none repeated
//!    consecutively; ≥ 4 faces; positive volume.
//! 2. **Closed and conforming**: vertices are identified by their exact coordinates
//!    (bits), and every directed edge `p → q` of a face occurs reversed, `q → p`, in
//!    exactly one other face. The boundary may be *subdivided*: a facet may be tiled by
//!    several coplanar faces (patches, e.g. one per neighbouring cell), and a face may
//!    carry collinear T-vertices where an adjacent facet was subdivided.
//!    [`ConvexPolyhedron::split_face`] maintains this by inserting the T-vertices.
//! 3. Convex within tolerance: every vertex is behind every (non-tiny) face plane, within
//!    `snap_abs()` (the weld distance: cuts treat vertices that near a plane as on it)
//!    plus the face plane's rounding uncertainty.
//!
//! Operations preserve these invariants: [`ConvexPolyhedron::cut`] classifies each
//! distinct vertex once, computes one new vertex per crossed edge (interpolated in a
//! canonical endpoint order, so it is bit-identical whichever face asks, and cached),
//! gives both pieces and the cross-section those same vertices, and keeps all On
//! vertices and T-vertices, so conforming input gives conforming output (a face with
//! every vertex On goes whole to one piece; when no assignment conforms, the cut is
//! retried with a wider On band, then with none). Volume,
//! centroid and area are boundary integrals, valid for subdivided boundaries.
//!
//! Vertex sharing between *different* polyhedra (a cell and its neighbour) is not
//! maintained here: a shared patch may carry T-vertices on one side only, and then the
//! two sides' crossing points can differ by rounding.

// Negated float comparisons (`!(x > eps)`) are deliberate: they send NaN to the safe side.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod clearance;
mod plane;
mod polygon;
mod polyhedron;
#[cfg(test)]
mod testutil;
pub(crate) mod vec;

pub use clearance::ClearanceField;
pub use plane::{Classification, Plane, Side};
pub use polygon::{ConvexPolygon, INLINE_VERTS, PolygonSplit, Subtraction, Verts};
pub use polyhedron::{
    ConvexPolyhedron, Cut, PolyhedronSplit, check_faces, contains_of, min_volume, moments_of, vertices_of,
};
