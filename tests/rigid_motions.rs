//! Why active-cell counts move under rigid motions (issue 16): the cause is the Delaunay
//! tetrahedralization, not the cell complex. A moved model's own tetrahedralization differs
//! (cospherical ties are broken by a perturbation keyed to the lexicographic order, which
//! motions change; rounding decides near-ties); the complex built on the *unmoved*
//! tetrahedralization with moved coordinates reproduces the unmoved counts exactly.
//! `examples/rigid_cause.rs` runs this over every stress model and rigid variant
//! (`results/stress/rigid_cause/`).
use portalfind::complex::CellComplex;
use portalfind::delaunay::Tetrahedralization;
use portalfind::model::{Model, from_soup};
use portalfind::suite::stress::{Variant, apply};
use portalfind::suite::{Family, case};

fn complex(m: &Model, t: &Tetrahedralization) -> CellComplex {
    let mut cx = CellComplex::build(m, t);
    cx.seal_cracks_auto(m);
    cx.validate(m).expect("valid complex");
    cx
}

/// The multi-storey building offset by 1e3: its own tetrahedralization differs from the
/// unmoved one (and so does the active-cell count, 5,688 against 5,640 when measured); on
/// the unmoved tetrahedralization moved, the complex has the unmoved counts.
#[test]
fn the_complex_is_motion_invariant_on_a_fixed_tetrahedralization() {
    let c = case(Family::MultiStorey, 1).expect("suite case");
    let m0 = from_soup(&c.name, c.model.vertices.clone(), c.model.polygons.clone()).unwrap();
    let t0 = Tetrahedralization::build(&m0.vertices).unwrap();
    let cx0 = complex(&m0, &t0);

    let (vs, ps) = apply(Variant::Offset(1e3), &c.model.vertices, &c.model.polygons);
    let m1 = from_soup(&c.name, vs, ps).unwrap();
    assert_eq!(m1.vertices.len(), m0.vertices.len());
    let t1 = Tetrahedralization::build(&m1.vertices).unwrap();
    assert_ne!(
        t1.sorted_tets(),
        t0.sorted_tets(),
        "the offset changes the tetrahedralization (the cause)"
    );

    let moved = t0.moved(&m1.vertices).expect("the offset inverts no tetrahedron here");
    assert_eq!(moved.points(), &m1.vertices[..]);
    let cx1 = complex(&m1, &moved);
    assert_eq!(cx1.stats.cells_after_split, cx0.stats.cells_after_split);
    assert_eq!(cx1.stats.active_cells, cx0.stats.active_cells);
    assert_eq!(cx1.stats.portal_pairs, cx0.stats.portal_pairs);
    assert_eq!(cx1.stats.interior_regions, cx0.stats.interior_regions);
    // The cells really sit at the moved coordinates.
    let x = |cx: &CellComplex| {
        let c = cx.cells.iter().find(|c| c.active()).unwrap();
        c.poly().faces[0].verts[0][0]
    };
    assert!((x(&cx1) - x(&cx0) - 1e3).abs() < 1e-6);
}
