//! Small hand-made scenes for tests and examples: axis-aligned rooms, doors, pillars.
//!
//! Orientation follows the crate convention: a polygon's front (counter-clockwise side)
//! faces free space, so room walls face inwards and a pillar's faces face outwards.

use crate::base::vec::P3;

/// A polygon soup under construction.
#[derive(Clone, Debug, Default)]
pub struct Soup {
    /// Vertices.
    pub vertices: Vec<P3>,
    /// Polygons as vertex index lists.
    pub polygons: Vec<Vec<u32>>,
}

impl Soup {
    /// An axis-aligned rectangle on the plane `axis = at`, spanning `u` and `v` on the other
    /// two axes (cyclic: for axis x, u = y and v = z), with its front facing `+axis` when
    /// `facing_positive`, else `-axis`.
    pub fn rect(&mut self, axis: usize, at: f64, u: (f64, f64), v: (f64, f64), facing_positive: bool) {
        let (ua, va) = ((axis + 1) % 3, (axis + 2) % 3);
        let mut corners = [(u.0, v.0), (u.1, v.0), (u.1, v.1), (u.0, v.1)];
        if !facing_positive {
            corners.reverse();
        }
        let base = self.vertices.len() as u32;
        for (cu, cv) in corners {
            let mut p = [0.0; 3];
            p[axis] = at;
            p[ua] = cu;
            p[va] = cv;
            self.vertices.push(p);
        }
        self.polygons.push((base..base + 4).collect());
    }

    /// The six faces of a box; `inward` for a room, outward for a solid (pillar, table).
    pub fn boxed(&mut self, lo: P3, hi: P3, inward: bool) {
        for axis in 0..3 {
            let (ua, va) = ((axis + 1) % 3, (axis + 2) % 3);
            let (u, v) = ((lo[ua], hi[ua]), (lo[va], hi[va]));
            self.rect(axis, lo[axis], u, v, inward);
            self.rect(axis, hi[axis], u, v, !inward);
        }
    }

    /// Applies a transform to every vertex.
    pub fn map(mut self, f: impl Fn(P3) -> P3) -> Self {
        for v in &mut self.vertices {
            *v = f(*v);
        }
        self
    }
}

/// One closed box room, `[0,4] × [0,4] × [0,3]`, walls facing in.
pub fn box_room() -> Soup {
    let mut s = Soup::default();
    s.boxed([0.0, 0.0, 0.0], [4.0, 4.0, 3.0], true);
    s
}

/// A 0.1 × 10 × 3 room whose floor is `k` pairs of sliver triangles running its length
/// (the walls' bottom edges meet the floor's vertices at T-junctions, which the loader
/// reports). With `k = 1000` the triangles are 1e-4 wide, below the sliver width (1e-5 of
/// the diagonal, 1.04e-4), and every tetrahedron over the floor is a sliver.
pub fn sliver_floor_room(k: usize) -> Soup {
    let mut s = Soup::default();
    let (w, l, h) = (0.1, 10.0, 3.0);
    s.rect(2, h, (0.0, w), (0.0, l), false);
    s.rect(0, 0.0, (0.0, l), (0.0, h), true);
    s.rect(0, w, (0.0, l), (0.0, h), false);
    s.rect(1, 0.0, (0.0, h), (0.0, w), true);
    s.rect(1, l, (0.0, h), (0.0, w), false);
    let b = s.vertices.len() as u32;
    for i in 0..=k {
        let x = w * i as f64 / k as f64;
        s.vertices.extend([[x, 0.0, 0.0], [x, l, 0.0]]);
    }
    for i in 0..k as u32 {
        let (a0, b0, a1, b1) = (b + 2 * i, b + 2 * i + 1, b + 2 * i + 2, b + 2 * i + 3);
        s.polygons.push(vec![a0, a1, b1]);
        s.polygons.push(vec![a0, b1, b0]);
    }
    s
}

/// Two 4 × 4 × 3 rooms, `x ∈ [0,4]` and `x ∈ [5,9]`, joined through a 1 m thick wall by a
/// door corridor `x ∈ [4,5], y ∈ [1.5,2.5], z ∈ [0,2]`.
pub fn two_rooms() -> Soup {
    let mut s = Soup::default();
    for (x0, x1, door_side_hi) in [(0.0, 4.0, true), (5.0, 9.0, false)] {
        // Floor, ceiling, the y walls and the outer x wall are whole.
        s.rect(2, 0.0, (x0, x1), (0.0, 4.0), true);
        s.rect(2, 3.0, (x0, x1), (0.0, 4.0), false);
        s.rect(1, 0.0, (0.0, 3.0), (x0, x1), true);
        s.rect(1, 4.0, (0.0, 3.0), (x0, x1), false);
        let (outer, inner) = if door_side_hi { (x0, x1) } else { (x1, x0) };
        s.rect(0, outer, (0.0, 4.0), (0.0, 3.0), door_side_hi);
        // The wall with the door: three pieces around the opening.
        let f = !door_side_hi;
        s.rect(0, inner, (0.0, 1.5), (0.0, 3.0), f);
        s.rect(0, inner, (2.5, 4.0), (0.0, 3.0), f);
        s.rect(0, inner, (1.5, 2.5), (2.0, 3.0), f);
    }
    // Corridor: floor, ceiling, two sides, facing in.
    s.rect(2, 0.0, (4.0, 5.0), (1.5, 2.5), true);
    s.rect(2, 2.0, (4.0, 5.0), (1.5, 2.5), false);
    s.rect(1, 1.5, (0.0, 2.0), (4.0, 5.0), true);
    s.rect(1, 2.5, (0.0, 2.0), (4.0, 5.0), false);
    s
}

