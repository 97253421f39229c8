//! Sharded sweeps (`portalfind experiment DIR --shard I/N`, then `--merge`): on a small
//! experiments directory (thesis models generated in memory; a rotation check that ties two
//! experiments together, a BSP run, an evaluated run, a run that fails and a definition that
//! cannot be read), three shards run in a shuffled order and merged give the same
//! `summary.csv`, `README.md`, `summary_visibility.csv` and per-experiment files, byte for
//! byte, as one unsharded run (timing files aside); the merge refuses a missing shard and
//! changed definitions.

use portalfind::experiment::{self, RunOptions, Shard};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("portalfind-shards-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const DEFS: &[(&str, &str)] = &[
    (
        "a_opt.json",
        r#"{"name": "a_opt", "model": "four_room_optimized", "heuristic": "refined", "estimator": "hull", "stop": "cells:4"}"#,
    ),
    (
        "b_opt_aspect.json",
        r#"{"name": "b_opt_aspect", "model": "four_room_optimized", "heuristic": "aspect", "estimator": "bbox", "stop": "cells:6", "evaluate": true}"#,
    ),
    (
        "c_rot.json",
        r#"{"name": "c_rot", "model": "four_room_optimized", "transforms": [{"rotate_deg": [7, 8, 9]}], "heuristic": "refined", "estimator": "hull", "stop": "cells:4",
            "compare_to": {"experiment": "a_opt", "transform_inverse_of": [{"rotate_deg": [7, 8, 9]}]}}"#,
    ),
    (
        "d_bsp.json",
        r#"{"name": "d_bsp", "model": "four_room_optimized", "subdivision": "bsp", "heuristic": "refined", "estimator": "hull", "stop": "cells:4"}"#,
    ),
    (
        "e_missing.json",
        r#"{"name": "e_missing", "model": "models/no_such_model.obj", "heuristic": "aspect", "estimator": "hull", "stop": "cells:4"}"#,
    ),
    (
        "f_bad.json",
        r#"{"name": "f_bad", "model": "four_room_optimized", "heuristic": "aspect", "estimator": "hull", "stop": "cells:4", "spin": 1}"#,
    ),
    (
        "g_tess.json",
        r#"{"name": "g_tess", "model": "four_room_tessellated", "heuristic": "volume", "estimator": "hull", "stop": "cells:4"}"#,
    ),
];

/// A repository-like directory: `experiments/` with the definitions.
fn repo(name: &str) -> (PathBuf, Vec<PathBuf>) {
    let root = tmp_dir(name);
    let dir = root.join("experiments");
    std::fs::create_dir_all(&dir).unwrap();
    for (f, text) in DEFS {
        std::fs::write(dir.join(f), text).unwrap();
    }
    let files = experiment::definition_files(&dir).unwrap();
    (root, files)
}

fn opts(root: &Path, out: &Path, shard: Option<Shard>) -> RunOptions {
    RunOptions {
        root: root.to_path_buf(),
        out: out.to_path_buf(),
        write_summary: shard.is_none(),
        command: "portalfind experiment experiments/".into(),
        shard,
        evaluate: None,
    }
}

/// Every file under `dir` (relative path → bytes), without the timing files and the shard
/// records.
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(base: &Path, d: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(base, &p, out);
                continue;
            }
            let rel = p.strip_prefix(base).unwrap().to_string_lossy().into_owned();
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            if name.starts_with("timings") || name.starts_with("shard-") {
                continue;
            }
            out.insert(rel, std::fs::read(&p).unwrap());
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

