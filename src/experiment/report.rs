//! `results/summary.csv` (one row per experiment) and `results/README.md` (the thesis's
//! figures beside ours, with the weight curves).

use super::eval::{Evaluation, RotationCheck, Separation, SeparationDoorway};
use super::{ExperimentError, PortalSet, Report, RunError, RunOptions};
use crate::model::write::write_atomic;
use serde::Serialize;
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A number with 4 significant digits, without trailing zeros after the point.
pub fn sig(x: f64) -> String {
    if !x.is_finite() {
        return x.to_string();
    }
    if x == 0.0 {
        return "0".into();
    }
    if x.abs() < 1e-3 {
        return format!("{x:.3e}");
    }
    let digits = (3 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
    let s = format!("{x:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

fn transforms_text(e: &Evaluation) -> String {
    e.model
        .transforms
        .iter()
        .map(|t| serde_json::to_string(t).unwrap_or_default())
        .collect::<Vec<_>>()
        .join(" ")
}

/// One row of `summary.csv`; the header is the field names, in order.
#[derive(Debug, Default, Serialize)]
pub struct SummaryRow {
    experiment: String,
    status: String,
    model: String,
    transforms: String,
    subdivision: String,
    heuristic: String,
    estimator: String,
    stop: String,
    vertices: Option<usize>,
    triangles: Option<usize>,
    tetrahedra: Option<usize>,
    cells_split: Option<usize>,
    exterior_removed: Option<usize>,
    active_cells: Option<usize>,
    collapses: Option<usize>,
    final_cells: Option<usize>,
    final_portal_pairs: Option<usize>,
    rooms: Option<usize>,
    rooms_isolated: Option<usize>,
    spike_cells: Option<usize>,
    spike_volume_fraction: Option<String>,
    jump_step: Option<usize>,
    jump_from_end: Option<usize>,
    weight_max_before: Option<String>,
    weight_last_before: Option<String>,
    weight_at_jump: Option<String>,
    spike_cells_at_jump: Option<usize>,
    rooms_isolated_at_jump: Option<usize>,
    doorways: Option<usize>,
    doorways_matched: Option<usize>,
    separation_collapses: Option<usize>,
    separating_portals: Option<usize>,
    doorways_matched_at_separation: Option<usize>,
    doorways_by_position_at_separation: Option<usize>,
    rotation_ours_matched: Option<String>,
    rotation_theirs_matched: Option<String>,
    separating_compare_ours_matched: Option<String>,
    separating_compare_theirs_matched: Option<String>,
    definition: String,
}

impl SummaryRow {
    /// The row of a finished experiment.
    pub fn of(e: &Evaluation) -> Self {
        let t = e.truth.as_ref();
        let j = t.and_then(|t| t.weight_jump.as_ref());
        let r = first_check(e, PortalSet::Final);
        let rs = first_check(e, PortalSet::Separating);
        let sep = t.and_then(|t| t.separation.as_ref());
        SummaryRow {
            experiment: e.experiment.clone(),
            status: "ok".into(),
            model: e.model.source.clone(),
            transforms: transforms_text(e),
            subdivision: e.settings.subdivision.clone(),
            heuristic: e.settings.heuristic.clone(),
            estimator: e.settings.estimator.clone(),
            stop: e.settings.stop.clone(),
            vertices: Some(e.model.vertices),
            triangles: Some(e.model.triangles),
            tetrahedra: Some(e.complex.tetrahedra),
            cells_split: Some(e.complex.cells_split),
            exterior_removed: Some(e.complex.exterior_cells_removed),
            active_cells: Some(e.complex.active_cells),
            collapses: Some(e.decimation.collapses),
            final_cells: Some(e.decimation.final_cells),
            final_portal_pairs: Some(e.decimation.final_portal_pairs),
            rooms: t.map(|t| t.rooms),
            rooms_isolated: t.map(|t| t.rooms_isolated),
            spike_cells: t.map(|t| t.spike_cells.count),
            spike_volume_fraction: t.map(|t| sig(t.spike_cells.volume_fraction)),
            jump_step: j.map(|j| j.step),
            jump_from_end: j.map(|j| j.from_end),
            weight_max_before: j.map(|j| sig(j.max_before)),
            weight_last_before: j.map(|j| sig(j.last_before)),
            weight_at_jump: j.map(|j| sig(j.weight)),
            spike_cells_at_jump: j.map(|j| j.spike_cells_before),
            rooms_isolated_at_jump: j.map(|j| j.rooms_isolated_before),
            doorways: t.map(|t| t.doorways),
            doorways_matched: t.map(|t| t.doorways_matched),
            separation_collapses: sep.map(|s| s.collapses),
            separating_portals: sep.map(|s| s.separating_portals),
            doorways_matched_at_separation: sep.map(|s| s.doorways_matched),
            doorways_by_position_at_separation: sep.map(|s| s.doorways_matched_by_position),
            rotation_ours_matched: r.map(|r| format!("{}/{}", r.ours_matched, r.ours_total)),
            rotation_theirs_matched: r.map(|r| format!("{}/{}", r.theirs_matched, r.theirs_total)),
            separating_compare_ours_matched: rs.map(|r| format!("{}/{}", r.ours_matched, r.ours_total)),
            separating_compare_theirs_matched: rs.map(|r| format!("{}/{}", r.theirs_matched, r.theirs_total)),
            definition: e.definition.clone(),
        }
    }

    /// The row of a failed experiment: its name, the error and the definition file.
    pub fn failed(name: &str, error: &ExperimentError, file: &Path) -> Self {
        SummaryRow {
            experiment: name.to_string(),
            status: format!("failed: {error}"),
            definition: file.display().to_string(),
            ..SummaryRow::default()
        }
    }
}

/// The first rotation check of this kind.
fn first_check(e: &Evaluation, set: PortalSet) -> Option<&RotationCheck> {
    e.rotation_checks.iter().find(|r| r.portals == set)
}

/// Median of finite values (`None` when there are none).
fn median(mut v: Vec<f64>) -> Option<f64> {
    v.retain(|x| x.is_finite());
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => None,
        n if n % 2 == 1 => Some(v[n / 2]),
        n => Some(0.5 * (v[n / 2 - 1] + v[n / 2])),
    }
}

/// The side-by-side text of the separating portals.
fn separating_text(s: &Separation, rooms: usize) -> String {
    format!(
        "{} separating portals after {} collapses ({}): {} cells, {} of {} rooms isolated, {} at doorways",
        s.separating_portals, s.collapses, s.state, s.cells, s.rooms_isolated, rooms, s.portals_at_doorways
    )
}

/// The side-by-side text of the doorways at separation.
fn separation_doorways_text(s: &Separation, doorways: usize, diag: f64) -> String {
    let mut out = format!(
        "{} of {} joined by a separating portal between the rooms' cells; {} of those within {}% of the diagonal ({})",
        s.doorways_matched,
        doorways,
        s.doorways_matched_by_position,
        sig(100.0 * s.position_tolerance / diag),
        sig(s.position_tolerance)
    );
    let m = |f: fn(&SeparationDoorway) -> Option<f64>| median(s.per_doorway.iter().filter_map(f).collect());
    if let (Some(d), Some(pl), Some(ax), Some(t)) = (
        m(|d| d.distance),
        m(|d| d.plane_distance),
        m(|d| d.axis_distance),
        m(|d| d.tilt_deg),
    ) {
        out += &format!(
            "; medians: {} from the doorway centre, {} from its plane, {} from its axis, tilted {}° from it",
            sig(d),
            sig(pl),
            sig(ax),
            sig(t)
        );
    }
    out
}

/// One rotation check, for the tables.
fn check_text(r: &RotationCheck) -> String {
    format!(
        "{}: {}/{} of ours match {}, {}/{} of theirs match ours{}",
        r.portals,
        r.ours_matched,
        r.ours_total,
        r.against,
        r.theirs_matched,
        r.theirs_total,
        if r.identical { " (identical)" } else { "" }
    )
}

fn thesis_text(v: Option<&Value>) -> String {
    match v {
        None => "—".into(),
        Some(Value::String(s)) => s.clone(),
        Some(v) => v.to_string(),
    }
}

/// Escapes `|` for a Markdown table cell.
fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// Our figure for each row of the side-by-side table: (label, thesis key, ours).
pub fn side_by_side(e: &Evaluation) -> Vec<(&'static str, &'static str, String)> {
    let t = e.truth.as_ref();
    let na = || "n/a (no ground truth)".to_string();
    let jump = match t {
        None => na(),
        Some(t) => match &t.weight_jump {
            None => "no collapse joins rooms".into(),
            Some(j) => format!(
                "{} (largest before; last before {}) → {} at collapse {} of {} ({}{} last){}",
                sig(j.max_before),
                sig(j.last_before),
                sig(j.weight),
                j.step,
                t.full_run_collapses,
                j.from_end,
                ordinal(j.from_end),
                if j.stop_before_jump {
                    "; the stop came before it"
                } else {
                    "; the stop came after it, so rooms were joined"
                }
            ),
        },
    };
    let spikes = match t {
        None => na(),
        Some(t) => {
            let mut s = format!(
                "{} at the stop ({}% of the active volume)",
                t.spike_cells.count,
                sig(100.0 * t.spike_cells.volume_fraction)
            );
            if let Some(j) = &t.weight_jump {
                s += &format!(
                    "; {} of {} cells when rooms first meet ({}%)",
                    j.spike_cells_before,
                    j.cells_before,
                    sig(100.0 * j.spike_volume_fraction_before)
                );
            }
            s
        }
    };
    let rotation = if e.rotation_checks.is_empty() {
        "—".into()
    } else {
        e.rotation_checks.iter().map(check_text).collect::<Vec<_>>().join("; ")
    };
    let sep = t.and_then(|t| t.separation.as_ref().map(|s| (t, s)));
    vec![
        ("vertices", "vertices", e.model.vertices.to_string()),
        ("triangles", "triangles", e.model.triangles.to_string()),
        ("tetrahedra", "tets", e.complex.tetrahedra.to_string()),
        ("cells added by splitting", "split", e.complex.cells_split.to_string()),
        (
            "exterior cells removed",
            "exterior",
            e.complex.exterior_cells_removed.to_string(),
        ),
        ("active cells", "active", e.complex.active_cells.to_string()),
        (
            "final cells / portal pairs",
            "portals",
            format!(
                "{} cells, {} portal pairs",
                e.decimation.final_cells, e.decimation.final_portal_pairs
            ),
        ),
        ("weight jump", "weight_jump", jump),
        (
            "rooms isolated",
            "rooms_isolated",
            t.map_or_else(na, |t| {
                let mut s = format!("{} of {} at the stop", t.rooms_isolated, t.rooms);
                if let Some(j) = &t.weight_jump {
                    s += &format!(
                        "; {} of {} just before the first room-joining collapse",
                        j.rooms_isolated_before, t.rooms
                    );
                }
                s
            }),
        ),
        ("spike cells", "spike_cells", spikes),
        (
            "doorways matched by a portal",
            "doorways",
            t.map_or_else(na, |t| {
                format!(
                    "{} of {} ({} of the portal pairs at doorways)",
                    t.doorways_matched, t.doorways, t.portals_at_doorways
                )
            }),
        ),
        (
            "separating portals (room-separation state)",
            "separating_portals",
            sep.map_or_else(na, |(t, s)| separating_text(s, t.rooms)),
        ),
        (
            "doorways matched at separation",
            "doorways_at_separation",
            sep.map_or_else(na, |(t, s)| {
                separation_doorways_text(s, t.doorways, e.model.bbox_diagonal)
            }),
        ),
        ("rotation check", "rotation_check", rotation),
    ]
}

fn ordinal(n: usize) -> &'static str {
    match (n % 10, n % 100) {
        (_, 11..=13) => "th",
        (1, _) => "st",
        (2, _) => "nd",
        (3, _) => "rd",
        _ => "th",
    }
}

/// Writes `summary.csv` and `README.md` into `opts.out`; `order` lists the definitions
/// (name, file) in run order.
pub fn write_summary(
    report: &Report,
    order: &[(String, PathBuf)],
    opts: &RunOptions,
) -> Result<Vec<PathBuf>, RunError> {
    let out = &opts.out;
    std::fs::create_dir_all(out).map_err(|source| RunError::CreateDir {
        dir: out.clone(),
        source,
    })?;
    // summary.csv: the header comes from `SummaryRow`'s fields.
    let csv_err = |e: csv::Error| RunError::SummaryCsv(Box::new(e));
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut rows = 0;
    for (name, file) in order {
        if let Some(o) = report.outcomes.iter().find(|o| o.def.name == *name && !name.is_empty()) {
            w.serialize(SummaryRow::of(&o.eval)).map_err(csv_err)?;
            rows += 1;
        } else if let Some(f) = report.failures.iter().find(|f| f.file() == file.as_path()) {
            w.serialize(SummaryRow::failed(name, f, file)).map_err(csv_err)?;
            rows += 1;
        }
    }
    if rows == 0 {
        // No rows, so `serialize` wrote no header: take it from a default row.
        w.serialize(SummaryRow::default()).map_err(csv_err)?;
        let all = w
            .into_inner()
            .map_err(|e| RunError::SummaryCsv(Box::new(e.into_error())))?;
        let end = all.iter().position(|&b| b == b'\n').map_or(all.len(), |i| i + 1);
        w = csv::Writer::from_writer(all[..end].to_vec());
    }
    let csv_bytes = w
        .into_inner()
        .map_err(|e| RunError::SummaryCsv(Box::new(e.into_error())))?;
    let csv_path = out.join("summary.csv");
    write_atomic(&csv_path, &csv_bytes).map_err(|source| RunError::WriteFile {
        path: csv_path.clone(),
        source,
    })?;
    // summary_visibility.csv: only when some experiment was evaluated (else an earlier one
    // is removed: it would no longer match).
    let vis_path = out.join(VISIBILITY_SUMMARY_FILE);
    let mut files = vec![csv_path];
    if report.outcomes.iter().any(|o| o.eval.visibility.is_some()) {
        let bytes = visibility_csv(report).map_err(|e| RunError::SummaryCsv(Box::new(e)))?;
        write_atomic(&vis_path, &bytes).map_err(|source| RunError::WriteFile {
            path: vis_path.clone(),
            source,
        })?;
        files.push(vis_path);
    } else if vis_path.is_file() {
        let _ = std::fs::remove_file(&vis_path);
    }
    // Comparison plots (one model, several heuristics), linked from the README.
    for (name, group) in comparison_groups(report) {
        let dir = out.join(COMPARISONS_DIR);
        std::fs::create_dir_all(&dir).map_err(|source| RunError::CreateDir {
            dir: dir.clone(),
            source,
        })?;
        let c = comparison(&group);
        let png = dir.join(format!("{name}.png"));
        let svg = dir.join(format!("{name}.svg"));
        let plot_err = |path: &Path, e: crate::output::OutputError| RunError::WriteFile {
            path: path.to_path_buf(),
            source: std::io::Error::other(e.to_string()),
        };
        crate::output::write_atomic(&png, |tmp| crate::output::compare::comparison_png(tmp, &c))
            .map_err(|e| plot_err(&png, e))?;
        let text = crate::output::compare::comparison_svg(&c).map_err(|e| plot_err(&svg, e))?;
        write_atomic(&svg, text.as_bytes()).map_err(|source| RunError::WriteFile {
            path: svg.clone(),
            source,
        })?;
        files.extend([png, svg]);
    }
    // README.md
    let readme = readme_text(report, opts);
    let md_path = out.join("README.md");
    write_atomic(&md_path, readme.as_bytes()).map_err(|source| RunError::WriteFile {
        path: md_path.clone(),
        source,
    })?;
    files.push(md_path);
    Ok(files)
}

/// The visibility summary's file name in the results directory.
pub const VISIBILITY_SUMMARY_FILE: &str = "summary_visibility.csv";

/// `summary_visibility.csv`: one row per evaluated experiment (no timings: the PVS seconds
/// are in `timings.json`; `pvs_chains` counts the PVS's work).
fn visibility_csv(report: &Report) -> Result<Vec<u8>, csv::Error> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "experiment",
        "cells",
        "portals",
        "pvs_mean_cells",
        "pvs_max_cells",
        "total_triangles",
        "expected_triangles",
        "area_fraction",
        "culling_ratio",
        "pvs_chains",
        "rays",
        "false_invisible",
        "overestimation_median",
    ])?;
    for o in &report.outcomes {
        let Some(v) = &o.eval.visibility else { continue };
        w.write_record([
            o.eval.experiment.clone(),
            v.cells.to_string(),
            v.portals.to_string(),
            sig(v.pvs_mean_cells),
            v.pvs_max_cells.to_string(),
            v.total_triangles.to_string(),
            sig(v.expected_triangles),
            sig(v.area_fraction),
            sig(v.culling_ratio),
            v.pvs_chains.to_string(),
            v.rays.to_string(),
            v.false_invisible.to_string(),
            v.overestimation_median.map_or(String::new(), sig),
        ])?;
    }
    w.into_inner().map_err(|e| e.into_error().into())
}

