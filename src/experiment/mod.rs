//! Experiments: the thesis reproduction (issue 5). An experiment definition
//! (`experiments/*.json`, schema in `experiments/README.md`) names a model (a thesis
//! reconstruction from [`crate::thesis_models`] with its ground truth, or an OBJ/`.mesh`
//! file), optional transforms, the subdivision, heuristic, estimator and stop rule, the
//! thesis's figures for the side-by-side table, and optionally other experiments to compare
//! portals with (the rotation check of thesis 4.3.4): the final portals, or the separating
//! portals of the room-separation state ([`eval::Separation`]).
//!
//! [`run_all`] runs definitions; each experiment writes `results/<name>/` with the files of
//! `portalfind run` ([`crate::output::write_outputs`]) and `evaluation.json`
//! ([`eval::Evaluation`]); a whole directory also gets `results/summary.csv` and
//! `results/README.md` ([`report`]). A failing experiment is reported as an
//! [`ExperimentError`] naming its file; the others still run.
//!
//! Definitions are parsed field by field from a JSON object so that every error names the
//! file and the field; unknown fields are rejected ([`ExperimentError::UnknownField`]).

pub mod eval;
pub mod report;

use crate::complex::CellComplex;
use crate::decimate::{Decimation, Estimator, HeuristicKind, QueueMode, Settings, StopRule};
use crate::delaunay::Tetrahedralization;
use crate::model::Model;
use crate::output::{self, ResultDoc};
use crate::predicates::P3;
use crate::thesis_models::{self, GroundTruth};
use anyhow::{Context, Result, bail};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::Instant;

/// The top-level fields of a definition.
pub const FIELDS: [&str; 12] = [
    "name",
    "description",
    "model",
    "truth",
    "transforms",
    "subdivision",
    "heuristic",
    "estimator",
    "stop",
    "thesis",
    "compare_to",
    "snapshots",
];

/// The fields of `compare_to`.
pub const COMPARE_FIELDS: [&str; 5] = [
    "experiment",
    "portals",
    "transform_inverse_of",
    "distance_tolerance",
    "area_tolerance",
];

/// The transform kinds (the one key of each `transforms` entry).
pub const TRANSFORM_KINDS: [&str; 3] = ["rotate_deg", "translate", "scale"];

/// Default rotation-check position tolerance, as a fraction of the reference model's
/// bounding-box diagonal.
pub const DEFAULT_DISTANCE_TOLERANCE: f64 = 0.02;
/// Default rotation-check area tolerance (relative difference to the larger area).
pub const DEFAULT_AREA_TOLERANCE: f64 = 0.2;

/// An experiment that could not be read or run; always names the definition file.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// The definition file (or directory) cannot be read.
    #[error("{}: cannot read: {source}", file.display())]
    Read {
        /// The file.
        file: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// Not valid JSON.
    #[error("{}: not valid JSON: {source}", file.display())]
    Json {
        /// The file.
        file: PathBuf,
        /// The parse error.
        #[source]
        source: serde_json::Error,
    },
    /// A field that the schema does not have.
    #[error("{}: unknown field `{field}` (see experiments/README.md for the schema)", file.display())]
    UnknownField {
        /// The file.
        file: PathBuf,
        /// The field, as a path (`compare_to.foo`, `transforms[1].spin`).
        field: String,
    },
    /// A missing or invalid field.
    #[error("{}: field `{field}`: {message}", file.display())]
    Invalid {
        /// The file.
        file: PathBuf,
        /// The field, as a path.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// Two definitions use the same name (the results directory).
    #[error("{}: experiment name {name:?} is already used by {}", file.display(), other.display())]
    DuplicateName {
        /// The file.
        file: PathBuf,
        /// The name.
        name: String,
        /// The other definition with this name.
        other: PathBuf,
    },
    /// The experiment ran and failed.
    #[error("{}: experiment {name:?} failed: {message}", file.display())]
    Failed {
        /// The file.
        file: PathBuf,
        /// The experiment name.
        name: String,
        /// The error chain.
        message: String,
    },
}

impl ExperimentError {
    /// The definition file the error is about.
    pub fn file(&self) -> &Path {
        match self {
            ExperimentError::Read { file, .. }
            | ExperimentError::Json { file, .. }
            | ExperimentError::UnknownField { file, .. }
            | ExperimentError::Invalid { file, .. }
            | ExperimentError::DuplicateName { file, .. }
            | ExperimentError::Failed { file, .. } => file,
        }
    }
}

/// A transform of the model's vertices and the ground truth's points.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Transform {
    /// Rotation by these angles in degrees about x, then y, then z (the axes are fixed).
    RotateDeg([f64; 3]),
    /// Translation.
    Translate([f64; 3]),
    /// Uniform scaling about the origin (positive).
    Scale(f64),
}

