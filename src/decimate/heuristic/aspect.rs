//! `aspect`: thesis 4.1.4, the largest projected cell area over the portal area.

use super::{Heuristic, PairContext};

/// Thesis 4.1.4: largest projected cell area over portal area.
pub struct Aspect;

impl Heuristic for Aspect {
    fn name(&self) -> &'static str {
        "aspect"
    }
    fn weight(&self, ctx: &PairContext) -> f64 {
        ctx.max_projected() / ctx.portal_area
    }
    /// `A_max` grows with either projected area; the portal area is fixed.
    fn monotone_in_projected_areas(&self) -> bool {
        true
    }
}
