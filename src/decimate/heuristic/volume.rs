//! `volume`: thesis 4.3.3 (our reading, see the [module docs](super)), the refined weight
//! times the cube root of the volume ratio.

use super::{Heuristic, PairContext, Refined};

/// Thesis 4.3.3 (our reading): refined, times the cube root of the volume ratio.
pub struct VolumeRatio;

impl Heuristic for VolumeRatio {
    fn name(&self) -> &'static str {
        "volume"
    }
    fn weight(&self, ctx: &PairContext) -> f64 {
        let [a, b] = ctx.volumes;
        let ratio = if a.max(b) > 0.0 { a.min(b) / a.max(b) } else { 1.0 };
        Refined.weight(ctx) * ratio.cbrt()
    }
    fn uses_volume(&self) -> bool {
        true
    }
    /// The refined weight's `√A_max` grows with either projected area; the volume factor
    /// does not depend on them.
    fn monotone_in_projected_areas(&self) -> bool {
        true
    }
}
