//! `portalfind evaluate` and `run --evaluate`: the visibility figures of a partition
//! ([`crate::visibility`]) — PVS sizes, expected rendered triangles `E_T`, PVS area
//! fraction, culling ratio, conservativeness by sampling, timings per stage — and, when
//! asked, a walkthrough ([`crate::visibility::walk`]), written beside a run's files:
//!
//! - `visibility.json` ([`Evaluation`]): the figures (the experiment runner's
//!   `evaluation.json` is another file: the ground-truth evaluation);
//! - `visibility_cells.csv`: one row per cell;
//! - with a walkthrough, `walkthrough.csv` (one row per frame), `walkthrough.png` (the
//!   triangles per frame, like Aliaga & Lastra's figures) and `walkthrough.md` (averages
//!   and speedups).
//!
//! A run directory is re-read without re-deciding anything: the model named in
//! `result.json` is loaded, its cells rebuilt with the run's subdivision (deterministic),
//! and the partition replayed from `weight_curve.csv`'s collapses; the cell ids must equal
//! `result.json`'s, or the evaluation refuses.

use crate::CellId;
use crate::complex::CellComplex;
use crate::decimate::{Decimation, Partition, Step};
use crate::model::Model;
use crate::output::{OutputError, ResultDoc};
use crate::pipeline::{CellSettings, PipelineError, Subdivision};
use crate::visibility::PvsSettings;
use crate::visibility::cost::{CellCost, PartitionVisibility, VisibilityReport};
use crate::visibility::sample::{self, CellSample, SampleSettings};
use crate::visibility::walk::{self, Frame, WalkReport, WalkSettings};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

pub mod plot;

/// The file names.
pub const VISIBILITY_FILE: &str = "visibility.json";
/// Per-cell rows.
pub const CELLS_FILE: &str = "visibility_cells.csv";
/// Per-frame rows.
pub const FRAMES_FILE: &str = "walkthrough.csv";
/// Per-frame plot.
pub const PLOT_FILE: &str = "walkthrough.png";
/// Averages and speedups.
pub const TABLE_FILE: &str = "walkthrough.md";
/// Per frame of the tilted walkthrough.
pub const TILTED_FRAMES_FILE: &str = "walkthrough_tilted.csv";
/// Its plot.
pub const TILTED_PLOT_FILE: &str = "walkthrough_tilted.png";

/// One row per frame: position, cell, the five methods' triangles, and per window
/// representation triangles, portals, overdraw, clips and clip vertices.
fn write_frames(tmp: &Path, names: &[String; 5], frames: &[Frame]) -> Result<(), csv::Error> {
    let mut w = csv::Writer::from_path(tmp)?;
    let mut head = vec!["frame".to_string(), "x".into(), "y".into(), "z".into(), "cell".into()];
    head.extend(names.iter().cloned());
    head.extend(["portals_traversed".into(), "cells_drawn".into(), "quads_k".into()]);
    for r in walk::REPS {
        for c in ["triangles", "portals", "overdraw", "clips", "clip_vertices", "cells"] {
            head.push(format!("{r}_{c}"));
        }
    }
    w.write_record(&head)?;
    for f in frames {
        let mut row = vec![
            f.frame.to_string(),
            f.eye[0].to_string(),
            f.eye[1].to_string(),
            f.eye[2].to_string(),
            f.cell.to_string(),
            f.frustum.to_string(),
            f.portal.to_string(),
            f.portal_rect.to_string(),
            f.textured_a.to_string(),
            f.textured_b.to_string(),
            f.portals_traversed.to_string(),
            f.cells_drawn.to_string(),
            f.quads_a.to_string(),
        ];
        for k in 0..walk::NREPS {
            row.push(f.rep_tris[k].to_string());
            row.push(f.rep_portals[k].to_string());
            row.push(f.rep_tris[k].saturating_sub(f.rep_tris[0]).to_string());
            row.push(f.rep_clips[k].to_string());
            row.push(f.rep_vertices[k].to_string());
            row.push(f.rep_cells[k].to_string());
        }
        w.write_record(&row)?;
    }
    w.flush()?;
    Ok(())
}

