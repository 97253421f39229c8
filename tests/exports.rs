//! The opt-in exports (`run --export prt,obj,gltf,dot`) on the thesis's four-room model:
//! each file parsed back and its cells, portals and names counted; PRT1's conventions
//! checked against qbsp's own `models/quake/e1m1.prt`; the default run writes none of them.

use portalfind::decimate::{Estimator, HeuristicKind, StopRule};
use portalfind::output::{self, PrtLimits, ResultDoc, parse_prt, prt_file};
use portalfind::pipeline::{self, Run, Settings};
use portalfind::predicates::P3;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};

const ALL: [&str; 4] = ["prt", "obj", "gltf", "dot"];

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("portalfind-exports-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// four_room_optimized with the thesis's settings (refined / hull, stopped at 4 cells): four
/// rooms of 24 convex pieces each, joined by portals.
fn four_rooms(stop: StopRule, dir: &Path) -> (portalfind::model::Model, Run) {
    let m = portalfind::generate::thesis::by_name("four_room_optimized").unwrap();
    portalfind::generate::thesis::write(&m, dir).unwrap();
    let mut s = Settings::default();
    s.decimation.heuristic = HeuristicKind::Refined;
    s.decimation.estimator = Estimator::Hull;
    s.decimation.stop = stop;
    pipeline::run(&dir.join("four_room_optimized.obj"), &s, &mut |_| {}).unwrap()
}

fn export_all(dir: &Path, m: &portalfind::model::Model, r: &Run) -> Vec<PathBuf> {
    let all: Vec<String> = ALL.iter().map(|s| s.to_string()).collect();
    output::write_outputs_exporting(dir, m, &r.doc, &r.dec, &[], Some(&r.cx), &all).unwrap()
}

fn names(files: &[PathBuf]) -> BTreeSet<String> {
    files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect()
}

fn cross(a: P3, b: P3) -> P3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: P3, b: P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Newell's area vector (twice the area, along the right-hand normal).
fn area_vector(w: &[P3]) -> P3 {
    let mut n = [0.0; 3];
    for i in 0..w.len() {
        let c = cross(w[i], w[(i + 1) % w.len()]);
        for k in 0..3 {
            n[k] += c[k];
        }
    }
    n
}

fn area(w: &[P3]) -> f64 {
    dot(area_vector(w), area_vector(w)).sqrt() / 2.0
}

/// For every leaf, its portals' planes oriented out of the leaf (the right-hand normal for
/// lines naming it first, reversed for lines naming it second) must have all of the leaf's
/// portal points behind them (within `eps`): the convention vis relies on. Returns the
/// number of points in front (violations) and of points tested.
fn orientation_violations(f: &output::PrtFile, eps: f64) -> (usize, usize) {
    let mut by_leaf: Vec<Vec<(P3, f64, usize)>> = vec![Vec::new(); f.leaves];
    for (k, p) in f.portals.iter().enumerate() {
        let a = area_vector(&p.winding);
        let len = dot(a, a).sqrt();
        let n = a.map(|x| x / len);
        let d = dot(n, p.winding[0]);
        by_leaf[p.leaves[0]].push((n, d, k));
        by_leaf[p.leaves[1]].push((n.map(|x| -x), -d, k));
    }
    let (mut bad, mut total) = (0, 0);
    for planes in &by_leaf {
        for (n, d, _) in planes {
            for &(_, _, k) in planes {
                for v in &f.portals[k].winding {
                    total += 1;
                    if dot(*n, *v) - d > eps {
                        bad += 1;
                    }
                }
            }
        }
    }
    (bad, total)
}

#[test]
fn qbsp_e1m1_prt_is_read_and_its_orientation_convention_is_ours() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/quake/e1m1.prt");
    let f = parse_prt("e1m1.prt", &std::fs::read_to_string(path).unwrap()).unwrap();
    assert_eq!(f.leaves, 1170);
    assert_eq!(f.portals.len(), 3253);
    assert!(
        f.portals
            .iter()
            .all(|p| (3..=output::MAX_POINTS_ON_WINDING).contains(&p.winding.len()))
    );
    assert!(f.portals_per_leaf().iter().all(|&n| n <= output::MAX_PORTALS_ON_LEAF));
    // qbsp's lines: the first leaf is the smaller, and lines come sorted by it.
    assert!(f.portals.iter().all(|p| p.leaves[0] < p.leaves[1]));
    assert!(f.portals.windows(2).all(|w| w[0].leaves[0] <= w[1].leaves[0]));
    // The right-hand normal points from the first leaf into the second: with that reading
    // every (convex) leaf lies behind all its portal planes; with the opposite, half fail.
    let (bad, total) = orientation_violations(&f, 0.2);
    assert_eq!(bad, 0, "of {total}");
    let mut flipped = f.clone();
    for p in &mut flipped.portals {
        p.winding.reverse();
    }
    let (bad, total) = orientation_violations(&flipped, 0.2);
    assert!(bad > total / 4, "{bad} of {total}");
}

