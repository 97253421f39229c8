//! `refined`: thesis 4.3.2, the aspect divided by the square root of the projected cell
//! area.

use super::{Heuristic, PairContext};

/// Thesis 4.3.2: the aspect divided by the square root of the projected cell area.
pub struct Refined;

impl Heuristic for Refined {
    fn name(&self) -> &'static str {
        "refined"
    }
    fn weight(&self, ctx: &PairContext) -> f64 {
        ctx.max_projected().sqrt() / ctx.portal_area
    }
    /// `A_max` grows with either projected area; the portal area is fixed.
    fn monotone_in_projected_areas(&self) -> bool {
        true
    }
}
