//! Model input: read a polygon model, clean it, and say exactly what was cleaned.
//!
//! # Conventions
//!
//! - **Front side.** The front side of a polygon is the side from which its vertices appear
//!   counter-clockwise; [`Model::polygon_normal`] (Newell's normal) points to the front. The
//!   front faces *free space*: as in Quake's `e1m1.obj`, whose faces look into the playable
//!   space, a viewer standing in the model's free space sees the front sides of the walls around
//!   them.
//! - **Coordinates** are kept exactly as read (`f64`); cleaning never moves a vertex. Welding
//!   merges a vertex into an earlier one, whose coordinates survive unchanged, so the exact
//!   predicates of [`crate::predicates`] see input coordinates.
//! - **Indices.** [`Model::vertices`] and [`Model::polygons`] are the cleaned model; every vertex
//!   is used by at least one polygon. [`SourceRef`] points each polygon back at the face of the
//!   input file it came from (a face triangulated on input gives several polygons with the same
//!   `SourceRef`).
//!
//! # Formats
//!
//! [`load_model`] dispatches on the file extension (case-insensitive):
//!
//! ## Wavefront OBJ (`.obj`)
//!
//! Read by a small parser of our own rather than `tobj`, because `tobj` does not report line
//! numbers, and every input error here names its line. Understood lines:
//! `v x y z [w | r g b]` (only x, y, z are used), `f` with vertex references in any of the forms
//! `i`, `i/j`, `i/j/k`, `i//k` (only the position index `i` is used; 1-based; negative indices
//! count back from the last vertex defined so far; positive indices may refer to vertices defined
//! later in the file), and `usemtl name` (the material of the following faces; the `.mtl` file is
//! never opened, so a missing one is harmless). Everything after `#` is a comment. All other
//! lines (`vt`, `vn`, `o`, `g`, `s`, `mtllib`, `l`, `p`, ...) are ignored, so all objects and
//! groups end up in one polygon soup. Backslash line continuation is not supported. The text
//! is parsed in pieces of whole lines on every core, with the result and the first error (in
//! file order) of one sequential pass.
//!
//! ## Simple text mesh (`.mesh`)
//!
//! ```text
//! # comments start with '#' (anywhere on a line); blank lines are ignored
//! <vertex_count> <polygon_count>
//! x y z                  (vertex_count lines, one vertex per line)
//! n i0 i1 ... i(n-1)     (polygon_count lines, one polygon per line; n >= 3;
//!                         0-based vertex indices; counter-clockwise seen from the front)
//! ```
//!
//! Numbers are separated by any whitespace; coordinates are anything Rust's `f64` parser
//! accepts (non-finite values are rejected). Each vertex and each polygon must be on a line of
//! its own with exactly the stated number of values. Content after the last polygon is an
//! error (the header's counts would not match the file).
//!
//! # Cleaning
//!
//! Both readers and [`from_soup`] apply the same cleaning, in this order, and count every
//! change in the [`CleaningReport`] (nothing is changed silently). Steps run on every core
//! (rayon) where that keeps their order: the result, the counts and the first error are
//! those of the sequence, on any number of threads.
//!
//! 1. **Tolerances** are [`Tolerances::for_scale`] of the bounding-box diagonal of the vertices
//!    referenced by some polygon (stray unreferenced vertices do not inflate it). The
//!    coordinates must be in range first ([`ModelError::CoordinateRange`]: largest |coordinate|
//!    of those vertices at most 1e15, diagonal at least 1e-9), since every later step uses the
//!    tolerances. Out of range, a model whose every polygon has zero area in the exact input
//!    coordinates (fewer than 3 distinct points, or collinear; e.g. `f 1 1 1`) is reported as
//!    [`ModelError::Empty`], as cleaning would: it would be empty at any scale.
//!
//!    **Exact recentring.** A point constructed on a plane cannot be closer to it than the
//!    rounding unit of its coordinates, so when `f64::EPSILON` × largest |coordinate| exceeds
//!    [`Tolerances::plane_abs`] (1e-9 of the diagonal; e.g. a model of size 15 at offset
//!    1e9, unit 2.2e-7 against 1.5e-8) the on-plane decisions of the cell complex would be
//!    arbitrary. Such a model is translated by a vector `c` before anything else: per axis
//!    `c_k = round(mid_k / U_k) · U_k` with `U_k` the ulp of the largest |coordinate| on that
//!    axis and `mid_k` the bounding box's middle, on every axis where that is exact (an axis
//!    whose own unit is under the tolerance and has no exact translation, e.g. one through
//!    the origin with fine digits, keeps `c_k = 0`; the axes near the tolerance move too, as
//!    constructions that close to it failed). Every subtraction `x - c` is verified exact (TwoSum's
//!    error term zero) for the referenced vertices and every vertex within two weld
//!    distances of their bounding box (the only possible weld targets), so the translated
//!    model is the input *exactly*, moved: every exact predicate (orientation, insphere,
//!    collinearity) gives the same answer as on the input coordinates, and every difference
//!    of two coordinates (welding, tolerances, the diagonal) is the same double. Only the
//!    points the cell complex constructs gain: they round at the unit of the recentred
//!    coordinates. The translation is recorded ([`CleaningReport::translation`],
//!    [`Model::origin`]) and added back on output. (The input's own digits are not restored:
//!    at offset 1e9 the file's coordinates are spaced 1.2e-7 apart, like noise of ~1e-8 of a
//!    size-15 model, which the complex handles.) An exact translation always exists when an
//!    axis needs one (its coordinates then all lie within 2.2e-7 of each other relative to
//!    their magnitude, in at most two binades, so `x - c` is a small multiple of half their
//!    ulp), so [`ModelError::Precision`] is the guard should the check ever fail.
//! 2. **Welding.** Vertices are visited in file order; a vertex closer than
//!    [`Tolerances::weld_abs`] to an earlier surviving vertex is merged into the nearest such
//!    vertex (grid hash with cell size = weld distance, expected O(n)). Chains are not
//!    transitive: each vertex is compared with the survivors only. (Computed on every core
//!    with exactly this result: the vertices of each cell of a coarse grid are welded on
//!    their own, those near a coarse cell's side in file order afterwards; tested against
//!    the sequential weld.)
//! 3. **Degenerate polygons.** After welding, consecutive repeated vertices are removed. A
//!    polygon with fewer than 3 distinct vertices, with all vertices exactly collinear
//!    ([`crate::predicates::collinear`]), or with (Newell) area below
//!    [`Tolerances::area_abs`] is dropped (`zero_area_polygons_dropped`).
//! 4. **Duplicates.** A polygon with the same cyclic vertex sequence as an earlier one (any
//!    starting vertex, same orientation) is dropped (`duplicate_polygons_dropped`). A polygon
//!    whose sequence is the *reverse* of an earlier one is kept: two opposite faces are a
//!    legitimate two-sided wall; such pairs are counted in `two_sided_pairs`.
//! 5. **Planarity and convexity.** A polygon with more than 3 vertices is kept as it is when
//!    all its vertices are exactly coplanar ([`crate::predicates::orient3d`]) and it is convex:
//!    no reflex vertex and winding once around its interior. Vertices collinear with their
//!    neighbours (a straight angle, typical where a T-junction was fixed) are allowed, because
//!    removing them would open a crack and triangulating would add edges that are not in the
//!    model. Otherwise it is triangulated in its plane (`nonplanar_or_nonconvex_triangulated`,
//!    `triangles_from_triangulation`): it is projected onto the coordinate plane that drops the
//!    dominant axis of its Newell normal and ear-clipped with exact 2D orientation tests; the
//!    triangles keep the polygon's winding, source and material. A non-planar quad whose
//!    projection is convex is split along its shorter diagonal. A planar polygon whose
//!    projection is not simple (self-intersecting, or touching itself) is triangulated
//!    best-effort and counted in `triangulation_fallbacks`. A non-planar one (an exact
//!    O(n²) test of its projected outline) has no in-plane triangulation: a quad is split
//!    along its flatter diagonal, a loop of up to 64 vertices is triangulated in 3D by
//!    minimum total area (`min_area_triangulated`; Barequet & Sharir 1995), and a larger
//!    one (a face of random vertex indices) is refused, naming the face. A planar convex
//!    polygon of more than 256 vertices is ear-clipped too (`triangles_from_triangulation`):
//!    splitting the cells by one polygon clips it against every cell it meets, O(n²) for
//!    an n-gon. Ear clipping stays near-linear on large polygons: an ear is tested only
//!    against the non-convex vertices under its bounding box (a uniform grid), and after
//!    an ear of a polygon of more than 64 vertices it goes on two vertices further
//!    (earcut's rule), so a convex stretch is halved pass by pass rather than cut into a
//!    fan of slivers (a non-convex 100k-gon: 58.9 s before, 1.1 s).
//! 6. **Unused vertices** (referenced by no surviving polygon) are dropped and the indices
//!    remapped (`unused_vertices`). So `final_vertices = input_vertices - welded_vertices -
//!    unused_vertices`.
//! 7. **Diagnostics** of the final polygons (reported, not repaired): `open_edges` (undirected
//!    edges used by exactly one polygon), `non_manifold_edges` (used by more than two),
//!    `t_junctions` (pairs of a vertex and an edge such that the vertex lies exactly on the
//!    edge, strictly between its endpoints; found with a uniform grid over the vertices).
//!
//! Finally the model must have at least one polygon ([`ModelError::Empty`]) and its polygons
//! must use at least four non-coplanar vertices ([`ModelError::Degenerate`]; unused vertices,
//! dropped in step 6, do not count).

