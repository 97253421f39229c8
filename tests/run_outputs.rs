//! `portalfind run` outputs: result.json against the documented schema, the CSV, PNG and
//! SVG files, atomic writing, reading back and `locate` — through the library and through
//! the binary.

use portalfind::complex::CellComplex;
use portalfind::decimate::{Decimation, Estimator, HeuristicKind, QueueMode, Settings, StopRule};
use portalfind::delaunay::Tetrahedralization;
use portalfind::generate::scenes::{self, Soup};
use portalfind::model::{Model, from_soup};
use portalfind::output::{self, Locator};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("portalfind-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn two_rooms_run(stop: StopRule) -> (Model, CellComplex, Decimation) {
    let s = scenes::two_rooms();
    let m = from_soup("two_rooms", s.vertices, s.polygons).unwrap();
    let t = Tetrahedralization::build(&m.vertices).unwrap();
    let cx = CellComplex::build(&m, &t);
    let d = Decimation::run(
        &cx,
        &Settings {
            heuristic: HeuristicKind::Aspect,
            estimator: Estimator::Hull,
            stop,
            queue: QueueMode::Auto,
        },
    );
    (m, cx, d)
}

/// Sample points inside room 0 (`x ∈ [0,4]`) or room 1 (`x ∈ [5,9]`) of `two_rooms`.
fn samples(room: usize) -> Vec<[f64; 3]> {
    let x0 = if room == 0 { 0.5 } else { 5.5 };
    let mut v = Vec::new();
    for i in 0..3 {
        for j in 0..3 {
            v.push([x0 + 1.5 * i as f64, 0.5 + 1.5 * j as f64, 1.0 + 0.5 * i as f64]);
        }
    }
    v
}

fn is_point(v: &Value) -> bool {
    v.as_array()
        .is_some_and(|a| a.len() == 3 && a.iter().all(|x| x.as_f64().is_some_and(f64::is_finite)))
}

fn uint(v: &Value, key: &str) -> u64 {
    v[key]
        .as_u64()
        .unwrap_or_else(|| panic!("{key} is not an unsigned integer: {}", v[key]))
}

fn num(v: &Value, key: &str) -> f64 {
    let x = v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} is not a number: {}", v[key]));
    assert!(x.is_finite(), "{key}");
    x
}

fn string<'a>(v: &'a Value, key: &str) -> &'a str {
    v[key]
        .as_str()
        .unwrap_or_else(|| panic!("{key} is not a string: {}", v[key]))
}

