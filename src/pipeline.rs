//! The one pipeline: load → subdivide (Delaunay or BSP) → cell complex → decimation →
//! result document. `portalfind run`, `portalfind complex` and the experiment runner all
//! call it; the binary adds only progress bars and printing.
//!
//! - [`load`]: read and clean a model file (timed).
//! - [`build_cells`]: the one dispatch on the [`Subdivision`]: the cell complex with the
//!   stages before its own timings and typed [`SubdivisionStats`].
//! - [`run_model`]: cells, decimation and the [`ResultDoc`] for a model already in memory;
//!   [`run`] loads the file first.
//!
//! Progress is reported through `&mut dyn FnMut(Progress)`: the [`Stage`] and how much of
//! it is done. Writing the outputs is [`crate::output`]'s business ([`crate::output::write_outputs`]).
//!
//! # Example
//!
//! ```
//! use portalfind::decimate::StopRule;
//! use portalfind::pipeline::{self, Settings};
//!
//! // Two box rooms joined by a door, as a `.mesh` file.
//! let s = portalfind::generate::scenes::two_rooms();
//! let dir = std::env::temp_dir().join(format!("portalfind-doctest-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let path = dir.join("two_rooms.mesh");
//! std::fs::write(&path, portalfind::model::write::mesh_text(&s.vertices, &s.polygons)).unwrap();
//!
//! let mut settings = Settings::default();
//! settings.decimation.stop = StopRule::Cells(2);
//! let (model, run) = pipeline::run(&path, &settings, &mut |_progress| {}).unwrap();
//! assert_eq!(model.polygons.len(), run.doc.model.polygons);
//! assert_eq!(run.doc.cells.len(), 2); // one cell per room
//! assert_eq!(run.doc.portals.len(), 1); // the door
//! assert_eq!(run.stages[0].0, "load model");
//! std::fs::remove_dir_all(&dir).unwrap();
//! ```

use crate::bsp::{BspSettings, BspStats};
use crate::complex::{CellComplex, SealedOpening};
use crate::decimate::Decimation;
use crate::delaunay::{DelaunayError, Tetrahedralization};
use crate::model::{Model, ModelError};
use crate::output::{self, OutputError, ResultDoc};
use crate::tolerances::{FALLBACK_LEVELS, Tolerances};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;
use std::str::FromStr;
use std::time::Instant;

/// The seed of the Delaunay insertion order (the result does not depend on it, only the
/// running time does).
pub const DEFAULT_SEED: u64 = 0x5eed;

/// How space is subdivided into cells.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Subdivision {
    /// Delaunay tetrahedralization split by the model's polygons (thesis ch. 4).
    #[default]
    Delaunay,
    /// A BSP tree of the model's polygons (the thesis's baseline, 4.3.3).
    Bsp,
}

impl Subdivision {
    /// Every subdivision, in the order of [`Subdivision::NAMES`].
    pub const ALL: [Subdivision; 2] = [Subdivision::Delaunay, Subdivision::Bsp];
    /// The names that [`FromStr`] accepts.
    pub const NAMES: [&'static str; 2] = ["delaunay", "bsp"];

    /// The name (`delaunay`, `bsp`).
    pub fn name(self) -> &'static str {
        match self {
            Subdivision::Delaunay => "delaunay",
            Subdivision::Bsp => "bsp",
        }
    }
}

impl fmt::Display for Subdivision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A subdivision name that is not one of [`Subdivision::NAMES`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown subdivision {name:?}; use delaunay or bsp")]
pub struct UnknownSubdivision {
    /// The name given.
    pub name: String,
}

impl FromStr for Subdivision {
    type Err = UnknownSubdivision;
    fn from_str(s: &str) -> Result<Self, UnknownSubdivision> {
        Subdivision::ALL
            .into_iter()
            .find(|d| d.name() == s)
            .ok_or_else(|| UnknownSubdivision { name: s.to_string() })
    }
}

/// How cells are made: the subdivision and the settings of each kind.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellSettings {
    /// Delaunay or BSP.
    pub subdivision: Subdivision,
    /// Seed of the Delaunay insertion order ([`DEFAULT_SEED`]).
    pub seed: u64,
    /// BSP plane choice.
    pub bsp: BspSettings,
    /// Seal openings of leaking regions: cracks ([`SealSize::Auto`], the default) or
    /// openings narrower than a size ([`CellComplex::seal_holes`]); `None`: no sealing.
    pub seal_holes: Option<SealSize>,
}

impl Default for CellSettings {
    fn default() -> Self {
        CellSettings {
            subdivision: Subdivision::Delaunay,
            seed: DEFAULT_SEED,
            bsp: BspSettings::default(),
            seal_holes: Some(SealSize::Auto),
        }
    }
}

/// The smallest opening that is not sealed: in model units (`0.25`), or as a percentage
/// of the model's bounding-box diagonal (`1%`); or `auto`, cracks only
/// ([`CellComplex::seal_cracks_auto`]: openings narrower than the sliver width).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SealSize {
    /// Cracks only, no size given ([`CellComplex::seal_cracks_auto`]).
    Auto,
    /// Model units.
    Units(f64),
    /// Percent of the bounding-box diagonal.
    PercentOfDiagonal(f64),
}

