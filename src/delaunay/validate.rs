//! Invariant checker for [`Tetrahedralization`]: every claim in the module docs, verified
//! with exact predicates. Tests call it on every tetrahedralization they build.

use super::{FACE_SLOTS, INFINITE, Tetrahedralization};
use crate::predicates::{insphere, orient3d};

/// What [`Tetrahedralization::validate`] counted on a valid tetrahedralization.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct ValidationReport {
    /// Distinct vertices used by finite tetrahedra.
    pub vertices: usize,
    /// Distinct edges of finite tetrahedra.
    pub edges: usize,
    /// Distinct faces of finite tetrahedra.
    pub faces: usize,
    /// Finite tetrahedra.
    pub tets: usize,
    /// Hull faces.
    pub hull_faces: usize,
    /// Interior faces whose opposite vertices are exactly cospherical (ties broken
    /// symbolically; a count of how degenerate the input is).
    pub cospherical_faces: usize,
    /// Hull edges whose two hull faces are exactly coplanar.
    pub coplanar_hull_edges: usize,
}

/// The first violated invariant.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ValidationError {
    /// A finite tetrahedron is flat or inverted.
    #[error("tetrahedron {tet} is not positively oriented (orient3d = {orient})")]
    BadOrientation {
        /// Tetrahedron index.
        tet: usize,
        /// Exact orientation sign.
        orient: i32,
    },
    /// Adjacency is not symmetric or neighbours disagree on the shared face.
    #[error("adjacency broken at tetrahedron {tet}, face {face}: {why}")]
    Adjacency {
        /// Tetrahedron index.
        tet: usize,
        /// Face index.
        face: usize,
        /// What is wrong.
        why: &'static str,
    },
    /// Two tetrahedra overlap across a face (their apexes are on the same side).
    #[error("tetrahedra {a} and {b} overlap across their shared face")]
    Overlap {
        /// One tetrahedron.
        a: usize,
        /// The other.
        b: usize,
    },
    /// The hull is not convex at an edge.
    #[error("hull is not convex at the edge shared by the faces of tetrahedra {a} and {b}")]
    NonConvexHull {
        /// One finite tetrahedron on the hull.
        a: usize,
        /// The other.
        b: usize,
    },
    /// The Euler characteristic of the complex or of its hull is wrong.
    #[error("Euler characteristic: {what} = {value}, expected {expected}")]
    Euler {
        /// Which formula.
        what: &'static str,
        /// Computed value.
        value: i64,
        /// Expected value.
        expected: i64,
    },
    /// An interior face is not locally Delaunay.
    #[error("face between tetrahedra {a} and {b} is not locally Delaunay")]
    NotDelaunay {
        /// One tetrahedron.
        a: usize,
        /// The other.
        b: usize,
    },
    /// A distinct input point is not a vertex.
    #[error("input point {0} is not a vertex of any tetrahedron")]
    UnusedVertex(usize),
}

