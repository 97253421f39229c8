//! Run outputs: `result.json` (schema in `docs/result-schema.md`), `weight_curve.csv`,
//! `weight_curve.png` and the top view `cells.svg`; reading `result.json` back and point
//! location in its cells.
//!
//! Every file is written by an [`Exporter`] (the list is [`exporters`]; a new format is
//! one new file plus one line there). [`write_run`] writes a run's files as one set: staged
//! in a hidden sibling directory, swapped in, `manifest.json` last (the module `set`
//! explains each failure mode); an error leaves the output directory as it was, and only
//! files of the previous run's set are ever replaced or removed.

mod cells_obj;
pub mod compare;
mod dot;
mod error;
mod export;
mod gltf;
mod leak_pts;
mod locate;
mod notes;
pub mod plot;
mod prt;
mod result_json;
mod set;
pub mod svg;
mod viewer;
mod weight_csv;

pub use error::OutputError;
pub use export::{ExportContext, Exporter, exporters, opt_in_formats, write_atomic};
pub use leak_pts::LEAK_FILE;
pub use locate::{Locator, read_points};
pub use notes::Notes;
pub use plot::register_fonts;
pub use plot::{ScatterPoint, scatter};
pub use prt::{MAX_POINTS_ON_WINDING, MAX_PORTALS_ON_LEAF, PrtFile, PrtLimits, PrtPortal, parse_prt, prt_file};
pub use result_json::strip_timings_json;
pub use set::{
    FileEntry, HashingWriter, MANIFEST_FILE, MANIFEST_SCHEMA, MANIFEST_VERSION, MANIFEST_VERSION_MIN, Manifest,
    SetOptions, Written, check_output_dir, check_run, interrupt, read_manifest, remove_run, verify_file, write_run,
    write_run_with,
};
pub use svg::cells_svg;
pub use viewer::{VIEWER_FILE, viewer_html, viewer_json};
pub use weight_csv::write_weight_csv;

use crate::complex::{CellComplex, ComplexStats};
use crate::decimate::{Decimation, DecimationStats, Estimator, HeuristicKind, QueueMode, StopReason};
use crate::model::Model;
use crate::predicates::P3;
use crate::tolerances::Tolerances;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Value of [`ResultDoc::schema`].
pub const SCHEMA: &str = "portalfind-result";
/// Value of [`ResultDoc::schema_version`]; bumped on any incompatible change.
pub const SCHEMA_VERSION: u32 = 1;
/// The file name of the result document (what `locate` and [`read_result`] read).
pub const RESULT_FILE: &str = "result.json";

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
    /// Stage timings in seconds, in order (absent from the experiments' committed files,
    /// which leave machine-dependent figures out: [`SetOptions::strip_timings`]).
    #[serde(default)]
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
    #[serde(serialize_with = "par_seq")]
    pub cells: Vec<CellDoc>,
    /// Final portals, sorted by cell pair.
    pub portals: Vec<PortalDoc>,
    /// Openings sealed by `--seal-holes` (absent when none were).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sealed_openings: Vec<crate::complex::SealedOpening>,
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
    /// The model's recentring ([`Model::origin`]): every coordinate of the file is in the
    /// input's frame, and the document in memory is in the model's frame, `origin` less
    /// ([`ResultDoc::translated`]; [`result_doc`] builds it so, the writer adds `origin`,
    /// [`read_result`] subtracts it). Absent (zero) for models that needed none.
    #[serde(default, skip_serializing_if = "is_zero_point")]
    pub origin: P3,
}

/// Serializes a long sequence as serde_json would, with its elements encoded on every core,
/// a batch at a time (each batch's JSON text is held until written in order, so the memory
/// is a batch's; the bytes do not depend on the thread count). For serde_json's
/// serializers only (the elements are passed on as [`serde_json::value::RawValue`]s, which
/// a pretty printer would copy compact); the result document of a million-triangle run is
/// ~500 MB of cell pieces.
fn par_seq<S: serde::Serializer, T: Serialize + Sync>(v: &[T], s: S) -> Result<S::Ok, S::Error> {
    use rayon::prelude::*;
    use serde::ser::{Error, SerializeSeq};
    const BATCH: usize = 16;
    type Raw = Vec<Result<Box<serde_json::value::RawValue>, serde_json::Error>>;
    let encode = |batch: &[T]| -> Raw {
        batch
            .par_iter()
            .with_max_len(1)
            .map(serde_json::value::to_raw_value)
            .collect()
    };
    let mut seq = s.serialize_seq(Some(v.len()))?;
    // Pipelined: while this thread writes a batch (and the writer hashes it), the next
    // one is encoded by a task the other cores take.
    let mut batches = v.chunks(BATCH);
    let mut ready = batches.next().map(encode);
    while let Some(raw) = ready.take() {
        let mut next = None;
        let mut written = Ok(());
        rayon::in_place_scope(|sc| {
            if let Some(b) = batches.next() {
                sc.spawn(|_| next = Some(encode(b)));
            }
            written = raw
                .into_iter()
                .try_for_each(|r| seq.serialize_element(&r.map_err(S::Error::custom)?));
        });
        written?;
        ready = next;
    }
    seq.end()
}

