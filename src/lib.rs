//! portalfind: find cells and portals in 3D polygon models.
//!
//! See `ARCHITECTURE.md` for the layers and their invariants. In short: [`base`] (RNG,
//! rigid transforms, vector helpers; uses nothing above it) ← [`predicates`] (exact
//! geometry) ← [`delaunay`] (tetrahedralization) and [`model`] (input) ← later stages (cell
//! complex, decimation); [`generate`] builds test and thesis models.

// Index loops over fixed-size vertex/face slots read more clearly than iterator chains
// in geometry code.
#![allow(clippy::needless_range_loop)]

pub mod base;
pub mod bench;
pub mod bsp;
pub mod complex;
pub mod decimate;
pub mod delaunay;
pub mod experiment;
pub mod generate;
pub mod geom;
pub mod ids;
pub mod model;
pub mod output;
pub mod predicates;
pub mod rooms;
pub mod tolerances;
pub mod visibility;

// compat re-export, removed after merge
#[doc(hidden)]
pub use generate::scenes;
// compat re-export, removed after merge
#[doc(hidden)]
pub use generate::thesis as thesis_models;

pub use ids::{CellId, PolygonId, TetId, VertexId};
pub use tolerances::Tolerances;