impl SealSize {
    /// In model units, for `model` (`None` for [`SealSize::Auto`]).
    pub fn resolve(self, model: &Model) -> Option<f64> {
        match self {
            SealSize::Auto => None,
            SealSize::Units(u) => Some(u),
            SealSize::PercentOfDiagonal(p) => Some(p / 100.0 * model.tolerances.scale),
        }
    }
}

impl fmt::Display for SealSize {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SealSize::Auto => f.write_str("auto"),
            SealSize::Units(u) => write!(f, "{u}"),
            SealSize::PercentOfDiagonal(p) => write!(f, "{p}%"),
        }
    }
}

/// A sealing size that is not a positive finite number (optionally followed by `%`).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "bad hole size {text:?}: use a positive size in model units (0.25), a percentage of the bounding-box diagonal (1%) or auto"
)]
pub struct BadSealSize {
    /// The text given.
    pub text: String,
}

impl FromStr for SealSize {
    type Err = BadSealSize;
    fn from_str(s: &str) -> Result<Self, BadSealSize> {
        let bad = || BadSealSize { text: s.to_string() };
        let t = s.trim();
        if t == "auto" {
            return Ok(SealSize::Auto);
        }
        let (num, pct) = match t.strip_suffix('%') {
            Some(n) => (n.trim(), true),
            None => (t, false),
        };
        let x: f64 = num.parse().map_err(|_| bad())?;
        if !x.is_finite() || x <= 0.0 {
            return Err(bad());
        }
        Ok(if pct {
            SealSize::PercentOfDiagonal(x)
        } else {
            SealSize::Units(x)
        })
    }
}

impl CellSettings {
    /// The default settings of `subdivision`.
    pub fn of(subdivision: Subdivision) -> Self {
        CellSettings {
            subdivision,
            ..CellSettings::default()
        }
    }
}

/// Settings of a whole run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Settings {
    /// How cells are made.
    pub cells: CellSettings,
    /// The decimation (heuristic, estimator, stop rule, queue).
    pub decimation: crate::decimate::Settings,
}

/// A stage of the pipeline, as reported to the progress callback.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Inserting points into the tetrahedralization (`done`/`total` points).
    Tetrahedralize,
    /// A stage of [`CellComplex::build_with_progress`], by its name.
    Complex(&'static str),
    /// Collapsing cell pairs: `done` collapses, `total` = collapses + cells left, with
    /// `cells` left.
    Decimate {
        /// Cells left.
        cells: usize,
    },
}

impl Stage {
    /// A short name for progress bars.
    pub fn name(&self) -> &'static str {
        match self {
            Stage::Tetrahedralize => "tetrahedralizing",
            Stage::Complex(s) => s,
            Stage::Decimate { .. } => "decimating",
        }
    }
}

/// A progress report: the stage and how far it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    /// The stage.
    pub stage: Stage,
    /// Work done.
    pub done: usize,
    /// Work in total (may grow).
    pub total: usize,
}

/// Statistics of the Delaunay subdivision.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DelaunayStats {
    /// Finite tetrahedra.
    pub tetrahedra: usize,
    /// Convex hull faces.
    pub hull_faces: usize,
    /// Time of the tetrahedralization.
    pub tetrahedralization_seconds: f64,
}

/// Statistics of the subdivision itself (what `result.json` calls `subdivision_stats`).
#[derive(Clone, Debug)]
pub enum SubdivisionStats {
    /// Tetrahedralization counts.
    Delaunay(DelaunayStats),
    /// BSP counts.
    Bsp(BspStats),
}

impl SubdivisionStats {
    /// As JSON: an object with the fields of [`DelaunayStats`] or [`BspStats`].
    pub fn to_json(&self) -> serde_json::Value {
        let v = match self {
            SubdivisionStats::Delaunay(s) => serde_json::to_value(s),
            SubdivisionStats::Bsp(s) => serde_json::to_value(s),
        };
        // Plain structs of numbers always serialize.
        v.unwrap_or(serde_json::Value::Null)
    }
}

/// Why the pipeline failed. Each names the model and what to do.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// The model file cannot be loaded.
    #[error("cannot load the model")]
    Load(#[source] Box<ModelError>),
    /// The tetrahedralization cannot be built.
    #[error("cannot tetrahedralize {model}")]
    Tetrahedralize {
        /// The model's path or name.
        model: String,
        /// Why.
        #[source]
        source: DelaunayError,
    },
    /// The cell complex came out invalid (a bug or an input it cannot handle yet): the
    /// run stops rather than decimate a broken complex.
    #[error(
        "the cell complex of {model} is invalid at the model's tolerances and at every fallback level ({levels} built); please report the model (`portalfind complex MODEL` prints the full validation)"
    )]
    InvalidComplex {
        /// The model's path or name.
        model: String,
        /// Levels built and rejected ([`Tolerances::fallback`]).
        levels: usize,
        /// The first violated invariant.
        #[source]
        source: crate::complex::ComplexError,
    },
    /// The result document cannot be assembled.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The model recorded in a run's result.json is not found ([`run_model_path`]).
    #[error(transparent)]
    ModelNotFound(Box<ModelNotFound>),
    /// A finished run directory cannot be re-exported ([`reexport`]).
    #[error("cannot re-export {}: {why}", dir.display())]
    Reexport {
        /// The run directory.
        dir: std::path::PathBuf,
        /// Why.
        why: String,
    },
}

