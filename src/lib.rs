//! portalfind: find cells and portals in 3D polygon models.
//!
//! See `ARCHITECTURE.md` for the layers and their invariants. In short:
//! [`predicates`] (exact geometry) ← [`delaunay`] (tetrahedralization) and [`model`] (input)
//! ← later stages (cell complex, decimation).

// Index loops over fixed-size vertex/face slots read more clearly than iterator chains
// in geometry code.
#![allow(clippy::needless_range_loop)]

pub mod bench;
pub mod bsp;
pub mod complex;
pub mod decimate;
pub mod delaunay;
pub mod experiment;
pub mod geom;
pub mod ids;
pub mod model;
pub mod output;
pub mod predicates;
pub mod scenes;
pub mod suite;
pub mod thesis_models;
pub mod tolerances;

pub use ids::{CellId, PolygonId, PortalId, TetId, VertexId};
pub use tolerances::Tolerances;
