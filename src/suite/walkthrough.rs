//! `portalfind bench walkthrough`: issue 14's comparison of the portal window
//! representations ([`walk::REPS`]: exact polygon, screen rectangle, k-gons 4/6/8, convex
//! hull per piece and per merged portal, per-pixel mask per piece and per merged portal) on
//! the thesis models, the generated multi-storey building of `bench visibility` and e1m1,
//! along the walkthrough's deterministic camera path, level and rolled
//! ([`WalkSettings::tilted_roll_deg`]): mean and worst triangles rendered and windows
//! passed per frame ([`walk::walkthrough`]), and the time per frame of the culling itself
//! ([`walk::time_culling`]: thread CPU and wall-clock time, every frame culled `repeat`
//! times by every representation, interleaved), with the triangle-by-triangle check that no representation misses a
//! triangle the exact window draws.
//!
//! Each model is partitioned as `run` does by default (Delaunay cells, `aperture` at its
//! default stop). Times are the culling thread's CPU time (`CLOCK_THREAD_CPUTIME_ID`) and
//! wall-clock time in this process (a loaded machine inflates the wall-clock ones most);
//! compare representations within one model and camera, where they ran interleaved.

use super::visibility::{BenchModel, VisibilityBenchError};
use crate::decimate::{Decimation, HeuristicKind, Settings};
use crate::evaluate::plot::{Panel, Series, log_lines};
use crate::pipeline::{CellSettings, Subdivision};
use crate::visibility::cost::PartitionVisibility;
use crate::visibility::walk::{self, CullTiming, Frame, NREPS, REPS, RepSummary, WalkSettings};
use crate::visibility::{PvsSettings, sample};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The benchmark's models: those of [`super::visibility::models`] whose name contains
/// `thesis-`, `multistorey-` or `e1m1` (and one of `only`, when given).
pub fn models(root: &Path, only: &[String]) -> Result<Vec<BenchModel>, VisibilityBenchError> {
    let ms = super::visibility::models(root, only)?;
    Ok(ms
        .into_iter()
        .filter(|m| ["thesis-", "multistorey-", "e1m1"].iter().any(|k| m.name.contains(k)))
        .collect())
}

/// One row: a model, a camera, a representation.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Row {
    /// Model name.
    pub model: String,
    /// Camera roll in degrees (0: level).
    pub roll_deg: f64,
    /// Representation ([`walk::REPS`]).
    pub window: String,
    /// Cells of the partition.
    pub cells: usize,
    /// Portals (cell pairs).
    pub portals: usize,
    /// Convex portal pieces.
    pub pieces: usize,
    /// Frames.
    pub frames: usize,
    /// Mean triangles rendered per frame.
    pub mean_triangles: f64,
    /// Worst frame.
    pub max_triangles: u64,
    /// Mean windows passed per frame (portal pieces; merged portals for `hull`/`mask`).
    pub mean_portals: f64,
    /// Worst frame.
    pub max_portals: u64,
    /// Mean triangles beyond the exact window's per frame.
    pub mean_overdraw: f64,
    /// Frames with a triangle the exact window draws and this one does not (must be 0).
    pub frames_missing: usize,
    /// Polygon–plane clips per frame (mean).
    pub clips_per_frame: f64,
    /// Culling time per frame, thread CPU microseconds: the fastest repetition's mean
    /// (`None` without the thread clock).
    pub cpu_us_per_frame_best: Option<f64>,
    /// The median repetition's mean.
    pub cpu_us_per_frame_median: Option<f64>,
    /// Culling time per frame, wall-clock microseconds: the fastest repetition's mean.
    pub us_per_frame_best: f64,
    /// The median repetition's mean.
    pub us_per_frame_median: f64,
    /// Repetitions.
    pub repeat: usize,
}

/// One walkthrough of one model: its rows and per-frame series.
pub struct Walk {
    /// Rows, one per representation.
    pub rows: Vec<Row>,
    /// Per frame (counts).
    pub frames: Vec<Frame>,
    /// Timings.
    pub timing: CullTiming,
}

