//! Diagnostics of the clearance merge on suite cases: every pair the merge looks at that
//! joins two true rooms (and the intra-room pairs of high persistence), with persistence,
//! portal area and the components' projected sections.
//!
//! `cargo run --release --example diag_rooms -- [tune|report] [family,..] [gate_from gate_ratio gate_ball]`
//!
//! Environment: `SCORE=1` scores the final partition at `RATIO` (default 1.8) instead of
//! tracing; `FINAL=1` (or `all`) describes its final cells; `SPLITS=1` the split rooms;
//! `DOMINANCE`, `SLICES`, `SLAB` and `SLAB_PEAK` set the gate's dominance ratio, section
//! slices and the clean-up's slab ratios.

use portalfind::decimate::clearance::{ApertureGate, trace};
use portalfind::decimate::{HeuristicKind, Settings, StopRule};
use portalfind::experiment::eval::locate_in_complex;
use portalfind::suite::{self, Half};
use std::collections::BTreeSet;

use portalfind::base::rigid::{rotate_789, rotate_xyz_deg_inverse};

/// The inverse of [`rotate_789`].
fn unrotate_789(p: [f64; 3]) -> [f64; 3] {
    rotate_xyz_deg_inverse(p, [7.0, 8.0, 9.0])
}

fn find(p: &mut [usize], mut x: usize) -> usize {
    while p[x] != x {
        p[x] = p[p[x]];
        x = p[x];
    }
    x
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("tunnels") {
        tunnels();
        return;
    }
    let half = match args.get(1).map(String::as_str) {
        Some("report") => Half::Report,
        _ => Half::Tune,
    };
    let fams: Vec<String> = args
        .get(2)
        .map(|s| s.split(',').map(str::to_string).collect())
        .unwrap_or_default();
    let gate = match (args.get(3), args.get(4), args.get(5)) {
        (Some(a), Some(b), Some(c)) => Some(ApertureGate {
            from: a.parse().unwrap(),
            ratio: b.parse().unwrap(),
            ball: c.parse().unwrap(),
            dominance: std::env::var("DOMINANCE")
                .ok()
                .and_then(|d| d.parse().ok())
                .unwrap_or(0.0),
            slices: std::env::var("SLICES").ok().and_then(|d| d.parse().ok()).unwrap_or(0),
            slab: std::env::var("SLAB").ok().and_then(|d| d.parse().ok()).unwrap_or(0.0),
            slab_peak: std::env::var("SLAB_PEAK")
                .ok()
                .and_then(|d| d.parse().ok())
                .unwrap_or(0.5),
            vector_opening: std::env::var("VECTOR").is_ok_and(|v| v != "0"),
            shadow_opening: std::env::var("SHADOW").is_ok_and(|v| v != "0"),
            tunnels: std::env::var("TUNNELS").is_ok_and(|v| v != "0"),
            core_cut: std::env::var("CORE_CUT").is_ok_and(|v| v != "0"),
        }),
        _ => None,
    };
    let score_only = std::env::var("SCORE").is_ok();
    let ratio: f64 = std::env::var("RATIO").ok().and_then(|r| r.parse().ok()).unwrap_or(1.8);
    let (mut tot, mut iso) = (0, 0);
    for case in suite::suite() {
        if case.half != half || (!fams.is_empty() && !fams.iter().any(|f| *f == case.family.to_string())) {
            continue;
        }
        if let Ok(dir) = std::env::var("WRITE") {
            // Write the case as OBJ (for `portalfind complex --pointfile`) and skip it.
            let mut text = String::new();
            for v in &case.model.vertices {
                text += &format!("v {:?} {:?} {:?}\n", v[0], v[1], v[2]);
            }
            for f in &case.model.polygons {
                text += "f";
                for i in f {
                    text += &format!(" {}", i + 1);
                }
                text += "\n";
            }
            std::fs::write(format!("{dir}/{}.obj", case.name), text).unwrap();
            continue;
        }
        if std::env::var("ROOMS").is_ok() {
            // The truth: each room's boxes (generator frame) and the doorways.
            println!("== {} rooms", case.name);
            if let portalfind::suite::Membership::Boxes { rooms, solids, .. } = &case.truth.membership {
                for (r, bs) in case.truth.rooms.iter().zip(rooms) {
                    println!("   {:24} {:?}", r.name, bs);
                }
                println!("   solids {:?}", solids);
            }
            for d in &case.truth.doorways {
                println!("   door {:?} {:?}", d.rooms, d.polygon);
            }
            continue;
        }
        let model = case.load().unwrap();
        let mut cx = portalfind::pipeline::complex_of_unchecked(&model).unwrap();
        if std::env::var("SEAL").is_ok() {
            let leaks = cx.leaks.len();
            let sealed = cx.seal_cracks_auto(&model);
            println!(
                "   {}: seal_cracks_auto: leaks {} -> {}, {} openings sealed (widest {:.2e}), active {}",
                case.name,
                leaks,
                cx.leaks.len(),
                sealed.len(),
                sealed.iter().map(|o| o.width).fold(0.0, f64::max),
                cx.active_cells().count(),
            );
        }
        if std::env::var("LEAK").is_ok() {
            println!("== {} leaks {}", case.name, cx.leaks.len());
            leak_diag(&model, &cx);
            continue;
        }
        let settings = Settings {
            heuristic: HeuristicKind::Clearance,
            stop: StopRule::Threshold(if score_only { ratio } else { 4.0 }),
            ..Settings::default()
        };
        let (dec, steps) = trace(&cx, &settings, gate);
        if score_only {
            let a = portalfind::suite::metrics::score(&cx, &dec.partition, &case.truth, &Default::default());
            tot += a.rooms;
            iso += a.rooms_isolated;
            println!(
                "{:32} rooms {:2} isolated {:2} final {:4} P {:.3} R {:.3} kept {}",
                case.name,
                a.rooms,
                a.rooms_isolated,
                a.final_cells,
                a.precision_micro,
                a.recall_micro,
                steps.iter().filter(|s| s.kept).count()
            );
            if std::env::var("FINAL").is_ok() {
                final_cells(&cx, &dec.partition, &case.truth);
            }
            if std::env::var("SPLITS").is_ok() {
                let cells: Vec<BTreeSet<usize>> = case
                    .truth
                    .rooms
                    .iter()
                    .map(|r| {
                        locate_in_complex(&cx, &r.samples)
                            .into_iter()
                            .flatten()
                            .filter_map(|c| dec.partition.cell_of(c))
                            .collect()
                    })
                    .collect();
                let ports = dec.partition.portals(&cx);
                for (i, cs) in cells.iter().enumerate() {
                    if cs.len() < 2 {
                        continue;
                    }
                    println!("   room {} split into {:?}", case.truth.rooms[i].name, cs);
                    for mp in &ports {
                        let (x, y) = (dec.partition.cell_of(mp.cells[0]), dec.partition.cell_of(mp.cells[1]));
                        if x.is_some_and(|x| cs.contains(&x)) && y.is_some_and(|y| cs.contains(&y)) {
                            let mut lo = [f64::MAX; 3];
                            let mut hi = [f64::MIN; 3];
                            for q in &mp.pieces {
                                for v in &q.verts {
                                    for k in 0..3 {
                                        lo[k] = lo[k].min(v[k]);
                                        hi[k] = hi[k].max(v[k]);
                                    }
                                }
                            }
                            println!(
                                "     portal {:?} area {:.2} pieces {} normal {:.2?} bbox {:.2?}..{:.2?}",
                                [x, y],
                                mp.area,
                                mp.pieces.len(),
                                mp.mean_normal,
                                lo,
                                hi
                            );
                        }
                    }
                    if let portalfind::suite::Membership::Boxes { rooms, .. } = &case.truth.membership {
                        println!("     room boxes {:?}", rooms[i]);
                    }
                }
            }
            continue;
        }
        let n = cx.cells.len();
        let mut parent: Vec<usize> = (0..n).collect();
        let mut rooms: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); n];
        for (i, r) in case.truth.rooms.iter().enumerate() {
            for c in locate_in_complex(&cx, &r.samples).into_iter().flatten() {
                rooms[c.idx()].insert(i);
            }
        }
        println!(
            "== {} ({} rooms, leaks {})",
            case.name,
            case.truth.rooms.len(),
            cx.leaks.len()
        );
        for s in &steps {
            let (a, b) = (find(&mut parent, s.a.idx()), find(&mut parent, s.b.idx()));
            let (ra, rb) = (rooms[a].clone(), rooms[b].clone());
            let ratio = s.projected[0].min(s.projected[1]) / s.portal_area;
            let big = s.projected[0].max(s.projected[1]) / s.portal_area;
            let join = !ra.is_empty() && !rb.is_empty() && ra.is_disjoint(&rb);
            if join || (s.weight >= 1.1 && s.weight < 1.8) {
                let what = if join {
                    let d = case.truth.doorways.iter().find(|d| {
                        ra.contains(&d.rooms[0]) && rb.contains(&d.rooms[1])
                            || ra.contains(&d.rooms[1]) && rb.contains(&d.rooms[0])
                    });
                    let dims = d.map(|d| {
                        let p = &d.polygon;
                        let l = |i: usize, j: usize| {
                            ((p[i][0] - p[j][0]).powi(2) + (p[i][1] - p[j][1]).powi(2) + (p[i][2] - p[j][2]).powi(2))
                                .sqrt()
                        };
                        if p.len() == 4 {
                            format!("{:.2}x{:.2}", l(0, 1), l(1, 2))
                        } else {
                            format!("{}-gon", p.len())
                        }
                    });
                    let names = |r: &BTreeSet<usize>| {
                        r.iter()
                            .map(|&i| case.truth.rooms[i].name.clone())
                            .collect::<Vec<_>>()
                            .join("+")
                    };
                    format!(
                        "JOIN [{}] | [{}] door {}",
                        names(&ra),
                        names(&rb),
                        dims.unwrap_or("none".into())
                    )
                } else if ra.is_empty() || rb.is_empty() {
                    "frag".to_string()
                } else {
                    "intra".to_string()
                };
                println!(
                    "  w {:.3} peaks {:.2}/{:.2} saddle {:.2} Ap {:.2} Av {:.2} sec {:.1}/{:.1} min/Ap {:.2} max/Ap {:.2} vol {:.1}/{:.1} {} {}",
                    s.weight,
                    s.peaks[0],
                    s.peaks[1],
                    s.saddle,
                    s.portal_area,
                    s.opening,
                    s.projected[0],
                    s.projected[1],
                    ratio,
                    big,
                    s.volumes[0],
                    s.volumes[1],
                    if s.kept { "KEPT" } else { "" },
                    what
                );
            }
            if !s.kept {
                parent[b] = a;
                let rb = std::mem::take(&mut rooms[b]);
                rooms[a].extend(rb);
            }
        }
    }
    if score_only {
        println!("TOTAL isolated {iso}/{tot}");
    }
}