/// What to compute.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    /// The PVS.
    pub pvs: PvsSettings,
    /// The sampling check (`None`: skipped).
    pub sampling: Option<SampleSettings>,
    /// The walkthrough (`None`: skipped).
    pub walkthrough: Option<WalkSettings>,
}

/// Errors.
#[derive(Debug, thiserror::Error)]
pub enum EvaluateError {
    /// Reading or writing files.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// Loading the model or rebuilding the cells.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// The run's weight curve cannot be read.
    #[error("cannot read {}: {message}", path.display())]
    WeightCurve {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// The replayed partition is not the run's.
    #[error(
        "the partition rebuilt from {} does not match its result.json ({message}); was the model or portalfind changed since the run?",
        dir.display()
    )]
    Mismatch {
        /// The run directory.
        dir: PathBuf,
        /// What differs.
        message: String,
    },
}

/// One timed stage.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StageTime {
    /// Name.
    pub stage: String,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// `visibility.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Evaluation {
    /// Always `"portalfind-visibility"`.
    pub schema: String,
    /// 1.
    pub schema_version: u32,
    /// `"portalfind X.Y.Z"`.
    pub generator: String,
    /// The model's path.
    pub model: String,
    /// The run's settings (heuristic, estimator, stop, subdivision), as in result.json.
    pub run_settings: serde_json::Value,
    /// What was computed.
    pub settings: Settings,
    /// The figures (with the sampling check when run).
    pub report: VisibilityReport,
    /// The walkthrough's summary.
    pub walkthrough: Option<WalkReport>,
    /// The same path with the camera rolled ([`WalkSettings::tilted_roll_deg`]).
    #[serde(default)]
    pub walkthrough_tilted: Option<WalkReport>,
    /// Seconds per stage.
    pub stages: Vec<StageTime>,
}

/// One row of `visibility_cells.csv`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellRow {
    /// The cell's id (as in result.json).
    pub id: u32,
    /// Its figures.
    #[serde(flatten)]
    pub cost: CellCost,
    /// Distinct polygons the sampling hit (0 without sampling).
    pub polygons_hit: usize,
    /// Their triangles.
    pub triangles_hit: u64,
    /// PVS triangles / sampled triangles (empty when nothing was hit).
    pub overestimation: Option<f64>,
}

/// Everything an evaluation produces.
#[derive(Clone, Debug)]
pub struct Output {
    /// The summary.
    pub evaluation: Evaluation,
    /// Per cell.
    pub cells: Vec<CellRow>,
    /// Per frame (empty without a walkthrough).
    pub frames: Vec<Frame>,
    /// Per frame of the tilted walkthrough (empty without one).
    pub frames_tilted: Vec<Frame>,
}

/// A run re-read from its directory.
pub struct LoadedRun {
    /// Its result document.
    pub doc: ResultDoc,
    /// The model.
    pub model: Model,
    /// The cells, rebuilt.
    pub cx: CellComplex,
    /// The final partition, replayed.
    pub partition: Partition,
    /// Timed stages of re-reading.
    pub stages: Vec<StageTime>,
}

fn stage(name: &str, t0: Instant) -> StageTime {
    StageTime {
        stage: name.into(),
        seconds: t0.elapsed().as_secs_f64(),
    }
}

