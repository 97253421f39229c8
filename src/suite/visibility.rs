//! `portalfind bench visibility`: issue 12's run-time-versus-error table for levels without
//! truth. For each model (the thesis models, a few generated suite models, Quake's e1m1) and
//! each subdivision and decimation configuration, the partition's visibility figures
//! ([`crate::evaluate::evaluate_partition`], the same as `run --evaluate`): cells, portals,
//! PVS sizes, E_T, the PVS area fraction, the culling ratio, the PVS seconds, the sampling
//! check's false invisibles, and the run time that made the partition.
//!
//! Configurations (each model's complex is built once per subdivision and shared):
//! - Delaunay cells, `aperture` and `clearance` at their default stop (`threshold:1.8`);
//! - Delaunay cells, the thesis's heuristics (`aspect`, `refined`, `volume`) with the `hull`
//!   and `bbox` estimators at a few `cells:N` counts (N = rooms and 4 × rooms where a
//!   ground truth gives the rooms, 100 and 300 on e1m1), and `union` (exact, slow: issue 17
//!   measured 384 s on e1m1) only on complexes of at most [`UNION_MAX_CELLS`] active cells;
//! - BSP cells (the thesis's baseline), `aperture` at its default stop and `aspect`/`hull`
//!   at the first N;
//! - qbsp's leaves from a PRT1 file (e1m1: `models/quake/e1m1.prt`), PVS only: a PRT file
//!   has no polygons, so no E_T, area fraction, culling ratio or sampling.
//!
//! Run time = the cells (tetrahedralization or BSP, splitting, portal graph, flood fill) +
//! the decimation, in this process; model loading and output writing are left out. The
//! e1m1 partitions finer than a few hundred cells are left out because their PVS takes
//! tens of seconds (see `results/visibility/README.md`).

