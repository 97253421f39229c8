//! Regression tests for the shrunk fuzz finds in `tests/data/fuzz_finds/` (see its
//! README): each model must either be refused at load with a typed error, or give a cell
//! complex that validates, in bounded time.

use portalfind::complex::CellComplex;
use portalfind::delaunay::Tetrahedralization;
use portalfind::model::load_model;
use std::path::PathBuf;
use std::time::Instant;

fn path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/fuzz_finds")
        .join(name)
}

/// Loads and builds; `Ok(None)` when the loader refused the file.
fn build(name: &str) -> Result<Option<CellComplex>, String> {
    let m = match load_model(&path(name)) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("{name}: refused at load: {e}");
            return Ok(None);
        }
    };
    let t = Tetrahedralization::build(&m.vertices).map_err(|e| e.to_string())?;
    let cx = CellComplex::build(&m, &t);
    cx.validate(&m).map_err(|e| format!("{name}: {e}"))?;
    Ok(Some(cx))
}

fn check(name: &str) {
    let t0 = Instant::now();
    if let Err(e) = build(name) {
        panic!("{e}");
    }
    eprintln!("{name}: {:.2} s", t0.elapsed().as_secs_f64());
}

#[test]
fn open_edge() {
    check("open_edge.obj");
}

#[test]
fn edge_used_twice() {
    check("edge_used_twice.obj");
}

#[test]
fn face_repeats_vertex() {
    check("face_repeats_vertex.obj");
}

#[test]
fn vertex_in_front_of_face() {
    check("vertex_in_front_of_face.obj");
}

#[test]
fn polygon_crosses_cell() {
    check("polygon_crosses_cell.obj");
}