mod clean;
mod error;
pub mod gaps;
mod mesh;
mod obj;
mod report;
mod triangulate;
pub mod write;

use std::path::Path;

use crate::ids::{PolygonId, VertexId};
use crate::tolerances::Tolerances;

pub use error::ModelError;
pub use report::{CleaningReport, Translation};

/// Where a polygon came from in the input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct SourceRef {
    /// 1-based line number in the file, when the polygon came from a file.
    pub line: Option<usize>,
    /// 0-based index of the face among the faces of the file (or of the soup passed to
    /// [`from_soup`]).
    pub element: usize,
}

/// A cleaned polygon: at least 3 distinct vertices; planar and convex when it has more than 3.
#[derive(Clone, Debug, PartialEq)]
pub struct Polygon {
    /// Vertices, counter-clockwise seen from the front (free-space) side.
    pub verts: Vec<VertexId>,
    /// The input face it came from.
    pub source: SourceRef,
    /// Material name (`usemtl` in OBJ), if any.
    pub material: Option<String>,
}

/// A cleaned polygon model.
#[derive(Clone, Debug)]
pub struct Model {
    /// Model name (the file stem for files).
    pub name: String,
    /// Welded vertices, each used by some polygon.
    pub vertices: Vec<[f64; 3]>,
    /// Cleaned polygons.
    pub polygons: Vec<Polygon>,
    /// What cleaning did.
    pub report: CleaningReport,
    /// Tolerances derived from the model's size.
    pub tolerances: Tolerances,
    /// The input's frame: a vertex `v` of [`Model::vertices`] is the input point
    /// `v + origin`. `[0, 0, 0]` for every model but one recentred exactly on loading
    /// ([`CleaningReport::translation`]); outputs carry coordinates in the input's frame
    /// ([`Model::to_user`]), and points read from the user go through [`Model::from_user`].
    pub origin: [f64; 3],
}

