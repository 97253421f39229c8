//! `results/summary.csv` (one row per experiment) and `results/README.md` (the thesis's
//! figures beside ours, with the weight curves).

use super::eval::{Evaluation, RotationCheck, Separation, SeparationDoorway};
use super::{PortalSet, Report, RunOptions};
use crate::model::write::write_atomic;
use anyhow::{Context, Result};
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Columns of `summary.csv`.
pub const COLUMNS: [&str; 40] = [
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
    "seconds",
    "definition",
];

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

fn opt<T: ToString>(x: Option<T>) -> String {
    x.map(|v| v.to_string()).unwrap_or_default()
}

fn transforms_text(e: &Evaluation) -> String {
    e.model
        .transforms
        .iter()
        .map(|t| serde_json::to_string(t).unwrap_or_default())
        .collect::<Vec<_>>()
        .join(" ")
}

fn csv_row(e: &Evaluation) -> Vec<String> {
    let t = e.truth.as_ref();
    let j = t.and_then(|t| t.weight_jump.as_ref());
    let r = first_check(e, PortalSet::Final);
    let rs = first_check(e, PortalSet::Separating);
    let sep = t.and_then(|t| t.separation.as_ref());
    vec![
        e.experiment.clone(),
        "ok".into(),
        e.model.source.clone(),
        transforms_text(e),
        e.settings.subdivision.clone(),
        e.settings.heuristic.clone(),
        e.settings.estimator.clone(),
        e.settings.stop.clone(),
        e.model.vertices.to_string(),
        e.model.triangles.to_string(),
        e.complex.tetrahedra.to_string(),
        e.complex.cells_split.to_string(),
        e.complex.exterior_cells_removed.to_string(),
        e.complex.active_cells.to_string(),
        e.decimation.collapses.to_string(),
        e.decimation.final_cells.to_string(),
        e.decimation.final_portal_pairs.to_string(),
        opt(t.map(|t| t.rooms)),
        opt(t.map(|t| t.rooms_isolated)),
        opt(t.map(|t| t.spike_cells.count)),
        opt(t.map(|t| sig(t.spike_cells.volume_fraction))),
        opt(j.map(|j| j.step)),
        opt(j.map(|j| j.from_end)),
        opt(j.map(|j| sig(j.max_before))),
        opt(j.map(|j| sig(j.last_before))),
        opt(j.map(|j| sig(j.weight))),
        opt(j.map(|j| j.spike_cells_before)),
        opt(j.map(|j| j.rooms_isolated_before)),
        opt(t.map(|t| t.doorways)),
        opt(t.map(|t| t.doorways_matched)),
        opt(sep.map(|s| s.collapses)),
        opt(sep.map(|s| s.separating_portals)),
        opt(sep.map(|s| s.doorways_matched)),
        opt(sep.map(|s| s.doorways_matched_by_position)),
        opt(r.map(|r| format!("{}/{}", r.ours_matched, r.ours_total))),
        opt(r.map(|r| format!("{}/{}", r.theirs_matched, r.theirs_total))),
        opt(rs.map(|r| format!("{}/{}", r.ours_matched, r.ours_total))),
        opt(rs.map(|r| format!("{}/{}", r.theirs_matched, r.theirs_total))),
        format!("{:.3}", e.timings.total_seconds),
        e.definition.clone(),
    ]
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
/// (name, file) in run order, `t0` is when the run started.
pub fn write_summary(
    report: &Report,
    order: &[(String, PathBuf)],
    opts: &RunOptions,
    t0: Instant,
) -> Result<Vec<PathBuf>> {
    let out = &opts.out;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    // summary.csv
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(COLUMNS)?;
    for (name, file) in order {
        if let Some(o) = report.outcomes.iter().find(|o| o.def.name == *name && !name.is_empty()) {
            w.write_record(csv_row(&o.eval))?;
        } else if let Some(f) = report.failures.iter().find(|f| f.file() == file.as_path()) {
            let mut row = vec![String::new(); COLUMNS.len()];
            row[0] = name.clone();
            row[1] = format!("failed: {f}");
            row[COLUMNS.len() - 1] = file.display().to_string();
            w.write_record(row)?;
        }
    }
    let csv_bytes = w.into_inner().context("cannot write summary.csv")?;
    let csv_path = out.join("summary.csv");
    write_atomic(&csv_path, &csv_bytes).with_context(|| format!("cannot write {}", csv_path.display()))?;
    // README.md
    let readme = readme_text(report, opts, t0.elapsed().as_secs_f64());
    let md_path = out.join("README.md");
    write_atomic(&md_path, readme.as_bytes()).with_context(|| format!("cannot write {}", md_path.display()))?;
    Ok(vec![csv_path, md_path])
}

fn rel_link(out: &Path, file: &str) -> String {
    // Definitions live beside the results directory: link them as ../experiments/X.
    let p = Path::new(file);
    match (p.parent().and_then(|d| d.file_name()), p.file_name()) {
        (Some(d), Some(f)) if out.parent().is_some() => format!("../{}/{}", d.to_string_lossy(), f.to_string_lossy()),
        _ => file.to_string(),
    }
}

fn readme_text(report: &Report, opts: &RunOptions, seconds: f64) -> String {
    let mut s = String::new();
    let build = if cfg!(debug_assertions) { "debug" } else { "release" };
    let _ = writeln!(s, "# Results: the experiments of the thesis, section 4.3\n");
    let _ = writeln!(
        s,
        "Generated by `{}` (portalfind {}, {build} build) from the definitions in \
         `experiments/` (schema and score definitions: `experiments/README.md`). The whole run \
         took **{:.1} s** wall time, measured by the program up to writing this file. Do not \
         edit by hand: rerun the command.\n",
        opts.command,
        env!("CARGO_PKG_VERSION"),
        seconds
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
        "| experiment | model | heuristic / estimator | stop | active cells | final cells | portal pairs | rooms isolated: at the stop (before the first room join) | weight jump (before → at) | spike cells | doorways matched | separating portals | doorways matched at separation (by position) | rotation check | seconds |"
    );
    let _ = writeln!(
        s,
        "|---|---|---|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---|---:|"
    );
    for o in &report.outcomes {
        let e = &o.eval;
        let t = e.truth.as_ref();
        let sep = t.and_then(|t| t.separation.as_ref());
        let _ = writeln!(
            s,
            "| [{n}]({n}/) | {} | {} / {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.2} |",
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
            e.timings.total_seconds,
            n = e.experiment,
        );
    }
    s.push('\n');
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
