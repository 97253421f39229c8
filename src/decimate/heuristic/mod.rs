//! Portal weights: the quality of the portal set between two cells. The pair with the
//! **lowest** weight is collapsed first (thesis 4.2.3), so a *good* portal — small compared
//! to a cell it opens into — must weigh *high*.
//!
//! A new heuristic is one new file in this folder with a unit type implementing
//! [`Heuristic`], plus one line in the `heuristics!` list (which declares the module and
//! adds the [`HeuristicKind`] variant). All of them see the same [`PairContext`]. The
//! engine calls the heuristic through `&dyn Heuristic`, once per weight: that costs
//! nothing next to the projected areas it needs.
//!
//! | name | weight | thesis | dimension |
//! |------|--------|--------|-----------|
//! | `aspect`  | `A_max / A_p` | 4.1.4: "the ratio between the area of the portal and the largest projected area of the two adjacent cells", figure 4.1: good portal "cell-portal aspect 4:1", bad "1:1" | none (scale-free) |
//! | `refined` | `(A_max / A_p) / √A_max = √A_max / A_p` | 4.3.2: "the cell-portal aspect ratio was now divided by the square root of the projected cell area" | 1/length |
//! | `volume`  | `refined · (V_min / V_max)^{1/3}` | 4.3.3 (our reading, below) | 1/length |
//! | `clearance` | `min(peak_a, peak_b) / saddle` (clearance engine) | ours | none |
//! | `aperture` | as `clearance`, plus the aperture gate ([`crate::decimate::clearance::ApertureGate`]) | ours | none |
//!
//! `A_p` is the summed area of all portal pieces between the two cells (4.1.4: "we sum the
//! areas of the involved portals"); `A_max` the larger of the two cells' projected areas on
//! the portal plane; `V` the cells' volumes.
//!
//! **Reading of 4.3.3.** The thesis gives no formula, only the intent: "include a measure
//! of the volume of the cells connected by a portal … to devalue the importance of cells
//! that were extremely small compared to their neighbours", applied to the heuristic in
//! use at that point (the refined one of 4.3.2; footnote 7 says the screenshots show it).
//! We multiply the refined weight by the cube root of the volume ratio (a length ratio,
//! in `(0, 1]`): pairs of similar volume keep their weight, a tiny cell next to a large
//! one weighs less and is absorbed early. The thesis found this unstable (the growing
//! cell "would slip through corridors in a self-accelerating attempt to consume the entire
//! model"); it is provided to reproduce that experiment.
//!
//! **No NaN or infinity.** `A_p` is floored at the area tolerance
//! [`Tolerances::area_abs`](crate::Tolerances::area_abs) (portal pieces below it are
//! discarded as slivers when the complex is built, so the floor only guards rounding);
//! projected areas are finite and `≥ 0` by construction; volumes are floored at
//! [`min_volume`](crate::geom::min_volume). Every weight is therefore a finite quotient of
//! finite numbers by a positive floor. [`sanitize`] enforces it anyway, and rounds weights
//! to [`WEIGHT_BITS`] significant bits so that rounding noise cannot break ties.

use super::UnknownName;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// What a heuristic may look at, for one pair of cells.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairContext {
    /// Summed area of all portal pieces between the two cells (floored, see module docs).
    pub portal_area: f64,
    /// The two cells' projected areas on the portal plane.
    pub projected: [f64; 2],
    /// The two cells' volumes (floored).
    pub volumes: [f64; 2],
    /// Number of convex pieces in each cell.
    pub pieces: [usize; 2],
    /// The two cells' peak clearance (the `clearance` engine only; 0 otherwise).
    pub peaks: [f64; 2],
    /// The highest pass between the two cells (the `clearance` engine only; 0 otherwise).
    pub saddle: f64,
}

/// Which engine runs a heuristic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Engine {
    /// The thesis's engine: pair weights from portal areas and the cells' projected areas
    /// (by the chosen estimator) and volumes.
    Projected,
    /// The clearance engine ([`super::clearance`]): pair weights from the components'
    /// peak clearance and the saddle between them; no estimator.
    Clearance,
}

impl PairContext {
    /// The larger projected area.
    pub fn max_projected(&self) -> f64 {
        self.projected[0].max(self.projected[1])
    }
}

/// A portal weight.
pub trait Heuristic: Send + Sync {
    /// The name used on the command line and in outputs.
    fn name(&self) -> &'static str;
    /// The weight of collapsing the pair (lower collapses first).
    fn weight(&self, ctx: &PairContext) -> f64;
    /// Whether the weight depends on cell volumes (then every pair of a cell that grew is
    /// re-weighed, even when its projected areas did not change).
    fn uses_volume(&self) -> bool {
        false
    }
    /// Whether the weight never decreases when a projected area grows, all other inputs
    /// of the [`PairContext`] fixed. Then the engine may re-weigh lazily: a cell that
    /// absorbs another only grows its projections on an unchanged plane, so a pair's stored
    /// weight (from its older, smaller areas) is a lower bound of its current weight, and
    /// the pair is re-weighed only when it reaches the front of the queue (see the
    /// [decimation docs](super#lazy-re-weighing)). `false` (the safe default) re-weighs
    /// every such pair at every merge.
    fn monotone_in_projected_areas(&self) -> bool {
        false
    }
    /// The engine that maintains this heuristic's inputs.
    fn engine(&self) -> Engine {
        Engine::Projected
    }
    /// The clearance engine's aperture gate, if the heuristic has one.
    fn aperture_gate(&self) -> Option<crate::decimate::clearance::ApertureGate> {
        None
    }
}