/// The README's visibility table (empty when no experiment was evaluated).
fn visibility_section(report: &Report) -> String {
    let rows: Vec<_> = report
        .outcomes
        .iter()
        .filter_map(|o| o.eval.visibility.as_ref().map(|v| (&o.eval, v)))
        .collect();
    if rows.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "## Visibility of the final partitions\n\n\
         Evaluated experiments (definition field `evaluate`, or `experiment --evaluate`): the \
         PVS, E_T and the sampling check of `portalfind evaluate` on the final cells; each \
         directory holds `visibility.json` and `visibility_cells.csv`, and \
         `summary_visibility.csv` has these rows (PVS seconds: `timings.json`).\n\n\
         | experiment | cells | portals | PVS cells mean / max | E_T | triangles | area fraction | culling ratio | rays | false invisibles | overestimation (median) |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for (e, v) in rows {
        let _ = writeln!(
            s,
            "| [{n}]({n}/) | {} | {} | {} / {} | {} | {} | {} | {} | {} | {} | {} |",
            v.cells,
            v.portals,
            sig(v.pvs_mean_cells),
            v.pvs_max_cells,
            sig(v.expected_triangles),
            v.total_triangles,
            sig(v.area_fraction),
            sig(v.culling_ratio),
            v.rays,
            v.false_invisible,
            v.overestimation_median.map_or("—".into(), sig),
            n = e.experiment
        );
    }
    s.push('\n');
    s
}

