//! The accuracy benchmark's library side: run one case ([`run_case`]), and aggregate
//! results per configuration, family and half ([`summarize`], [`table`], [`write_csv`],
//! [`write_summary_csv`], [`to_json`]).

use super::metrics::{Accuracy, MetricOptions, score};
use super::{Family, Half, SuiteCase};
use crate::decimate::{Decimation, Estimator, HeuristicKind, Settings, StopRule};
use serde::Serialize;
use std::fmt::Write as _;
use std::time::Instant;

/// One case run with one configuration.
#[derive(Clone, Debug, Serialize)]
pub struct CaseResult {
    /// Case name.
    pub name: String,
    /// Family.
    pub family: Family,
    /// Seed.
    pub seed: u64,
    /// Half.
    pub half: Half,
    /// `heuristic/estimator stop` (a stop `cells:K` with K the number of rooms is written
    /// `cells:K`).
    pub config: String,
    /// Triangles of the cleaned model.
    pub triangles: usize,
    /// Active cells of the complex.
    pub complex_cells: usize,
    /// Leaks the complex reported.
    pub leaks: usize,
    /// Whether the complex passed the structural check (`CellComplex::check_valid`); an
    /// invalid one is still decimated and scored here, so the table shows what it costs.
    pub valid: bool,
    /// Scores.
    pub accuracy: Accuracy,
    /// Seconds: loading and cleaning.
    pub seconds_load: f64,
    /// Seconds: tetrahedralization and complex.
    pub seconds_complex: f64,
    /// Seconds: decimation.
    pub seconds_decimate: f64,
    /// Seconds: scoring (not part of the pipeline's time).
    pub seconds_score: f64,
}

impl CaseResult {
    /// The pipeline's time: load + complex + decimation.
    pub fn seconds_pipeline(&self) -> f64 {
        self.seconds_load + self.seconds_complex + self.seconds_decimate
    }
}

/// Settings with stop `cells:K`, K the case's number of rooms.
pub fn settings_at_rooms(case: &SuiteCase, heuristic: HeuristicKind, estimator: Estimator) -> Settings {
    Settings {
        heuristic,
        estimator,
        stop: StopRule::Cells(case.truth.rooms.len().max(1)),
        ..Settings::default()
    }
}

/// The configuration's label: `heuristic/estimator stop`, with `cells:K` for a stop at the
/// number of rooms.
pub fn config_label(case: &SuiteCase, s: &Settings) -> String {
    let stop = match s.stop {
        StopRule::Cells(n) if n == case.truth.rooms.len() => "cells:K".to_string(),
        other => other.to_string(),
    };
    if s.heuristic.heuristic().engine() == crate::decimate::HeuristicEngine::Clearance {
        return format!("{} {stop}", s.heuristic);
    }
    format!("{}/{} {stop}", s.heuristic, s.estimator)
}

/// Loads the case, builds the Delaunay cell complex, decimates with `settings`, scores
/// ([`score`] with default options) and times each stage.
/// Why a suite case or its report could not be made.
#[derive(Debug, thiserror::Error)]
pub enum SuiteError {
    /// The generated model does not load (a generator bug: the suite's models must load).
    #[error("cannot load the suite case {case}")]
    Load {
        /// The case.
        case: String,
        /// Why.
        #[source]
        source: Box<crate::model::ModelError>,
    },
    /// The cells of a case cannot be built.
    #[error("cannot build the cells of the suite case {case}")]
    Cells {
        /// The case.
        case: String,
        /// Why.
        #[source]
        source: crate::pipeline::PipelineError,
    },
    /// Writing a report failed.
    #[error("cannot write the suite report")]
    Write(#[from] std::io::Error),
    /// Writing a CSV report failed.
    #[error("cannot write a suite CSV report")]
    Csv(#[from] csv::Error),
    /// Serializing the JSON report failed.
    #[error("cannot serialize the suite report")]
    Json(#[from] serde_json::Error),
}

type Result<T> = std::result::Result<T, SuiteError>;

/// Loads the case, builds the Delaunay cell complex, decimates with `settings`, scores
/// ([`score`] with default options) and times each stage.
pub fn run_case(case: &SuiteCase, settings: &Settings) -> Result<CaseResult> {
    run_case_with(case, settings, &MetricOptions::default())
}

/// [`run_case`] with metric options.
pub fn run_case_with(case: &SuiteCase, settings: &Settings, opts: &MetricOptions) -> Result<CaseResult> {
    let mut out = run_settings(std::slice::from_ref(case), &[*settings], opts, &mut |_, _| {})?;
    Ok(out.pop().expect("one case, one configuration"))
}

/// The stop of a benchmark configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConfigStop {
    /// `cells:K` with K the case's true number of rooms (an oracle: how good the merge
    /// *order* is, whatever the stop).
    Rooms,
    /// A stop rule the user could give without knowing the answer.
    Rule(StopRule),
}

/// One benchmark configuration: `heuristic/estimator@stop`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Heuristic.
    pub heuristic: HeuristicKind,
    /// Estimator (unused by `clearance`).
    pub estimator: Estimator,
    /// Stop.
    pub stop: ConfigStop,
}

/// A configuration that cannot be parsed.
#[derive(Debug, thiserror::Error)]
#[error(
    "bad benchmark configuration {text:?}: {why}; write heuristic[/estimator]@stop, e.g. aspect/hull@rooms, clearance@threshold:1.8 (stop: rooms, threshold:W, cells:N or none)"
)]
pub struct ConfigError {
    /// The text.
    pub text: String,
    /// Why.
    pub why: String,
}

