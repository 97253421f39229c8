//! Projected-area estimators and the per-cell state each keeps so that a collapse costs
//! about the size of what changed.
//!
//! | estimator | measure of a cell projected on the portal plane | per-cell state | merge |
//! |-----------|-----------------------------------------------|----------------|-------|
//! | `bbox`  | area of the bounding rectangle, axis-aligned in the plane's canonical frame ([`Frame`]) — the thesis's "bounding rectangle" | 3D convex hull | insert the smaller hull's vertices into the larger: `O(k·h)` |
//! | `hull`  | area of the 2D convex hull of the projected cell | 3D convex hull | as `bbox` |
//! | `union` | exact area of the union of the projected convex pieces | boundary faces keyed by patch (below) | symmetric difference: `O(size of the absorbed cell's boundary)` (hash look-ups) |
//!
//! **Why the 3D hull suffices for `bbox` and `hull`.** Orthogonal projection is linear, so
//! the projection of the convex hull of a point set is the convex hull of the projected
//! points, and the extreme points in any in-plane direction are projections of 3D hull
//! vertices. Both measures therefore depend only on the cell's 3D hull vertex set, and the
//! hull of a union is the hull of the two hulls' vertices. A merged room keeps tens to a
//! few hundred hull vertices however many pieces it absorbed; when the absorbed cell lies
//! inside the survivor's hull, nothing changes (exactly: the insertion is decided by exact
//! [`orient3d`](crate::predicates::orient3d)) and the survivor's other pairs keep their
//! weights without being re-weighed.
//!
//! **Boundary faces for `union`.** The projection of a cell is the union of its pieces'
//! projections, which is the projection of the solid they fill: the union of the
//! projections of its *front* boundary faces (see [`Boundary`]). The state is the set of
//! boundary faces keyed by patch; a merge is a symmetric difference (cost: the absorbed
//! cell's boundary). A merge that brings no face (the absorbed cell was enclosed) changes
//! no projection, and `absorb` says so. On an unchanged plane the survivor's area grows
//! incrementally from the version its stored area was computed at (one merge back, or
//! several when the engine re-weighs lazily): the stored area plus what the front faces
//! added since then add to the front faces of the boundary as it was then, which they
//! overlap ([`union_area_delta_slices`](super::project::union_area_delta_slices); faces
//! record the merge that added them, and faces that became interior are logged with the
//! merge that removed them). On a new plane (a pair whose portal set
//! changed) the whole front is unioned
//! ([`union_area_paired`](super::project::union_area_paired)): neighbouring front faces
//! share edges exactly, and only the unshared edges (the silhouette, and the edges of
//! overlapping layers) are integrated; an exact area on a new direction depends on the
//! cell's whole silhouette, so no state kept for other directions can make that cheaper
//! than one pass over its front faces. History: a union over pieces was quadratic in a
//! merged room's size (e1m1 at `cells:60`: 807 s with convex blocks of pieces, 384 s with
//! boundary faces unioned edge by edge; `hull` takes under a second).
//!
//! # Adding an estimator
//!
//! One new file in this folder with a unit type implementing [`AreaEstimator`] (the name,
//! the per-cell state and its merge, the projected area), and one line in the
//! `estimators!` list below. The decimation engine is generic over the trait, so each
//! estimator gets its own monomorphised engine: no per-call dispatch, no state that may
//! not match its estimator. [`Estimator`] (the command-line and JSON name) dispatches once,
//! at the top of a run.

use super::UnknownName;
use super::project::Frame;
use crate::geom::ConvexPolyhedron;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// A measure of the projected area of a (merged, non-convex) cell on a portal plane,
/// with the per-cell state that makes a merge cost about the size of what changed.
pub trait AreaEstimator: 'static {
    /// The name used on the command line and in outputs (the [`Estimator`] variant's
    /// name in lower case).
    const NAME: &'static str;
    /// What the estimator keeps per cell.
    type State;
    /// The state of one convex piece (a cell of the complex, faces tagged by patch).
    fn piece(poly: &ConvexPolyhedron) -> Self::State;
    /// Size of the state (3D hull vertices, boundary faces), for the statistics.
    fn size(state: &Self::State) -> usize;
    /// Merges `other` into `state` (the cell that absorbs it); returns whether any
    /// projected measure of `state` may have changed. `false` must be exact: every
    /// projected area of the state is then what it was in exact arithmetic (the survivor's
    /// other pairs keep their stored weights without being re-weighed).
    fn absorb(state: &mut Self::State, other: Self::State) -> bool;
    /// Projected area on the plane of `frame` (the engine maps non-finite values to 0 and
    /// negative ones to 0).
    fn projected_area(state: &Self::State, frame: &Frame) -> f64;
    /// The projected area now, given the area `before` on the same plane when the state's
    /// version was `since` (the version counts the merges whose `absorb` returned `true`,
    /// from 0 for a piece; the engine keeps the same count). The default recomputes it in
    /// full.
    fn projected_area_grown(state: &Self::State, frame: &Frame, before: f64, since: u32) -> f64 {
        let _ = (before, since);
        Self::projected_area(state, frame)
    }
    /// The projected area of a cell given by its convex pieces, computed from scratch (no
    /// state): the reference the incremental states are tested against.
    fn projected_area_direct(pieces: &[&ConvexPolyhedron], frame: &Frame) -> f64;
}