#[test]
fn default_run_writes_none_of_the_exports_and_unknown_names_fail() {
    let dir = tmp_dir("default");
    let (m, r) = four_rooms(StopRule::Cells(4), &dir);
    let out = dir.join("out");
    let files = output::write_outputs(&out, &m, &r.doc, &r.dec).unwrap();
    let got = names(&files);
    for f in [
        "cells.prt",
        "cells.obj",
        "cells.mtl",
        "cells.glb",
        "portals.dot",
        "viewer.html",
    ] {
        assert!(!got.contains(f) && !out.join(f).exists(), "{f}");
    }
    // The four formats for other tools, then the 3D viewer (tests/viewer.rs).
    assert_eq!(output::opt_in_formats(), [&ALL[..], &["html"]].concat());
    let e =
        output::write_outputs_exporting(&out, &m, &r.doc, &r.dec, &[], Some(&r.cx), &["ply".to_string()]).unwrap_err();
    assert!(format!("{e} {}", std::error::Error::source(&e).unwrap()).contains("prt, obj, gltf, dot"));
    // An export that needs the complex, asked for without it, fails and leaves nothing.
    let out2 = dir.join("out2");
    assert!(output::write_outputs_exporting(&out2, &m, &r.doc, &r.dec, &[], None, &["obj".to_string()]).is_err());
    // (The output set is staged beside `out2`, so the directory is not even created.)
    assert!(!out2.exists() || std::fs::read_dir(&out2).unwrap().count() == 0);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn prt_has_one_leaf_per_cell_and_one_line_per_convex_portal_piece() {
    let dir = tmp_dir("prt");
    let (m, r) = four_rooms(StopRule::Cells(4), &dir);
    let files = export_all(&dir, &m, &r);
    assert!(
        names(&files).is_superset(
            &["cells.prt", "cells.obj", "cells.mtl", "cells.glb", "portals.dot"]
                .map(String::from)
                .into()
        )
    );
    let doc: &ResultDoc = &r.doc;
    let text = std::fs::read_to_string(dir.join("cells.prt")).unwrap();
    assert!(text.starts_with(&format!("PRT1\n{}\n", doc.cells.len())));
    let f = parse_prt("cells.prt", &text).unwrap();
    assert_eq!(f.leaves, 4);
    let pieces: usize = doc.portals.iter().map(|p| p.polygons.len()).sum();
    assert!(pieces >= doc.portals.len() && doc.portals.len() >= 3);
    assert_eq!(f.portals.len(), pieces);
    // Leaf i is result.json's i-th cell; each pair's lines carry its pieces and area.
    let leaf_of: HashMap<u32, usize> = doc.cells.iter().enumerate().map(|(i, c)| (c.id, i)).collect();
    let mut by_pair: BTreeMap<[usize; 2], (usize, f64)> = BTreeMap::new();
    for p in &f.portals {
        let e = by_pair.entry(p.leaves).or_default();
        e.0 += 1;
        e.1 += area(&p.winding);
    }
    for p in &doc.portals {
        let (a, b) = (leaf_of[&p.cells[0]], leaf_of[&p.cells[1]]);
        let key = [a.min(b), a.max(b)];
        let (n, ar) = by_pair[&key];
        assert_eq!(n, p.polygons.len());
        assert!((ar - p.area).abs() <= 1e-9 * p.area.max(1.0), "{ar} vs {}", p.area);
        // Orientation: the winding's normal agrees with result.json's (from cells[0] to
        // cells[1]) when the leaves are in that order.
        let line = f.portals.iter().find(|l| l.leaves == key).unwrap();
        let along = dot(area_vector(&line.winding), p.mean_normal);
        assert!(if a < b { along > 0.0 } else { along < 0.0 }, "{:?}", p.cells);
    }
    assert_eq!(by_pair.len(), doc.portals.len());
    assert!(f.portals.iter().all(|p| p.leaves[0] < p.leaves[1]));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn prt_splits_leaves_and_windings_over_the_limits() {
    let dir = tmp_dir("prt-limits");
    let (_, r) = four_rooms(StopRule::Cells(4), &dir);
    let vis = prt_file(&r.cx, &r.dec.partition, PrtLimits::VIS).unwrap();
    assert_eq!(vis.leaf_cells, r.doc.cells.iter().map(|c| c.id).collect::<Vec<_>>());
    // One line fewer than the busiest leaf has: that cell becomes one leaf per piece. Taken
    // at the first state of the run (replayed) where that fits: a merged cell with more
    // portal lines than any of its pieces.
    let mut found = false;
    for k in 0..=r.dec.steps.len() {
        let part = portalfind::decimate::Decimation::replay(&r.cx, &r.dec.steps[..k]).unwrap();
        let vis = prt_file(&r.cx, &part, PrtLimits::VIS).unwrap();
        let per_leaf = vis.portals_per_leaf();
        let max = *per_leaf.iter().max().unwrap();
        let limits = PrtLimits {
            points: 3,
            portals_per_leaf: max - 1,
        };
        let Ok(f) = prt_file(&r.cx, &part, limits) else {
            continue;
        };
        found = true;
        let busiest = per_leaf.iter().position(|&n| n == max).unwrap();
        let pieces = part.cells[busiest].pieces.len();
        assert!(f.leaves >= vis.leaves + pieces - 1, "{} leaves", f.leaves);
        assert_eq!(f.leaf_cells.len(), f.leaves);
        assert_eq!(f.leaf_cells[..vis.leaves], vis.leaf_cells[..]);
        assert!(f.portals.iter().all(|p| p.winding.len() == 3));
        assert!(f.portals_per_leaf().iter().all(|&n| n < max));
        // The cell's own pieces are now joined by portal lines between its leaves.
        let id = part.cells[busiest].id.0;
        assert!(
            f.portals
                .iter()
                .any(|p| p.leaves.iter().all(|&l| f.leaf_cells[l] == id))
        );
        break;
    }
    assert!(
        found,
        "no state of the run could be split within its busiest leaf's count"
    );
    // At the initial state every cell is one convex piece: nothing to split, an error.
    let part = portalfind::decimate::Decimation::replay(&r.cx, &[]).unwrap();
    let e = prt_file(
        &r.cx,
        &part,
        PrtLimits {
            points: 64,
            portals_per_leaf: 1,
        },
    )
    .unwrap_err();
    assert!(e.contains("more than the limit of 1"), "{e}");
    // There every leaf is convex, as qbsp's are: our windings follow e1m1.prt's convention.
    let f = prt_file(&r.cx, &part, PrtLimits::VIS).unwrap();
    assert!(f.portals.len() > 50);
    let (bad, total) = orientation_violations(&f, 1e-9 * r.cx.tol.scale);
    assert_eq!(bad, 0, "of {total}");
    let vis = prt_file(&r.cx, &r.dec.partition, PrtLimits::VIS).unwrap();
    // Points alone: the fans keep every portal's area.
    let fans = prt_file(
        &r.cx,
        &r.dec.partition,
        PrtLimits {
            points: 3,
            portals_per_leaf: usize::MAX,
        },
    )
    .unwrap();
    assert_eq!(fans.leaves, vis.leaves);
    assert!(fans.portals.iter().all(|p| p.winding.len() == 3));
    let total = |f: &output::PrtFile| f.portals.iter().map(|p| area(&p.winding)).sum::<f64>();
    assert!((total(&fans) - total(&vis)).abs() <= 1e-9 * total(&vis));
    let text = fans.to_text();
    assert_eq!(parse_prt("fans.prt", &text).unwrap().portals.len(), fans.portals.len());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `o` names and the faces under each, from an OBJ's text.
fn obj_objects(text: &str) -> BTreeMap<String, usize> {
    let mut out = BTreeMap::new();
    let mut cur = String::new();
    for l in text.lines() {
        if let Some(n) = l.strip_prefix("o ") {
            cur = n.to_string();
            assert!(out.insert(cur.clone(), 0).is_none(), "object {cur} twice");
        } else if l.starts_with("f ") {
            *out.get_mut(&cur).unwrap() += 1;
        }
    }
    out
}

#[test]
fn obj_has_one_object_per_cell_and_portal_and_reads_back() {
    let dir = tmp_dir("obj");
    // A run stopped early, so cells have several pieces and interior faces to leave out.
    let (m, r) = four_rooms(StopRule::Cells(12), &dir);
    export_all(&dir, &m, &r);
    let doc = &r.doc;
    let text = std::fs::read_to_string(dir.join("cells.obj")).unwrap();
    let all_objects = obj_objects(&text);
    // Each portal's convex stand-in, `Portal_<a>_<b>_hull`: one face, after its portal.
    let hulls: BTreeSet<String> = all_objects.keys().filter(|n| n.ends_with("_hull")).cloned().collect();
    assert_eq!(hulls.len(), doc.portals.len());
    for h in &hulls {
        assert_eq!(all_objects[h], 1, "{h}");
        assert!(all_objects.contains_key(h.strip_suffix("_hull").unwrap()), "{h}");
    }
    let objects: BTreeMap<String, usize> = all_objects
        .iter()
        .filter(|(n, _)| !n.ends_with("_hull"))
        .map(|(n, f)| (n.clone(), *f))
        .collect();
    let expect: BTreeSet<String> = doc
        .cells
        .iter()
        .map(|c| format!("Cell_{}", c.id))
        .chain(
            doc.portals
                .iter()
                .map(|p| format!("Portal_{}_{}", p.cells[0], p.cells[1])),
        )
        .collect();
    assert_eq!(objects.keys().cloned().collect::<BTreeSet<_>>(), expect);
    for p in &doc.portals {
        assert_eq!(
            objects[&format!("Portal_{}_{}", p.cells[0], p.cells[1])],
            p.polygons.len()
        );
    }
    // The project's own reader takes it: every face read, every material one of ours.
    let back = portalfind::model::load_model(&dir.join("cells.obj")).unwrap();
    let faces: usize = all_objects.values().sum();
    assert_eq!(back.report.input_polygons, faces);
    // (Portal faces coincide with a cell's boundary face, so cleaning drops them as
    // duplicates: only the cells' materials survive it.)
    let mats: BTreeSet<String> = back
        .polygons
        .iter()
        .filter_map(|p| p.material.clone())
        .filter(|m| m != "portal_hull")
        .collect();
    let mut want: BTreeSet<String> = doc.cells.iter().map(|c| format!("cell_{}", c.id)).collect();
    assert_eq!(mats, want);
    assert!(text.lines().any(|l| l == "usemtl portal"));
    want.insert("portal".into());
    let mtl = std::fs::read_to_string(dir.join("cells.mtl")).unwrap();
    for w in &want {
        assert!(mtl.contains(&format!("newmtl {w}\n")), "{w}");
    }
    // Each cell's faces bound it: outward, closed (divergence theorem gives its volume),
    // and with the faces between its own pieces left out.
    let mut verts: Vec<P3> = Vec::new();
    let mut cur = String::new();
    let mut vol: HashMap<String, f64> = HashMap::new();
    let mut face_area: HashMap<String, f64> = HashMap::new();
    for l in text.lines() {
        let mut t = l.split_whitespace();
        match t.next() {
            Some("o") => cur = t.next().unwrap().to_string(),
            Some("v") => verts.push([0, 1, 2].map(|_| t.next().unwrap().parse().unwrap())),
            Some("f") => {
                let w: Vec<P3> = t.map(|i| verts[i.parse::<usize>().unwrap() - 1]).collect();
                let mut v = 0.0;
                for i in 1..w.len() - 1 {
                    v += dot(w[0], cross(w[i], w[i + 1])) / 6.0;
                }
                *vol.entry(cur.clone()).or_default() += v;
                *face_area.entry(cur.clone()).or_default() += area(&w);
            }
            _ => {}
        }
    }
    let mut merged = 0;
    for c in &doc.cells {
        let name = format!("Cell_{}", c.id);
        assert!(
            (vol[&name] - c.volume).abs() <= 1e-6 * c.volume,
            "{name}: {} vs {}",
            vol[&name],
            c.volume
        );
        if c.pieces.len() > 1 {
            merged += 1;
            let surface: f64 = c
                .pieces
                .iter()
                .map(|p| r.cx.cells[p.source_cell as usize].surface_area())
                .sum();
            assert!(face_area[&name] < surface - 1e-9, "{name}: interior faces written");
        }
    }
    assert!(merged > 0);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The JSON chunk and BIN chunk of a GLB, checking its header and alignment.
fn read_glb(bytes: &[u8]) -> (Value, Vec<u8>) {
    let u = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as usize;
    assert_eq!(&bytes[0..4], b"glTF");
    assert_eq!(u(4), 2);
    assert_eq!(u(8), bytes.len());
    let jl = u(12);
    assert_eq!(&bytes[16..20], b"JSON");
    assert_eq!(jl % 4, 0);
    let json: Value = serde_json::from_slice(&bytes[20..20 + jl]).unwrap();
    let o = 20 + jl;
    let bl = u(o);
    assert_eq!(&bytes[o + 4..o + 8], b"BIN\0");
    assert_eq!(bl % 4, 0);
    assert_eq!(o + 8 + bl, bytes.len());
    (json, bytes[o + 8..o + 8 + bl].to_vec())
}

#[test]
fn glb_has_godot_room_and_portal_nodes_with_extras_and_exact_bounds() {
    let dir = tmp_dir("glb");
    let (m, r) = four_rooms(StopRule::Cells(4), &dir);
    export_all(&dir, &m, &r);
    let doc = &r.doc;
    let (g, bin) = read_glb(&std::fs::read(dir.join("cells.glb")).unwrap());
    assert_eq!(g["asset"]["version"], "2.0");
    assert_eq!(g["buffers"][0]["byteLength"].as_u64().unwrap() as usize, bin.len());
    let nodes = g["nodes"].as_array().unwrap();
    assert_eq!(nodes[0]["name"], "RoomList");
    let name = |i: &Value| {
        nodes[i.as_u64().unwrap() as usize]["name"]
            .as_str()
            .unwrap()
            .to_string()
    };
    let rooms: Vec<&Value> = nodes[0]["children"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| &nodes[i.as_u64().unwrap() as usize])
        .collect();
    assert_eq!(rooms.len(), doc.cells.len());
    let mut portals_seen: BTreeMap<[u32; 2], usize> = BTreeMap::new();
    for (room, c) in rooms.iter().zip(&doc.cells) {
        assert_eq!(room["name"], format!("Room_{}-room", c.id));
        assert_eq!(room["extras"]["cell_id"], c.id);
        assert!((room["extras"]["volume"].as_f64().unwrap() - c.volume).abs() <= 1e-12 * c.volume);
        let children: Vec<String> = room["children"].as_array().unwrap().iter().map(name).collect();
        assert!(children.contains(&format!("Cell_{}", c.id)));
        for ch in children.iter().filter(|n| n.ends_with("-portal")) {
            // Godot 3.5: the name before `*` (or `-portal`) is the room it leads to.
            let target = ch.split(['*', '-']).next().unwrap();
            let rest = ch.split_once('*').unwrap().1;
            let b: u32 = target.strip_prefix("Room_").unwrap().parse().unwrap();
            assert!(rest.starts_with(&format!("Portal_{}_{b}_", c.id)), "{ch}");
            *portals_seen.entry([c.id, b]).or_default() += 1;
        }
    }
    let want: BTreeMap<[u32; 2], usize> = doc.portals.iter().map(|p| (p.cells, p.polygons.len())).collect();
    assert_eq!(portals_seen, want);
    // POSITION accessors: min/max equal to the data, indices within range.
    for mesh in g["meshes"].as_array().unwrap() {
        let prim = &mesh["primitives"][0];
        let acc = &g["accessors"][prim["attributes"]["POSITION"].as_u64().unwrap() as usize];
        let view = &g["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
        let off = view["byteOffset"].as_u64().unwrap() as usize;
        let n = acc["count"].as_u64().unwrap() as usize;
        assert_eq!(view["byteLength"].as_u64().unwrap() as usize, 12 * n);
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for i in 0..n {
            for k in 0..3 {
                let o = off + 12 * i + 4 * k;
                let x = f32::from_le_bytes(bin[o..o + 4].try_into().unwrap());
                lo[k] = lo[k].min(x);
                hi[k] = hi[k].max(x);
            }
        }
        let as_f32 = |v: &Value| {
            v.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap() as f32)
                .collect::<Vec<_>>()
        };
        assert_eq!(as_f32(&acc["min"]), lo);
        assert_eq!(as_f32(&acc["max"]), hi);
        let ia = &g["accessors"][prim["indices"].as_u64().unwrap() as usize];
        let iv = &g["bufferViews"][ia["bufferView"].as_u64().unwrap() as usize];
        let ioff = iv["byteOffset"].as_u64().unwrap() as usize;
        for i in 0..ia["count"].as_u64().unwrap() as usize {
            let o = ioff + 4 * i;
            assert!((u32::from_le_bytes(bin[o..o + 4].try_into().unwrap()) as usize) < n);
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn dot_has_one_node_per_cell_one_edge_per_pair_and_region_clusters() {
    let dir = tmp_dir("dot");
    let (m, r) = four_rooms(StopRule::Cells(4), &dir);
    export_all(&dir, &m, &r);
    let doc = &r.doc;
    let text = std::fs::read_to_string(dir.join("portals.dot")).unwrap();
    assert!(text.contains("graph portals {") && text.trim_end().ends_with('}'));
    let nodes: BTreeSet<u32> = text
        .lines()
        .filter_map(|l| l.trim().strip_prefix('c'))
        .filter(|l| l.contains("[label=\"cell "))
        .map(|l| l.split(' ').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(nodes, doc.cells.iter().map(|c| c.id).collect());
    let edges: BTreeSet<[u32; 2]> = text
        .lines()
        .filter(|l| l.contains(" -- "))
        .map(|l| {
            let (a, rest) = l.trim().split_once(" -- ").unwrap();
            let b = rest.split(' ').next().unwrap();
            [a[1..].parse().unwrap(), b[1..].parse().unwrap()]
        })
        .collect();
    assert_eq!(edges, doc.portals.iter().map(|p| p.cells).collect());
    for p in &doc.portals {
        assert!(text.contains(&format!("area={}", p.area)));
    }
    // The four rooms are joined: one region.
    assert_eq!(text.matches("subgraph cluster_region_").count(), 1);
    std::fs::remove_dir_all(&dir).unwrap();
}