/// The model recorded in a run's result.json is not found ([`run_model_path`]): names the
/// recorded path, the result.json and `--model`.
#[derive(Debug, thiserror::Error)]
#[error(
    "cannot find the run's model `{recorded}` (the path recorded in {}{}); give the model's \
     path with --model PATH",
    dir.join(crate::output::RESULT_FILE).display(),
    match cwd {
        Some(cwd) => format!(
            ", relative to the folder the run was started in; tried from the current folder \
             {} and from {} and every folder above it",
            cwd.display(),
            dir.display()
        ),
        None => String::new(),
    }
)]
pub struct ModelNotFound {
    /// The path as result.json records it.
    pub recorded: String,
    /// The run directory.
    pub dir: std::path::PathBuf,
    /// The current folder, for a relative `recorded` (`None` for an absolute one).
    pub cwd: Option<std::path::PathBuf>,
}

/// The cell complex of a model and how it was made ([`build_cells`]).
pub struct Cells {
    /// The complex.
    pub cx: CellComplex,
    /// Statistics of the subdivision.
    pub stats: SubdivisionStats,
    /// Timed stages that precede the complex's own timings (`cx.stats.timings`).
    pub stages: Vec<(String, f64)>,
    /// Openings sealed ([`CellSettings::seal_holes`]; empty without it).
    pub sealed: Vec<SealedOpening>,
    /// Peak resident memory (MiB) at the end of the stages before the complex's own
    /// ([`peak_rss_mib`]; empty where it cannot be read).
    pub memory: Vec<(String, f64)>,
    /// Timed stages after the complex's own: [`build_cells`]' checks ([`CHECKS_STAGE`];
    /// empty from [`build_cells_unchecked`]), after the time spent on rejected levels
    /// ([`REJECTED_STAGE`]) when there were any.
    pub checks: Vec<(String, f64)>,
    /// The levels of [`build_cells`]' fallback ladder that were built and failed the
    /// checks, in order (empty when the model's own tolerances gave a valid complex).
    pub rejected: Vec<RejectedLevel>,
    /// The no-crossing check ([`CellComplex::check_no_crossing`]) and its seconds, when
    /// [`build_cells`] ran it beside the portal graph ([`CellComplex::build_beside`]: the
    /// Delaunay path, whose cells are final by then — sealing changes portals and exterior
    /// flags, never a cell); `None` otherwise.
    pub crossing: Option<(Result<(), crate::complex::ComplexError>, f64)>,
}

/// The process's peak resident memory so far in MiB (Linux `VmHWM`; `None` elsewhere):
/// [`Run::memory`] samples it at the end of each stage.
pub use crate::base::mem::peak_rss_mib;

/// Returns the allocator's free pages to the system (glibc's `malloc_trim`; nothing
/// elsewhere): after [`CellComplex::release_inactive`] most of what the removed cells held
/// is whole free pages, which the decimation's large arrays (fresh mappings) would not
/// reuse, so its memory came on top of the complex's.
fn trim_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `malloc_trim` only releases memory the allocator holds free; it takes no
    // pointer and is thread-safe.
    unsafe {
        libc::malloc_trim(0);
    }
}

fn sample_peak(memory: &mut Vec<(String, f64)>, stage: &str) {
    if let Some(m) = peak_rss_mib() {
        memory.push((stage.to_string(), m));
    }
}

/// Loads and cleans a model file; returns it with the seconds it took.
pub fn load(path: &Path) -> Result<(Model, f64), PipelineError> {
    let t0 = Instant::now();
    let m = crate::model::load_model(path).map_err(|e| PipelineError::Load(Box::new(e)))?;
    Ok((m, t0.elapsed().as_secs_f64()))
}

/// Where the model of the run in `dir` is, when `--model` does not say: the path its
/// result.json records ([`crate::output::ModelInfo::path`], `recorded`), as given when the run
/// was started. A relative one is tried from the current folder first, then from `dir` and
/// each folder above it (a run started in S with `--out out/x` has its results in S/out/x,
/// so its model is found from there wherever the command runs now). The second member is
/// `true` when the model was found from `dir` rather than from the current folder. The
/// model found is checked against the run by the callers (the rebuilt cells must be the
/// run's).
pub fn run_model_path(dir: &Path, recorded: &str) -> Result<(std::path::PathBuf, bool), PipelineError> {
    let p = Path::new(recorded);
    if p.exists() {
        return Ok((p.to_path_buf(), false));
    }
    let not_found = |cwd| {
        PipelineError::ModelNotFound(Box::new(ModelNotFound {
            recorded: recorded.to_string(),
            dir: dir.to_path_buf(),
            cwd,
        }))
    };
    if p.is_absolute() {
        return Err(not_found(None));
    }
    let cwd = std::env::current_dir().ok();
    let abs = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    for base in abs.ancestors() {
        let c = base.join(p);
        if c.is_file() {
            return Ok((c, true));
        }
    }
    Err(not_found(Some(cwd.unwrap_or_else(|| ".".into()))))
}

