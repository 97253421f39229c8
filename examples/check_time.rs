//! `check_time MODEL [REPEATS [valid|crossing|both]]`: the Delaunay complex of MODEL, then
//! the wall time of the pipeline's two structural checks (`check_valid`,
//! `check_no_crossing`) each alone, REPEATS times (default 3), interleaved. Set
//! `RAYON_NUM_THREADS` to compare thread counts. For instruction counts, run it under
//! `valgrind --tool=callgrind` with REPEATS 0 and with REPEATS 1 and one check: the
//! difference of the totals is that check's (rayon's workers run it off the main thread,
//! so per-function inclusive counts miss it).
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).expect("usage: check_time MODEL [REPEATS]");
    let repeats: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(3);
    let which = args.get(3).map_or("both", String::as_str);
    let (do_valid, do_cross) = (which != "crossing", which != "valid");
    let m = portalfind::model::load_model(std::path::Path::new(path)).expect("model");
    let t = portalfind::delaunay::Tetrahedralization::build(&m.vertices).expect("tetra");
    let cx = portalfind::complex::CellComplex::build(&m, &t);
    println!(
        "{path}: {} polygons, {} cells alive, {} patches, {} portals",
        m.polygons.len(),
        cx.cells.iter().filter(|c| c.alive).count(),
        cx.patches.len(),
        cx.portals.len()
    );
    for _ in 0..repeats {
        let t0 = Instant::now();
        let valid = if do_valid { cx.check_valid() } else { Ok(()) };
        let t_valid = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let crossing = if do_cross { cx.check_no_crossing(&m) } else { Ok(()) };
        let t_cross = t1.elapsed().as_secs_f64();
        println!(
            "check_valid {t_valid:.4} s ({}), check_no_crossing {t_cross:.4} s ({})",
            valid.map_or_else(|e| e.to_string(), |()| "ok".into()),
            crossing.map_or_else(|e| e.to_string(), |()| "ok".into()),
        );
    }
}
