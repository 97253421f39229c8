//! Cell complex on hand-made models and on e1m1: validate() after building, and counts.

use portalfind::complex::CellComplex;
use portalfind::delaunay::Tetrahedralization;
use portalfind::model::{Model, from_soup, load_model};
use portalfind::scenes::{self, Soup};

fn build(s: &Soup) -> (Model, CellComplex) {
    let m = from_soup("test", s.vertices.clone(), s.polygons.clone()).expect("model");
    let t = Tetrahedralization::build(&m.vertices).expect("tetra");
    t.validate().expect("tetra validate");
    let cx = CellComplex::build(&m, &t);
    cx.validate(&m).unwrap_or_else(|e| panic!("complex validate: {e}"));
    (m, cx)
}

fn active_volume(cx: &CellComplex) -> f64 {
    cx.active_cells().map(|(_, c)| c.poly.volume()).sum()
}

fn rot_offset(s: &Soup) -> Soup {
    s.clone().map(|p| {
        let r = portalfind::bench::rotate_789(p);
        [r[0] + 1e6, r[1] + 1e6, r[2] + 1e6]
    })
}

#[test]
fn one_box_room() {
    let (_, cx) = build(&scenes::box_room());
    assert_eq!(cx.stats.interior_regions, 1);
    assert_eq!(cx.stats.leaks, 0);
    assert!((active_volume(&cx) - 48.0).abs() < 1e-9, "{}", active_volume(&cx));
}

#[test]
fn two_rooms_joined_by_a_door() {
    let (_, cx) = build(&scenes::two_rooms());
    // One connected region: both rooms and the corridor; the inside of the wall is gone.
    assert_eq!(cx.stats.interior_regions, 1);
    assert_eq!(cx.stats.leaks, 0);
    assert!(cx.stats.exterior_cells_removed > 0);
    assert!((active_volume(&cx) - 98.0).abs() < 1e-6, "{}", active_volume(&cx));
}

#[test]
fn two_rooms_rotated_and_offset_agree() {
    let (_, a) = build(&scenes::two_rooms());
    let (_, b) = build(&rot_offset(&scenes::two_rooms()));
    assert_eq!(a.stats.interior_regions, b.stats.interior_regions);
    assert_eq!(a.stats.leaks, b.stats.leaks);
    assert!((active_volume(&a) - active_volume(&b)).abs() < 1e-6 * 98.0);
}

#[test]
fn leaky_room_is_reported() {
    let mut s = scenes::box_room();
    s.polygons.remove(1); // the +x wall
    let (_, cx) = build(&s);
    assert_eq!(cx.stats.leaks, 1);
    let l = &cx.leaks[0];
    // The hull point is on the missing wall, x = 4.
    assert!((l.hull_point[0] - 4.0).abs() < 1e-9, "{:?}", l.hull_point);
}

#[test]
fn outward_facing_solid_is_removed() {
    // A pillar (faces outward) inside a room: the pillar's inside faces no occluder.
    let mut s = Soup::default();
    s.boxed([0.0, 0.0, 0.0], [6.0, 6.0, 3.0], true);
    s.boxed([2.0, 2.0, 0.5], [3.0, 3.5, 2.5], false);
    let (_, cx) = build(&s);
    assert_eq!(cx.stats.interior_regions, 1);
    assert!(
        (active_volume(&cx) - (108.0 - 3.0)).abs() < 1e-6,
        "{}",
        active_volume(&cx)
    );
    // Only outward faces: everything is removed.
    let mut solid = Soup::default();
    solid.boxed([0.0, 0.0, 0.0], [1.0, 1.0, 1.0], false);
    let (_, cx) = build(&solid);
    assert_eq!(cx.stats.active_cells, 0);
}

