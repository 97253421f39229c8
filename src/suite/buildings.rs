//! Procedural buildings: floor plans by recursive splitting, thick walls, doors of several
//! widths, windows between rooms, pillars, furniture, storeys with a stairwell; meshed as the
//! boundary of a union of boxes on the grid of their coordinates (see the module docs of
//! [`crate::suite`]).

use super::util::{Aabb, Rng, Similarity};
use super::{Doorway, Family, Membership, SuiteTruth, TruthRoom};
use crate::generate::scenes::Soup;
use crate::predicates::P3;
use std::collections::HashMap;

/// Rounds to millimetres, so box coordinates that should coincide are bit-identical.
fn mm(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}
/// Rounds to decimetres (plan coordinates).
fn dm(v: f64) -> f64 {
    (v * 10.0).round() / 10.0
}
fn bx(lo: P3, hi: P3) -> Aabb {
    Aabb::new(lo.map(mm), hi.map(mm))
}

/// Rotated and multi-storey buildings: the fine-grid variant for `seed / 2` even, else greedy.
pub(crate) fn fine_variant(seed: u64) -> bool {
    (seed / 2).is_multiple_of(2)
}

/// How the boundary is cut into faces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Faces {
    /// Every face a cell of the box-coordinate grid refined to intervals ≤ `h`
    /// (conforming, no T-junctions).
    Grid(f64),
    /// Coplanar faces of the same orientation greedy-merged into maximal rectangles
    /// (T-junctions where they meet).
    Greedy,
}

/// A rectangle of the plan: split-line coordinates and the wall half-thickness inset on
/// each side (−x, +x, −y, +y).
#[derive(Clone, Copy, Debug)]
struct Leaf {
    x: (f64, f64),
    y: (f64, f64),
    inset: [f64; 4],
    corridor: bool,
}

impl Leaf {
    /// The free rectangle (x0, x1, y0, y1).
    fn free(&self) -> [f64; 4] {
        [
            mm(self.x.0 + self.inset[0]),
            mm(self.x.1 - self.inset[1]),
            mm(self.y.0 + self.inset[2]),
            mm(self.y.1 - self.inset[3]),
        ]
    }
    fn area(&self) -> f64 {
        (self.x.1 - self.x.0) * (self.y.1 - self.y.0)
    }
}

const THICKNESS: [f64; 4] = [0.2, 0.3, 0.4, 0.5];
const MIN_ROOM: f64 = 2.4;

/// A floor plan of about `target` rooms in a `w × d` rectangle; with a corridor strip
/// across it for `corridor`.
fn plan(rng: &mut Rng, w: f64, d: f64, target: usize, corridor: bool) -> Vec<Leaf> {
    let mut leaves = vec![Leaf {
        x: (0.0, w),
        y: (0.0, d),
        inset: [0.0; 4],
        corridor: false,
    }];
    if corridor {
        let cw = dm(rng.range(1.8, 2.6));
        let yc = dm(rng.range(0.3 * d, 0.7 * d - cw));
        let (t1, t2) = (rng.pick(&THICKNESS) / 2.0, rng.pick(&THICKNESS) / 2.0);
        leaves = vec![
            Leaf {
                x: (0.0, w),
                y: (0.0, yc),
                inset: [0.0, 0.0, 0.0, t1],
                corridor: false,
            },
            Leaf {
                x: (0.0, w),
                y: (yc, yc + cw),
                inset: [0.0, 0.0, t1, t2],
                corridor: true,
            },
            Leaf {
                x: (0.0, w),
                y: (yc + cw, d),
                inset: [0.0, 0.0, t2, 0.0],
                corridor: false,
            },
        ];
    }
    while leaves.len() < target {
        let splittable = |l: &Leaf| !l.corridor && (l.x.1 - l.x.0).max(l.y.1 - l.y.0) >= 2.0 * MIN_ROOM + 0.6;
        let Some(i) = (0..leaves.len())
            .filter(|&i| splittable(&leaves[i]))
            .max_by(|&a, &b| leaves[a].area().total_cmp(&leaves[b].area()))
        else {
            break;
        };
        let l = leaves[i];
        let along_x = l.x.1 - l.x.0 >= l.y.1 - l.y.0;
        let (a, b) = if along_x { l.x } else { l.y };
        let lo = a + MIN_ROOM + 0.3;
        let hi = b - MIN_ROOM - 0.3;
        let s = dm(rng.range(lo.max(a + 0.35 * (b - a)).min(hi), hi.min(a + 0.65 * (b - a)).max(lo)));
        let t = rng.pick(&THICKNESS) / 2.0;
        let (mut p, mut q) = (l, l);
        if along_x {
            p.x.1 = s;
            p.inset[1] = t;
            q.x.0 = s;
            q.inset[0] = t;
        } else {
            p.y.1 = s;
            p.inset[3] = t;
            q.y.0 = s;
            q.inset[2] = t;
        }
        leaves[i] = p;
        leaves.push(q);
    }
    leaves
}

