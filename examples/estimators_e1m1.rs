//! The cheaper projected-area estimators (`bbox`, `hull`) against the exact `union` on a
//! real level (issue 17), and whether the decimation they drive differs.
//!
//! For each estimator, one decimation of the model with a thesis heuristic at its default
//! stop (`threshold:3`): collapses, final cells and portal pairs, collapse seconds, and
//! the length of the common prefix of its collapses with the `union` run's. Then, on the
//! partitions of the `union` run after 0, 10, …, 100 % of its collapses (rebuilt by replay),
//! up to `PAIRS` sampled portal pairs each: both cells' projected areas on the pair's
//! portal plane (the engine's frame: mean portal normal, largest piece's centroid) by all
//! three estimators, each cell's state built by folding its pieces with the estimator's
//! own `piece`/`absorb`; the relative error of `bbox` and `hull` against `union`.
//!
//! `cargo run --release --example estimators_e1m1 -- [MODEL] [HEURISTIC] [PAIRS]`
//! (defaults: `models/quake/e1m1.obj aspect 300`). Prints a Markdown report.

use portalfind::complex::CellComplex;
use portalfind::decimate::estimator::{AreaEstimator, Bbox, Hull, Union};
use portalfind::decimate::project::Frame;
use portalfind::decimate::{Decimation, Estimator, HeuristicKind, Partition, Settings};
use portalfind::ids::CellId;
use std::collections::HashMap;
use std::path::Path;

/// Projected area of a merged cell: its pieces folded into one estimator state.
fn area<E: AreaEstimator>(
    cx: &CellComplex,
    pieces: &[CellId],
    frame: &Frame,
    cache: &mut HashMap<CellId, E::State>,
) -> f64 {
    let state = cache.entry(pieces[0]).or_insert_with(|| {
        let mut s = E::piece(&cx.cells[pieces[0].idx()].poly);
        for p in &pieces[1..] {
            E::absorb(&mut s, E::piece(&cx.cells[p.idx()].poly));
        }
        s
    });
    let a = E::projected_area(state, frame);
    if a.is_finite() { a.max(0.0) } else { 0.0 }
}

fn quantile(xs: &mut [f64], q: f64) -> f64 {
    if xs.is_empty() {
        return f64::NAN;
    }
    xs.sort_by(f64::total_cmp);
    xs[((xs.len() - 1) as f64 * q).round() as usize]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let model = args.get(1).map(String::as_str).unwrap_or("models/quake/e1m1.obj");
    let h: HeuristicKind = args
        .get(2)
        .map(|s| s.parse().expect("heuristic"))
        .unwrap_or(HeuristicKind::Aspect);
    let pairs: usize = args.get(3).map(|s| s.parse().expect("pairs")).unwrap_or(300);
    let m = portalfind::model::load_model(Path::new(model)).expect("model");
    let cx = portalfind::pipeline::complex_of_unchecked(&m).expect("complex");
    let stop = h.default_stop();

    println!(
        "Model `{model}`, heuristic `{h}`, stop `{stop}`, {} active cells.\n",
        cx.active_cells().count()
    );
    println!(
        "| estimator | collapses | final cells | final portal pairs | common prefix with union (collapses) | collapse seconds |"
    );
    println!("|---|---:|---:|---:|---:|---:|");
    let runs: Vec<(Estimator, Decimation)> = Estimator::ALL
        .iter()
        .map(|&e| {
            let settings = Settings {
                heuristic: h,
                estimator: e,
                stop,
                ..Settings::default()
            };
            (e, Decimation::run(&cx, &settings))
        })
        .collect();
    let union = &runs.iter().find(|r| r.0 == Estimator::Union).expect("union").1;
    for (e, d) in &runs {
        let common = d
            .steps
            .iter()
            .zip(&union.steps)
            .take_while(|(a, b)| (a.a, a.b) == (b.a, b.b))
            .count();
        println!(
            "| {e} | {} | {} | {} | {common} | {:.2} |",
            d.steps.len(),
            d.partition.len(),
            d.partition.portals(&cx).len(),
            d.stats.collapse_seconds
        );
    }

    // Errors on the union run's partitions.
    let mut rel: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    let mut signed: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    let mut rng = portalfind::base::rng::SplitMix64(17);
    let n = union.steps.len();
    for tenth in 0..=10 {
        let part: Partition = Decimation::replay(&cx, &union.steps[..n * tenth / 10]).expect("replay");
        let portals = part.portals(&cx);
        let (mut cb, mut ch, mut cu) = (HashMap::new(), HashMap::new(), HashMap::new());
        for _ in 0..pairs.min(portals.len()) {
            let mp = &portals[rng.below(portals.len())];
            let Some(largest) = mp
                .pieces
                .iter()
                .fold(None, |m: Option<&portalfind::geom::ConvexPolygon>, q| match m {
                    Some(b) if b.area() >= q.area() => Some(b),
                    _ => Some(q),
                })
            else {
                continue;
            };
            let Some(frame) = Frame::new(mp.mean_normal, largest.centroid()) else {
                continue;
            };
            for c in mp.cells {
                let Some(i) = part.cell_of(c) else { continue };
                let pieces = &part.cells[i].pieces;
                let exact = area::<Union>(&cx, pieces, &frame, &mut cu);
                if exact.is_nan() || exact <= 0.0 {
                    continue;
                }
                let est = [
                    area::<Bbox>(&cx, pieces, &frame, &mut cb),
                    area::<Hull>(&cx, pieces, &frame, &mut ch),
                ];
                for (k, a) in est.iter().enumerate() {
                    rel[k].push((a - exact).abs() / exact);
                    signed[k].push((a - exact) / exact);
                }
            }
        }
    }
    println!(
        "\nRelative error against `union` ({} cell measurements: both cells of up to {pairs} sampled portal pairs on each of the union run's partitions after 0, 10, …, 100 % of its collapses):\n",
        rel[0].len()
    );
    println!("| estimator | relative error median | p90 | max | signed median |");
    println!("|---|---:|---:|---:|---:|");
    for (k, name) in ["bbox", "hull"].iter().enumerate() {
        let max = rel[k].iter().copied().fold(0.0, f64::max);
        println!(
            "| {name} | {:.4} | {:.4} | {:.4} | {:+.4} |",
            quantile(&mut rel[k], 0.5),
            quantile(&mut rel[k], 0.9),
            max,
            quantile(&mut signed[k], 0.5)
        );
    }
}
