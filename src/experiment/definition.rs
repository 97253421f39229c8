//! The experiment definition: the schema of `experiments/*.json` (documented in
//! `experiments/README.md`) and its parser. Definitions are parsed field by field from a
//! JSON object so that every error names the file and the field; unknown fields are
//! rejected ([`ExperimentError::UnknownField`]).

use super::ExperimentError;
use super::transform::Transform;
use crate::decimate::{Estimator, HeuristicKind, QueueMode, Settings, StopRule};
use crate::generate::thesis as thesis_models;
use crate::pipeline::Subdivision;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// The top-level fields of a definition.
pub const FIELDS: [&str; 13] = [
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
    "evaluate",
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
    /// The separating portals at the room-separation state ([`super::eval::Separation`]): needs a
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
    /// Evaluate the final partition's visibility (`evaluate: true`; as `portalfind run
    /// --evaluate` without the walkthrough): `visibility.json` and `visibility_cells.csv` in
    /// the experiment's directory, a summary in `evaluation.json`. `experiment --evaluate`
    /// turns it on for every definition.
    pub evaluate: bool,
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
        let heuristic =
            HeuristicKind::from_str(&required("heuristic")?).map_err(|e| invalid("heuristic", e.to_string()))?;
        let estimator =
            Estimator::from_str(&required("estimator")?).map_err(|e| invalid("estimator", e.to_string()))?;
        let stop = StopRule::from_str(&required("stop")?).map_err(|e| invalid("stop", e.to_string()))?;
        let subdivision = Subdivision::from_str(&parsed("subdivision", "delaunay")?)
            .map_err(|e| invalid("subdivision", e.to_string()))?;
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
            evaluate: field(file, obj, "evaluate")?.unwrap_or(false),
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
