//! Diagnostics for one stress variant: `cargo run --release --example diag_stress -- FAMILY SEED VARIANT [ARG]`
//! (e.g. `thesis 0 noise 1e-6`): complex stats, validation, leaks with their paths.
use portalfind::suite::stress::{Variant, apply};
use portalfind::suite::{Family, case};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let fam: Family = Family::from_name(&a[1]).unwrap_or_else(|| panic!("family {}", a[1]));
    let seed: u64 = a[2].parse().unwrap();
    let arg = a.get(4).map(|s| s.parse::<f64>().unwrap()).unwrap_or(1.0);
    let v = match a[3].as_str() {
        "base" => Variant::Base,
        "rot789" => Variant::Rotate789,
        "rot" => Variant::RotateRandom(arg as u64),
        "offset" => Variant::Offset(arg),
        "scale" => Variant::Scale(arg),
        "noise" => Variant::Noise(arg),
        "shuffle" => Variant::Shuffle(arg as u64),
        "centroid" => Variant::CentroidSplit,
        "dup" => Variant::Duplicate,
        "flipdup" => Variant::FlippedDuplicate,
        v => panic!("variant {v}"),
    };
    let c = case(fam, seed).expect("case");
    let (vs, ps) = apply(v, &c.model.vertices, &c.model.polygons);
    if let Ok(p) = std::env::var("DIAG_OBJ") {
        let mut s = String::new();
        for q in &vs {
            s += &format!("v {:?} {:?} {:?}\n", q[0], q[1], q[2]);
        }
        for f in &ps {
            s += "f";
            for i in f {
                s += &format!(" {}", i + 1);
            }
            s += "\n";
        }
        std::fs::write(p, s).unwrap();
    }
    let m = portalfind::model::from_soup(&c.name, vs, ps).expect("load");
    // DIAG_SEAL_OFF=1: no sealing (as `--seal-holes off`).
    let cx = if std::env::var("DIAG_SEAL_OFF").is_ok() {
        let settings = portalfind::pipeline::CellSettings {
            seal_holes: None,
            ..Default::default()
        };
        portalfind::pipeline::build_cells_unchecked(&m, std::path::Path::new(&c.name), &settings, &mut |_| {})
            .expect("complex")
            .cx
    } else {
        portalfind::pipeline::complex_of_unchecked(&m).expect("complex")
    };
    println!("{} {v}: {:#?}", c.name, cx.stats);
    let gap = portalfind::suite::stress::widest_gap(&m);
    println!(
        "closed {} (open edges {}, T-junctions {}, non-manifold {}), widest gap {gap:.3e} = {:.3e} of the diagonal",
        portalfind::suite::stress::is_closed(&m),
        m.report.open_edges,
        m.report.t_junctions,
        m.report.non_manifold_edges,
        gap / m.tolerances.scale
    );
    // DIAG_SEAL=k1,k2,..: seal openings narrower than k × the widest gap (a fresh complex each).
    if let Ok(ks) = std::env::var("DIAG_SEAL") {
        for k in ks.split(',').map(|k| k.parse::<f64>().unwrap()) {
            let mut c2 = portalfind::pipeline::complex_of_unchecked(&m).expect("complex");
            let sealed = c2.seal_holes(&m, k * gap);
            println!(
                "seal {k} x gap = {:.3e}: {} openings sealed (widest {:.3e}), leaks {}, active cells {}",
                k * gap,
                sealed.len(),
                sealed.iter().map(|s| s.width).fold(0.0, f64::max),
                c2.stats.leaks,
                c2.stats.active_cells
            );
        }
    }
    // DIAG_ROOMS=1: the aperture merge's steps (`run`'s default decimation) that join or
    // keep apart two components holding samples of different rooms.
    if std::env::var("DIAG_ROOMS").is_ok() {
        use portalfind::decimate::{HeuristicKind, Settings};
        let mut settings = Settings {
            heuristic: HeuristicKind::Aperture,
            ..Default::default()
        };
        settings.stop = settings.heuristic.default_stop();
        let mut gate = settings.heuristic.heuristic().aperture_gate();
        // DIAG_GATE=scalar|still|both: the gate without the vector opening, without the
        // moved boundaries, or without either (the aperture gate before branch h4).
        if let (Ok(g), Some(a)) = (std::env::var("DIAG_GATE"), gate.as_mut()) {
            a.vector_opening &= g == "still";
            a.tunnels &= g == "scalar";
        }
        let (dec, steps) = portalfind::decimate::clearance::trace(&cx, &settings, gate);
        let mut rooms: std::collections::HashMap<u32, std::collections::BTreeSet<usize>> = Default::default();
        // The truth's samples moved with the model (rigid motions, scalings), in its frame.
        let map = portalfind::suite::stress::point_map(v);
        let moved: Vec<Vec<[f64; 3]>> = c
            .truth
            .rooms
            .iter()
            .map(|r| {
                r.samples
                    .iter()
                    .map(|&p| m.from_user(map.as_ref().map_or(p, |f| f(p))))
                    .collect()
            })
            .collect();
        for (r, samples) in moved.iter().enumerate() {
            for cell in portalfind::experiment::eval::locate_in_complex(&cx, samples)
                .into_iter()
                .flatten()
            {
                rooms.entry(cell.0).or_default().insert(r);
            }
        }
        let mut parent: std::collections::HashMap<u32, u32> = Default::default();
        fn find(p: &mut std::collections::HashMap<u32, u32>, mut x: u32) -> u32 {
            while let Some(&q) = p.get(&x) {
                if q == x {
                    break;
                }
                x = q;
            }
            x
        }
        for (i, st) in steps.iter().enumerate() {
            let (a, b) = (find(&mut parent, st.a.0), find(&mut parent, st.b.0));
            let (ra, rb) = (
                rooms.get(&a).cloned().unwrap_or_default(),
                rooms.get(&b).cloned().unwrap_or_default(),
            );
            if !ra.is_empty() && !rb.is_empty() && ra != rb {
                println!(
                    "step {i}: rooms {ra:?} + {rb:?} kept {} w {:.4} peaks [{:.4}, {:.4}] saddle {:.4} portal {:.4} opening {:.4} projected [{:.3}, {:.3}] volumes [{:.3}, {:.3}]",
                    st.kept,
                    st.weight,
                    st.peaks[0],
                    st.peaks[1],
                    st.saddle,
                    st.portal_area,
                    st.opening,
                    st.projected[0],
                    st.projected[1],
                    st.volumes[0],
                    st.volumes[1]
                );
            }
            // DIAG_KEPT=1: every pair the gate kept apart, whatever rooms its sides hold.
            if st.kept && std::env::var("DIAG_KEPT").is_ok() {
                println!(
                    "step {i}: kept {ra:?} | {rb:?} w {:.4} peaks [{:.4}, {:.4}] saddle {:.4} portal {:.4} opening {:.4} projected [{:.3}, {:.3}] volumes [{:.3}, {:.3}]",
                    st.weight,
                    st.peaks[0],
                    st.peaks[1],
                    st.saddle,
                    st.portal_area,
                    st.opening,
                    st.projected[0],
                    st.projected[1],
                    st.volumes[0],
                    st.volumes[1]
                );
            }
            // DIAG_ROOM=r: merges of room r's component with a component holding no samples.
            if let Some(r) = std::env::var("DIAG_ROOM").ok().and_then(|r| r.parse::<usize>().ok()) {
                let has = |x: &std::collections::BTreeSet<usize>| x.contains(&r);
                if !st.kept
                    && ((has(&ra) && rb.is_empty()) || (has(&rb) && ra.is_empty()))
                    && st.volumes[0].min(st.volumes[1]) > 0.5
                {
                    println!(
                        "step {i}: room {r} absorbs w {:.4} peaks [{:.4}, {:.4}] saddle {:.4} portal {:.4} volumes [{:.3}, {:.3}] ({} side has the room)",
                        st.weight,
                        st.peaks[0],
                        st.peaks[1],
                        st.saddle,
                        st.portal_area,
                        st.volumes[0],
                        st.volumes[1],
                        if has(&ra) { "first" } else { "second" }
                    );
                }
            }
            if !st.kept {
                let (lo, hi) = (a.min(b), a.max(b));
                parent.insert(hi, lo);
                let mut u = rooms.remove(&hi).unwrap_or_default();
                u.extend(rooms.remove(&lo).unwrap_or_default());
                if !u.is_empty() {
                    rooms.insert(lo, u);
                }
            }
        }
        println!(
            "stop {:?}, final portals {}",
            dec.stop,
            dec.partition.portals(&cx).len()
        );
        for (r, room) in c.truth.rooms.iter().enumerate() {
            let finals: std::collections::BTreeSet<Option<usize>> =
                portalfind::experiment::eval::locate_in_complex(&cx, &moved[r])
                    .into_iter()
                    .map(|c| c.and_then(|c| dec.partition.cell_of(c)))
                    .collect();
            println!("room {r} ({}): final cells {finals:?}", room.name);
        }
        // DIAG_PAIR=i,j: the portals between final cells i and j, with their cells' peaks,
        // the sampled and refined passes and the pieces' areas (the pass that keeps them apart).
        if let Some((fi, fj)) = std::env::var("DIAG_PAIR").ok().and_then(|s| {
            let (a, b) = s.split_once(',')?;
            Some((a.parse::<usize>().ok()?, b.parse::<usize>().ok()?))
        }) {
            let f = portalfind::decimate::clearance::CellField::new(&cx);
            let (mut best, mut area) = (0.0f64, 0.0f64);
            let mut rows = Vec::new();
            for (k, p) in cx.portals.iter().enumerate() {
                let [a, b] = p.cells;
                let (ca, cb) = (dec.partition.cell_of(a), dec.partition.cell_of(b));
                if (ca, cb) == (Some(fi), Some(fj)) || (ca, cb) == (Some(fj), Some(fi)) {
                    let ar: f64 = p.pieces.iter().map(|q| q.area()).sum();
                    let r = f.refined_passage(&cx, k);
                    best = best.max(r);
                    area += ar;
                    rows.push((r, k, f.value[a.idx()], f.value[b.idx()], f.passage[k], ar));
                }
            }
            rows.sort_by(|x, y| y.0.total_cmp(&x.0));
            println!(
                "pair {fi},{fj}: {} portals, area {area:.3}, best refined pass {best:.4}",
                rows.len()
            );
            for (r, k, pa, pb, s, ar) in rows.iter().take(15) {
                println!("  portal {k}: peaks [{pa:.4}, {pb:.4}] pass {s:.4} refined {r:.4} area {ar:.4}");
            }
        }
    }
    // DIAG_CELLS=id,id,..: every face of those cells, its patch's cells and occluders.
    if let Ok(ids) = std::env::var("DIAG_CELLS") {
        for id in ids.split(',').map(|x| x.parse::<usize>().unwrap()) {
            let c = &cx.cells[id];
            println!(
                "cell {id} tet {:?} alive {} exterior {} flat {} vol {:.3e}",
                c.tet,
                c.alive,
                c.exterior,
                c.flat,
                c.volume()
            );
            for (f, &t) in c.poly().faces.iter().zip(c.tags()) {
                print_patch(&cx, t, "  face", f);
            }
        }
    }
    println!("check_valid: {:?}", cx.check_valid().err().map(|e| e.to_string()));
    println!("validate: {:?}", cx.validate(&m).err().map(|e| e.to_string()));
    for l in &cx.leaks {
        println!(
            "leak: region {} from {:?} path {:?} first portal {:?} hull {:?}",
            l.region_cells, l.from_cell, l.path, l.first_portal_point, l.hull_point
        );
        for w in l.path.windows(2) {
            let p = cx.portals.iter().find(|p| p.cells == [w[0].min(w[1]), w[0].max(w[1])]);
            let c0 = &cx.cells[w[0].idx()];
            println!(
                "  {:?} (faces occluder {}, thin {}, vol {:.3e}, tet {:?}) -> {:?}: portal {:?}",
                w[0],
                cx.faces_occluder(w[0]),
                cx.is_thin(w[0]),
                c0.volume(),
                c0.tet,
                w[1],
                p.map(|p| (
                    p.area,
                    p.pieces.len(),
                    p.pieces.iter().map(|q| q.centroid()).collect::<Vec<_>>()
                ))
            );
            if std::env::var("DIAG_DEEP").is_ok() {
                if let Some(p) = p {
                    for q in &p.pieces {
                        println!("     piece {:?}", q.verts);
                        let c = q.centroid();
                        for (k, mp) in m.polygons.iter().enumerate() {
                            let vs: Vec<[f64; 3]> = mp.verts.iter().map(|v| m.vertices[v.idx()]).collect();
                            let lo = [0, 1, 2].map(|a| vs.iter().map(|v| v[a]).fold(f64::INFINITY, f64::min));
                            let hi = [0, 1, 2].map(|a| vs.iter().map(|v| v[a]).fold(f64::NEG_INFINITY, f64::max));
                            if (0..3).all(|a| c[a] > lo[a] - 1e-3 && c[a] < hi[a] + 1e-3) {
                                let pl = &cx.polygon_planes[k];
                                println!(
                                    "       polygon {k} {:?} support dist {:.3e}",
                                    vs,
                                    pl.normalized().eval(&c)
                                );
                            }
                        }
                    }
                }
                for &t in c0.tags() {
                    let pa = &cx.patches[t as usize];
                    if pa.cells.contains(&w[1]) {
                        print_patch(&cx, t, "     patch", &pa.polygon);
                    }
                }
            }
        }
    }
}

/// One patch (`polygon`: its geometry as seen from the caller) with its cells and occluders.
fn print_patch(cx: &portalfind::complex::CellComplex, t: u32, indent: &str, polygon: &portalfind::geom::ConvexPolygon) {
    let pa = &cx.patches[t as usize];
    println!(
        "{indent} {t} cells {:?} alive {} area {:.4e} verts {:?}",
        pa.cells,
        pa.alive,
        polygon.area(),
        polygon.verts
    );
    for o in &pa.occluders {
        println!(
            "{indent}   occ src {:?} faces {} area {:.4e} {:?}",
            o.source,
            o.faces,
            o.polygon.area(),
            o.polygon.verts
        );
    }
}
