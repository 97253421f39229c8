//! Integration tests of the model input layer on real files (`tests/fixtures/`, and Quake's
//! e1m1 in `models/quake/`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use portalfind::PolygonId;
use portalfind::model::{CleaningReport, Model, ModelError, from_soup, load_model, parse_mesh_str};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures").join(name)
}

fn load(name: &str) -> Model {
    match load_model(&fixture(name)) {
        Ok(m) => m,
        Err(e) => panic!("{name}: {e}"),
    }
}

fn load_err(name: &str) -> ModelError {
    match load_model(&fixture(name)) {
        Ok(_) => panic!("{name}: expected an error"),
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.contains(name), "error does not name the file: {msg}");
            println!("{name}: {msg}");
            e
        }
    }
}

/// Signed volume enclosed by the polygons (positive when their fronts face outwards).
fn signed_volume(m: &Model) -> f64 {
    let mut vol = 0.0;
    for p in &m.polygons {
        let a = m.vertices[p.verts[0].idx()];
        for w in p.verts[1..].windows(2) {
            let (b, c) = (m.vertices[w[0].idx()], m.vertices[w[1].idx()]);
            vol += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0]);
        }
    }
    vol / 6.0
}

/// Checks that every polygon's normal points away from the model's centroid (outward; only
/// meaningful for convex models).
fn assert_outward(m: &Model) {
    let n = m.vertices.len() as f64;
    let c: [f64; 3] = std::array::from_fn(|k| m.vertices.iter().map(|v| v[k]).sum::<f64>() / n);
    for (i, p) in m.polygons.iter().enumerate() {
        let nrm = m.polygon_normal(PolygonId(i as u32));
        let v = m.vertices[p.verts[0].idx()];
        let d: f64 = (0..3).map(|k| nrm[k] * (v[k] - c[k])).sum();
        assert!(d > 0.0, "polygon {i} faces inwards");
    }
}

fn assert_invariants(r: &CleaningReport) {
    assert_eq!(
        r.final_vertices,
        r.input_vertices - r.welded_vertices - r.unused_vertices
    );
}

#[test]
fn cube_obj_quads_kept() {
    let m = load("cube.obj");
    let r = &m.report;
    assert_eq!(m.name, "cube");
    assert_eq!((r.input_vertices, r.input_polygons), (8, 6));
    assert_eq!((r.final_vertices, r.final_polygons), (8, 6));
    assert_eq!(r.welded_vertices + r.unused_vertices + r.zero_area_polygons_dropped, 0);
    assert_eq!(r.duplicate_polygons_dropped + r.nonplanar_or_nonconvex_triangulated, 0);
    assert_eq!((r.open_edges, r.non_manifold_edges, r.t_junctions), (0, 0, 0));
    assert!(m.polygons.iter().all(|p| p.verts.len() == 4));
    assert_eq!(m.triangle_count(), 12);
    assert_eq!(m.bbox(), ([0.0; 3], [1.0; 3]));
    assert_outward(&m);
    assert!((signed_volume(&m) - 1.0).abs() < 1e-15);
    // Materials from `usemtl`, although the .mtl file does not exist.
    assert_eq!(m.polygons[0].material.as_deref(), Some("floor"));
    assert_eq!(m.polygons[5].material.as_deref(), Some("wall"));
    // Source references: element index and 1-based line.
    assert_eq!(m.polygons[0].source.element, 0);
    assert_eq!(m.polygons[0].source.line, Some(14));
    assert_eq!(m.polygons[5].source.line, Some(21));
    assert!((m.tolerances.scale - 3f64.sqrt()).abs() < 1e-15);
}

#[test]
fn cube_mesh_equals_cube_obj() {
    let a = load("cube.obj");
    let b = load("cube.mesh");
    assert_eq!(a.vertices, b.vertices);
    let va: Vec<_> = a.polygons.iter().map(|p| p.verts.clone()).collect();
    let vb: Vec<_> = b.polygons.iter().map(|p| p.verts.clone()).collect();
    assert_eq!(va, vb);
    assert_eq!(a.report, b.report);
    assert_eq!(b.polygons[0].material, None);
    assert_eq!(b.polygons[0].source.line, Some(11));
    assert_eq!(b.polygons[4].source.line, Some(15));
}

