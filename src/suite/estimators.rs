//! The projected-area estimators' error against the exact union, on the same pairs
//! (issue 15: "include the estimators' area error against the exact union on the same
//! pairs"). On a few suite models, the cells are the partition halfway through the
//! `clearance` merge (merged, non-convex cells of every size); for sampled neighbouring
//! pairs, each cell's projected area on the pair's portal plane is measured by every
//! estimator from scratch ([`projected_area_direct`]) and timed.

use super::SuiteCase;
use super::bench::SuiteError;
use crate::base::rng::SplitMix64;
use crate::decimate::estimator::projected_area_direct;
use crate::decimate::project::Frame;
use crate::decimate::{Decimation, Estimator, HeuristicKind, Settings, StopRule};
use crate::geom::ConvexPolyhedron;
use serde::Serialize;
use std::fmt::Write as _;
use std::time::Instant;

/// The error of one estimator against `union` over all sampled cells.
#[derive(Clone, Debug, Serialize)]
pub struct EstimatorRow {
    /// Estimator name.
    pub estimator: String,
    /// Models.
    pub models: usize,
    /// Measured cells (two per pair).
    pub samples: usize,
    /// Median of |A − A_union| / A_union.
    pub rel_error_median: f64,
    /// 90th percentile of the same.
    pub rel_error_p90: f64,
    /// Median of (A − A_union) / A_union (signed: bbox and hull over-estimate).
    pub signed_error_median: f64,
    /// Mean microseconds per call (from scratch, one cell on one plane).
    pub micros_per_call: f64,
}

fn quantile(xs: &mut [f64], q: f64) -> f64 {
    if xs.is_empty() {
        return 0.0;
    }
    xs.sort_by(f64::total_cmp);
    xs[((xs.len() - 1) as f64 * q).round() as usize]
}

/// Measures the estimators on up to `pairs` sampled pairs of each case.
pub fn estimator_errors(cases: &[&SuiteCase], pairs: usize, seed: u64) -> Result<Vec<EstimatorRow>, SuiteError> {
    let mut rel: Vec<Vec<f64>> = vec![Vec::new(); Estimator::ALL.len()];
    let mut signed: Vec<Vec<f64>> = vec![Vec::new(); Estimator::ALL.len()];
    let mut secs = vec![0.0f64; Estimator::ALL.len()];
    for case in cases {
        let model = case.load().map_err(|e| SuiteError::Load {
            case: case.name.clone(),
            source: Box::new(e),
        })?;
        let cx = crate::pipeline::complex_of_unchecked(&model).map_err(|source| SuiteError::Cells {
            case: case.name.clone(),
            source,
        })?;
        let full = Decimation::run(
            &cx,
            &Settings {
                heuristic: HeuristicKind::Clearance,
                stop: StopRule::Threshold(crate::decimate::clearance::DEFAULT_RATIO),
                ..Settings::default()
            },
        );
        let part = Decimation::replay(&cx, &full.steps[..full.steps.len() / 2]).expect("a prefix of the run's steps");
        let portals = part.portals(&cx);
        let mut rng = SplitMix64(seed ^ case.seed.wrapping_mul(0x9E37_79B9));
        for _ in 0..pairs.min(portals.len()) {
            let mp = &portals[rng.below(portals.len())];
            let Some(largest) = mp.pieces.iter().max_by(|a, b| a.area().total_cmp(&b.area())) else {
                continue;
            };
            let Some(frame) = Frame::new(mp.mean_normal, largest.centroid()) else {
                continue;
            };
            for c in mp.cells {
                let Some(i) = part.cell_of(c) else { continue };
                let owned: Vec<_> = part.cells[i].pieces.iter().map(|&p| cx.cells[p.idx()].poly()).collect();
                let pieces: Vec<&ConvexPolyhedron> = owned.iter().map(|p| &**p).collect();
                let mut areas = Vec::new();
                for (k, e) in Estimator::ALL.iter().enumerate() {
                    let t = Instant::now();
                    areas.push(projected_area_direct(*e, &pieces, &frame));
                    secs[k] += t.elapsed().as_secs_f64();
                }
                let exact = areas[Estimator::ALL
                    .iter()
                    .position(|e| *e == Estimator::Union)
                    .expect("union")];
                if !(exact > 0.0 && exact.is_finite()) {
                    continue;
                }
                for (k, a) in areas.iter().enumerate() {
                    rel[k].push((a - exact).abs() / exact);
                    signed[k].push((a - exact) / exact);
                }
            }
        }
    }
    Ok(Estimator::ALL
        .iter()
        .enumerate()
        .map(|(k, e)| {
            let n = rel[k].len();
            EstimatorRow {
                estimator: e.to_string(),
                models: cases.len(),
                samples: n,
                rel_error_median: quantile(&mut rel[k], 0.5),
                rel_error_p90: quantile(&mut rel[k], 0.9),
                signed_error_median: quantile(&mut signed[k], 0.5),
                micros_per_call: 1e6 * secs[k] / n.max(1) as f64,
            }
        })
        .collect())
}

/// The rows as a Markdown table.
pub fn estimator_table(rows: &[EstimatorRow], cases: &[&SuiteCase]) -> String {
    let mut s = String::new();
    let names: Vec<&str> = cases.iter().map(|c| c.name.as_str()).collect();
    let _ = writeln!(
        s,
        "Projected-area estimators against the exact union, same cells and planes ({}; cells halfway through the clearance merge):\n",
        names.join(", ")
    );
    s.push_str("| estimator | cells measured | relative error median | p90 | signed median | µs per call |\n");
    s.push_str("|---|---:|---:|---:|---:|---:|\n");
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {:.4} | {:.4} | {:+.4} | {:.1} |",
            r.estimator, r.samples, r.rel_error_median, r.rel_error_p90, r.signed_error_median, r.micros_per_call
        );
    }
    s
}

/// Picks up to one case per family (the first), measures, writes `estimators.csv` and
/// `estimators.md` into `dir` and returns the table.
pub fn write_estimator_errors(cases: &[SuiteCase], dir: &std::path::Path) -> Result<String, SuiteError> {
    let mut picked: Vec<&SuiteCase> = Vec::new();
    for c in cases {
        if !picked.iter().any(|p| p.family == c.family) && c.family != super::Family::Noisy {
            picked.push(c);
        }
    }
    picked.truncate(4);
    let rows = estimator_errors(&picked, 150, 15)?;
    std::fs::create_dir_all(dir)?;
    let mut w = csv::Writer::from_path(dir.join("estimators.csv"))?;
    for r in &rows {
        w.serialize(r)?;
    }
    w.flush()?;
    let t = estimator_table(&rows, &picked);
    std::fs::write(dir.join("estimators.md"), &t)?;
    Ok(t)
}