/// Re-reads a run directory (see the module docs). `model` overrides the model path of
/// result.json (which is as given on the run's command line).
pub fn load_run(dir: &Path, model: Option<&Path>) -> Result<LoadedRun, EvaluateError> {
    let doc = crate::output::read_result(dir)?;
    let path = match model {
        Some(m) => m.to_path_buf(),
        None => crate::pipeline::run_model_path(dir, &doc.model.path)?.0,
    };
    let t0 = Instant::now();
    let (model, _) = crate::pipeline::load(&path)?;
    let mut stages = vec![stage("load model", t0)];
    let subdivision: Subdivision = doc.settings.subdivision.parse().unwrap_or(Subdivision::Delaunay);
    let t0 = Instant::now();
    let cells = crate::pipeline::build_cells(&model, &path, &CellSettings::of(subdivision), &mut |_| {})?;
    stages.push(stage("rebuild cells", t0));
    let t0 = Instant::now();
    let csv_path = dir.join("weight_curve.csv");
    let steps = read_steps(&csv_path)?;
    let partition = Decimation::replay(&cells.cx, &steps).map_err(|e| EvaluateError::WeightCurve {
        path: csv_path.clone(),
        message: e.to_string(),
    })?;
    stages.push(stage("replay collapses", t0));
    let ids: Vec<u32> = partition.cells.iter().map(|c| c.id.0).collect();
    let want: Vec<u32> = doc.cells.iter().map(|c| c.id).collect();
    if ids != want {
        return Err(EvaluateError::Mismatch {
            dir: dir.to_path_buf(),
            message: format!("{} cells rebuilt, {} in result.json", ids.len(), want.len()),
        });
    }
    Ok(LoadedRun {
        doc,
        model,
        cx: cells.cx,
        partition,
        stages,
    })
}

/// The collapses of a `weight_curve.csv` (only the pairs matter for a replay).
fn read_steps(path: &Path) -> Result<Vec<Step>, EvaluateError> {
    let bad = |message: String| EvaluateError::WeightCurve {
        path: path.to_path_buf(),
        message,
    };
    let mut r = csv::Reader::from_path(path).map_err(|e| bad(e.to_string()))?;
    let h = r.headers().map_err(|e| bad(e.to_string()))?.clone();
    let col = |name: &str| {
        h.iter()
            .position(|x| x == name)
            .ok_or_else(|| bad(format!("no column {name}")))
    };
    let (ca, cb) = (col("cell_a")?, col("cell_b")?);
    let mut steps = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let rec = rec.map_err(|e| bad(e.to_string()))?;
        let get = |k: usize| -> Result<u32, EvaluateError> {
            rec.get(k)
                .and_then(|s| s.parse().ok())
                .ok_or_else(|| bad(format!("row {}: not a cell id", i + 2)))
        };
        steps.push(Step {
            a: CellId(get(ca)?),
            b: CellId(get(cb)?),
            weight: 0.0,
            cells_remaining: 0,
            portal_area: 0.0,
            projected: [0.0; 2],
        });
    }
    Ok(steps)
}

/// Evaluates a partition of `cx` (built from `model`). `stages` are earlier timed stages.
pub fn evaluate_partition(
    model: &Model,
    model_path: &str,
    run_settings: serde_json::Value,
    cx: &CellComplex,
    partition: &Partition,
    settings: &Settings,
    mut stages: Vec<StageTime>,
) -> Output {
    let t0 = Instant::now();
    let v = PartitionVisibility::compute(model, cx, partition, &settings.pvs);
    let total = t0.elapsed().as_secs_f64();
    stages.push(StageTime {
        stage: "PVS: base visibility".into(),
        seconds: v.pvs.stats.base_seconds,
    });
    stages.push(StageTime {
        stage: "PVS: portal flow".into(),
        seconds: v.pvs.stats.flow_seconds,
    });
    stages.push(StageTime {
        stage: "portal graph, polygons per cell, costs".into(),
        seconds: (total - v.pvs.stats.base_seconds - v.pvs.stats.flow_seconds).max(0.0),
    });
    let mut report = v.report.clone();
    let mut samples: Vec<Option<CellSample>> = vec![None; partition.len()];
    let pieces = sample::pieces_of_partition(partition);
    if let Some(ss) = &settings.sampling {
        let (s, per) = sample::check(model, cx, &pieces, &v.pvs, &v.polygons, &v.cells, ss);
        stages.push(StageTime {
            stage: "sampling check".into(),
            seconds: s.seconds,
        });
        report.sampling = Some(s);
        samples = per.into_iter().map(Some).collect();
    }
    let mut walkthrough = None;
    let mut frames = Vec::new();
    let mut walkthrough_tilted = None;
    let mut frames_tilted = Vec::new();
    if let Some(ws) = &settings.walkthrough {
        let t0 = Instant::now();
        let scene = walk::Scene {
            model,
            cx,
            graph: &v.graph,
            polygons: &v.polygons,
            pieces: &pieces,
        };
        let (w, f) = walk::walkthrough(&scene, ws);
        stages.push(stage("walkthrough", t0));
        walkthrough = Some(w);
        frames = f;
        if ws.tilted_roll_deg != 0.0 {
            let t0 = Instant::now();
            let tilted = WalkSettings {
                roll_deg: ws.tilted_roll_deg,
                ..*ws
            };
            let (w, f) = walk::walkthrough(&scene, &tilted);
            stages.push(stage("tilted walkthrough", t0));
            walkthrough_tilted = Some(w);
            frames_tilted = f;
        }
    }
    let cells = partition
        .cells
        .iter()
        .zip(&v.cells)
        .zip(&samples)
        .map(|((mc, c), s)| CellRow {
            id: mc.id.0,
            cost: c.clone(),
            polygons_hit: s.as_ref().map_or(0, |s| s.polygons_hit),
            triangles_hit: s.as_ref().map_or(0, |s| s.triangles_hit),
            overestimation: s.as_ref().and_then(|s| s.overestimation),
        })
        .collect();
    Output {
        evaluation: Evaluation {
            schema: "portalfind-visibility".into(),
            schema_version: 1,
            generator: format!("portalfind {}", env!("CARGO_PKG_VERSION")),
            model: model_path.into(),
            run_settings,
            settings: *settings,
            report,
            walkthrough,
            walkthrough_tilted,
            stages,
        },
        cells,
        frames,
        frames_tilted,
    }
}

