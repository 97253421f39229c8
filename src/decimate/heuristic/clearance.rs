//! `clearance`: the relative persistence of the lower of two clearance peaks,
//! `min(peak_a, peak_b) / saddle` (see [`crate::decimate::clearance`] for the field and the
//! engine). Scale-free: a ratio of two lengths of the same model.

use super::{Engine, Heuristic, PairContext};

/// Peak-to-pass ratio of the clearance field (rooms are basins, doorways saddles).
pub struct Clearance;

/// Floor of saddles, so weights stay finite.
const TINY: f64 = 1e-300;

impl Heuristic for Clearance {
    fn name(&self) -> &'static str {
        "clearance"
    }
    fn weight(&self, ctx: &PairContext) -> f64 {
        ctx.peaks[0].min(ctx.peaks[1]) / ctx.saddle.max(TINY)
    }
    fn engine(&self) -> Engine {
        Engine::Clearance
    }
}
