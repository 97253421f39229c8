//! The reconstructed thesis models (section 4.3): each loads without dropped polygons, has
//! the counts we document (the thesis's printed beside them), builds a valid cell complex
//! with no leak and one interior region, and every ground-truth sample lies in an active
//! cell.

use std::collections::HashMap;

use portalfind::complex::CellComplex;
use portalfind::delaunay::Tetrahedralization;
use portalfind::generate::thesis::{self as thesis_models, GroundTruth, ThesisModel};
use portalfind::model::{Model, from_soup};

/// Our counts: (name, vertices, triangles); the thesis's: (vertices, triangles).
type Counts = (&'static str, usize, usize, Option<(usize, usize)>);
const COUNTS: [Counts; 6] = [
    ("four_room_optimized", 64, 96, Some((64, 96))),
    ("four_room_tessellated", 186, 372, Some((200, 400))),
    ("four_room_distorted", 64, 96, Some((106, 96))),
    ("caverns", 438, 880, Some((408, 548))),
    ("caverns_rotated", 438, 880, Some((408, 548))),
    ("noisy", 360, 676, None),
];

/// The thesis's complex figures: (tetrahedra, cells split, exterior removed, active).
fn thesis_complex(name: &str) -> &'static str {
    match name {
        "four_room_optimized" => "160 tets, 18 split, 74 exterior, - active",
        "four_room_tessellated" => "523 tets, 0 split, 125 exterior, - active",
        "four_room_distorted" => "299 tets, 112 split, 251 exterior, 160 active",
        "caverns" => "1129 tets, 0 split, 553 exterior, 576 active",
        "caverns_rotated" => "(slightly fewer tets), same cells after removal as caverns",
        _ => "-",
    }
}

fn load(m: &ThesisModel) -> Model {
    let model = from_soup(m.name, m.soup.vertices.clone(), m.soup.polygons.clone()).expect("model");
    let r = &model.report;
    assert_eq!(r.zero_area_polygons_dropped, 0, "{}: {r:?}", m.name);
    assert_eq!(r.duplicate_polygons_dropped, 0, "{}: {r:?}", m.name);
    assert_eq!(r.welded_vertices, 0, "{}: {r:?}", m.name);
    assert_eq!(r.unused_vertices, 0, "{}: {r:?}", m.name);
    model
}

fn check_complex(m: &ThesisModel, model: &Model) -> CellComplex {
    let t = Tetrahedralization::build(&model.vertices).expect("tetra");
    let cx = CellComplex::build(model, &t);
    cx.validate(model)
        .unwrap_or_else(|e| panic!("{}: complex validate: {e}", m.name));
    let s = &cx.stats;
    println!(
        "{}: complex {} tets, {} split, {} exterior removed, {} active cells, {} portal pairs \
         (thesis: {})",
        m.name,
        s.tetrahedra,
        s.cells_split,
        s.exterior_cells_removed,
        s.active_cells,
        s.portal_pairs,
        thesis_complex(m.name)
    );
    assert_eq!(s.leaks, 0, "{}", m.name);
    assert_eq!(s.interior_regions, 1, "{}", m.name);
    for room in &m.truth.rooms {
        for p in &room.samples {
            let inside = cx.active_cells().any(|(_, c)| c.contains(p, &cx.tol));
            assert!(inside, "{}: sample {p:?} of {} in no active cell", m.name, room.name);
        }
    }
    cx
}

