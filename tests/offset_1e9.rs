//! A shipped model offset by 1e9 (issue 16, "offsets up to 1e9 where the input's precision
//! allows"): the loader recentres it by an exact translation (once refused as
//! `ModelError::Precision`), the complex validates, `run` finds the unmoved model's final
//! cells and rooms, and every output is in the input's frame: within rounding of the
//! unmoved outputs plus the offset.

use portalfind::decimate::HeuristicKind;
use portalfind::generate::thesis::GroundTruth;
use portalfind::model::load_model;
use portalfind::output::{self, Locator};
use portalfind::pipeline::{self, Settings};
use portalfind::predicates::P3;
use std::path::{Path, PathBuf};

/// The stress suite's offset direction: (o, 0.7 o, -0.4 o).
const OFFSET: P3 = [1e9, 0.7e9, -0.4e9];

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("portalfind-offset-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn add(p: P3, q: P3) -> P3 {
    [p[0] + q[0], p[1] + q[1], p[2] + q[2]]
}

/// `src` with every `v` line moved by `OFFSET`, written with full precision (`{:?}`, the
/// shortest text that reads back as the same double).
fn write_offset(src: &Path, dst: &Path) {
    let text = std::fs::read_to_string(src).unwrap();
    let mut out = String::new();
    for line in text.lines() {
        let t: Vec<&str> = line.split_whitespace().collect();
        if t.first() == Some(&"v") {
            let p: Vec<f64> = t[1..4].iter().map(|x| x.parse().unwrap()).collect();
            let q = add([p[0], p[1], p[2]], OFFSET);
            out.push_str(&format!("v {:?} {:?} {:?}\n", q[0], q[1], q[2]));
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    std::fs::write(dst, out).unwrap();
}

/// `run`'s defaults: aperture at its own stop.
fn settings() -> Settings {
    let mut s = Settings::default();
    s.decimation.heuristic = HeuristicKind::Aperture;
    s.decimation.stop = s.decimation.heuristic.default_stop();
    s
}

/// The `v` lines of an OBJ file.
fn obj_vertices(path: &Path) -> Vec<P3> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

/// Largest distance (max norm) from a point of `a` to the nearest point of `b`.
fn one_sided(a: &[P3], b: &[P3]) -> f64 {
    a.iter()
        .map(|p| {
            b.iter()
                .map(|q| (0..3).map(|k| (p[k] - q[k]).abs()).fold(0.0, f64::max))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

/// Rooms isolated: the final cell holding all of a room's samples and no other room's
/// (`None` when the room is not isolated), locating points given in the input's frame.
fn room_cells(doc: &output::ResultDoc, truth: &GroundTruth, moved: bool) -> Vec<Option<u32>> {
    let loc = Locator::new(doc);
    let o = doc.model.origin.map(|x| -x);
    let cells: Vec<Vec<Option<u32>>> = truth
        .rooms
        .iter()
        .map(|r| {
            r.samples
                .iter()
                .map(|&s| {
                    let s = if moved { add(s, OFFSET) } else { s };
                    loc.locate(&portalfind::model::translate_point(s, o)).map(|c| c.0)
                })
                .collect()
        })
        .collect();
    (0..cells.len())
        .map(|r| {
            let c = cells[r].first().copied().flatten()?;
            let alone = cells[r].iter().all(|&x| x == Some(c))
                && (0..cells.len()).all(|o| o == r || cells[o].iter().all(|&x| x != Some(c)));
            alone.then_some(c)
        })
        .collect()
}

#[test]
fn four_room_optimized_at_offset_1e9_gives_the_same_rooms_in_the_input_frame() {
    let name = "four_room_optimized";
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("models/thesis/{name}.obj"));
    let truth: GroundTruth =
        serde_json::from_str(&std::fs::read_to_string(shipped.with_file_name(format!("{name}.truth.json"))).unwrap())
            .unwrap();
    let dir = tmp_dir(name);
    let moved_path = dir.join(format!("{name}_1e9.obj"));
    write_offset(&shipped, &moved_path);

    // Loading: recentred exactly, recorded, the input's points given back bit for bit.
    let m0 = load_model(&shipped).unwrap();
    assert_eq!(m0.origin, [0.0; 3]);
    assert!(m0.report.translation.is_none());
    let m1 = load_model(&moved_path).unwrap();
    let t = m1.report.translation.expect("recentred");
    assert_eq!(t.by, m1.origin);
    assert!(t.unit > t.plane, "{t:?}");
    assert!(m1.report.to_string().contains("translated by ["));
    assert_eq!(m1.vertices.len(), m0.vertices.len());
    for (a, b) in m0.vertices.iter().zip(&m1.vertices) {
        // The file holds a + OFFSET rounded; the model that value less the origin, exactly.
        assert_eq!(m1.to_user(*b), add(*a, OFFSET));
    }

    // The whole run, and its complex validates.
    let s = settings();
    let (m0, r0) = pipeline::run(&shipped, &s, &mut |_| {}).unwrap();
    let (m1, r1) = pipeline::run(&moved_path, &s, &mut |_| {}).unwrap();
    // (A run frees the inactive cells' geometry: validate a fresh complex.)
    for m in [&m0, &m1] {
        pipeline::complex_of(m).unwrap().validate(m).unwrap();
    }
    assert_eq!(r1.cx.stats.leaks, r0.cx.stats.leaks);
    assert_eq!(r1.cx.stats.active_cells, r0.cx.stats.active_cells);
    assert_eq!(r1.doc.cells.len(), r0.doc.cells.len());
    assert_eq!(r1.doc.portals.len(), r0.doc.portals.len());
    // The same space in total. Cell by cell the volumes differ (55.2 vs 55.44 m³ for the
    // smallest room cell): the file at 1e9 holds the vertices rounded to 1.2e-7 (8e-9 of
    // the diagonal), which breaks the exact cospherical ties of the model's grid-like
    // points, so the Delaunay tetrahedra, and with them the pieces a room's cell gathers at
    // its doorways, differ; the rooms do not (below).
    let total = |r: &pipeline::Run| r.doc.cells.iter().map(|c| c.volume).sum::<f64>();
    // (Up to that rounding of the walls: 2.8e-7 of 241.6.)
    assert!(
        (total(&r0) - total(&r1)).abs() <= 1e-8 * total(&r0),
        "{} {}",
        total(&r0),
        total(&r1)
    );
    // And that rounding is the only difference: the recentred model run from a file near
    // the origin (its vertices, which are the 1e9 file's less the origin exactly) gives
    // the 1e9 run bit for bit, the origin added.
    let local_path = dir.join(format!("{name}_local.obj"));
    let polys: Vec<Vec<u32>> = m1
        .polygons
        .iter()
        .map(|p| p.verts.iter().map(|v| v.0).collect())
        .collect();
    std::fs::write(
        &local_path,
        portalfind::model::write::obj_text("local", &m1.vertices, &polys),
    )
    .unwrap();
    let (ml, rl) = pipeline::run(&local_path, &s, &mut |_| {}).unwrap();
    assert_eq!(ml.origin, [0.0; 3]);
    assert_eq!(rl.doc.cells.len(), r1.doc.cells.len());
    for (a, b) in rl.doc.cells.iter().zip(&r1.doc.cells) {
        assert_eq!((a.id, a.volume), (b.id, b.volume));
        for (p, q) in a.pieces.iter().zip(&b.pieces) {
            assert_eq!(p.vertices, q.vertices);
        }
    }

    // Outputs: written, read back, in the input's frame.
    let all: Vec<String> = ["obj", "prt", "gltf", "html"].iter().map(|s| s.to_string()).collect();
    let (d0, d1) = (dir.join("run0"), dir.join("run1"));
    output::write_outputs_exporting(&d0, &m0, &r0.doc, &r0.dec, &[], Some(&r0.cx), &all).unwrap();
    output::write_outputs_exporting(&d1, &m1, &r1.doc, &r1.dec, &[], Some(&r1.cx), &all).unwrap();
    // Rounding in the input's frame at 1e9: a few units of 1.2e-7.
    let tol = 8.0 * f64::EPSILON * 1e9;
    let moved0: Vec<P3> = obj_vertices(&d0.join("cells.obj"))
        .into_iter()
        .map(|p| add(p, OFFSET))
        .collect();
    let got1 = obj_vertices(&d1.join("cells.obj"));
    assert_eq!(got1.len(), moved0.len());
    let (e01, e10) = (one_sided(&moved0, &got1), one_sided(&got1, &moved0));
    assert!(e01 <= tol && e10 <= tol, "{e01:e} {e10:e}");
    // The cells' coordinates are in the input's frame in result.json, and read back in the
    // model's.
    let text: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d1.join("result.json")).unwrap()).unwrap();
    assert_eq!(text["model"]["origin"], serde_json::json!(m1.origin));
    let bbox_file: Vec<f64> = text["model"]["bbox"][0]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let lo0 = add(m0.bbox().0, OFFSET);
    assert!(
        (0..3).all(|k| (bbox_file[k] - lo0[k]).abs() <= tol),
        "{bbox_file:?} {lo0:?}"
    );
    let back = output::read_result(&d1).unwrap();
    assert!(output::read_result(&d0).unwrap().model.origin == [0.0; 3]);
    assert!((0..3).all(|k| (back.model.bbox[0][k] - r1.doc.model.bbox[0][k]).abs() <= tol));
    // The same rooms, located from the files as `portalfind locate` does (points in the
    // input's frame), and every room isolated.
    let rooms0 = room_cells(&output::read_result(&d0).unwrap(), &truth, false);
    let rooms1 = room_cells(&back, &truth, true);
    assert!(rooms0.iter().all(|c| c.is_some()), "{rooms0:?}");
    assert_eq!(
        rooms1.iter().filter(|c| c.is_some()).count(),
        rooms0.len(),
        "{rooms1:?}"
    );
    // PRT windings in the input's frame too.
    let prt = std::fs::read_to_string(d1.join("cells.prt")).unwrap();
    let first: Vec<f64> = prt
        .split(['(', ')'])
        .nth(1)
        .unwrap()
        .split_whitespace()
        .map(|x| x.parse().unwrap())
        .collect();
    assert!(
        (first[0] - 1e9).abs() < 20.0 && (first[1] - 0.7e9).abs() < 20.0,
        "{first:?}"
    );
    // glTF: f32 positions near zero, the origin in the roots' translation.
    let glb = std::fs::read(d1.join("cells.glb")).unwrap();
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let g: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let o = m1.origin;
    assert_eq!(g["nodes"][0]["translation"], serde_json::json!([o[0], o[2], -o[1]]));
    let g0: serde_json::Value = {
        let glb = std::fs::read(d0.join("cells.glb")).unwrap();
        let n = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
        serde_json::from_slice(&glb[20..20 + n]).unwrap()
    };
    assert!(g0["nodes"][0].get("translation").is_none());
    let _ = std::fs::remove_dir_all(&dir);
}