/// Where the comparison plots go, inside the results directory.
pub const COMPARISONS_DIR: &str = "comparisons";

/// Experiments on the same model (same source and transforms) with different settings,
/// in run order, named by their first experiment; only groups of two or more.
pub fn comparison_groups(report: &Report) -> Vec<(String, Vec<&super::Outcome>)> {
    let mut groups: Vec<(String, Vec<&super::Outcome>)> = Vec::new();
    let key = |o: &super::Outcome| (o.eval.model.source.clone(), transforms_text(&o.eval));
    for o in &report.outcomes {
        match groups.iter_mut().find(|(_, g)| key(g[0]) == key(o)) {
            Some((_, g)) => g.push(o),
            None => groups.push((o.eval.experiment.clone(), vec![o])),
        }
    }
    groups.retain(|(_, g)| g.len() >= 2);
    groups
}

/// What one run of a comparison shows: `heuristic / estimator` (and the subdivision when
/// it is not Delaunay's).
fn series_label(e: &Evaluation) -> String {
    let mut l = format!("{}: {} / {}", e.experiment, e.settings.heuristic, e.settings.estimator);
    if e.settings.subdivision != "delaunay" {
        let _ = write!(l, ", {} cells", e.settings.subdivision);
    }
    l
}

/// The comparison picture of a group: each run's weight curve up to its stop, read back
/// from its `weight_curve.csv` (a run whose file cannot be read is drawn without steps).
fn comparison(group: &[&super::Outcome]) -> crate::output::compare::Comparison {
    use crate::output::compare::{Comparison, Series};
    let series = group
        .iter()
        .map(|o| {
            let e = &o.eval;
            let steps = read_curve(&o.dir.join("weight_curve.csv"));
            let first_join = e
                .truth
                .as_ref()
                .and_then(|t| t.weight_jump.as_ref())
                .map(|j| j.step)
                .filter(|&j| j <= steps.len());
            Series {
                label: series_label(e),
                initial_cells: e.complex.active_cells,
                steps,
                first_join,
            }
        })
        .collect();
    Comparison {
        title: format!(
            "{}: the weight curves of {} runs compared",
            group[0].eval.model.source,
            group.len()
        ),
        series,
        rooms: group[0].eval.truth.as_ref().map(|t| t.rooms),
    }
}