/// Runs the level and the tilted walkthrough of `m` with `repeat` timing repetitions.
pub fn run_model(m: &BenchModel, settings: &WalkSettings, repeat: usize) -> Result<Vec<Walk>, VisibilityBenchError> {
    let path = PathBuf::from(&m.source);
    let cells = crate::pipeline::build_cells(&m.model, &path, &CellSettings::of(Subdivision::Delaunay), &mut |_| {})
        .map_err(|source| VisibilityBenchError::Cells {
            name: m.name.clone(),
            subdivision: Subdivision::Delaunay.to_string(),
            source,
        })?;
    let ds = Settings {
        heuristic: HeuristicKind::Aperture,
        stop: HeuristicKind::Aperture.default_stop(),
        ..Settings::default()
    };
    let dec = Decimation::run(&cells.cx, &ds);
    let v = PartitionVisibility::compute(&m.model, &cells.cx, &dec.partition, &PvsSettings::default());
    let pieces = sample::pieces_of_partition(&dec.partition);
    let scene = walk::Scene {
        model: &m.model,
        cx: &cells.cx,
        graph: &v.graph,
        polygons: &v.polygons,
        pieces: &pieces,
    };
    let mut out = Vec::new();
    for roll in [settings.roll_deg, settings.tilted_roll_deg] {
        let ws = WalkSettings {
            roll_deg: roll,
            ..*settings
        };
        let (rep, frames) = walk::walkthrough(&scene, &ws);
        let (cams, _) = walk::cameras(&scene, &ws);
        let timing = walk::time_culling(&scene, &cams, repeat);
        let (best, median) = (timing.per_frame_best(), timing.per_frame_median());
        let (cpu_best, cpu_median) = (timing.cpu_per_frame_best(), timing.cpu_per_frame_median());
        let nf = frames.len().max(1) as f64;
        let rows = rep
            .reps
            .iter()
            .enumerate()
            .map(|(k, s): (usize, &RepSummary)| Row {
                model: m.name.clone(),
                roll_deg: roll,
                window: s.name.clone(),
                cells: v.graph.cells,
                portals: v.graph.portals.len(),
                pieces: v.graph.pieces(),
                frames: rep.frames,
                mean_triangles: s.mean_triangles,
                max_triangles: s.max_triangles,
                mean_portals: s.mean_portals,
                max_portals: s.max_portals,
                mean_overdraw: s.mean_overdraw,
                frames_missing: timing.frames_missing[k],
                clips_per_frame: s.ops.plane_clips as f64 / nf,
                cpu_us_per_frame_best: cpu_best.map(|b| b[k] * 1e6),
                cpu_us_per_frame_median: cpu_median.map(|m| m[k] * 1e6),
                us_per_frame_best: best[k] * 1e6,
                us_per_frame_median: median[k] * 1e6,
                repeat: timing.repeat,
            })
            .collect();
        out.push(Walk { rows, frames, timing });
        if settings.tilted_roll_deg == settings.roll_deg {
            break;
        }
    }
    Ok(out)
}

/// The Markdown table (one section per model).
pub fn table(rows: &[Row]) -> String {
    let mut s = String::new();
    let mut last = String::new();
    for r in rows {
        let key = format!("{} {}", r.model, r.roll_deg);
        if key != last {
            last = key;
            let cam = if r.roll_deg == 0.0 {
                "level camera".to_string()
            } else {
                format!("camera rolled {}°", r.roll_deg)
            };
            let _ = writeln!(
                s,
                "\n### {}, {cam} ({} cells, {} portals, {} pieces; {} frames, {} repetitions)\n\n| window | triangles mean | worst | windows passed mean | worst | overdraw mean | frames missing a triangle | clips / frame | culling CPU µs / frame (best) | (median) | wall µs / frame (best) |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
                r.model, r.cells, r.portals, r.pieces, r.frames, r.repeat
            );
        }
        let _ = writeln!(
            s,
            "| {} | {:.1} | {} | {:.2} | {} | {:.2} | {} | {:.0} | {} | {} | {:.1} |",
            r.window,
            r.mean_triangles,
            r.max_triangles,
            r.mean_portals,
            r.max_portals,
            r.mean_overdraw,
            r.frames_missing,
            r.clips_per_frame,
            r.cpu_us_per_frame_best.map_or("–".into(), |x| format!("{x:.1}")),
            r.cpu_us_per_frame_median.map_or("–".into(), |x| format!("{x:.1}")),
            r.us_per_frame_best,
        );
    }
    s
}