impl Model {
    /// Whether vertex position `k` of polygon `p` is a *corner*: not exactly collinear
    /// with its two neighbours ([`crate::predicates::collinear`]). A convex polygon kept
    /// whole may have straight-angle vertices (typically where a T-junction was fixed, or
    /// a floor whose edges carry every wall vertex); the region it bounds is that of its
    /// corners alone, so the splitting and the crossing check clip the corners' polygon
    /// (a floor with 10,000 vertices along four straight edges is a quad there, not a
    /// 10,000-gon clipped against every cell it meets). In a convex polygon every
    /// straight-angle vertex lies on the segment between two corners, so testing against
    /// the immediate neighbours (straight or not) finds exactly those.
    pub fn is_corner(&self, p: usize, k: usize) -> bool {
        let v = &self.polygons[p].verts;
        let n = v.len();
        if n <= 3 {
            return true;
        }
        let at = |i: usize| &self.vertices[v[i % n].idx()];
        !crate::predicates::collinear(at(k + n - 1), at(k), at(k + 1))
    }

    /// A point of the model's (possibly recentred) frame in the input's frame: `p + origin`
    /// (rounded to the input's precision there; exact for the vertices). The identity,
    /// bit for bit (signed zeros too), on axes with no translation.
    pub fn to_user(&self, p: [f64; 3]) -> [f64; 3] {
        translate_point(p, self.origin)
    }