/// (weight, cells remaining) per row of a `weight_curve.csv`; empty if unreadable.
fn read_curve(path: &Path) -> Vec<(f64, usize)> {
    let Ok(mut r) = csv::Reader::from_path(path) else {
        return Vec::new();
    };
    r.records()
        .map_while(|rec| {
            let rec = rec.ok()?;
            Some((rec.get(1)?.parse().ok()?, rec.get(2)?.parse().ok()?))
        })
        .collect()
}

fn rel_link(out: &Path, file: &str) -> String {
    // Definitions live beside the results directory: link them as ../experiments/X.
    let p = Path::new(file);
    match (p.parent().and_then(|d| d.file_name()), p.file_name()) {
        (Some(d), Some(f)) if out.parent().is_some() => format!("../{}/{}", d.to_string_lossy(), f.to_string_lossy()),
        _ => file.to_string(),
    }
}

/// The room accuracy on the generated suite, from the files `portalfind bench accuracy`
/// wrote under `out/accuracy/` (absent: no section): the "all families" rows of the full
/// bench (`accuracy/table.md`, the thesis heuristics and the new ones, both halves) and of
/// each later round (`accuracy/roundN/table.md`), without their time column (timings stay
/// out of committed files), then the time-against-error plot and the pictures.
fn accuracy_section(out: &Path) -> String {
    let dir = out.join("accuracy");
    let Ok(full) = std::fs::read_to_string(dir.join("table.md")) else {
        return String::new();
    };
    let mut tables = vec![("accuracy/table.md".to_string(), full)];
    let mut rounds: Vec<(u32, String)> = std::fs::read_dir(&dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|d| {
            let name = d.file_name().to_string_lossy().into_owned();
            let n = name.strip_prefix("round")?.parse().ok()?;
            Some((n, name))
        })
        .collect();
    rounds.sort();
    for (_, name) in rounds {
        if let Ok(t) = std::fs::read_to_string(dir.join(&name).join("table.md")) {
            tables.push((format!("accuracy/{name}/table.md"), t));
        }
    }
    let mut s = String::new();
    let _ = writeln!(s, "## Rooms on the generated suite (`portalfind bench accuracy`)\n");
    let _ = writeln!(
        s,
        "66 generated models with ground truth; even seeds are the **tune** half, odd seeds \
         the **report** half (never used for a choice). Rows over all families, per table \
         file as `bench accuracy` wrote it; the later rounds rerun the default heuristics \
         after a change (what each changed: [accuracy/README.md](accuracy/README.md) and \
         each round's README). Per-family rows, volumetric scores and run times are in the \
         files.\n"
    );
    for (file, text) in &tables {
        let _ = writeln!(s, "From [{file}]({file}):\n");
        for line in text.lines() {
            let cols: Vec<&str> = line.split('|').collect();
            // | config | half | family | ... | time |: keep the header, the rule and the
            // "all" rows, without the last (time) column.
            let keep =
                cols.len() > 4 && (cols[3].trim() == "all" || cols[3].trim() == "family" || cols[3].starts_with("---"));
            if keep {
                let _ = writeln!(s, "{}|", cols[..cols.len() - 2].join("|"));
            }
        }
        s.push('\n');
    }
    if dir.join("time_vs_error.png").exists() {
        let _ = writeln!(s, "![time against error](accuracy/time_vs_error.png)\n");
    }
    let mut pictures: Vec<String> = std::fs::read_dir(dir.join("pictures"))
        .into_iter()
        .flatten()
        .flatten()
        .map(|d| d.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".svg"))
        .collect();
    pictures.sort();
    if !pictures.is_empty() {
        let _ = writeln!(s, "Models at the default stop (`aperture`, `threshold:1.8`):\n");
        for p in &pictures {
            let _ = writeln!(s, "![{p}](accuracy/pictures/{p})");
        }
        s.push('\n');
    }
    s
}