fn rot(p: P3, deg: [f64; 3], sign: f64) -> P3 {
    let (sx, cx) = (sign * deg[0]).to_radians().sin_cos();
    let (sy, cy) = (sign * deg[1]).to_radians().sin_cos();
    let (sz, cz) = (sign * deg[2]).to_radians().sin_cos();
    let [mut x, mut y, mut z] = p;
    if sign > 0.0 {
        // The same expressions as `bench::rotate_789`, so `rotate_deg [7, 8, 9]` of the
        // caverns is bit-identical to the generated `caverns_rotated`.
        (y, z) = (cx * y - sx * z, sx * y + cx * z);
        (x, z) = (cy * x + sy * z, -sy * x + cy * z);
        [cz * x - sz * y, sz * x + cz * y, z]
    } else {
        // The inverse: about z, then y, then x, by the negated angles.
        (x, y) = (cz * x - sz * y, sz * x + cz * y);
        (x, z) = (cy * x + sy * z, -sy * x + cy * z);
        [x, cx * y - sx * z, sx * y + cx * z]
    }
}

impl Transform {
    /// The transformed point.
    pub fn apply(&self, p: P3) -> P3 {
        match *self {
            Transform::RotateDeg(d) => rot(p, d, 1.0),
            Transform::Translate(t) => [p[0] + t[0], p[1] + t[1], p[2] + t[2]],
            Transform::Scale(s) => [p[0] * s, p[1] * s, p[2] * s],
        }
    }

    /// The point mapped by the inverse transform.
    pub fn apply_inverse(&self, p: P3) -> P3 {
        match *self {
            Transform::RotateDeg(d) => rot(p, d, -1.0),
            Transform::Translate(t) => [p[0] - t[0], p[1] - t[1], p[2] - t[2]],
            Transform::Scale(s) => [p[0] / s, p[1] / s, p[2] / s],
        }
    }

    /// Factor by which lengths change.
    pub fn length_factor(&self) -> f64 {
        match *self {
            Transform::Scale(s) => s,
            _ => 1.0,
        }
    }
}

/// Applies `ts` in order.
pub fn apply_all(ts: &[Transform], p: P3) -> P3 {
    ts.iter().fold(p, |q, t| t.apply(q))
}

/// Undoes `ts` (the inverses in reverse order).
pub fn invert_all(ts: &[Transform], p: P3) -> P3 {
    ts.iter().rev().fold(p, |q, t| t.apply_inverse(q))
}

/// Product of the transforms' length factors.
pub fn length_factor(ts: &[Transform]) -> f64 {
    ts.iter().map(Transform::length_factor).product()
}

pub use crate::complex::Subdivision;

/// Where the model comes from.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(tag = "kind", content = "value", rename_all = "lowercase")]
pub enum ModelSource {
    /// A thesis reconstruction ([`thesis_models::by_name`]), generated in memory with its
    /// ground truth.
    Thesis(String),
    /// An OBJ or `.mesh` file, relative to the repository (the parent of the definitions
    /// directory).
    File(PathBuf),
}

impl fmt::Display for ModelSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ModelSource::Thesis(n) => write!(f, "thesis:{n}"),
            ModelSource::File(p) => write!(f, "{}", p.display()),
        }
    }
}

/// Which portals a comparison ([`CompareTo`]) matches.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PortalSet {
    /// The portal pairs of the final partition (at the experiment's stop).
    #[default]
    Final,
    /// The separating portals at the room-separation state ([`eval::Separation`]): needs a
    /// ground truth on both sides.
    Separating,
}

impl fmt::Display for PortalSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            PortalSet::Final => "final",
            PortalSet::Separating => "separating",
        })
    }
}