/// Colours of the representations in the plots.
const COLOURS: [plotters::style::RGBColor; NREPS] = [
    plotters::style::RGBColor(0, 0, 0),
    plotters::style::RGBColor(0, 170, 200),
    plotters::style::RGBColor(150, 100, 0),
    plotters::style::RGBColor(200, 150, 0),
    plotters::style::RGBColor(230, 120, 0),
    plotters::style::RGBColor(120, 120, 120),
    plotters::style::RGBColor(31, 90, 200),
    plotters::style::RGBColor(140, 175, 235),
    plotters::style::RGBColor(208, 16, 28),
];

/// The per-frame plot of one walk: triangles rendered (top) and culling microseconds
/// (bottom: thread CPU time, else wall-clock, the fastest repetition of each frame) per
/// representation.
pub fn plot(path: &Path, w: &Walk, title: &str) -> Result<(), std::io::Error> {
    use plotters::prelude::*;
    let tris: Vec<Series> = (0..NREPS)
        .map(|k| Series {
            name: REPS[k].into(),
            colour: COLOURS[k],
            points: w
                .frames
                .iter()
                .map(|f| (f.frame as f64, f.rep_tris[k].max(1) as f64))
                .collect(),
        })
        .collect();
    let cpu = !w.timing.frame_cpu_seconds.is_empty();
    let per_frame = if cpu {
        &w.timing.frame_cpu_seconds
    } else {
        &w.timing.frame_seconds
    };
    let times: Vec<Series> = (0..NREPS)
        .map(|k| Series {
            name: REPS[k].into(),
            colour: COLOURS[k],
            points: per_frame
                .iter()
                .enumerate()
                .map(|(f, s)| (f as f64, (s[k] * 1e6).max(1e-3)))
                .collect(),
        })
        .collect();
    let range = |ss: &[Series], floor: f64| {
        let mut lo = f64::INFINITY;
        let mut hi = floor;
        for p in ss.iter().flat_map(|s| &s.points) {
            lo = lo.min(p.1);
            hi = hi.max(p.1);
        }
        (lo.min(hi) / 1.5, hi * 1.5)
    };
    let x_max = w.frames.len().max(2) as f64;
    let root = BitMapBackend::new(path, (1200, 1000)).into_drawing_area();
    root.fill(&WHITE).map_err(perr)?;
    let (top, bottom) = root.split_vertically(500);
    let t1 = format!("{title}: triangles rendered per frame");
    log_lines(
        &top,
        &Panel {
            title: &t1,
            x_max,
            y: (1.0, range(&tris, 10.0).1),
            y_desc: "triangles (log)",
        },
        &tris,
    )?;
    let t2 = format!(
        "culling {} time per frame (fastest of {} repetitions)",
        if cpu { "CPU" } else { "wall-clock" },
        w.timing.repeat
    );
    log_lines(
        &bottom,
        &Panel {
            title: &t2,
            x_max,
            y: range(&times, 1.0),
            y_desc: "microseconds (log)",
        },
        &times,
    )?;
    root.present().map_err(perr)?;
    Ok(())
}

fn perr<E: std::fmt::Debug>(e: E) -> std::io::Error {
    std::io::Error::other(format!("{e:?}"))
}

/// The file stem of a walk's per-frame files: `<model>_level` or `<model>_roll<deg>`.
pub fn stem(model: &str, roll: f64) -> String {
    if roll == 0.0 {
        format!("{model}_level")
    } else {
        format!("{model}_roll{roll}")
    }
}

