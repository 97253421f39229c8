//! `bbox`: the area of the bounding rectangle of the projected cell, axis-aligned in the
//! portal plane's canonical frame (the thesis's "bounding rectangle", 4.4).

use super::AreaEstimator;
use crate::decimate::hull3::Hull3;
use crate::decimate::project::{Frame, P2, bbox_area};
use crate::geom::ConvexPolyhedron;

/// Axis-aligned bounding rectangle in the plane's canonical frame (thesis 4.4).
#[derive(Clone, Copy, Debug, Default)]
pub struct Bbox;

impl AreaEstimator for Bbox {
    const NAME: &'static str = "bbox";
    type State = Hull3;

    fn piece(poly: &ConvexPolyhedron) -> Hull3 {
        Hull3::new(&poly.vertices())
    }

    fn size(state: &Hull3) -> usize {
        state.pts.len()
    }

    fn absorb(state: &mut Hull3, other: Hull3) -> bool {
        state.insert_all(&other)
    }

    fn projected_area(state: &Hull3, frame: &Frame) -> f64 {
        bbox_area(&state.pts.iter().map(|p| frame.project(p)).collect::<Vec<P2>>())
    }

    fn projected_area_direct(pieces: &[&ConvexPolyhedron], frame: &Frame) -> f64 {
        let proj = |p: &ConvexPolyhedron| -> Vec<P2> { p.vertices().iter().map(|v| frame.project(v)).collect() };
        bbox_area(&pieces.iter().flat_map(|p| proj(p)).collect::<Vec<_>>())
    }
}