#[test]
fn merged_shards_equal_an_unsharded_run() {
    let (root, defs) = repo("roundtrip");
    let whole = root.join("whole");
    let sharded = root.join("sharded");
    let r = experiment::run_all(
        experiment::read_definitions(&defs),
        &opts(&root, &whole, None),
        &mut |_| {},
    );
    assert_eq!(
        r.outcomes.len(),
        5,
        "{:?}",
        r.failures.iter().map(|f| f.to_string()).collect::<Vec<_>>()
    );
    assert_eq!(r.failures.len(), 2);
    // The evaluated experiment has its visibility; the rotation check ran.
    let b = r.outcomes.iter().find(|o| o.def.name == "b_opt_aspect").unwrap();
    let v = b.eval.visibility.as_ref().expect("evaluate: true");
    assert_eq!(v.cells, 6);
    assert_eq!(v.false_invisible, 0);
    assert!(v.rays > 0);
    let c = r.outcomes.iter().find(|o| o.def.name == "c_rot").unwrap();
    assert_eq!(c.eval.rotation_checks.len(), 1);
    assert!(
        r.outcomes
            .iter()
            .filter(|o| o.def.name != "b_opt_aspect")
            .all(|o| o.eval.visibility.is_none())
    );

    // Three shards, in a shuffled order, into one directory.
    let mut finished: Vec<(usize, String)> = Vec::new();
    let mut failed = 0;
    for index in [3, 1, 2] {
        let sh = Shard { index, count: 3 };
        let r = experiment::run_all(
            experiment::read_definitions(&defs),
            &opts(&root, &sharded, Some(sh)),
            &mut |_| {},
        );
        assert!(sharded.join(sh.record_file()).is_file());
        assert!(sharded.join(sh.timings_file()).is_file());
        assert!(!sharded.join("summary.csv").exists(), "a shard writes no summary");
        finished.extend(r.outcomes.iter().map(|o| (index, o.def.name.clone())));
        failed += r.failures.len();
    }
    // Every experiment ran exactly once; compared experiments ran in the same shard.
    let mut names: Vec<&str> = finished.iter().map(|(_, n)| n.as_str()).collect();
    names.sort_unstable();
    assert_eq!(names, ["a_opt", "b_opt_aspect", "c_rot", "d_bsp", "g_tess"]);
    assert_eq!(failed, 2);
    let shard_of = |n: &str| finished.iter().find(|(_, m)| m == n).unwrap().0;
    assert_eq!(shard_of("a_opt"), shard_of("c_rot"));
    let used: std::collections::BTreeSet<usize> = finished.iter().map(|(k, _)| *k).collect();
    assert!(used.len() >= 2, "the work is spread: {finished:?}");

    let m = experiment::merge(experiment::read_definitions(&defs), &opts(&root, &sharded, None)).unwrap();
    assert_eq!(m.outcomes.len(), 5);
    assert_eq!(m.failures.len(), 2);
    let (a, b) = (files(&whole), files(&sharded));
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "the same files"
    );
    assert!(a.contains_key("summary.csv") && a.contains_key("README.md"));
    assert!(a.contains_key("summary_visibility.csv"));
    assert!(a.contains_key("b_opt_aspect/visibility.json"));
    for (k, v) in &a {
        assert!(
            b[k] == *v,
            "{k} differs:\n--- unsharded\n{}\n--- merged\n{}",
            String::from_utf8_lossy(v),
            String::from_utf8_lossy(&b[k])
        );
    }
    // The failures are in the summary, in definition order.
    let csv = String::from_utf8(a["summary.csv"].clone()).unwrap();
    let status: Vec<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap_or("").trim_start_matches('"'))
        .collect();
    assert!(status[4].starts_with("failed:"), "{status:?}");
    assert!(status[5].starts_with("failed:"), "{status:?}");
    assert!(sharded.join("timings.json").is_file());
}

#[test]
fn merge_refuses_missing_shards_and_changed_definitions() {
    let (root, defs) = repo("refuse");
    let out = root.join("out");
    let err = experiment::merge(experiment::read_definitions(&defs), &opts(&root, &out, None));
    assert!(err.is_err(), "no shards yet");
    // Only the first definition file and an unreadable one: quick shards.
    let keep: Vec<PathBuf> = defs
        .iter()
        .filter(|p| p.ends_with("a_opt.json") || p.ends_with("f_bad.json"))
        .cloned()
        .collect();
    for index in 1..=2 {
        let sh = Shard { index, count: 2 };
        experiment::run_all(
            experiment::read_definitions(&keep),
            &opts(&root, &out, Some(sh)),
            &mut |_| {},
        );
    }
    experiment::merge(experiment::read_definitions(&keep), &opts(&root, &out, None)).unwrap();
    // A changed definition.
    let a = keep.iter().find(|p| p.ends_with("a_opt.json")).unwrap();
    let text = std::fs::read_to_string(a).unwrap();
    std::fs::write(a, text.replace("cells:4", "cells:5")).unwrap();
    let e = experiment::merge(experiment::read_definitions(&keep), &opts(&root, &out, None))
        .err()
        .expect("changed definition");
    assert!(e.to_string().contains("definitions differ"), "{e}");
    std::fs::write(a, text).unwrap();
    // A missing shard.
    std::fs::remove_file(out.join(Shard { index: 2, count: 2 }.record_file())).unwrap();
    let e = experiment::merge(experiment::read_definitions(&keep), &opts(&root, &out, None))
        .err()
        .expect("missing shard");
    assert!(e.to_string().contains("shard 2/2"), "{e}");
    // Records of two shard counts.
    experiment::run_all(
        experiment::read_definitions(&keep),
        &opts(&root, &out, Some(Shard { index: 1, count: 1 })),
        &mut |_| {},
    );
    let e = experiment::merge(experiment::read_definitions(&keep), &opts(&root, &out, None))
        .err()
        .expect("mixed counts");
    assert!(e.to_string().contains("different shard counts"), "{e}");
}

#[test]
fn the_command_line_refuses_a_bad_shard() {
    let (root, _) = repo("cli");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_portalfind"))
        .args(["experiment", "experiments", "--shard", "4/3", "--out", "out"])
        .current_dir(&root)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("bad shard"));
    assert!(!root.join("out").exists(), "nothing ran");
}
