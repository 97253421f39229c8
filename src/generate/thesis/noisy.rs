//! The noisy model (thesis 4.3.5): the tessellated rooms with vertex noise and furniture.

use std::collections::HashMap;

use super::ThesisModel;
use super::build::*;
use super::four_room::*;
use crate::base::rigid::rotate_z_deg;
use crate::base::rng::SplitMix64;
use crate::base::vec::{P3, add, lerp, scale};

/// A closed extruded prism (furniture), outward-facing: `profile` counter-clockwise in the
/// plane spanned by `ex` (first coordinate) and `ez` (second), extruded `depth` along `ey`.
pub(super) fn prism(b: &mut Builder, profile: &[[f64; 2]], origin: P3, ex: P3, ey: P3, ez: P3, depth: f64) {
    let at = |p: [f64; 2], d: f64| {
        add(
            &origin,
            &add(&add(&scale(&ex, p[0]), &scale(&ez, p[1])), &scale(&ey, d)),
        )
    };
    let front: Vec<u32> = profile.iter().map(|&p| b.v(at(p, 0.0))).collect();
    let back: Vec<u32> = profile.iter().map(|&p| b.v(at(p, depth))).collect();
    b.poly_dir(front.clone(), scale(&ey, -1.0));
    b.poly_dir(back.clone(), ey);
    for i in 0..profile.len() {
        let j = (i + 1) % profile.len();
        let d = [profile[j][0] - profile[i][0], profile[j][1] - profile[i][1]];
        let out = add(&scale(&ex, d[1]), &scale(&ez, -d[0]));
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
            v[k] += NOISE * rng.signed_unit();
        }
    }
    // Replace the south wall of room A by a grid four times finer in each direction, its
    // boundary on the noisy coarse edges, its inside displaced up to 0.12 m across the wall.
    let removed = b.soup.polygons.drain(wall.triangles.clone()).count();
    debug_assert!(removed > 0);
    let verts = b.soup.vertices.clone();
    let g = |i: usize, k: usize| verts[wall.grid[i][k] as usize];
    let normal = rotate_z_deg([0.0, 1.0, 0.0], PLANS[0].angle);
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
            let mut p = lerp(
                &lerp(&g(i, k), &g(i + 1, k), s),
                &lerp(&g(i, k + 1), &g(i + 1, k + 1), s),
                t,
            );
            // Boundary points stay on the coarse edges (T-junctions); inner ones move.
            if x != 0 && y != 0 && x != fi && y != fk {
                p = add(&p, &scale(&normal, 0.12 * rng.signed_unit()));
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
    let ex = rotate_z_deg([1.0, 0.0, 0.0], PLANS[0].angle);
    let ey = rotate_z_deg([0.0, 1.0, 0.0], PLANS[0].angle);
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
    prism(
        &mut b,
        &table,
        add(&rooms[0].at(0.35, 0.2, 0.0), &lift),
        ex,
        ey,
        ez,
        0.8,
    );
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
    let chair_origin = add(&rooms[0].at(0.62, 0.12, 0.0), &lift);
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