/// [`run_model_path`] of the run in `dir`. Reads only `model.path` from its result.json
/// (the rest is skipped, not built: the caller reads the whole document once, with its
/// checks, when it loads the run — a million-triangle run's result.json is ~0.5 GB).
pub fn recorded_model_path(dir: &Path) -> Result<(std::path::PathBuf, bool), PipelineError> {
    #[derive(serde::Deserialize)]
    struct Doc {
        model: Model,
    }
    #[derive(serde::Deserialize)]
    struct Model {
        path: String,
    }
    // An interrupted run is refused as reading the whole document would refuse it.
    if crate::output::read_manifest(dir)?.is_some_and(|m| !m.complete) {
        return Err(OutputError::IncompleteRun { dir: dir.to_path_buf() }.into());
    }
    let p = dir.join(crate::output::RESULT_FILE);
    let file = std::fs::File::open(&p).map_err(|source| OutputError::Read {
        path: p.clone(),
        source,
    })?;
    let doc: Doc = serde_json::from_reader(std::io::BufReader::new(file)).map_err(|source| OutputError::Parse {
        path: p.clone(),
        source,
    })?;
    run_model_path(dir, &doc.model.path)
}

/// The Delaunay cell complex of `model` with the default settings, no progress reports
/// (for tests, benchmarks and the suite).
pub fn complex_of(model: &Model) -> Result<CellComplex, PipelineError> {
    let label = std::path::PathBuf::from(&model.name);
    Ok(build_cells(model, &label, &CellSettings::default(), &mut |_| {})?.cx)
}

/// [`complex_of`] without the structural check (the caller checks and reports).
pub fn complex_of_unchecked(model: &Model) -> Result<CellComplex, PipelineError> {
    let label = std::path::PathBuf::from(&model.name);
    Ok(build_cells_unchecked(model, &label, &CellSettings::default(), &mut |_| {})?.cx)
}

/// The one dispatch on the subdivision: the cell complex of `model`, checked. `label`
/// names the model in errors (its path).
///
/// The complex is built at the model's tolerances and checked ([`check`]: every cell a
/// valid convex polyhedron, no model polygon crossing a cell); when the check fails, it
/// is built again at the fallback levels 1..=[`FALLBACK_LEVELS`] of
/// [`Tolerances::fallback`] in turn, each of which must pass the check *and* the full
/// validation ([`CellComplex::validate`]), and the first that passes is returned with its level
/// in `cx.stats.tolerance_level` and the rejected levels in [`Cells::rejected`]. When
/// none passes, the error names level 0's violated invariant.
pub fn build_cells(
    model: &Model,
    label: &Path,
    settings: &CellSettings,
    progress: &mut dyn FnMut(Progress),
) -> Result<Cells, PipelineError> {
    let attempts = build_cells_attempts(model, label, settings, progress)?;
    if attempts.valid {
        return Ok(attempts.cells);
    }
    let levels = attempts.cells.rejected.len();
    let source = attempts
        .cells
        .rejected
        .into_iter()
        .next()
        .expect("a rejected level")
        .error;
    Err(PipelineError::InvalidComplex {
        model: label.display().to_string(),
        levels,
        source,
    })
}

/// A level of [`build_cells`]' fallback ladder whose complex failed the checks.
#[derive(Debug)]
pub struct RejectedLevel {
    /// The level ([`Tolerances::fallback`]).
    pub level: u32,
    /// The BSP tree variant ([`BspSettings::variant`]; 0 for the Delaunay path).
    pub variant: u32,
    /// The tolerances used.
    pub tolerances: Tolerances,
    /// The first violated invariant.
    pub error: crate::complex::ComplexError,
    /// Seconds spent building and checking it.
    pub seconds: f64,
}

/// The outcome of [`build_cells_attempts`].
pub struct Attempts {
    /// The cells of the first level that passed the checks, or level 0's when none did.
    pub cells: Cells,
    /// Whether `cells` passed the checks.
    pub valid: bool,
}

/// The stage name of the time spent on rejected levels of the fallback ladder (in
/// [`Cells::checks`]).
pub const REJECTED_STAGE: &str = "rejected complexes (fallback tolerances)";

