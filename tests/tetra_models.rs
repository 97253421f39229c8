//! Tetrahedralization of real model files: golden counts and validate() on each.

use portalfind::delaunay::Tetrahedralization;
use portalfind::model::load_model;
use std::path::Path;

fn tetra(path: &str) -> (Tetrahedralization, portalfind::delaunay::ValidationReport) {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    let m = load_model(&p).unwrap_or_else(|e| panic!("{e}"));
    let t = Tetrahedralization::build(&m.vertices).expect("build");
    let r = t.validate().unwrap_or_else(|e| panic!("{path}: {e}"));
    (t, r)
}

#[test]
fn e1m1_golden_counts() {
    let (t, r) = tetra("models/quake/e1m1.obj");
    assert_eq!(r.vertices, 6822);
    assert_eq!(t.num_tets(), 41761);
    assert_eq!(t.num_hull_faces(), 544);
    // Quake geometry is full of exact ties (integer coordinates, axis-aligned walls).
    assert_eq!(r.cospherical_faces, 11872);
}

#[test]
fn e1m1_rotated_and_offset_keeps_every_vertex() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/quake/e1m1.obj");
    let m = load_model(&p).unwrap();
    let pts: Vec<[f64; 3]> = m
        .vertices
        .iter()
        .map(|&v| portalfind::base::rigid::rotate_789_offset(v))
        .collect();
    let t = Tetrahedralization::build(&pts).unwrap();
    let r = t.validate().unwrap();
    assert_eq!(r.vertices, 6822);
}

#[test]
fn cube_fixture() {
    let (t, r) = tetra("tests/fixtures/cube.obj");
    assert_eq!(r.vertices, 8);
    assert!(t.num_tets() == 5 || t.num_tets() == 6);
}