/// Every final cell: volume, peak (largest clearance sample), rooms whose samples it holds,
/// and its largest-portal neighbour's peak and volume.
fn final_cells(
    cx: &portalfind::complex::CellComplex,
    part: &portalfind::decimate::Partition,
    truth: &portalfind::suite::SuiteTruth,
) {
    let field = portalfind::decimate::clearance::CellField::new(cx);
    let mut rooms: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); part.len()];
    for (i, r) in truth.rooms.iter().enumerate() {
        for c in locate_in_complex(cx, &r.samples).into_iter().flatten() {
            if let Some(f) = part.cell_of(c) {
                rooms[f].insert(i);
            }
        }
    }
    let peak: Vec<f64> = part
        .cells
        .iter()
        .map(|m| m.pieces.iter().map(|p| field.value[p.idx()]).fold(0.0, f64::max))
        .collect();
    let ports = part.portals(cx);
    // Regions of the final cell graph, and which hold rooms.
    let mut reg: Vec<usize> = (0..part.len()).collect();
    for mp in &ports {
        let (x, y) = (part.cell_of(mp.cells[0]).unwrap(), part.cell_of(mp.cells[1]).unwrap());
        let (rx, ry) = (find(&mut reg, x), find(&mut reg, y));
        reg[rx] = ry;
    }
    let mut with_rooms = BTreeSet::new();
    let mut all = BTreeSet::new();
    for (i, held) in rooms.iter().enumerate() {
        let r = find(&mut reg, i);
        all.insert(r);
        if !held.is_empty() {
            with_rooms.insert(r);
        }
    }
    let junk_in_room_regions = (0..part.len())
        .filter(|&i| rooms[i].is_empty() && with_rooms.contains(&find(&mut reg, i)))
        .count();
    let maxpeak = peak.iter().copied().fold(0.0, f64::max);
    let roompeak = (0..part.len())
        .filter(|&i| !rooms[i].is_empty())
        .map(|i| peak[i])
        .fold(f64::MAX, f64::min);
    let junkpeak = (0..part.len())
        .filter(|&i| rooms[i].is_empty())
        .map(|i| peak[i])
        .fold(0.0, f64::max);
    println!(
        "   regions {} with rooms {} | junk cells in room regions {} | max peak {:.3} min room-cell peak {:.3} max junk peak {:.3}",
        all.len(),
        with_rooms.len(),
        junk_in_room_regions,
        maxpeak,
        roompeak,
        junkpeak
    );
    if std::env::var("FINAL").as_deref() != Ok("all") {
        return;
    }
    for (i, m) in part.cells.iter().enumerate() {
        let mut best: Option<(f64, usize)> = None;
        let mut nb = 0;
        for mp in &ports {
            let (x, y) = (part.cell_of(mp.cells[0]).unwrap(), part.cell_of(mp.cells[1]).unwrap());
            let o = if x == i {
                y
            } else if y == i {
                x
            } else {
                continue;
            };
            nb += 1;
            if best.is_none_or(|(a, _)| mp.area > a) {
                best = Some((mp.area, o));
            }
        }
        let (ba, bo) = best.map_or((0.0, usize::MAX), |b| b);
        let (op, ov) = if bo == usize::MAX {
            (0.0, 0.0)
        } else {
            (peak[bo], part.cells[bo].volume)
        };
        println!(
            "   cell {:3} pieces {:5} vol {:9.3} peak {:.3} rooms {:?} nbrs {} | largest portal {:.3} to {} peak {:.3} vol {:.3} | peak/nb {:.3} vol/nb {:.4}",
            i,
            m.pieces.len(),
            m.volume,
            peak[i],
            rooms[i],
            nb,
            ba,
            bo,
            op,
            ov,
            peak[i] / op,
            m.volume / ov
        );
    }
}

