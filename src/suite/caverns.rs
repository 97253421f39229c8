//! Caverns: 4–9 ellipsoid blobs joined by capsule tunnels of varied radius (a tree), smooth
//! union of their signed distances, meshed by marching tetrahedra on a regular grid (each
//! cube split into the six tetrahedra around its main diagonal, so neighbouring cubes agree
//! and the surface is closed and conforming). Fronts face the free space (field < 0).
//!
//! Truth: one room per blob (samples: centre and points at 45 % of the horizontal radii and
//! 30 % of the vertical one), membership by the blobs' ellipsoids (tunnels belong to no
//! room), doorways the tunnels' middle cross-sections (octagons).

use super::util::{Rng, add, cross, dist, dot, norm, scale, sub};
use super::{Doorway, Ellipsoid, Membership, SuiteTruth, TruthRoom};
use crate::generate::scenes::Soup;
use crate::predicates::P3;
use std::collections::HashMap;

/// Finest grid spacing of the mesher (metres).
pub const SPACING: f64 = 0.4;
/// Coarsest grid spacing: the spacing grows from [`SPACING`] up to this while the mesh has
/// more than [`TARGET_TRIANGLES`] triangles.
pub const MAX_SPACING: f64 = 0.75;
/// Triangle budget of a cavern.
pub const TARGET_TRIANGLES: usize = 4500;
/// Smooth-union radius.
const BLEND: f64 = 0.5;

#[derive(Clone, Copy, Debug)]
struct Tunnel {
    a: usize,
    b: usize,
    p: P3,
    q: P3,
    r: f64,
}

/// Approximate signed distance of an ellipsoid (negative inside).
fn ellipsoid_sd(e: &Ellipsoid, p: P3) -> f64 {
    let d = sub(p, e.center);
    let q = [0, 1, 2].map(|k| dot(e.axes[k], d));
    let k0 = norm([0, 1, 2].map(|k| q[k] / e.radii[k]));
    let k1 = norm([0, 1, 2].map(|k| q[k] / (e.radii[k] * e.radii[k])));
    if k1 == 0.0 {
        return -e.radii.iter().cloned().fold(f64::INFINITY, f64::min);
    }
    k0 * (k0 - 1.0) / k1
}

fn segment_point(p: P3, a: P3, b: P3) -> (f64, P3) {
    let ab = sub(b, a);
    let t = (dot(sub(p, a), ab) / dot(ab, ab)).clamp(0.0, 1.0);
    (t, add(a, scale(ab, t)))
}

fn smin(a: f64, b: f64, k: f64) -> f64 {
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - h * h * k * 0.25
}

fn field(blobs: &[Ellipsoid], tunnels: &[Tunnel], p: P3) -> f64 {
    let mut f = f64::INFINITY;
    for e in blobs {
        f = smin(f, ellipsoid_sd(e, p), BLEND);
    }
    for t in tunnels {
        let (_, c) = segment_point(p, t.p, t.q);
        f = smin(f, dist(p, c) - t.r, BLEND);
    }
    if f == 0.0 { 1e-12 } else { f }
}

/// Distance between segments `ab` and `cd` (sampled; enough for a rejection test).
fn segment_distance(a: P3, b: P3, c: P3, d: P3) -> f64 {
    (0..=32)
        .map(|i| {
            let p = add(a, scale(sub(b, a), i as f64 / 32.0));
            dist(p, segment_point(p, c, d).1)
        })
        .fold(f64::INFINITY, f64::min)
}

