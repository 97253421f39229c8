//! Run outputs: `result.json` (schema in `docs/result-schema.md`), `weight_curve.csv`,
//! `weight_curve.png` and the top view `cells.svg`; reading `result.json` back and point
//! location in its cells.
//!
//! Every file is written to a temporary name in the output directory and renamed into
//! place, so an error never leaves a partial file under a final name.

mod plot;
mod svg;

use crate::complex::{CellComplex, ComplexStats};
use crate::decimate::{Decimation, DecimationStats, Estimator, HeuristicKind, QueueMode, StopReason, StopRule};
use crate::model::Model;
use crate::predicates::P3;
use crate::tolerances::Tolerances;
use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Value of [`ResultDoc::schema`].
pub const SCHEMA: &str = "portalfind-result";
/// Value of [`ResultDoc::schema_version`]; bumped on any incompatible change.
pub const SCHEMA_VERSION: u32 = 1;
/// File names written by [`write_outputs`].
pub const FILES: [&str; 4] = ["result.json", "weight_curve.csv", "weight_curve.png", "cells.svg"];

/// `result.json`. See `docs/result-schema.md` for every field.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ResultDoc {
    /// Always [`SCHEMA`].
    pub schema: String,
    /// [`SCHEMA_VERSION`].
    pub schema_version: u32,
    /// `portalfind` version that wrote the file.
    pub generator: String,
    /// The input model.
    pub model: ModelInfo,
    /// Settings of the run.
    pub settings: SettingsDoc,
    /// Stage timings in seconds, in order.
    pub stages: Vec<StageTiming>,
    /// Cell-complex statistics ([`ComplexStats`], serialized as is).
    pub complex: serde_json::Value,
    /// Statistics of the subdivision itself (`bsp`: [`crate::bsp::BspStats`]; `delaunay`:
    /// tetrahedra, hull faces, seconds); `null` when not recorded.
    #[serde(default)]
    pub subdivision_stats: serde_json::Value,
    /// Decimation statistics.
    pub decimation: DecimationStats,
    /// Why the decimation stopped.
    pub stop_reason: StopReason,
    /// Final cells, sorted by id.
    pub cells: Vec<CellDoc>,
    /// Final portals, sorted by cell pair.
    pub portals: Vec<PortalDoc>,
}

/// The input model.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModelInfo {
    /// Model name.
    pub name: String,
    /// Path as given.
    pub path: String,
    /// Vertices after cleaning.
    pub vertices: usize,
    /// Polygons after cleaning.
    pub polygons: usize,
    /// Triangles (fan count).
    pub triangles: usize,
    /// Bounding box `[lo, hi]`.
    pub bbox: [P3; 2],
    /// Tolerances used (relative to `scale`).
    pub tolerances: Tolerances,
    /// The cleaning report (`CleaningReport`, serialized as is).
    pub report: serde_json::Value,
}

/// Settings of the run.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SettingsDoc {
    /// Heuristic name.
    pub heuristic: HeuristicKind,
    /// Estimator name.
    pub estimator: Estimator,
    /// Stop rule as on the command line (`threshold:W`, `cells:N`, `none`).
    pub stop: String,
    /// Queue variant (identical results).
    pub queue: QueueMode,
    /// How the cells were made (`delaunay` or `bsp`; files without it are `delaunay`).
    #[serde(default)]
    pub subdivision: crate::complex::Subdivision,
}

/// One stage's time.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StageTiming {
    /// Stage name.
    pub stage: String,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// A final (merged) cell.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CellDoc {
    /// Cell id: the smallest complex cell id among its pieces.
    pub id: u32,
    /// Volume (sum of the pieces').
    pub volume: f64,
    /// Convex pieces.
    pub pieces: Vec<PieceDoc>,
}

/// A convex piece of a final cell.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PieceDoc {
    /// Its cell id in the complex.
    pub source_cell: u32,
    /// Volume.
    pub volume: f64,
    /// Outward face planes `[nx, ny, nz, d]` with unit `n`: inside is `n·x <= d`.
    pub planes: Vec<[f64; 4]>,
    /// Distinct vertices.
    pub vertices: Vec<P3>,
}

/// All portals between two final cells.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PortalDoc {
    /// The two cell ids, `cells[0] < cells[1]`.
    pub cells: [u32; 2],
    /// Summed area.
    pub area: f64,
    /// Unit portal-plane normal from `cells[0]` to `cells[1]`.
    pub mean_normal: P3,
    /// Convex polygons (vertex lists, counter-clockwise around the direction from
    /// `cells[0]` to `cells[1]`).
    pub polygons: Vec<Vec<P3>>,
}

