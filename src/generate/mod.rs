//! Generators of test and thesis models, one file (or folder) per family. Everything
//! here is deterministic: fixed layouts and fixed seeds ([`crate::base::rng`]).
//!
//! - [`scenes`]: the indexed polygon [`Soup`](scenes::Soup) and hand-made scenes (a box
//!   room, two rooms with a door, pillars) and [`room_grid`](scenes::room_grid), a
//!   tessellated building that scales to a million triangles (`portalfind gen rooms`).
//! - [`four_rooms`]: the 2 × 2 rooms joined by door corridors, with any subset of the
//!   doors, that the decimation tests separate.
//! - [`thesis`]: reconstructions of the thesis's models (4.3) with ground-truth rooms and
//!   doorways (`portalfind gen thesis`; `models/thesis/` holds their files).

pub mod four_rooms;
pub mod scenes;
pub mod thesis;