/// Writes one walk's per-frame CSV (`frames_<stem>.csv`: per representation triangles,
/// windows passed and the fastest culling microseconds) and plot (`frames_<stem>.png`).
pub fn write_walk(dir: &Path, w: &Walk) -> Result<Vec<PathBuf>, VisibilityBenchError> {
    let werr = |path: &Path, e: &dyn std::fmt::Display| VisibilityBenchError::Write {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    std::fs::create_dir_all(dir).map_err(|e| werr(dir, &e))?;
    let Some(r0) = w.rows.first() else {
        return Ok(Vec::new());
    };
    let stem = stem(&r0.model, r0.roll_deg);
    let csv_path = dir.join(format!("frames_{stem}.csv"));
    let mut s = String::from("frame,cell");
    for k in REPS {
        let _ = write!(s, ",{k}_triangles,{k}_windows,{k}_cpu_us,{k}_us");
    }
    s.push('\n');
    for (f, fr) in w.frames.iter().enumerate() {
        let _ = write!(s, "{},{}", fr.frame, fr.cell);
        for k in 0..NREPS {
            let us = w.timing.frame_seconds.get(f).map_or(0.0, |t| t[k] * 1e6);
            let cpu = w.timing.frame_cpu_seconds.get(f).map_or(f64::NAN, |t| t[k] * 1e6);
            let _ = write!(s, ",{},{},{cpu:.3},{us:.3}", fr.rep_tris[k], fr.rep_portals[k]);
        }
        s.push('\n');
    }
    crate::model::write::write_atomic(&csv_path, s.as_bytes()).map_err(|e| werr(&csv_path, &e))?;
    let png = dir.join(format!("frames_{stem}.png"));
    let cam = if r0.roll_deg == 0.0 {
        "level".to_string()
    } else {
        format!("rolled {}°", r0.roll_deg)
    };
    plot(&png, w, &format!("{} ({cam})", r0.model)).map_err(|e| werr(&png, &e))?;
    Ok(vec![csv_path, png])
}

/// Writes `walkthrough.csv` and `walkthrough.md` (with `command` and `preamble` at the top)
/// into `dir`; returns the paths.
pub fn write(dir: &Path, rows: &[Row], command: &str, preamble: &str) -> Result<Vec<PathBuf>, VisibilityBenchError> {
    let werr = |path: &Path, e: &dyn std::fmt::Display| VisibilityBenchError::Write {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    std::fs::create_dir_all(dir).map_err(|e| werr(dir, &e))?;
    let csv_path = dir.join("walkthrough.csv");
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).map_err(|e| werr(&csv_path, &e))?;
    }
    let bytes = w.into_inner().map_err(|e| werr(&csv_path, &e.into_error()))?;
    crate::model::write::write_atomic(&csv_path, &bytes).map_err(|e| werr(&csv_path, &e))?;
    let md_path = dir.join("walkthrough.md");
    let md = format!(
        "# Portal window representations along the walkthroughs (issue 14)\n\nMade by `{command}` (columns: `walkthrough.csv`; per frame: `frames_<model>_<camera>.csv` and `.png`).\n\n{preamble}\n{}",
        table(rows)
    );
    crate::model::write::write_atomic(&md_path, md.as_bytes()).map_err(|e| werr(&md_path, &e))?;
    Ok(vec![csv_path, md_path])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thesis_model_gets_every_representation_and_timings() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let ms = models(root, &["four_room_optimized".to_string()]).unwrap();
        assert_eq!(ms.len(), 1);
        let ws = WalkSettings {
            max_frames: 60,
            mask_width: 64,
            ..WalkSettings::default()
        };
        let walks = run_model(&ms[0], &ws, 2).unwrap();
        assert_eq!(walks.len(), 2, "level and tilted");
        for w in &walks {
            assert_eq!(w.rows.len(), NREPS);
            assert_eq!(w.timing.frame_seconds.len(), w.frames.len());
            assert_eq!(w.timing.run_seconds.len(), 2);
            let exact = &w.rows[0];
            for r in &w.rows {
                assert_eq!(r.frames_missing, 0, "{r:?}");
                assert!(r.mean_triangles + 1e-9 >= exact.mean_triangles, "{r:?}");
                assert!(r.max_triangles as f64 >= r.mean_triangles, "{r:?}");
                assert!(r.us_per_frame_best > 0.0 && r.us_per_frame_best <= r.us_per_frame_median + 1e-9);
                if let (Some(b), Some(m)) = (r.cpu_us_per_frame_best, r.cpu_us_per_frame_median) {
                    assert!(b >= 0.0 && b <= m + 1e-9, "{r:?}");
                }
            }
        }
        let rows: Vec<Row> = walks.iter().flat_map(|w| w.rows.clone()).collect();
        let t = table(&rows);
        assert!(t.contains("camera rolled 30°") && t.contains("level camera"));
    }
}
