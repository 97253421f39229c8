//! `hull`: the area of the 2D convex hull of the projected cell, from its 3D hull.

use super::AreaEstimator;
use crate::decimate::hull3::Hull3;
use crate::decimate::project::{Frame, P2, hull2, polygon_area};
use crate::geom::ConvexPolyhedron;

/// 2D convex hull of the projected vertices.
#[derive(Clone, Copy, Debug, Default)]
pub struct Hull;

impl AreaEstimator for Hull {
    const NAME: &'static str = "hull";
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
        polygon_area(&hull2(state.pts.iter().map(|p| frame.project(p)).collect::<Vec<P2>>()))
    }

    fn projected_area_direct(pieces: &[&ConvexPolyhedron], frame: &Frame) -> f64 {
        let proj = |p: &ConvexPolyhedron| -> Vec<P2> { p.vertices().iter().map(|v| frame.project(v)).collect() };
        polygon_area(&hull2(pieces.iter().flat_map(|p| proj(p)).collect()))
    }
}