/// The rotation check: map this experiment's portals (final or separating) back by the
/// inverse of `transform_inverse_of` and match them against the same set of `experiment`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CompareTo {
    /// The other experiment's name.
    pub experiment: String,
    /// Which portals are compared (default: final).
    pub portals: PortalSet,
    /// The transforms whose inverse maps this experiment's model onto the other's
    /// (normally a copy of this experiment's `transforms`).
    pub transform_inverse_of: Vec<Transform>,
    /// Centroid distance tolerance as a fraction of the other model's bounding-box diagonal.
    pub distance_tolerance: f64,
    /// Relative area tolerance.
    pub area_tolerance: f64,
}

/// A parsed experiment definition.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Definition {
    /// The file it was read from.
    pub file: PathBuf,
    /// Name: also the results subdirectory.
    pub name: String,
    /// What the experiment shows (optional, shown in the README).
    pub description: Option<String>,
    /// The model.
    pub model: ModelSource,
    /// A ground-truth file (`GroundTruth` JSON, as `models/thesis/*.truth.json`), relative
    /// to the repository; overrides a thesis model's own.
    pub truth: Option<PathBuf>,
    /// Transforms applied to the model and the ground truth first.
    pub transforms: Vec<Transform>,
    /// The subdivision.
    pub subdivision: Subdivision,
    /// Decimation settings (queue: auto).
    pub settings: Settings,
    /// The thesis's figures (free-form numbers and strings).
    pub thesis: Map<String, Value>,
    /// The rotation checks (`compare_to`: one object or a list), in order.
    pub compare_to: Vec<CompareTo>,
    /// Cell counts whose intermediate states are drawn as `cells_N.svg` (rebuilt by
    /// replay) and summarised in `evaluation.json`.
    pub snapshots: Vec<usize>,
}

/// Reads a field with serde, naming it in the error.
fn field<T: DeserializeOwned>(file: &Path, obj: &Map<String, Value>, key: &str) -> Result<Option<T>, ExperimentError> {
    match obj.get(key) {
        None => Ok(None),
        Some(v) => serde_json::from_value(v.clone())
            .map(Some)
            .map_err(|e| ExperimentError::Invalid {
                file: file.to_path_buf(),
                field: key.to_string(),
                message: e.to_string(),
            }),
    }
}

fn unknown_fields(file: &Path, obj: &Map<String, Value>, known: &[&str], prefix: &str) -> Result<(), ExperimentError> {
    match obj.keys().find(|k| !known.contains(&k.as_str())) {
        Some(k) => Err(ExperimentError::UnknownField {
            file: file.to_path_buf(),
            field: format!("{prefix}{k}"),
        }),
        None => Ok(()),
    }
}

fn parse_transforms(file: &Path, v: Option<&Value>, path: &str) -> Result<Vec<Transform>, ExperimentError> {
    let invalid = |field: String, message: String| ExperimentError::Invalid {
        file: file.to_path_buf(),
        field,
        message,
    };
    let Some(v) = v else { return Ok(Vec::new()) };
    let list = v
        .as_array()
        .ok_or_else(|| invalid(path.into(), "expected a list of transforms".into()))?;
    let mut out = Vec::new();
    for (i, t) in list.iter().enumerate() {
        let at = format!("{path}[{i}]");
        let obj = t.as_object().ok_or_else(|| {
            invalid(
                at.clone(),
                "expected an object with one key: rotate_deg, translate or scale".into(),
            )
        })?;
        unknown_fields(file, obj, &TRANSFORM_KINDS, &format!("{at}."))?;
        if obj.len() != 1 {
            return Err(invalid(
                at,
                format!(
                    "expected exactly one of rotate_deg, translate, scale; got {} keys",
                    obj.len()
                ),
            ));
        }
        let tr: Transform = serde_json::from_value(t.clone()).map_err(|e| invalid(at.clone(), e.to_string()))?;
        let finite = match tr {
            Transform::RotateDeg(a) | Transform::Translate(a) => a.iter().all(|x| x.is_finite()),
            Transform::Scale(s) => s.is_finite() && s > 0.0,
        };
        if !finite {
            return Err(invalid(
                at,
                "values must be finite, and a scale positive (a negative scale would flip the polygons' orientation)"
                    .into(),
            ));
        }
        out.push(tr);
    }
    Ok(out)
}

