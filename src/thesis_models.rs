//! Reconstructions of the test models of Gjørup's thesis, section 4.3 (issue 5).
//!
//! The thesis's models are not published; these generators follow the text's description
//! of each, and every model carries a ground truth: the rooms (sample points inside each)
//! and the doorways (the opening a person would draw between two rooms). Each model's
//! `description` states how it follows the thesis and how its counts compare.
//!
//! Orientation follows the crate convention: every polygon's counter-clockwise front faces
//! free space (room walls face inwards, furniture faces outwards). Every generator is
//! deterministic (fixed seeds, [`SplitMix64`]).
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

use std::collections::HashMap;
use std::f64::consts::PI;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::delaunay::SplitMix64;
use crate::predicates::P3;
use crate::scenes::Soup;

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

// ---------------------------------------------------------------------------------------
// Small vector helpers and an indexed builder.

fn sub(a: P3, b: P3) -> P3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn add(a: P3, b: P3) -> P3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn scale(a: P3, s: f64) -> P3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn dot(a: P3, b: P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
/// `a (1 - t) + b t`: exactly `a` at `t = 0` and exactly `b` at `t = 1`, so grid points on
/// box corners and edges are bit-identical however they are reached.
fn lerp(a: P3, b: P3, t: f64) -> P3 {
    let s = 1.0 - t;
    [a[0] * s + b[0] * t, a[1] * s + b[1] * t, a[2] * s + b[2] * t]
}
fn mean(ps: &[P3]) -> P3 {
    let s = ps.iter().fold([0.0; 3], |acc, &p| add(acc, p));
    scale(s, 1.0 / ps.len() as f64)
}
fn newell(ps: &[P3]) -> P3 {
    let mut n = [0.0; 3];
    for i in 0..ps.len() {
        let (a, b) = (sub(ps[i], ps[0]), sub(ps[(i + 1) % ps.len()], ps[0]));
        n[0] += a[1] * b[2] - a[2] * b[1];
        n[1] += a[2] * b[0] - a[0] * b[2];
        n[2] += a[0] * b[1] - a[1] * b[0];
    }
    n
}
fn rot_z(p: P3, deg: f64) -> P3 {
    let (s, c) = deg.to_radians().sin_cos();
    [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]]
}
fn rot_xyz(p: P3, deg: [f64; 3]) -> P3 {
    let (sx, cx) = deg[0].to_radians().sin_cos();
    let (sy, cy) = deg[1].to_radians().sin_cos();
    let [x, y, z] = p;
    let (y, z) = (cx * y - sx * z, sx * y + cx * z);
    let (x, z) = (cy * x + sy * z, -sy * x + cy * z);
    rot_z([x, y, z], deg[2])
}
/// Uniform in `[-1, 1)`.
fn unit(rng: &mut SplitMix64) -> f64 {
    (rng.next_u64() >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// An indexed soup whose vertices are shared by exact coordinates.
#[derive(Default)]
struct Builder {
    soup: Soup,
    index: HashMap<[u64; 3], u32>,
}

impl Builder {
    fn v(&mut self, p: P3) -> u32 {
        let key = [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()];
        let soup = &mut self.soup;
        *self.index.entry(key).or_insert_with(|| {
            soup.vertices.push(p);
            soup.vertices.len() as u32 - 1
        })
    }
    /// A polygon through the given vertices, oriented so its front faces `toward`.
    fn poly_toward(&mut self, mut ids: Vec<u32>, toward: P3) {
        let ps: Vec<P3> = ids.iter().map(|&i| self.soup.vertices[i as usize]).collect();
        if dot(newell(&ps), sub(toward, mean(&ps))) < 0.0 {
            ids.reverse();
        }
        self.soup.polygons.push(ids);
    }
    /// A polygon oriented so its front faces direction `dir`.
    fn poly_dir(&mut self, mut ids: Vec<u32>, dir: P3) {
        let ps: Vec<P3> = ids.iter().map(|&i| self.soup.vertices[i as usize]).collect();
        if dot(newell(&ps), dir) < 0.0 {
            ids.reverse();
        }
        self.soup.polygons.push(ids);
    }
    /// A quad `a b c d` (in cyclic order) as two triangles split along `a c`, fronts
    /// facing `toward`.
    /// Two triangles of a (nearly planar) quad along the diagonal the Delaunay criterion
    /// picks: `0–2` unless the angles at `1` and `3` sum to more than π. Curved surfaces
    /// tessellated this way have far more triangles that are faces of the tetrahedralization.
    fn quad_tris_delaunay(&mut self, q: [P3; 4], toward: P3) {
        let angle = |a: P3, o: P3, b: P3| {
            let (u, v) = (sub(a, o), sub(b, o));
            (dot(u, v) / (dot(u, u) * dot(v, v)).sqrt()).clamp(-1.0, 1.0).acos()
        };
        if angle(q[0], q[1], q[2]) + angle(q[0], q[3], q[2]) > PI {
            self.quad_tris([q[1], q[2], q[3], q[0]], toward);
        } else {
            self.quad_tris(q, toward);
        }
    }

    fn quad_tris(&mut self, q: [P3; 4], toward: P3) {
        let ids = q.map(|p| self.v(p));
        self.poly_toward(vec![ids[0], ids[1], ids[2]], toward);
        self.poly_toward(vec![ids[0], ids[2], ids[3]], toward);
    }
}

// ---------------------------------------------------------------------------------------
// The four rooms.

/// A room as its eight corners, indexed `u + 2v + 4w` (u along the room's x, v along its
/// y, w up); points inside by trilinear interpolation.
#[derive(Clone, Copy, Debug)]
struct RoomBox {
    corners: [P3; 8],
}

impl RoomBox {
    fn at(&self, u: f64, v: f64, w: f64) -> P3 {
        let c = &self.corners;
        let b = lerp(lerp(c[0], c[1], u), lerp(c[2], c[3], u), v);
        let t = lerp(lerp(c[4], c[5], u), lerp(c[6], c[7], u), v);
        lerp(b, t, w)
    }
    fn center(&self) -> P3 {
        self.at(0.5, 0.5, 0.5)
    }
}

/// A wall of a room box: which parameter is fixed (0 = u, 1 = v) and at which end.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Wall {
    fixed: usize,
    end: f64,
}

impl Wall {
    /// The wall point at parameter `t` along the wall (the free one of u, v) and height `w`.
    fn at(&self, r: &RoomBox, t: f64, w: f64) -> P3 {
        if self.fixed == 0 {
            r.at(self.end, t, w)
        } else {
            r.at(t, self.end, w)
        }
    }
}

const HEIGHT: f64 = 3.0;
const DOOR_WIDTH: f64 = 1.0;

/// Plan of a room: centre, size along its x and y, rotation about z (degrees).
struct RoomPlan {
    name: &'static str,
    center: [f64; 2],
    size: [f64; 2],
    angle: f64,
}

const PLANS: [RoomPlan; 4] = [
    RoomPlan {
        name: "A (south-west)",
        center: [0.0, 0.0],
        size: [5.0, 4.0],
        angle: 4.0,
    },
    RoomPlan {
        name: "B (south-east)",
        center: [5.8, 0.3],
        size: [4.0, 4.6],
        angle: -6.0,
    },
    RoomPlan {
        name: "C (north-east)",
        center: [6.0, 5.9],
        size: [4.6, 4.0],
        angle: 7.0,
    },
    RoomPlan {
        name: "D (north-west)",
        center: [0.2, 5.4],
        size: [4.4, 4.2],
        angle: -3.0,
    },
];

/// Corridors of the ring: (room, wall, room, wall, a world point the door is centred on
/// along the walls).
const CORRIDORS: [(usize, Wall, usize, Wall, [f64; 2]); 4] = [
    (
        0,
        Wall { fixed: 0, end: 1.0 },
        1,
        Wall { fixed: 0, end: 0.0 },
        [3.0, 0.9],
    ),
    (
        1,
        Wall { fixed: 1, end: 1.0 },
        2,
        Wall { fixed: 1, end: 0.0 },
        [5.9, 3.3],
    ),
    (
        3,
        Wall { fixed: 0, end: 1.0 },
        2,
        Wall { fixed: 0, end: 0.0 },
        [3.0, 5.0],
    ),
    (
        0,
        Wall { fixed: 1, end: 1.0 },
        3,
        Wall { fixed: 1, end: 0.0 },
        [0.6, 2.6],
    ),
];

/// A door: room, wall and its span `[t0, t1]` along the wall.
#[derive(Clone, Copy, Debug)]
struct Door {
    room: usize,
    wall: Wall,
    t: (f64, f64),
}

/// The regular room boxes (rotated about z only) and the doors, corridor by corridor.
fn four_room_layout() -> (Vec<RoomBox>, Vec<[Door; 2]>) {
    let rooms: Vec<RoomBox> = PLANS
        .iter()
        .map(|p| {
            let mut corners = [[0.0; 3]; 8];
            for (i, c) in corners.iter_mut().enumerate() {
                let (u, v, w) = ((i & 1) as f64, ((i >> 1) & 1) as f64, (i >> 2) as f64);
                let local = [(u - 0.5) * p.size[0], (v - 0.5) * p.size[1], w * HEIGHT];
                let r = rot_z(local, p.angle);
                *c = [r[0] + p.center[0], r[1] + p.center[1], r[2]];
            }
            RoomBox { corners }
        })
        .collect();
    let doors = CORRIDORS
        .iter()
        .map(|&(ra, wa, rb, wb, target)| {
            let door = |room: usize, wall: Wall| {
                let p = &PLANS[room];
                let local = rot_z([target[0] - p.center[0], target[1] - p.center[1], 0.0], -p.angle);
                let free = 1 - wall.fixed;
                let len = p.size[free];
                let c = local[free] / len + 0.5;
                let h = 0.5 * DOOR_WIDTH / len;
                Door {
                    room,
                    wall,
                    t: (c - h, c + h),
                }
            };
            [door(ra, wa), door(rb, wb)]
        })
        .collect();
    (rooms, doors)
}

/// The distorted room boxes: each regular box rotated about its centre around x, y and z
/// by its own angles, and two of its corners displaced by 0.25 m in random directions.
fn distort(rooms: &[RoomBox]) -> Vec<RoomBox> {
    const ANGLES: [[f64; 3]; 4] = [[3.0, -2.0, 5.0], [-2.5, 3.5, -4.0], [2.0, 2.5, 6.0], [-3.0, -2.0, -5.0]];
    let mut rng = SplitMix64(0x0007_E515_0004_0303);
    rooms
        .iter()
        .zip(ANGLES)
        .map(|(r, a)| {
            let c = r.center();
            let mut corners = r.corners.map(|p| add(c, rot_xyz(sub(p, c), a)));
            for _ in 0..2 {
                let k = rng.below(8);
                let mut d = [unit(&mut rng), unit(&mut rng), unit(&mut rng)];
                let n = dot(d, d).sqrt().max(1e-9);
                d = scale(d, 0.25 / n);
                corners[k] = add(corners[k], d);
            }
            RoomBox { corners }
        })
        .collect()
}

fn doors_of(doors: &[[Door; 2]], room: usize) -> Vec<Door> {
    doors.iter().flatten().filter(|d| d.room == room).copied().collect()
}

/// The four-room model with the fewest triangles: per room floor, ceiling and walls, door
/// walls as two full-height quads beside the door; per corridor four quads; all as
/// triangles.
fn four_room_minimal(rooms: &[RoomBox], doors: &[[Door; 2]]) -> Soup {
    let mut b = Builder::default();
    for (ri, r) in rooms.iter().enumerate() {
        let c = r.center();
        let cn = r.corners;
        b.quad_tris([cn[0], cn[1], cn[3], cn[2]], c);
        b.quad_tris([cn[4], cn[5], cn[7], cn[6]], c);
        let room_doors = doors_of(doors, ri);
        for wall in [0.0, 1.0]
            .map(|e| Wall { fixed: 0, end: e })
            .into_iter()
            .chain([0.0, 1.0].map(|e| Wall { fixed: 1, end: e }))
        {
            let spans = match room_doors.iter().find(|d| d.wall == wall) {
                Some(d) => vec![(0.0, d.t.0), (d.t.1, 1.0)],
                None => vec![(0.0, 1.0)],
            };
            for (t0, t1) in spans {
                let q = [
                    wall.at(r, t0, 0.0),
                    wall.at(r, t1, 0.0),
                    wall.at(r, t1, 1.0),
                    wall.at(r, t0, 1.0),
                ];
                b.quad_tris(q, c);
            }
        }
    }
    for [da, db] in doors {
        let (ra, rb) = (&rooms[da.room], &rooms[db.room]);
        let pa = |t: f64, w: f64| da.wall.at(ra, t, w);
        let pb = |t: f64, w: f64| db.wall.at(rb, t, w);
        let (a0b, a1b, a0t, a1t) = (pa(da.t.0, 0.0), pa(da.t.1, 0.0), pa(da.t.0, 1.0), pa(da.t.1, 1.0));
        let (b0b, b1b, b0t, b1t) = (pb(db.t.0, 0.0), pb(db.t.1, 0.0), pb(db.t.0, 1.0), pb(db.t.1, 1.0));
        let c = mean(&[a0b, a1b, a0t, a1t, b0b, b1b, b0t, b1t]);
        b.quad_tris([a0b, a1b, b1b, b0b], c);
        b.quad_tris([a0t, a1t, b1t, b0t], c);
        b.quad_tris([a0b, b0b, b0t, a0t], c);
        b.quad_tris([a1b, b1b, b1t, a1t], c);
    }
    b.soup
}

/// The four-room ground truth: five samples per room at 1.8 m (above any furniture), and
/// per corridor its cross-section half-way along.
fn four_room_truth(rooms: &[RoomBox], doors: &[[Door; 2]]) -> GroundTruth {
    let rooms_t = rooms
        .iter()
        .zip(&PLANS)
        .map(|(r, p)| Room {
            name: p.name.to_string(),
            samples: [(0.5, 0.5), (0.25, 0.25), (0.75, 0.25), (0.75, 0.75), (0.25, 0.75)]
                .iter()
                .map(|&(u, v)| r.at(u, v, 0.6))
                .collect(),
        })
        .collect();
    let doorways = doors
        .iter()
        .map(|[da, db]| {
            let (ra, rb) = (&rooms[da.room], &rooms[db.room]);
            let ring = [(0, 0.0), (1, 0.0), (1, 1.0), (0, 1.0)];
            let polygon = ring
                .iter()
                .map(|&(side, w)| {
                    let (ta, tb) = if side == 0 { (da.t.0, db.t.0) } else { (da.t.1, db.t.1) };
                    lerp(da.wall.at(ra, ta, w), db.wall.at(rb, tb, w), 0.5)
                })
                .collect();
            Doorway {
                rooms: [da.room, db.room],
                polygon,
            }
        })
        .collect();
    GroundTruth {
        rooms: rooms_t,
        doorways,
    }
}

/// 4.3.1: the four unaligned rooms with the fewest triangles.
pub fn four_room_optimized() -> ThesisModel {
    let (rooms, doors) = four_room_layout();
    ThesisModel {
        name: "four_room_optimized",
        soup: four_room_minimal(&rooms, &doors),
        truth: four_room_truth(&rooms, &doors),
        description: "Thesis 4.3.1, optimised room model: four unaligned rooms (different plan sizes, \
            rotated about z by 4, -6, 7, -3 degrees, no shared wall planes) joined in a ring by four \
            short corridors, with the fewest triangles. Reading of the thesis's counts (64 shared \
            vertices, 8 per room and per corridor; 96 triangles): doors span the full wall height, so \
            a door wall is two quads beside the door and a corridor is four quads whose eight \
            vertices are the door jambs of its two rooms (lying on the rooms' floor and ceiling \
            edges: T-junctions, closed surface). Ours: 64 vertices, 96 triangles, like the thesis. \
            Ground truth: five samples per room at 1.8 m; doorways are the corridors' mid \
            cross-sections."
            .into(),
    }
}

/// 4.3.3: each room rotated about all three axes, two corners of each displaced.
pub fn four_room_distorted() -> ThesisModel {
    let (rooms, doors) = four_room_layout();
    let rooms = distort(&rooms);
    ThesisModel {
        name: "four_room_distorted",
        soup: four_room_minimal(&rooms, &doors),
        truth: four_room_truth(&rooms, &doors),
        description: "Thesis 4.3.3, distorted room model: the optimised four-room model with each \
            room rotated about its centre around x, y and z by its own angles (2-6 degrees) and two \
            corners per room displaced 0.25 m in random directions (seeded); door jambs stay on the \
            displaced edges, corridors follow the rooms, faces are triangles (96, as in the thesis). \
            The thesis had 106 vertices because its modeller lost some vertex sharing to round-off; \
            ours keep sharing exact (64 vertices), so the surface stays closed."
            .into(),
    }
}

/// Grid parameters along a wall of `len` metres with a door span `door` (or none): cells of
/// about `h` metres, the door exactly one cell.
fn grid_params(len: f64, door: Option<(f64, f64)>, h: f64) -> Vec<f64> {
    let uniform = |a: f64, b: f64, out: &mut Vec<f64>| {
        let n = (((b - a) * len / h).round() as usize).max(1);
        for i in 1..=n {
            out.push(if i == n { b } else { a + (b - a) * i as f64 / n as f64 });
        }
    };
    let mut out = vec![0.0];
    match door {
        Some((t0, t1)) => {
            uniform(0.0, t0, &mut out);
            out.push(t1);
            uniform(t1, 1.0, &mut out);
        }
        None => uniform(0.0, 1.0, &mut out),
    }
    out
}

/// Indices of the triangles of one wall, and its vertex grid, kept for the noisy model.
struct WallGrid {
    triangles: std::ops::Range<usize>,
    /// `grid[i][k]`: vertex index at the wall's `i`-th parameter and `k`-th height.
    grid: Vec<Vec<u32>>,
    toward: P3,
}

const TESS_CELL: f64 = 1.5;
const TESS_LEVELS: [f64; 3] = [0.0, 0.5, 1.0];

/// The tessellated four rooms: every face a grid of cells of about 1.5 m (doors exactly one
/// cell wide, heights in two 1.5 m rows), conforming everywhere, each corridor a tube
/// between its two door rings. Returns the soup and the grid of room A's south wall.
fn four_room_tess(rooms: &[RoomBox], doors: &[[Door; 2]]) -> (Soup, WallGrid) {
    let mut b = Builder::default();
    let mut south_a = None;
    for (ri, r) in rooms.iter().enumerate() {
        let c = r.center();
        let room_doors = doors_of(doors, ri);
        let door_on = |fixed: usize| room_doors.iter().find(|d| d.wall.fixed == 1 - fixed).map(|d| d.t);
        // Parameters along u come from the doors in the v walls and vice versa.
        let us = grid_params(PLANS[ri].size[0], door_on(0), TESS_CELL);
        let vs = grid_params(PLANS[ri].size[1], door_on(1), TESS_CELL);
        let ws = TESS_LEVELS;
        for w in [0.0, 1.0] {
            for i in 0..us.len() - 1 {
                for j in 0..vs.len() - 1 {
                    let q = [
                        r.at(us[i], vs[j], w),
                        r.at(us[i + 1], vs[j], w),
                        r.at(us[i + 1], vs[j + 1], w),
                        r.at(us[i], vs[j + 1], w),
                    ];
                    b.quad_tris(q, c);
                }
            }
        }
        for fixed in 0..2 {
            for end in [0.0, 1.0] {
                let wall = Wall { fixed, end };
                let ts = if fixed == 0 { &vs } else { &us };
                let door = room_doors.iter().find(|d| d.wall == wall).map(|d| d.t);
                let start = b.soup.polygons.len();
                for i in 0..ts.len() - 1 {
                    if door.is_some_and(|(t0, _)| ts[i] == t0) {
                        continue;
                    }
                    for k in 0..ws.len() - 1 {
                        let q = [
                            wall.at(r, ts[i], ws[k]),
                            wall.at(r, ts[i + 1], ws[k]),
                            wall.at(r, ts[i + 1], ws[k + 1]),
                            wall.at(r, ts[i], ws[k + 1]),
                        ];
                        b.quad_tris(q, c);
                    }
                }
                if ri == 0 && fixed == 1 && end == 0.0 {
                    let grid = ts
                        .iter()
                        .map(|&t| ws.iter().map(|&w| b.v(wall.at(r, t, w))).collect())
                        .collect();
                    south_a = Some(WallGrid {
                        triangles: start..b.soup.polygons.len(),
                        grid,
                        toward: c,
                    });
                }
            }
        }
    }
    for [da, db] in doors {
        let (ra, rb) = (&rooms[da.room], &rooms[db.room]);
        // The door ring: floor edge, jamb t1 up, ceiling edge, jamb t0 down.
        let ring = |d: &Door, r: &RoomBox| -> Vec<P3> {
            let mut out = vec![d.wall.at(r, d.t.0, 0.0), d.wall.at(r, d.t.1, 0.0)];
            for &w in &TESS_LEVELS[1..] {
                out.push(d.wall.at(r, d.t.1, w));
            }
            out.push(d.wall.at(r, d.t.0, 1.0));
            for &w in TESS_LEVELS[1..TESS_LEVELS.len() - 1].iter().rev() {
                out.push(d.wall.at(r, d.t.0, w));
            }
            out
        };
        let (qa, qb) = (ring(da, ra), ring(db, rb));
        let c = mean(&[qa.clone(), qb.clone()].concat());
        for i in 0..qa.len() {
            let j = (i + 1) % qa.len();
            b.quad_tris([qa[i], qa[j], qb[j], qb[i]], c);
        }
    }
    (b.soup, south_a.expect("room A has a south wall"))
}

/// 4.3.2: the four rooms with polygons tessellated to roughly equal size.
pub fn four_room_tessellated() -> ThesisModel {
    let (rooms, doors) = four_room_layout();
    ThesisModel {
        name: "four_room_tessellated",
        soup: four_room_tess(&rooms, &doors).0,
        truth: four_room_truth(&rooms, &doors),
        description: "Thesis 4.3.2, tessellated room model: the same four rooms and corridors with \
            every face tessellated into cells of about 1.5 m (two 1.5 m rows in height; doors exactly \
            one cell, so the corridor tubes share the door rings), as triangles: 186 vertices and 372 \
            triangles (the thesis: 200 and 400). The surface is closed and conforming, a torus (the \
            ring of rooms), so V = F/2 exactly, as for the thesis's counts."
            .into(),
    }
}

/// A closed extruded prism (furniture), outward-facing: `profile` counter-clockwise in the
/// plane spanned by `ex` (first coordinate) and `ez` (second), extruded `depth` along `ey`.
fn prism(b: &mut Builder, profile: &[[f64; 2]], origin: P3, ex: P3, ey: P3, ez: P3, depth: f64) {
    let at = |p: [f64; 2], d: f64| add(origin, add(add(scale(ex, p[0]), scale(ez, p[1])), scale(ey, d)));
    let front: Vec<u32> = profile.iter().map(|&p| b.v(at(p, 0.0))).collect();
    let back: Vec<u32> = profile.iter().map(|&p| b.v(at(p, depth))).collect();
    b.poly_dir(front.clone(), scale(ey, -1.0));
    b.poly_dir(back.clone(), ey);
    for i in 0..profile.len() {
        let j = (i + 1) % profile.len();
        let d = [profile[j][0] - profile[i][0], profile[j][1] - profile[i][1]];
        let out = add(scale(ex, d[1]), scale(ez, -d[0]));
        b.poly_dir(vec![front[i], front[j], back[j], back[i]], out);
    }
}

/// 4.3.5: vertex noise on the tessellated model, room A's south wall highly tessellated and
/// perturbed, and a table and a chair in room A.
pub fn noisy() -> ThesisModel {
    let (rooms, doors) = four_room_layout();
    let (soup, wall) = four_room_tess(&rooms, &doors);
    let mut b = Builder {
        soup,
        index: HashMap::new(),
    };
    let mut rng = SplitMix64(0x4350_015E);
    const NOISE: f64 = 0.03;
    for v in &mut b.soup.vertices {
        for k in 0..3 {
            v[k] += NOISE * unit(&mut rng);
        }
    }
    // Replace the south wall of room A by a grid four times finer in each direction, its
    // boundary on the noisy coarse edges, its inside displaced up to 0.12 m across the wall.
    let removed = b.soup.polygons.drain(wall.triangles.clone()).count();
    debug_assert!(removed > 0);
    let verts = b.soup.vertices.clone();
    let g = |i: usize, k: usize| verts[wall.grid[i][k] as usize];
    let normal = rot_z([0.0, 1.0, 0.0], PLANS[0].angle);
    const FINE: usize = 4;
    let (ni, nk) = (wall.grid.len() - 1, wall.grid[0].len() - 1);
    let (fi, fk) = (ni * FINE, nk * FINE);
    let mut fine = vec![vec![0u32; fk + 1]; fi + 1];
    for (x, col) in fine.iter_mut().enumerate() {
        for (y, slot) in col.iter_mut().enumerate() {
            if x % FINE == 0 && y % FINE == 0 {
                // A coarse grid vertex: shared with the neighbouring faces.
                *slot = wall.grid[x / FINE][y / FINE];
                continue;
            }
            let (i, k) = ((x / FINE).min(ni - 1), (y / FINE).min(nk - 1));
            let (s, t) = ((x - i * FINE) as f64 / FINE as f64, (y - k * FINE) as f64 / FINE as f64);
            let mut p = lerp(lerp(g(i, k), g(i + 1, k), s), lerp(g(i, k + 1), g(i + 1, k + 1), s), t);
            // Boundary points stay on the coarse edges (T-junctions); inner ones move.
            if x != 0 && y != 0 && x != fi && y != fk {
                p = add(p, scale(normal, 0.12 * unit(&mut rng)));
            }
            b.soup.vertices.push(p);
            *slot = b.soup.vertices.len() as u32 - 1;
        }
    }
    for x in 0..fi {
        for y in 0..fk {
            let q = [fine[x][y], fine[x + 1][y], fine[x + 1][y + 1], fine[x][y + 1]];
            b.poly_toward(vec![q[0], q[1], q[2]], wall.toward);
            b.poly_toward(vec![q[0], q[2], q[3]], wall.toward);
        }
    }
    // Furniture in room A, standing 5 cm above the nominal floor (clear of the floor noise).
    let ex = rot_z([1.0, 0.0, 0.0], PLANS[0].angle);
    let ey = rot_z([0.0, 1.0, 0.0], PLANS[0].angle);
    let ez = [0.0, 0.0, 1.0];
    let lift = [0.0, 0.0, 0.05];
    let table = [
        [0.0, 0.0],
        [0.08, 0.0],
        [0.08, 0.67],
        [1.12, 0.67],
        [1.12, 0.0],
        [1.2, 0.0],
        [1.2, 0.75],
        [0.0, 0.75],
    ];
    prism(&mut b, &table, add(rooms[0].at(0.35, 0.2, 0.0), lift), ex, ey, ez, 0.8);
    let chair = [
        [0.0, 0.0],
        [0.05, 0.0],
        [0.05, 0.4],
        [0.4, 0.4],
        [0.4, 0.0],
        [0.45, 0.0],
        [0.45, 0.95],
        [0.4, 0.95],
        [0.4, 0.45],
        [0.0, 0.45],
    ];
    // The chair's profile is its side view (depth along ey, back at the far end).
    let chair_origin = add(rooms[0].at(0.62, 0.12, 0.0), lift);
    prism(&mut b, &chair, chair_origin, ey, ex, ez, 0.45);
    ThesisModel {
        name: "noisy",
        soup: b.soup,
        truth: four_room_truth(&rooms, &doors),
        description: "Thesis 4.3.5, other tests: the tessellated four-room model with uniform vertex \
            noise of +-3 cm (seeded, shared vertices move together, so the surface stays closed); \
            room A's south wall re-tessellated four times finer each way, its inside displaced up to \
            12 cm across the wall (its boundary on the noisy coarse edges: T-junctions); a table \
            (1.2 x 0.8 m, 0.75 m high, trestle profile) and a chair (seat 0.45 m, back 0.95 m) in \
            room A, as closed outward-facing prisms standing 5 cm above the floor. No thesis counts."
            .into(),
    }
}

// ---------------------------------------------------------------------------------------
// Caverns.

/// One cave: centre, radii, rotation about z, noise seed.
struct Cave {
    center: P3,
    radii: P3,
    angle: f64,
    bumps: Vec<(P3, f64, f64)>,
}

impl Cave {
    /// The cave wall in the direction of cube point `q` (cube-sphere projection, radii,
    /// smooth bumps of up to about 12 %).
    fn point(&self, q: P3) -> P3 {
        let n = dot(q, q).sqrt();
        let d = scale(q, 1.0 / n);
        let bump: f64 = self.bumps.iter().map(|&(k, a, ph)| a * (dot(k, d) + ph).sin()).sum();
        let local = [d[0] * self.radii[0], d[1] * self.radii[1], d[2] * self.radii[2]];
        add(self.center, scale(rot_z(local, self.angle), 1.0 + bump))
    }
}

const CAVE_N: [usize; 3] = [4, 4, 2];

/// The cube lattice point of a side face's `(a, b)` grid point: face `dir` is 0 = +x,
/// 1 = −x, 2 = +y, 3 = −y; `a` runs along the face's horizontal axis, `b` up.
fn side_lattice(dir: usize, a: usize, b: usize) -> [usize; 3] {
    match dir {
        0 => [CAVE_N[0], a, b],
        1 => [0, a, b],
        2 => [a, CAVE_N[1], b],
        _ => [a, 0, b],
    }
}

fn lattice_q(l: [usize; 3]) -> P3 {
    [0, 1, 2].map(|k| 2.0 * l[k] as f64 / CAVE_N[k] as f64 - 1.0)
}

/// The hole ring of a side face, as `(a, b)` grid points (the boundary of the central
/// 2 × 2 block of cells).
const HOLE_RING: [(usize, usize); 8] = [(1, 0), (2, 0), (3, 0), (3, 1), (3, 2), (2, 2), (1, 2), (1, 1)];

fn caverns_build(name: &'static str, rotated: bool) -> ThesisModel {
    let mut rng = SplitMix64(0x0CA7_E434);
    // Six caves on a 2 × 3 grid, jittered; the 7 edges of the grid are the tunnels.
    let mut caves = Vec::new();
    for row in 0..2 {
        for col in 0..3 {
            let center = [
                col as f64 * 9.0 + 0.6 * unit(&mut rng),
                row as f64 * 8.0 + 0.6 * unit(&mut rng),
                0.5 * unit(&mut rng),
            ];
            let radii = [
                3.0 + 0.4 * unit(&mut rng),
                2.6 + 0.4 * unit(&mut rng),
                1.9 + 0.3 * unit(&mut rng),
            ];
            let angle = 8.0 * unit(&mut rng);
            let bumps = (0..3)
                .map(|_| {
                    let k = [2.0 * unit(&mut rng), 2.0 * unit(&mut rng), 2.0 * unit(&mut rng)];
                    (k, 0.04 + 0.02 * unit(&mut rng), PI * unit(&mut rng))
                })
                .collect();
            caves.push(Cave {
                center,
                radii,
                angle,
                bumps,
            });
        }
    }
    // Tunnels: (cave, face dir, cave, face dir).
    let tunnels = [
        (0, 0, 1, 1),
        (1, 0, 2, 1),
        (3, 0, 4, 1),
        (4, 0, 5, 1),
        (0, 2, 3, 3),
        (1, 2, 4, 3),
        (2, 2, 5, 3),
    ];
    let xf = |p: P3| if rotated { crate::bench::rotate_789(p) } else { p };
    let mut b = Builder::default();
    for (ci, cave) in caves.iter().enumerate() {
        let holes: Vec<usize> = tunnels
            .iter()
            .flat_map(|&(a, da, c, dc)| [(a, da), (c, dc)])
            .filter(|&(c, _)| c == ci)
            .map(|(_, d)| d)
            .collect();
        let center = xf(cave.center);
        // The six faces of the lattice box; cells of side faces' central blocks are holes.
        for axis in 0..3 {
            let (ua, va) = ((axis + 1) % 3, (axis + 2) % 3);
            for end in [0, CAVE_N[axis]] {
                for i in 0..CAVE_N[ua] {
                    for j in 0..CAVE_N[va] {
                        let cell = |di: usize, dj: usize| {
                            let mut l = [0; 3];
                            l[axis] = end;
                            l[ua] = i + di;
                            l[va] = j + dj;
                            l
                        };
                        if axis < 2 {
                            let dir = axis * 2 + usize::from(end == 0);
                            // (a, b) of the cell: a along the other horizontal axis, b = z.
                            let (a, bz) = if axis == 0 { (i, j) } else { (j, i) };
                            if holes.contains(&dir) && (1..3).contains(&a) && bz < 2 {
                                continue;
                            }
                        }
                        let q = [cell(0, 0), cell(1, 0), cell(1, 1), cell(0, 1)].map(|l| xf(cave.point(lattice_q(l))));
                        b.quad_tris_delaunay(q, center);
                    }
                }
            }
        }
    }
    let mut doorways = Vec::new();
    for &(ca, da, cb, db) in &tunnels {
        let ring = |c: usize, d: usize| -> Vec<P3> {
            HOLE_RING
                .iter()
                .map(|&(a, h)| caves[c].point(lattice_q(side_lattice(d, a, h))))
                .collect()
        };
        let (ra, rb) = (ring(ca, da), ring(cb, db));
        let axis_a = mean(&ra);
        let axis_b = mean(&rb);
        let mid_axis = lerp(axis_a, axis_b, 0.5);
        // The middle ring: half-way, narrowed by 15 % towards the axis.
        let mid: Vec<P3> = ra
            .iter()
            .zip(&rb)
            .map(|(&p, &q)| lerp(mid_axis, lerp(p, q, 0.5), 0.85))
            .collect();
        for (r0, r1, t) in [(&ra, &mid, 0.25), (&mid, &rb, 0.75)] {
            let toward = xf(lerp(axis_a, axis_b, t));
            for i in 0..8 {
                let j = (i + 1) % 8;
                b.quad_tris_delaunay([r0[i], r0[j], r1[j], r1[i]].map(xf), toward);
            }
        }
        doorways.push(Doorway {
            rooms: [ca, cb],
            polygon: mid.iter().map(|&p| xf(p)).collect(),
        });
    }
    let rooms = caves
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let mut samples = vec![xf(c.center)];
            for d in [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]] {
                let local = [0.35 * d[0] * c.radii[0], 0.35 * d[1] * c.radii[1], 0.0];
                samples.push(xf(add(c.center, rot_z(local, c.angle))));
            }
            Room {
                name: format!("cave {i}"),
                samples,
            }
        })
        .collect();
    let description = format!(
        "Thesis 4.3.4, caverns{}: six cave rooms (deformed ellipsoids, radii about 3 x 2.6 x 1.9 m, \
         cube-sphere tessellation 4 x 4 x 2 per cave, smooth seeded bumps, walls facing in) on a \
         jittered 2 x 3 grid, joined by the grid's 7 edges as tunnels: each tunnel's mouths are \
         holes of half the cave's side (the central 2 x 2 cells), lofted through a middle ring \
         narrowed by 15 %, so rooms and tunnels blend without articulated door frames. Quads are \
         split along the diagonal the Delaunay criterion picks, so that, as in the thesis, almost \
         no triangle needs a split (3 of 880; an arbitrary diagonal gave 961 splits). Closed, \
         conforming surface. Ground truth: five samples per cave; doorways are the tunnels' middle \
         rings (non-planar 8-gons). The thesis: 408 vertices, 548 triangles (its surface was \
         not closed conforming: V - F/2 = 134); exactly 7 portals separate the 6 rooms.",
        if rotated {
            ", rotated 7, 8 and 9 degrees about x, y and z (bench::rotate_789)"
        } else {
            ""
        }
    );
    ThesisModel {
        name,
        soup: b.soup,
        truth: GroundTruth { rooms, doorways },
        description,
    }
}

/// 4.3.4: six cave rooms joined by seven tunnels without articulated transitions.
pub fn caverns() -> ThesisModel {
    caverns_build("caverns", false)
}

/// 4.3.4: the caverns rotated 7°, 8° and 9° about x, y and z.
pub fn caverns_rotated() -> ThesisModel {
    caverns_build("caverns_rotated", true)
}
