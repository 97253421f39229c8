//! Sharded sweeps (issue 17): `portalfind experiment DIR --shard I/N` runs a deterministic
//! subset of the definitions, and `portalfind experiment DIR --merge` writes `summary.csv`
//! and `README.md` from the shards' outputs, equal to what one unsharded run writes
//! (timings aside). An existing engine (GNU parallel, a Slurm job array) runs the shards;
//! nothing here schedules.
//!
//! **Assignment rule** ([`assign`]). Experiments joined by `compare_to` (directly or through
//! others) form one *group* and always run in the same shard, since a rotation check needs
//! the other experiment's portals of the same run. Each group's expected cost is the sum of
//! its models' polygon counts ([`expected_cost`]: a thesis model is generated in memory, a
//! file is read and cleaned; a model that cannot be loaded costs 0 and fails in its
//! shard). Groups are taken by decreasing cost (ties by their smallest name) and each goes
//! to the shard with the least cost so far (ties to the lowest index): the greedy
//! longest-processing-time rule. A definition that cannot be read goes to shard 1, which
//! reports it. The rule depends only on the definition files and the models, so every
//! shard computes the same assignment without talking to the others.
//!
//! **Files.** Shard `I` of `N` writes its experiments' `OUT/NAME/` directories (as an
//! unsharded run does), `OUT/shard-I-of-N.json` ([`ShardRecord`]: every definition with
//! its shard, cost and content hash, what this shard finished and what failed, with the
//! error text) and `OUT/timings.shard-I-of-N.json`; it never writes `summary.csv`,
//! `README.md` or another shard's files, so shards may run at the same time into one
//! directory. A shard removes its own record first, so a killed shard leaves none and the
//! merge refuses to run. The merge needs all N records of one N, each listing the same
//! definitions with the same content hashes as the directory now holds; it reads each
//! finished experiment's `evaluation.json` and writes `summary.csv`, `README.md` (with the
//! unsharded command the shards recorded) and `timings.json` (the shards' experiments; the
//! wall time of the slowest shard).

use super::definition::Definition;
use super::error::ExperimentError;
use super::eval::Evaluation;
use super::runner::{EVALUATION_FILE, Outcome, Report, RunOptions, TIMINGS_FILE};
use crate::model::write::write_atomic;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

/// One shard of N: `index` in `1..=count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// 1-based.
    pub index: usize,
    /// How many shards.
    pub count: usize,
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// A `--shard` value that is not `I/N` with `1 ≤ I ≤ N`.
#[derive(Debug, thiserror::Error)]
#[error("bad shard {0:?}: expected I/N with 1 <= I <= N (e.g. 2/4)")]
pub struct BadShard(String);

