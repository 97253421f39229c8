//! Reconstructions of the test models of Gjørup's thesis, section 4.3 (issue 5).
//!
//! The thesis's models are not published; these generators follow the text's description
//! of each, and every model carries a ground truth: the rooms (sample points inside each)
//! and the doorways (the opening a person would draw between two rooms). Each model's
//! `description` states how it follows the thesis and how its counts compare.
//!
//! Orientation follows the crate convention: every polygon's counter-clockwise front faces
//! free space (room walls face inwards, furniture faces outwards). Every generator is
//! deterministic (fixed seeds, [`SplitMix64`](crate::base::rng::SplitMix64)).
//!
//! **The four rooms.** Rooms A (south-west), B (south-east), C (north-east) and D
//! (north-west), all 3 m high, of different plan sizes, each rotated about z by its own
//! angle (4°, −6°, 7°, −3°) and offset so that no two rooms share a wall plane. Short
//! corridors (about 1.3 m long, 1 m wide) join them in a ring A–B–C–D–A, so each room has
//! doors in two walls. A door spans the wall's full height: that is how the thesis's counts
//! come out — 64 vertices = 8 per room box and 8 per corridor, 96 triangles = per room
//! floor, ceiling and two whole walls (8) plus two door walls of two quads each (8), per
//! corridor floor, ceiling and two sides (8): 4 × 16 + 4 × 8 = 96. The corridor's end
//! vertices are the door jambs, lying on the room's floor and ceiling edges
//! (T-junctions, as in a minimal-triangle model; the surface is closed).
//! The tessellated model's counts (200 vertices, 400 triangles, V = F/2) are those of a
//! closed conforming torus surface, which is what the ring of rooms and corridors is.

//!
//! One file per family: `four_room.rs` (optimized, distorted, tessellated), `noisy.rs`,
//! `caverns.rs` (plain and rotated); `build.rs` has the indexed builder they share.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::generate::scenes::Soup;

mod build;
mod caverns;
mod four_room;
mod noisy;

pub use caverns::{caverns, caverns_rotated};
pub use four_room::{four_room_distorted, four_room_optimized, four_room_tessellated};
pub use noisy::noisy;

/// A room of the ground truth: points that lie inside it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Room {
    /// Room name.
    pub name: String,
    /// Sample points inside the room (clear of furniture).
    pub samples: Vec<[f64; 3]>,
}

/// A doorway of the ground truth: the opening between two rooms.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Doorway {
    /// The two rooms (indices into [`GroundTruth::rooms`]).
    pub rooms: [usize; 2],
    /// The opening, a closed polygon (not necessarily planar for cave tunnels).
    pub polygon: Vec<[f64; 3]>,
}

/// Rooms and doorways a person would draw.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct GroundTruth {
    /// The rooms.
    pub rooms: Vec<Room>,
    /// The doorways between rooms.
    pub doorways: Vec<Doorway>,
}

/// One reconstructed thesis model.
#[derive(Clone, Debug)]
pub struct ThesisModel {
    /// Model name (file stem).
    pub name: &'static str,
    /// The polygon soup.
    pub soup: Soup,
    /// Rooms and doorways.
    pub truth: GroundTruth,
    /// How the reconstruction follows the thesis, with the thesis's figures.
    pub description: String,
}

/// The model names, in the thesis's order.
pub const NAMES: [&str; 6] = [
    "four_room_optimized",
    "four_room_tessellated",
    "four_room_distorted",
    "caverns",
    "caverns_rotated",
    "noisy",
];

/// All models, in the thesis's order.
pub fn all() -> Vec<ThesisModel> {
    NAMES.iter().filter_map(|n| by_name(n)).collect()
}

/// The model of this name, if any.
pub fn by_name(name: &str) -> Option<ThesisModel> {
    Some(match name {
        "four_room_optimized" => four_room_optimized(),
        "four_room_tessellated" => four_room_tessellated(),
        "four_room_distorted" => four_room_distorted(),
        "caverns" => caverns(),
        "caverns_rotated" => caverns_rotated(),
        "noisy" => noisy(),
        _ => return None,
    })
}

/// Writes `<dir>/<name>.obj` (the description as the header) and `<dir>/<name>.truth.json`.
pub fn write(model: &ThesisModel, dir: &Path) -> std::io::Result<()> {
    use crate::model::write::{obj_text, write_atomic};
    std::fs::create_dir_all(dir)?;
    let header = format!("{}\n{}", model.name, model.description);
    let obj = obj_text(&header, &model.soup.vertices, &model.soup.polygons);
    write_atomic(&dir.join(format!("{}.obj", model.name)), obj.as_bytes())?;
    let json = serde_json::to_string_pretty(&model.truth).map_err(std::io::Error::other)?;
    write_atomic(&dir.join(format!("{}.truth.json", model.name)), json.as_bytes())
}
