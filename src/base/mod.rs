//! The bottom layer: what every other module may use, and which uses nothing of the crate
//! above it (only `std`).
//!
//! - [`rng`]: the one random-number generator ([`rng::SplitMix64`]), seedable, so every
//!   insertion order, generated model and test input is reproducible.
//! - [`hash`]: a fast deterministic hasher for integer keys ([`hash::FxBuild`]).
//! - [`mem`]: the process's peak resident memory (`VmHWM`), which every stage reports, and
//!   the cache hint ([`mem::prefetch`]) of loops over random indices.
//! - [`rigid`]: the one rigid-transform module (rotations by degrees about the coordinate
//!   axes, the 7°/8°/9° stress rotation of the tests and benchmarks).
//! - [`vec`](mod@vec): the vector helpers on plain `[f64; 3]` arrays ([`vec::P3`]) and a compensated
//!   dot product. Plain arrays, not a SIMD vector type, because copies must keep bit
//!   patterns (the B-rep identifies vertices by their exact coordinates) and every formula
//!   must keep its operation order (outputs are compared byte for byte).

pub mod hash;
pub mod mem;
pub mod rigid;
pub mod rng;
pub mod vec;