impl FromStr for Shard {
    type Err = BadShard;
    fn from_str(s: &str) -> Result<Self, BadShard> {
        let bad = || BadShard(s.to_string());
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let index: usize = i.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        if index == 0 || index > count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

impl Shard {
    /// `shard-I-of-N.json`.
    pub fn record_file(&self) -> String {
        format!("shard-{}-of-{}.json", self.index, self.count)
    }

    /// `timings.shard-I-of-N.json`.
    pub fn timings_file(&self) -> String {
        format!("timings.shard-{}-of-{}.json", self.index, self.count)
    }
}

/// Errors of the merge (and of writing a shard's record).
#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    /// The results directory cannot be listed.
    #[error("cannot list {}", dir.display())]
    List {
        /// The directory.
        dir: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// No `shard-I-of-N.json` in the results directory.
    #[error("no shard records (shard-I-of-N.json) in {}: run `portalfind experiment DIR --shard I/N` first", dir.display())]
    NoShards {
        /// The directory.
        dir: PathBuf,
    },
    /// Records of different shard counts.
    #[error("shard records of different shard counts ({counts:?}) in {}: remove the stale ones", dir.display())]
    MixedCounts {
        /// The directory.
        dir: PathBuf,
        /// The counts found.
        counts: Vec<usize>,
    },
    /// A shard's record is missing (not run, still running, or failed before its end).
    #[error("shard {index}/{count} has no record {} (not run, still running, or killed)", path.display())]
    MissingShard {
        /// Its index.
        index: usize,
        /// The count.
        count: usize,
        /// The record expected.
        path: PathBuf,
    },
    /// A record cannot be read or parsed.
    #[error("cannot read shard record {}: {message}", path.display())]
    BadRecord {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// The definitions changed since the shard ran.
    #[error("{}: the definitions differ from those the shard ran ({message}); rerun the shards", path.display())]
    DefinitionsChanged {
        /// The record.
        path: PathBuf,
        /// What differs.
        message: String,
    },
    /// An experiment that a shard finished has no readable `evaluation.json`.
    #[error("cannot read {}: {message}", path.display())]
    Evaluation {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// Writing a file failed.
    #[error("cannot write {}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Writing the summary failed.
    #[error(transparent)]
    Summary(#[from] super::error::RunError),
}

/// One definition as a shard saw it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct RecordedDefinition {
    /// The definition file, as given.
    pub file: String,
    /// Its experiment name (empty when it could not be read).
    pub name: String,
    /// FNV-1a 64 of the file's bytes, hexadecimal (empty when unreadable).
    pub hash: String,
    /// The shard it is assigned to (1-based).
    pub shard: usize,
    /// Its expected cost ([`expected_cost`]).
    pub cost: u64,
}

/// A failure as a shard reported it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct RecordedFailure {
    /// The definition file.
    pub file: String,
    /// The error, as printed.
    pub message: String,
}

/// `shard-I-of-N.json`: what one shard did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShardRecord {
    /// `"portalfind-experiment-shard"`.
    pub schema: String,
    /// 1.
    pub schema_version: u32,
    /// `"portalfind X.Y.Z"`.
    pub generator: String,
    /// This shard's index (1-based).
    pub index: usize,
    /// The shard count.
    pub count: usize,
    /// The equivalent unsharded command (for the merged README).
    pub command: String,
    /// Every definition of the directory, in run order, with its shard.
    pub definitions: Vec<RecordedDefinition>,
    /// The experiments this shard finished (their `evaluation.json` is final).
    pub finished: Vec<String>,
    /// The failures this shard reported, in definition order.
    pub failures: Vec<RecordedFailure>,
}

/// 64-bit FNV-1a of `bytes`, as 16 hexadecimal digits.
fn fnv1a(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// The expected cost of a definition: its model's polygon count after cleaning (run time
/// grows about linearly with it: issue 17 measured an exponent of 1.07), 0 when the model
/// cannot be loaded.
pub fn expected_cost(def: &Definition, root: &Path) -> u64 {
    match &def.model {
        super::ModelSource::Thesis(n) => {
            crate::generate::thesis::by_name(n).map_or(0, |m| m.soup.polygons.len() as u64)
        }
        super::ModelSource::File(p) => crate::model::load_model(&root.join(p)).map_or(0, |m| m.polygons.len() as u64),
    }
}

/// [`expected_cost`] of each definition (0 for unreadable ones), loading each model file
/// once.
pub fn costs(defs: &[Result<Definition, ExperimentError>], root: &Path) -> Vec<u64> {
    let mut seen: Vec<(String, u64)> = Vec::new();
    defs.iter()
        .map(|d| {
            let Ok(d) = d else { return 0 };
            let key = d.model.to_string();
            if let Some((_, c)) = seen.iter().find(|(k, _)| *k == key) {
                return *c;
            }
            let c = expected_cost(d, root);
            seen.push((key, c));
            c
        })
        .collect()
}

/// The shard (1-based) of each definition, in input order, by the rule of the module docs;
/// `costs[i]` is definition `i`'s expected cost (ignored for unreadable ones).
pub fn assign(defs: &[Result<Definition, ExperimentError>], costs: &[u64], count: usize) -> Vec<usize> {
    let count = count.max(1);
    let n = defs.len();
    // Union-find over compare_to between readable definitions.
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let name_of = |i: usize| defs[i].as_ref().ok().map(|d| d.name.as_str());
    for i in 0..n {
        let Ok(d) = &defs[i] else { continue };
        for c in &d.compare_to {
            if let Some(j) = (0..n).find(|&j| name_of(j) == Some(c.experiment.as_str())) {
                let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
    }
    // Groups: (cost, smallest name, members).
    let mut groups: Vec<(u64, String, Vec<usize>)> = Vec::new();
    let mut group_of: Vec<Option<usize>> = vec![None; n];
    for i in 0..n {
        let Some(name) = name_of(i) else { continue };
        let r = find(&mut parent, i);
        let g = match group_of[r] {
            Some(g) => g,
            None => {
                groups.push((0, name.to_string(), Vec::new()));
                group_of[r] = Some(groups.len() - 1);
                groups.len() - 1
            }
        };
        groups[g].0 += costs.get(i).copied().unwrap_or(0);
        if name < groups[g].1.as_str() {
            groups[g].1 = name.to_string();
        }
        groups[g].2.push(i);
    }
    groups.sort_by(|a, b| b.0.cmp(&a.0).then_with(|| a.1.cmp(&b.1)));
    let mut load = vec![0u64; count];
    let mut shard = vec![1usize; n];
    for (cost, _, members) in &groups {
        let s = (0..count).min_by_key(|&k| (load[k], k)).unwrap_or(0);
        load[s] += cost;
        for &i in members {
            shard[i] = s + 1;
        }
    }
    shard
}

/// The definitions of `defs` as a shard records them (file, name, hash, shard, cost).
pub fn record_definitions(
    defs: &[Result<Definition, ExperimentError>],
    costs: &[u64],
    shards: &[usize],
) -> Vec<RecordedDefinition> {
    defs.iter()
        .enumerate()
        .map(|(i, d)| {
            let file = match d {
                Ok(d) => d.file.clone(),
                Err(e) => e.file().to_path_buf(),
            };
            RecordedDefinition {
                hash: std::fs::read(&file).map_or(String::new(), |b| fnv1a(&b)),
                file: file.display().to_string(),
                name: d.as_ref().map_or(String::new(), |d| d.name.clone()),
                shard: shards[i],
                cost: costs.get(i).copied().unwrap_or(0),
            }
        })
        .collect()
}

/// Writes `text` atomically to `path`.
fn write_file(path: &Path, text: &str) -> Result<(), ShardError> {
    write_atomic(path, text.as_bytes()).map_err(|source| ShardError::Write {
        path: path.to_path_buf(),
        source,
    })
}

/// Writes shard `shard`'s record into `out`.
pub fn write_record(out: &Path, shard: Shard, record: &ShardRecord) -> Result<PathBuf, ShardError> {
    let path = out.join(shard.record_file());
    let text = serde_json::to_string_pretty(record).map_err(|e| ShardError::BadRecord {
        path: path.clone(),
        message: e.to_string(),
    })?;
    write_file(&path, &(text + "\n"))?;
    Ok(path)
}

/// The shard records in `out`: all N of one shard count, in index order.
pub fn read_records(out: &Path) -> Result<Vec<(PathBuf, ShardRecord)>, ShardError> {
    let rd = std::fs::read_dir(out).map_err(|source| ShardError::List {
        dir: out.to_path_buf(),
        source,
    })?;
    let mut counts: Vec<usize> = Vec::new();
    for e in rd.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = name.strip_prefix("shard-").and_then(|r| r.strip_suffix(".json")) else {
            continue;
        };
        let Some((i, n)) = rest.split_once("-of-") else {
            continue;
        };
        if let (Ok(_), Ok(n)) = (i.parse::<usize>(), n.parse::<usize>())
            && !counts.contains(&n)
        {
            counts.push(n);
        }
    }
    counts.sort_unstable();
    let count = match counts[..] {
        [] => return Err(ShardError::NoShards { dir: out.to_path_buf() }),
        [n] => n,
        _ => {
            return Err(ShardError::MixedCounts {
                dir: out.to_path_buf(),
                counts,
            });
        }
    };
    (1..=count)
        .map(|index| {
            let s = Shard { index, count };
            let path = out.join(s.record_file());
            if !path.is_file() {
                return Err(ShardError::MissingShard { index, count, path });
            }
            let bad = |message: String| ShardError::BadRecord {
                path: path.clone(),
                message,
            };
            let text = std::fs::read_to_string(&path).map_err(|e| bad(e.to_string()))?;
            let r: ShardRecord = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
            if r.index != index || r.count != count {
                return Err(bad(format!("it says shard {}/{}", r.index, r.count)));
            }
            Ok((path, r))
        })
        .collect()
}

/// Merges the shards' outputs in `opts.out` for the definitions `defs` (read again from the
/// same directory as the shards did): checks the records (see the module docs), rebuilds
/// the report from each finished experiment's `evaluation.json` and the recorded failures,
/// and writes `summary.csv`, `README.md` and `timings.json`.
pub fn merge(defs: Vec<Result<Definition, ExperimentError>>, opts: &RunOptions) -> Result<Report, ShardError> {
    let records = read_records(&opts.out)?;
    // The definitions now, with the shard numbers and costs of the records (compared apart).
    let shards = vec![0; defs.len()];
    let now = record_definitions(&defs, &[], &shards);
    for (path, r) in &records {
        let changed = |message: String| ShardError::DefinitionsChanged {
            path: path.clone(),
            message,
        };
        if r.definitions.len() != now.len() {
            return Err(changed(format!(
                "{} definitions then, {} now",
                r.definitions.len(),
                now.len()
            )));
        }
        for (a, b) in r.definitions.iter().zip(&now) {
            if (&a.file, &a.name, &a.hash) != (&b.file, &b.name, &b.hash) {
                return Err(changed(format!(
                    "{} ({:?}) then, {} ({:?}) now",
                    a.file, a.name, b.file, b.name
                )));
            }
        }
        if r.definitions != records[0].1.definitions {
            return Err(changed(format!(
                "its assignment differs from {}",
                records[0].0.display()
            )));
        }
    }
    let mut outcomes = Vec::new();
    let mut failures = Vec::new();
    let mut order = Vec::new();
    for (i, d) in defs.into_iter().enumerate() {
        let rd = &records[0].1.definitions[i];
        let file = PathBuf::from(&rd.file);
        let k = rd.shard.clamp(1, records.len()) - 1;
        let (rec_path, rec) = &records[k];
        order.push((rd.name.clone(), file.clone()));
        if let Some(f) = rec.failures.iter().find(|f| f.file == rd.file) {
            failures.push(ExperimentError::Recorded {
                file,
                message: f.message.clone(),
            });
            continue;
        }
        let def = match d {
            Ok(def) if rec.finished.contains(&def.name) => def,
            Ok(def) => {
                return Err(ShardError::BadRecord {
                    path: rec_path.clone(),
                    message: format!("experiment {:?} neither finished nor failed", def.name),
                });
            }
            Err(e) => {
                return Err(ShardError::BadRecord {
                    path: rec_path.clone(),
                    message: format!("the unreadable definition {} is not reported: {e}", rd.file),
                });
            }
        };
        let dir = opts.out.join(&def.name);
        let path = dir.join(EVALUATION_FILE);
        let eval: Evaluation = std::fs::read_to_string(&path)
            .map_err(|e| e.to_string())
            .and_then(|t| serde_json::from_str(&t).map_err(|e| e.to_string()))
            .map_err(|message| ShardError::Evaluation {
                path: path.clone(),
                message,
            })?;
        outcomes.push(Outcome {
            def,
            eval,
            portals: Vec::new(),
            separating: None,
            dir,
        });
    }
    let mut report = Report {
        outcomes,
        failures,
        seconds: 0.0,
        files: Vec::new(),
    };
    // Timings: the shards' experiments, and the slowest shard's wall time.
    let mut experiments = Vec::new();
    let mut wall: f64 = 0.0;
    let mut shard_walls = Vec::new();
    for (_, r) in &records {
        let s = Shard {
            index: r.index,
            count: r.count,
        };
        let p = opts.out.join(s.timings_file());
        let Ok(text) = std::fs::read_to_string(&p) else {
            continue;
        };
        let Ok(v) = serde_json::from_str::<serde_json::Value>(&text) else {
            continue;
        };
        let w = v.get("wall_seconds").and_then(|x| x.as_f64()).unwrap_or(0.0);
        wall = wall.max(w);
        shard_walls.push(serde_json::json!({"shard": s.to_string(), "wall_seconds": w}));
        if let Some(e) = v.get("experiments").and_then(|e| e.as_array()) {
            experiments.extend(e.iter().cloned());
        }
    }
    let doc = serde_json::json!({
        "generator": format!("portalfind {}", env!("CARGO_PKG_VERSION")),
        "wall_seconds": wall,
        "shards": shard_walls,
        "experiments": experiments,
    });
    let tp = opts.out.join(TIMINGS_FILE);
    write_file(&tp, &serde_json::to_string_pretty(&doc).unwrap_or_default())?;
    report.files.push(tp);
    let merged_opts = RunOptions {
        root: opts.root.clone(),
        out: opts.out.clone(),
        write_summary: true,
        command: records[0].1.command.clone(),
        shard: None,
        evaluate: opts.evaluate,
    };
    report
        .files
        .extend(super::report::write_summary(&report, &order, &merged_opts)?);
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn def(name: &str, compare: Option<&str>) -> Result<Definition, ExperimentError> {
        let c = compare.map_or(String::new(), |c| format!(r#","compare_to":{{"experiment":"{c}"}}"#));
        Definition::parse(
            Path::new(&format!("{name}.json")),
            &format!(
                r#"{{"name":"{name}","model":"four_room_optimized","heuristic":"aspect","estimator":"hull","stop":"cells:4"{c}}}"#
            ),
        )
    }

    #[test]
    fn shard_parses_only_i_of_n() {
        assert_eq!("2/4".parse::<Shard>().unwrap(), Shard { index: 2, count: 4 });
        for bad in ["0/4", "5/4", "4", "a/b", "1/0", ""] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        assert_eq!(Shard { index: 3, count: 7 }.record_file(), "shard-3-of-7.json");
    }

    #[test]
    fn assignment_balances_cost_and_keeps_compared_experiments_together() {
        let defs = vec![
            def("a", None),
            def("b", Some("d")),
            def("c", None),
            def("d", None),
            Err(ExperimentError::Recorded {
                file: "x.json".into(),
                message: "x".into(),
            }),
            def("e", Some("b")),
        ];
        let costs = [100, 10, 50, 10, 0, 10];
        let s = assign(&defs, &costs, 2);
        // {b, d, e} cost 30 stays together; a (100) alone, c (50) then joins the lighter.
        assert_eq!(s[1], s[3]);
        assert_eq!(s[1], s[5]);
        assert_eq!(s[0], 1);
        assert_eq!(s[2], 2);
        assert_eq!(s[1], 2);
        assert_eq!(s[4], 1, "unreadable definitions go to shard 1");
        // One shard: everything in it; the rule is a function of its inputs.
        assert!(assign(&defs, &costs, 1).iter().all(|&k| k == 1));
        assert_eq!(assign(&defs, &costs, 2), s);
        // More shards than groups: every group on its own shard, the rest empty.
        let s4 = assign(&defs, &costs, 4);
        let mut used: Vec<usize> = s4.clone();
        used.sort_unstable();
        used.dedup();
        assert_eq!(used.len(), 3, "{s4:?}");
    }

    #[test]
    fn fnv_is_the_reference_function() {
        assert_eq!(fnv1a(b""), "cbf29ce484222325");
        assert_eq!(fnv1a(b"a"), "af63dc4c8601ec8c");
    }
}