use crate::decimate::{Decimation, Estimator, HeuristicKind, QueueMode, Settings, StopRule};
use crate::evaluate;
use crate::model::Model;
use crate::output::ScatterPoint;
use crate::pipeline::{CellSettings, Subdivision};
use crate::visibility::{PvsSettings, prt, pvs, sample::SampleSettings};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Complexes with more active cells than this skip the `union` estimator (its cost grows
/// with the cells merged: minutes on the noisy thesis model's 1,245 under load).
pub const UNION_MAX_CELLS: usize = 500;

/// Errors of the benchmark.
#[derive(Debug, thiserror::Error)]
pub enum VisibilityBenchError {
    /// A model cannot be loaded.
    #[error("cannot load model {name}: {message}")]
    Load {
        /// The model.
        name: String,
        /// Why.
        message: String,
    },
    /// The cells of a model cannot be built.
    #[error("cannot build the {subdivision} cells of {name}")]
    Cells {
        /// The model.
        name: String,
        /// The subdivision.
        subdivision: String,
        /// Why.
        #[source]
        source: crate::pipeline::PipelineError,
    },
    /// A PRT file cannot be read.
    #[error(transparent)]
    Prt(#[from] prt::PrtError),
    /// Writing the table or the plot failed.
    #[error("cannot write {}: {message}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
}

/// One model of the benchmark.
pub struct BenchModel {
    /// Short name.
    pub name: String,
    /// The model.
    pub model: Model,
    /// Its path or generator name (as `result.json`'s model path).
    pub source: String,
    /// Rooms of its ground truth (`None` without one).
    pub rooms: Option<usize>,
    /// qbsp's portal file of the same model, if any.
    pub prt: Option<PathBuf>,
}

/// The benchmark's models: the thesis's six (from the suite's thesis family), the first
/// report-half seed of the tessellated, multi-storey and caverns suite families, and e1m1
/// (with its PRT file) from `root/models/quake/`. `only`: keep the models whose name
/// contains one of these strings (all when empty).
pub fn models(root: &Path, only: &[String]) -> Result<Vec<BenchModel>, VisibilityBenchError> {
    use super::Family;
    let keep = |n: &str| only.is_empty() || only.iter().any(|o| n.contains(o.as_str()));
    let mut out = Vec::new();
    let mut cases: Vec<super::SuiteCase> = Family::Thesis
        .seeds()
        .filter_map(|s| super::case(Family::Thesis, s))
        .collect();
    for f in [Family::Tessellated, Family::MultiStorey, Family::Caverns] {
        cases.extend(super::case(f, 1));
    }
    for c in cases {
        if !keep(&c.name) {
            continue;
        }
        let model = c.load().map_err(|e| VisibilityBenchError::Load {
            name: c.name.clone(),
            message: e.to_string(),
        })?;
        out.push(BenchModel {
            source: format!("suite:{}", c.name),
            name: c.name.clone(),
            model,
            rooms: Some(c.truth.rooms.len()),
            prt: None,
        });
    }
    if keep("e1m1") {
        let path = root.join("models/quake/e1m1.obj");
        let model = crate::model::load_model(&path).map_err(|e| VisibilityBenchError::Load {
            name: "e1m1".into(),
            message: e.to_string(),
        })?;
        out.push(BenchModel {
            name: "e1m1".into(),
            model,
            source: "models/quake/e1m1.obj".into(),
            rooms: None,
            prt: Some(root.join("models/quake/e1m1.prt")),
        });
    }
    Ok(out)
}

/// One configuration: subdivision and decimation settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// The subdivision.
    pub subdivision: Subdivision,
    /// The decimation.
    pub settings: Settings,
}

fn config(subdivision: Subdivision, heuristic: HeuristicKind, estimator: Estimator, stop: StopRule) -> Config {
    Config {
        subdivision,
        settings: Settings {
            heuristic,
            estimator,
            stop,
            queue: QueueMode::Auto,
        },
    }
}

/// The configurations of a model (see the module docs); `union` is listed, and skipped by
/// [`run_model`] on complexes of more than [`UNION_MAX_CELLS`] active cells.
pub fn configs(m: &BenchModel) -> Vec<Config> {
    use Estimator::{Bbox, Hull, Union};
    use HeuristicKind::{Aperture, Aspect, Clearance, Refined, Volume};
    use Subdivision::{Bsp, Delaunay};
    let counts: Vec<usize> = match m.rooms {
        Some(r) => vec![r, 4 * r],
        None => vec![100, 300],
    };
    let mut v = vec![
        config(Delaunay, Aperture, Hull, Aperture.default_stop()),
        config(Delaunay, Clearance, Hull, Clearance.default_stop()),
    ];
    for &n in &counts {
        for h in [Aspect, Refined, Volume] {
            for e in [Hull, Bbox, Union] {
                v.push(config(Delaunay, h, e, StopRule::Cells(n)));
            }
        }
    }
    v.push(config(Bsp, Aperture, Hull, Aperture.default_stop()));
    v.push(config(Bsp, Aspect, Hull, StopRule::Cells(counts[0])));
    v
}

/// One row of `comparison.csv`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Row {
    /// Model name.
    pub model: String,
    /// `delaunay`, `bsp` or `qbsp-prt`.
    pub subdivision: String,
    /// Heuristic (empty for qbsp).
    pub heuristic: String,
    /// Estimator (empty where unused).
    pub estimator: String,
    /// Stop rule.
    pub stop: String,
    /// Cells of the partition.
    pub cells: usize,
    /// Portals (cell pairs).
    pub portals: usize,
    /// Mean PVS size in cells.
    pub pvs_mean_cells: f64,
    /// Largest PVS size in cells.
    pub pvs_max_cells: usize,
    /// Model triangles.
    pub total_triangles: u64,
    /// E_T (none for qbsp's leaves).
    pub expected_triangles: Option<f64>,
    /// PVS area fraction.
    pub area_fraction: Option<f64>,
    /// Culling ratio.
    pub culling_ratio: Option<f64>,
    /// PVS seconds (base visibility + flow).
    pub pvs_seconds: f64,
    /// PVS flow steps.
    pub pvs_chains: u64,
    /// Source portals whose flow hit the work bound.
    pub pvs_sources_truncated: usize,
    /// Sampling: rays.
    pub rays: Option<u64>,
    /// Sampling: false invisibles (must be 0).
    pub false_invisible: Option<u64>,
    /// Sampling: median overestimation.
    pub overestimation_median: Option<f64>,
    /// Seconds for the cells (shared by the model's configurations of one subdivision).
    pub cells_seconds: Option<f64>,
    /// Seconds for the decimation.
    pub decimation_seconds: Option<f64>,
    /// `cells_seconds + decimation_seconds`.
    pub run_seconds: Option<f64>,
}

/// Options.
#[derive(Clone, Debug)]
pub struct Options {
    /// The sampling check (`None`: skipped).
    pub sampling: Option<SampleSettings>,
    /// The PVS.
    pub pvs: PvsSettings,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            sampling: Some(SampleSettings::default()),
            pvs: PvsSettings::default(),
        }
    }
}

