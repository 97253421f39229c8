//! The 3D viewer (`run --export html` → `viewer.html`) on the thesis's four-room model: the
//! page is self-contained (three.js inlined, nothing loaded from elsewhere), and its data
//! replays to the run: the initial cells are the complex's active cells, replaying the
//! first `stop` steps gives result.json's cells, each portal's recorded removal step is
//! when its two cells join. The browser half is `scripts/check-viewer.sh` (headless Chromium).

use portalfind::decimate::{Decimation, Estimator, HeuristicKind, Settings as DecSettings, StopRule};
use portalfind::output::{self, Notes, SetOptions, VIEWER_FILE};
use portalfind::pipeline::{self, Settings};
use serde_json::Value;
use std::collections::HashMap;

fn b64(s: &str) -> Vec<u8> {
    let val = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    };
    let mut out = Vec::new();
    for chunk in s.as_bytes().chunks(4) {
        let pad = chunk.iter().filter(|&&c| c == b'=').count();
        let mut n = 0u32;
        for &c in chunk {
            n = n << 6 | if c == b'=' { 0 } else { val(c) as u32 };
        }
        let bytes = [(n >> 16) as u8, (n >> 8) as u8, n as u8];
        out.extend_from_slice(&bytes[..3 - pad]);
    }
    out
}
fn u32s(v: &Value) -> Vec<u32> {
    b64(v.as_str().unwrap())
        .chunks(4)
        .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}