/// Checks every key and type that docs/result-schema.md promises.
fn check_schema(doc: &Value) {
    let top = [
        "schema",
        "schema_version",
        "generator",
        "model",
        "settings",
        "stages",
        "complex",
        "decimation",
        "stop_reason",
        "cells",
        "portals",
    ];
    for k in top {
        assert!(doc.get(k).is_some(), "missing top-level key {k}");
    }
    assert_eq!(string(doc, "schema"), "portalfind-result");
    assert_eq!(uint(doc, "schema_version"), 1);
    assert!(string(doc, "generator").starts_with("portalfind "));

    let m = &doc["model"];
    string(m, "name");
    string(m, "path");
    for k in ["vertices", "polygons", "triangles"] {
        assert!(uint(m, k) > 0);
    }
    let bbox = m["bbox"].as_array().unwrap();
    assert!(bbox.len() == 2 && bbox.iter().all(is_point));
    for k in ["scale", "weld", "area", "plane", "coplanar"] {
        num(&m["tolerances"], k);
    }
    assert!(m["report"].is_object() && m["report"].get("input_vertices").is_some());

    let s = &doc["settings"];
    assert!(["aspect", "refined", "volume"].contains(&string(s, "heuristic")));
    assert!(["bbox", "hull", "union"].contains(&string(s, "estimator")));
    assert!(string(s, "stop").parse::<StopRule>().is_ok());
    assert!(["auto", "exact"].contains(&string(s, "queue")));

    let stages = doc["stages"].as_array().unwrap();
    for st in stages {
        string(st, "stage");
        assert!(num(st, "seconds") >= 0.0);
    }
    assert!(doc["complex"].is_object() && doc["complex"].get("active_cells").is_some());

    let d = &doc["decimation"];
    for k in [
        "initial_cells",
        "initial_pairs",
        "regions",
        "steps",
        "weights_computed",
        "reweighs_skipped",
        "max_shape_vertices",
    ] {
        uint(d, k);
    }
    for k in ["heap_pushes", "heap_updates", "parked", "parked_max"] {
        uint(&d["queue"], k);
    }
    num(d, "init_seconds");
    num(d, "collapse_seconds");

    let r = &doc["stop_reason"];
    match string(r, "kind") {
        "threshold" => {
            num(r, "threshold");
            num(r, "next_weight");
        }
        "cells" => {
            uint(r, "target");
        }
        "exhausted" => {}
        k => panic!("unknown stop kind {k}"),
    }

    let cells = doc["cells"].as_array().unwrap();
    assert_eq!(
        cells.len() as u64,
        uint(d, "initial_cells") - uint(d, "steps"),
        "cells left = initial − collapses"
    );
    let mut last_id = None;
    for c in cells {
        let id = uint(c, "id");
        assert!(last_id < Some(id), "cells sorted by id");
        last_id = Some(id);
        assert!(num(c, "volume") > 0.0);
        let pieces = c["pieces"].as_array().unwrap();
        assert!(!pieces.is_empty());
        assert_eq!(uint(&pieces[0], "source_cell"), id, "id is the smallest piece id");
        for p in pieces {
            uint(p, "source_cell");
            assert!(num(p, "volume") > 0.0);
            let planes = p["planes"].as_array().unwrap();
            assert!(planes.len() >= 4);
            for q in planes {
                let q = q.as_array().unwrap();
                assert_eq!(q.len(), 4);
                let n: Vec<f64> = q.iter().map(|x| x.as_f64().unwrap()).collect();
                assert!(
                    (n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1.0).abs() < 1e-9,
                    "unit normal"
                );
            }
            let verts = p["vertices"].as_array().unwrap();
            assert!(verts.len() >= 4 && verts.iter().all(is_point));
        }
    }
    for p in doc["portals"].as_array().unwrap() {
        let cs = p["cells"].as_array().unwrap();
        assert_eq!(cs.len(), 2);
        assert!(cs[0].as_u64().unwrap() < cs[1].as_u64().unwrap());
        assert!(num(p, "area") > 0.0);
        assert!(is_point(&p["mean_normal"]));
        let polys = p["polygons"].as_array().unwrap();
        assert!(!polys.is_empty());
        for poly in polys {
            let poly = poly.as_array().unwrap();
            assert!(poly.len() >= 3 && poly.iter().all(is_point));
        }
    }
}

fn no_temp_files(dir: &Path) -> bool {
    std::fs::read_dir(dir)
        .unwrap()
        .all(|e| !e.unwrap().file_name().to_string_lossy().starts_with('.'))
}