impl std::str::FromStr for Config {
    type Err = ConfigError;
    fn from_str(s: &str) -> std::result::Result<Self, ConfigError> {
        let bad = |why: String| ConfigError {
            text: s.to_string(),
            why,
        };
        let (hs, stop) = s.split_once('@').ok_or_else(|| bad("no '@stop'".into()))?;
        let (h, e) = hs.split_once('/').unwrap_or((hs, "hull"));
        let heuristic = HeuristicKind::parse(h).map_err(|e| bad(e.to_string()))?;
        let estimator = Estimator::parse(e).map_err(|e| bad(e.to_string()))?;
        let stop = if stop == "rooms" {
            ConfigStop::Rooms
        } else {
            ConfigStop::Rule(StopRule::parse(stop).map_err(|e| bad(e.to_string()))?)
        };
        Ok(Config {
            heuristic,
            estimator,
            stop,
        })
    }
}

impl Config {
    /// The decimation settings for `case`.
    pub fn settings(&self, case: &SuiteCase) -> Settings {
        Settings {
            heuristic: self.heuristic,
            estimator: self.estimator,
            stop: match self.stop {
                ConfigStop::Rooms => StopRule::Cells(case.truth.rooms.len().max(1)),
                ConfigStop::Rule(r) => r,
            },
            ..Settings::default()
        }
    }
}

/// Runs every configuration on every case, building each case's complex once; calls
/// `progress(case index, result)` after each run.
pub fn run_cases(
    cases: &[SuiteCase],
    configs: &[Config],
    opts: &MetricOptions,
    progress: &mut dyn FnMut(usize, &CaseResult),
) -> Result<Vec<CaseResult>> {
    let mut out = Vec::new();
    for (i, case) in cases.iter().enumerate() {
        let settings: Vec<Settings> = configs.iter().map(|c| c.settings(case)).collect();
        out.extend(run_settings(
            std::slice::from_ref(case),
            &settings,
            opts,
            &mut |_, r| progress(i, r),
        )?);
    }
    Ok(out)
}

/// Runs each of `settings` on every case, building each case's complex once.
fn run_settings(
    cases: &[SuiteCase],
    settings: &[Settings],
    opts: &MetricOptions,
    progress: &mut dyn FnMut(usize, &CaseResult),
) -> Result<Vec<CaseResult>> {
    let mut out = Vec::new();
    for (i, case) in cases.iter().enumerate() {
        let t = Instant::now();
        let model = case.load().map_err(|e| SuiteError::Load {
            case: case.name.clone(),
            source: Box::new(e),
        })?;
        let seconds_load = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let cx = crate::pipeline::complex_of_unchecked(&model).map_err(|source| SuiteError::Cells {
            case: case.name.clone(),
            source,
        })?;
        let seconds_complex = t.elapsed().as_secs_f64();
        let valid = cx.check_valid().is_ok();
        for settings in settings {
            let t = Instant::now();
            let dec = Decimation::run(&cx, settings);
            let seconds_decimate = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let accuracy = score(&cx, &dec.partition, &case.truth, opts);
            let r = CaseResult {
                name: case.name.clone(),
                family: case.family,
                seed: case.seed,
                half: case.half,
                config: config_label(case, settings),
                triangles: model.triangle_count(),
                complex_cells: cx.active_cells().count(),
                leaks: cx.leaks.len(),
                valid,
                accuracy,
                seconds_load,
                seconds_complex,
                seconds_decimate,
                seconds_score: t.elapsed().as_secs_f64(),
            };
            progress(i, &r);
            out.push(r);
        }
    }
    Ok(out)
}