/// One `compare_to` object; `path` names it in errors (`compare_to` or `compare_to[i]`).
fn parse_compare(file: &Path, c: &Value, path: &str) -> Result<CompareTo, ExperimentError> {
    let invalid = |field: &str, message: String| ExperimentError::Invalid {
        file: file.to_path_buf(),
        field: field.to_string(),
        message,
    };
    let co = c
        .as_object()
        .ok_or_else(|| invalid(path, "expected an object or a list of objects".into()))?;
    unknown_fields(file, co, &COMPARE_FIELDS, &format!("{path}."))?;
    let experiment: String = field(file, co, "experiment")
        .map_err(|_| invalid(&format!("{path}.experiment"), "expected a string".into()))?
        .ok_or_else(|| invalid(&format!("{path}.experiment"), "missing (required)".into()))?;
    let portals: PortalSet = field(file, co, "portals")
        .map_err(|_| {
            invalid(
                &format!("{path}.portals"),
                "expected \"final\" or \"separating\"".into(),
            )
        })?
        .unwrap_or_default();
    let tol = |key: &str, default: f64| -> Result<f64, ExperimentError> {
        let f = format!("{path}.{key}");
        let x: f64 = field(file, co, key)
            .map_err(|_| invalid(&f, "expected a number".into()))?
            .unwrap_or(default);
        if x.is_finite() && x > 0.0 {
            Ok(x)
        } else {
            Err(invalid(&f, "expected a positive number".into()))
        }
    };
    Ok(CompareTo {
        experiment,
        portals,
        transform_inverse_of: parse_transforms(
            file,
            co.get("transform_inverse_of"),
            &format!("{path}.transform_inverse_of"),
        )?,
        distance_tolerance: tol("distance_tolerance", DEFAULT_DISTANCE_TOLERANCE)?,
        area_tolerance: tol("area_tolerance", DEFAULT_AREA_TOLERANCE)?,
    })
}

fn valid_name(n: &str) -> bool {
    !n.is_empty() && !n.starts_with('.') && n.chars().all(|c| c.is_ascii_alphanumeric() || "_-.".contains(c))
}

impl Definition {
    /// Parses a definition from JSON text; `file` names it in errors.
    pub fn parse(file: &Path, text: &str) -> Result<Definition, ExperimentError> {
        let v: Value = serde_json::from_str(text).map_err(|source| ExperimentError::Json {
            file: file.to_path_buf(),
            source,
        })?;
        let invalid = |field: &str, message: String| ExperimentError::Invalid {
            file: file.to_path_buf(),
            field: field.to_string(),
            message,
        };
        let obj = v
            .as_object()
            .ok_or_else(|| invalid("(top level)", "expected a JSON object".into()))?;
        unknown_fields(file, obj, &FIELDS, "")?;
        let required = |key: &str| -> Result<String, ExperimentError> {
            field::<String>(file, obj, key)?.ok_or_else(|| invalid(key, "missing (required)".into()))
        };
        let name = required("name")?;
        if !valid_name(&name) {
            return Err(invalid(
                "name",
                format!("{name:?} is not a directory name (letters, digits, _ - . only)"),
            ));
        }
        let model_s = required("model")?;
        let model = if thesis_models::by_name(&model_s).is_some() {
            ModelSource::Thesis(model_s)
        } else {
            let p = PathBuf::from(&model_s);
            let ext = p
                .extension()
                .map(|e| e.to_string_lossy().to_ascii_lowercase())
                .unwrap_or_default();
            if ext != "obj" && ext != "mesh" {
                return Err(invalid(
                    "model",
                    format!(
                        "{model_s:?} is neither a thesis model ({}) nor an .obj or .mesh path",
                        thesis_models::NAMES.join(", ")
                    ),
                ));
            }
            ModelSource::File(p)
        };
        let parsed = |key: &str, default: &str| -> Result<String, ExperimentError> {
            Ok(field::<String>(file, obj, key)?.unwrap_or_else(|| default.to_string()))
        };
        // The same parsers as `portalfind run`'s options.
        let heuristic = HeuristicKind::from_str(&required("heuristic")?).map_err(|e| invalid("heuristic", e))?;
        let estimator = Estimator::from_str(&required("estimator")?).map_err(|e| invalid("estimator", e))?;
        let stop = StopRule::from_str(&required("stop")?).map_err(|e| invalid("stop", e))?;
        let subdivision =
            Subdivision::from_str(&parsed("subdivision", "delaunay")?).map_err(|e| invalid("subdivision", e))?;
        let thesis: Map<String, Value> = field(file, obj, "thesis")?.unwrap_or_default();
        if let Some((k, _)) = thesis.iter().find(|(_, v)| !(v.is_number() || v.is_string())) {
            return Err(invalid(&format!("thesis.{k}"), "expected a number or a string".into()));
        }
        let compare_to = match obj.get("compare_to") {
            None => Vec::new(),
            Some(Value::Array(list)) => list
                .iter()
                .enumerate()
                .map(|(i, c)| parse_compare(file, c, &format!("compare_to[{i}]")))
                .collect::<Result<Vec<_>, _>>()?,
            Some(c) => vec![parse_compare(file, c, "compare_to")?],
        };
        Ok(Definition {
            file: file.to_path_buf(),
            name,
            description: field(file, obj, "description")?,
            model,
            truth: field::<String>(file, obj, "truth")?.map(PathBuf::from),
            transforms: parse_transforms(file, obj.get("transforms"), "transforms")?,
            subdivision,
            settings: Settings {
                heuristic,
                estimator,
                stop,
                queue: QueueMode::Auto,
            },
            thesis,
            compare_to,
            snapshots: field(file, obj, "snapshots")?.unwrap_or_default(),
        })
    }