    /// A point of the input's frame in the model's frame: `p - origin` (the identity on
    /// axes with no translation).
    pub fn from_user(&self, p: [f64; 3]) -> [f64; 3] {
        translate_point(p, self.origin.map(|o| -o))
    }

    /// Axis-aligned bounding box `(min, max)` of the vertices (all zeros for no vertices).
    pub fn bbox(&self) -> ([f64; 3], [f64; 3]) {
        bbox_of(self.vertices.iter())
    }

    /// Number of triangles when every polygon is fanned: `sum(n - 2)`.
    pub fn triangle_count(&self) -> usize {
        self.polygons.iter().map(|p| p.verts.len().saturating_sub(2)).sum()
    }

    /// Newell normal of polygon `p` (not normalized; its length is twice the area for a planar
    /// polygon). Points to the front side, from which the vertices appear counter-clockwise.
    pub fn polygon_normal(&self, p: PolygonId) -> [f64; 3] {
        let poly = &self.polygons[p.idx()];
        newell(poly.verts.iter().map(|v| &self.vertices[v.idx()]))
    }
}

/// Loads a model file, dispatching on its extension (`.obj` or `.mesh`, case-insensitive), and
/// cleans it (see the module documentation).
pub fn load_model(path: &Path) -> Result<Model, ModelError> {
    if path.is_dir() {
        let mut models: Vec<String> = std::fs::read_dir(path)
            .map(|rd| {
                rd.filter_map(|e| e.ok())
                    .map(|e| e.file_name().to_string_lossy().into_owned())
                    .filter(|n| {
                        let l = n.to_ascii_lowercase();
                        l.ends_with(".obj") || l.ends_with(".mesh")
                    })
                    .collect()
            })
            .unwrap_or_default();
        models.sort();
        models.truncate(5);
        return Err(ModelError::IsDirectory {
            path: path.to_path_buf(),
            models,
        });
    }
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if ext != "obj" && ext != "mesh" {
        return Err(ModelError::UnknownExtension {
            path: path.to_path_buf(),
            ext,
        });
    }
    let bytes = std::fs::read(path).map_err(|error| ModelError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    let not_text = |reason: String| ModelError::NotText {
        path: path.to_path_buf(),
        reason,
        kind: binary_kind(&bytes),
    };
    // No text model holds a NUL byte; images, archives and binary meshes nearly all do
    // within their first bytes.
    if let Some(i) = bytes.iter().position(|&b| b == 0) {
        return Err(not_text(format!(
            "it holds binary data (a NUL byte at byte offset {i})"
        )));
    }
    // Invalid UTF-8 is read leniently (a Latin-1 comment or material name must not stop a
    // model), unless nothing of a model is found in it.
    let utf8 = std::str::from_utf8(&bytes).err();
    let text = String::from_utf8_lossy(&bytes);
    let file = path.display().to_string();
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| file.clone());
    let soup = if ext == "obj" {
        obj::parse_obj(&file, &text)?
    } else {
        mesh::parse_mesh(&file, &text)?
    };
    if let Some(e) = utf8
        && soup.vertices.is_empty()
        && soup.polygons.is_empty()
    {
        return Err(not_text(format!(
            "it is not valid UTF-8 text (an invalid byte at byte offset {}) and holds no vertex or \
             polygon line",
            e.valid_up_to()
        )));
    }
    clean::clean(&name, &file, soup)
}