/// Runs every configuration of `m`; `log` gets one line per row.
pub fn run_model(m: &BenchModel, opts: &Options, log: &mut dyn FnMut(&Row)) -> Result<Vec<Row>, VisibilityBenchError> {
    let mut rows = Vec::new();
    let path = PathBuf::from(&m.source);
    let es = evaluate::Settings {
        pvs: opts.pvs,
        sampling: opts.sampling,
        walkthrough: None,
    };
    let all = configs(m);
    for sub in [Subdivision::Delaunay, Subdivision::Bsp] {
        let list: Vec<&Config> = all.iter().filter(|c| c.subdivision == sub).collect();
        if list.is_empty() {
            continue;
        }
        let t0 = Instant::now();
        let cells =
            crate::pipeline::build_cells(&m.model, &path, &CellSettings::of(sub), &mut |_| {}).map_err(|source| {
                VisibilityBenchError::Cells {
                    name: m.name.clone(),
                    subdivision: sub.to_string(),
                    source,
                }
            })?;
        let cells_seconds = t0.elapsed().as_secs_f64();
        let union_ok = cells.cx.stats.active_cells <= UNION_MAX_CELLS;
        for c in list {
            if c.settings.estimator == Estimator::Union && !union_ok {
                continue;
            }
            let t1 = Instant::now();
            let dec = Decimation::run(&cells.cx, &c.settings);
            let decimation_seconds = t1.elapsed().as_secs_f64();
            let rs = serde_json::json!({
                "subdivision": sub.to_string(),
                "heuristic": c.settings.heuristic.to_string(),
                "estimator": c.settings.estimator.to_string(),
                "stop": c.settings.stop.to_string(),
            });
            let o = evaluate::evaluate_partition(&m.model, &m.source, rs, &cells.cx, &dec.partition, &es, Vec::new());
            let r = &o.evaluation.report;
            let uses_estimator =
                c.settings.heuristic.heuristic().engine() == crate::decimate::HeuristicEngine::Projected;
            let row = Row {
                model: m.name.clone(),
                subdivision: sub.to_string(),
                heuristic: c.settings.heuristic.to_string(),
                estimator: if uses_estimator {
                    c.settings.estimator.to_string()
                } else {
                    String::new()
                },
                stop: c.settings.stop.to_string(),
                cells: r.cells,
                portals: r.portals,
                pvs_mean_cells: r.pvs_mean_cells,
                pvs_max_cells: r.pvs_max_cells,
                total_triangles: r.total_triangles,
                expected_triangles: Some(r.expected_triangles),
                area_fraction: Some(r.area_fraction),
                culling_ratio: Some(r.culling_ratio),
                pvs_seconds: r.pvs_seconds,
                pvs_chains: r.pvs.chains,
                pvs_sources_truncated: r.pvs.sources_truncated,
                rays: r.sampling.as_ref().map(|s| s.rays),
                false_invisible: r.sampling.as_ref().map(|s| s.false_invisible),
                overestimation_median: r.sampling.as_ref().map(|s| s.overestimation_median),
                cells_seconds: Some(cells_seconds),
                decimation_seconds: Some(decimation_seconds),
                run_seconds: Some(cells_seconds + decimation_seconds),
            };
            log(&row);
            rows.push(row);
        }
    }
    if let Some(p) = &m.prt {
        let file = prt::read(p)?;
        let graph = file.graph();
        let pv = pvs::compute(&graph, &opts.pvs);
        let row = Row {
            model: m.name.clone(),
            subdivision: "qbsp-prt".into(),
            stop: "qbsp leaves".into(),
            cells: graph.cells,
            portals: graph.portals.len(),
            pvs_mean_cells: pv.mean_size(),
            pvs_max_cells: pv.max_size(),
            total_triangles: m.model.triangle_count() as u64,
            pvs_seconds: pv.stats.base_seconds + pv.stats.flow_seconds,
            pvs_chains: pv.stats.chains,
            pvs_sources_truncated: pv.stats.sources_truncated,
            ..Row::default()
        };
        log(&row);
        rows.push(row);
    }
    Ok(rows)
}

fn opt(x: Option<f64>, f: impl Fn(f64) -> String) -> String {
    x.map_or_else(|| "–".into(), f)
}

/// The Markdown table (one section per model).
pub fn table(rows: &[Row]) -> String {
    let mut s = String::new();
    let mut last = "";
    for r in rows {
        if r.model != last {
            last = &r.model;
            let _ = writeln!(
                s,
                "\n### {} ({} triangles)\n\n| subdivision | heuristic / estimator | stop | cells | portals | PVS cells mean / max | E_T | area fraction | culling ratio | PVS s | false invisibles (rays) | overestimation median | run s (cells + decimation) |\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
                r.model, r.total_triangles
            );
        }
        let he = match (r.heuristic.as_str(), r.estimator.as_str()) {
            ("", _) => "–".to_string(),
            (h, "") => h.to_string(),
            (h, e) => format!("{h} / {e}"),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {:.1} / {} | {} | {} | {} | {:.3} | {} | {} | {} |",
            r.subdivision,
            he,
            r.stop,
            r.cells,
            r.portals,
            r.pvs_mean_cells,
            r.pvs_max_cells,
            opt(r.expected_triangles, |x| format!("{x:.1}")),
            opt(r.area_fraction, |x| format!("{x:.4}")),
            opt(r.culling_ratio, |x| format!("{x:.4}")),
            r.pvs_seconds,
            match (r.false_invisible, r.rays) {
                (Some(f), Some(n)) => format!("{f} ({n})"),
                _ => "–".into(),
            },
            opt(r.overestimation_median, |x| format!("{x:.2}")),
            match (r.run_seconds, r.cells_seconds, r.decimation_seconds) {
                (Some(t), Some(c), Some(d)) => format!("{t:.3} ({c:.3} + {d:.3})"),
                _ => "–".into(),
            },
        );
    }
    s
}