fn is_zero_point(p: &P3) -> bool {
    *p == [0.0; 3]
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
    /// How the cells were made (`delaunay` or `bsp`, the names of
    /// `crate::pipeline::Subdivision`; files without it are `delaunay`).
    #[serde(default = "default_subdivision")]
    pub subdivision: String,
}

fn default_subdivision() -> String {
    "delaunay".into()
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

impl ResultDoc {
    /// The document with every coordinate moved by `t` (bounding box, piece vertices and
    /// planes, portal polygons, sealed openings' points; volumes, areas and normals do not
    /// move). Axes where `t` is zero keep their bits ([`crate::model::translate_point`]).
    pub fn translated(&self, t: P3) -> ResultDoc {
        use crate::model::translate_point as tr;
        let mut d = self.clone();
        if t == [0.0; 3] {
            return d;
        }
        d.model.bbox = d.model.bbox.map(|p| tr(p, t));
        for c in &mut d.cells {
            for p in &mut c.pieces {
                for v in &mut p.vertices {
                    *v = tr(*v, t);
                }
                for q in &mut p.planes {
                    q[3] += q[0] * t[0] + q[1] * t[1] + q[2] * t[2];
                }
            }
        }
        for p in &mut d.portals {
            for v in p.polygons.iter_mut().flatten() {
                *v = tr(*v, t);
            }
        }
        for o in &mut d.sealed_openings {
            o.point = tr(o.point, t);
        }
        d
    }

    /// The document in the input's frame, as `result.json` holds it (a copy only when the
    /// model was recentred).
    pub fn in_user_frame(&self) -> std::borrow::Cow<'_, ResultDoc> {
        if self.model.origin == [0.0; 3] {
            std::borrow::Cow::Borrowed(self)
        } else {
            std::borrow::Cow::Owned(self.translated(self.model.origin))
        }
    }
}