    /// Reads and parses a definition file.
    pub fn read(file: &Path) -> Result<Definition, ExperimentError> {
        let text = std::fs::read_to_string(file).map_err(|source| ExperimentError::Read {
            file: file.to_path_buf(),
            source,
        })?;
        Self::parse(file, &text)
    }
}

/// The `*.json` files of a directory, sorted by name.
pub fn definition_files(dir: &Path) -> Result<Vec<PathBuf>, ExperimentError> {
    let rd = std::fs::read_dir(dir).map_err(|source| ExperimentError::Read {
        file: dir.to_path_buf(),
        source,
    })?;
    let mut files: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "json"))
        .collect();
    files.sort();
    Ok(files)
}

/// Reads definition files; duplicates of an earlier name become errors.
pub fn read_definitions(files: &[PathBuf]) -> Vec<Result<Definition, ExperimentError>> {
    let mut seen: Vec<(String, PathBuf)> = Vec::new();
    files
        .iter()
        .map(|f| {
            let d = Definition::read(f)?;
            if let Some((_, other)) = seen.iter().find(|(n, _)| *n == d.name) {
                return Err(ExperimentError::DuplicateName {
                    file: f.clone(),
                    name: d.name,
                    other: other.clone(),
                });
            }
            seen.push((d.name.clone(), f.clone()));
            Ok(d)
        })
        .collect()
}

/// What [`build_cells`] returns: the cell complex, statistics of the subdivision itself
/// (JSON), and timed stages that precede the complex's own timings.
pub type Cells = (CellComplex, Value, Vec<(String, f64)>);

/// The one dispatch on the subdivision: the cell complex of `model` (see [`Cells`]).
pub fn build_cells(model: &Model, subdivision: Subdivision) -> Result<Cells> {
    match subdivision {
        Subdivision::Delaunay => {
            let t0 = Instant::now();
            let t = Tetrahedralization::build(&model.vertices).context("cannot tetrahedralize")?;
            let tt = t0.elapsed().as_secs_f64();
            let cx = CellComplex::build(model, &t);
            let stats = serde_json::json!({
                "tetrahedra": t.num_tets(),
                "hull_faces": t.num_hull_faces(),
                "tetrahedralization_seconds": tt,
            });
            Ok((cx, stats, vec![("delaunay tetrahedralization".into(), tt)]))
        }
        Subdivision::Bsp => {
            let (cx, stats) = crate::bsp::build_complex(model);
            let stats = serde_json::to_value(&stats).context("cannot serialize BSP statistics")?;
            Ok((cx, stats, Vec::new()))
        }
    }
}

/// A finished run: what `portalfind run` computes, for a model already loaded.
pub struct Pipeline {
    /// The cell complex.
    pub cx: CellComplex,
    /// Subdivision statistics from [`build_cells`].
    pub subdivision_stats: Value,
    /// The decimation.
    pub dec: Decimation,
    /// Stage timings (those passed in first).
    pub stages: Vec<(String, f64)>,
    /// The `result.json` document.
    pub doc: ResultDoc,
}

