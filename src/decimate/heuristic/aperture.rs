//! `aperture`: the `clearance` persistence merge with an **aperture gate** (see
//! [`crate::decimate::clearance`]): two components that each hold their own largest empty
//! ball are kept apart when the opening between them is small against the smaller one's
//! cross-section on the opening's plane, whatever the persistence. Scale-free: a ratio
//! of two areas of the same model, and one of two volumes.

use super::{Engine, Heuristic, PairContext};
use crate::decimate::clearance::{ApertureGate, DEFAULT_APERTURE};

/// Peak-to-pass ratio of the clearance field, with rooms joined through wide openings kept
/// apart by their section-to-opening ratio.
pub struct Aperture;

/// Floor of saddles, so weights stay finite.
const TINY: f64 = 1e-300;

impl Heuristic for Aperture {
    fn name(&self) -> &'static str {
        "aperture"
    }
    fn weight(&self, ctx: &PairContext) -> f64 {
        ctx.peaks[0].min(ctx.peaks[1]) / ctx.saddle.max(TINY)
    }
    fn engine(&self) -> Engine {
        Engine::Clearance
    }
    fn aperture_gate(&self) -> Option<ApertureGate> {
        Some(DEFAULT_APERTURE)
    }
}
