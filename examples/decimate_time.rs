//! One decimation per configuration on one model, in this process, for profiling and
//! comparing builds (issue 17): builds the cell complex once, then for each
//! `HEURISTIC/ESTIMATOR/STOP` argument runs `Decimation::run` and prints the collapses,
//! final cells, weights computed, initial-weight and collapse seconds, and a fingerprint
//! of the steps (FNV-1a over each step's cells and weight bits), so that two builds can be
//! compared decision for decision.
//!
//! A spec ending in `+curve` runs `Decimation::run_with_curve` (what `portalfind run` does:
//! the stopped run and the weight curve to the end) and adds the curve's steps to the
//! fingerprint.
//!
//! The complex has its cell volumes cached, as `run` has it when it decimates.
//!
//! `cargo run --release --example decimate_time -- MODEL aspect/union/threshold:3 aspect/union/none …`

use portalfind::decimate::{Decimation, Estimator, HeuristicKind, Settings, StopRule};
use std::path::Path;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(model) = args.get(1) else {
        eprintln!("usage: decimate_time MODEL HEURISTIC/ESTIMATOR/STOP...");
        std::process::exit(2);
    };
    let t = Instant::now();
    let m = portalfind::model::load_model(Path::new(model)).expect("model");
    let mut cx = portalfind::pipeline::complex_of_unchecked(&m).expect("complex");
    // As `run` has it before decimating: each cell's volume computed once (the gate's
    // core cut sums its sides' volumes; without the cache a profile shows work `run`
    // does not do).
    cx.cache_volumes();
    println!(
        "{model}: {} active cells, complex {:.2} s",
        cx.active_cells().count(),
        t.elapsed().as_secs_f64()
    );
    for spec in &args[2..] {
        let (body, curve) = match spec.strip_suffix("+curve") {
            Some(b) => (b, true),
            None => (spec.as_str(), false),
        };
        let parts: Vec<&str> = body.splitn(3, '/').collect();
        let [h, e, s] = parts[..] else {
            eprintln!("bad spec {spec}");
            std::process::exit(2);
        };
        let heuristic: HeuristicKind = h.parse().expect("heuristic");
        let estimator: Estimator = e.parse().expect("estimator");
        let stop: StopRule = s.parse().expect("stop");
        let settings = Settings {
            heuristic,
            estimator,
            stop,
            ..Settings::default()
        };
        let t = Instant::now();
        let (d, full) = if curve {
            Decimation::run_with_curve(&cx, &settings, &mut |_, _| {})
        } else {
            (Decimation::run(&cx, &settings), None)
        };
        let wall = t.elapsed().as_secs_f64();
        let mut fp: u64 = 0xcbf2_9ce4_8422_2325;
        for st in d.steps.iter().chain(full.iter().flatten()) {
            for x in [st.a.0 as u64, st.b.0 as u64, st.weight.to_bits()] {
                for b in x.to_le_bytes() {
                    fp = (fp ^ b as u64).wrapping_mul(0x0100_0000_01b3);
                }
            }
        }
        println!(
            "{spec}: collapses {} final cells {} weights {} skipped {} init {:.3} s collapses {:.3} s total {:.3} s stop {} fingerprint {fp:016x}",
            d.steps.len(),
            d.partition.len(),
            d.stats.weights_computed,
            d.stats.reweighs_skipped,
            d.stats.init_seconds,
            d.stats.collapse_seconds,
            wall,
            d.stop
        );
    }
}