/// [`build_cells`]' ladder without turning its failure into an error: the complex of the
/// first level that passes the checks, or level 0's complex when none does (for
/// `portalfind complex`, which prints the full validation of what it got).
pub fn build_cells_attempts(
    model: &Model,
    label: &Path,
    settings: &CellSettings,
    progress: &mut dyn FnMut(Progress),
) -> Result<Attempts, PipelineError> {
    let mut rejected: Vec<RejectedLevel> = Vec::new();
    let mut first: Option<Cells> = None;
    let mut rejected_seconds = 0.0;
    // (tolerance level, BSP tree variant): the tolerance ladder, then for the BSP its
    // other tree variants at the model's own tolerances, then at the fallback levels.
    let variants = if settings.subdivision == Subdivision::Bsp {
        BSP_VARIANTS
    } else {
        0
    };
    let rungs = (0..=FALLBACK_LEVELS)
        .map(|l| (l, 0))
        .chain((1..=variants).map(|v| (0, v)))
        .chain((1..=FALLBACK_LEVELS).flat_map(|l| (1..=variants).map(move |v| (l, v))));
    for (level, variant) in rungs {
        let t0 = Instant::now();
        let varied;
        let settings = if variant == 0 {
            settings
        } else {
            varied = CellSettings {
                bsp: BspSettings {
                    variant,
                    ..settings.bsp
                },
                ..*settings
            };
            &varied
        };
        let coarser;
        let m = if level == 0 {
            model
        } else {
            coarser = Model {
                tolerances: model.tolerances.fallback(level),
                ..model.clone()
            };
            &coarser
        };
        let mut cells = build_cells_inner(m, label, settings, progress, true)?;
        let (beside, beside_stage) = match cells.crossing.take() {
            Some((r, secs)) => (Some(r), Some((BESIDE_STAGE.to_string(), secs))),
            None => (None, None),
        };
        // The cheap structural check on every build: never decimate (or write) a broken
        // complex. The full validation (`CellComplex::validate`) is `portalfind complex`'s.
        // A model polygon crossing a cell (a wall the portal graph does not see) is as
        // invalid: `run` must not exit 0 on it.
        // A fallback level must pass the full validation too (it is already the slow
        // path, and its coarser bands must not trade a failed check for a subtler
        // violation: a fuzz find's BSP complex passed the checks at levels 1-3 with a
        // patch whose portal area missed 1e-3 of it).
        let t1 = Instant::now();
        // The cells are final: their volumes once, for the checks and everything after.
        cells.cx.cache_volumes();
        let r = check(&cells.cx, m, beside).and_then(|()| {
            if level == 0 && variant == 0 {
                Ok(())
            } else {
                cells.cx.validate(m).map(|_| ())
            }
        });
        let check_seconds = t1.elapsed().as_secs_f64();
        match r {
            Ok(()) => {
                cells.cx.stats.tolerance_level = level;
                cells.cx.stats.rejected_levels = rejected
                    .iter()
                    .map(|r| match r.variant {
                        0 => format!("level {}: {}", r.level, r.error),
                        v => format!("level {} (BSP tree variant {v}): {}", r.level, r.error),
                    })
                    .collect();
                if rejected_seconds > 0.0 {
                    cells.checks.push((REJECTED_STAGE.into(), rejected_seconds));
                }
                cells.checks.extend(beside_stage);
                cells.checks.push((CHECKS_STAGE.into(), check_seconds));
                cells.rejected = rejected;
                return Ok(Attempts { cells, valid: true });
            }
            Err(error) => {
                let seconds = t0.elapsed().as_secs_f64();
                rejected_seconds += seconds;
                rejected.push(RejectedLevel {
                    level,
                    variant,
                    tolerances: m.tolerances,
                    error,
                    seconds,
                });
                if first.is_none() {
                    cells.checks.extend(beside_stage);
                    cells.checks.push((CHECKS_STAGE.into(), check_seconds));
                    first = Some(cells);
                }
            }
        }
    }
    let mut cells = first.expect("level 0 was built");
    cells.rejected = rejected;
    Ok(Attempts { cells, valid: false })
}

/// The BSP tree variants ([`BspSettings::variant`] 1..=this) [`build_cells`] tries after
/// every tolerance level of variant 0 failed: at the model's own tolerances, then at each
/// fallback level.
pub const BSP_VARIANTS: u32 = 4;

/// The stage name of [`build_cells`]' checks (in [`Cells::checks`] and [`Run::stages`]).
pub const CHECKS_STAGE: &str = "checks (cells valid, no crossing)";

/// `check_valid`, then `check_no_crossing`, as one result: both read the complex only and
/// run on two threads (rayon), and the error is the one the sequence would return
/// (`check_valid`'s first), so the outcome does not depend on the thread count.
fn check(
    cx: &CellComplex,
    model: &Model,
    crossing: Option<Result<(), crate::complex::ComplexError>>,
) -> Result<(), crate::complex::ComplexError> {
    match crossing {
        // Run beside the portal graph on the same cells (nothing after it changes a cell:
        // the exterior removal and sealing set flags, portals and leaks only).
        Some(crossing) => cx.check_valid().and(crossing),
        None => {
            let (valid, crossing) = rayon::join(|| cx.check_valid(), || cx.check_no_crossing(model));
            valid.and(crossing)
        }
    }
}

/// The stage name of the no-crossing check when it ran beside the portal graph
/// ([`Cells::crossing`]): its own seconds, inside the portal graph's wall time.
pub const BESIDE_STAGE: &str = "checks: no crossing (beside the portal graph)";

/// [`build_cells`] without the structural check (for `portalfind complex`, which runs the
/// full validation and reports every violation itself).
pub fn build_cells_unchecked(
    model: &Model,
    label: &Path,
    settings: &CellSettings,
    progress: &mut dyn FnMut(Progress),
) -> Result<Cells, PipelineError> {
    build_cells_inner(model, label, settings, progress, false)
}