/// Evaluates the run in `dir` (see [`load_run`]).
pub fn evaluate_dir(dir: &Path, model: Option<&Path>, settings: &Settings) -> Result<Output, EvaluateError> {
    let run = load_run(dir, model)?;
    let rs = serde_json::to_value(&run.doc.settings).unwrap_or(serde_json::Value::Null);
    Ok(evaluate_partition(
        &run.model,
        &run.doc.model.path,
        rs,
        &run.cx,
        &run.partition,
        settings,
        run.stages,
    ))
}

/// The walkthrough table (markdown): mean and largest triangles per frame, and the
/// speedup over view-frustum culling, of each method.
pub fn walkthrough_table(w: &WalkReport) -> String {
    let ws = w.settings.unwrap_or_default();
    let names = walk::columns(&ws);
    let mut s = format!(
        "{} frames along a path of length {:.1}; {} model triangles; field of view {}° × {:.1}°.\n\n",
        w.frames,
        w.path_length,
        w.total_triangles,
        ws.fov_deg,
        2.0 * ((ws.fov_deg.to_radians() / 2.0).tan() * ws.aspect).atan().to_degrees()
    );
    s.push_str("| method | mean triangles | max triangles | speedup (triangles) | culling seconds (all frames) |\n");
    s.push_str("|---|---:|---:|---:|---:|\n");
    for k in 0..5 {
        s.push_str(&format!(
            "| {} | {:.1} | {} | {:.2} | {:.3} |\n",
            names[k], w.mean[k], w.max[k], w.speedup[k], w.seconds[k]
        ));
    }
    s.push_str(&reps_table(w));
    s
}

/// The window representations (exact, rectangle, k-gons): per frame means, overdraw against
/// the exact window, and operation counts.
pub fn reps_table(w: &WalkReport) -> String {
    if w.reps.is_empty() {
        return String::new();
    }
    let ws = w.settings.unwrap_or_default();
    let nf = w.frames.max(1) as f64;
    let mut s = format!(
        "\nWindow representations (camera roll {}°; overdraw = triangles beyond the exact window's):\n\n",
        ws.roll_deg
    );
    s.push_str(
        "Windows: `*_pieces` and exact/rect/k-gons narrow piece by piece; `hull` and `mask` once per \
         merged portal (portals = windows passed: pieces, or merged portals; cells = cells drawn, with \
         repetitions). Mask pixels/words: conservative raster spans and 64-pixel words read.\n\n",
    );
    s.push_str("| window | mean triangles | max | mean portals | mean cells | mean overdraw | max overdraw | frames below exact | clips / frame | clip vertices / frame | 2D ops / frame | sphere rejects / frame | mask pixels / frame | mask words / frame | culling ms / frame |\n");
    s.push_str("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for r in &w.reps {
        s.push_str(&format!(
            "| {} | {:.1} | {} | {:.2} | {:.2} | {:.2} | {} | {} | {:.0} | {:.0} | {:.0} | {:.1} | {:.0} | {:.0} | {:.3} |\n",
            r.name,
            r.mean_triangles,
            r.max_triangles,
            r.mean_portals,
            r.mean_cells,
            r.mean_overdraw,
            r.max_overdraw,
            r.frames_below_exact,
            r.ops.plane_clips as f64 / nf,
            r.ops.vertices as f64 / nf,
            r.ops.screen_ops as f64 / nf,
            r.ops.sphere_rejects as f64 / nf,
            r.ops.mask_pixels as f64 / nf,
            r.ops.mask_words as f64 / nf,
            1e3 * r.seconds / nf
        ));
    }
    s
}