/// Builds the document for a finished run.
pub fn result_doc(
    model: &Model,
    model_path: &Path,
    cx: &CellComplex,
    dec: &Decimation,
    stages: &[(String, f64)],
) -> Result<ResultDoc> {
    let (lo, hi) = model.bbox();
    let area_min = cx.tol.area_abs();
    let cells = dec
        .partition
        .cells
        .iter()
        .map(|c| CellDoc {
            id: c.id.0,
            volume: c.volume,
            pieces: c
                .pieces
                .iter()
                .map(|&p| {
                    let poly = &cx.cells[p.idx()].poly;
                    let mut planes: Vec<[f64; 4]> = Vec::new();
                    for (f, pl) in poly.faces.iter().zip(poly.planes()) {
                        // Tiny faces have unreliable planes (and `contains` ignores them).
                        let row = [pl.n[0], pl.n[1], pl.n[2], pl.d];
                        if f.area() >= area_min && !planes.contains(&row) {
                            planes.push(row);
                        }
                    }
                    PieceDoc {
                        source_cell: p.0,
                        volume: poly.volume(),
                        planes,
                        vertices: poly.vertices(),
                    }
                })
                .collect(),
        })
        .collect();
    let portals = dec
        .partition
        .portals(cx)
        .into_iter()
        .map(|p| PortalDoc {
            cells: [p.cells[0].0, p.cells[1].0],
            area: p.area,
            mean_normal: p.mean_normal,
            polygons: p.pieces.into_iter().map(|q| q.verts).collect(),
        })
        .collect();
    let stats: &ComplexStats = &cx.stats;
    Ok(ResultDoc {
        schema: SCHEMA.to_string(),
        schema_version: SCHEMA_VERSION,
        generator: format!("portalfind {}", env!("CARGO_PKG_VERSION")),
        model: ModelInfo {
            name: model.name.clone(),
            path: model_path.display().to_string(),
            vertices: model.vertices.len(),
            polygons: model.polygons.len(),
            triangles: model.triangle_count(),
            bbox: [lo, hi],
            tolerances: model.tolerances,
            report: serde_json::to_value(&model.report)?,
        },
        settings: SettingsDoc {
            heuristic: dec.settings.heuristic,
            estimator: dec.settings.estimator,
            stop: dec.settings.stop.to_string(),
            queue: dec.settings.queue,
            subdivision: crate::complex::Subdivision::Delaunay,
        },
        stages: stages
            .iter()
            .map(|(s, t)| StageTiming {
                stage: s.clone(),
                seconds: *t,
            })
            .collect(),
        complex: serde_json::to_value(stats)?,
        subdivision_stats: serde_json::Value::Null,
        decimation: dec.stats.clone(),
        stop_reason: dec.stop,
        cells,
        portals,
    })
}

/// Writes `path`'s content through a temporary file in the same directory (named with the
/// same extension, as plotters picks the image format from it) and renames it into place.
fn write_atomic(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .context("output path has no file name")?
        .to_string_lossy();
    let tmp = dir.join(format!(".{}.tmp-{}.{}", name, std::process::id(), ext(path)));
    let r = write(&tmp).and_then(|()| {
        std::fs::rename(&tmp, path).with_context(|| format!("cannot rename {} to {}", tmp.display(), path.display()))
    });
    if r.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    r
}