/// [`build_cells_unchecked`]; with `check_beside`, the Delaunay path also runs the
/// no-crossing check beside the portal graph ([`Cells::crossing`]).
fn build_cells_inner(
    model: &Model,
    label: &Path,
    settings: &CellSettings,
    progress: &mut dyn FnMut(Progress),
    check_beside: bool,
) -> Result<Cells, PipelineError> {
    // Sealing (below) redoes the portal graph and the exterior removal only: it changes
    // no cell, so a crossing check run beside the first portal graph still holds.
    let mut cells = build_cells_unsealed(model, label, settings, progress, check_beside)?;
    if let Some(size) = settings.seal_holes {
        cells.sealed = match size.resolve(model) {
            None => cells.cx.seal_cracks_auto(model),
            Some(s) => cells.cx.seal_holes(model, s),
        };
    }
    Ok(cells)
}

fn build_cells_unsealed(
    model: &Model,
    label: &Path,
    settings: &CellSettings,
    progress: &mut dyn FnMut(Progress),
    check_beside: bool,
) -> Result<Cells, PipelineError> {
    match settings.subdivision {
        Subdivision::Delaunay => {
            let t0 = Instant::now();
            let t =
                Tetrahedralization::build_with_progress(&model.vertices, settings.seed, true, &mut |done, total| {
                    progress(Progress {
                        stage: Stage::Tetrahedralize,
                        done,
                        total,
                    })
                })
                .map_err(|source| PipelineError::Tetrahedralize {
                    model: label.display().to_string(),
                    source,
                })?;
            let tt = t0.elapsed().as_secs_f64();
            let mut memory = Vec::new();
            sample_peak(&mut memory, "delaunay tetrahedralization");
            let mut report = |s, done, total| {
                progress(Progress {
                    stage: Stage::Complex(s),
                    done,
                    total,
                })
            };
            let (cx, crossing) = if check_beside {
                let (cx, r) = CellComplex::build_beside(model, &t, &mut report, |cx| {
                    let t = Instant::now();
                    let r = cx.check_no_crossing(model);
                    (r, t.elapsed().as_secs_f64())
                });
                (cx, Some(r))
            } else {
                (CellComplex::build_with_progress(model, &t, &mut report), None)
            };
            Ok(Cells {
                cx,
                stats: SubdivisionStats::Delaunay(DelaunayStats {
                    tetrahedra: t.num_tets(),
                    hull_faces: t.num_hull_faces(),
                    tetrahedralization_seconds: tt,
                }),
                stages: vec![("delaunay tetrahedralization".into(), tt)],
                sealed: Vec::new(),
                memory,
                checks: Vec::new(),
                rejected: Vec::new(),
                crossing,
            })
        }
        Subdivision::Bsp => {
            let (cx, stats) = crate::bsp::build_complex_with(model, &settings.bsp);
            Ok(Cells {
                cx,
                stats: SubdivisionStats::Bsp(stats),
                stages: Vec::new(),
                sealed: Vec::new(),
                memory: Vec::new(),
                checks: Vec::new(),
                rejected: Vec::new(),
                crossing: None,
            })
        }
    }
}

/// The stage name of releasing the inactive geometry ([`CellComplex::release_inactive`] and
/// returning free pages), in [`Run::stages`].
pub const RELEASE_STAGE: &str = "release inactive geometry";

/// The stage name of assembling the result document, in [`Run::stages`] (not in the
/// document's own stages, which it records).
pub const DOCUMENT_STAGE: &str = "result document";

/// A finished run.
pub struct Run {
    /// The cell complex, its inactive geometry released
    /// ([`CellComplex::release_inactive`]: only active cells, the patches they border and
    /// the portals keep their polygons).
    pub cx: CellComplex,
    /// Statistics of the subdivision.
    pub subdivision_stats: SubdivisionStats,
    /// The decimation.
    pub dec: Decimation,
    /// The collapses of the run to the end when `dec` stopped early and the run was asked
    /// for them ([`run_model_with_curve`]); `None` otherwise.
    pub full_steps: Option<Vec<crate::decimate::Step>>,
    /// Stage timings in order (those passed in first), as in `result.json`.
    pub stages: Vec<(String, f64)>,
    /// The `result.json` document.
    pub doc: ResultDoc,
    /// Openings sealed ([`CellSettings::seal_holes`]; also in `doc.sealed_openings`).
    pub sealed: Vec<SealedOpening>,
    /// Peak resident memory of the process (MiB, [`peak_rss_mib`]) at the end of each
    /// stage: the tetrahedralization, the cell complex, the decimation, the result
    /// document (empty where it cannot be read).
    pub memory: Vec<(String, f64)>,
}

/// Cells, decimation and result document for a model already loaded. `model_path` is
/// recorded in the document (and names the model in errors); `stages` are earlier timed
/// stages (loading).
pub fn run_model(
    model: &Model,
    model_path: &Path,
    settings: &Settings,
    stages: Vec<(String, f64)>,
    progress: &mut dyn FnMut(Progress),
) -> Result<Run, PipelineError> {
    run_model_inner(model, model_path, settings, stages, false, progress)
}

