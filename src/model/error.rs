//! Input errors. Each names the file, the line where known, the offending element, and
//! suggests a fix.

use std::path::PathBuf;

/// `file:line` or just `file`.
fn loc(file: &str, line: &Option<usize>) -> String {
    match line {
        Some(l) => format!("{file}:{l}"),
        None => file.to_string(),
    }
}

/// Why a model could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// The file is missing or unreadable.
    #[error(
        "cannot read model file `{}`: {error}; check that the path exists and is readable",
        path.display()
    )]
    Io {
        path: PathBuf,
        /// The operating system's error (in the message, so not a `source`: error chains
        /// would print it twice).
        error: std::io::Error,
    },

    /// The file is not text: it holds a NUL byte (no text model does), or it is not UTF-8
    /// and has no vertex or polygon line.
    #[error(
        "`{}` is not a text model file: {reason}{}; give a Wavefront OBJ or .mesh text file \
         (export or convert the model to OBJ)",
        path.display(),
        kind.map(|k| format!(" (it starts like {k})")).unwrap_or_default()
    )]
    NotText {
        path: PathBuf,
        /// What gave it away (binary content, invalid UTF-8, at which byte).
        reason: String,
        /// The file type its first bytes announce, when recognised (e.g. `a PNG image`).
        kind: Option<&'static str>,
    },

    /// The extension is neither `.obj` nor `.mesh`.
    #[error(
        "`{}`: unknown model file extension `{ext}`; supported are `.obj` (Wavefront OBJ) and \
         `.mesh` (simple text mesh): convert the model or rename the file if it is one of these",
        path.display()
    )]
    UnknownExtension { path: PathBuf, ext: String },

    /// The path is a directory.
    #[error(
        "`{}` is a directory, not a model file; give one model file (.obj or .mesh){}",
        path.display(),
        if models.is_empty() { String::from(": it holds none") } else { format!(", such as {}", models.join(", ")) }
    )]
    IsDirectory {
        path: PathBuf,
        /// Up to five model files in it.
        models: Vec<String>,
    },

    /// A `.mesh` file of another format (Medit/INRIA, as TetGen, Gmsh and meshio write it).
    #[error(
        "{file}:{line}: this is a Medit/TetGen `.mesh` file (`{found}`), not portalfind's simple \
         `.mesh` (a header `<vertex_count> <polygon_count>`, then vertex and polygon lines; see \
         the README); convert its surface triangles to OBJ, e.g. `meshio convert in.mesh out.obj`"
    )]
    OtherMeshFormat { file: String, line: usize, found: String },

    /// A line does not have the expected form.
    #[error(
        "{file}:{line}: malformed {element}: expected {expected}, found `{found}`; fix or remove \
         this line"
    )]
    Malformed {
        file: String,
        line: usize,
        /// What the line was supposed to be, e.g. `vertex 4` or `header`.
        element: String,
        expected: String,
        found: String,
    },

    /// A coordinate is NaN or infinite.
    #[error(
        "{}: vertex {vertex} (0-based) has a non-finite coordinate {coords:?}; every coordinate \
         must be a finite number: fix the exporter or remove the vertex",
        loc(file, line)
    )]
    NonFinite {
        file: String,
        line: Option<usize>,
        /// 0-based vertex index.
        vertex: usize,
        coords: [f64; 3],
    },

    /// A polygon refers to a vertex that does not exist.
    #[error(
        "{}: polygon {polygon} (0-based) refers to vertex index {index}, but there are \
         {vertex_count} vertices ({convention}); fix the index or add the missing vertices",
        loc(file, line)
    )]
    IndexOutOfRange {
        file: String,
        line: Option<usize>,
        /// 0-based polygon (face) index.
        polygon: usize,
        /// The index as written in the input.
        index: i64,
        /// Number of vertices it had to be checked against.
        vertex_count: usize,
        /// The index convention of the format.
        convention: &'static str,
    },

    /// A polygon refers to a vertex index too large for any integer type the reader
    /// uses (it overflows 64 bits), so it is out of range whatever the vertex count.
    #[error(
        "{file}:{line}: polygon {polygon} (0-based) refers to vertex index {index}, which is out of \
         range (it does not even fit in 64 bits; a model has at most 4294967295 vertices, \
         {convention}); fix the index"
    )]
    IndexTooLarge {
        file: String,
        line: usize,
        /// 0-based polygon (face) index.
        polygon: usize,
        /// The index as written in the input.
        index: String,
        /// The index convention of the format.
        convention: &'static str,
    },

    /// A polygon in the input has fewer than 3 vertices.
    #[error(
        "{}: polygon {polygon} (0-based) has {count} vertices, a polygon needs at least 3; \
         remove it or add its missing vertices",
        loc(file, line)
    )]
    TooFewVertices {
        file: String,
        line: Option<usize>,
        polygon: usize,
        count: usize,
    },

    /// The `.mesh` header's counts do not match the file.
    #[error(
        "{file}:{line}: the header declares {declared} {what}, but the file has {found}; correct \
         the counts in the header"
    )]
    CountMismatch {
        file: String,
        /// The header line (file too short) or the first line past the declared content.
        line: usize,
        /// `"vertices"` or `"polygons"`.
        what: &'static str,
        declared: usize,
        found: usize,
    },

    /// No vertices or no polygons (in the input, or left after cleaning).
    #[error("{file}: empty model: {reason}; the model needs at least one non-degenerate polygon")]
    Empty { file: String, reason: String },

    /// All vertices used by the cleaned polygons lie in one plane (or on one line, or at one
    /// point). Vertices used by no polygon (in the input, or after cleaning dropped every
    /// polygon using them) are ignored, so they do not make a flat model 3D.
    #[error(
        "{file}: degenerate model: the vertices used by polygons are {shape} (only \
         {independent} affinely independent; vertices used by no polygon are ignored); a 3D \
         model needs polygons using at least 4 non-coplanar vertices"
    )]
    Degenerate {
        file: String,
        /// Size of the largest affinely independent set of used vertices (0 to 3).
        independent: usize,
        /// `"coincident"`, `"collinear"` or `"coplanar"`: the shape of the used vertices.
        shape: &'static str,
    },

    /// Coordinates too large or the model too small for the arithmetic.
    #[error(
        "{file}: coordinates out of range: largest |coordinate| {max_abs:e}, bounding-box diagonal \
         {diag:e}; portalfind needs |coordinates| <= 1e15 and a diagonal >= 1e-9: rescale the model \
         (e.g. to metres or game units)"
    )]
    CoordinateRange {
        file: String,
        /// Largest absolute coordinate of a referenced vertex.
        max_abs: f64,
        /// Bounding-box diagonal of the referenced vertices.
        diag: f64,
    },

    /// The coordinates are too coarse for the model's size and no exact translation makes
    /// them fine enough. Their rounding unit (`f64::EPSILON` × largest |coordinate|) exceeds
    /// the plane tolerance ([`crate::Tolerances::plane_abs`], 1e-9 of the diagonal), so
    /// points constructed on a plane (where a cell is cut) could not be represented within
    /// the tolerance that decides whether a point is on that plane. A small model far from
    /// the origin is normally recentred by an exact translation instead (see
    /// [`crate::model::Translation`]); this error remains for coordinates that no
    /// translation by a multiple of their rounding unit moves exactly (`reason` says which).
    #[error(
        "{file}: coordinates too coarse for the model's size: largest |coordinate| {max_abs:e} has \
         rounding unit {unit:e}, above the plane tolerance {plane:e} (1e-9 of the diagonal \
         {diag:e}), and no exact translation brings it below: {reason}; translating the file \
         cannot restore digits it does not hold: export the model with coordinates relative to \
         an origin near it"
    )]
    Precision {
        file: String,
        /// Largest absolute coordinate of a referenced vertex.
        max_abs: f64,
        /// Its rounding unit, `f64::EPSILON * max_abs`.
        unit: f64,
        /// The absolute plane tolerance.
        plane: f64,
        /// Bounding-box diagonal of the referenced vertices.
        diag: f64,
        /// Why the exact translation failed (the vertex and axis it could not move exactly).
        reason: String,
    },
}

impl ModelError {
    /// The 1-based line the error refers to, when known.
    pub fn line(&self) -> Option<usize> {
        match self {
            ModelError::Malformed { line, .. }
            | ModelError::CountMismatch { line, .. }
            | ModelError::IndexTooLarge { line, .. } => Some(*line),
            ModelError::NonFinite { line, .. }
            | ModelError::IndexOutOfRange { line, .. }
            | ModelError::TooFewVertices { line, .. } => *line,
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_file_line_and_element() {
        let e = ModelError::IndexOutOfRange {
            file: "a.obj".into(),
            line: Some(7),
            polygon: 2,
            index: 9,
            vertex_count: 8,
            convention: "OBJ indices are 1-based",
        };
        let s = e.to_string();
        assert!(s.starts_with("a.obj:7: polygon 2"), "{s}");
        assert!(s.contains("index 9") && s.contains("8 vertices"), "{s}");
        assert_eq!(e.line(), Some(7));
        let e = ModelError::NonFinite {
            file: "soup".into(),
            line: None,
            vertex: 3,
            coords: [f64::NAN, 0.0, 0.0],
        };
        assert!(e.to_string().starts_with("soup: vertex 3"), "{e}");
        assert_eq!(e.line(), None);
    }
}