/// Two leaves sharing a wall: `axis` is the wall's normal (0: x, 1: y), `wall` the wall's
/// extent along it, `span` the shared free extent along the wall.
#[derive(Clone, Copy, Debug)]
struct Adjacency {
    a: usize,
    b: usize,
    axis: usize,
    wall: (f64, f64),
    span: (f64, f64),
}

fn adjacencies(leaves: &[Leaf]) -> Vec<Adjacency> {
    let mut out = Vec::new();
    for a in 0..leaves.len() {
        for b in 0..leaves.len() {
            let (la, lb) = (&leaves[a], &leaves[b]);
            let (fa, fb) = (la.free(), lb.free());
            // b to the +x of a.
            if (la.x.1 - lb.x.0).abs() < 1e-9 {
                let span = (fa[2].max(fb[2]), fa[3].min(fb[3]));
                if span.1 - span.0 >= 1.4 {
                    out.push(Adjacency {
                        a,
                        b,
                        axis: 0,
                        wall: (fa[1], fb[0]),
                        span,
                    });
                }
            }
            if (la.y.1 - lb.y.0).abs() < 1e-9 {
                let span = (fa[0].max(fb[0]), fa[1].min(fb[1]));
                if span.1 - span.0 >= 1.4 {
                    out.push(Adjacency {
                        a,
                        b,
                        axis: 1,
                        wall: (fa[3], fb[2]),
                        span,
                    });
                }
            }
        }
    }
    out
}

/// An opening through the wall of `adj` on the storey whose floor is at `z0`: its free box
/// and the doorway rectangle in the middle of the wall.
fn opening(rng: &mut Rng, adj: &Adjacency, window: bool, z0: f64) -> (Aabb, Vec<P3>) {
    let (s0, s1) = adj.span;
    let avail = s1 - s0 - 0.4;
    let w = if window {
        rng.pick(&[0.8, 1.0, 1.2, 1.5])
    } else if rng.chance(0.25) {
        // A wide opening: up to 70 % of the shared wall.
        dm(rng.range(0.45, 0.7) * (s1 - s0))
    } else {
        rng.pick(&[0.8, 0.9, 1.0, 1.2, 1.4])
    };
    let w = w.min(dm(avail - 0.05));
    let c0 = mm(dm(rng.range(s0 + 0.2, (s1 - 0.2 - w).max(s0 + 0.2))).max(s0 + 0.1));
    let c1 = mm(c0 + w);
    let (z_lo, z_hi) = if window { (z0 + 1.0, z0 + 2.0) } else { (z0, z0 + 2.1) };
    let mid = 0.5 * (adj.wall.0 + adj.wall.1);
    let (b, poly) = if adj.axis == 0 {
        (
            bx([adj.wall.0, c0, z_lo], [adj.wall.1, c1, z_hi]),
            vec![[mid, c0, z_lo], [mid, c1, z_lo], [mid, c1, z_hi], [mid, c0, z_hi]],
        )
    } else {
        (
            bx([c0, adj.wall.0, z_lo], [c1, adj.wall.1, z_hi]),
            vec![[c0, mid, z_lo], [c1, mid, z_lo], [c1, mid, z_hi], [c0, mid, z_hi]],
        )
    };
    (b, poly)
}

