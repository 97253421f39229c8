//! A purpose-built model for the window representations: a row of rooms whose doors are not
//! aligned (the thesis's figure 2.13 case). Five 4 × 4 × 3 m rooms along x, joined by 1 m
//! deep openings through the walls whose cross-sections differ and do not line up: a door
//! at the south side, a diamond (a square turned 45°, so its edges are at 45° on any level
//! screen), a raised door at mid-height, a larger diamond off-centre. A sight line along
//! the row must thread openings at different places, so screen rectangles and k-gons of the
//! window sequence over-estimate most there, and the diamonds' slanted edges are never
//! axis-aligned on screen.
//!
//! Ground truth: the five rooms (interior sample points) and four doorways (each opening's
//! section half-way through the wall), in the thesis models' format
//! ([`crate::generate::thesis::GroundTruth`]), so `portalfind run` can score it.

use crate::base::vec::{P3, cross, dot, sub};
use crate::generate::scenes::Soup;
use crate::generate::thesis::{Doorway, GroundTruth, Room, ThesisModel};

/// Room pitch along x (4 m room + 1 m opening depth).
const PITCH: f64 = 5.0;
/// Room size.
const ROOM: [f64; 3] = [4.0, 4.0, 3.0];

/// The cross-section of an opening on the wall plane (y, z).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Hole {
    /// `y0..y1 × z0..z1`.
    Rect(f64, f64, f64, f64),
    /// A diamond around `(yc, zc)` with half-diagonal `r`.
    Diamond(f64, f64, f64),
}

impl Hole {
    /// The boundary loop (y, z), counter-clockwise seen from +x.
    fn boundary(&self) -> Vec<[f64; 2]> {
        match *self {
            Hole::Rect(y0, y1, z0, z1) => vec![[y0, z0], [y1, z0], [y1, z1], [y0, z1]],
            Hole::Diamond(yc, zc, r) => vec![[yc, zc - r], [yc + r, zc], [yc, zc + r], [yc - r, zc]],
        }
    }

    /// The wall `[0, 4] × [0, 3]` (y, z) around the hole, as convex pieces.
    fn wall(&self) -> Vec<Vec<[f64; 2]>> {
        let [w, _, h] = ROOM;
        let rect = |y0: f64, y1: f64, z0: f64, z1: f64| vec![[y0, z0], [y1, z0], [y1, z1], [y0, z1]];
        match *self {
            Hole::Rect(y0, y1, z0, z1) => {
                let mut v = vec![rect(0.0, y0, 0.0, h), rect(y1, w, 0.0, h), rect(y0, y1, z1, h)];
                if z0 > 0.0 {
                    v.push(rect(y0, y1, 0.0, z0));
                }
                v
            }
            Hole::Diamond(yc, zc, r) => vec![
                rect(0.0, yc - r, 0.0, h),
                rect(yc + r, w, 0.0, h),
                vec![[yc - r, 0.0], [yc, 0.0], [yc, zc - r], [yc - r, zc]],
                vec![[yc, 0.0], [yc + r, 0.0], [yc + r, zc], [yc, zc - r]],
                vec![[yc - r, zc], [yc, zc + r], [yc, h], [yc - r, h]],
                vec![[yc, zc + r], [yc + r, zc], [yc + r, h], [yc, h]],
            ],
        }
    }

    fn centre(&self) -> [f64; 2] {
        let b = self.boundary();
        let n = b.len() as f64;
        [
            b.iter().map(|p| p[0]).sum::<f64>() / n,
            b.iter().map(|p| p[1]).sum::<f64>() / n,
        ]
    }
}

/// The openings between room `i` and room `i + 1`.
const HOLES: [Hole; 4] = [
    Hole::Rect(0.4, 1.4, 0.0, 2.0),
    Hole::Diamond(2.9, 1.5, 0.6),
    Hole::Rect(0.9, 1.9, 0.7, 2.5),
    Hole::Diamond(2.2, 1.3, 0.7),
];

/// Adds the convex planar polygon `pts`, its front turned towards the free-space point `free`.
fn add(s: &mut Soup, mut pts: Vec<P3>, free: &P3) {
    let n = cross(&sub(&pts[1], &pts[0]), &sub(&pts[2], &pts[0]));
    if dot(&n, &sub(free, &pts[0])) < 0.0 {
        pts.reverse();
    }
    let base = s.vertices.len() as u32;
    s.vertices.extend(pts);
    s.polygons.push((base..s.vertices.len() as u32).collect());
}

fn on_x(x: f64, yz: &[[f64; 2]]) -> Vec<P3> {
    yz.iter().map(|p| [x, p[0], p[1]]).collect()
}

