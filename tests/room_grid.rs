//! The scalable room-grid building: one connected interior, no leak, every room reachable.

use portalfind::complex::CellComplex;
use portalfind::delaunay::Tetrahedralization;
use portalfind::generate::scenes::room_grid;
use portalfind::model::from_soup;

#[test]
fn room_grid_is_one_sealed_region() {
    let (s, centres) = room_grid(3, 2, 8);
    let m = from_soup("grid", s.vertices, s.polygons).unwrap();
    let t = Tetrahedralization::build(&m.vertices).unwrap();
    t.validate().unwrap();
    let cx = CellComplex::build(&m, &t);
    cx.validate(&m).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(cx.stats.leaks, 0, "{:?}", cx.stats);
    assert_eq!(cx.stats.interior_regions, 1, "{:?}", cx.stats);
    // Air volume: 6 rooms of 48 m³ plus 7 corridors of 1 m³.
    let vol: f64 = cx.active_cells().map(|(_, c)| c.volume()).sum();
    assert!((vol - (6.0 * 48.0 + 7.0)).abs() < 1e-6, "{vol}");
    // Every room centre lies in an active cell.
    let tol = cx.tol;
    for c in centres {
        assert!(cx.active_cells().any(|(_, cell)| cell.contains(&c, &tol)), "{c:?}");
    }
}