/// The stage that times the decimation past the stop (the weight curve's rest): its
/// presence in `result.json` tells [`reexport`] that the run drew the full curve.
const CURVE_STAGE: &str = "decimation: past the stop (weight curve)";

/// [`run_model`], and for a run that stops early also the collapses of the run to the end
/// ([`Run::full_steps`], for the weight curve; [`Decimation::run_with_curve`]: with the
/// `clearance` engine and a threshold stop, from the same pass). Its extra time is the
/// stage `decimation: past the stop (weight curve)` in [`Run::stages`] (not in the
/// document's stages).
pub fn run_model_with_curve(
    model: &Model,
    model_path: &Path,
    settings: &Settings,
    stages: Vec<(String, f64)>,
    progress: &mut dyn FnMut(Progress),
) -> Result<Run, PipelineError> {
    run_model_inner(model, model_path, settings, stages, true, progress)
}

fn run_model_inner(
    model: &Model,
    model_path: &Path,
    settings: &Settings,
    mut stages: Vec<(String, f64)>,
    curve: bool,
    progress: &mut dyn FnMut(Progress),
) -> Result<Run, PipelineError> {
    let mut cells = build_cells(model, model_path, &settings.cells, progress)?;
    stages.extend(std::mem::take(&mut cells.stages));
    stages.extend(cells.cx.stats.timings.iter().cloned());
    stages.append(&mut cells.checks);
    let mut memory = std::mem::take(&mut cells.memory);
    memory.extend(cells.cx.stats.memory.iter().map(|(n, m)| (format!("complex: {n}"), *m)));
    sample_peak(&mut memory, "cell complex");
    // Checked: the geometry of inactive cells and unused patches is not read again, and
    // the decimation's memory reuses it.
    let t_release = Instant::now();
    cells.cx.release_inactive();
    trim_heap();
    stages.push((RELEASE_STAGE.into(), t_release.elapsed().as_secs_f64()));
    let mut report = |steps: usize, left: usize| {
        progress(Progress {
            stage: Stage::Decimate { cells: left },
            done: steps,
            total: steps + left,
        })
    };
    let t0 = Instant::now();
    let (dec, full_steps) = if curve {
        Decimation::run_with_curve(&cells.cx, &settings.decimation, &mut report)
    } else {
        (
            Decimation::run_with_progress(&cells.cx, &settings.decimation, &mut report),
            None,
        )
    };
    let past_stop = t0.elapsed().as_secs_f64() - dec.stats.init_seconds - dec.stats.collapse_seconds;
    sample_peak(&mut memory, "decimation");
    stages.push(("decimation: initial weights".into(), dec.stats.init_seconds));
    stages.push(("decimation: collapses".into(), dec.stats.collapse_seconds));
    let t_doc = Instant::now();
    let mut doc = output::result_doc(model, model_path, &cells.cx, &dec, &stages)?;
    doc.settings.subdivision = settings.cells.subdivision.to_string();
    doc.subdivision_stats = cells.stats.to_json();
    doc.sealed_openings = cells.sealed.clone();
    // The rest of the decimation's time: past the stop (when asked), else the replayed
    // partition and freeing the engine's state (after its timed collapses).
    let rest = if full_steps.is_some() {
        CURVE_STAGE
    } else {
        "decimation: partition and clean-up"
    };
    stages.push((rest.into(), past_stop.max(0.0)));
    stages.push((DOCUMENT_STAGE.into(), t_doc.elapsed().as_secs_f64()));
    sample_peak(&mut memory, "result document");
    Ok(Run {
        cx: cells.cx,
        subdivision_stats: cells.stats,
        dec,
        full_steps,
        stages,
        doc,
        sealed: cells.sealed,
        memory,
    })
}

/// Loads `path` and runs the whole pipeline: the model and the [`Run`]. The first stage
/// is `load model`.
pub fn run(
    path: &Path,
    settings: &Settings,
    progress: &mut dyn FnMut(Progress),
) -> Result<(Model, Run), PipelineError> {
    let (m, secs) = load(path)?;
    let r = run_model(&m, path, settings, vec![("load model".into(), secs)], progress)?;
    Ok((m, r))
}

