//! The one place where epsilons live.
//!
//! Exact predicates ([`crate::predicates`]) need no tolerance. Where a constructed
//! quantity (a clipped polygon's vertex, an area after subtraction) must be compared
//! against zero, the threshold is taken from here, and every threshold is *relative to the
//! model's size* (the length of its bounding-box diagonal), so scaling a model by any factor
//! gives the same decisions.

use serde::{Deserialize, Serialize};

/// Tolerances, all relative to `scale` (the model's bounding-box diagonal).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tolerances {
    /// Length of the model's bounding-box diagonal; all other fields multiply it.
    pub scale: f64,
    /// Vertices closer than `weld * scale` are merged on input.
    pub weld: f64,
    /// Polygons with area below `(area * scale)^2` are dropped as degenerate; portal slivers
    /// below this area are discarded after occluder subtraction.
    pub area: f64,
    /// Points closer than `plane * scale` to a constructed plane count as on it.
    pub plane: f64,
    /// Model polygons whose vertices all lie within `coplanar * scale` of another polygon's
    /// plane share that plane for splitting (input rounding makes ramps and fans of one
    /// face slightly non-coplanar; splitting by each plane separately leaves wedge cells
    /// that leak between them).
    pub coplanar: f64,
}

impl Tolerances {
    /// Default relative tolerances for a model whose bounding-box diagonal is `scale`.
    pub fn for_scale(scale: f64) -> Self {
        let scale = if scale.is_finite() && scale > 0.0 { scale } else { 1.0 };
        Tolerances {
            scale,
            weld: 1e-7,
            area: 1e-5,
            plane: 1e-9,
            coplanar: 1e-6,
        }
    }
    /// Absolute weld distance.
    pub fn weld_abs(&self) -> f64 {
        self.weld * self.scale
    }
    /// Absolute area threshold.
    pub fn area_abs(&self) -> f64 {
        let l = self.area * self.scale;
        l * l
    }
    /// Portal pieces narrower than this (twice the area over the perimeter) are cracks
    /// left by rounding or by polygons that meet at T-junctions: discarded as slivers.
    pub fn sliver_width(&self) -> f64 {
        self.area * self.scale
    }
    /// Absolute distance for sharing a support plane.
    pub fn coplanar_abs(&self) -> f64 {
        self.coplanar * self.scale
    }
    /// Absolute plane distance.
    pub fn plane_abs(&self) -> f64 {
        self.plane * self.scale
    }
    /// Distance within which a vertex counts as lying on a plane that *cuts a cell*, and
    /// the convexity allowance of cells: `max(weld, plane)`. A cut through an edge whose
    /// endpoint is nearer than this would create a vertex nearer than the weld distance
    /// to an existing one (the sliver edges and faces that later cuts cannot classify
    /// consistently), so such endpoints are on the plane instead; a cell is then convex
    /// up to this distance.
    pub fn snap_abs(&self) -> f64 {
        self.weld_abs().max(self.plane_abs())
    }
    /// The tolerances of fallback level `level` (0: `self`): `weld`, `plane` and `coplanar`
    /// multiplied by `10^level`, `area` unchanged. [`crate::pipeline::build_cells`] builds
    /// the complex again at levels 1..=[`FALLBACK_LEVELS`] when the complex at the model's
    /// own tolerances fails its checks: coarser bands put a vertex that rounding or input
    /// noise left a hair off a cut plane *on* it, and let nearly coplanar polygons share
    /// one support plane, which removes the sliver wedges between them where the
    /// splitting's decisions disagree. Welding on input is not redone (the model keeps
    /// its vertices); the larger weld distance only widens the complex's snapping band
    /// ([`snap_abs`](Self::snap_abs)). A complex built at a fallback level is reported as
    /// such (`ComplexStats::tolerance_level`, `run`'s warning), never silently.
    pub fn fallback(&self, level: u32) -> Tolerances {
        let f = 10f64.powi(level as i32);
        Tolerances {
            weld: self.weld * f,
            plane: self.plane * f,
            coplanar: self.coplanar * f,
            ..*self
        }
    }
    /// The tolerances for a split that *seals a crack*: a cell crossed by model polygons
    /// whose cross-section is covered by them up to cracks (narrower than
    /// [`sliver_width`](Self::sliver_width)) must be split even when that section is below
    /// the area tolerance, or the cell would connect both sides of the wall. Such a split
    /// only needs to be numerically meaningful, so the area threshold drops to the weld
    /// distance squared (`area = weld`); the thickness rule (pieces thicker than `weld`)
    /// is unchanged.
    pub fn sealing(&self) -> Tolerances {
        Tolerances {
            area: self.weld,
            ..*self
        }
    }
}

/// The most fallback levels [`Tolerances::fallback`] tries after the model's own
/// tolerances (level 3: weld 1e-4, plane 1e-6, coplanar 1e-3 of the diagonal).
pub const FALLBACK_LEVELS: u32 = 3;

impl Default for Tolerances {
    fn default() -> Self {
        Self::for_scale(1.0)
    }
}