/// The registration list: variant (its lower-case name is the serde name and must equal
/// the heuristic's [`Heuristic::name`]) => module :: type.
macro_rules! heuristics {
    ($($variant:ident => $module:ident :: $ty:ident,)*) => {
        $(mod $module; pub use $module::$ty;)*

        /// The built-in heuristics, by name.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
        #[serde(rename_all = "lowercase")]
        pub enum HeuristicKind {
            $(#[doc = concat!("[`", stringify!($ty), "`].")] $variant,)*
        }

        impl HeuristicKind {
            /// All built-in heuristics.
            pub const ALL: [HeuristicKind; [$(stringify!($variant)),*].len()] = [$(HeuristicKind::$variant),*];

            /// The implementation.
            pub fn heuristic(self) -> &'static dyn Heuristic {
                match self {
                    $(HeuristicKind::$variant => &$ty,)*
                }
            }
        }
    };
}

heuristics! {
    Aspect => aspect::Aspect,
    Refined => refined::Refined,
    Volume => volume::VolumeRatio,
    Clearance => clearance::Clearance,
    Aperture => aperture::Aperture,
}

impl HeuristicKind {
    /// The stop rule used when none is given: `threshold:`[`DEFAULT_RATIO`] for
    /// `clearance` (scale-free), `threshold:3` for the thesis's heuristics (4.1.4 suggests
    /// 3 to 4 for `aspect`).
    ///
    /// [`DEFAULT_RATIO`]: crate::decimate::clearance::DEFAULT_RATIO
    pub fn default_stop(self) -> super::StopRule {
        match self.heuristic().engine() {
            Engine::Clearance => super::StopRule::Threshold(super::clearance::DEFAULT_RATIO),
            Engine::Projected => super::StopRule::Threshold(3.0),
        }
    }

    /// The heuristic of this name, or an error listing the valid names.
    pub fn parse(s: &str) -> Result<Self, UnknownName> {
        HeuristicKind::ALL
            .into_iter()
            .find(|h| h.heuristic().name() == s)
            .ok_or_else(|| {
                UnknownName::new(
                    "heuristic",
                    s,
                    HeuristicKind::ALL.map(|h| h.heuristic().name()).to_vec(),
                )
            })
    }
}

impl fmt::Display for HeuristicKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.heuristic().name())
    }
}

impl FromStr for HeuristicKind {
    type Err = UnknownName;
    fn from_str(s: &str) -> Result<Self, UnknownName> {
        HeuristicKind::parse(s)
    }
}

/// Significant bits kept in a weight (see [`sanitize`]): relative resolution `2^-30 ≈ 1e-9`.
pub const WEIGHT_BITS: u32 = 30;

/// The weight as used everywhere (queue, threshold, records): finite, non-negative, and
/// rounded down to [`WEIGHT_BITS`] significant bits.
///
/// - NaN becomes 0 and +∞ the largest finite value (neither happens with the floors above;
///   this is the last line of defence).
/// - Rounding makes weights that are equal up to floating-point noise (say `6` and
///   `6.000000000000002` for a rotated copy of an axis-aligned scene) *exactly* equal, so
///   the queue's tie-break (smaller cell first) decides between them as it does for the
///   axis-aligned scene, instead of the noise. Weights that differ by more than about
///   `1e-9` relative keep their order.
pub fn sanitize(w: f64) -> f64 {
    let w = if w.is_nan() { 0.0 } else { w.clamp(0.0, f64::MAX) };
    let drop = 52 - WEIGHT_BITS;
    f64::from_bits(w.to_bits() & !((1u64 << drop) - 1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn good_portals_weigh_high() {
        // Figure 4.1: a portal a quarter of the cell's projection is good (4), 1:1 bad (1).
        let good = PairContext {
            portal_area: 1.0,
            projected: [4.0, 1.0],
            volumes: [8.0, 1.0],
            pieces: [1, 1],
            peaks: [0.0, 0.0],
            saddle: 0.0,
        };
        let bad = PairContext {
            projected: [1.0, 1.0],
            ..good
        };
        assert_eq!(Aspect.weight(&good), 4.0);
        assert_eq!(Aspect.weight(&bad), 1.0);
        assert_eq!(Refined.weight(&good), 2.0);
        assert_eq!(VolumeRatio.weight(&good), 1.0);
        for h in HeuristicKind::ALL {
            assert_eq!(h.to_string().parse::<HeuristicKind>().unwrap(), h);
        }
        assert!("nope".parse::<HeuristicKind>().is_err());
        assert_eq!(
            HeuristicKind::parse("nope").unwrap_err().to_string(),
            "unknown heuristic \"nope\"; use aspect, refined, volume, clearance or aperture"
        );
        for h in HeuristicKind::ALL {
            assert_eq!(serde_json::to_string(&h).unwrap(), format!("\"{h}\""));
        }
        assert_eq!(sanitize(f64::NAN), 0.0);
        assert!(sanitize(f64::INFINITY).is_finite());
        assert_eq!(sanitize(6.000000000000002), 6.0);
        assert_eq!(sanitize(6.0), 6.0);
        assert!(sanitize(6.00001) > 6.0);
        assert!(sanitize(-1.0) == 0.0);
    }
}