impl Tetrahedralization {
    /// Checks every invariant with exact predicates; returns counts on success.
    ///
    /// - every finite tetrahedron positively oriented;
    /// - adjacency symmetric, neighbours agree on the shared face's vertices, and the two
    ///   apexes of every interior face lie on opposite sides of it (no overlap);
    /// - the hull is a closed, locally (hence globally) convex surface:
    ///   V − E + F = 2 on the hull and V − E + F − T = 1 for the solid;
    /// - every interior face is locally Delaunay (exact insphere ≤ 0);
    /// - every distinct input point is a vertex.
    pub fn validate(&self) -> Result<ValidationReport, ValidationError> {
        let nf = self.n_finite;
        let mut rep = ValidationReport {
            tets: nf,
            hull_faces: self.slots.len() - nf,
            ..Default::default()
        };
        let p = |v: u32| &self.points[v as usize];
        for t in 0..self.slots.len() {
            let v = self.slots[t].v;
            let finite = t < nf;
            if finite == v.contains(&INFINITE) {
                return Err(ValidationError::Adjacency {
                    tet: t,
                    face: 0,
                    why: "finite/infinite numbering",
                });
            }
            if finite {
                let o = orient3d(p(v[0]), p(v[1]), p(v[2]), p(v[3]));
                if o <= 0 {
                    return Err(ValidationError::BadOrientation { tet: t, orient: o });
                }
            }
            for i in 0..4 {
                let a = self.slots[t].n[i];
                let (n, j) = ((a >> 2) as usize, (a & 3) as usize);
                if n >= self.slots.len() || self.slots[n].n[j] != (t * 4 + i) as u32 {
                    return Err(ValidationError::Adjacency {
                        tet: t,
                        face: i,
                        why: "not symmetric",
                    });
                }
                let mut f1 = FACE_SLOTS[i].map(|s| v[s]);
                let mut f2 = FACE_SLOTS[j].map(|s| self.slots[n].v[s]);
                f1.sort_unstable();
                f2.sort_unstable();
                if f1 != f2 {
                    return Err(ValidationError::Adjacency {
                        tet: t,
                        face: i,
                        why: "neighbours disagree on the face",
                    });
                }
                if !finite && v[i] == INFINITE && n >= nf {
                    return Err(ValidationError::Adjacency {
                        tet: t,
                        face: i,
                        why: "hull face without a finite side",
                    });
                }
                if finite && n < nf && t < n {
                    // Apex of the neighbour must be strictly on the other side of face i.
                    let f = FACE_SLOTS[i].map(|s| p(v[s]));
                    let apex = p(self.slots[n].v[j]);
                    if orient3d(f[0], f[1], f[2], apex) <= 0 {
                        return Err(ValidationError::Overlap { a: t, b: n });
                    }
                    let s = insphere(p(v[0]), p(v[1]), p(v[2]), p(v[3]), apex);
                    if s > 0 {
                        return Err(ValidationError::NotDelaunay { a: t, b: n });
                    }
                    if s == 0 {
                        rep.cospherical_faces += 1;
                    }
                }
            }
        }
        // Hull convexity: at every hull edge the apex of the neighbouring hull face is not
        // strictly outside this face's plane. Hull faces are the finite faces of infinite
        // tetrahedra; two hull faces share an edge exactly when their infinite tetrahedra
        // are adjacent across the face containing the infinite vertex and that edge.
        for t in nf..self.slots.len() {
            let v = self.slots[t].v;
            let k = v.iter().position(|&x| x == INFINITE).expect("checked above");
            let face: Vec<u32> = FACE_SLOTS[k].iter().map(|&s| v[s]).collect();
            for i in 0..4 {
                if i == k {
                    continue;
                }
                let a = self.slots[t].n[i];
                let (n, _) = ((a >> 2) as usize, (a & 3) as usize);
                if n < nf {
                    return Err(ValidationError::Adjacency {
                        tet: t,
                        face: i,
                        why: "infinite tetrahedron next to a finite one across an infinite face",
                    });
                }
                // The apex of n's hull face that is not on the shared edge.
                let w = self.slots[n].v;
                let apex = *w
                    .iter()
                    .find(|&&x| x != INFINITE && !v.contains(&x))
                    .expect("hull faces differ");
                // Face k of an infinite tetrahedron is counter-clockwise seen from outside
                // *that* tetrahedron, i.e. from inside the hull: a point strictly outside the
                // hull is below it.
                let o = orient3d(p(face[0]), p(face[1]), p(face[2]), p(apex));
                if o < 0 {
                    let fin = |u: usize| {
                        (self.slots[u].n[self.slots[u].v.iter().position(|&x| x == INFINITE).unwrap()] >> 2) as usize
                    };
                    return Err(ValidationError::NonConvexHull { a: fin(t), b: fin(n) });
                }
                if o == 0 && t < n {
                    rep.coplanar_hull_edges += 1;
                }
            }
        }
        // Counts: vertices, edges, faces.
        let mut used = vec![false; self.points.len()];
        let mut edges: Vec<u64> = Vec::with_capacity(nf * 6);
        for v in self.slots[..nf].iter().map(|s| &s.v) {
            for &x in v {
                used[x as usize] = true;
            }
            for a in 0..4 {
                for b in a + 1..4 {
                    let (x, y) = (v[a].min(v[b]), v[a].max(v[b]));
                    edges.push(((x as u64) << 32) | y as u64);
                }
            }
        }
        edges.sort_unstable();
        edges.dedup();
        rep.edges = edges.len();
        drop(edges);
        for (i, &r) in self.representative.iter().enumerate() {
            if r as usize == i && !used[i] {
                return Err(ValidationError::UnusedVertex(i));
            }
        }
        rep.vertices = used.iter().filter(|&&u| u).count();
        // Each finite tet has 4 faces; interior faces are counted twice, hull faces once.
        rep.faces = (4 * nf + rep.hull_faces) / 2;
        let (v, e, f, t) = (rep.vertices as i64, rep.edges as i64, rep.faces as i64, nf as i64);
        if v - e + f - t != 1 {
            return Err(ValidationError::Euler {
                what: "V - E + F - T",
                value: v - e + f - t,
                expected: 1,
            });
        }
        // Hull: F_h hull faces, E_h = 3 F_h / 2 hull edges, V_h hull vertices.
        let mut hull_v: Vec<u32> = self.slots[nf..]
            .iter()
            .flat_map(|s| s.v.into_iter().filter(|&x| x != INFINITE))
            .collect();
        hull_v.sort_unstable();
        hull_v.dedup();
        let fh = rep.hull_faces as i64;
        let chi = hull_v.len() as i64 - 3 * fh / 2 + fh;
        if 3 * fh % 2 != 0 || chi != 2 {
            return Err(ValidationError::Euler {
                what: "hull V - E + F",
                value: chi,
                expected: 2,
            });
        }
        Ok(rep)
    }
}