fn seg_tri(p: [f64; 3], q: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> Option<f64> {
    let sub = |x: [f64; 3], y: [f64; 3]| [x[0] - y[0], x[1] - y[1], x[2] - y[2]];
    let cr = |x: [f64; 3], y: [f64; 3]| {
        [
            x[1] * y[2] - x[2] * y[1],
            x[2] * y[0] - x[0] * y[2],
            x[0] * y[1] - x[1] * y[0],
        ]
    };
    let dt = |x: [f64; 3], y: [f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    let d = sub(q, p);
    let (e1, e2) = (sub(b, a), sub(c, a));
    let h = cr(d, e2);
    let det = dt(e1, h);
    if det.abs() < 1e-30 {
        return None;
    }
    let s = sub(p, a);
    let u = dt(s, h) / det;
    let qq = cr(s, e1);
    let v = dt(d, qq) / det;
    let t = dt(e2, qq) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && (0.0..=1.0).contains(&t)).then_some(t)
}

/// `LEAK=1`: for each leak of the case's complex, the steps of the leak path whose segments
/// (cell centroid → portal centroid → next cell centroid) cross a model polygon, with the
/// cells, the patches between them and their occluders.
pub fn leak_diag(model: &portalfind::model::Model, cx: &portalfind::complex::CellComplex) {
    use portalfind::ids::CellId;
    let tris: Vec<(usize, [[f64; 3]; 3])> = model
        .polygons
        .iter()
        .enumerate()
        .flat_map(|(i, p)| {
            let v: Vec<[f64; 3]> = p.verts.iter().map(|v| model.vertices[v.idx()]).collect();
            (1..v.len() - 1)
                .map(move |k| (i, [v[0], v[k], v[k + 1]]))
                .collect::<Vec<_>>()
        })
        .collect();
    let tol = &model.tolerances;
    let describe = |c: CellId| {
        let cell = &cx.cells[c.idx()];
        format!(
            "cell {} tet {:?} flat {} membrane {} thin {} faces_occ {} vol {:.3e} nfaces {}",
            c.0,
            cell.tet,
            cell.flat,
            cx.is_membrane(c),
            cx.is_thin(c),
            cx.faces_occluder(c),
            cell.volume(),
            cell.poly().faces.len()
        )
    };
    for leak in &cx.leaks {
        let pts = cx.leak_pointfile(leak);
        println!("  leak: path {} cells", leak.path.len());
        for i in 0..pts.len() - 1 {
            for (pi, t) in &tris {
                if let Some(s) = seg_tri(pts[i], pts[i + 1], t[0], t[1], t[2]) {
                    let step = i / 2;
                    let (c, d) = (leak.path[step], leak.path.get(step + 1).copied());
                    println!(
                        "  segment {i} (step {step}) crosses polygon {pi} at t {s:.4}: {:?} -> {:?}",
                        pts[i],
                        pts[i + 1]
                    );
                    println!("    {}", describe(c));
                    if let Some(d) = d {
                        println!("    {}", describe(d));
                        let k = cx.portals.iter().position(|p| p.cells == [c.min(d), c.max(d)]).unwrap();
                        let pl = portalfind::geom::ConvexPolygon::new(t.to_vec()).plane().normalized();
                        for q in &cx.portals[k].pieces {
                            println!(
                                "    portal piece area {:.3e} verts {} dist to polygon plane {:?}",
                                q.area(),
                                q.verts.len(),
                                q.verts.iter().map(|v| pl.eval(v)).collect::<Vec<_>>()
                            );
                        }
                        let direct: Vec<u32> = cx.cells[c.idx()]
                            .tags()
                            .iter()
                            .copied()
                            .filter(|&tg| cx.patches[tg as usize].cells.contains(&d))
                            .collect();
                        println!("    direct patches {:?} (none: a join across membranes)", direct);
                        for tg in direct {
                            let p = &cx.patches[tg as usize];
                            println!(
                                "     patch {tg} area {:.3e} occluders {:?}",
                                p.polygon.area(),
                                p.occluders
                                    .iter()
                                    .map(|o| (o.source.0, o.faces, o.polygon.area()))
                                    .collect::<Vec<_>>()
                            );
                        }
                        // Distances of both cells' vertices to the crossed polygon's plane.
                        for e in [c, d] {
                            let ds: Vec<f64> = cx.cells[e.idx()].vertices().iter().map(|v| pl.eval(v)).collect();
                            println!(
                                "    cell {} vertex distances to plane: min {:.3e} max {:.3e}",
                                e.0,
                                ds.iter().cloned().fold(f64::MAX, f64::min),
                                ds.iter().cloned().fold(f64::MIN, f64::max)
                            );
                        }
                    }
                    let _ = tol;
                }
            }
        }
    }
}

/// Area and area-weighted centroid (mapped by `back`) of a set of complex portals.
fn surface(
    cx: &portalfind::complex::CellComplex,
    ks: &[usize],
    back: &dyn Fn([f64; 3]) -> [f64; 3],
) -> (f64, [f64; 3]) {
    let (mut a, mut c) = (0.0, [0.0; 3]);
    for &k in ks {
        for q in &cx.portals[k].pieces {
            let (qa, qc) = (q.area(), back(q.centroid()));
            a += qa;
            for i in 0..3 {
                c[i] += qa * qc[i];
            }
        }
    }
    (a, c.map(|x| x / a))
}

/// The thesis caverns as shipped, rotated 7°/8°/9° and offset by 1e6, at the default stop:
/// each final portal (area, centroid mapped back to the shipped frame) and, for the same
/// pair of final cells, the minimum cut by portal area between the cells of each side
/// whose field value is at least the geometric mean of the pair's saddle and lower peak
/// (the cores), over the other cells of the two (the tunnel zone).
fn tunnels() {
    use portalfind::decimate::Decimation;
    use portalfind::decimate::clearance::CellField;
    type Map = Box<dyn Fn([f64; 3]) -> [f64; 3]>;
    let variants: Vec<(&str, Map, Map)> = vec![
        ("shipped", Box::new(|p| p), Box::new(|p| p)),
        ("rot789", Box::new(rotate_789), Box::new(unrotate_789)),
        (
            "offset1e6",
            Box::new(|p: [f64; 3]| p.map(|x| x + 1e6)),
            Box::new(|p: [f64; 3]| p.map(|x| x - 1e6)),
        ),
    ];
    let name = std::env::var("MODEL").unwrap_or("caverns".into());
    for (vname, fwd, back) in &variants {
        let tm = portalfind::generate::thesis::by_name(&name).unwrap();
        let verts: Vec<[f64; 3]> = tm.soup.vertices.iter().map(|&p| fwd(p)).collect();
        let m = portalfind::model::from_soup(tm.name, verts, tm.soup.polygons.clone()).unwrap();
        let cx = portalfind::pipeline::complex_of(&m).unwrap();
        let d = Decimation::run(
            &cx,
            &Settings {
                heuristic: HeuristicKind::Aperture,
                stop: StopRule::Threshold(1.8),
                ..Settings::default()
            },
        );
        let part = &d.partition;
        let field = CellField::new(&cx);
        let peak: Vec<f64> = part
            .cells
            .iter()
            .map(|mc| mc.pieces.iter().map(|p| field.value[p.idx()]).fold(0.0, f64::max))
            .collect();
        println!("== {vname}: {} cells", part.len());
        for mp in part.portals(&cx) {
            let (i, j) = (part.cell_of(mp.cells[0]).unwrap(), part.cell_of(mp.cells[1]).unwrap());
            let saddle = mp.portals.iter().map(|&k| field.passage[k]).fold(0.0, f64::max);
            let level = (saddle * peak[i].min(peak[j])).sqrt();
            let (fa, fc) = surface(&cx, &mp.portals, back);
            // Min cut: nodes are the complex cells of i and j; source = cores of i, sink =
            // cores of j; capacities = portal areas (both directions).
            let side = |c: portalfind::ids::CellId| part.cell_of(c).filter(|&x| x == i || x == j);
            let n = cx.cells.len();
            let (src, snk) = (n, n + 1);
            let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n + 2];
            let mut to = Vec::new();
            let mut cap: Vec<f64> = Vec::new();
            let add =
                |adj: &mut Vec<Vec<usize>>, a: usize, b: usize, c: f64, to: &mut Vec<usize>, cap: &mut Vec<f64>| {
                    adj[a].push(to.len());
                    to.push(b);
                    cap.push(c);
                    adj[b].push(to.len());
                    to.push(a);
                    cap.push(c);
                };
            let mut portal_edge = Vec::new();
            for (k, p) in cx.portals.iter().enumerate() {
                let [a, b] = p.cells;
                if side(a).is_some() && side(b).is_some() && a != b {
                    portal_edge.push((k, to.len()));
                    add(&mut adj, a.idx(), b.idx(), p.area, &mut to, &mut cap);
                }
            }
            let mut cores = [0usize; 2];
            for (id, _) in cx.active_cells() {
                if let Some(x) = side(id)
                    && field.value[id.idx()] >= level
                {
                    let t = if x == i { src } else { snk };
                    cores[(x == j) as usize] += 1;
                    add(&mut adj, id.idx(), t, f64::INFINITY, &mut to, &mut cap);
                }
            }
            // Edmonds–Karp.
            let mut flow = 0.0;
            let reach = loop {
                let mut prev = vec![usize::MAX; n + 2];
                let mut seen = vec![false; n + 2];
                seen[src] = true;
                let mut q = std::collections::VecDeque::from([src]);
                while let Some(u) = q.pop_front() {
                    for &e in &adj[u] {
                        let v = to[e];
                        if !seen[v] && cap[e] > 1e-15 {
                            seen[v] = true;
                            prev[v] = e;
                            q.push_back(v);
                        }
                    }
                }
                if !seen[snk] {
                    break seen;
                }
                let mut b = f64::INFINITY;
                let mut v = snk;
                while v != src {
                    let e = prev[v];
                    b = b.min(cap[e]);
                    v = to[e ^ 1];
                }
                let mut v = snk;
                while v != src {
                    let e = prev[v];
                    cap[e] -= b;
                    cap[e ^ 1] += b;
                    v = to[e ^ 1];
                }
                flow += b;
            };
            let cut: Vec<usize> = portal_edge
                .iter()
                .filter(|&&(k, _)| {
                    let [a, b] = cx.portals[k].cells;
                    reach[a.idx()] != reach[b.idx()]
                })
                .map(|&(k, _)| k)
                .collect();
            let (ca, cc) = surface(&cx, &cut, back);
            println!(
                "  pair {i}-{j} final area {fa:6.2} at {:>6.2?} | saddle {saddle:.3} level {level:.3} cores {:?} mincut {flow:6.2} ({ca:6.2}, {} portals) at {:>6.2?}",
                fc,
                cores,
                cut.len(),
                cc
            );
        }
    }
}
