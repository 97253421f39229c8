//! Diagnostics for one fuzz find: `cargo run --release --example diag_fuzz -- FILE.obj`:
//! both subdivisions' stats, check_valid and validate.
fn main() {
    let p = std::env::args().nth(1).expect("file");
    let text = std::fs::read_to_string(&p).expect("read");
    let m = match portalfind::model::parse_obj_str("fuzz.obj", &text) {
        Ok(m) => m,
        Err(e) => return println!("refused: {e}"),
    };
    println!(
        "{} vertices, {} polygons, scale {:e}",
        m.vertices.len(),
        m.polygons.len(),
        m.tolerances.scale
    );
    let (cx, st) = portalfind::bsp::build_complex(&m);
    println!(
        "bsp: nodes {} splitting {} sealing {} leaves {} refused {} thin sealed {}",
        st.nodes, st.splitting_nodes, st.sealing_cuts, st.leaves, cx.stats.splits_refused, st.thin_leaves_sealed
    );
    println!("  check_valid: {:?}", cx.check_valid().err().map(|e| e.to_string()));
    println!("  validate: {:?}", cx.validate(&m).err().map(|e| e.to_string()));
    let t = portalfind::delaunay::Tetrahedralization::build(&m.vertices).expect("tetra");
    let cx = portalfind::complex::CellComplex::build(&m, &t);
    println!(
        "delaunay: split {} refused {} sealed {} unplaced {}",
        cx.stats.cells_split, cx.stats.splits_refused, cx.stats.cells_sealed, cx.stats.unplaced_fragments
    );
    println!("  check_valid: {:?}", cx.check_valid().err().map(|e| e.to_string()));
    println!("  validate: {:?}", cx.validate(&m).err().map(|e| e.to_string()));
}