/// The file type announced by the first bytes of `bytes`, for formats a model file is
/// sometimes confused with.
fn binary_kind(bytes: &[u8]) -> Option<&'static str> {
    const MAGIC: [(&[u8], &str); 9] = [
        (b"\x89PNG\r\n\x1a\n", "a PNG image"),
        (b"\xff\xd8\xff", "a JPEG image"),
        (b"\xff\xfe", "UTF-16 text: save it as UTF-8"),
        (b"\xfe\xff", "UTF-16 text: save it as UTF-8"),
        (b"GIF8", "a GIF image"),
        (b"PK\x03\x04", "a ZIP archive"),
        (b"\x1f\x8b", "a gzip file"),
        (b"glTF", "a binary glTF (.glb) file"),
        (b"Kaydara FBX Binary", "a binary FBX file"),
    ];
    MAGIC.iter().find(|(m, _)| bytes.starts_with(m)).map(|(_, k)| *k)
}

/// Parses `.mesh` text (see the module documentation) and cleans it. `name` is used as the
/// model name and as the file name in error messages.
pub fn parse_mesh_str(name: &str, text: &str) -> Result<Model, ModelError> {
    let soup = mesh::parse_mesh(name, text)?;
    clean::clean(name, name, soup)
}

/// Parses Wavefront OBJ text (see the module documentation) and cleans it. `name` is used as
/// the model name and as the file name in error messages.
pub fn parse_obj_str(name: &str, text: &str) -> Result<Model, ModelError> {
    let soup = obj::parse_obj(name, text)?;
    clean::clean(name, name, soup)
}

/// The fuzzer's differential check of the parallel OBJ reader (`bench fuzz --target obj`):
/// the text parsed in pieces of 1 to 61 bytes (chosen by `seed`) equals the whole parse,
/// and the parallel weld of the parsed vertices, at three weld distances relative to their
/// bounding box (short runs, runs crossing the coarse grid, one run), equals the sequential
/// weld. Small fuzz inputs would otherwise take the one-piece, one-run paths only.
pub(crate) fn obj_reader_paths_agree(text: &str, seed: u64) -> Result<(), String> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    obj::chunking_agrees(text, 1 + (seed % 61) as usize)?;
    let Ok(soup) = obj::parse_obj("fuzz.obj", text) else {
        return Ok(());
    };
    let pts: Vec<[f64; 3]> = soup
        .vertices
        .into_iter()
        .filter(|p| p.iter().all(|x| x.is_finite()))
        .collect();
    let Some(&first) = pts.first() else {
        return Ok(());
    };
    let (mut lo, mut hi) = (first, first);
    for p in &pts {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let diag = (0..3).map(|k| (hi[k] - lo[k]) * (hi[k] - lo[k])).sum::<f64>().sqrt();
    let diag = if diag.is_finite() && diag > 0.0 { diag } else { 1.0 };
    for d in [diag * 2f64.powi(-30), diag / 600.0, diag / 8.0] {
        clean::weld_paths_agree(&pts, lo, d, (seed / 61 % 3) as usize)?;
    }
    Ok(())
}