fn support(e: &Ellipsoid, d: P3) -> f64 {
    (0..3)
        .map(|k| (e.radii[k] * dot(e.axes[k], d)).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// A cavern layout: blobs and tunnels.
fn layout(rng: &mut Rng) -> (Vec<Ellipsoid>, Vec<Tunnel>) {
    let n = 4 + rng.below(6);
    let mut blobs: Vec<Ellipsoid> = Vec::new();
    let mut tunnels: Vec<Tunnel> = Vec::new();
    let new_blob = |rng: &mut Rng, center: P3| {
        let th = rng.range(0.0, std::f64::consts::PI);
        let (s, c) = th.sin_cos();
        Ellipsoid {
            center,
            axes: [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]],
            radii: [rng.range(1.6, 2.6), rng.range(1.5, 2.4), rng.range(1.25, 1.7)],
        }
    };
    let first = new_blob(rng, [0.0; 3]);
    blobs.push(first);
    let mut attempts = 0;
    while blobs.len() < n && attempts < 400 {
        attempts += 1;
        let j = rng.below(blobs.len());
        let th = rng.range(0.0, 2.0 * std::f64::consts::PI);
        let el: f64 = rng.range(-0.3, 0.3);
        let d = [th.cos() * el.cos(), th.sin() * el.cos(), el.sin()];
        let mut e = new_blob(rng, [0.0; 3]);
        let len = rng.range(1.5, 4.0);
        e.center = add(blobs[j].center, scale(d, support(&blobs[j], d) + support(&e, d) + len));
        // Disjoint from every blob, with a margin (sampled on the new blob's surface).
        let disjoint = (0..400).all(|s| {
            let (u, v) = ((s % 20) as f64 / 20.0, (s / 20) as f64 / 19.0);
            let (ph, z) = (2.0 * std::f64::consts::PI * u, 2.0 * v - 1.0);
            let r = (1.0 - z * z).sqrt();
            let local = [r * ph.cos() * e.radii[0], r * ph.sin() * e.radii[1], z * e.radii[2]];
            let p = add(
                e.center,
                add(
                    add(scale(e.axes[0], local[0]), scale(e.axes[1], local[1])),
                    scale(e.axes[2], local[2]),
                ),
            );
            blobs.iter().all(|b| b.level(p) > 1.6)
        });
        if !disjoint {
            continue;
        }
        let rmax = 0.65 * e.radii[2].min(blobs[j].radii[2]);
        let r = rng.range(0.75, 1.1).min(rmax);
        let t = Tunnel {
            a: j,
            b: blobs.len(),
            p: blobs[j].center,
            q: e.center,
            r,
        };
        // The tunnel passes no other blob and keeps clear of other tunnels.
        let clear_blobs = (0..=40).all(|i| {
            let p = add(t.p, scale(sub(t.q, t.p), i as f64 / 40.0));
            blobs.iter().enumerate().all(|(k, b)| k == j || b.level(p) > 2.0)
        });
        let clear_tunnels = tunnels.iter().all(|o| {
            let shared = o.a == j || o.b == j;
            let (p0, q0) = if shared {
                // Compare the parts away from the shared blob.
                let h = |a: P3, b: P3| add(a, scale(sub(b, a), 0.5));
                (h(t.p, t.q), h(o.p, o.q))
            } else {
                (t.p, o.p)
            };
            segment_distance(p0, t.q, q0, o.q) > t.r + o.r + 1.0
        });
        if !clear_blobs || !clear_tunnels {
            continue;
        }
        blobs.push(e);
        tunnels.push(t);
    }
    (blobs, tunnels)
}

/// Marching tetrahedra of `f < 0` over the grid `origin + h (i, j, k)`, `i < n[0]`, ...
fn march(f: &dyn Fn(P3) -> f64, origin: P3, h: f64, n: [usize; 3]) -> (Vec<P3>, Vec<[u32; 3]>) {
    let gid = |i: usize, j: usize, k: usize| (k * n[1] + j) * n[0] + i;
    let pos = |i: usize, j: usize, k: usize| {
        [
            origin[0] + h * i as f64,
            origin[1] + h * j as f64,
            origin[2] + h * k as f64,
        ]
    };
    let mut val = vec![0.0; n[0] * n[1] * n[2]];
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                val[gid(i, j, k)] = f(pos(i, j, k));
            }
        }
    }
    let mut verts: Vec<P3> = Vec::new();
    let mut tris: Vec<[u32; 3]> = Vec::new();
    let mut edge_vert: HashMap<(usize, usize), u32> = HashMap::new();
    let perms = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
    for k in 0..n[2] - 1 {
        for j in 0..n[1] - 1 {
            for i in 0..n[0] - 1 {
                // Skip cubes with no sign change.
                let corners = [0, 1, 2, 3, 4, 5, 6, 7].map(|c| gid(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2)));
                let neg = corners.iter().filter(|&&g| val[g] < 0.0).count();
                if neg == 0 || neg == 8 {
                    continue;
                }
                for perm in perms {
                    let mut g = [i, j, k];
                    let mut tet = [(gid(g[0], g[1], g[2]), pos(g[0], g[1], g[2])); 4];
                    for (s, &ax) in perm.iter().enumerate() {
                        g[ax] += 1;
                        tet[s + 1] = (gid(g[0], g[1], g[2]), pos(g[0], g[1], g[2]));
                    }
                    let inside: Vec<usize> = (0..4).filter(|&s| val[tet[s].0] < 0.0).collect();
                    let outside: Vec<usize> = (0..4).filter(|&s| val[tet[s].0] >= 0.0).collect();
                    if inside.is_empty() || outside.is_empty() {
                        continue;
                    }
                    let mut ev = |a: usize, b: usize, verts: &mut Vec<P3>| -> u32 {
                        let (ga, gb) = (tet[a].0, tet[b].0);
                        let key = (ga.min(gb), ga.max(gb));
                        *edge_vert.entry(key).or_insert_with(|| {
                            let (fa, fb) = (val[ga], val[gb]);
                            let t = (fa / (fa - fb)).clamp(0.02, 0.98);
                            verts.push(add(tet[a].1, scale(sub(tet[b].1, tet[a].1), t)));
                            verts.len() as u32 - 1
                        })
                    };
                    let toward = sub(
                        super::util::mean(&inside.iter().map(|&s| tet[s].1).collect::<Vec<_>>()),
                        super::util::mean(&outside.iter().map(|&s| tet[s].1).collect::<Vec<_>>()),
                    );
                    let ring: Vec<u32> = match (inside.len(), outside.len()) {
                        (1, 3) => outside.iter().map(|&o| ev(inside[0], o, &mut verts)).collect(),
                        (3, 1) => inside.iter().map(|&s| ev(s, outside[0], &mut verts)).collect(),
                        _ => {
                            let (p, q, r, s) = (inside[0], inside[1], outside[0], outside[1]);
                            vec![
                                ev(p, r, &mut verts),
                                ev(p, s, &mut verts),
                                ev(q, s, &mut verts),
                                ev(q, r, &mut verts),
                            ]
                        }
                    };
                    for t in 1..ring.len() - 1 {
                        let mut tri = [ring[0], ring[t], ring[t + 1]];
                        let (a, b, c) = (verts[tri[0] as usize], verts[tri[1] as usize], verts[tri[2] as usize]);
                        if dot(cross(sub(b, a), sub(c, a)), toward) < 0.0 {
                            tri.swap(1, 2);
                        }
                        tris.push(tri);
                    }
                }
            }
        }
    }
    (verts, tris)
}

