//! The cleaning report: every change cleaning made, and the mesh diagnostics.

use std::fmt;

use serde::Serialize;

/// What cleaning did to a model (see the module documentation of [`crate::model`] for the
/// exact meaning of each step). Invariant:
/// `final_vertices == input_vertices - welded_vertices - unused_vertices`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct CleaningReport {
    /// Vertices in the input.
    pub input_vertices: usize,
    /// Polygons (faces) in the input.
    pub input_polygons: usize,
    /// Vertices merged into an earlier vertex closer than the weld distance.
    pub welded_vertices: usize,
    /// Vertices (after welding) used by no surviving polygon; dropped.
    pub unused_vertices: usize,
    /// Polygons dropped for having fewer than 3 distinct vertices after welding, all vertices
    /// collinear, or area below the area tolerance.
    pub zero_area_polygons_dropped: usize,
    /// Polygons dropped as a same-orientation repeat of an earlier polygon.
    pub duplicate_polygons_dropped: usize,
    /// Polygons kept that are the reverse of an earlier polygon (two-sided walls).
    pub two_sided_pairs: usize,
    /// Polygons with more than 3 vertices that were triangulated (non-planar or non-convex).
    pub nonplanar_or_nonconvex_triangulated: usize,
    /// Of those, the non-planar ones.
    pub nonplanar_polygons: usize,
    /// Triangles produced by that triangulation.
    pub triangles_from_triangulation: usize,
    /// Polygons whose projection was not simple, triangulated best-effort.
    pub triangulation_fallbacks: usize,
    /// Non-planar polygons whose outline crosses itself in projection (no in-plane
    /// triangulation exists), triangulated in 3D by minimum total area instead; absent
    /// from `result.json` when 0.
    #[serde(skip_serializing_if = "is_zero")]
    pub min_area_triangulated: usize,
    /// Undirected edges used by exactly one polygon.
    pub open_edges: usize,
    /// (vertex, edge) pairs with the vertex strictly inside the edge.
    pub t_junctions: usize,
    /// Undirected edges used by more than two polygons.
    pub non_manifold_edges: usize,
    /// Vertices in the cleaned model.
    pub final_vertices: usize,
    /// Polygons in the cleaned model.
    pub final_polygons: usize,
    /// The exact translation applied to a model far from the origin (`None`, and absent
    /// from `result.json`, for every model that does not need one).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub translation: Option<Translation>,
}

/// An exact recentring (step 1 of cleaning, see the module documentation of
/// [`crate::model`]): the model's vertices were translated by `-by` before cleaning, every
/// subtraction exact, and every output adds `by` back ([`crate::model::Model::origin`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Translation {
    /// The vector subtracted from every vertex (and added back on output): per axis a
    /// multiple of that axis's rounding unit; 0 on an axis that needed none and has no exact
    /// one.
    pub by: [f64; 3],
    /// Largest |coordinate| of the input (referenced vertices).
    pub max_abs: f64,
    /// Its rounding unit `f64::EPSILON * max_abs`: how far a point constructed on a plane
    /// would be rounded in the input's frame.
    pub unit: f64,
    /// The plane tolerance it exceeded.
    pub plane: f64,
    /// Per axis, the spacing of the input's coordinates there (the ulp of the largest
    /// |coordinate| on that axis; 0 on untranslated axes): the input's own quantisation,
    /// which the translation keeps exactly.
    pub quantum: [f64; 3],
}

// Coordinates are finite (the loader refuses NaN), so equality is an equivalence.
impl Eq for Translation {}

impl fmt::Display for CleaningReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "input:   {} vertices, {} polygons",
            self.input_vertices, self.input_polygons
        )?;
        writeln!(f, "cleaning:")?;
        writeln!(f, "  welded vertices (merged away)      {:>9}", self.welded_vertices)?;
        writeln!(f, "  unused vertices dropped            {:>9}", self.unused_vertices)?;
        writeln!(
            f,
            "  zero-area polygons dropped         {:>9}",
            self.zero_area_polygons_dropped
        )?;
        writeln!(
            f,
            "  duplicate polygons dropped         {:>9}",
            self.duplicate_polygons_dropped
        )?;
        writeln!(f, "  two-sided pairs kept               {:>9}", self.two_sided_pairs)?;
        writeln!(
            f,
            "  polygons triangulated              {:>9}  ({} non-planar, {} best-effort) -> {} triangles",
            self.nonplanar_or_nonconvex_triangulated,
            self.nonplanar_polygons,
            self.triangulation_fallbacks,
            self.triangles_from_triangulation
        )?;
        if self.min_area_triangulated > 0 {
            writeln!(
                f,
                "  outlines crossing themselves       {:>9}  (non-planar; triangulated by minimum area in 3D)",
                self.min_area_triangulated
            )?;
        }
        writeln!(f, "diagnostics (not repaired):")?;
        writeln!(f, "  open edges                         {:>9}", self.open_edges)?;
        writeln!(f, "  non-manifold edges                 {:>9}", self.non_manifold_edges)?;
        writeln!(f, "  T-junctions                        {:>9}", self.t_junctions)?;
        write!(
            f,
            "output:  {} vertices, {} polygons",
            self.final_vertices, self.final_polygons
        )?;
        if let Some(t) = &self.translation {
            write!(f, "\n{t}")?;
        }
        Ok(())
    }
}

impl fmt::Display for Translation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let q = self.quantum.iter().copied().fold(0.0f64, f64::max);
        write!(
            f,
            "translated by [{:?}, {:?}, {:?}] exactly (coordinates ~{:.0e} would round constructed points by \
             {:.1e}, above the plane tolerance {:.1e}); the input's coordinates are spaced {:.1e} apart \
             there, and outputs are in the input's frame",
            self.by[0], self.by[1], self.by[2], self.max_abs, self.unit, self.plane, q
        )
    }
}

/// `serde`'s test for fields left out of `result.json` when 0.
fn is_zero(n: &usize) -> bool {
    *n == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_is_multiline_and_complete() {
        let r = CleaningReport {
            input_vertices: 8,
            welded_vertices: 2,
            t_junctions: 5,
            ..Default::default()
        };
        let s = r.to_string();
        assert!(s.lines().count() >= 10, "{s}");
        assert!(s.contains("input:   8 vertices"));
        assert!(
            s.lines()
                .any(|l| l.contains("T-junctions") && l.trim_end().ends_with('5'))
        );
    }
}