/// Builds the cells, decimates and assembles the result document (the code path of
/// `portalfind run`, without progress bars). `stages` are earlier stages (loading).
pub fn run_pipeline(
    model: &Model,
    model_path: &Path,
    subdivision: Subdivision,
    settings: &Settings,
    mut stages: Vec<(String, f64)>,
) -> Result<Pipeline> {
    let (cx, subdivision_stats, pre) = build_cells(model, subdivision)?;
    stages.extend(pre);
    stages.extend(cx.stats.timings.iter().cloned());
    let dec = Decimation::run(&cx, settings);
    stages.push(("decimation: initial weights".into(), dec.stats.init_seconds));
    stages.push(("decimation: collapses".into(), dec.stats.collapse_seconds));
    let mut doc = output::result_doc(model, model_path, &cx, &dec, &stages)?;
    doc.settings.subdivision = subdivision;
    doc.subdivision_stats = subdivision_stats.clone();
    Ok(Pipeline {
        cx,
        subdivision_stats,
        dec,
        stages,
        doc,
    })
}

/// The model and ground truth of a definition, transformed. `root` is the directory that
/// relative paths are resolved against.
pub fn load_model(def: &Definition, root: &Path) -> Result<(Model, Option<GroundTruth>)> {
    let (name, vertices, polygons, mut truth) = match &def.model {
        ModelSource::Thesis(n) => {
            let tm = thesis_models::by_name(n).with_context(|| format!("unknown thesis model {n:?}"))?;
            (n.clone(), tm.soup.vertices, tm.soup.polygons, Some(tm.truth))
        }
        ModelSource::File(p) => {
            let path = root.join(p);
            let m = crate::model::load_model(&path).context("cannot load the model")?;
            if def.transforms.is_empty() {
                let truth = read_truth(def, root)?;
                return Ok((m, truth));
            }
            let polys = m
                .polygons
                .iter()
                .map(|q| q.verts.iter().map(|v| v.0).collect())
                .collect();
            (m.name, m.vertices, polys, None)
        }
    };
    if def.truth.is_some() {
        truth = read_truth(def, root)?;
    }
    let vertices = vertices.into_iter().map(|p| apply_all(&def.transforms, p)).collect();
    if let Some(t) = &mut truth {
        for r in &mut t.rooms {
            for p in &mut r.samples {
                *p = apply_all(&def.transforms, *p);
            }
        }
        for d in &mut t.doorways {
            for p in &mut d.polygon {
                *p = apply_all(&def.transforms, *p);
            }
        }
    }
    let m = crate::model::from_soup(&name, vertices, polygons).with_context(|| format!("invalid model {name}"))?;
    Ok((m, truth))
}

fn read_truth(def: &Definition, root: &Path) -> Result<Option<GroundTruth>> {
    let Some(p) = &def.truth else { return Ok(None) };
    let path = root.join(p);
    let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read truth {}", path.display()))?;
    let t: GroundTruth = serde_json::from_str(&text).with_context(|| format!("bad truth file {}", path.display()))?;
    for d in &t.doorways {
        if d.rooms.iter().any(|&r| r >= t.rooms.len()) {
            bail!(
                "truth file {}: a doorway names room {:?} of {}",
                path.display(),
                d.rooms,
                t.rooms.len()
            );
        }
    }
    Ok(Some(t))
}

/// One experiment run, before the comparisons.
pub struct Outcome {
    /// The definition.
    pub def: Definition,
    /// Its evaluation (the rotation check is filled in by [`run_all`]).
    pub eval: eval::Evaluation,
    /// Its final portals, for comparisons.
    pub portals: Vec<eval::PortalSummary>,
    /// Its separating portals at the room-separation state (`None` without a ground
    /// truth), for comparisons.
    pub separating: Option<Vec<eval::PortalSummary>>,
    /// Its results directory.
    pub dir: PathBuf,
}

