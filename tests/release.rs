//! `CellComplex::release_inactive` (the pipeline calls it before the decimation): it frees
//! the geometry of cells that are not active and of patches no active cell borders, and
//! nothing the decimation or the outputs read changes — the same collapses (stopped run and
//! run to the end) and the same output files, byte for byte, every opt-in export included.

use portalfind::complex::CellComplex;
use portalfind::decimate::{Decimation, Estimator, HeuristicKind, QueueMode, Settings, StopRule};
use portalfind::generate::four_rooms::four_rooms;
use portalfind::generate::scenes::{self, Soup};
use portalfind::model::{Model, from_soup};
use portalfind::output;
use serde_json::Value;
use std::path::{Path, PathBuf};

fn model(name: &str, s: Soup) -> Model {
    from_soup(name, s.vertices, s.polygons).expect("model")
}

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("portalfind-release-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Every file of `dir` by name, with its bytes.
fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

/// A JSON document without its timing members (keys naming seconds or timings).
fn untimed(bytes: &[u8]) -> Value {
    fn strip(v: Value) -> Value {
        match v {
            Value::Object(m) => Value::Object(
                m.into_iter()
                    .filter(|(k, _)| !k.contains("seconds") && !k.contains("timings"))
                    .map(|(k, v)| (k, strip(v)))
                    .collect(),
            ),
            Value::Array(a) => Value::Array(a.into_iter().map(strip).collect()),
            v => v,
        }
    }
    strip(serde_json::from_slice(bytes).expect("JSON"))
}

/// A manifest's file entries other than result.json's.
fn manifest_without_result(bytes: &[u8]) -> Vec<Value> {
    let v: Value = serde_json::from_slice(bytes).expect("JSON");
    v["files"]
        .as_array()
        .expect("files")
        .iter()
        .filter(|f| f["name"] != "result.json")
        .cloned()
        .collect()
}

/// Decimates `cx` and writes every output (opt-in exports included) into `dir`.
fn run_and_write(m: &Model, cx: &CellComplex, settings: &Settings, dir: &Path) -> Decimation {
    let (dec, full) = Decimation::run_with_curve(cx, settings, &mut |_, _| {});
    let doc = output::result_doc(m, Path::new("model.obj"), cx, &dec, &[]).expect("document");
    let export: Vec<String> = output::opt_in_formats().iter().map(|s| s.to_string()).collect();
    output::write_outputs_exporting(dir, m, &doc, &dec, &[], Some(cx), &export).expect("outputs");
    if let Some(full) = full {
        assert!(full.len() >= dec.steps.len());
    }
    dec
}

#[test]
fn released_complex_decimates_and_writes_the_same() {
    let (grid, _) = scenes::room_grid(2, 2, 8);
    let scenes = [("four_rooms", four_rooms()), ("grid", grid)];
    let settings = [
        Settings {
            heuristic: HeuristicKind::Aperture,
            estimator: Estimator::Hull,
            stop: HeuristicKind::Aperture.default_stop(),
            queue: QueueMode::Auto,
        },
        Settings {
            heuristic: HeuristicKind::Refined,
            estimator: Estimator::Union,
            stop: StopRule::Cells(4),
            queue: QueueMode::Auto,
        },
    ];
    for (name, soup) in scenes {
        let m = model(name, soup);
        let full = portalfind::pipeline::complex_of(&m).expect("complex");
        let mut released = full.clone();
        let (cells, patches) = released.release_inactive();
        // The scenes have an outside and wall interiors: there is something to free.
        assert!(
            cells > 0 && patches > 0,
            "{name}: released {cells} cells, {patches} patches"
        );
        assert_eq!(released.cells.len(), full.cells.len());
        for (id, c) in full.active_cells() {
            assert_eq!(released.cells[id.idx()].poly(), c.poly(), "{name}: active cell {id:?}");
        }
        assert!(
            released
                .cells
                .iter()
                .filter(|c| !c.active())
                .all(|c| c.poly().faces.is_empty())
        );
        // The exact estimator only on the small scene (it is slow on the grid).
        let n = if name == "grid" { 1 } else { settings.len() };
        for (k, s) in settings[..n].iter().enumerate() {
            let (a, b) = (
                tmp_dir(&format!("{name}-{k}-full")),
                tmp_dir(&format!("{name}-{k}-rel")),
            );
            let da = run_and_write(&m, &full, s, &a);
            let db = run_and_write(&m, &released, s, &b);
            assert_eq!(da.steps, db.steps, "{name}, settings {k}: collapses");
            let (fa, fb) = (files(&a), files(&b));
            assert!(fa.len() >= 5, "{name}: {} files", fa.len());
            assert_eq!(
                fa.iter().map(|f| &f.0).collect::<Vec<_>>(),
                fb.iter().map(|f| &f.0).collect::<Vec<_>>()
            );
            for ((n, x), (_, y)) in fa.iter().zip(&fb) {
                // The decimation's own seconds differ between the two runs (result.json,
                // and its size and hash in the manifest); everything else is bytes.
                let same = match n.as_str() {
                    "result.json" => untimed(x) == untimed(y),
                    "manifest.json" => manifest_without_result(x) == manifest_without_result(y),
                    _ => x == y,
                };
                assert!(same, "{name}, settings {k}: {n} differs");
            }
            let _ = std::fs::remove_dir_all(&a);
            let _ = std::fs::remove_dir_all(&b);
        }
        // Releasing twice frees nothing more.
        assert_eq!(released.release_inactive(), (0, 0));
    }
}
