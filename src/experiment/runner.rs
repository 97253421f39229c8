//! The experiment runner: loads each definition's model (and ground truth), runs the
//! library pipeline ([`crate::pipeline::run_model`]), writes the run's outputs, evaluates
//! it ([`super::eval`]), runs the rotation checks and writes `evaluation.json`,
//! `summary.csv` and `README.md` ([`super::report`]).

use super::definition::{CompareTo, Definition, ModelSource, PortalSet};
use super::error::{ExperimentError, RunError, chain};
use super::transform::apply_all;
use super::{eval, report, shard};
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
                let truth = read_truth(def, root)?.map(|t| truth_in_model_frame(t, &m));
                return Ok((m, truth));
            }
            let polys = m
                .polygons
                .iter()
                .map(|q| q.verts.iter().map(|v| v.0).collect())
                .collect();
            // The transforms act in the input's frame (exact: the recentring was).
            let vertices = m.vertices.iter().map(|&v| m.to_user(v)).collect();
            (m.name, vertices, polys, None)
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
    let truth = truth.map(|t| truth_in_model_frame(t, &m));
    Ok((m, truth))
}

/// The ground truth (given in the input's frame) in the model's frame
/// ([`Model::from_user`]): the evaluation locates its samples in the model's cells. The
/// identity for models that were not recentred.
fn truth_in_model_frame(mut t: GroundTruth, m: &Model) -> GroundTruth {
    for p in t.rooms.iter_mut().flat_map(|r| r.samples.iter_mut()) {
        *p = m.from_user(*p);
    }
    for p in t.doorways.iter_mut().flat_map(|d| d.polygon.iter_mut()) {
        *p = m.from_user(*p);
    }
    t
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

/// The visibility settings of an evaluated experiment (definition field `evaluate`): the
/// PVS and the sampling check at their defaults, no walkthrough.
pub fn default_evaluate_settings() -> crate::evaluate::Settings {
    crate::evaluate::Settings {
        pvs: Default::default(),
        sampling: Some(Default::default()),
        walkthrough: None,
    }
}

/// Runs one experiment: writes `out/<name>/` (result.json, weight curve CSV/PNG,
/// cells.svg; with the definition's `evaluate`, the visibility files) and returns the
/// evaluation, not yet written (see [`run_all`]).
pub fn run_experiment(def: &Definition, root: &Path, out: &Path) -> Result<Outcome, RunError> {
    let es = def.evaluate.then(default_evaluate_settings);
    run_experiment_with(def, root, out, es.as_ref())
}

/// [`run_experiment`] with the visibility evaluation given (`None`: not evaluated, whatever
/// the definition says).
pub fn run_experiment_with(
    def: &Definition,
    root: &Path,
    out: &Path,
    evaluate: Option<&crate::evaluate::Settings>,
) -> Result<Outcome, RunError> {
    let t0 = Instant::now();
    let dir = out.join(&def.name);
    // Refuse a directory holding foreign files with output names before the work.
    output::check_output_dir(&dir, &set_options(evaluate.is_some()))?;
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
        ..set_options(evaluate.is_some())
    };
    output::write_run(&dir, &model, &p.doc, &p.dec, &snapshots, &opts)?;
    ev.timings
        .stages
        .push(("write outputs".into(), t1.elapsed().as_secs_f64()));
    if let Some(es) = evaluate {
        ev.visibility = Some(evaluate_visibility(def, &model, &p, es, &dir, &mut ev.timings.stages)?);
    }
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

/// The visibility of the final partition, as `portalfind run --evaluate` computes it
/// ([`crate::evaluate::evaluate_partition`]): writes `visibility.json` and
/// `visibility_cells.csv` into `dir` with their timings zeroed (the timings go to `stages`,
/// hence to `timings.json`, so the files are the same on every machine) and returns the
/// summary for `evaluation.json`.
fn evaluate_visibility(
    def: &Definition,
    model: &Model,
    p: &pipeline::Run,
    es: &crate::evaluate::Settings,
    dir: &Path,
    stages: &mut Vec<(String, f64)>,
) -> Result<eval::VisibilitySummary, RunError> {
    let rs = serde_json::to_value(&p.doc.settings).unwrap_or_default();
    let mut o =
        crate::evaluate::evaluate_partition(model, &p.doc.model.path, rs, &p.cx, &p.dec.partition, es, Vec::new());
    let e = &mut o.evaluation;
    stages.push((eval::VISIBILITY_PVS_STAGE.into(), e.report.pvs_seconds));
    stages.extend(
        e.stages
            .drain(..)
            .map(|s| (format!("visibility: {}", s.stage), s.seconds)),
    );
    let r = &mut e.report;
    r.pvs_seconds = 0.0;
    r.cost_seconds = 0.0;
    r.pvs.base_seconds = 0.0;
    r.pvs.flow_seconds = 0.0;
    if let Some(s) = &mut r.sampling {
        s.seconds = 0.0;
    }
    crate::evaluate::write(dir, &o, &def.name).map_err(|e| RunError::Evaluate(Box::new(e)))?;
    let r = &o.evaluation.report;
    Ok(eval::VisibilitySummary {
        cells: r.cells,
        portals: r.portals,
        pvs_mean_cells: r.pvs_mean_cells,
        pvs_max_cells: r.pvs_max_cells,
        total_triangles: r.total_triangles,
        expected_triangles: r.expected_triangles,
        area_fraction: r.area_fraction,
        culling_ratio: r.culling_ratio,
        pvs_chains: r.pvs.chains,
        rays: r.sampling.as_ref().map_or(0, |s| s.rays),
        false_invisible: r.sampling.as_ref().map_or(0, |s| s.false_invisible),
        overestimation_median: r.sampling.as_ref().map(|s| s.overestimation_median),
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
    /// The command line, for the README (for a shard: the equivalent unsharded command,
    /// which the merged README shows).
    pub command: String,
    /// Run only this shard's definitions ([`super::shard`]): no `summary.csv` or
    /// `README.md`, but `shard-I-of-N.json` and `timings.shard-I-of-N.json`.
    pub shard: Option<super::shard::Shard>,
    /// Evaluate every experiment's visibility with these settings (`experiment
    /// --evaluate`); `None`: only the definitions with `evaluate: true`, at
    /// [`default_evaluate_settings`].
    pub evaluate: Option<crate::evaluate::Settings>,
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

/// The experiment's output set: the run's files plus `evaluation.json` (and, when evaluated,
/// the visibility files), written later.
fn set_options(evaluated: bool) -> output::SetOptions<'static> {
    const PLAIN: &[&str] = &[EVALUATION_FILE];
    const EVALUATED: &[&str] = &[
        EVALUATION_FILE,
        crate::evaluate::VISIBILITY_FILE,
        crate::evaluate::CELLS_FILE,
    ];
    output::SetOptions {
        later: if evaluated { EVALUATED } else { PLAIN },
        ..Default::default()
    }
}

/// Removes the earlier run's set from an experiment's results directory `dir` (named by its
/// manifest; `dir` itself too if that leaves it empty), so that a failed experiment leaves
/// neither a partial set nor an earlier run's files that look current; other files stay.
/// Returns how many files were removed.
fn clear_results(dir: &Path) -> usize {
    output::remove_run(dir, &set_options(true)).map_or(0, |v| v.len())
}

/// Runs the definitions in order, then the rotation checks, then writes every
/// `evaluation.json` and (with `write_summary`) `summary.csv` and `README.md`. Calls
/// `log` with a line per finished or failed experiment.
pub fn run_all(defs: Vec<Result<Definition, ExperimentError>>, opts: &RunOptions, log: &mut dyn FnMut(&str)) -> Report {
    let t0 = Instant::now();
    // A shard keeps its own definitions (the same rule in every shard) and forgets its
    // earlier record first, so a shard killed on the way leaves none.
    let (defs, sharded) = match opts.shard {
        None => (defs, None),
        Some(sh) => {
            let costs = shard::costs(&defs, &opts.root);
            let which = shard::assign(&defs, &costs, sh.count);
            let recorded = shard::record_definitions(&defs, &costs, &which);
            let _ = std::fs::remove_file(opts.out.join(sh.record_file()));
            let total: u64 = costs.iter().sum();
            let mine: u64 = costs
                .iter()
                .zip(&which)
                .filter(|(_, k)| **k == sh.index)
                .map(|(c, _)| c)
                .sum();
            let n = defs.len();
            let defs: Vec<_> = defs
                .into_iter()
                .zip(&which)
                .filter(|(_, k)| **k == sh.index)
                .map(|(d, _)| d)
                .collect();
            log(&format!(
                "shard {sh}: {} of {n} definitions (expected cost {mine} of {total} polygons)",
                defs.len()
            ));
            (defs, Some((sh, recorded)))
        }
    };
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
        let es = opts.evaluate.or_else(|| def.evaluate.then(default_evaluate_settings));
        match run_experiment_with(&def, &opts.root, &opts.out, es.as_ref()) {
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
    // Failures in definition order (a merge of shards reports them in that order too).
    let rank = |f: &ExperimentError| order.iter().position(|(_, file)| file.as_path() == f.file());
    failures.sort_by_key(|f| rank(f));
    let mut report = Report {
        outcomes,
        failures,
        seconds: 0.0,
        files: Vec::new(),
    };
    let timings = opts
        .shard
        .map_or_else(|| TIMINGS_FILE.to_string(), |s| s.timings_file());
    match write_timings(&report, &opts.out, &timings, t0) {
        Ok(p) => report.files.push(p),
        Err(e) => log(&format!("warning: {}", chain(&e))),
    }
    if let Some((sh, definitions)) = sharded {
        let record = shard::ShardRecord {
            schema: "portalfind-experiment-shard".into(),
            schema_version: 1,
            generator: format!("portalfind {}", env!("CARGO_PKG_VERSION")),
            index: sh.index,
            count: sh.count,
            command: opts.command.clone(),
            definitions,
            finished: report.outcomes.iter().map(|o| o.def.name.clone()).collect(),
            failures: report
                .failures
                .iter()
                .map(|f| shard::RecordedFailure {
                    file: f.file().display().to_string(),
                    message: f.to_string(),
                })
                .collect(),
        };
        match shard::write_record(&opts.out, sh, &record) {
            Ok(p) => report.files.push(p),
            Err(e) => {
                let e = ExperimentError::Failed {
                    file: opts.out.clone(),
                    name: format!("shard {sh}"),
                    message: chain(&e),
                };
                log(&format!("error: {e}"));
                report.failures.push(e);
            }
        }
        report.seconds = t0.elapsed().as_secs_f64();
        return report;
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
fn write_timings(report: &Report, out: &Path, file: &str, t0: Instant) -> Result<PathBuf, RunError> {
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
    let path = out.join(file);
    let text = serde_json::to_string_pretty(&doc).map_err(RunError::SerializeEvaluation)?;
    crate::model::write::write_atomic(&path, text.as_bytes()).map_err(|source| RunError::WriteFile {
        path: path.clone(),
        source,
    })?;
    Ok(path)
}