#[test]
fn library_writes_all_outputs_matching_the_schema() {
    let (m, cx, d) = two_rooms_run(StopRule::Cells(2));
    let stages = vec![("test stage".to_string(), 0.5)];
    let doc = output::result_doc(&m, Path::new("two_rooms.obj"), &cx, &d, &stages).unwrap();
    let dir = tmp_dir("lib");
    let files = output::write_outputs(&dir, &m, &doc, &d).unwrap();
    assert_eq!(files.len(), 4);
    assert!(no_temp_files(&dir));

    let json: Value = serde_json::from_str(&std::fs::read_to_string(dir.join("result.json")).unwrap()).unwrap();
    check_schema(&json);
    assert_eq!(json["cells"].as_array().unwrap().len(), 2);
    assert_eq!(json["stop_reason"]["kind"], "cells");
    assert_eq!(json["portals"].as_array().unwrap().len(), 1);

    let csv = std::fs::read_to_string(dir.join("weight_curve.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(
        rows[0],
        "step,weight,cells_remaining,cell_a,cell_b,portal_area,projected_a,projected_b"
    );
    assert_eq!(rows.len(), d.steps.len() + 1);
    let last: Vec<&str> = rows[rows.len() - 1].split(',').collect();
    assert_eq!(last[0], d.steps.len().to_string());
    assert_eq!(last[2], "2");
    assert_eq!(last[1].parse::<f64>().unwrap(), d.steps.last().unwrap().weight);

    let png = std::fs::read(dir.join("weight_curve.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert!(png.len() > 1000);
    let svg = std::fs::read_to_string(dir.join("cells.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert_eq!(svg.matches("<title>cells").count(), 1, "one portal drawn");
    assert!(svg.contains("stroke=\"#888\""), "walls drawn");

    // Read back, and locate points.
    let back = output::read_result(&dir).unwrap();
    assert_eq!(back.cells.len(), 2);
    let loc = Locator::new(&back);
    let ids: Vec<Vec<Option<portalfind::CellId>>> = (0..2)
        .map(|r| samples(r).iter().map(|p| loc.locate(p)).collect())
        .collect();
    let (a, b) = (ids[0][0].expect("room 0 located"), ids[1][0].expect("room 1 located"));
    assert_ne!(a, b);
    assert!(ids[0].iter().all(|&i| i == Some(a)) && ids[1].iter().all(|&i| i == Some(b)));
    // Outside the model, and inside the wall between the rooms (beside the door).
    assert_eq!(loc.locate(&[20.0, 20.0, 20.0]), None);
    assert_eq!(loc.locate(&[4.5, 0.5, 1.0]), None);
    // In the door corridor: one of the two rooms.
    assert!([Some(a), Some(b)].contains(&loc.locate(&[4.5, 2.0, 1.0])));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn failed_writes_leave_no_partial_files_and_bad_schemas_are_refused() {
    let (m, cx, d) = two_rooms_run(StopRule::Cells(3));
    let doc = output::result_doc(&m, Path::new("x.obj"), &cx, &d, &[]).unwrap();
    let dir = tmp_dir("fail");
    // A directory where the CSV should go: renaming onto it fails.
    std::fs::create_dir_all(dir.join("weight_curve.csv").join("blocker")).unwrap();
    assert!(output::write_outputs(&dir, &m, &doc, &d).is_err());
    assert!(no_temp_files(&dir), "temporary files left behind");
    assert!(!dir.join("weight_curve.png").exists(), "later files not written");
    assert!(!dir.join("result.json").exists(), "a failed run leaves no result.json");
    // Remove the blocker: now the whole set is written; then tamper with the version.
    std::fs::remove_dir_all(dir.join("weight_curve.csv")).unwrap();
    output::write_outputs(&dir, &m, &doc, &d).unwrap();
    let text = std::fs::read_to_string(dir.join("result.json")).unwrap();
    assert!(output::read_result(&dir).is_ok());
    std::fs::write(
        dir.join("result.json"),
        text.replacen("\"schema_version\":1", "\"schema_version\":99", 1),
    )
    .unwrap();
    let err = output::read_result(&dir).unwrap_err().to_string();
    assert!(err.contains("v99"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Snapshots are the replayed states: the one at the final count equals the run's final
/// cells and portals, one at the initial count has every portal pair, and intermediate
/// ones have as many cells as asked; a count the run never passed through is an error
/// naming the range, before anything is written.
#[test]
fn snapshots_replay_intermediate_states_and_refuse_counts_never_reached() {
    let (m, cx, d) = two_rooms_run(StopRule::Cells(2));
    let path = Path::new("two_rooms.obj");
    let doc = output::result_doc(&m, path, &cx, &d, &[]).unwrap();
    let initial = d.stats.initial_cells;
    let middle = d.steps[d.steps.len() / 2].cells_remaining;
    let snaps: Vec<_> = [initial, middle, 2]
        .iter()
        .map(|&n| output::snapshot(&m, path, &cx, &d, n).unwrap())
        .collect();
    let (first, _) = &snaps[0];
    assert_eq!((first.collapses, first.last_weight), (0, None));
    assert_eq!(first.next_weight, Some(d.steps[0].weight));
    assert_eq!(first.portal_pairs, d.stats.initial_pairs);
    let (mid, mid_doc) = &snaps[1];
    assert_eq!(mid_doc.cells.len(), middle);
    assert_eq!(mid.collapses, initial - middle);
    assert_eq!(mid.last_weight, Some(d.steps[mid.collapses - 1].weight));
    let (last, last_doc) = &snaps[2];
    assert_eq!((last.collapses, last.next_weight), (d.steps.len(), None));
    assert_eq!(last_doc.cells.len(), doc.cells.len());
    assert_eq!(last_doc.portals.len(), doc.portals.len());
    for (a, b) in last_doc.portals.iter().zip(&doc.portals) {
        assert_eq!((a.cells, a.area), (b.cells, b.area));
    }
    let err = output::snapshot(&m, path, &cx, &d, 1).unwrap_err().to_string();
    assert!(err.contains(&format!("from {initial} cells down to 2")), "{err}");
    assert!(output::snapshot(&m, path, &cx, &d, initial + 1).is_err());

    let dir = tmp_dir("snap");
    let files = output::write_outputs_with_snapshots(&dir, &m, &doc, &d, &snaps).unwrap();
    assert_eq!(files.len(), 4 + 3);
    for (s, _) in &snaps {
        let svg = std::fs::read_to_string(dir.join(&s.file)).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains(&format!("snapshot at {} cells", s.cells)));
    }
    assert!(no_temp_files(&dir));
    std::fs::remove_dir_all(&dir).unwrap();
}

fn write_obj(s: &Soup, path: &Path) {
    let mut t = String::new();
    for v in &s.vertices {
        t.push_str(&format!("v {} {} {}\n", v[0], v[1], v[2]));
    }
    for p in &s.polygons {
        t.push('f');
        for i in p {
            t.push_str(&format!(" {}", i + 1));
        }
        t.push('\n');
    }
    std::fs::write(path, t).unwrap();
}

#[test]
fn binary_run_and_locate() {
    let dir = tmp_dir("bin");
    let obj = dir.join("two_rooms.obj");
    write_obj(&scenes::two_rooms(), &obj);
    let out = dir.join("out");
    let exe = env!("CARGO_BIN_EXE_portalfind");
    let r = Command::new(exe)
        .args([
            "run",
            obj.to_str().unwrap(),
            "--stop",
            "cells:2",
            "--estimator",
            "union",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let stdout = String::from_utf8_lossy(&r.stdout);
    assert!(stdout.starts_with("stage"), "{stdout}");
    assert!(stdout.contains("decimation: collapses") && stdout.contains("final cells"));
    for f in ["result.json", "weight_curve.csv", "weight_curve.png", "cells.svg"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let json: Value = serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    check_schema(&json);
    assert_eq!(json["settings"]["estimator"], "union");
    assert_eq!(json["settings"]["stop"], "cells:2");
    let stages: Vec<&str> = json["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["stage"].as_str().unwrap())
        .collect();
    assert!(
        stages.len() >= 5 && stages.contains(&"delaunay tetrahedralization"),
        "{stages:?}"
    );
    assert!(stages.contains(&"decimation: collapses"));

    let pts = dir.join("points.csv");
    let mut text = String::from("x,y,z\n");
    for p in samples(0)
        .iter()
        .chain(samples(1).iter())
        .chain([[20.0, 20.0, 20.0]].iter())
    {
        text.push_str(&format!("{},{},{}\n", p[0], p[1], p[2]));
    }
    std::fs::write(&pts, text).unwrap();
    let r = Command::new(exe).arg("locate").arg(&out).arg(&pts).output().unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let ids: Vec<i64> = String::from_utf8_lossy(&r.stdout)
        .lines()
        .map(|l| l.parse().unwrap())
        .collect();
    assert_eq!(ids.len(), 19);
    assert!(ids[..9].iter().all(|&i| i == ids[0]) && ids[0] >= 0);
    assert!(ids[9..18].iter().all(|&i| i == ids[9]) && ids[9] >= 0);
    assert_ne!(ids[0], ids[9]);
    assert_eq!(ids[18], -1);

    // Bad arguments fail cleanly.
    let r = Command::new(exe)
        .args(["run", obj.to_str().unwrap(), "--stop", "cells:x", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!r.status.success());
    let r = Command::new(exe)
        .arg("locate")
        .arg(dir.join("nowhere"))
        .arg(&pts)
        .output()
        .unwrap();
    assert!(!r.status.success());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A run that fails (here: a missing model) removes the output directories it created,
/// parents included, and leaves an existing directory alone.
#[test]
fn failed_run_removes_the_directories_it_created() {
    let base = tmp_dir("failed-run");
    let exe = env!("CARGO_BIN_EXE_portalfind");
    let out = base.join("a").join("b");
    let r = Command::new(exe)
        .args(["run", "no/such/model.obj", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!r.status.success());
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(err.contains("no/such/model.obj"), "{err}");
    assert!(!base.join("a").exists(), "created directories left behind");
    assert!(base.is_dir(), "an existing directory is not removed");
    std::fs::remove_dir_all(&base).unwrap();
}

/// `locate` input: a non-finite coordinate and an empty file are errors naming the file
/// (and the line).
#[test]
fn point_files_with_non_finite_values_or_no_points_are_errors() {
    let dir = tmp_dir("points");
    let nan = dir.join("nan.csv");
    std::fs::write(&nan, "x,y,z\n1,2,3\n1,NaN,1\n").unwrap();
    let e = format!("{:#}", output::read_points(&nan).unwrap_err());
    assert!(e.contains("nan.csv:3") && e.contains("finite"), "{e}");
    let empty = dir.join("empty.csv");
    std::fs::write(&empty, "x,y,z\n\n# nothing\n").unwrap();
    let e = format!("{:#}", output::read_points(&empty).unwrap_err());
    assert!(e.contains("empty.csv") && e.contains("no points"), "{e}");
    let ok = dir.join("ok.csv");
    std::fs::write(&ok, "x, y, z\r\n1, 2, 3\r\n4,5,6\n").unwrap();
    assert_eq!(
        output::read_points(&ok).unwrap(),
        vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