/// Runs one experiment: writes `out/<name>/` (result.json, weight curve CSV/PNG,
/// cells.svg) and returns the evaluation, not yet written (see [`run_all`]).
pub fn run_experiment(def: &Definition, root: &Path, out: &Path) -> Result<Outcome> {
    let t0 = Instant::now();
    let dir = out.join(&def.name);
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let (model, truth) = load_model(def, root)?;
    let stages = vec![("load model".to_string(), t0.elapsed().as_secs_f64())];
    let model_path = PathBuf::from(def.model.to_string());
    let mut p = run_pipeline(&model, &model_path, def.subdivision, &def.settings, stages)?;
    let t1 = Instant::now();
    let snapshots = def
        .snapshots
        .iter()
        .map(|&n| output::snapshot(&model, &model_path, &p.cx, &p.dec, n))
        .collect::<Result<Vec<_>>>()
        .with_context(|| format!("{}: field `snapshots`", def.file.display()))?;
    output::write_outputs_with_snapshots(&dir, &model, &p.doc, &p.dec, &snapshots)?;
    p.stages.push(("write outputs".into(), t1.elapsed().as_secs_f64()));
    let mut ev = eval::evaluate(def, &model, truth.as_ref(), &mut p, t0)?;
    ev.snapshots = snapshots.into_iter().map(|(s, _)| s).collect();
    let portals = eval::portal_summaries(&p.doc);
    let separating = eval::separating_summaries(&ev);
    Ok(Outcome {
        def: def.clone(),
        eval: ev,
        portals,
        separating,
        dir,
    })
}

/// Options of [`run_all`].
pub struct RunOptions {
    /// Where relative model and truth paths are resolved (the repository).
    pub root: PathBuf,
    /// The results directory.
    pub out: PathBuf,
    /// Write `summary.csv` and `README.md` (for a whole directory of definitions).
    pub write_summary: bool,
    /// The command line, for the README.
    pub command: String,
}

/// What [`run_all`] did.
pub struct Report {
    /// Finished experiments, in definition order.
    pub outcomes: Vec<Outcome>,
    /// Failed ones.
    pub failures: Vec<ExperimentError>,
    /// Wall time of the whole run in seconds.
    pub seconds: f64,
    /// Files written besides the experiments' own (summary, README).
    pub files: Vec<PathBuf>,
}

/// The portals of `o` that a comparison of kind `set` matches.
fn portal_set(o: &Outcome, set: PortalSet) -> Result<&[eval::PortalSummary]> {
    match set {
        PortalSet::Final => Ok(&o.portals),
        PortalSet::Separating => o.separating.as_deref().with_context(|| {
            format!(
                "compare_to: experiment {:?} has no ground truth, so no separating portals",
                o.def.name
            )
        }),
    }
}

/// The portals (and the model's bounding-box diagonal) of an experiment of an earlier run:
/// final portals from its `result.json`, separating ones from its `evaluation.json`.
fn earlier_portals(out: &Path, c: &CompareTo) -> Result<(Vec<eval::PortalSummary>, f64)> {
    let dir = out.join(&c.experiment);
    let missing = || {
        format!(
            "compare_to: experiment {:?} is neither in this run nor in {}",
            c.experiment,
            out.display()
        )
    };
    match c.portals {
        PortalSet::Final => {
            let doc = output::read_result(&dir).with_context(missing)?;
            Ok((eval::portal_summaries(&doc), eval::diagonal(&doc.model.bbox)))
        }
        PortalSet::Separating => {
            let path = dir.join("evaluation.json");
            let text = std::fs::read_to_string(&path).with_context(missing)?;
            let ev: eval::Evaluation =
                serde_json::from_str(&text).with_context(|| format!("cannot parse {}", path.display()))?;
            let ps = eval::separating_summaries(&ev).with_context(|| {
                format!(
                    "compare_to: {} has no separating portals (no ground truth, or an older schema)",
                    path.display()
                )
            })?;
            Ok((ps, ev.model.bbox_diagonal))
        }
    }
}

/// Removes what an experiment writes from its results directory `dir` (and `dir` itself
/// if that leaves it empty), so that a failed experiment leaves neither a partial set nor
/// an earlier run's files that look current. Returns how many files were removed.
fn clear_results(dir: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let ours = output::FILES.contains(&name.as_str())
            || name == "evaluation.json"
            || (name.starts_with("cells_") && name.ends_with(".svg"));
        if ours && std::fs::remove_file(e.path()).is_ok() {
            removed += 1;
        }
    }
    let _ = std::fs::remove_dir(dir);
    removed
}