#[test]
fn l_prism_caps_are_triangulated() {
    let m = load("l_prism.obj");
    let r = &m.report;
    println!("{r}");
    assert_eq!((r.input_vertices, r.input_polygons), (12, 8));
    assert_eq!(r.nonplanar_or_nonconvex_triangulated, 2);
    assert_eq!(r.nonplanar_polygons, 0);
    assert_eq!(r.triangulation_fallbacks, 0);
    assert_eq!(r.triangles_from_triangulation, 8);
    assert_eq!((r.final_vertices, r.final_polygons), (12, 14));
    assert_eq!((r.open_edges, r.non_manifold_edges, r.t_junctions), (0, 0, 0));
    assert_eq!(m.triangle_count(), 20);
    assert!((signed_volume(&m) - 3.0).abs() < 1e-12, "{}", signed_volume(&m));
    // The caps' triangles point back at their source faces.
    let from_bottom = m.polygons.iter().filter(|p| p.source.element == 0).count();
    assert_eq!(from_bottom, 4);
    assert!(
        m.polygons
            .iter()
            .filter(|p| p.source.element == 0)
            .all(|p| p.source.line == Some(16))
    );
}

#[test]
fn weld_merges_copies_and_reports() {
    let m = load("weld.obj");
    let r = &m.report;
    println!("{r}");
    assert_eq!((r.input_vertices, r.input_polygons), (25, 7));
    assert_eq!(r.welded_vertices, 16);
    assert_eq!(r.unused_vertices, 1);
    assert_eq!(r.duplicate_polygons_dropped, 1);
    assert_eq!(r.final_vertices, 8);
    assert_invariants(r);
    // Welding keeps the first copy's coordinates, so faces through a vertex that is 1e-9 off
    // are no longer exactly planar and get split: the x = 0, x = 1, y = 0 and y = 1 sides.
    assert_eq!(r.nonplanar_polygons, r.nonplanar_or_nonconvex_triangulated);
    // Only x = 0 (through vertex 1) and x = 1 (through vertices 2 and 8, opposite corners)
    // lose planarity; the other sides move within their plane.
    assert_eq!(r.nonplanar_polygons, 2);
    assert_eq!(r.final_polygons, 4 + 2 * 2);
    assert_eq!((r.open_edges, r.non_manifold_edges, r.t_junctions), (0, 0, 0));
    assert_outward(&m);
}

#[test]
fn from_soup_cleans_the_same_way() {
    let a = load("cube.obj");
    let polys: Vec<Vec<u32>> = a
        .polygons
        .iter()
        .map(|p| p.verts.iter().map(|v| v.0).collect())
        .collect();
    let b = from_soup("soup", a.vertices.clone(), polys).unwrap();
    assert_eq!(a.report, b.report);
    assert_eq!(b.polygons[3].source.line, None);
    assert_eq!(b.polygons[3].source.element, 3);

    let e = from_soup("soup", vec![[0.0; 3]; 3], vec![vec![0, 1, 3]]).unwrap_err();
    assert!(matches!(
        e,
        ModelError::IndexOutOfRange {
            polygon: 0,
            index: 3,
            vertex_count: 3,
            ..
        }
    ));
    let e = from_soup("soup", vec![[0.0, f64::NAN, 0.0]], vec![vec![0, 0, 0]]).unwrap_err();
    assert!(matches!(
        e,
        ModelError::NonFinite {
            vertex: 0,
            line: None,
            ..
        }
    ));
    let e = from_soup("soup", vec![[0.0; 3]; 3], vec![vec![0, 1]]).unwrap_err();
    assert!(matches!(
        e,
        ModelError::TooFewVertices {
            polygon: 0,
            count: 2,
            ..
        }
    ));
    let e = from_soup("soup", vec![], vec![]).unwrap_err();
    assert!(matches!(e, ModelError::Empty { .. }));
}

#[test]
fn parse_mesh_str_works() {
    let m = parse_mesh_str(
        "tet",
        "4 4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n",
    )
    .unwrap();
    assert_eq!(m.report.final_polygons, 4);
    assert_eq!(m.report.open_edges, 0);
    assert_outward(&m);
}

// ----- error paths -----

#[test]
fn error_missing_file() {
    let p = fixture("does_not_exist.obj");
    let e = load_model(&p).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, ModelError::Io { .. }), "{msg}");
    assert!(msg.contains("does_not_exist.obj"), "{msg}");
}