/// For closed conforming surfaces: every edge used once in each direction.
fn assert_closed_oriented(m: &ThesisModel) {
    let mut edges: HashMap<(u32, u32), usize> = HashMap::new();
    for p in &m.soup.polygons {
        for i in 0..p.len() {
            *edges.entry((p[i], p[(i + 1) % p.len()])).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &edges {
        assert_eq!(n, 1, "{}: edge {a}->{b} used {n} times", m.name);
        assert_eq!(edges.get(&(b, a)), Some(&1), "{}: edge {a}->{b} has no twin", m.name);
    }
}

fn run(name: &str) -> (ThesisModel, Model, CellComplex) {
    let m = thesis_models::by_name(name).expect("model");
    assert_eq!(m.name, name);
    let model = load(&m);
    let (_, v, t, thesis) = COUNTS.iter().find(|c| c.0 == name).copied().expect("counts");
    println!(
        "{name}: {} vertices, {} triangles (thesis: {})",
        model.vertices.len(),
        model.triangle_count(),
        thesis.map_or("-".into(), |(v, t)| format!("{v} vertices, {t} triangles"))
    );
    assert_eq!((model.vertices.len(), model.triangle_count()), (v, t), "{name}");
    let cx = check_complex(&m, &model);
    (m, model, cx)
}

#[test]
fn four_room_optimized() {
    let (m, _, _) = run("four_room_optimized");
    assert_eq!(m.truth.rooms.len(), 4);
    assert_eq!(m.truth.doorways.len(), 4);
}

#[test]
fn four_room_tessellated() {
    let (m, _, _) = run("four_room_tessellated");
    assert_closed_oriented(&m);
    // A closed torus: V = F / 2.
    assert_eq!(m.soup.vertices.len() * 2, m.soup.polygons.len());
}

#[test]
fn four_room_distorted() {
    run("four_room_distorted");
}

#[test]
fn caverns() {
    let (m, _, _) = run("caverns");
    assert_closed_oriented(&m);
    assert_eq!(m.truth.rooms.len(), 6);
    assert_eq!(m.truth.doorways.len(), 7);
}

#[test]
fn caverns_rotated() {
    let (m, _, _) = run("caverns_rotated");
    assert_closed_oriented(&m);
    let plain = thesis_models::caverns();
    assert_eq!(m.soup.polygons, plain.soup.polygons);
    for (a, b) in m.soup.vertices.iter().zip(&plain.soup.vertices) {
        let r = portalfind::base::rigid::rotate_789(*b);
        assert!((0..3).all(|k| (a[k] - r[k]).abs() < 1e-9));
    }
}

#[test]
fn noisy() {
    run("noisy");
}

#[test]
fn all_names_and_truth_round_trip() {
    let all = thesis_models::all();
    assert_eq!(all.len(), thesis_models::NAMES.len());
    assert!(thesis_models::by_name("nope").is_none());
    for m in &all {
        let json = serde_json::to_string(&m.truth).expect("json");
        let back: GroundTruth = serde_json::from_str(&json).expect("parse");
        assert_eq!(back.rooms.len(), m.truth.rooms.len());
        assert_eq!(back.doorways.len(), m.truth.doorways.len());
        let pts = |t: &GroundTruth| -> Vec<[f64; 3]> {
            let s = t.rooms.iter().flat_map(|r| r.samples.iter().copied());
            s.chain(t.doorways.iter().flat_map(|d| d.polygon.iter().copied()))
                .collect()
        };
        for (a, b) in pts(&back).iter().zip(&pts(&m.truth)) {
            assert!((0..3).all(|k| (a[k] - b[k]).abs() <= 1e-12 * b[k].abs().max(1.0)));
        }
        assert!(!m.description.is_empty());
    }
}

#[test]
fn committed_files_match_generators() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/thesis");
    for m in thesis_models::all() {
        let tmp = std::env::temp_dir().join(format!("thesis_models_{}", std::process::id()));
        thesis_models::write(&m, &tmp).expect("write");
        for ext in ["obj", "truth.json"] {
            let file = format!("{}.{ext}", m.name);
            let want = std::fs::read_to_string(tmp.join(&file)).expect("written");
            let have = std::fs::read_to_string(dir.join(&file))
                .unwrap_or_else(|e| panic!("{file}: {e}; regenerate with `thesis_models::write`"));
            assert!(have == want, "models/thesis/{file} is stale; regenerate it");
        }
        let _ = std::fs::remove_dir_all(&tmp);
    }
}

/// Regenerates `models/thesis/`: `cargo test --release --test thesis_models -- --ignored`.
#[test]
#[ignore]
fn write_models() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/thesis");
    for m in thesis_models::all() {
        thesis_models::write(&m, &dir).expect("write");
    }
}
