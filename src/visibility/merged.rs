//! A merged portal as one object for engines: its convex pieces (a surface, possibly
//! non-planar) and one **convex planar polygon** standing in for it, for engines that accept
//! only convex portals (Godot's rooms and portals, Quake-style PRT consumers).
//!
//! The polygon lies on the plane through the pieces' area-weighted centroid, normal to their
//! area-weighted normal `n` (the pieces are oriented alike, from one cell into the other),
//! and is the convex hull of every piece vertex projected onto that plane along `n`. It
//! therefore contains each piece's orthogonal projection: for coplanar pieces it contains
//! the portal itself (a sight line through a piece crosses the polygon); for non-planar
//! ones, a line that crosses a piece at distance `d` from the plane, at angle `θ` from `n`,
//! crosses the plane within `d·tan θ` of the polygon, with `d ≤` [`ConvexPortal::thickness`]
//! (reported, so a consumer can inflate the polygon for its grazing angles).

use super::kgon::hull;
use super::walk::Ops;
use crate::base::vec::{P3, cross, dot, fan_normal, mean, norm, sub};

/// The convex stand-in of a merged portal.
#[derive(Clone, Debug, PartialEq)]
pub struct ConvexPortal {
    /// Vertices, counter-clockwise around `normal`.
    pub verts: Vec<P3>,
    /// Unit normal (the pieces' area-weighted normal).
    pub normal: P3,
    /// Largest distance of a piece vertex from the polygon's plane (0 for coplanar pieces,
    /// up to rounding).
    pub thickness: f64,
}

/// The convex polygon of a portal's pieces (see the module docs); `None` when the pieces'
/// normals cancel or their projection has no area.
pub fn convex_portal(pieces: &[Vec<P3>]) -> Option<ConvexPortal> {
    let mut nsum = [0.0; 3];
    let mut csum = [0.0; 3];
    let mut asum = 0.0;
    for q in pieces.iter().filter(|q| q.len() >= 3) {
        let n = fan_normal(q);
        let a = norm(&n);
        let c = mean(q);
        for k in 0..3 {
            nsum[k] += n[k];
            csum[k] += a * c[k];
        }
        asum += a;
    }
    let nl = norm(&nsum);
    if !(nl > 0.0 && asum > 0.0 && nl.is_finite()) {
        return None;
    }
    let n = nsum.map(|x| x / nl);
    let c = csum.map(|x| x / asum);
    // An orthonormal basis (u, v) of the plane with u × v = n.
    let k = (0..3).min_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs())).unwrap_or(0);
    let mut e = [0.0; 3];
    e[k] = 1.0;
    let u0 = cross(&e, &n);
    let ul = norm(&u0);
    let u = u0.map(|x| x / ul);
    let v = cross(&n, &u);
    let mut thickness: f64 = 0.0;
    let mut pts = Vec::new();
    for q in pieces {
        for p in q {
            let d = sub(p, &c);
            thickness = thickness.max(dot(&d, &n).abs());
            pts.push([dot(&d, &u), dot(&d, &v)]);
        }
    }
    let h = hull(&pts, &mut Ops::default());
    if h.len() < 3 {
        return None;
    }
    let verts = h
        .iter()
        .map(|s| std::array::from_fn(|i| c[i] + s[0] * u[i] + s[1] * v[i]))
        .collect();
    Some(ConvexPortal {
        verts,
        normal: n,
        thickness,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coplanar_pieces_give_their_hull_and_bent_ones_a_thickness() {
        // Two unit squares side by side on z = 1, normal +z: the hull is the 2 × 1 rectangle.
        let a = vec![[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.0, 1.0, 1.0]];
        let b = vec![[1.0, 0.0, 1.0], [2.0, 0.0, 1.0], [2.0, 1.0, 1.0], [1.0, 1.0, 1.0]];
        let p = convex_portal(&[a.clone(), b]).unwrap();
        assert_eq!(p.verts.len(), 4);
        assert!((p.normal[2] - 1.0).abs() < 1e-15);
        assert!(p.thickness < 1e-15);
        let area = 0.5 * norm(&fan_normal(&p.verts));
        assert!((area - 2.0).abs() < 1e-12, "{area}");
        assert!(
            dot(&fan_normal(&p.verts), &p.normal) > 0.0,
            "counter-clockwise around n"
        );
        // Bent: the second square turned up 90° about the shared edge x = 1.
        let c = vec![[1.0, 0.0, 1.0], [1.0, 0.0, 2.0], [1.0, 1.0, 2.0], [1.0, 1.0, 1.0]];
        let p = convex_portal(&[a, c]).unwrap();
        assert!(p.thickness > 0.3, "{}", p.thickness);
        // Every piece vertex projects into the polygon along the normal.
        for q in [[0.0, 0.0, 1.0], [1.0, 1.0, 2.0], [1.0, 0.0, 2.0]] {
            let d = dot(&sub(&q, &p.verts[0]), &p.normal);
            let r: P3 = std::array::from_fn(|i| q[i] - d * p.normal[i]);
            for i in 0..p.verts.len() {
                let (s, t) = (p.verts[i], p.verts[(i + 1) % p.verts.len()]);
                let side = dot(&cross(&sub(&t, &s), &sub(&r, &s)), &p.normal);
                assert!(side >= -1e-12, "{q:?} outside");
            }
        }
        // Opposite normals cancel: no polygon.
        let a = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
        let mut b = a.clone();
        b.reverse();
        assert!(convex_portal(&[a, b]).is_none());
    }
}