fn readme_text(report: &Report, opts: &RunOptions) -> String {
    let mut s = String::new();
    let build = if cfg!(debug_assertions) { "debug" } else { "release" };
    let _ = writeln!(s, "# Results: the experiments of the thesis, section 4.3\n");
    let _ = writeln!(
        s,
        "Generated by `{}` (portalfind {}, {build} build) from the definitions in \
         `experiments/` (schema and score definitions: `experiments/README.md`). Do not edit \
         by hand: rerun the command. Timings depend on the machine, so no committed file holds \
         them (a rerun leaves a clean checkout clean): the run writes them to `{}` beside this \
         file, which git ignores.\n",
        opts.command,
        env!("CARGO_PKG_VERSION"),
        super::runner::TIMINGS_FILE
    );
    let _ = writeln!(
        s,
        "Each experiment's directory holds `result.json` (schema: `docs/result-schema.md`), \
         `evaluation.json` (the counts and scores below), `weight_curve.csv`, \
         `weight_curve.png` and the top view `cells.svg`; `summary.csv` has one row per \
         experiment.\n"
    );
    if !report.failures.is_empty() {
        let _ = writeln!(s, "## Failed experiments\n");
        for f in &report.failures {
            let _ = writeln!(s, "- {}", cell(&f.to_string()));
        }
        s.push('\n');
    }
    let _ = writeln!(s, "## Overview\n");
    let _ = writeln!(
        s,
        "| experiment | model | heuristic / estimator | stop | active cells | final cells | portal pairs | rooms isolated: at the stop (before the first room join) | weight jump (before → at) | spike cells | doorways matched | separating portals | doorways matched at separation (by position) | rotation check |"
    );
    let _ = writeln!(s, "|---|---|---|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---|");
    for o in &report.outcomes {
        let e = &o.eval;
        let t = e.truth.as_ref();
        let sep = t.and_then(|t| t.separation.as_ref());
        let _ = writeln!(
            s,
            "| [{n}]({n}/) | {} | {} / {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            cell(&e.model.source),
            e.settings.heuristic,
            e.settings.estimator,
            e.settings.stop,
            e.complex.active_cells,
            e.decimation.final_cells,
            e.decimation.final_portal_pairs,
            t.map_or("—".into(), |t| {
                let before = t
                    .weight_jump
                    .as_ref()
                    .map_or(String::new(), |j| format!(" ({}/{})", j.rooms_isolated_before, t.rooms));
                format!("{}/{}{before}", t.rooms_isolated, t.rooms)
            }),
            t.and_then(|t| t.weight_jump.as_ref()).map_or("—".into(), |j| format!(
                "{} → {}",
                sig(j.max_before),
                sig(j.weight)
            )),
            t.map_or("—".into(), |t| t.spike_cells.count.to_string()),
            t.map_or("—".into(), |t| format!("{}/{}", t.doorways_matched, t.doorways)),
            sep.map_or("—".into(), |s| s.separating_portals.to_string()),
            t.zip(sep).map_or("—".into(), |(t, s)| format!(
                "{}/{} ({})",
                s.doorways_matched, t.doorways, s.doorways_matched_by_position
            )),
            if e.rotation_checks.is_empty() {
                "—".into()
            } else {
                e.rotation_checks
                    .iter()
                    .map(|r| {
                        format!(
                            "{} {}/{} · {}/{}",
                            r.portals, r.ours_matched, r.ours_total, r.theirs_matched, r.theirs_total
                        )
                    })
                    .collect::<Vec<_>>()
                    .join("; ")
            },
            n = e.experiment,
        );
    }
    s.push('\n');
    s.push_str(&visibility_section(report));
    let groups = comparison_groups(report);
    if !groups.is_empty() {
        let _ = writeln!(s, "## Comparisons\n");
        let _ = writeln!(
            s,
            "The runs on one model overlaid: the weight of each collapse over the cells \
             remaining (log scales; each run goes from right to left), a dot at each run's \
             stop, a cross at its first room join when that came before the stop, a dashed \
             line at the true room count. A run whose curve jumps at the room count separates \
             the rooms there.\n"
        );
        for (name, g) in &groups {
            let runs: Vec<String> = g
                .iter()
                .map(|o| format!("[{n}]({n}/)", n = o.eval.experiment))
                .collect();
            let _ = writeln!(
                s,
                "### {name}: {}\n\n![comparison on {name}]({COMPARISONS_DIR}/{name}.png)\n\n[SVG]({COMPARISONS_DIR}/{name}.svg)\n",
                runs.join(", ")
            );
        }
    }
    s.push_str(&accuracy_section(&opts.out));
    for o in &report.outcomes {
        let e = &o.eval;
        let _ = writeln!(s, "## [{n}]({n}/)\n", n = e.experiment);
        if let Some(d) = &e.description {
            let _ = writeln!(s, "{d}\n");
        }
        let tr = if e.model.transforms.is_empty() {
            String::new()
        } else {
            format!(", transformed by `{}`", transforms_text(e))
        };
        let _ = writeln!(
            s,
            "Model `{}`{tr}; {} subdivision; heuristic `{}`, estimator `{}`, stop `{}` ({}). \
             Definition: [`{}`]({}).\n",
            e.model.source,
            e.settings.subdivision,
            e.settings.heuristic,
            e.settings.estimator,
            e.settings.stop,
            e.decimation.stop_reason,
            e.definition,
            rel_link(&opts.out, &e.definition)
        );
        let _ = writeln!(s, "| count | thesis | ours |\n|---|---|---|");
        let rows = side_by_side(e);
        for (label, key, ours) in &rows {
            let _ = writeln!(
                s,
                "| {label} | {} | {} |",
                cell(&thesis_text(e.thesis.get(*key))),
                cell(ours)
            );
        }
        for (k, v) in &e.thesis {
            if rows.iter().any(|(_, key, _)| key == k) {
                continue;
            }
            let ours = match k.as_str() {
                "heuristic" => format!("{} / {}", e.settings.heuristic, e.settings.estimator),
                "stop" => e.settings.stop.clone(),
                _ => "—".into(),
            };
            let label = match k.as_str() {
                "heuristic" => "heuristic / estimator",
                "bsp_cells" => "BSP cells (the thesis's baseline)",
                other => other,
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} |",
                cell(label),
                cell(&thesis_text(Some(v))),
                cell(&ours)
            );
        }
        let _ = writeln!(
            s,
            "\n![weight curve of {n}]({n}/weight_curve.png)\n\nTop view of the final cells: [{n}/cells.svg]({n}/cells.svg)\n",
            n = e.experiment
        );
        if !e.snapshots.is_empty() {
            let _ = writeln!(
                s,
                "Intermediate states (rebuilt by replaying the recorded collapses):\n\n\
                 | cells left | collapses | last weight | next weight | portal pairs | portal area | top view |\n\
                 |---:|---:|---:|---:|---:|---:|---|"
            );
            let w = |x: Option<f64>| x.map_or("–".to_string(), |v| format!("{v:.4}"));
            for sn in &e.snapshots {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {:.4e} | [{f}]({n}/{f}) |",
                    sn.cells,
                    sn.collapses,
                    w(sn.last_weight),
                    w(sn.next_weight),
                    sn.portal_pairs,
                    sn.portal_area,
                    f = sn.file,
                    n = e.experiment
                );
            }
            let _ = writeln!(s);
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The columns `summary.csv` has always had, in order.
    const COLUMNS: [&str; 39] = [
        "experiment",
        "status",
        "model",
        "transforms",
        "subdivision",
        "heuristic",
        "estimator",
        "stop",
        "vertices",
        "triangles",
        "tetrahedra",
        "cells_split",
        "exterior_removed",
        "active_cells",
        "collapses",
        "final_cells",
        "final_portal_pairs",
        "rooms",
        "rooms_isolated",
        "spike_cells",
        "spike_volume_fraction",
        "jump_step",
        "jump_from_end",
        "weight_max_before",
        "weight_last_before",
        "weight_at_jump",
        "spike_cells_at_jump",
        "rooms_isolated_at_jump",
        "doorways",
        "doorways_matched",
        "separation_collapses",
        "separating_portals",
        "doorways_matched_at_separation",
        "doorways_by_position_at_separation",
        "rotation_ours_matched",
        "rotation_theirs_matched",
        "separating_compare_ours_matched",
        "separating_compare_theirs_matched",
        "definition",
    ];

    #[test]
    fn summary_header_comes_from_the_row_struct_and_failed_rows_are_mostly_empty() {
        let err = ExperimentError::UnknownField {
            file: PathBuf::from("experiments/x.json"),
            field: "spin".into(),
        };
        let mut w = csv::Writer::from_writer(Vec::new());
        w.serialize(SummaryRow::failed("x", &err, Path::new("experiments/x.json")))
            .unwrap();
        let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next().unwrap(), COLUMNS.join(","));
        let row = lines.next().unwrap();
        assert!(
            row.starts_with("x,failed: experiments/x.json: unknown field `spin`"),
            "{row}"
        );
        assert!(
            row.ends_with(&format!("{},experiments/x.json", ",".repeat(36))),
            "{row}"
        );
    }

    #[test]
    fn sig_keeps_four_significant_digits() {
        assert_eq!(sig(0.0), "0");
        assert_eq!(sig(1.23456), "1.235");
        assert_eq!(sig(1234.6), "1235");
        assert_eq!(sig(2.5), "2.5");
        assert_eq!(sig(0.0001234), "1.234e-4");
    }
}
