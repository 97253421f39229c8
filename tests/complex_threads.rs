//! The complex's stages and checks run on rayon; their results must not depend on the
//! thread count: ids, geometry bits, portal order, counts and the first error reported.

use portalfind::complex::CellComplex;
use portalfind::delaunay::Tetrahedralization;
use portalfind::generate::scenes::room_grid;
use portalfind::model::{Model, from_soup, load_model};
use std::path::PathBuf;

fn on<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(f)
}

fn model(name: &str) -> Model {
    load_model(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(name)).unwrap()
}

/// Everything the build produced except timings and memory, with every float in a form that differs
/// whenever its bits do (`{:?}` prints the shortest string that reads back to the same
/// bits).
fn fingerprint(cx: &CellComplex) -> String {
    let mut stats = cx.stats.clone();
    stats.timings.clear();
    stats.memory.clear();
    format!(
        "{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}",
        cx.cells,
        cx.patches,
        cx.portals,
        cx.cracks,
        cx.leaks,
        stats,
        cx.hull_volume.to_bits(),
        cx.polygon_planes
    )
}

fn build(m: &Model) -> CellComplex {
    let t = Tetrahedralization::build(&m.vertices).unwrap();
    CellComplex::build(m, &t)
}

#[test]
fn complex_does_not_depend_on_the_thread_count() {
    let (s, _) = room_grid(3, 2, 8);
    let grid = from_soup("grid", s.vertices, s.polygons).unwrap();
    // The noisy thesis model has splits, sealed cracks, membranes and crack links; the
    // grid has hull patches and large portal pieces.
    for (name, m) in [("grid", grid), ("noisy", model("models/thesis/noisy.obj"))] {
        let one = on(1, || build(&m));
        let two = on(2, || build(&m));
        assert!(one.stats.cells_split > 0 || name == "grid", "{name}: {:?}", one.stats);
        assert_eq!(fingerprint(&one), fingerprint(&two), "{name}");
        // The checks pass alike.
        for cx in [&one, &two] {
            on(2, || cx.check_valid()).unwrap();
            on(2, || cx.check_no_crossing(&m)).unwrap();
        }
    }
}

/// On a complex that fails, the checks name the same cell (the smallest id) on one
/// thread and on several.
#[test]
fn checks_report_the_same_first_error_on_any_thread_count() {
    // A model polygon added after the build crosses the cells of the thesis rooms: many
    // cells are crossed, and the error must name the first.
    let m = model("models/thesis/four_room_optimized.obj");
    let cx = build(&m);
    let (lo, hi) = m.bbox();
    let mid = |k: usize, f: f64| lo[k] + f * (hi[k] - lo[k]);
    let mut vs = m.vertices.clone();
    let k = vs.len() as u32;
    let x = mid(0, 0.37);
    vs.extend([
        [x, mid(1, 0.05), mid(2, 0.1)],
        [x, mid(1, 0.95), mid(2, 0.1)],
        [x, mid(1, 0.95), mid(2, 0.9)],
        [x, mid(1, 0.05), mid(2, 0.9)],
    ]);
    let mut ps: Vec<Vec<u32>> = m
        .polygons
        .iter()
        .map(|p| p.verts.iter().map(|v| v.0).collect())
        .collect();
    ps.push(vec![k, k + 1, k + 2, k + 3]);
    let m2 = from_soup("crossed", vs, ps).unwrap();
    let one = on(1, || cx.check_no_crossing(&m2)).expect_err("a wall through the rooms");
    for threads in [2, 3] {
        let many = on(threads, || cx.check_no_crossing(&m2)).unwrap_err();
        assert_eq!(one, many, "{threads} threads");
    }
    // check_valid on a corrupted complex: two cells made to name a patch twice.
    let mut bad = cx.clone();
    let alive: Vec<usize> = (0..bad.cells.len()).filter(|&i| bad.cells[i].alive).collect();
    for &i in [alive[alive.len() / 3], alive[2 * alive.len() / 3]].iter() {
        let t = bad.cells[i].tags()[0];
        bad.cells[i].poly_mut().tags[1] = t;
    }
    let one = on(1, || bad.check_valid()).unwrap_err();
    let two = on(2, || bad.check_valid()).unwrap_err();
    assert_eq!(one, two);
    assert!(
        one.to_string().contains(&format!("cell {}", alive[alive.len() / 3])),
        "{one}"
    );
}
