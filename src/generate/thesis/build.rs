//! The indexed soup builder the thesis generators share.

use std::collections::HashMap;
use std::f64::consts::PI;

use crate::base::vec::{P3, dot, fan_normal, mean, sub};
use crate::generate::scenes::Soup;

/// An indexed soup whose vertices are shared by exact coordinates.
#[derive(Default)]
pub(super) struct Builder {
    pub(super) soup: Soup,
    pub(super) index: HashMap<[u64; 3], u32>,
}

impl Builder {
    pub(super) fn v(&mut self, p: P3) -> u32 {
        let key = [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()];
        let soup = &mut self.soup;
        *self.index.entry(key).or_insert_with(|| {
            soup.vertices.push(p);
            soup.vertices.len() as u32 - 1
        })
    }
    /// A polygon through the given vertices, oriented so its front faces `toward`.
    pub(super) fn poly_toward(&mut self, mut ids: Vec<u32>, toward: P3) {
        let ps: Vec<P3> = ids.iter().map(|&i| self.soup.vertices[i as usize]).collect();
        if dot(&fan_normal(&ps), &sub(&toward, &mean(&ps))) < 0.0 {
            ids.reverse();
        }
        self.soup.polygons.push(ids);
    }
    /// A polygon oriented so its front faces direction `dir`.
    pub(super) fn poly_dir(&mut self, mut ids: Vec<u32>, dir: P3) {
        let ps: Vec<P3> = ids.iter().map(|&i| self.soup.vertices[i as usize]).collect();
        if dot(&fan_normal(&ps), &dir) < 0.0 {
            ids.reverse();
        }
        self.soup.polygons.push(ids);
    }
    /// A quad `a b c d` (in cyclic order) as two triangles split along `a c`, fronts
    /// facing `toward`.
    /// Two triangles of a (nearly planar) quad along the diagonal the Delaunay criterion
    /// picks: `0–2` unless the angles at `1` and `3` sum to more than π. Curved surfaces
    /// tessellated this way have far more triangles that are faces of the tetrahedralization.
    pub(super) fn quad_tris_delaunay(&mut self, q: [P3; 4], toward: P3) {
        let angle = |a: P3, o: P3, b: P3| {
            let (u, v) = (sub(&a, &o), sub(&b, &o));
            (dot(&u, &v) / (dot(&u, &u) * dot(&v, &v)).sqrt())
                .clamp(-1.0, 1.0)
                .acos()
        };
        if angle(q[0], q[1], q[2]) + angle(q[0], q[3], q[2]) > PI {
            self.quad_tris([q[1], q[2], q[3], q[0]], toward);
        } else {
            self.quad_tris(q, toward);
        }
    }

    pub(super) fn quad_tris(&mut self, q: [P3; 4], toward: P3) {
        let ids = q.map(|p| self.v(p));
        self.poly_toward(vec![ids[0], ids[1], ids[2]], toward);
        self.poly_toward(vec![ids[0], ids[2], ids[3]], toward);
    }
}