fn find(parent: &mut [usize], mut x: usize) -> usize {
    while parent[x] != x {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    x
}

/// The set of boxes and the truth in the generator's frame.
struct Layout {
    free: Vec<Aabb>,
    solid: Vec<Aabb>,
    rooms: Vec<(String, Vec<Aabb>, Vec<P3>)>,
    doorways: Vec<Doorway>,
}

/// Generates the layout of a building of `storeys` storeys (1: no stairwell).
fn layout(rng: &mut Rng, storeys: usize) -> Layout {
    let (w, d, target) = if storeys == 1 {
        (dm(rng.range(10.0, 20.0)), dm(rng.range(8.0, 15.0)), 4 + rng.below(7))
    } else {
        (dm(rng.range(9.0, 14.0)), dm(rng.range(7.0, 11.0)), 3 + rng.below(4))
    };
    let corridor = rng.chance(0.6);
    let leaves = plan(rng, w, d, target, corridor);
    let adj = adjacencies(&leaves);
    let h = dm(rng.range(2.6, 3.4));
    let slab = 0.3;
    let z_of = |k: usize| mm(k as f64 * (h + slab));
    // The stairwell: the smallest non-corridor leaf, through all storeys.
    let stair = (storeys > 1).then(|| {
        (0..leaves.len())
            .filter(|&i| !leaves[i].corridor)
            .min_by(|&a, &b| leaves[a].area().total_cmp(&leaves[b].area()))
            .expect("a plan has a room")
    });
    let mut out = Layout {
        free: Vec::new(),
        solid: Vec::new(),
        rooms: Vec::new(),
        doorways: Vec::new(),
    };
    // Room index of (leaf, storey).
    let mut room_of = vec![vec![usize::MAX; storeys]; leaves.len()];
    for k in 0..storeys {
        for (i, l) in leaves.iter().enumerate() {
            if Some(i) == stair && k > 0 {
                room_of[i][k] = room_of[i][0];
                continue;
            }
            let f = l.free();
            let top = if Some(i) == stair {
                z_of(storeys - 1) + h
            } else {
                z_of(k) + h
            };
            let b = bx([f[0], f[2], z_of(k)], [f[1], f[3], top]);
            let kind = if Some(i) == stair {
                "stairwell"
            } else if l.corridor {
                "corridor"
            } else {
                "room"
            };
            let name = if Some(i) == stair {
                format!("{kind} {i}")
            } else {
                format!("{kind} {i} storey {k}")
            };
            room_of[i][k] = out.rooms.len();
            out.free.push(b);
            out.rooms.push((name, vec![b], Vec::new()));
        }
    }
    // A hole in the slab between two stacked rooms (multi-storey, half the time).
    let mut holed = Vec::new();
    if storeys > 1 && rng.chance(0.5) {
        let cand: Vec<usize> = (0..leaves.len())
            .filter(|&i| {
                let f = leaves[i].free();
                Some(i) != stair && !leaves[i].corridor && (f[1] - f[0]).min(f[3] - f[2]) >= 3.5
            })
            .collect();
        if !cand.is_empty() {
            let i = rng.pick(&cand);
            let f = leaves[i].free();
            let s = 1.2;
            let x = mm(dm(rng.range(f[0] + 0.8, f[1] - 0.8 - s)));
            let y = mm(dm(rng.range(f[2] + 0.8, f[3] - 0.8 - s)));
            let (za, zb) = (mm(z_of(0) + h), z_of(1));
            out.free.push(bx([x, y, za], [x + s, y + s, zb]));
            let zm = 0.5 * (za + zb);
            out.doorways.push(Doorway {
                rooms: [room_of[i][0], room_of[i][1]],
                polygon: vec![[x, y, zm], [x + s, y, zm], [x + s, y + s, zm], [x, y + s, zm]],
            });
            holed.push(i);
        }
    }
    // Doors and windows, storey by storey: a random spanning tree gets doors, a few other
    // adjacencies a door or a window.
    for k in 0..storeys {
        let mut order: Vec<usize> = (0..adj.len()).collect();
        for i in (1..order.len()).rev() {
            let j = rng.below(i + 1);
            order.swap(i, j);
        }
        let mut parent: Vec<usize> = (0..leaves.len()).collect();
        let mut extra = 0;
        for &e in &order {
            let a = &adj[e];
            let (ra, rb) = (find(&mut parent, a.a), find(&mut parent, a.b));
            let kind = if ra != rb {
                parent[ra] = rb;
                Some(false)
            } else if extra < 3 && rng.chance(0.3) {
                extra += 1;
                Some(rng.chance(0.5))
            } else {
                None
            };
            if let Some(window) = kind {
                let (b, polygon) = opening(rng, a, window, z_of(k));
                out.free.push(b);
                out.doorways.push(Doorway {
                    rooms: [room_of[a.a][k], room_of[a.b][k]],
                    polygon,
                });
            }
        }
        // Pillars and furniture.
        for (i, l) in leaves.iter().enumerate() {
            if l.corridor || Some(i) == stair || holed.contains(&i) {
                continue;
            }
            let f = l.free();
            let (sx, sy) = (f[1] - f[0], f[3] - f[2]);
            let z0 = z_of(k);
            let mut here: Vec<Aabb> = Vec::new();
            if sx.min(sy) >= 4.5 && rng.chance(0.5) {
                let p = dm(rng.range(0.3, 0.5));
                let x = dm(rng.range(f[0] + 1.0, f[1] - 1.0 - p));
                let y = dm(rng.range(f[2] + 1.0, f[3] - 1.0 - p));
                here.push(bx([x, y, z0], [x + p, y + p, z0 + h]));
            }
            if sx.min(sy) >= 3.0 && rng.chance(0.6) {
                for _ in 0..5 {
                    let (a, b) = (dm(rng.range(0.6, 1.6)), dm(rng.range(0.5, 1.0)));
                    let (a, b) = if rng.chance(0.5) { (a, b) } else { (b, a) };
                    let ht = rng.pick(&[0.5, 0.75, 0.9]);
                    let x = dm(rng.range(f[0] + 0.6, f[1] - 0.6 - a));
                    let y = dm(rng.range(f[2] + 0.6, f[3] - 0.6 - b));
                    let fb = bx([x, y, z0], [x + a, y + b, z0 + ht]);
                    let clash = here.iter().any(|p| {
                        let g = p.grown(0.3);
                        (0..2).all(|q| fb.lo[q] < g.hi[q] && fb.hi[q] > g.lo[q])
                    });
                    if !clash {
                        here.push(fb);
                        break;
                    }
                }
            }
            out.solid.extend(here);
        }
    }
    // Samples: five points at 60 % of the height of each storey the room spans, clear of
    // solids.
    for (ri, (_, boxes, samples)) in out.rooms.iter_mut().enumerate() {
        let b = boxes[0];
        let levels: Vec<f64> = (0..storeys)
            .map(|k| z_of(k) + 0.6 * h)
            .filter(|&z| z > b.lo[2] && z < b.hi[2])
            .collect();
        for &z in &levels {
            for (u, v) in [(0.5, 0.5), (0.25, 0.25), (0.75, 0.25), (0.75, 0.75), (0.25, 0.75)] {
                let p = [b.lo[0] + u * (b.hi[0] - b.lo[0]), b.lo[1] + v * (b.hi[1] - b.lo[1]), z];
                if !out.solid.iter().any(|s| s.grown(0.15).contains(p)) {
                    samples.push(p);
                }
            }
        }
        debug_assert!(samples.len() >= 3, "room {ri}");
    }
    out
}

/// An indexed mesh of quads on grid points.
struct GridMesh {
    vertices: Vec<P3>,
    quads: Vec<[u32; 4]>,
}

/// The boundary of `free` minus `solid` (boxes on one coordinate grid), faces facing free
/// space.
fn mesh(free: &[Aabb], solid: &[Aabb], faces: Faces) -> GridMesh {
    let mut coords: [Vec<f64>; 3] = Default::default();
    for b in free.iter().chain(solid) {
        for k in 0..3 {
            coords[k].push(b.lo[k]);
            coords[k].push(b.hi[k]);
        }
    }
    for c in &mut coords {
        c.sort_by(f64::total_cmp);
        c.dedup();
    }
    if let Faces::Grid(h) = faces {
        for c in &mut coords {
            let mut r = vec![c[0]];
            for w in c.windows(2) {
                let n = (((w[1] - w[0]) / h) - 1e-9).ceil().max(1.0) as usize;
                for i in 1..n {
                    r.push(w[0] + (w[1] - w[0]) * i as f64 / n as f64);
                }
                r.push(w[1]);
            }
            *c = r;
        }
    }
    let n = [coords[0].len() - 1, coords[1].len() - 1, coords[2].len() - 1];
    let idx = |k: usize, v: f64| {
        coords[k]
            .binary_search_by(|x| x.total_cmp(&v))
            .expect("a grid coordinate")
    };
    let mut occ = vec![false; n[0] * n[1] * n[2]];
    let at = |i: usize, j: usize, k: usize| (k * n[1] + j) * n[0] + i;
    for (list, value) in [(free, true), (solid, false)] {
        for b in list {
            let lo = [0, 1, 2].map(|k| idx(k, b.lo[k]));
            let hi = [0, 1, 2].map(|k| idx(k, b.hi[k]));
            for k in lo[2]..hi[2] {
                for j in lo[1]..hi[1] {
                    for i in lo[0]..hi[0] {
                        occ[at(i, j, k)] = value;
                    }
                }
            }
        }
    }
    let free_at = |c: [isize; 3]| {
        (0..3).all(|k| c[k] >= 0 && (c[k] as usize) < n[k]) && occ[at(c[0] as usize, c[1] as usize, c[2] as usize)]
    };
    let mut vid: HashMap<[usize; 3], u32> = HashMap::new();
    let mut m = GridMesh {
        vertices: Vec::new(),
        quads: Vec::new(),
    };
    let mut vertex = |g: [usize; 3], m: &mut GridMesh| -> u32 {
        *vid.entry(g).or_insert_with(|| {
            m.vertices.push([coords[0][g[0]], coords[1][g[1]], coords[2][g[2]]]);
            m.vertices.len() as u32 - 1
        })
    };
    for a in 0..3 {
        let (ua, va) = ((a + 1) % 3, (a + 2) % 3);
        let (nu, nv) = (n[ua], n[va]);
        for p in 0..=n[a] {
            // mask[v * nu + u]: 0 none, 1 facing +a, 2 facing -a.
            let mut mask = vec![0u8; nu * nv];
            for v in 0..nv {
                for u in 0..nu {
                    let mut c = [0isize; 3];
                    c[ua] = u as isize;
                    c[va] = v as isize;
                    c[a] = p as isize;
                    let above = free_at(c);
                    c[a] -= 1;
                    let below = free_at(c);
                    mask[v * nu + u] = match (below, above) {
                        (false, true) => 1,
                        (true, false) => 2,
                        _ => 0,
                    };
                }
            }
            let mut emit = |u0: usize, u1: usize, v0: usize, v1: usize, o: u8, m: &mut GridMesh| {
                let g = |u: usize, v: usize| {
                    let mut g = [0usize; 3];
                    g[a] = p;
                    g[ua] = u;
                    g[va] = v;
                    g
                };
                let mut q = [g(u0, v0), g(u1, v0), g(u1, v1), g(u0, v1)].map(|g| vertex(g, m));
                if o == 2 {
                    q.reverse();
                }
                m.quads.push(q);
            };
            match faces {
                Faces::Grid(_) => {
                    for v in 0..nv {
                        for u in 0..nu {
                            let o = mask[v * nu + u];
                            if o != 0 {
                                emit(u, u + 1, v, v + 1, o, &mut m);
                            }
                        }
                    }
                }
                Faces::Greedy => {
                    for v in 0..nv {
                        let mut u = 0;
                        while u < nu {
                            let o = mask[v * nu + u];
                            if o == 0 {
                                u += 1;
                                continue;
                            }
                            let mut u1 = u + 1;
                            while u1 < nu && mask[v * nu + u1] == o {
                                u1 += 1;
                            }
                            let mut v1 = v + 1;
                            while v1 < nv && (u..u1).all(|x| mask[v1 * nu + x] == o) {
                                v1 += 1;
                            }
                            for y in v..v1 {
                                for x in u..u1 {
                                    mask[y * nu + x] = 0;
                                }
                            }
                            emit(u, u1, v, v1, o, &mut m);
                            u = u1;
                        }
                    }
                }
            }
        }
    }
    m
}

/// Fine grid: intervals of at most 1 m ("unit-ish quads").
pub const FINE: f64 = 1.0;
/// Coarse grid: intervals of at most 2.5 m.
pub const COARSE: f64 = 2.5;

/// The building of `family` (a building family) with this seed: the variant's name, the
/// soup and the truth.
pub fn building(family: Family, seed: u64) -> (String, Soup, SuiteTruth) {
    let fam = Family::ALL.iter().position(|&f| f == family).expect("a family") as u64;
    let mut rng = Rng::new(0xB01D_0000_0000 ^ (fam << 32) ^ seed.wrapping_mul(0x9E37_79B9));
    let storeys = if family == Family::MultiStorey {
        2 + rng.below(2)
    } else {
        1
    };
    let lay = layout(&mut rng, storeys);
    let fine = fine_variant(seed);
    let (faces, triangles, noise, frame, variant) = match family {
        Family::Tessellated => {
            let h = if seed % 4 < 2 { FINE } else { COARSE };
            let v = if seed % 4 < 2 { "fine" } else { "coarse" };
            (Faces::Grid(h), false, 0.0, Similarity::IDENTITY, v.to_string())
        }
        Family::Greedy => (Faces::Greedy, false, 0.0, Similarity::IDENTITY, "greedy".into()),
        Family::Rotated => {
            let s = rng.range(0.5, 3.0);
            let off = [0, 1, 2].map(|_| rng.range(-1000.0, 1000.0));
            let frame = Similarity::random(&mut rng, s, off);
            let faces = if fine { Faces::Grid(FINE) } else { Faces::Greedy };
            let v = if fine { "fine" } else { "greedy" };
            (faces, false, 0.0, frame, v.to_string())
        }
        Family::Noisy => {
            let rel = if seed % 4 < 2 { 1e-3 } else { 3e-3 };
            (
                Faces::Grid(FINE),
                true,
                rel,
                Similarity::IDENTITY,
                format!("noise{rel:e}"),
            )
        }
        Family::MultiStorey => {
            let faces = if fine { Faces::Grid(FINE) } else { Faces::Greedy };
            let v = if fine { "fine" } else { "greedy" };
            (faces, false, 0.0, Similarity::IDENTITY, format!("{storeys}storeys-{v}"))
        }
        Family::Caverns | Family::Thesis => unreachable!("not a building family"),
    };
    let m = mesh(&lay.free, &lay.solid, faces);
    let mut vertices = m.vertices;
    if noise > 0.0 {
        let size: f64 = lay
            .rooms
            .iter()
            .map(|r| {
                let b = r.1[0];
                ((b.hi[0] - b.lo[0]) * (b.hi[1] - b.lo[1])).sqrt()
            })
            .sum::<f64>()
            / lay.rooms.len() as f64;
        let a = noise * size;
        for v in &mut vertices {
            for k in 0..3 {
                v[k] += rng.range(-a, a);
            }
        }
    }
    if !frame.is_identity() {
        for v in &mut vertices {
            *v = frame.apply(*v);
        }
    }
    let polygons: Vec<Vec<u32>> = if triangles {
        m.quads
            .iter()
            .flat_map(|q| [vec![q[0], q[1], q[2]], vec![q[0], q[2], q[3]]])
            .collect()
    } else {
        m.quads.iter().map(|q| q.to_vec()).collect()
    };
    let xf = |p: P3| frame.apply(p);
    let truth = SuiteTruth {
        rooms: lay
            .rooms
            .iter()
            .map(|(name, _, s)| TruthRoom {
                name: name.clone(),
                samples: s.iter().map(|&p| xf(p)).collect(),
            })
            .collect(),
        doorways: lay
            .doorways
            .iter()
            .map(|d| Doorway {
                rooms: d.rooms,
                polygon: d.polygon.iter().map(|&p| xf(p)).collect(),
            })
            .collect(),
        membership: Membership::Boxes {
            frame,
            rooms: lay.rooms.iter().map(|r| r.1.clone()).collect(),
            solids: lay.solid.clone(),
        },
    };
    (variant, Soup { vertices, polygons }, truth)
}