fn i32s(v: &Value) -> Vec<i32> {
    b64(v.as_str().unwrap())
        .chunks(4)
        .map(|c| i32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}
fn f64s(v: &Value) -> Vec<f64> {
    b64(v.as_str().unwrap())
        .chunks(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

fn find(p: &mut [usize], mut i: usize) -> usize {
    while p[i] != i {
        p[i] = p[p[i]];
        i = p[i];
    }
    i
}

#[test]
fn viewer_is_self_contained_and_its_data_replays_to_the_run() {
    let dir = std::env::temp_dir().join(format!("portalfind-viewer-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let tm = portalfind::generate::thesis::by_name("four_room_optimized").unwrap();
    portalfind::generate::thesis::write(&tm, &dir).unwrap();
    let mut s = Settings::default();
    s.decimation.heuristic = HeuristicKind::Refined;
    s.decimation.estimator = Estimator::Hull;
    s.decimation.stop = StopRule::Cells(4);
    let (model, run) = pipeline::run(&dir.join("four_room_optimized.obj"), &s, &mut |_| {}).unwrap();
    let full = Decimation::run(
        &run.cx,
        &DecSettings {
            stop: StopRule::None,
            ..run.dec.settings
        },
    );
    let out = dir.join("out");
    let export = vec!["html".to_string()];
    let written = output::write_run(
        &out,
        &model,
        &run.doc,
        &run.dec,
        &[],
        &SetOptions {
            cx: Some(&run.cx),
            export: &export,
            notes: Notes {
                full_steps: Some(&full.steps),
                ..Default::default()
            },
            ..Default::default()
        },
    )
    .unwrap();
    assert!(written.files.iter().any(|f| f.ends_with(VIEWER_FILE)));
    let html = std::fs::read_to_string(out.join(VIEWER_FILE)).unwrap();

    // Self-contained: three.js inline, no element loads anything.
    assert!(html.starts_with("<!doctype html>"));
    assert!(html.contains("globalThis.THREE={"));
    // The placeholders are filled (three.js itself mentions `__THREE__`, its devtools hook).
    assert!(!html.contains(">__THREE__<") && !html.contains(">__DATA__<") && !html.contains("__TITLE__"));
    assert!(html.contains("<title>four_room_optimized: portalfind viewer</title>"));
    let lower = html.to_ascii_lowercase();
    assert!(!lower.contains("<script src") && !lower.contains("<link") && !lower.contains("<iframe"));
    assert_eq!(lower.matches("<script").count(), 3);
    assert_eq!(lower.matches("</script>").count(), 3);
    assert!(html.len() < 2_000_000, "{} bytes", html.len());

    // The data block.
    let open = r#"<script type="application/json" id="data">"#;
    let start = html.find(open).unwrap() + open.len();
    let end = start + html[start..].find("</script>").unwrap();
    let d: Value = serde_json::from_str(&html[start..end]).unwrap();
    assert_eq!(d["format"], "portalfind-viewer");
    assert_eq!(d["model"], "four_room_optimized");
    assert_eq!(d["settings"]["heuristic"], "refined");
    let n = d["cells"]["n"].as_u64().unwrap() as usize;
    assert_eq!(n, run.dec.stats.initial_cells);
    let ids = u32s(&d["cells"]["ids"]);
    let active: Vec<u32> = run.cx.active_cells().map(|(id, _)| id.0).collect();
    assert_eq!(ids, active);
    let volumes = f64s(&d["cells"]["volume"]);
    let dense: HashMap<u32, usize> = ids.iter().enumerate().map(|(i, &id)| (id, i)).collect();

    // Steps: the full run, whose first `stop` are the run's.
    let stop = d["stop"].as_u64().unwrap() as usize;
    assert_eq!(stop, run.dec.steps.len());
    assert_eq!(d["steps"]["n"].as_u64().unwrap() as usize, full.steps.len());
    assert!(full.steps.len() > stop, "the full run goes past the stop");
    let sc = u32s(&d["steps"]["cells"]);
    let weights = f64s(&d["steps"]["weight"]);
    let remaining = u32s(&d["steps"]["remaining"]);
    for (k, st) in full.steps.iter().enumerate() {
        assert_eq!([ids[sc[2 * k] as usize], ids[sc[2 * k + 1] as usize]], [st.a.0, st.b.0]);
        assert_eq!(weights[k], st.weight);
        assert_eq!(remaining[k] as usize, st.cells_remaining);
    }
    // Replaying the first `stop` steps (b joins a) gives result.json's cells and volumes.
    let mut parent: Vec<usize> = (0..n).collect();
    for k in 0..stop {
        let (a, b) = (
            find(&mut parent, sc[2 * k] as usize),
            find(&mut parent, sc[2 * k + 1] as usize),
        );
        parent[a.max(b)] = a.min(b);
    }
    let mut vol = vec![0.0; n];
    for (i, v) in volumes.iter().enumerate() {
        let r = find(&mut parent, i);
        vol[r] += v;
    }
    let roots: Vec<usize> = (0..n).filter(|&i| find(&mut parent, i) == i).collect();
    assert_eq!(roots.len(), run.doc.cells.len());
    for c in &run.doc.cells {
        let r = dense[&c.id];
        assert_eq!(find(&mut parent, r), r, "cell {} is a root", c.id);
        for p in &c.pieces {
            assert_eq!(find(&mut parent, dense[&p.source_cell]), r);
        }
        assert!((vol[r] - c.volume).abs() <= 1e-9 * c.volume, "cell {}", c.id);
    }

    // Patches: each side an initial cell or -1; every initial cell bounded by ≥ 4 of them.
    let counts = b64(d["patches"]["counts"].as_str().unwrap());
    let sides = i32s(&d["patches"]["sides"]);
    assert_eq!(sides.len(), 2 * counts.len());
    let mut faces = vec![0usize; n];
    for &sd in &sides {
        assert!(sd >= -1 && sd < n as i32);
        if sd >= 0 {
            faces[sd as usize] += 1;
        }
    }
    assert!(faces.iter().all(|&f| f >= 4), "{faces:?}");
    let idx = u32s(&d["patches"]["idx"]);
    assert_eq!(idx.len(), counts.iter().map(|&c| c as usize).sum::<usize>());
    let nverts = b64(d["patches"]["verts"].as_str().unwrap()).len() / 12;
    assert!(idx.iter().all(|&i| (i as usize) < nverts));

    // Portals: removed exactly at the step where their two cells join (0: never).
    let psides = u32s(&d["portals"]["sides"]);
    let removed = u32s(&d["portals"]["removed"]);
    let area: f64 = f64s(&d["portals"]["area"]).iter().sum();
    let run_area: f64 = run
        .cx
        .portals
        .iter()
        .flat_map(|p| p.pieces.iter())
        .map(|q| q.area())
        .sum();
    assert!((area - run_area).abs() <= 1e-9 * run_area);
    assert_eq!(removed.len() * 2, psides.len());
    let mut parent: Vec<usize> = (0..n).collect();
    let mut joined = vec![0u32; removed.len()];
    for k in 0..full.steps.len() {
        let (a, b) = (
            find(&mut parent, sc[2 * k] as usize),
            find(&mut parent, sc[2 * k + 1] as usize),
        );
        parent[a.max(b)] = a.min(b);
        for (j, w) in psides.chunks(2).enumerate() {
            if joined[j] == 0 && find(&mut parent, w[0] as usize) == find(&mut parent, w[1] as usize) {
                joined[j] = (k + 1) as u32;
            }
        }
    }
    assert_eq!(removed, joined);
    assert!(
        removed.iter().any(|&r| r as usize > stop),
        "some portals outlive the stop"
    );

    // Walls: the model's polygons, fanned in the page.
    let wc = b64(d["walls"]["counts"].as_str().unwrap());
    let tris: usize = wc.iter().map(|&c| c as usize - 2).sum();
    assert_eq!(tris, model.triangle_count());
    std::fs::remove_dir_all(&dir).unwrap();
}