/// A computation generic over the estimator, run by [`Estimator::with`].
pub trait WithEstimator {
    /// The result.
    type Output;
    /// Runs with estimator `E`.
    fn call<E: AreaEstimator>(self) -> Self::Output;
}

/// The registration list: variant (its lower-case name is the serde name and must equal
/// the type's [`AreaEstimator::NAME`]) => module :: type.
macro_rules! estimators {
    ($($(#[$doc:meta])* $variant:ident => $module:ident :: $ty:ident,)*) => {
        $(mod $module; pub use $module::$ty;)*

        /// How the projected area of a (merged, non-convex) cell on a portal plane is
        /// measured: the name of an [`AreaEstimator`].
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
        #[serde(rename_all = "lowercase")]
        pub enum Estimator {
            $($(#[$doc])* $variant,)*
        }

        impl Estimator {
            /// All estimators, in a fixed order.
            pub const ALL: [Estimator; [$(stringify!($variant)),*].len()] = [$(Estimator::$variant),*];

            /// The name used on the command line.
            pub fn name(self) -> &'static str {
                match self {
                    $(Estimator::$variant => <$ty as AreaEstimator>::NAME,)*
                }
            }

            /// Runs `f` with this estimator's type (the one dispatch from name to code).
            pub fn with<F: WithEstimator>(self, f: F) -> F::Output {
                match self {
                    $(Estimator::$variant => f.call::<$ty>(),)*
                }
            }
        }
    };
}

estimators! {
    /// Axis-aligned bounding rectangle in the plane's canonical frame (thesis 4.4).
    Bbox => bbox::Bbox,
    /// 2D convex hull of the projected vertices.
    Hull => hull::Hull,
    /// Exact union of the projected convex pieces.
    Union => union::Union,
}

pub use union::Boundary;

impl Estimator {
    /// The estimator of this name, or an error listing the valid names.
    pub fn parse(s: &str) -> Result<Self, UnknownName> {
        Estimator::ALL
            .into_iter()
            .find(|e| e.name() == s)
            .ok_or_else(|| UnknownName::new("estimator", s, Estimator::ALL.map(Estimator::name).to_vec()))
    }
}

impl fmt::Display for Estimator {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Estimator {
    type Err = UnknownName;
    fn from_str(s: &str) -> Result<Self, UnknownName> {
        Estimator::parse(s)
    }
}

/// The projected area of a cell given by its convex pieces, computed from scratch (no
/// hulls or boundary faces kept): the reference the incremental states are tested against.
/// `bbox` and `hull` use all piece vertices; `union` the union of the pieces' projections.
pub fn projected_area_direct(est: Estimator, pieces: &[&ConvexPolyhedron], frame: &Frame) -> f64 {
    struct Direct<'a, 'b> {
        pieces: &'a [&'b ConvexPolyhedron],
        frame: &'a Frame,
    }
    impl WithEstimator for Direct<'_, '_> {
        type Output = f64;
        fn call<E: AreaEstimator>(self) -> f64 {
            E::projected_area_direct(self.pieces, self.frame)
        }
    }
    est.with(Direct { pieces, frame })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_match_serde_and_parse() {
        for e in Estimator::ALL {
            assert_eq!(serde_json::to_string(&e).unwrap(), format!("\"{}\"", e.name()));
            assert_eq!(e.to_string().parse::<Estimator>(), Ok(e));
        }
        assert_eq!(
            Estimator::parse("nope").unwrap_err().to_string(),
            "unknown estimator \"nope\"; use bbox, hull or union"
        );
        assert_eq!(
            "nope".parse::<Estimator>().unwrap_err().to_string(),
            "unknown estimator \"nope\"; use bbox, hull or union"
        );
    }
}
