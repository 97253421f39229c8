//! Diagnostics for one fuzz find: `cargo run --release --example diag_fuzz -- FILE.obj`:
//! both subdivisions' stats, check_valid and validate.
//! `diag_fuzz --time-check MODEL [REPEATS]`: the Delaunay complex of MODEL, then the
//! wall time of `check_valid` and of the two passes it added (patches' cells, portals),
//! interleaved, REPEATS times (default 5).
use std::time::Instant;

fn time_check(path: &str, repeats: usize) {
    let m = portalfind::model::load_model(std::path::Path::new(path)).expect("model");
    let t = portalfind::delaunay::Tetrahedralization::build(&m.vertices).expect("tetra");
    let cx = portalfind::complex::CellComplex::build(&m, &t);
    println!(
        "{path}: {} cells alive, {} patches, {} portals",
        cx.cells.iter().filter(|c| c.alive).count(),
        cx.patches.len(),
        cx.portals.len()
    );
    for _ in 0..repeats {
        let t0 = Instant::now();
        let all = cx.check_valid();
        let t_all = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let added = cx.check_patch_cells().and_then(|()| cx.check_portals());
        let t_added = t1.elapsed().as_secs_f64();
        println!(
            "check_valid {t_all:.4} s ({}), of which the added passes {t_added:.4} s ({})",
            if all.is_ok() { "ok" } else { "err" },
            if added.is_ok() { "ok" } else { "err" }
        );
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("--time-check") {
        let n = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(5);
        return time_check(&args[2], n);
    }
    let p = args.get(1).expect("file");
    let text = std::fs::read_to_string(p).expect("read");
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
