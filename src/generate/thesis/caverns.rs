//! The caverns (thesis 4.3.4), plain and rotated 7°, 8° and 9° about x, y and z.

use std::f64::consts::PI;

use super::build::*;
use super::{Doorway, GroundTruth, Room, ThesisModel};
use crate::base::rigid::rotate_z_deg;
use crate::base::rng::SplitMix64;
use crate::base::vec::{P3, add, dot, lerp, mean, scale};

/// One cave: centre, radii, rotation about z, noise seed.
pub(super) struct Cave {
    pub(super) center: P3,
    pub(super) radii: P3,
    pub(super) angle: f64,
    pub(super) bumps: Vec<(P3, f64, f64)>,
}

impl Cave {
    /// The cave wall in the direction of cube point `q` (cube-sphere projection, radii,
    /// smooth bumps of up to about 12 %).
    pub(super) fn point(&self, q: P3) -> P3 {
        let n = dot(&q, &q).sqrt();
        let d = scale(&q, 1.0 / n);
        let bump: f64 = self.bumps.iter().map(|&(k, a, ph)| a * (dot(&k, &d) + ph).sin()).sum();
        let local = [d[0] * self.radii[0], d[1] * self.radii[1], d[2] * self.radii[2]];
        add(&self.center, &scale(&rotate_z_deg(local, self.angle), 1.0 + bump))
    }
}

pub(super) const CAVE_N: [usize; 3] = [4, 4, 2];

/// The cube lattice point of a side face's `(a, b)` grid point: face `dir` is 0 = +x,
/// 1 = −x, 2 = +y, 3 = −y; `a` runs along the face's horizontal axis, `b` up.
pub(super) fn side_lattice(dir: usize, a: usize, b: usize) -> [usize; 3] {
    match dir {
        0 => [CAVE_N[0], a, b],
        1 => [0, a, b],
        2 => [a, CAVE_N[1], b],
        _ => [a, 0, b],
    }
}

pub(super) fn lattice_q(l: [usize; 3]) -> P3 {
    [0, 1, 2].map(|k| 2.0 * l[k] as f64 / CAVE_N[k] as f64 - 1.0)
}

/// The hole ring of a side face, as `(a, b)` grid points (the boundary of the central
/// 2 × 2 block of cells).
pub(super) const HOLE_RING: [(usize, usize); 8] = [(1, 0), (2, 0), (3, 0), (3, 1), (3, 2), (2, 2), (1, 2), (1, 1)];

pub(super) fn caverns_build(name: &'static str, rotated: bool) -> ThesisModel {
    let mut rng = SplitMix64(0x0CA7_E434);
    // Six caves on a 2 × 3 grid, jittered; the 7 edges of the grid are the tunnels.
    let mut caves = Vec::new();
    for row in 0..2 {
        for col in 0..3 {
            let center = [
                col as f64 * 9.0 + 0.6 * rng.signed_unit(),
                row as f64 * 8.0 + 0.6 * rng.signed_unit(),
                0.5 * rng.signed_unit(),
            ];
            let radii = [
                3.0 + 0.4 * rng.signed_unit(),
                2.6 + 0.4 * rng.signed_unit(),
                1.9 + 0.3 * rng.signed_unit(),
            ];
            let angle = 8.0 * rng.signed_unit();
            let bumps = (0..3)
                .map(|_| {
                    let k = [
                        2.0 * rng.signed_unit(),
                        2.0 * rng.signed_unit(),
                        2.0 * rng.signed_unit(),
                    ];
                    (k, 0.04 + 0.02 * rng.signed_unit(), PI * rng.signed_unit())
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
    let xf = |p: P3| if rotated { crate::base::rigid::rotate_789(p) } else { p };
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
        let mid_axis = lerp(&axis_a, &axis_b, 0.5);
        // The middle ring: half-way, narrowed by 15 % towards the axis.
        let mid: Vec<P3> = ra
            .iter()
            .zip(&rb)
            .map(|(&p, &q)| lerp(&mid_axis, &lerp(&p, &q, 0.5), 0.85))
            .collect();
        for (r0, r1, t) in [(&ra, &mid, 0.25), (&mid, &rb, 0.75)] {
            let toward = xf(lerp(&axis_a, &axis_b, t));
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
                samples.push(xf(add(&c.center, &rotate_z_deg(local, c.angle))));
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