/// Aggregate of the results of one configuration on one family (or all) and half.
#[derive(Clone, Debug, Serialize)]
pub struct SummaryRow {
    /// Configuration label.
    pub config: String,
    /// Family name, or `all`.
    pub family: String,
    /// Half.
    pub half: Half,
    /// Models.
    pub models: usize,
    /// Rooms in all.
    pub rooms: usize,
    /// Rooms isolated in all.
    pub rooms_isolated: usize,
    /// Mean over models of the micro precision.
    pub precision_micro: f64,
    /// Mean over models of the micro recall.
    pub recall_micro: f64,
    /// Mean over models of the macro precision.
    pub precision_macro: f64,
    /// Mean over models of the macro recall.
    pub recall_macro: f64,
    /// Mean over models of the spike cells' volume share.
    pub spike_volume_share: f64,
    /// Median over models of final cells / rooms.
    pub cells_per_room_median: f64,
    /// Doorways in all.
    pub doorways: usize,
    /// Doorways matched in all.
    pub doorways_matched: usize,
    /// Median pipeline seconds per model.
    pub seconds_median: f64,
    /// Total pipeline seconds.
    pub seconds_total: f64,
    /// Models whose complex reported a leak.
    pub models_with_leaks: usize,
}

fn median(mut xs: Vec<f64>) -> f64 {
    if xs.is_empty() {
        return 0.0;
    }
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    if n % 2 == 1 {
        xs[n / 2]
    } else {
        0.5 * (xs[n / 2 - 1] + xs[n / 2])
    }
}

fn summary_row(config: &str, family: &str, half: Half, rs: &[&CaseResult]) -> SummaryRow {
    let n = rs.len().max(1) as f64;
    let mean = |f: &dyn Fn(&Accuracy) -> f64| rs.iter().map(|r| f(&r.accuracy)).sum::<f64>() / n;
    SummaryRow {
        config: config.to_string(),
        family: family.to_string(),
        half,
        models: rs.len(),
        rooms: rs.iter().map(|r| r.accuracy.rooms).sum(),
        rooms_isolated: rs.iter().map(|r| r.accuracy.rooms_isolated).sum(),
        precision_micro: mean(&|a| a.precision_micro),
        recall_micro: mean(&|a| a.recall_micro),
        precision_macro: mean(&|a| a.precision_macro),
        recall_macro: mean(&|a| a.recall_macro),
        spike_volume_share: mean(&|a| a.spike_volume_share),
        cells_per_room_median: median(rs.iter().map(|r| r.accuracy.cells_per_room).collect()),
        doorways: rs.iter().map(|r| r.accuracy.doorways).sum(),
        doorways_matched: rs.iter().map(|r| r.accuracy.doorways_matched).sum(),
        seconds_median: median(rs.iter().map(|r| r.seconds_pipeline()).collect()),
        seconds_total: rs.iter().map(|r| r.seconds_pipeline()).sum(),
        models_with_leaks: rs.iter().filter(|r| r.leaks > 0).count(),
    }
}

/// Rows per configuration (in order of first appearance), half (tune, report) and family
/// (in [`Family::ALL`] order, then `all`).
pub fn summarize(results: &[CaseResult]) -> Vec<SummaryRow> {
    let mut configs: Vec<&str> = Vec::new();
    for r in results {
        if !configs.contains(&r.config.as_str()) {
            configs.push(&r.config);
        }
    }
    let mut rows = Vec::new();
    for c in configs {
        for half in [Half::Tune, Half::Report, Half::Holdout] {
            for fam in Family::ALL {
                let rs: Vec<&CaseResult> = results
                    .iter()
                    .filter(|r| r.config == c && r.half == half && r.family == fam)
                    .collect();
                if !rs.is_empty() {
                    rows.push(summary_row(c, fam.name(), half, &rs));
                }
            }
            let rs: Vec<&CaseResult> = results.iter().filter(|r| r.config == c && r.half == half).collect();
            if !rs.is_empty() {
                rows.push(summary_row(c, "all", half, &rs));
            }
        }
    }
    rows
}

/// The summary as a Markdown table.
pub fn table(results: &[CaseResult]) -> String {
    let mut s = String::new();
    s.push_str(
        "| config | half | family | models | rooms isolated | P micro | R micro | P macro | R macro | spike vol | final/rooms (median) | doorways matched | time s (median / total) |\n",
    );
    s.push_str("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for r in summarize(results) {
        let pct = |a: usize, b: usize| if b > 0 { 100.0 * a as f64 / b as f64 } else { 0.0 };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {}/{} ({:.0}%) | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.1} | {}/{} | {:.2} / {:.1} |",
            r.config,
            r.half,
            r.family,
            r.models,
            r.rooms_isolated,
            r.rooms,
            pct(r.rooms_isolated, r.rooms),
            r.precision_micro,
            r.recall_micro,
            r.precision_macro,
            r.recall_macro,
            r.spike_volume_share,
            r.cells_per_room_median,
            r.doorways_matched,
            r.doorways,
            r.seconds_median,
            r.seconds_total,
        );
    }
    s
}

