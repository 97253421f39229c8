//! The scale benchmark (issue 17; `portalfind bench scale`): `gen rooms`-style buildings
//! from about 10k to about 1M triangles, each run through `portalfind run` at defaults and
//! `portalfind tetra --no-validate` in fresh child processes of the given executable. Per
//! size: wall time and peak resident memory of each child (`wait4`'s `ru_maxrss`, the
//! child's own high-water mark), the run's per-stage seconds as it printed them, the ratio
//! run / tetra (both measured in the same go, since a shared machine drifts), and over all
//! sizes the growth exponents of run time and peak memory (log-log least squares).
//! Writes `scale.csv`, `scale.json`, `table.md` and `scale.svg` (log-log plot).

use crate::generate::scenes::room_grid;
use crate::model::write::{obj_text, write_atomic};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// Room grids (nx = ny) at tessellation 8: about 9.9k, 31k, 103k, 244k, 477k and 974k
/// triangles.
pub const GRIDS: [usize; 6] = [4, 7, 13, 20, 28, 40];
/// Tessellation of every size (door edges need a multiple of 8).
pub const TESS: usize = 8;

/// One size.
#[derive(Clone, Debug, Serialize)]
pub struct ScaleRow {
    pub nx: usize,
    pub ny: usize,
    pub tess: usize,
    pub triangles: usize,
    /// Wall seconds of the `run` child (spawn to exit).
    pub run_s: f64,
    /// Peak resident memory of the `run` child, MiB.
    pub run_peak_mib: f64,
    /// CPU seconds (user + system, all threads) of the `run` child: on a shared machine
    /// less disturbed by other jobs than the wall time.
    #[serde(default)]
    pub run_cpu_s: f64,
    /// CPU seconds of the `tetra` child.
    #[serde(default)]
    pub tetra_cpu_s: f64,
    /// Wall seconds of the `tetra --no-validate` child (spawn to exit, load included).
    pub tetra_s: f64,
    /// Peak resident memory of the `tetra` child, MiB.
    pub tetra_peak_mib: f64,
    /// `run_s / tetra_s`.
    pub ratio: f64,
    /// The run's stage report (name, seconds), as it printed it.
    pub stages: Vec<(String, f64)>,
    /// The run's "final cells" line.
    pub final_cells: Option<usize>,
    /// The run's peak resident memory (MiB) at the end of each stage, as it printed it.
    #[serde(default)]
    pub memory: Vec<(String, f64)>,
    /// Finite tetrahedra (the run's `result.json`).
    #[serde(default)]
    pub tetrahedra: Option<usize>,
    /// Active cells at the start of the decimation (the run's "active cells" line).
    #[serde(default)]
    pub active_cells: Option<usize>,
    /// With thread counts ([`ScaleOptions::threads`]): one `run` per count and repetition,
    /// in fresh processes with `RAYON_NUM_THREADS` set, interleaved (counts in turn, then
    /// the next repetition), in the order they ran. The row's own run figures are then
    /// those of the largest count's first run.
    #[serde(default)]
    pub by_threads: Vec<ThreadRun>,
}

/// One `run` child at a fixed rayon thread count.
#[derive(Clone, Debug, Serialize)]
pub struct ThreadRun {
    /// `RAYON_NUM_THREADS` of the child.
    pub threads: usize,
    /// Wall seconds.
    pub run_s: f64,
    /// CPU seconds (user + system, all threads).
    pub run_cpu_s: f64,
    /// Peak resident memory, MiB.
    pub run_peak_mib: f64,
    /// The stage report as the run printed it.
    pub stages: Vec<(String, f64)>,
}

/// What [`run`] measures besides the sizes.
#[derive(Clone, Debug, Default)]
pub struct ScaleOptions {
    /// Rayon thread counts to run each size at (e.g. `[1, 2]`); empty: one run at the
    /// machine's default.
    pub threads: Vec<usize>,
    /// Runs per thread count (at least 1), interleaved.
    pub repeat: usize,
}