/// Writes the evaluation's files into `dir`; returns their paths.
pub fn write(dir: &Path, out: &Output, title: &str) -> Result<Vec<PathBuf>, EvaluateError> {
    let mut files = Vec::new();
    let p = dir.join(VISIBILITY_FILE);
    crate::output::write_atomic(&p, |tmp| -> Result<(), std::io::Error> {
        let s = serde_json::to_string_pretty(&out.evaluation).map_err(std::io::Error::other)?;
        std::fs::write(tmp, s + "\n")
    })?;
    files.push(p);
    let p = dir.join(CELLS_FILE);
    crate::output::write_atomic(&p, |tmp| -> Result<(), csv::Error> {
        let mut w = csv::Writer::from_path(tmp)?;
        w.write_record([
            "id",
            "volume",
            "pvs_cells",
            "own_triangles",
            "pvs_triangles",
            "pvs_area",
            "polygons_hit",
            "triangles_hit",
            "overestimation",
        ])?;
        for c in &out.cells {
            w.write_record([
                c.id.to_string(),
                c.cost.volume.to_string(),
                c.cost.pvs_cells.to_string(),
                c.cost.own_triangles.to_string(),
                c.cost.pvs_triangles.to_string(),
                c.cost.pvs_area.to_string(),
                c.polygons_hit.to_string(),
                c.triangles_hit.to_string(),
                c.overestimation.map_or(String::new(), |x| x.to_string()),
            ])?;
        }
        w.flush()?;
        Ok(())
    })?;
    files.push(p);
    if let Some(wr) = &out.evaluation.walkthrough {
        let names = walk::columns(&wr.settings.unwrap_or_default());
        let p = dir.join(FRAMES_FILE);
        crate::output::write_atomic(&p, |tmp| write_frames(tmp, &names, &out.frames))?;
        files.push(p);
        if let Some(wt) = &out.evaluation.walkthrough_tilted {
            let p = dir.join(TILTED_FRAMES_FILE);
            crate::output::write_atomic(&p, |tmp| write_frames(tmp, &names, &out.frames_tilted))?;
            files.push(p);
            let p = dir.join(TILTED_PLOT_FILE);
            let t = format!("{title} (camera rolled {}°)", wt.settings.unwrap_or_default().roll_deg);
            crate::output::write_atomic(&p, |tmp| plot::frames(tmp, &out.frames_tilted, &names, &t))?;
            files.push(p);
        }
        let p = dir.join(PLOT_FILE);
        crate::output::write_atomic(&p, |tmp| plot::frames(tmp, &out.frames, &names, title))?;
        files.push(p);
        let p = dir.join(TABLE_FILE);
        let mut table = format!("# Walkthrough: {title}\n\n{}", walkthrough_table(wr));
        if let Some(wt) = &out.evaluation.walkthrough_tilted {
            table.push_str(&format!(
                "\n## Tilted camera (rolled {}°, same path)\n\n{}",
                wt.settings.unwrap_or_default().roll_deg,
                walkthrough_table(wt)
            ));
        }
        crate::output::write_atomic(&p, |tmp| std::fs::write(tmp, table))?;
        files.push(p);
    }
    Ok(files)
}