impl Soup {
    /// [`Soup::rect`] tessellated into `n.0 × n.1` equal quads; cells for which `skip(i, j)`
    /// holds are left out (openings such as doors).
    #[allow(clippy::too_many_arguments)]
    pub fn rect_tess(
        &mut self,
        axis: usize,
        at: f64,
        u: (f64, f64),
        v: (f64, f64),
        facing_positive: bool,
        n: (usize, usize),
        skip: impl Fn(usize, usize) -> bool,
    ) {
        let (du, dv) = ((u.1 - u.0) / n.0 as f64, (v.1 - v.0) / n.1 as f64);
        for i in 0..n.0 {
            for j in 0..n.1 {
                if skip(i, j) {
                    continue;
                }
                let u0 = u.0 + du * i as f64;
                let v0 = v.0 + dv * j as f64;
                let u1 = if i + 1 == n.0 { u.1 } else { u0 + du };
                let v1 = if j + 1 == n.1 { v.1 } else { v0 + dv };
                self.rect(axis, at, (u0, u1), (v0, v1), facing_positive);
            }
        }
    }
}

/// A scalable test building: `nx × ny` rooms (4 × 4 × 3, walls 0.5 thick) in a grid, each
/// joined to its +x and +y neighbours by a door corridor (1 wide, 2 high), every surface
/// tessellated into quads of `4 / tess` units (`tess` is rounded down to a multiple of 8,
/// at least 8, so that door edges fall on grid lines). Returns the soup and one sample point
/// per room (the room centres), row-major.
pub fn room_grid(nx: usize, ny: usize, tess: usize) -> (Soup, Vec<P3>) {
    // A multiple of 8 (at least 8), so the door's edges (1.5 and 2.5 m across, 2 m up) fall
    // on grid lines.
    let tess = (tess / 8).max(1) * 8;
    let (w, h, gap) = (4.0, 3.0, 0.5);
    let pitch = w + gap;
    let mut s = Soup::default();
    let mut centres = Vec::new();
    let nz = (tess * 3 / 4).max(3);
    // Door: u in [1.5, 2.5] of the 4 m wall, z in [0, 2]; with tess cells of 4/tess and
    // nz cells of 3/nz, door cells are those fully inside.
    let cu = w / tess as f64;
    let cz = h / nz as f64;
    let door = move |i: usize, j: usize| {
        let (u0, z0) = (i as f64 * cu, j as f64 * cz);
        u0 >= 1.5 - 1e-9 && u0 + cu <= 2.5 + 1e-9 && z0 + cz <= 2.0 + 1e-9
    };
    for ry in 0..ny {
        for rx in 0..nx {
            let (x0, y0) = (rx as f64 * pitch, ry as f64 * pitch);
            let (x1, y1) = (x0 + w, y0 + w);
            centres.push([x0 + w / 2.0, y0 + w / 2.0, h / 2.0]);
            let none = |_: usize, _: usize| false;
            s.rect_tess(2, 0.0, (x0, x1), (y0, y1), true, (tess, tess), none);
            s.rect_tess(2, h, (x0, x1), (y0, y1), false, (tess, tess), none);
            // x walls: u = y, v = z.
            let east_door = rx + 1 < nx;
            let west_door = rx > 0;
            s.rect_tess(0, x0, (y0, y1), (0.0, h), true, (tess, nz), |i, j| {
                west_door && door(i, j)
            });
            s.rect_tess(0, x1, (y0, y1), (0.0, h), false, (tess, nz), |i, j| {
                east_door && door(i, j)
            });
            // y walls: u = z, v = x (swap the door test's arguments).
            let north_door = ry + 1 < ny;
            let south_door = ry > 0;
            s.rect_tess(1, y0, (0.0, h), (x0, x1), true, (nz, tess), |j, i| {
                south_door && door(i, j)
            });
            s.rect_tess(1, y1, (0.0, h), (x0, x1), false, (nz, tess), |j, i| {
                north_door && door(i, j)
            });
            let k = (tess / 4).max(1);
            if east_door {
                // Corridor from x1 to x1 + gap at y in [y0+1.5, y0+2.5], z in [0, 2].
                let (ya, yb) = (y0 + 1.5, y0 + 2.5);
                s.rect_tess(2, 0.0, (x1, x1 + gap), (ya, yb), true, (1, k), none);
                s.rect_tess(2, 2.0, (x1, x1 + gap), (ya, yb), false, (1, k), none);
                s.rect_tess(1, ya, (0.0, 2.0), (x1, x1 + gap), true, (k, 1), none);
                s.rect_tess(1, yb, (0.0, 2.0), (x1, x1 + gap), false, (k, 1), none);
            }
            if north_door {
                let (xa, xb) = (x0 + 1.5, x0 + 2.5);
                s.rect_tess(2, 0.0, (xa, xb), (y1, y1 + gap), true, (k, 1), none);
                s.rect_tess(2, 2.0, (xa, xb), (y1, y1 + gap), false, (k, 1), none);
                s.rect_tess(0, xa, (y1, y1 + gap), (0.0, 2.0), true, (1, k), none);
                s.rect_tess(0, xb, (y1, y1 + gap), (0.0, 2.0), false, (1, k), none);
            }
        }
    }
    (s, centres)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn room_grid_counts() {
        let (s, c) = room_grid(2, 2, 8);
        assert_eq!(c.len(), 4);
        // Each room: floor and ceiling 64 quads, walls 8 x 6 = 48 quads each, minus door
        // cells (2 columns x 5 rows = 10... depends on tessellation) on inner walls.
        assert!(s.polygons.len() > 4 * (128 + 4 * 48 - 20));
    }
}