/// All sizes and the fitted exponents.
#[derive(Clone, Debug, Serialize)]
pub struct ScaleReport {
    pub rows: Vec<ScaleRow>,
    /// Slope of log(run_s) against log(triangles).
    pub time_exponent: Option<f64>,
    /// Slope of log(run_peak_mib) against log(triangles).
    pub memory_exponent: Option<f64>,
    /// Slope of log(run_cpu_s) against log(triangles).
    pub cpu_exponent: Option<f64>,
}

/// Least-squares slope of log y against log x (None for fewer than two points).
pub fn loglog_slope(pts: &[(f64, f64)]) -> Option<f64> {
    let p: Vec<(f64, f64)> = pts
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    if p.len() < 2 {
        return None;
    }
    let n = p.len() as f64;
    let mx = p.iter().map(|q| q.0).sum::<f64>() / n;
    let my = p.iter().map(|q| q.1).sum::<f64>() / n;
    let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
    let sxx: f64 = p.iter().map(|q| (q.0 - mx) * (q.0 - mx)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// A finished child: wall seconds, CPU seconds (user + system, all threads), peak RSS
/// (MiB), exit success, stdout and stderr.
pub(crate) struct Child {
    pub(crate) secs: f64,
    pub(crate) cpu: f64,
    pub(crate) peak_mib: f64,
    pub(crate) ok: bool,
    pub(crate) stdout: String,
    pub(crate) stderr: String,
}

/// Runs `exe args` to completion (with `RAYON_NUM_THREADS` set when `threads` is given);
/// the peak memory is the child's own (`wait4`).
pub(crate) fn run_child(exe: &Path, args: &[&std::ffi::OsStr], threads: Option<usize>) -> std::io::Result<Child> {
    use std::io::Read;
    let t0 = Instant::now();
    let mut cmd = Command::new(exe);
    if let Some(t) = threads {
        cmd.env("RAYON_NUM_THREADS", t.to_string());
    }
    let mut child = cmd
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()?;
    // Standard error on its own thread, so that neither pipe can fill while the other
    // is read.
    let err = child.stderr.take().map(|mut e| {
        std::thread::spawn(move || {
            let mut b = Vec::new();
            let _ = e.read_to_end(&mut b);
            String::from_utf8_lossy(&b).into_owned()
        })
    });
    let mut stdout = String::new();
    if let Some(mut out) = child.stdout.take() {
        out.read_to_string(&mut stdout)?;
    }
    let stderr = err.and_then(|h| h.join().ok()).unwrap_or_default();
    let pid = child.id() as libc::pid_t;
    let mut status: libc::c_int = 0;
    // SAFETY: a zeroed rusage is a valid out-parameter; `pid` is our own unwaited child.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    let secs = t0.elapsed().as_secs_f64();
    if r != pid {
        return Err(std::io::Error::last_os_error());
    }
    let ok = libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0;
    let tv = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    // Linux reports ru_maxrss in KiB.
    Ok(Child {
        secs,
        cpu: tv(usage.ru_utime) + tv(usage.ru_stime),
        peak_mib: usage.ru_maxrss as f64 / 1024.0,
        ok,
        stdout,
        stderr,
    })
}

/// The stage table `run` prints: rows between the "stage seconds" header and "total".
pub fn parse_stages(stdout: &str) -> Vec<(String, f64)> {
    let mut out = Vec::new();
    let mut inside = false;
    for line in stdout.lines() {
        let t = line.trim_end();
        if t.starts_with("stage") && t.ends_with("seconds") {
            inside = true;
            continue;
        }
        if !inside {
            continue;
        }
        let Some((name, secs)) = t.rsplit_once(' ') else { break };
        let Ok(secs) = secs.parse::<f64>() else { break };
        let name = name.trim().to_string();
        if name == "total" {
            break;
        }
        out.push((name, secs));
    }
    out
}

/// The memory table `run` prints: rows between the "peak memory after MiB" header and the
/// next blank line.
pub fn parse_memory(stdout: &str) -> Vec<(String, f64)> {
    let mut out = Vec::new();
    let mut inside = false;
    for line in stdout.lines() {
        let t = line.trim_end();
        if t.starts_with("peak memory after") && t.ends_with("MiB") {
            inside = true;
            continue;
        }
        if !inside {
            continue;
        }
        let Some((name, mib)) = t.rsplit_once(' ') else { break };
        let Ok(mib) = mib.parse::<f64>() else { break };
        out.push((name.trim().to_string(), mib));
    }
    out
}

fn counter(stdout: &str, name: &str) -> Option<usize> {
    let line = stdout.lines().find(|l| l.starts_with(name))?;
    line.split_whitespace().last()?.parse().ok()
}

fn final_cells(stdout: &str) -> Option<usize> {
    counter(stdout, "final cells")
}

/// Finite tetrahedra recorded in a run directory's `result.json`.
fn tetrahedra(run_dir: &Path) -> Option<usize> {
    let text = std::fs::read_to_string(run_dir.join("result.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    v.get("subdivision_stats")?
        .get("tetrahedra")?
        .as_u64()
        .map(|n| n as usize)
}

/// Runs every grid of [`GRIDS`] whose model has `min_triangles..=max_triangles` triangles.
/// `exe` is the portalfind executable; `work` a scratch directory (models and run
/// outputs; each size's files are removed after it ran). `log` gets progress lines.
pub fn run(exe: &Path, sizes: (usize, usize), work: &Path, log: &mut dyn FnMut(&str)) -> std::io::Result<ScaleReport> {
    run_with(exe, sizes, &ScaleOptions::default(), work, log)
}

/// [`run`], with the thread counts and repetitions of `opts`.
pub fn run_with(
    exe: &Path,
    (min_triangles, max_triangles): (usize, usize),
    opts: &ScaleOptions,
    work: &Path,
    log: &mut dyn FnMut(&str),
) -> std::io::Result<ScaleReport> {
    std::fs::create_dir_all(work)?;
    let mut rows = Vec::new();
    for &n in &GRIDS {
        let (s, _) = room_grid(n, n, TESS);
        let triangles: usize = s.polygons.iter().map(|p| p.len() - 2).sum();
        if triangles > max_triangles || triangles < min_triangles {
            continue;
        }
        let model = work.join(format!("rooms_{n}x{n}_t{TESS}.obj"));
        let header = format!("portalfind gen rooms --nx {n} --ny {n} --tess {TESS}");
        write_atomic(&model, obj_text(&header, &s.vertices, &s.polygons).as_bytes())?;
        drop(s);
        let out_dir: PathBuf = work.join(format!("run_{n}"));
        log(&format!("{n}x{n} rooms, {triangles} triangles: tetra ..."));
        let tetra = run_child(
            exe,
            &["tetra".as_ref(), "--no-validate".as_ref(), model.as_os_str()],
            None,
        )?;
        log(&format!(
            "  tetra {:.2} s (CPU {:.2} s), {:.0} MiB; run ...",
            tetra.secs, tetra.cpu, tetra.peak_mib
        ));
        let args = ["run".as_ref(), model.as_os_str(), "--out".as_ref(), out_dir.as_os_str()];
        let mut by_threads = Vec::new();
        let mut main_run: Option<Child> = None;
        let most = opts.threads.iter().copied().max();
        if opts.threads.is_empty() {
            main_run = Some(run_child(exe, &args, None)?);
        }
        for rep in 0..opts.repeat.max(1) {
            for &t in &opts.threads {
                let c = run_child(exe, &args, Some(t))?;
                log(&format!(
                    "  run at {t} thread(s) #{}: {:.2} s (CPU {:.2} s), {:.0} MiB",
                    rep + 1,
                    c.secs,
                    c.cpu,
                    c.peak_mib
                ));
                if !c.ok {
                    return Err(std::io::Error::other(format!(
                        "run failed on {} at {t} thread(s)",
                        model.display()
                    )));
                }
                by_threads.push(ThreadRun {
                    threads: t,
                    run_s: c.secs,
                    run_cpu_s: c.cpu,
                    run_peak_mib: c.peak_mib,
                    stages: parse_stages(&c.stdout),
                });
                if main_run.is_none() && Some(t) == most {
                    main_run = Some(c);
                }
            }
        }
        let run = main_run.expect("a run at the default or the largest thread count");
        log(&format!(
            "  run {:.2} s (CPU {:.2} s), {:.0} MiB",
            run.secs, run.cpu, run.peak_mib
        ));
        if !tetra.ok || !run.ok {
            return Err(std::io::Error::other(format!(
                "a child failed on {} (tetra ok: {}, run ok: {})",
                model.display(),
                tetra.ok,
                run.ok
            )));
        }
        let tets = tetrahedra(&out_dir);
        let _ = std::fs::remove_file(&model);
        let _ = std::fs::remove_dir_all(&out_dir);
        rows.push(ScaleRow {
            nx: n,
            ny: n,
            tess: TESS,
            triangles,
            run_s: run.secs,
            run_peak_mib: run.peak_mib,
            run_cpu_s: run.cpu,
            tetra_cpu_s: tetra.cpu,
            tetra_s: tetra.secs,
            tetra_peak_mib: tetra.peak_mib,
            ratio: run.secs / tetra.secs,
            stages: parse_stages(&run.stdout),
            final_cells: final_cells(&run.stdout),
            memory: parse_memory(&run.stdout),
            tetrahedra: tets,
            active_cells: counter(&run.stdout, "active cells"),
            by_threads,
        });
    }
    let time_exponent = loglog_slope(&rows.iter().map(|r| (r.triangles as f64, r.run_s)).collect::<Vec<_>>());
    let cpu_exponent = loglog_slope(
        &rows
            .iter()
            .map(|r| (r.triangles as f64, r.run_cpu_s))
            .collect::<Vec<_>>(),
    );
    let memory_exponent = loglog_slope(
        &rows
            .iter()
            .map(|r| (r.triangles as f64, r.run_peak_mib))
            .collect::<Vec<_>>(),
    );
    Ok(ScaleReport {
        rows,
        time_exponent,
        memory_exponent,
        cpu_exponent,
    })
}

/// Names in first-seen order over all rows, of the (name, value) list `of` picks.
fn names_of(rows: &[ScaleRow], of: impl Fn(&ScaleRow) -> &[(String, f64)]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for r in rows {
        for (n, _) in of(r) {
            if !names.contains(n) {
                names.push(n.clone());
            }
        }
    }
    names
}

/// Stage names in first-seen order over all rows.
fn stage_names(rows: &[ScaleRow]) -> Vec<String> {
    names_of(rows, |r| &r.stages)
}

/// A Markdown table with one row per name and one column per size (headed by its
/// triangle count), after a blank line and `caption:`; `cell` gives one cell (` v |`).
fn per_size_table(
    s: &mut String,
    caption: &str,
    first: &str,
    rows: &[ScaleRow],
    names: &[String],
    cell: impl Fn(&ScaleRow, &str) -> String,
) {
    if names.is_empty() {
        return;
    }
    s.push_str(&format!("\n{caption}:\n\n| {first} |"));
    for r in rows {
        s.push_str(&format!(" {} |", r.triangles));
    }
    s.push_str("\n|---|");
    for _ in rows {
        s.push_str("---:|");
    }
    s.push('\n');
    for n in names {
        s.push_str(&format!("| {n} |"));
        for r in rows {
            s.push_str(&cell(r, n));
        }
        s.push('\n');
    }
}

fn stage_secs(r: &ScaleRow, name: &str) -> Option<f64> {
    r.stages.iter().find(|(n, _)| n == name).map(|s| s.1)
}

/// The Markdown table: one row per size, then the stage seconds per size, then exponents.
pub fn table(rep: &ScaleReport) -> String {
    let mut s = String::new();
    s.push_str("| rooms | triangles | run s | run CPU s | run peak MiB | tetra s | tetra CPU s | tetra peak MiB | run / tetra | final cells |\n");
    s.push_str("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for r in &rep.rows {
        s.push_str(&format!(
            "| {}×{} | {} | {:.2} | {:.2} | {:.0} | {:.2} | {:.2} | {:.0} | {:.1} | {} |\n",
            r.nx,
            r.ny,
            r.triangles,
            r.run_s,
            r.run_cpu_s,
            r.run_peak_mib,
            r.tetra_s,
            r.tetra_cpu_s,
            r.tetra_peak_mib,
            r.ratio,
            r.final_cells.map_or("-".into(), |c| c.to_string())
        ));
    }
    let f = |e: Option<f64>| e.map_or("-".to_string(), |v| format!("{v:.3}"));
    s.push_str(&format!(
        "\nGrowth exponent (log-log least squares over the sizes above): run time {}, run CPU time {}, run peak memory {}.\n",
        f(rep.time_exponent),
        f(rep.cpu_exponent),
        f(rep.memory_exponent)
    ));
    per_size_table(
        &mut s,
        "Stage seconds as each run printed them",
        "stage",
        &rep.rows,
        &stage_names(&rep.rows),
        |r, n| stage_secs(r, n).map_or(" - |".into(), |v| format!(" {v:.3} |")),
    );
    let mem_names = memory_names(&rep.rows);
    if !mem_names.is_empty() {
        per_size_table(
            &mut s,
            "Peak resident memory (MiB) at the end of each stage, as each run printed it",
            "after",
            &rep.rows,
            &mem_names,
            |r, n| memory_at(r, n).map_or(" - |".into(), |v| format!(" {v:.0} |")),
        );
        let per = |r: &ScaleRow, stage: &str, count: Option<usize>| -> String {
            match (memory_at(r, stage), count) {
                (Some(m), Some(c)) if c > 0 => format!(" {:.0} |", m * 1048576.0 / c as f64),
                _ => " - |".into(),
            }
        };
        s.push_str("| tetrahedra |");
        for r in &rep.rows {
            s.push_str(&r.tetrahedra.map_or(" - |".into(), |c| format!(" {c} |")));
        }
        s.push_str("\n| active cells |");
        for r in &rep.rows {
            s.push_str(&r.active_cells.map_or(" - |".into(), |c| format!(" {c} |")));
        }
        s.push_str("\n| bytes per tetrahedron (peak after the cell complex) |");
        for r in &rep.rows {
            s.push_str(&per(r, "cell complex", r.tetrahedra));
        }
        s.push_str("\n| bytes per active cell (peak after the decimation) |");
        for r in &rep.rows {
            s.push_str(&per(r, "decimation", r.active_cells));
        }
        s.push('\n');
    }
    s.push_str(&threads_table(&rep.rows));
    s
}

/// Thread counts measured over all rows, ascending.
fn thread_counts(rows: &[ScaleRow]) -> Vec<usize> {
    let mut t: Vec<usize> = rows
        .iter()
        .flat_map(|r| r.by_threads.iter().map(|x| x.threads))
        .collect();
    t.sort_unstable();
    t.dedup();
    t
}

/// Median of a stage's seconds (or of the whole run's wall time, `name` = `None`) over the
/// runs of one size at `threads`.
fn thread_median(r: &ScaleRow, threads: usize, name: Option<&str>) -> Option<f64> {
    let mut v: Vec<f64> = r
        .by_threads
        .iter()
        .filter(|x| x.threads == threads)
        .filter_map(|x| match name {
            None => Some(x.run_s),
            Some(n) => x.stages.iter().find(|(m, _)| m == n).map(|s| s.1),
        })
        .collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    Some(if v.len() % 2 == 1 {
        v[m]
    } else {
        (v[m - 1] + v[m]) / 2.0
    })
}

/// Per-stage seconds side by side per thread count (medians over the repetitions), and the
/// speedup of the largest count over the smallest, per size; empty without thread runs.
pub fn threads_table(rows: &[ScaleRow]) -> String {
    let counts = thread_counts(rows);
    let rows: Vec<&ScaleRow> = rows.iter().filter(|r| !r.by_threads.is_empty()).collect();
    if counts.is_empty() || rows.is_empty() {
        return String::new();
    }
    let mut names: Vec<&String> = Vec::new();
    for (n, _) in rows
        .iter()
        .flat_map(|r| r.by_threads.iter().flat_map(|x| x.stages.iter()))
    {
        if !names.contains(&n) {
            names.push(n);
        }
    }
    let (lo, hi) = (counts[0], counts[counts.len() - 1]);
    let mut s = format!(
        "\nStage seconds by rayon thread count (RAYON_NUM_THREADS, fresh processes, interleaved; median of {} run(s) each); speedup = {lo} thread(s) / {hi} thread(s):\n\n| stage |",
        rows[0].by_threads.iter().filter(|x| x.threads == lo).count()
    );
    for r in &rows {
        for t in &counts {
            s.push_str(&format!(" {} @{t} |", r.triangles));
        }
        if counts.len() > 1 {
            s.push_str(&format!(" {} speedup |", r.triangles));
        }
    }
    s.push_str("\n|---|");
    for _ in &rows {
        for _ in &counts {
            s.push_str("---:|");
        }
        if counts.len() > 1 {
            s.push_str("---:|");
        }
    }
    s.push('\n');
    let line = |s: &mut String, label: &str, name: Option<&str>| {
        s.push_str(&format!("| {label} |"));
        for r in &rows {
            for &t in &counts {
                s.push_str(&thread_median(r, t, name).map_or(" - |".into(), |v| format!(" {v:.3} |")));
            }
            if counts.len() > 1 {
                s.push_str(&match (thread_median(r, lo, name), thread_median(r, hi, name)) {
                    (Some(a), Some(b)) if b > 0.0 => format!(" {:.2} |", a / b),
                    _ => " - |".into(),
                });
            }
        }
        s.push('\n');
    };
    for n in &names {
        line(&mut s, n, Some(n));
    }
    line(&mut s, "run (wall, spawn to exit)", None);
    s
}

/// Memory-table stage names in first-seen order over all rows.
fn memory_names(rows: &[ScaleRow]) -> Vec<String> {
    names_of(rows, |r| &r.memory)
}

fn memory_at(r: &ScaleRow, name: &str) -> Option<f64> {
    r.memory.iter().find(|(n, _)| n == name).map(|s| s.1)
}

fn csv_text(rep: &ScaleReport) -> String {
    let names = stage_names(&rep.rows);
    let mut s = String::from(
        "nx,ny,tess,triangles,run_s,run_peak_mib,tetra_s,tetra_peak_mib,ratio,final_cells,run_cpu_s,tetra_cpu_s",
    );
    for n in &names {
        s.push_str(&format!(",\"stage: {n}\""));
    }
    s.push('\n');
    for r in &rep.rows {
        s.push_str(&format!(
            "{},{},{},{},{:.4},{:.1},{:.4},{:.1},{:.3},{}",
            r.nx,
            r.ny,
            r.tess,
            r.triangles,
            r.run_s,
            r.run_peak_mib,
            r.tetra_s,
            r.tetra_peak_mib,
            r.ratio,
            r.final_cells.map_or(String::new(), |c| c.to_string())
        ));
        s.push_str(&format!(",{:.4},{:.4}", r.run_cpu_s, r.tetra_cpu_s));
        for n in &names {
            s.push_str(&stage_secs(r, n).map_or(",".into(), |v| format!(",{v:.4}")));
        }
        s.push('\n');
    }
    s
}

const FONTS: [&str; 3] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
];

/// The log-log plot: run and tetra seconds and run peak GiB against triangles.
fn plot(rep: &ScaleReport, path: &Path) -> Result<(), String> {
    use plotters::prelude::*;
    let text = std::env::var("PORTALFIND_FONT")
        .ok()
        .into_iter()
        .chain(FONTS.iter().map(|s| s.to_string()))
        .any(|p| {
            std::fs::read(&p).ok().is_some_and(|b| {
                let b: &'static [u8] = Box::leak(b.into_boxed_slice());
                plotters::style::register_font("sans-serif", FontStyle::Normal, b).is_ok()
            })
        });
    let e = |e: &dyn std::fmt::Debug| format!("{e:?}");
    let root = SVGBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let rows = &rep.rows;
    if rows.is_empty() {
        return root.present().map_err(|x| e(&x));
    }
    let xs: Vec<f64> = rows.iter().map(|r| r.triangles as f64).collect();
    let ys: Vec<f64> = rows
        .iter()
        .flat_map(|r| [r.run_s, r.tetra_s, r.run_peak_mib / 1024.0])
        .filter(|v| *v > 0.0)
        .collect();
    let (xlo, xhi) = (
        xs.iter().cloned().fold(f64::INFINITY, f64::min) / 1.3,
        xs.iter().cloned().fold(0.0, f64::max) * 1.3,
    );
    let (ylo, yhi) = (
        ys.iter().cloned().fold(f64::INFINITY, f64::min) / 1.5,
        ys.iter().cloned().fold(0.0, f64::max) * 1.5,
    );
    let mut b = ChartBuilder::on(&root);
    b.margin(20);
    if text {
        b.caption(
            "portalfind run at defaults vs triangles (gen rooms, log-log)",
            ("sans-serif", 20),
        )
        .x_label_area_size(45)
        .y_label_area_size(60);
    }
    let mut chart = b
        .build_cartesian_2d((xlo..xhi).log_scale(), (ylo..yhi).log_scale())
        .map_err(|x| e(&x))?;
    if text {
        chart
            .configure_mesh()
            .x_desc("triangles")
            .y_desc("seconds / GiB")
            .draw()
            .map_err(|x| e(&x))?;
    }
    type Series = (&'static str, RGBColor, Vec<(f64, f64)>);
    let series: [Series; 3] = [
        (
            "run wall s",
            BLUE,
            rows.iter().map(|r| (r.triangles as f64, r.run_s)).collect(),
        ),
        (
            "tetra wall s",
            GREEN,
            rows.iter().map(|r| (r.triangles as f64, r.tetra_s)).collect(),
        ),
        (
            "run peak GiB",
            RED,
            rows.iter()
                .map(|r| (r.triangles as f64, r.run_peak_mib / 1024.0))
                .collect(),
        ),
    ];
    for (name, color, pts) in series {
        let s = chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
            .map_err(|x| e(&x))?;
        if text {
            s.label(name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
        }
        chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))
            .map_err(|x| e(&x))?;
    }
    if text {
        chart
            .configure_series_labels()
            .background_style(WHITE)
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .map_err(|x| e(&x))?;
    }
    root.present().map_err(|x| e(&x))
}

/// Writes scale.csv, scale.json, table.md and scale.svg into `dir`.
pub fn write_all(rep: &ScaleReport, dir: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    write_atomic(&dir.join("scale.csv"), csv_text(rep).as_bytes())?;
    let json = serde_json::to_string_pretty(rep).map_err(std::io::Error::other)?;
    write_atomic(&dir.join("scale.json"), json.as_bytes())?;
    write_atomic(&dir.join("table.md"), table(rep).as_bytes())?;
    plot(rep, &dir.join("scale.svg")).map_err(std::io::Error::other)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slope_of_a_power_law() {
        let pts: Vec<(f64, f64)> = [1e4, 1e5, 1e6].iter().map(|&x: &f64| (x, 3.0 * x.powf(1.07))).collect();
        assert!((loglog_slope(&pts).unwrap() - 1.07).abs() < 1e-9);
        assert_eq!(loglog_slope(&pts[..1]), None);
    }

    #[test]
    fn stage_table_is_parsed() {
        let out = "loaded x in 0.1 s\nstage                 seconds\nload model    0.096\ndecimation: collapses   0.205\ntotal   2.447\n\nfinal cells      16\n";
        assert_eq!(
            parse_stages(out),
            vec![
                ("load model".to_string(), 0.096),
                ("decimation: collapses".to_string(), 0.205)
            ]
        );
        assert_eq!(final_cells(out), Some(16));
        let out = "total   2.447\n\npeak memory after                 MiB\nload model        12.5\ncell complex     80.0\n\nheuristic / estimator  aperture / -\nactive cells     45864\n";
        assert_eq!(
            parse_memory(out),
            vec![("load model".to_string(), 12.5), ("cell complex".to_string(), 80.0)]
        );
        assert_eq!(counter(out, "active cells"), Some(45864));
    }

    #[test]
    fn thread_table_takes_medians_and_divides_the_smallest_count_by_the_largest() {
        let tr = |threads: usize, run_s: f64, split: f64| ThreadRun {
            threads,
            run_s,
            run_cpu_s: run_s,
            run_peak_mib: 1.0,
            stages: vec![("splitting".to_string(), split)],
        };
        let row = ScaleRow {
            nx: 2,
            ny: 2,
            tess: 8,
            triangles: 500,
            run_s: 1.0,
            run_peak_mib: 1.0,
            run_cpu_s: 1.0,
            tetra_cpu_s: 0.1,
            tetra_s: 0.1,
            tetra_peak_mib: 1.0,
            ratio: 10.0,
            stages: Vec::new(),
            final_cells: None,
            memory: Vec::new(),
            tetrahedra: None,
            active_cells: None,
            // Medians at 1 thread: run 4, splitting 3; at 2 threads: run 2, splitting 1.
            by_threads: vec![
                tr(1, 4.0, 3.0),
                tr(2, 2.0, 1.0),
                tr(1, 5.0, 3.5),
                tr(2, 2.5, 1.5),
                tr(1, 3.0, 2.0),
                tr(2, 1.0, 0.5),
            ],
        };
        let t = threads_table(std::slice::from_ref(&row));
        assert!(t.contains("| stage | 500 @1 | 500 @2 | 500 speedup |"), "{t}");
        assert!(t.contains("| splitting | 3.000 | 1.000 | 3.00 |"), "{t}");
        assert!(
            t.contains("| run (wall, spawn to exit) | 4.000 | 2.000 | 2.00 |"),
            "{t}"
        );
        let plain = ScaleRow {
            by_threads: Vec::new(),
            ..row
        };
        assert_eq!(threads_table(&[plain]), "");
    }

    #[test]
    fn per_size_tables_have_one_column_per_size_and_a_dash_for_missing_values() {
        let row = |triangles: usize, stages: &[(&str, f64)], memory: &[(&str, f64)]| ScaleRow {
            nx: 2,
            ny: 2,
            tess: 8,
            triangles,
            run_s: 2.0,
            run_peak_mib: 10.0,
            run_cpu_s: 1.5,
            tetra_cpu_s: 0.1,
            tetra_s: 0.2,
            tetra_peak_mib: 5.0,
            ratio: 10.0,
            stages: stages.iter().map(|(n, v)| (n.to_string(), *v)).collect(),
            final_cells: Some(4),
            memory: memory.iter().map(|(n, v)| (n.to_string(), *v)).collect(),
            tetrahedra: Some(1024),
            active_cells: None,
            by_threads: Vec::new(),
        };
        let rep = ScaleReport {
            rows: vec![
                row(100, &[("load model", 0.5)], &[("cell complex", 2.0)]),
                row(
                    1000,
                    &[("load model", 1.25), ("splitting", 3.0)],
                    &[("cell complex", 8.0)],
                ),
            ],
            time_exponent: None,
            memory_exponent: None,
            cpu_exponent: None,
        };
        let t = table(&rep);
        assert!(
            t.contains(
                "| stage | 100 | 1000 |\n|---|---:|---:|\n| load model | 0.500 | 1.250 |\n| splitting | - | 3.000 |\n"
            ),
            "{t}"
        );
        assert!(
            t.contains(
                "| after | 100 | 1000 |\n|---|---:|---:|\n| cell complex | 2 | 8 |\n| tetrahedra | 1024 | 1024 |\n"
            ),
            "{t}"
        );
        assert!(
            t.contains("| bytes per tetrahedron (peak after the cell complex) | 2048 | 8192 |"),
            "{t}"
        );
        assert!(
            t.contains("| bytes per active cell (peak after the decimation) | - | - |"),
            "{t}"
        );
    }
}
