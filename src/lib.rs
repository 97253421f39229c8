//! portalfind: find cells and portals in 3D polygon models.
//!
//! See `ARCHITECTURE.md` for the layers and their invariants. In short: [`base`] (RNG,
//! rigid transforms, vector helpers; uses nothing above it) ← [`predicates`] (exact
//! geometry) ← [`delaunay`] (tetrahedralization) and [`model`] (input) ← later stages (cell
//! complex, decimation); [`generate`] builds test and thesis models.
//!
//! The entry point is [`pipeline`]: [`pipeline::run`] loads a model file and runs
//! subdivision (Delaunay or BSP), cell complex and decimation to the `result.json`
//! document; [`output::write_outputs`] writes the files of every registered
//! [`output::Exporter`]. The `portalfind` binary (feature `cli`, on by default) and the
//! experiment runner ([`experiment::run_all`]) both go through it.

// Index loops over fixed-size vertex/face slots read more clearly than iterator chains
// in geometry code.
#![allow(clippy::needless_range_loop)]

pub mod base;
pub mod bench;
pub mod bsp;
pub mod complex;
pub mod decimate;
pub mod delaunay;
pub mod evaluate;
pub mod experiment;
pub mod generate;
pub mod geom;
pub mod ids;
pub mod model;
pub mod output;
pub mod pipeline;
pub mod predicates;
pub mod suite;
pub mod tolerances;
pub mod visibility;

pub use ids::{CellId, PatchId, PolygonId, TetId, VertexId};
pub use tolerances::Tolerances;