#[test]
fn error_unknown_extension() {
    let e = load_model(&fixture("cube.ply")).unwrap_err();
    assert!(
        matches!(&e, ModelError::UnknownExtension { ext, .. } if ext == "ply"),
        "{e}"
    );
    assert!(e.to_string().contains(".mesh"));
}

#[test]
fn error_malformed_vertex_line() {
    let e = load_err("err_malformed_vertex.obj");
    assert!(
        matches!(&e, ModelError::Malformed { line: 4, element, .. } if element.contains("vertex 3")),
        "{e}"
    );
    assert_eq!(e.line(), Some(4));
    assert!(e.to_string().contains("err_malformed_vertex.obj:4:"));
}

#[test]
fn error_nan_coordinate() {
    let e = load_err("err_nan.obj");
    assert!(
        matches!(
            e,
            ModelError::NonFinite {
                line: Some(4),
                vertex: 2,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn error_index_out_of_range() {
    let e = load_err("err_index.obj");
    assert!(
        matches!(
            e,
            ModelError::IndexOutOfRange {
                line: Some(8),
                polygon: 3,
                index: 5,
                vertex_count: 4,
                ..
            }
        ),
        "{e}"
    );
    let e = load_err("err_index.mesh");
    assert!(
        matches!(
            e,
            ModelError::IndexOutOfRange {
                line: Some(6),
                polygon: 0,
                index: 4,
                vertex_count: 4,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn error_empty() {
    let e = load_err("err_empty.obj");
    assert!(matches!(e, ModelError::Empty { .. }), "{e}");
}

#[test]
fn error_all_coplanar() {
    let e = load_err("err_coplanar.obj");
    assert!(matches!(e, ModelError::Degenerate { independent: 3, .. }), "{e}");
}

/// The reason of an `Empty` error.
fn empty_reason(e: &ModelError) -> &str {
    match e {
        ModelError::Empty { reason, .. } => reason,
        _ => panic!("expected an empty-model error, got: {e}"),
    }
}

#[test]
fn error_only_degenerate_face_is_empty() {
    // `f 1 1 1` references a single point, so the referenced vertices' bounding box has a zero
    // diagonal; that must not be reported as a coordinate-range problem.
    let e = load_err("err_degenerate_face.obj");
    assert!(matches!(e, ModelError::Empty { .. }), "{e}");
    let msg = e.to_string();
    assert!(msg.contains("zero-area") && !msg.contains("out of range"), "{msg}");
    // The same reason as when cleaning drops every polygon of an in-range model.
    let collinear = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
    let in_range = from_soup("soup", collinear, vec![vec![0, 1, 2]]).unwrap_err();
    assert_eq!(empty_reason(&e), empty_reason(&in_range));
    assert_eq!(
        empty_reason(&e),
        "all 1 polygons were dropped (1 zero-area, 0 duplicate)"
    );

    // Distinct indices at one point, and exactly collinear polygons at scales far outside the
    // supported range: still empty (every polygon has zero area at any scale).
    let soups = [
        (vec![[1.0, 2.0, 3.0]; 3], vec![vec![0, 1, 2], vec![2, 1, 0]]),
        (
            vec![[0.0; 3], [1e300, 0.0, 0.0], [3e300, 0.0, 0.0]],
            vec![vec![0, 1, 2]],
        ),
        (
            vec![[1e-300, 1e-300, 0.0], [2e-300, 2e-300, 0.0], [5e-300, 5e-300, 0.0]],
            vec![vec![0, 1, 2]],
        ),
        (
            vec![[1e20, 0.0, 1e20], [0.0, 1e20, 1e20], [1e20, 1e20, 1e20]],
            vec![vec![0, 0, 1], vec![2, 2, 2]],
        ),
    ];
    for (v, f) in soups {
        let n = f.len();
        let e = from_soup("soup", v, f).unwrap_err();
        let expected = format!("all {n} polygons were dropped ({n} zero-area, 0 duplicate)");
        assert_eq!(empty_reason(&e), expected, "{e}");
    }

    // One real polygon out of range besides a degenerate one: the range is the problem.
    let v = vec![[0.0; 3], [1e20, 0.0, 0.0], [0.0, 1e20, 0.0]];
    let e = from_soup("soup", v, vec![vec![0, 0, 0], vec![0, 1, 2]]).unwrap_err();
    assert!(matches!(e, ModelError::CoordinateRange { .. }), "{e}");
}

#[test]
fn error_used_vertices_coplanar() {
    // One triangle plus two unused vertices off its plane: the unused vertices are ignored, so
    // the model is flat, and the message must say that it is the *used* vertices that are.
    let e = load_err("err_coplanar_unused.obj");
    assert!(
        matches!(
            e,
            ModelError::Degenerate {
                independent: 3,
                shape: "coplanar",
                ..
            }
        ),
        "{e}"
    );
    let msg = e.to_string();
    assert!(msg.contains("used by polygons"), "{msg}");
    assert!(!msg.contains("all vertices are"), "{msg}");
}

#[test]
fn error_mesh_counts_and_short_polygon() {
    let e = load_err("err_counts.mesh");
    assert!(
        matches!(
            e,
            ModelError::CountMismatch {
                line: 2,
                what: "polygons",
                declared: 2,
                found: 1,
                ..
            }
        ),
        "{e}"
    );
    let e = load_err("err_two_vertices.mesh");
    assert!(
        matches!(
            e,
            ModelError::TooFewVertices {
                line: Some(7),
                polygon: 1,
                count: 2,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn no_panic_on_truncated_or_garbled_fixtures() {
    // Every prefix of every fixture, as both formats: errors are fine, panics are not.
    for entry in std::fs::read_dir(fixture("")).unwrap() {
        let text = std::fs::read_to_string(entry.unwrap().path()).unwrap();
        for cut in (0..text.len()).filter(|&i| text.is_char_boundary(i)) {
            let t = &text[..cut];
            let _ = parse_mesh_str("x", t);
            let _ = portalfind::model::parse_obj_str("x", t);
        }
    }
}

// ----- Quake e1m1 -----

fn e1m1_path() -> Option<PathBuf> {
    let here = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/models/quake/e1m1.obj"));
    let shared = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/models/quake/e1m1.obj"));
    [here, shared].into_iter().find(|p| p.exists())
}

#[test]
fn e1m1_loads_with_golden_counts() {
    let Some(path) = e1m1_path() else {
        println!("note: models/quake/e1m1.obj not found; skipping the e1m1 test");
        return;
    };
    let t = Instant::now();
    let m = load_model(&path).unwrap();
    let dt = t.elapsed();
    let r = &m.report;
    println!("e1m1 loaded and cleaned in {:.1} ms\n{r}", dt.as_secs_f64() * 1e3);
    let (lo, hi) = m.bbox();
    println!("bbox {lo:?} .. {hi:?}, tolerances {:?}", m.tolerances);
    assert_eq!(r.input_vertices, 6822);
    assert_eq!(r.input_polygons, 15186);
    assert_invariants(r);
    // Golden numbers. e1m1 is the BSP's faces fanned into triangles; faces carry extra vertices
    // on their edges (qbsp's T-junction fixing), so the fans contain 1319 exactly collinear
    // triangles, plus 2 with area ~1e-12: 1321 zero-area drops. No vertex is duplicated (no
    // welds). 93 faces are the reverse of another (two-sided surfaces, mostly slime, sky and
    // water). The mesh is open (door openings, sky) with T-junctions everywhere, as the
    // model's README says; `e1m1_t_junctions_brute_force` confirms the T-junction count.
    let golden = CleaningReport {
        input_vertices: 6822,
        input_polygons: 15186,
        welded_vertices: GOLDEN[0],
        unused_vertices: GOLDEN[1],
        zero_area_polygons_dropped: GOLDEN[2],
        duplicate_polygons_dropped: GOLDEN[3],
        two_sided_pairs: GOLDEN[4],
        nonplanar_or_nonconvex_triangulated: 0,
        nonplanar_polygons: 0,
        triangles_from_triangulation: 0,
        triangulation_fallbacks: 0,
        min_area_triangulated: 0,
        open_edges: GOLDEN[5],
        t_junctions: GOLDEN[6],
        non_manifold_edges: GOLDEN[7],
        final_vertices: GOLDEN[8],
        final_polygons: GOLDEN[9],
        translation: None,
    };
    assert_eq!(*r, golden);
    assert_eq!(m.triangle_count(), r.final_polygons);
    assert!(m.polygons.iter().all(|p| p.material.is_some()));
}

const GOLDEN: [usize; 10] = [0, 0, 1321, 0, 93, 2746, 1311, 815, 6822, 13865];

/// Brute-force check of the T-junction count (every vertex against every edge). Slow in debug
/// builds: `cargo test --release --test model_input -- --ignored`.
#[test]
#[ignore]
fn e1m1_t_junctions_brute_force() {
    let Some(path) = e1m1_path() else { return };
    let m = load_model(&path).unwrap();
    let mut edges: Vec<(u32, u32)> = Vec::new();
    for p in &m.polygons {
        for i in 0..p.verts.len() {
            let (a, b) = (p.verts[i].0, p.verts[(i + 1) % p.verts.len()].0);
            edges.push((a.min(b), a.max(b)));
        }
    }
    edges.sort_unstable();
    edges.dedup();
    let mut count = 0;
    for &(a, b) in &edges {
        let (pa, pb) = (m.vertices[a as usize], m.vertices[b as usize]);
        for (v, q) in m.vertices.iter().enumerate() {
            if v as u32 == a || v as u32 == b {
                continue;
            }
            let inside = (0..3).all(|k| q[k] >= pa[k].min(pb[k]) && q[k] <= pa[k].max(pb[k]));
            if inside && portalfind::predicates::collinear(&pa, &pb, q) {
                count += 1;
            }
        }
    }
    assert_eq!(count, m.report.t_junctions);
}

/// Scaling check: a torus of about 1M triangles given as a soup with 3 vertex copies per
/// triangle (3M input vertices to weld). `cargo test --release --test model_input -- --ignored
/// --nocapture`.
#[test]
#[ignore]
fn million_triangle_soup_scales() {
    let (nu, nv) = (1000usize, 500usize);
    let pt = |i: usize, j: usize| -> [f64; 3] {
        let (u, v) = (
            (i % nu) as f64 * std::f64::consts::TAU / nu as f64,
            (j % nv) as f64 * std::f64::consts::TAU / nv as f64,
        );
        let r = 3.0 + v.cos();
        [r * u.cos(), r * u.sin(), v.sin()]
    };
    let mut vertices = Vec::with_capacity(nu * nv * 6);
    let mut polys = Vec::with_capacity(nu * nv * 2);
    for i in 0..nu {
        for j in 0..nv {
            for tri in [
                [(i, j), (i + 1, j), (i + 1, j + 1)],
                [(i, j), (i + 1, j + 1), (i, j + 1)],
            ] {
                let base = vertices.len() as u32;
                for (a, b) in tri {
                    vertices.push(pt(a, b));
                }
                polys.push(vec![base, base + 1, base + 2]);
            }
        }
    }
    let t = Instant::now();
    let m = from_soup("torus", vertices, polys).unwrap();
    println!(
        "1M-triangle soup cleaned in {:.2} s\n{}",
        t.elapsed().as_secs_f64(),
        m.report
    );
    assert_eq!(m.report.final_vertices, nu * nv);
    assert_eq!(m.report.open_edges, 0);
}

#[test]
fn error_coordinates_out_of_range() {
    use portalfind::model::{ModelError, from_soup};
    let tet = vec![vec![0, 2, 1], vec![0, 1, 3], vec![0, 3, 2], vec![1, 2, 3]];
    let scaled = |s: f64| vec![[0.0, 0.0, 0.0], [s, 0.0, 0.0], [0.0, s, 0.0], [0.0, 0.0, s]];
    for s in [1e300, 1e20, 1e-50, 1e-12] {
        let e = from_soup("t", scaled(s), tet.clone()).unwrap_err();
        assert!(matches!(e, ModelError::CoordinateRange { .. }), "{s}: {e}");
        assert!(e.to_string().contains("rescale"), "{e}");
    }
    assert!(from_soup("t", scaled(1e6), tet.clone()).is_ok());
    assert!(from_soup("t", scaled(1e-6), tet).is_ok());
}

/// A directory given as MODEL names itself and the models in it, not "unknown extension".
#[test]
fn a_directory_as_model_says_so_and_lists_its_models() {
    let d = std::env::temp_dir().join(format!("portalfind-dir-model-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("sub.obj")).unwrap();
    std::fs::write(d.join("b.obj"), "").unwrap();
    std::fs::write(d.join("a.mesh"), "").unwrap();
    std::fs::write(d.join("notes.txt"), "").unwrap();
    let e = portalfind::model::load_model(&d).unwrap_err().to_string();
    assert!(e.contains("is a directory, not a model file"), "{e}");
    assert!(
        e.contains("such as a.mesh, b.obj, sub.obj") && !e.contains("notes.txt"),
        "{e}"
    );
    assert!(!e.contains("unknown model file extension"), "{e}");
    // A directory named like a model is a directory too.
    let e = portalfind::model::load_model(&d.join("sub.obj"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("is a directory") && e.contains("it holds none"), "{e}");
    std::fs::remove_dir_all(&d).unwrap();
}

/// A Medit/TetGen `.mesh` file gets a hint that it is another format.
#[test]
fn a_medit_mesh_gets_a_hint_that_it_is_another_format() {
    let text =
        "MeshVersionFormatted 1\nDimension 3\nVertices\n3\n0 0 0 1\n1 0 0 1\n0 1 0 1\nTriangles\n1\n1 2 3 1\nEnd\n";
    let e = portalfind::model::parse_mesh_str("tet.mesh", text)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("tet.mesh:1: this is a Medit/TetGen `.mesh` file"), "{e}");
    assert!(e.contains("meshio convert"), "{e}");
    // Comment lines before the keyword do not hide it.
    let e = portalfind::model::parse_mesh_str("t.mesh", &format!("# exported\n{text}"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("Medit/TetGen"), "{e}");
}

/// A file in the temporary folder (unique per process).
fn temp_file(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("portalfind-model-input-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// A face index too large for 64 bits is out of range (file, line, index), not a generic
/// parse error, in OBJ and in .mesh. Found by a new-user trial.
#[test]
fn an_overflowing_face_index_is_out_of_range() {
    let big = "99999999999999999999999";
    for (name, text, line) in [
        (
            "overflow.obj",
            format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 {big}\n"),
            5,
        ),
        (
            "overflow_neg.obj",
            format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -{big}/1\n"),
            4,
        ),
        (
            "overflow.mesh",
            format!("4 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 {big}\n"),
            6,
        ),
    ] {
        let p = temp_file(name, text.as_bytes());
        let e = load_model(&p).unwrap_err();
        assert!(
            matches!(&e, ModelError::IndexTooLarge { line: l, polygon: 0, index, .. } if *l == line && index.ends_with(big)),
            "{name}: {e:?}"
        );
        assert_eq!(e.line(), Some(line));
        let msg = e.to_string();
        assert!(
            msg.starts_with(&format!("{}:{line}: ", p.display())) && msg.contains("out of range") && msg.contains(big),
            "{msg}"
        );
        std::fs::remove_file(&p).unwrap();
    }
}

/// A binary file named `.obj` (here a PNG image) is reported as not a text model file,
/// naming the file and what it looks like, not as an empty model; a file with a stray
/// Latin-1 byte in a comment still loads. Found by a new-user trial.
#[test]
fn a_binary_file_named_obj_is_not_a_text_model() {
    let png: &[u8] = b"\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR\x00\x00\x00\x01\x00\x00\x00\x01\x08\x00\x00\x00\x00";
    for name in ["picture.obj", "picture.mesh"] {
        let p = temp_file(name, png);
        let e = load_model(&p).unwrap_err();
        assert!(matches!(e, ModelError::NotText { .. }), "{name}: {e:?}");
        let msg = e.to_string();
        assert!(
            msg.contains(&p.display().to_string()) && msg.contains("not a text model file") && msg.contains("PNG"),
            "{msg}"
        );
        std::fs::remove_file(&p).unwrap();
    }
    // Not UTF-8 and nothing of a model in it, without a NUL byte.
    let p = temp_file("junk.obj", b"\xc3\x28\xa0\xa1 \xff\xfe\xfd\n\x80\x81\n");
    let e = load_model(&p).unwrap_err();
    assert!(
        matches!(e, ModelError::NotText { .. }) && e.to_string().contains("not valid UTF-8"),
        "{e:?}"
    );
    std::fs::remove_file(&p).unwrap();
    let cube = std::fs::read(fixture("cube.obj")).unwrap();
    let mut latin1 = b"# caf\xe9 (Latin-1)\n".to_vec();
    latin1.extend(cube);
    let p = temp_file("latin1.obj", &latin1);
    assert!(load_model(&p).is_ok());
    std::fs::remove_file(&p).unwrap();
}