/// One CSV row per case result.
pub fn write_csv(results: &[CaseResult], w: impl std::io::Write) -> Result<()> {
    let mut out = csv::Writer::from_writer(w);
    out.write_record([
        "name",
        "family",
        "seed",
        "half",
        "config",
        "triangles",
        "complex_cells",
        "leaks",
        "valid",
        "rooms",
        "final_cells",
        "rooms_isolated",
        "unlocated_samples",
        "precision_micro",
        "recall_micro",
        "precision_macro",
        "recall_macro",
        "spike_cells",
        "spike_volume_share",
        "room_volume_share",
        "doorways",
        "doorways_matched",
        "cells_per_room",
        "seconds_load",
        "seconds_complex",
        "seconds_decimate",
        "seconds_score",
    ])?;
    for r in results {
        let a = &r.accuracy;
        out.write_record([
            r.name.clone(),
            r.family.to_string(),
            r.seed.to_string(),
            r.half.to_string(),
            r.config.clone(),
            r.triangles.to_string(),
            r.complex_cells.to_string(),
            r.leaks.to_string(),
            r.valid.to_string(),
            a.rooms.to_string(),
            a.final_cells.to_string(),
            a.rooms_isolated.to_string(),
            a.unlocated_samples.to_string(),
            format!("{:.6}", a.precision_micro),
            format!("{:.6}", a.recall_micro),
            format!("{:.6}", a.precision_macro),
            format!("{:.6}", a.recall_macro),
            a.spike_cells.to_string(),
            format!("{:.6}", a.spike_volume_share),
            format!("{:.6}", a.room_volume_share),
            a.doorways.to_string(),
            a.doorways_matched.to_string(),
            format!("{:.4}", a.cells_per_room),
            format!("{:.4}", r.seconds_load),
            format!("{:.4}", r.seconds_complex),
            format!("{:.4}", r.seconds_decimate),
            format!("{:.4}", r.seconds_score),
        ])?;
    }
    out.flush()?;
    Ok(())
}

/// One CSV row per summary row.
pub fn write_summary_csv(results: &[CaseResult], w: impl std::io::Write) -> Result<()> {
    let mut out = csv::Writer::from_writer(w);
    for r in summarize(results) {
        out.serialize(r)?;
    }
    out.flush()?;
    Ok(())
}

/// `{"cases": [...], "summary": [...]}`.
pub fn to_json(results: &[CaseResult]) -> Result<String> {
    let v = serde_json::json!({
        "schema": "portalfind-suite-accuracy",
        "cases": results,
        "summary": summarize(results),
    });
    Ok(serde_json::to_string_pretty(&v)?)
}

/// The time-versus-error plot: one point per configuration and half (all families), x the
/// median pipeline seconds per model, y the share of rooms not isolated.
pub fn time_vs_error_points(results: &[CaseResult]) -> Vec<crate::output::ScatterPoint> {
    summarize(results)
        .into_iter()
        .filter(|r| r.family == "all")
        .map(|r| crate::output::ScatterPoint {
            label: r.config.clone(),
            series: match r.half {
                Half::Tune => 0,
                Half::Report => 1,
                Half::Holdout => 2,
            },
            x: r.seconds_median.max(1e-3),
            y: 1.0 - r.rooms_isolated as f64 / r.rooms.max(1) as f64,
        })
        .collect()
}

/// Writes `cases.csv`, `summary.csv`, `accuracy.json`, `table.md` and the time-versus-error
/// plot (`time_vs_error.png`, `time_vs_error.svg`) into `dir`.
pub fn write_all(results: &[CaseResult], dir: &std::path::Path) -> Result<()> {
    std::fs::create_dir_all(dir)?;
    write_csv(results, std::fs::File::create(dir.join("cases.csv"))?)?;
    write_summary_csv(results, std::fs::File::create(dir.join("summary.csv"))?)?;
    std::fs::write(dir.join("accuracy.json"), to_json(results)?)?;
    std::fs::write(dir.join("table.md"), table(results))?;
    let points = time_vs_error_points(results);
    for f in ["time_vs_error.png", "time_vs_error.svg"] {
        crate::output::scatter(
            &dir.join(f),
            &points,
            "accuracy bench: run time against error (one point per configuration and half)",
            (
                "median pipeline seconds per model (load + complex + decimation)",
                "share of rooms not isolated",
            ),
            &["tune half", "report half", "holdout seeds"],
        )
        .map_err(|e| SuiteError::Write(std::io::Error::other(e.to_string())))?;
    }
    Ok(())
}
