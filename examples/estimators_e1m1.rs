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
//! `cargo run --release --example estimators_e1m1 -- [--csv FILE] [--heuristic H] [--pairs N] [MODEL…]`
//! (defaults: `aspect`, 300, `models/quake/e1m1.obj`). Prints a Markdown report per model
//! (the errors also on the initial pairs alone, the partition before any collapse) and
//! writes one CSV row per model and estimator.

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
        let mut s = E::piece(&cx.cells[pieces[0].idx()].poly());
        for p in &pieces[1..] {
            E::absorb(&mut s, E::piece(&cx.cells[p.idx()].poly()));
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
    // `[--csv FILE] [--heuristic H] [--pairs N] [MODEL…]`
    let mut args = std::env::args().skip(1);
    let (mut csv, mut h, mut pairs, mut models) = (None, HeuristicKind::Aspect, 300usize, Vec::new());
    while let Some(a) = args.next() {
        match a.as_str() {
            "--csv" => csv = args.next(),
            "--heuristic" => h = args.next().expect("heuristic").parse().expect("heuristic"),
            "--pairs" => pairs = args.next().expect("pairs").parse().expect("pairs"),
            _ => models.push(a),
        }
    }
    if models.is_empty() {
        models.push("models/quake/e1m1.obj".to_string());
    }
    let mut rows = vec![
        "model,heuristic,estimator,collapses,final_cells,final_portal_pairs,common_prefix,same_final_cells,collapse_seconds,samples,rel_error_median,rel_error_p90,rel_error_max,signed_error_median,initial_rel_error_median,initial_rel_error_p90".to_string(),
    ];
    for model in &models {
        rows.extend(one_model(model, h, pairs));
    }
    if let Some(path) = csv {
        std::fs::write(&path, rows.join("\n") + "\n").expect("write csv");
        println!("\nwrote {path}");
    }
}

/// The report for one model; returns its CSV rows.
fn one_model(model: &str, h: HeuristicKind, pairs: usize) -> Vec<String> {
    let m = portalfind::model::load_model(Path::new(model)).expect("model");
    let cx = portalfind::pipeline::complex_of_unchecked(&m).expect("complex");
    let stop = h.default_stop();

    println!(
        "## `{model}`\n\nHeuristic `{h}`, stop `{stop}`, {} active cells.\n",
        cx.active_cells().count()
    );
    println!(
        "| estimator | collapses | final cells | final portal pairs | common prefix with union (collapses) | final cells equal to a union-run cell | collapse seconds |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
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
    let mut decided = Vec::new();
    for (e, d) in &runs {
        let common = d
            .steps
            .iter()
            .zip(&union.steps)
            .take_while(|(a, b)| (a.a, a.b) == (b.a, b.b))
            .count();
        let portals = d.partition.portals(&cx).len();
        // Final cells that are also final cells of the union run (the same pieces).
        let same = d
            .partition
            .cells
            .iter()
            .filter(|c| {
                union
                    .partition
                    .cell_of(c.id)
                    .is_some_and(|i| union.partition.cells[i].pieces == c.pieces)
            })
            .count();
        println!(
            "| {e} | {} | {} | {portals} | {common} | {same} | {:.2} |",
            d.steps.len(),
            d.partition.len(),
            d.stats.collapse_seconds
        );
        decided.push((
            *e,
            d.steps.len(),
            d.partition.len(),
            portals,
            common,
            same,
            d.stats.collapse_seconds,
        ));
    }

    // Errors on the union run's partitions.
    let mut rel: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    let mut signed: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
    // The initial pairs alone (the partition before any collapse).
    let mut initial: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
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
                    if tenth == 0 {
                        initial[k].push((a - exact).abs() / exact);
                    }
                }
            }
        }
    }
    println!(
        "\nRelative error against `union` ({} cell measurements: both cells of up to {pairs} sampled portal pairs on each of the union run's partitions after 0, 10, …, 100 % of its collapses):\n",
        rel[0].len()
    );
    println!("| estimator | relative error median | p90 | max | signed median | initial pairs only: median | p90 |");
    println!("|---|---:|---:|---:|---:|---:|---:|");
    let mut rows = Vec::new();
    for (e, collapses, cells, portals, common, same, secs) in decided {
        let k = match e {
            Estimator::Bbox => 0,
            Estimator::Hull => 1,
            Estimator::Union => {
                rows.push(format!(
                    "{model},{h},{e},{collapses},{cells},{portals},{common},{same},{secs:.3},,,,,,,"
                ));
                continue;
            }
        };
        let max = rel[k].iter().copied().fold(0.0, f64::max);
        let (med, p90, smed) = (
            quantile(&mut rel[k], 0.5),
            quantile(&mut rel[k], 0.9),
            quantile(&mut signed[k], 0.5),
        );
        let (imed, ip90) = (quantile(&mut initial[k], 0.5), quantile(&mut initial[k], 0.9));
        println!("| {e} | {med:.4} | {p90:.4} | {max:.4} | {smed:+.4} | {imed:.4} | {ip90:.4} |");
        rows.push(format!(
            "{model},{h},{e},{collapses},{cells},{portals},{common},{same},{secs:.3},{},{med},{p90},{max},{smed},{imed},{ip90}",
            rel[k].len()
        ));
    }
    println!();
    rows
}
