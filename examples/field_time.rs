//! Times the clearance field on one model (issue 17): builds the cell complex once, then
//! builds `CellField::new` (the distance tree, every active cell's peak and every portal's
//! passage) `N` times (default 3) and prints each time and a fingerprint of the values'
//! bits (FNV-1a over the peaks and passages), so that two builds can be compared for speed
//! and for identity.
//!
//! With `REFINED=S` in the environment it also times `CellField::refined_passage` on every
//! `S`-th portal between active cells (in portal order, on one thread) and prints the time
//! and a fingerprint of the values' bits.
//!
//! `cargo run --release --example field_time -- MODEL [N]`

use portalfind::decimate::clearance::CellField;
use std::path::Path;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(model) = args.get(1) else {
        eprintln!("usage: field_time MODEL [N]");
        std::process::exit(2);
    };
    let n: usize = args.get(2).map_or(3, |s| s.parse().expect("N"));
    let m = portalfind::model::load_model(Path::new(model)).expect("model");
    let cx = portalfind::pipeline::complex_of_unchecked(&m).expect("complex");
    for i in 0..n {
        let t = Instant::now();
        let f = CellField::new(&cx);
        let s = t.elapsed().as_secs_f64();
        let mut fp: u64 = 0xcbf2_9ce4_8422_2325;
        for x in f.value.iter().chain(&f.passage) {
            fp ^= x.to_bits();
            fp = fp.wrapping_mul(0x100_0000_01b3);
        }
        println!("{model} run {i}: field {s:.3} s, fingerprint {fp:016x}");
        if let Some(stride) = std::env::var("REFINED").ok().and_then(|v| v.parse::<usize>().ok()) {
            let t = Instant::now();
            let (mut fp, mut count): (u64, usize) = (0xcbf2_9ce4_8422_2325, 0);
            for (k, p) in cx.portals.iter().enumerate().step_by(stride.max(1)) {
                if !p.cells.iter().all(|c| cx.cells[c.idx()].active()) {
                    continue;
                }
                fp ^= f.refined_passage(&cx, k).to_bits();
                fp = fp.wrapping_mul(0x100_0000_01b3);
                count += 1;
            }
            let s = t.elapsed().as_secs_f64();
            println!("{model} run {i}: {count} refined passages {s:.3} s, fingerprint {fp:016x}");
        }
    }
}