/// Re-exports the finished `run` directory `dir` with the opt-in formats `export` (`prt`,
/// `obj`, `gltf`, `dot`): the cell complex is rebuilt from the model (`model`, or the path
/// recorded in `result.json`) with the run's subdivision, the recorded collapses
/// (`weight_curve.csv`) are replayed, and the replayed cells must equal `result.json`'s (ids
/// and volumes) — otherwise the model changed since the run and nothing is written. The set
/// is then written again as one (the same files, byte for byte, plus the new formats;
/// snapshots listed in the manifest are redrawn). Experiment directories are refused (their
/// pictures need the experiment's ground truth and transforms).
pub fn reexport(dir: &Path, model: Option<&Path>, export: &[String]) -> Result<crate::output::Written, PipelineError> {
    use crate::decimate::{Step, StopRule};
    let fail = |why: String| PipelineError::Reexport {
        dir: dir.to_path_buf(),
        why,
    };
    let doc = crate::output::read_result(dir)?;
    let manifest = crate::output::read_manifest(dir)?;
    if manifest.as_ref().is_some_and(|m| !m.later.is_empty()) {
        return Err(fail(
            "it is an experiment's results directory; add the formats to a `portalfind run` of its model instead"
                .into(),
        ));
    }
    let path = match model {
        Some(m) => m.to_path_buf(),
        None => run_model_path(dir, &doc.model.path)?.0,
    };
    let (m, _) = load(&path)?;
    let mut cs = CellSettings::of(if doc.settings.subdivision == "bsp" {
        Subdivision::Bsp
    } else {
        Subdivision::Delaunay
    });
    if let Some(k) = doc.subdivision_stats.get("max_candidates").and_then(|v| v.as_u64()) {
        cs.bsp.max_candidates = k as usize;
    }
    let cells = build_cells(&m, &path, &cs, &mut |_| {})?;
    let cx = &cells.cx;
    // The recorded collapses.
    let csv_path = dir.join("weight_curve.csv");
    let bad_csv = |e: String| fail(format!("{}: {e}", csv_path.display()));
    let mut rd = csv::Reader::from_path(&csv_path).map_err(|e| bad_csv(e.to_string()))?;
    let mut steps = Vec::new();
    for rec in rd.records() {
        let r = rec.map_err(|e| bad_csv(e.to_string()))?;
        let f = |i: usize| -> Result<f64, PipelineError> {
            r.get(i)
                .and_then(|x| x.parse::<f64>().ok())
                .ok_or_else(|| bad_csv(format!("bad column {i} in row {r:?}")))
        };
        steps.push(Step {
            a: crate::ids::CellId(f(3)? as u32),
            b: crate::ids::CellId(f(4)? as u32),
            weight: f(1)?,
            cells_remaining: f(2)? as usize,
            portal_area: f(5)?,
            projected: [f(6)?, f(7)?],
        });
    }
    let partition = Decimation::replay(cx, &steps).map_err(|e| {
        fail(format!(
            "the recorded collapses do not replay on {}: {e}",
            path.display()
        ))
    })?;
    let same = partition.cells.len() == doc.cells.len()
        && partition
            .cells
            .iter()
            .zip(&doc.cells)
            .all(|(a, b)| a.id.0 == b.id && (a.volume - b.volume).abs() <= 1e-9 * b.volume.abs());
    if !same {
        return Err(fail(format!(
            "the model {} no longer gives this run's cells (changed since the run? give the run's model with --model)",
            path.display()
        )));
    }
    let stop: StopRule = doc.settings.stop.parse().map_err(|e| fail(format!("stop rule: {e}")))?;
    let settings = crate::decimate::Settings {
        heuristic: doc.settings.heuristic,
        estimator: doc.settings.estimator,
        stop,
        queue: doc.settings.queue,
    };
    let dec = Decimation {
        settings,
        steps,
        stop: doc.stop_reason,
        stats: doc.decimation.clone(),
        partition,
    };
    let counts: Vec<usize> = manifest
        .iter()
        .flat_map(|m| m.files.iter())
        .filter_map(|f| f.name.strip_prefix("cells_")?.strip_suffix(".svg")?.parse().ok())
        .collect();
    let snapshots = counts
        .iter()
        .map(|&n| crate::output::snapshot(&m, &path, cx, &dec, n))
        .collect::<Result<Vec<_>, _>>()?;
    // The weight curve past the stop, exactly as the run drew it: only when the run drew
    // one (its stages name the pass; a run without timings is assumed to have), and from
    // the same function (`run_with_curve`: for `aperture` the run to the end is the
    // stopped pass continued, not a second run with stop `none`, whose gate keeps pairs
    // apart and ends elsewhere), so the plots come out byte-identical.
    let drew_curve = doc.stages.is_empty() || doc.stages.iter().any(|s| s.stage == CURVE_STAGE);
    let full = (stop != StopRule::None && drew_curve)
        .then(|| Decimation::run_with_curve(cx, &settings, &mut |_, _| {}).1)
        .flatten();
    let opts = crate::output::SetOptions {
        cx: Some(cx),
        export,
        notes: crate::output::Notes {
            full_steps: full.as_deref(),
            ..Default::default()
        },
        strip_timings: doc.stages.is_empty(),
        ..Default::default()
    };
    Ok(crate::output::write_run(dir, &m, &doc, &dec, &snapshots, &opts)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subdivision_names_round_trip_and_errors_list_them() {
        for d in Subdivision::ALL {
            assert_eq!(d.to_string().parse::<Subdivision>(), Ok(d));
            assert_eq!(serde_json::to_string(&d).unwrap(), format!("\"{d}\""));
        }
        let e = "octree".parse::<Subdivision>().unwrap_err();
        assert_eq!(e.to_string(), "unknown subdivision \"octree\"; use delaunay or bsp");
        for n in Subdivision::NAMES {
            assert!(e.to_string().contains(n));
        }
    }
}