/// The cavern with this seed.
pub fn cavern(seed: u64) -> (Soup, SuiteTruth) {
    let mut rng = Rng::new(0xCA7E_0000_0000 ^ seed.wrapping_mul(0x9E37_79B9_7F4A));
    let (blobs, tunnels) = layout(&mut rng);
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for b in &blobs {
        let r = b.radii.iter().cloned().fold(0.0, f64::max) + 1.0;
        for k in 0..3 {
            lo[k] = lo[k].min(b.center[k] - r);
            hi[k] = hi[k].max(b.center[k] + r);
        }
    }
    let f = |p: P3| field(&blobs, &tunnels, p);
    let mut h = SPACING;
    let (vertices, tris) = loop {
        let n = [0, 1, 2].map(|k| ((hi[k] - lo[k]) / h).ceil() as usize + 1);
        let (v, t) = march(&f, lo, h, n);
        if t.len() <= TARGET_TRIANGLES || h >= MAX_SPACING {
            break (v, t);
        }
        h = (h * (t.len() as f64 / (0.9 * TARGET_TRIANGLES as f64)).sqrt()).min(MAX_SPACING);
    };
    let rooms = blobs
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let mut samples = vec![b.center];
            for (k, s) in [(0, 0.45), (1, 0.45), (2, 0.3)] {
                for sign in [-1.0, 1.0] {
                    let p = add(b.center, scale(b.axes[k], sign * s * b.radii[k]));
                    if f(p) < 0.0 && b.level(p) < 1.0 {
                        samples.push(p);
                    }
                }
            }
            TruthRoom {
                name: format!("blob {i}"),
                samples,
            }
        })
        .collect();
    let doorways = tunnels
        .iter()
        .map(|t| {
            // The middle of the tunnel's part outside both ellipsoids.
            let at = |s: f64| add(t.p, scale(sub(t.q, t.p), s));
            let exit = (0..=1000)
                .map(|i| i as f64 / 1000.0)
                .find(|&s| blobs[t.a].level(at(s)) >= 1.0)
                .unwrap_or(0.5);
            let entry = (0..=1000)
                .rev()
                .map(|i| i as f64 / 1000.0)
                .find(|&s| blobs[t.b].level(at(s)) >= 1.0)
                .unwrap_or(0.5);
            let c = at(0.5 * (exit + entry));
            let d = scale(sub(t.q, t.p), 1.0 / dist(t.q, t.p));
            let helper = if d[2].abs() < 0.9 {
                [0.0, 0.0, 1.0]
            } else {
                [1.0, 0.0, 0.0]
            };
            let u = cross(d, helper);
            let u = scale(u, 1.0 / norm(u));
            let v = cross(d, u);
            let polygon = (0..8)
                .map(|i| {
                    let a = i as f64 * std::f64::consts::PI / 4.0;
                    add(c, add(scale(u, t.r * a.cos()), scale(v, t.r * a.sin())))
                })
                .collect();
            Doorway {
                rooms: [t.a, t.b],
                polygon,
            }
        })
        .collect();
    let soup = Soup {
        vertices,
        polygons: tris.iter().map(|t| t.to_vec()).collect(),
    };
    (
        soup,
        SuiteTruth {
            rooms,
            doorways,
            membership: Membership::Ellipsoids(blobs),
        },
    )
}