#[test]
fn walls_crossing_many_tetrahedra() {
    // A room with a table and a free-standing partition: big quads that cut many cells.
    let mut s = Soup::default();
    s.boxed([0.0, 0.0, 0.0], [10.0, 8.0, 3.0], true);
    s.boxed([1.0, 1.0, 0.7], [2.3, 1.9, 0.8], false); // table top
    s.boxed([6.0, 2.0, 0.4], [6.2, 5.0, 2.6], false); // free-standing panel
    // A large window-less wall quad at x = 8 from floor to ceiling facing -x, and a
    // second room behind it up to x = 10 closed by its own walls: the quad's plane cuts
    // the tetrahedra spanning the whole box.
    s.rect(0, 8.0, (0.0, 8.0), (0.0, 3.0), false);
    s.rect(0, 8.01, (0.0, 8.0), (0.0, 3.0), true);
    let (_, r) = build(&rot_offset(&s));
    let (_, cx) = build(&s);
    assert_eq!(r.stats.interior_regions, 3, "{:?}", r.stats);
    assert_eq!(r.stats.leaks, 0);
    assert!(cx.stats.polygons_clipped > 0);
    assert!(cx.stats.cells_split > 0, "{:?}", cx.stats);
    // Three regions: the two rooms, and the 1 cm slab between the wall pair, which the
    // big box's floor, ceiling and side walls face (the method keeps any region that
    // faces an occluder).
    assert_eq!(cx.stats.interior_regions, 3, "{:?}", cx.stats);
    let expect = 240.0 - 1.3 * 0.9 * 0.1 - 0.2 * 3.0 * 2.2;
    assert!(
        (active_volume(&cx) - expect).abs() < 1e-6,
        "{} vs {expect}",
        active_volume(&cx)
    );
}

#[test]
fn two_rooms_offset_agree() {
    let (_, a) = build(&scenes::two_rooms());
    let (_, b) = build(&scenes::two_rooms().map(|p| [p[0] + 1e6, p[1] + 1e6, p[2] + 1e6]));
    assert_eq!(a.stats.interior_regions, b.stats.interior_regions);
    assert_eq!(a.stats.leaks, b.stats.leaks);
    assert!((active_volume(&a) - active_volume(&b)).abs() < 1e-6 * 98.0);
}

#[test]
fn t_junction_heavy_wall_does_not_leak() {
    // The +x wall is one big quad on the lower half and many small quads on the upper half
    // whose vertices sit on each other's edges and on the big quad's edge (T-junctions).
    let mut s = Soup::default();
    s.rect(2, 0.0, (0.0, 4.0), (0.0, 4.0), true);
    s.rect(2, 3.0, (0.0, 4.0), (0.0, 4.0), false);
    s.rect(1, 0.0, (0.0, 3.0), (0.0, 4.0), true);
    s.rect(1, 4.0, (0.0, 3.0), (0.0, 4.0), false);
    s.rect(0, 0.0, (0.0, 4.0), (0.0, 3.0), true);
    s.rect(0, 4.0, (0.0, 4.0), (0.0, 1.5), false);
    for k in 0..7 {
        let y0 = k as f64 * 4.0 / 7.0;
        s.rect(0, 4.0, (y0, y0 + 4.0 / 7.0), (1.5, 3.0), false);
    }
    let (m, cx) = build(&s);
    assert!(m.report.t_junctions > 0);
    assert_eq!(cx.stats.leaks, 0);
    assert_eq!(cx.stats.interior_regions, 1);
    assert!((active_volume(&cx) - 48.0).abs() < 1e-6);
}

#[test]
fn e1m1_builds_and_validates() {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/quake/e1m1.obj");
    let m = load_model(&p).unwrap();
    let t = Tetrahedralization::build(&m.vertices).unwrap();
    let cx = CellComplex::build(&m, &t);
    cx.validate(&m).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(cx.stats.tetrahedra, 41761);
    assert!(cx.stats.polygons_conforming > 4000, "{}", cx.stats.polygons_conforming);
    assert!(cx.stats.active_cells > 0);
}