/// The model: five rooms in a row joined by non-aligned openings (see the module docs).
pub fn nonaligned_doors() -> ThesisModel {
    let [w, d, h] = ROOM;
    let n = HOLES.len() + 1;
    let mut s = Soup::default();
    let mut truth = GroundTruth::default();
    for i in 0..n {
        let x0 = PITCH * i as f64;
        let x1 = x0 + w;
        let c = [x0 + w / 2.0, d / 2.0, h / 2.0];
        s.rect(2, 0.0, (x0, x1), (0.0, d), true);
        s.rect(2, h, (x0, x1), (0.0, d), false);
        s.rect(1, 0.0, (0.0, h), (x0, x1), true);
        s.rect(1, d, (0.0, h), (x0, x1), false);
        for (x, hole) in [(x0, i.checked_sub(1).map(|k| HOLES[k])), (x1, HOLES.get(i).copied())] {
            match hole {
                None => add(&mut s, on_x(x, &[[0.0, 0.0], [d, 0.0], [d, h], [0.0, h]]), &c),
                Some(hole) => {
                    for piece in hole.wall() {
                        add(&mut s, on_x(x, &piece), &c);
                    }
                }
            }
        }
        truth.rooms.push(Room {
            name: format!("room {i}"),
            samples: [
                [0.0, 0.0, 0.0],
                [-1.2, -1.2, -0.8],
                [1.2, -1.2, 0.6],
                [1.2, 1.2, -0.6],
                [-1.2, 1.2, 0.8],
            ]
            .iter()
            .map(|o| [c[0] + o[0], c[1] + o[1], c[2] + o[2]])
            .collect(),
        });
    }
    // The openings' sides (1 m deep tubes through the wall gap), facing their axis.
    for (i, hole) in HOLES.iter().enumerate() {
        let (xa, xb) = (PITCH * i as f64 + w, PITCH * (i + 1) as f64);
        let b = hole.boundary();
        let m = hole.centre();
        let axis = [(xa + xb) / 2.0, m[0], m[1]];
        for k in 0..b.len() {
            let (p, q) = (b[k], b[(k + 1) % b.len()]);
            add(
                &mut s,
                vec![[xa, p[0], p[1]], [xa, q[0], q[1]], [xb, q[0], q[1]], [xb, p[0], p[1]]],
                &axis,
            );
        }
        truth.doorways.push(Doorway {
            rooms: [i, i + 1],
            polygon: on_x(axis[0], &b),
        });
    }
    ThesisModel {
        name: "nonaligned_doors",
        soup: s,
        truth,
        description: "Five 4 x 4 x 3 m rooms in a row along x joined by 1 m deep openings that do not line up \
                      (a door, a diamond, a raised door, a larger diamond): the thesis's figure 2.13 case. \
                      Made by portalfind::visibility::doors::nonaligned_doors."
            .into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_rooms_with_openings_that_do_not_line_up() {
        let m = nonaligned_doors();
        let model = crate::model::from_soup("doors", m.soup.vertices.clone(), m.soup.polygons.clone()).expect("model");
        assert_eq!(m.truth.rooms.len(), 5);
        assert_eq!(m.truth.doorways.len(), 4);
        // Wall area: 5 rooms' floors, ceilings and long walls, 10 end walls less the 4
        // openings twice, plus the tubes' sides.
        let area: f64 = model
            .polygons
            .iter()
            .map(|p| {
                let v: Vec<P3> = p.verts.iter().map(|v| model.vertices[v.idx()]).collect();
                0.5 * crate::base::vec::norm(&crate::base::vec::fan_normal(&v))
            })
            .sum();
        let holes: f64 = HOLES
            .iter()
            .map(|h| match *h {
                Hole::Rect(y0, y1, z0, z1) => (y1 - y0) * (z1 - z0),
                Hole::Diamond(_, _, r) => 2.0 * r * r,
            })
            .sum();
        let perim: f64 = HOLES
            .iter()
            .map(|h| match *h {
                Hole::Rect(y0, y1, z0, z1) => 2.0 * ((y1 - y0) + (z1 - z0)),
                Hole::Diamond(_, _, r) => 4.0 * r * std::f64::consts::SQRT_2,
            })
            .sum();
        let want = 5.0 * (2.0 * 16.0 + 2.0 * 12.0) + 10.0 * 12.0 - 2.0 * holes + perim;
        assert!((area - want).abs() < 1e-9 * want, "area {area}, want {want}");
        // No straight line along x passes all four openings (they do not line up).
        let inside = |h: &Hole, y: f64, z: f64| match *h {
            Hole::Rect(y0, y1, z0, z1) => y0 < y && y < y1 && z0 < z && z < z1,
            Hole::Diamond(yc, zc, r) => (y - yc).abs() + (z - zc).abs() < r,
        };
        for i in 0..=80 {
            for j in 0..=60 {
                let (y, z) = (i as f64 * 0.05, j as f64 * 0.05);
                assert!(!HOLES.iter().all(|h| inside(h, y, z)), "aligned at ({y}, {z})");
            }
        }
    }
}
