//! Small hand-made scenes for tests and examples: axis-aligned rooms, doors, pillars.
//!
//! Orientation follows the crate convention: a polygon's front (counter-clockwise side)
//! faces free space, so room walls face inwards and a pillar's faces face outwards.

use crate::predicates::P3;

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