fn ext(p: &Path) -> String {
    p.extension()
        .map(|e| e.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Rows of `weight_curve.csv`.
pub fn write_weight_csv(path: &Path, dec: &Decimation) -> Result<()> {
    write_atomic(path, |tmp| {
        let mut w = csv::Writer::from_path(tmp)?;
        w.write_record([
            "step",
            "weight",
            "cells_remaining",
            "cell_a",
            "cell_b",
            "portal_area",
            "projected_a",
            "projected_b",
        ])?;
        for (i, s) in dec.steps.iter().enumerate() {
            w.write_record([
                (i + 1).to_string(),
                s.weight.to_string(),
                s.cells_remaining.to_string(),
                s.a.0.to_string(),
                s.b.0.to_string(),
                s.portal_area.to_string(),
                s.projected[0].to_string(),
                s.projected[1].to_string(),
            ])?;
        }
        w.flush()?;
        Ok(())
    })
}

/// An intermediate state of a run, rebuilt by replay: what `cells_<N>.svg` shows.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    /// Cells left.
    pub cells: usize,
    /// Collapses replayed to reach them.
    pub collapses: usize,
    /// Weight of the last of those collapses (`None` for the initial state).
    pub last_weight: Option<f64>,
    /// Weight of the run's next collapse (`None` if the run stopped there).
    pub next_weight: Option<f64>,
    /// Pairs of cells with portals between them.
    pub portal_pairs: usize,
    /// Their summed portal area.
    pub portal_area: f64,
    /// The top view's file name, in the output directory.
    pub file: String,
}

/// The state of a run with `n` cells left, rebuilt from its recorded steps
/// ([`Decimation::replay`]), as a [`Snapshot`] and the [`ResultDoc`] its top view draws.
/// An error (naming the counts the run passed through) if the run never had `n` cells.
pub fn snapshot(
    model: &Model,
    model_path: &Path,
    cx: &CellComplex,
    dec: &Decimation,
    n: usize,
) -> Result<(Snapshot, ResultDoc)> {
    let initial = dec.stats.initial_cells;
    let last = dec.steps.last().map_or(initial, |s| s.cells_remaining);
    let k = if n == initial {
        Some(0)
    } else {
        dec.steps.iter().position(|s| s.cells_remaining == n).map(|i| i + 1)
    };
    let Some(k) = k else {
        bail!(
            "snapshot at {n} cells: the run went from {initial} cells down to {last}; \
             choose counts in that range (lower the stop rule to reach fewer cells)"
        );
    };
    let partition = Decimation::replay(cx, &dec.steps[..k]).context("replaying the recorded steps")?;
    let state = Decimation {
        settings: dec.settings,
        steps: Vec::new(),
        stop: StopReason::Cells { target: n },
        stats: dec.stats.clone(),
        partition,
    };
    let mut doc = result_doc(model, model_path, cx, &state, &[])?;
    doc.settings.stop = format!("snapshot at {n} cells, after {k} collapses");
    let snap = Snapshot {
        cells: n,
        collapses: k,
        last_weight: k.checked_sub(1).map(|i| dec.steps[i].weight),
        next_weight: dec.steps.get(k).map(|s| s.weight),
        portal_pairs: doc.portals.len(),
        portal_area: doc.portals.iter().map(|p| p.area).sum(),
        file: format!("cells_{n}.svg"),
    };
    Ok((snap, doc))
}

/// Writes all four outputs into `dir` (created if missing); returns their paths.
pub fn write_outputs(dir: &Path, model: &Model, doc: &ResultDoc, dec: &Decimation) -> Result<Vec<PathBuf>> {
    write_outputs_with_snapshots(dir, model, doc, dec, &[])
}

/// As [`write_outputs`], plus the top view `cells_<N>.svg` of each snapshot (from
/// [`snapshot`]); returns the paths written.
pub fn write_outputs_with_snapshots(
    dir: &Path,
    model: &Model,
    doc: &ResultDoc,
    dec: &Decimation,
    snapshots: &[(Snapshot, ResultDoc)],
) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut paths: Vec<PathBuf> = FILES.iter().map(|f| dir.join(f)).collect();
    // Each file goes through a temporary name; `result.json` (what `locate` reads) comes
    // last, and if any file fails, the ones this call already wrote are removed, so a
    // failed run never leaves a partial set behind.
    let mut written: Vec<PathBuf> = Vec::new();
    let result = (|| -> Result<()> {
        for (snap, sdoc) in snapshots {
            let path = dir.join(&snap.file);
            let svg = svg::cells_svg(model, sdoc);
            write_atomic(&path, |tmp| Ok(std::fs::write(tmp, svg)?))
                .with_context(|| format!("writing {}", snap.file))?;
            written.push(path);
        }
        write_weight_csv(&paths[1], dec).context("writing weight_curve.csv")?;
        written.push(paths[1].clone());
        let threshold = match dec.settings.stop {
            StopRule::Threshold(w) => Some(w),
            _ => None,
        };
        let title = format!(
            "{}: {} / {}, {} collapses",
            model.name,
            dec.settings.heuristic,
            dec.settings.estimator,
            dec.steps.len()
        );
        write_atomic(&paths[2], |tmp| plot::weight_curve(tmp, &dec.steps, &title, threshold))
            .context("writing weight_curve.png")?;
        written.push(paths[2].clone());
        let svg = svg::cells_svg(model, doc);
        write_atomic(&paths[3], |tmp| Ok(std::fs::write(tmp, svg)?)).context("writing cells.svg")?;
        written.push(paths[3].clone());
        write_atomic(&paths[0], |tmp| {
            let f = std::io::BufWriter::new(std::fs::File::create(tmp)?);
            serde_json::to_writer(f, doc)?;
            Ok(())
        })
        .context("writing result.json")?;
        Ok(())
    })();
    if let Err(e) = result {
        for p in &written {
            let _ = std::fs::remove_file(p);
        }
        return Err(e);
    }
    paths.extend(snapshots.iter().map(|(s, _)| dir.join(&s.file)));
    Ok(paths)
}