/// The series of the plot: Delaunay at the default stop, Delaunay at `cells:N`, BSP.
pub const SERIES: [&str; 3] = [
    "Delaunay cells, default stop (aperture, clearance)",
    "Delaunay cells, cells:N (aspect, refined, volume)",
    "BSP cells",
];

/// The plot's points: one per configuration with an E_T, x = run seconds, y = E_T as a
/// fraction of the model's triangles (1 − culling ratio), so models of different sizes
/// share the axis; labelled by model.
pub fn points(rows: &[Row]) -> Vec<ScatterPoint> {
    rows.iter()
        .filter_map(|r| {
            let (t, c) = (r.run_seconds?, r.culling_ratio?);
            let series = if r.subdivision == "bsp" {
                2
            } else if r.stop.starts_with("cells:") {
                1
            } else {
                0
            };
            Some(ScatterPoint {
                label: String::new(),
                series,
                x: t.max(1e-3),
                y: 1.0 - c,
            })
        })
        .collect()
}

/// Writes `comparison.csv`, `comparison.md` (with `command` and `preamble` at the top) and
/// `comparison.png` into `dir`; returns the paths.
pub fn write(dir: &Path, rows: &[Row], command: &str, preamble: &str) -> Result<Vec<PathBuf>, VisibilityBenchError> {
    let werr = |path: &Path, e: &dyn std::fmt::Display| VisibilityBenchError::Write {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    std::fs::create_dir_all(dir).map_err(|e| werr(dir, &e))?;
    let csv_path = dir.join("comparison.csv");
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).map_err(|e| werr(&csv_path, &e))?;
    }
    let bytes = w.into_inner().map_err(|e| werr(&csv_path, &e.into_error()))?;
    crate::model::write::write_atomic(&csv_path, &bytes).map_err(|e| werr(&csv_path, &e))?;
    let md_path = dir.join("comparison.md");
    let md = format!(
        "# Visibility: run time against E_T (issue 12)\n\nMade by `{command}` (columns: `comparison.csv`; plot: `comparison.png`).\n\n{preamble}\n{}",
        table(rows)
    );
    crate::model::write::write_atomic(&md_path, md.as_bytes()).map_err(|e| werr(&md_path, &e))?;
    let png = dir.join("comparison.png");
    crate::output::scatter(
        &png,
        &points(rows),
        "run time against E_T (one point per model and configuration)",
        (
            "run seconds (cells + decimation)",
            "E_T / model triangles (1 - culling ratio)",
        ),
        &SERIES,
    )
    .map_err(|e| werr(&png, &e))?;
    Ok(vec![csv_path, md_path, png])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_model_gets_every_configuration_and_correct_figures() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let ms = models(root, &["four_room_optimized".to_string()]).unwrap();
        assert_eq!(ms.len(), 1);
        let m = &ms[0];
        assert_eq!(m.rooms, Some(4));
        let cs = configs(m);
        // 2 default stops + 2 counts × 3 heuristics × 3 estimators + 2 BSP.
        assert_eq!(cs.len(), 2 + 18 + 2);
        let opts = Options {
            sampling: Some(SampleSettings {
                seed: 1,
                points_per_cell: 4,
                rays_per_point: 8,
            }),
            ..Options::default()
        };
        let rows = run_model(m, &opts, &mut |_| {}).unwrap();
        assert_eq!(rows.len(), cs.len(), "96 active cells: union runs");
        for r in &rows {
            assert_eq!(r.false_invisible, Some(0), "{r:?}");
            let (et, c) = (r.expected_triangles.unwrap(), r.culling_ratio.unwrap());
            assert!(et <= r.total_triangles as f64 + 1e-9);
            assert!((1.0 - et / r.total_triangles as f64 - c).abs() < 1e-12);
            assert!(r.pvs_max_cells <= r.cells);
            if let (StopRule::Cells(n), "delaunay") = (r.stop.parse().unwrap(), r.subdivision.as_str()) {
                assert_eq!(r.cells, n, "{r:?}");
            }
        }
        // The 16-cell partitions see less than everything; 4 room cells see all 4.
        let at16 = rows
            .iter()
            .find(|r| r.stop == "cells:16" && r.subdivision == "delaunay")
            .unwrap();
        assert_eq!(at16.cells, 16);
        let t = table(&rows);
        assert!(t.contains("four_room_optimized"));
        assert_eq!(points(&rows).len(), rows.len());
    }
}