/// Runs the definitions in order, then the rotation checks, then writes every
/// `evaluation.json` and (with `write_summary`) `summary.csv` and `README.md`. Calls
/// `log` with a line per finished or failed experiment.
pub fn run_all(defs: Vec<Result<Definition, ExperimentError>>, opts: &RunOptions, log: &mut dyn FnMut(&str)) -> Report {
    let t0 = Instant::now();
    let mut outcomes = Vec::new();
    let mut failures = Vec::new();
    let mut order: Vec<(String, PathBuf)> = Vec::new();
    for d in defs {
        let def = match d {
            Ok(d) => d,
            Err(e) => {
                log(&format!("error: {e}"));
                order.push((String::new(), e.file().to_path_buf()));
                failures.push(e);
                continue;
            }
        };
        order.push((def.name.clone(), def.file.clone()));
        match run_experiment(&def, &opts.root, &opts.out) {
            Ok(o) => {
                log(&eval::one_line(&o.eval));
                outcomes.push(o);
            }
            Err(e) => {
                let e = ExperimentError::Failed {
                    file: def.file.clone(),
                    name: def.name.clone(),
                    message: format!("{e:#}"),
                };
                log(&format!("error: {e}"));
                let removed = clear_results(&opts.out.join(&def.name));
                if removed > 0 {
                    log(&format!(
                        "  removed {removed} result files of an earlier run of {:?}: they no longer match its definition",
                        def.name
                    ));
                }
                failures.push(e);
            }
        }
    }
    // Rotation checks, against an experiment of this run or an earlier run's files.
    let mut checks = Vec::new();
    for (i, o) in outcomes.iter().enumerate() {
        if o.def.compare_to.is_empty() {
            continue;
        }
        let r: Result<Vec<eval::RotationCheck>> = o
            .def
            .compare_to
            .iter()
            .map(|c| {
                let ours = portal_set(o, c.portals)?;
                let (theirs, diag) = match outcomes.iter().find(|x| x.def.name == c.experiment) {
                    Some(other) => (portal_set(other, c.portals)?.to_vec(), other.eval.model.bbox_diagonal),
                    None => earlier_portals(&opts.out, c)?,
                };
                Ok(eval::rotation_check(c, ours, &theirs, diag))
            })
            .collect();
        checks.push((i, r));
    }
    let mut failed_idx = Vec::new();
    for (i, r) in checks {
        match r {
            Ok(rc) => outcomes[i].eval.rotation_checks = rc,
            Err(e) => {
                let d = &outcomes[i].def;
                let e = ExperimentError::Failed {
                    file: d.file.clone(),
                    name: d.name.clone(),
                    message: format!("{e:#}"),
                };
                log(&format!("error: {e}"));
                failures.push(e);
                failed_idx.push(i);
            }
        }
    }
    for (i, o) in outcomes.iter().enumerate() {
        let path = o.dir.join("evaluation.json");
        let r = serde_json::to_string_pretty(&o.eval)
            .map_err(anyhow::Error::from)
            .and_then(|s| {
                crate::model::write::write_atomic(&path, s.as_bytes())
                    .with_context(|| format!("cannot write {}", path.display()))
            });
        if let Err(e) = r
            && !failed_idx.contains(&i)
        {
            let e = ExperimentError::Failed {
                file: o.def.file.clone(),
                name: o.def.name.clone(),
                message: format!("{e:#}"),
            };
            log(&format!("error: {e}"));
            failures.push(e);
            failed_idx.push(i);
        }
    }
    outcomes = outcomes
        .into_iter()
        .enumerate()
        .filter(|(i, _)| !failed_idx.contains(i))
        .map(|(_, o)| o)
        .collect();
    let mut report = Report {
        outcomes,
        failures,
        seconds: 0.0,
        files: Vec::new(),
    };
    if opts.write_summary {
        match report::write_summary(&report, &order, opts, t0) {
            Ok(files) => report.files = files,
            Err(e) => {
                let e = ExperimentError::Failed {
                    file: opts.out.clone(),
                    name: "summary".into(),
                    message: format!("{e:#}"),
                };
                log(&format!("error: {e}"));
                report.failures.push(e);
            }
        }
    }
    report.seconds = t0.elapsed().as_secs_f64();
    report
}