/// Reads `DIR/result.json` and checks its schema name and version.
pub fn read_result(dir: &Path) -> Result<ResultDoc> {
    let p = dir.join(FILES[0]);
    let text = std::fs::read_to_string(&p).with_context(|| format!("cannot read {}", p.display()))?;
    let doc: ResultDoc = serde_json::from_str(&text).with_context(|| format!("bad {}", p.display()))?;
    if doc.schema != SCHEMA || doc.schema_version != SCHEMA_VERSION {
        bail!(
            "{} has schema {} v{}, expected {SCHEMA} v{SCHEMA_VERSION}",
            p.display(),
            doc.schema,
            doc.schema_version
        );
    }
    Ok(doc)
}

/// Point location in the final cells of a [`ResultDoc`].
pub struct Locator<'a> {
    doc: &'a ResultDoc,
    /// (cell index, piece index, aabb lo, aabb hi), by cell id order.
    boxes: Vec<(usize, usize, P3, P3)>,
    slack: f64,
}

impl<'a> Locator<'a> {
    /// Prepares the pieces' bounding boxes. A point counts as inside a piece when it is
    /// within the plane tolerance (`tolerances.plane_abs()`) of the inside of every plane.
    pub fn new(doc: &'a ResultDoc) -> Self {
        let mut boxes = Vec::new();
        for (ci, c) in doc.cells.iter().enumerate() {
            for (pi, p) in c.pieces.iter().enumerate() {
                let mut lo = [f64::INFINITY; 3];
                let mut hi = [f64::NEG_INFINITY; 3];
                for v in &p.vertices {
                    for k in 0..3 {
                        lo[k] = lo[k].min(v[k]);
                        hi[k] = hi[k].max(v[k]);
                    }
                }
                boxes.push((ci, pi, lo, hi));
            }
        }
        Locator {
            doc,
            boxes,
            slack: doc.model.tolerances.plane_abs(),
        }
    }

    /// The id of the final cell containing `p` (the lowest id if it lies on a shared
    /// boundary), or `None` (outside every cell: in a wall, outside the model, or in a
    /// sliver gap).
    pub fn locate(&self, p: &P3) -> Option<u32> {
        let s = self.slack;
        for &(ci, pi, lo, hi) in &self.boxes {
            if (0..3).any(|k| p[k] < lo[k] - s || p[k] > hi[k] + s) {
                continue;
            }
            let piece = &self.doc.cells[ci].pieces[pi];
            if piece
                .planes
                .iter()
                .all(|q| q[0] * p[0] + q[1] * p[1] + q[2] * p[2] - q[3] <= s)
            {
                return Some(self.doc.cells[ci].id);
            }
        }
        None
    }
}

/// Parses `x,y,z` rows (blank lines and lines starting with `#` skipped; a first row that
/// does not parse as numbers is taken as a header).
pub fn read_points(path: &Path) -> Result<Vec<P3>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut out = Vec::new();
    let mut header_allowed = true;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = t.split(',').map(|s| s.trim()).collect();
        let nums: Option<Vec<f64>> = f.iter().map(|s| s.parse::<f64>().ok()).collect();
        let first = std::mem::replace(&mut header_allowed, false);
        match nums {
            Some(v) if v.len() == 3 && v.iter().all(|x| x.is_finite()) => out.push([v[0], v[1], v[2]]),
            // A header row (names such as `x,y,z`), not a malformed first point.
            None if first && f.len() == 3 && f.iter().all(|s| s.starts_with(|c: char| c.is_ascii_alphabetic())) => {
                continue;
            }
            Some(v) if v.len() == 3 => bail!(
                "{}:{}: coordinates must be finite numbers, got {t:?}",
                path.display(),
                i + 1
            ),
            _ => bail!("{}:{}: expected x,y,z, got {t:?}", path.display(), i + 1),
        }
    }
    if out.is_empty() {
        bail!(
            "{}: no points (expected x,y,z rows, optionally after a header row)",
            path.display()
        );
    }
    Ok(out)
}