/// Builds a model from a polygon soup (0-based indices, counter-clockwise from the front),
/// applying the same validation and cleaning as the file readers. Errors name `name` as the
/// file and have no line numbers; `SourceRef::element` is the index into `polygons`.
pub fn from_soup(name: &str, vertices: Vec<[f64; 3]>, polygons: Vec<Vec<u32>>) -> Result<Model, ModelError> {
    let polygons = polygons
        .into_iter()
        .enumerate()
        .map(|(element, verts)| clean::RawPolygon {
            verts,
            source: SourceRef { line: None, element },
            material: None,
        })
        .collect();
    clean::clean(name, name, clean::Soup { vertices, polygons })
}

/// `p + t`, leaving the axes where `t` is zero untouched (so `-0.0` stays `-0.0` and a
/// model without translation writes the same bytes as before).
pub fn translate_point(p: [f64; 3], t: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|k| if t[k] == 0.0 { p[k] } else { p[k] + t[k] })
}

/// Bounding box of points; all zeros when there are none.
pub(crate) fn bbox_of<'a>(pts: impl Iterator<Item = &'a [f64; 3]>) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut any = false;
    for p in pts {
        any = true;
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if any { (lo, hi) } else { ([0.0; 3], [0.0; 3]) }
}

/// Newell normal of a closed polygon, computed relative to its first vertex for accuracy.
pub(crate) fn newell<'a>(pts: impl Iterator<Item = &'a [f64; 3]> + Clone) -> [f64; 3] {
    let mut it = pts.clone();
    let Some(o) = it.next() else { return [0.0; 3] };
    let o = *o;
    let rel = |p: &[f64; 3]| [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
    let mut n = [0.0f64; 3];
    let mut prev = [0.0f64; 3];
    for p in it {
        let cur = rel(p);
        n[0] += (prev[1] - cur[1]) * (prev[2] + cur[2]);
        n[1] += (prev[2] - cur[2]) * (prev[0] + cur[0]);
        n[2] += (prev[0] - cur[0]) * (prev[1] + cur[1]);
        prev = cur;
    }
    // Closing edge back to the origin vertex (relative coordinates 0).
    n[0] += prev[1] * prev[2];
    n[1] += prev[2] * prev[0];
    n[2] += prev[0] * prev[1];
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fuzzer's reader check on a real model: its text in pieces of every size the check
    /// picks, and its weld in runs of 0, 1 and 2 vertices, agree with the sequential paths.
    #[test]
    fn reader_paths_agree_on_a_shipped_model() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/thesis/four_room_distorted.obj");
        let text = std::fs::read_to_string(path).unwrap();
        for seed in [0, 1, 7, 60, 61, 122, 150] {
            obj_reader_paths_agree(&text, seed).unwrap();
        }
    }

    #[test]
    fn newell_ccw_points_up() {
        let pts = [[0.0, 0.0, 5.0], [1.0, 0.0, 5.0], [1.0, 1.0, 5.0], [0.0, 1.0, 5.0]];
        let n = newell(pts.iter());
        assert_eq!(n, [0.0, 0.0, 2.0]);
        let rev: Vec<_> = pts.iter().rev().copied().collect();
        assert_eq!(newell(rev.iter()), [0.0, 0.0, -2.0]);
    }

    #[test]
    fn newell_tilted_triangle() {
        // Triangle in the plane x = 3, CCW seen from +x.
        let pts = [[3.0, 0.0, 0.0], [3.0, 2.0, 0.0], [3.0, 0.0, 2.0]];
        let n = newell(pts.iter());
        assert_eq!(n, [4.0, 0.0, 0.0]);
    }

    #[test]
    fn bbox_empty_and_some() {
        assert_eq!(bbox_of(std::iter::empty()), ([0.0; 3], [0.0; 3]));
        let pts = [[1.0, -2.0, 3.0], [-1.0, 4.0, 0.0]];
        assert_eq!(bbox_of(pts.iter()), ([-1.0, -2.0, 0.0], [1.0, 4.0, 3.0]));
    }
}