/// Builds the document for a finished run.
pub fn result_doc(
    model: &Model,
    model_path: &Path,
    cx: &CellComplex,
    dec: &Decimation,
    stages: &[(String, f64)],
) -> Result<ResultDoc, OutputError> {
    let (lo, hi) = model.bbox();
    let area_min = cx.tol.area_abs();
    // Every piece's document is a function of its cell alone: built on all cores (rayon),
    // collected in order, so the document does not depend on the thread count.
    use rayon::prelude::*;
    let cells = dec
        .partition
        .cells
        .par_iter()
        .map(|c| CellDoc {
            id: c.id.0,
            volume: c.volume,
            pieces: c
                .pieces
                .par_iter()
                .with_min_len(256)
                .map(|&p| {
                    let poly = &cx.cells[p.idx()].poly();
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
                        volume: cx.cell_volume(p),
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
            polygons: p.pieces.into_iter().map(|q| q.verts.into_vec()).collect(),
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
            report: serde_json::to_value(&model.report).map_err(|source| OutputError::Serialize {
                what: "the cleaning report",
                source,
            })?,
            origin: model.origin,
        },
        settings: SettingsDoc {
            heuristic: dec.settings.heuristic,
            estimator: dec.settings.estimator,
            stop: dec.settings.stop.to_string(),
            queue: dec.settings.queue,
            subdivision: default_subdivision(),
        },
        stages: stages
            .iter()
            .map(|(s, t)| StageTiming {
                stage: s.clone(),
                seconds: *t,
            })
            .collect(),
        complex: serde_json::to_value(stats).map_err(|source| OutputError::Serialize {
            what: "the complex statistics",
            source,
        })?,
        subdivision_stats: serde_json::Value::Null,
        decimation: dec.stats.clone(),
        stop_reason: dec.stop,
        cells,
        portals,
        sealed_openings: Vec::new(),
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
) -> Result<(Snapshot, ResultDoc), OutputError> {
    let initial = dec.stats.initial_cells;
    let last = dec.steps.last().map_or(initial, |s| s.cells_remaining);
    let k = if n == initial {
        Some(0)
    } else {
        dec.steps.iter().position(|s| s.cells_remaining == n).map(|i| i + 1)
    };
    let Some(k) = k else {
        return Err(OutputError::SnapshotCount { n, initial, last });
    };
    let partition = Decimation::replay(cx, &dec.steps[..k]).map_err(OutputError::Replay)?;
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

/// Checks snapshot counts before a run: a count of 0, a repeated count or one below the
/// `cells:N` stop rule's N can never be drawn, so the run is refused before any work (counts
/// above the model's active cells are found after the run, [`snapshot`]).
pub fn check_snapshot_counts(counts: &[usize], stop: &crate::decimate::StopRule) -> Result<(), OutputError> {
    for (i, &n) in counts.iter().enumerate() {
        let reason = if n == 0 {
            Some("a run never has 0 cells (it ends with one cell per connected region)".to_string())
        } else if counts[..i].contains(&n) {
            Some("the count is given twice".to_string())
        } else if let crate::decimate::StopRule::Cells(k) = *stop
            && n < k
        {
            Some(format!(
                "the stop rule cells:{k} ends the run at {k} cells; choose counts of at least {k} or lower the stop rule"
            ))
        } else {
            None
        };
        if let Some(reason) = reason {
            return Err(OutputError::SnapshotUnreachable { n, reason });
        }
    }
    Ok(())
}

/// Writes every output of [`exporters`] into `dir` (created if missing) without
/// snapshots; returns the paths written.
pub fn write_outputs(
    dir: &Path,
    model: &Model,
    doc: &ResultDoc,
    dec: &Decimation,
) -> Result<Vec<PathBuf>, OutputError> {
    write_outputs_with_snapshots(dir, model, doc, dec, &[])
}

/// As [`write_outputs`], plus the top view `cells_<N>.svg` of each snapshot (from
/// [`snapshot`]); returns the paths written, in the order of [`exporters`].
///
/// The files are one set ([`write_run`]): if any exporter fails, nothing in `dir` changes;
/// the previous run's set is replaced as a whole; files named like outputs that no
/// manifest lists make it refuse ([`OutputError::Foreign`]).
pub fn write_outputs_with_snapshots(
    dir: &Path,
    model: &Model,
    doc: &ResultDoc,
    dec: &Decimation,
    snapshots: &[(Snapshot, ResultDoc)],
) -> Result<Vec<PathBuf>, OutputError> {
    Ok(write_run(dir, model, doc, dec, snapshots, &SetOptions::default())?.files)
}

/// As [`write_outputs_with_snapshots`], plus the opt-in formats named in `export` (see
/// [`opt_in_formats`]: `prt`, `obj`, `gltf`, `dot`, `html`), which read the cell complex `cx`. An
/// unknown name is an error before anything is written.
pub fn write_outputs_exporting(
    dir: &Path,
    model: &Model,
    doc: &ResultDoc,
    dec: &Decimation,
    snapshots: &[(Snapshot, ResultDoc)],
    cx: Option<&CellComplex>,
    export: &[String],
) -> Result<Vec<PathBuf>, OutputError> {
    let opts = SetOptions {
        cx,
        export,
        ..Default::default()
    };
    Ok(write_run(dir, model, doc, dec, snapshots, &opts)?.files)
}

/// Reads `DIR/result.json` and checks it against `DIR/manifest.json` (a directory without a
/// manifest is output of an earlier version and read as is; an incomplete or disagreeing
/// manifest is an error) and its schema name and version.
pub fn read_result(dir: &Path) -> Result<ResultDoc, OutputError> {
    if read_manifest(dir)?.is_some_and(|m| !m.complete) {
        return Err(OutputError::IncompleteRun { dir: dir.to_path_buf() });
    }
    let p = dir.join(RESULT_FILE);
    let text = std::fs::read_to_string(&p).map_err(|source| OutputError::Read {
        path: p.clone(),
        source,
    })?;
    verify_file(dir, RESULT_FILE, text.as_bytes())?;
    let mut doc: ResultDoc = serde_json::from_str(&text).map_err(|source| OutputError::Parse {
        path: p.clone(),
        source,
    })?;
    // The file is in the input's frame; the document in memory in the model's.
    if doc.model.origin != [0.0; 3] {
        doc = doc.translated(doc.model.origin.map(|o| -o));
    }
    if doc.schema != SCHEMA || doc.schema_version != SCHEMA_VERSION {
        return Err(OutputError::Schema {
            path: p,
            schema: doc.schema,
            version: doc.schema_version,
        });
    }
    Ok(doc)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize)]
    struct Par<'a> {
        #[serde(serialize_with = "par_seq")]
        cells: &'a [CellDoc],
    }

    #[derive(Serialize)]
    struct Plain<'a> {
        cells: &'a [CellDoc],
    }

    /// The batched encoding writes serde_json's bytes and builds its value, across batch
    /// boundaries, for empty and odd-sized sequences.
    #[test]
    fn parallel_sequence_has_serde_jsons_bytes() {
        let mut rng = crate::base::rng::SplitMix64(11);
        for n in [0, 1, 15, 16, 17, 100] {
            let cells: Vec<CellDoc> = (0..n)
                .map(|i| CellDoc {
                    id: i as u32,
                    volume: f64::from_bits(rng.next_u64() >> 2),
                    pieces: (0..(i % 4))
                        .map(|k| PieceDoc {
                            source_cell: k as u32,
                            volume: 1.0 / (k + 3) as f64,
                            planes: vec![[0.1, -0.2, 1e-300, 3.0]; k],
                            vertices: vec![[1.5, 2.0, -7e20]; k + 1],
                        })
                        .collect(),
                })
                .collect();
            let (par, plain) = (Par { cells: &cells }, Plain { cells: &cells });
            assert_eq!(
                serde_json::to_string(&par).unwrap(),
                serde_json::to_string(&plain).unwrap()
            );
            assert_eq!(
                serde_json::to_value(&par).unwrap(),
                serde_json::to_value(&plain).unwrap()
            );
        }
    }
}
