//! The experiment runner: loads each definition's model (and ground truth), runs the
//! library pipeline ([`crate::pipeline::run_model`]), writes the run's outputs, evaluates
//! it ([`super::eval`]), runs the rotation checks and writes `evaluation.json`,
//! `summary.csv` and `README.md` ([`super::report`]).

use super::definition::{CompareTo, Definition, ModelSource, PortalSet};
use super::error::{ExperimentError, RunError, chain};
use super::transform::apply_all;
use super::{eval, report};
use crate::decimate::{Decimation, StopRule};
use crate::generate::thesis::{self as thesis_models, GroundTruth};
use crate::model::Model;
use crate::output;
use crate::pipeline::{self, CellSettings};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The evaluation's file name in an experiment's results directory.
pub const EVALUATION_FILE: &str = "evaluation.json";
/// The file in the results directory that holds the run's timings (machine-dependent, so
/// kept out of every committed file; `.gitignore` lists it).
pub const TIMINGS_FILE: &str = "timings.json";

/// The model and ground truth of a definition, transformed. `root` is the directory that
/// relative paths are resolved against.
pub fn load_model(def: &Definition, root: &Path) -> Result<(Model, Option<GroundTruth>), RunError> {
    let (name, vertices, polygons, mut truth) = match &def.model {
        ModelSource::Thesis(n) => {
            let tm = thesis_models::by_name(n).ok_or_else(|| RunError::UnknownThesisModel { name: n.clone() })?;
            (n.clone(), tm.soup.vertices, tm.soup.polygons, Some(tm.truth))
        }
        ModelSource::File(p) => {
            let path = root.join(p);
            let m = crate::model::load_model(&path).map_err(|e| RunError::LoadModel(Box::new(e)))?;
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
    let m = crate::model::from_soup(&name, vertices, polygons).map_err(|source| RunError::InvalidModel {
        name: name.clone(),
        source: Box::new(source),
    })?;
    Ok((m, truth))
}

fn read_truth(def: &Definition, root: &Path) -> Result<Option<GroundTruth>, RunError> {
    let Some(p) = &def.truth else { return Ok(None) };
    let path = root.join(p);
    let text = std::fs::read_to_string(&path).map_err(|source| RunError::ReadTruth {
        path: path.clone(),
        source,
    })?;
    let t: GroundTruth = serde_json::from_str(&text).map_err(|source| RunError::BadTruth {
        path: path.clone(),
        source,
    })?;
    for d in &t.doorways {
        if d.rooms.iter().any(|&r| r >= t.rooms.len()) {
            return Err(RunError::TruthRoom {
                path,
                rooms: d.rooms,
                count: t.rooms.len(),
            });
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
pub fn run_experiment(def: &Definition, root: &Path, out: &Path) -> Result<Outcome, RunError> {
    let t0 = Instant::now();
    let dir = out.join(&def.name);
    // Refuse a directory holding foreign files with output names before the work.
    output::check_output_dir(&dir, &set_options())?;
    output::check_snapshot_counts(&def.snapshots, &def.settings.stop).map_err(|source| RunError::Snapshots {
        file: def.file.clone(),
        source,
    })?;
    let (model, truth) = load_model(def, root)?;
    let stages = vec![("load model".to_string(), t0.elapsed().as_secs_f64())];
    let model_path = PathBuf::from(def.model.to_string());
    let settings = pipeline::Settings {
        cells: CellSettings::of(def.subdivision),
        decimation: def.settings,
    };
    let mut p = pipeline::run_model(&model, &model_path, &settings, stages, &mut |_| {})?;
    // The full decimation (stop `none`): the weight curve is drawn past the stop, and the
    // evaluation finds the first room-joining collapse in it.
    let full = (p.dec.settings.stop != StopRule::None).then(|| {
        let t = Instant::now();
        let settings = crate::decimate::Settings {
            stop: StopRule::None,
            ..p.dec.settings
        };
        let full = Decimation::run(&p.cx, &settings);
        p.stages.push((
            "decimation: full run (weight curve, weight jump)".into(),
            t.elapsed().as_secs_f64(),
        ));
        full
    });
    let snapshots = def
        .snapshots
        .iter()
        .map(|&n| output::snapshot(&model, &model_path, &p.cx, &p.dec, n))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|source| RunError::Snapshots {
            file: def.file.clone(),
            source,
        })?;
    let mut ev = eval::evaluate(def, &model, truth.as_ref(), &mut p, full.as_ref(), t0);
    let t1 = Instant::now();
    let notes = output::Notes {
        full_steps: full.as_ref().map(|f| &f.steps[..]),
        first_join: ev.truth.as_ref().and_then(|t| t.weight_jump.as_ref()).map(|j| j.step),
        truth: truth.as_ref(),
    };
    // One set, swapped in whole; `evaluation.json` (written by `run_all`) belongs to it.
    // Timings stay out of the committed files (they go to `timings.json`).
    let opts = output::SetOptions {
        notes,
        strip_timings: true,
        ..set_options()
    };
    output::write_run(&dir, &model, &p.doc, &p.dec, &snapshots, &opts)?;
    ev.timings
        .stages
        .push(("write outputs".into(), t1.elapsed().as_secs_f64()));
    ev.timings.total_seconds = t0.elapsed().as_secs_f64();
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
fn portal_set(o: &Outcome, set: PortalSet) -> Result<&[eval::PortalSummary], RunError> {
    match set {
        PortalSet::Final => Ok(&o.portals),
        PortalSet::Separating => o.separating.as_deref().ok_or_else(|| RunError::NoSeparatingPortals {
            experiment: o.def.name.clone(),
        }),
    }
}

/// The portals (and the model's bounding-box diagonal) of an experiment of an earlier run:
/// final portals from its `result.json`, separating ones from its `evaluation.json`.
fn earlier_portals(out: &Path, c: &CompareTo) -> Result<(Vec<eval::PortalSummary>, f64), RunError> {
    let dir = out.join(&c.experiment);
    let missing = |source: Box<dyn std::error::Error + Send + Sync>| RunError::MissingComparison {
        experiment: c.experiment.clone(),
        out: out.to_path_buf(),
        source,
    };
    match c.portals {
        PortalSet::Final => {
            let doc = output::read_result(&dir).map_err(|e| missing(e.into()))?;
            Ok((eval::portal_summaries(&doc), eval::diagonal(&doc.model.bbox)))
        }
        PortalSet::Separating => {
            let path = dir.join("evaluation.json");
            let text = std::fs::read_to_string(&path).map_err(|e| missing(e.into()))?;
            let ev: eval::Evaluation = serde_json::from_str(&text).map_err(|source| RunError::ParseEvaluation {
                path: path.clone(),
                source,
            })?;
            let ps = eval::separating_summaries(&ev).ok_or(RunError::NoSeparatingPortalsIn { path })?;
            Ok((ps, ev.model.bbox_diagonal))
        }
    }
}

/// The experiment's output set: the run's files plus `evaluation.json`, written later.
fn set_options() -> output::SetOptions<'static> {
    output::SetOptions {
        later: &[EVALUATION_FILE],
        ..Default::default()
    }
}

/// Removes the earlier run's set from an experiment's results directory `dir` (named by its
/// manifest; `dir` itself too if that leaves it empty), so that a failed experiment leaves
/// neither a partial set nor an earlier run's files that look current; other files stay.
/// Returns how many files were removed.
fn clear_results(dir: &Path) -> usize {
    output::remove_run(dir, &set_options()).map_or(0, |v| v.len())
}

/// Runs the definitions in order, then the rotation checks, then writes every
/// `evaluation.json` and (with `write_summary`) `summary.csv` and `README.md`. Calls
/// `log` with a line per finished or failed experiment.
pub fn run_all(defs: Vec<Result<Definition, ExperimentError>>, opts: &RunOptions, log: &mut dyn FnMut(&str)) -> Report {
    let t0 = Instant::now();
    let mut outcomes = Vec::new();
    let mut failures = Vec::new();
    let mut order: Vec<(String, PathBuf)> = Vec::new();
    let total = defs.len();
    for (k, d) in defs.into_iter().enumerate() {
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
        log(&format!("[{}/{total}] {}: running ({})", k + 1, def.name, def.model));
        match run_experiment(&def, &opts.root, &opts.out) {
            Ok(o) => {
                log(&eval::one_line(&o.eval));
                outcomes.push(o);
            }
            Err(e) => {
                let e = ExperimentError::Failed {
                    file: def.file.clone(),
                    name: def.name.clone(),
                    message: chain(&e),
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
        let r: Result<Vec<eval::RotationCheck>, RunError> = o
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
                    message: chain(&e),
                };
                log(&format!("error: {e}"));
                failures.push(e);
                failed_idx.push(i);
            }
        }
    }
    for (i, o) in outcomes.iter().enumerate() {
        let path = o.dir.join(EVALUATION_FILE);
        let r = serde_json::to_string_pretty(&o.eval)
            .map_err(RunError::SerializeEvaluation)
            .and_then(|s| {
                crate::model::write::write_atomic(&path, s.as_bytes()).map_err(|source| RunError::WriteFile {
                    path: path.clone(),
                    source,
                })
            });
        if let Err(e) = r
            && !failed_idx.contains(&i)
        {
            let e = ExperimentError::Failed {
                file: o.def.file.clone(),
                name: o.def.name.clone(),
                message: chain(&e),
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
    match write_timings(&report, &opts.out, t0) {
        Ok(p) => report.files.push(p),
        Err(e) => log(&format!("warning: {}", chain(&e))),
    }
    if opts.write_summary {
        match report::write_summary(&report, &order, opts) {
            Ok(files) => report.files.extend(files),
            Err(e) => {
                let e = ExperimentError::Failed {
                    file: opts.out.clone(),
                    name: "summary".into(),
                    message: chain(&e),
                };
                log(&format!("error: {e}"));
                report.failures.push(e);
            }
        }
    }
    report.seconds = t0.elapsed().as_secs_f64();
    report
}

/// Writes `out/timings.json`: each finished experiment's stage timings and total, and the
/// run's wall time so far.
fn write_timings(report: &Report, out: &Path, t0: Instant) -> Result<PathBuf, RunError> {
    let experiments: Vec<serde_json::Value> = report
        .outcomes
        .iter()
        .map(|o| {
            serde_json::json!({
                "experiment": o.def.name,
                "total_seconds": o.eval.timings.total_seconds,
                "stages": o.eval.timings.stages,
            })
        })
        .collect();
    let doc = serde_json::json!({
        "generator": format!("portalfind {}", env!("CARGO_PKG_VERSION")),
        "wall_seconds": t0.elapsed().as_secs_f64(),
        "experiments": experiments,
    });
    std::fs::create_dir_all(out).map_err(|source| RunError::CreateDir {
        dir: out.to_path_buf(),
        source,
    })?;
    let path = out.join(TIMINGS_FILE);
    let text = serde_json::to_string_pretty(&doc).map_err(RunError::SerializeEvaluation)?;
    crate::model::write::write_atomic(&path, text.as_bytes()).map_err(|source| RunError::WriteFile {
        path: path.clone(),
        source,
    })?;
    Ok(path)
}
