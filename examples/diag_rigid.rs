//! Why a rigid motion changes the rooms (issue 16): the aperture merge of one stress
//! variant, traced, with the truth rooms located in the moved model. Prints every traced
//! pair that joins two true rooms or that the gate kept apart, and the rooms isolated.
//!
//! `cargo run --release --example diag_rigid -- FAMILY SEED VARIANT [ARG]` (KEPT=1 also
//! prints pairs kept apart between a room and another component, ALL=1 every pair kept
//! apart, FIRST=1 traces the first pass instead of the second, TRACK=ID every step of the
//! component holding cell ID (ids as the peak-cell lines print them); variants as
//! `diag_stress`: base, rot789, rot K, offset X, scale X, shuffle K, noise X).
use portalfind::decimate::clearance::trace;
use portalfind::decimate::{HeuristicKind, Settings};
use portalfind::experiment::eval::locate_in_complex;
use portalfind::suite::stress::{Variant, apply, point_map};
use portalfind::suite::{Family, case};
use std::collections::BTreeSet;

fn find(p: &mut [usize], mut x: usize) -> usize {
    while p[x] != x {
        p[x] = p[p[x]];
        x = p[x];
    }
    x
}

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
        "shuffle" => Variant::Shuffle(arg as u64),
        "noise" => Variant::Noise(arg),
        v => panic!("variant {v}"),
    };
    let c = case(fam, seed).expect("case");
    let (vs, ps) = apply(v, &c.model.vertices, &c.model.polygons);
    let m = portalfind::model::from_soup(&c.name, vs, ps).expect("load");
    let map = point_map(v);
    let samples: Vec<Vec<[f64; 3]>> = c
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
    let cx = portalfind::pipeline::complex_of(&m).expect("complex");
    let settings = Settings {
        heuristic: HeuristicKind::Aperture,
        stop: HeuristicKind::Aperture.default_stop(),
        ..Settings::default()
    };
    let mut gate = settings.heuristic.heuristic().aperture_gate();
    if std::env::var("FIRST").is_ok() {
        // The first pass only (no boundary moves, no second pass).
        gate = gate.map(|g| portalfind::decimate::clearance::ApertureGate { tunnels: false, ..g });
    }
    let (dec, steps) = trace(&cx, &settings, gate);
    let n = cx.cells.len();
    let mut rooms: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); n];
    for (i, s) in samples.iter().enumerate() {
        for c in locate_in_complex(&cx, s).into_iter().flatten() {
            rooms[c.idx()].insert(i);
        }
    }
    let mut parent: Vec<usize> = (0..n).collect();
    // Each set's highest cell (field value), and the truth room nearest to a cell's centroid.
    let field = portalfind::decimate::clearance::CellField::new(&cx);
    let mut top: Vec<usize> = (0..n).collect();
    let nearest = |cell: usize| -> String {
        let g = cx.cells[cell].centroid();
        let mut best = (f64::INFINITY, String::new());
        for (i, s) in samples.iter().enumerate() {
            for p in s {
                let d = (0..3).map(|k| (p[k] - g[k]).powi(2)).sum::<f64>();
                if d < best.0 {
                    best = (d, c.truth.rooms[i].name.clone());
                }
            }
        }
        format!("{} at {:.2}", best.1, best.0.sqrt())
    };
    println!(
        "== {} {v}: {} rooms, {} active cells, {} steps traced, {} final cells",
        c.name,
        samples.len(),
        cx.stats.active_cells,
        steps.len(),
        dec.partition.len()
    );
    let names = |r: &BTreeSet<usize>| {
        r.iter()
            .map(|&i| c.truth.rooms[i].name.clone())
            .collect::<Vec<_>>()
            .join("+")
    };
    // TRACK=cell: also every step whose side holds that cell.
    let track: Option<usize> = std::env::var("TRACK").ok().map(|t| t.parse().expect("TRACK=cell id"));
    for s in &steps {
        let (x, y) = (find(&mut parent, s.a.idx()), find(&mut parent, s.b.idx()));
        let (rx, ry) = (rooms[x].clone(), rooms[y].clone());
        let join = !rx.is_empty() && !ry.is_empty() && rx.is_disjoint(&ry);
        let tracked = track.is_some_and(|t| {
            let r = find(&mut parent, t);
            r == x || r == y
        });
        if join
            || tracked
            || (s.kept && std::env::var("ALL").is_ok())
            || (s.kept && (!rx.is_empty() || !ry.is_empty()) && rx != ry && std::env::var("KEPT").is_ok())
        {
            println!(
                "  {} w {:.4} peaks {:.3}/{:.3} saddle {:.3} Ap {:.2} Av {:.2} sec {:.2}/{:.2} vol {:.1}/{:.1} [{}] | [{}]",
                if s.kept { "KEPT" } else { "JOIN" },
                s.weight,
                s.peaks[0],
                s.peaks[1],
                s.saddle,
                s.portal_area,
                s.opening,
                s.projected[0],
                s.projected[1],
                s.volumes[0],
                s.volumes[1],
                names(&rx),
                names(&ry)
            );
        }
        if join {
            println!(
                "      peak cells: #{} {} ({:.3}) | #{} {} ({:.3})",
                top[x],
                nearest(top[x]),
                field.value[top[x]],
                top[y],
                nearest(top[y]),
                field.value[top[y]]
            );
        }
        if !s.kept {
            let (lo, hi) = (x.min(y), x.max(y));
            if field.value[top[hi]] > field.value[top[lo]] {
                top[lo] = top[hi];
            }
            parent[hi] = lo;
            let r = rooms[hi].clone();
            rooms[lo].extend(r);
        }
    }
    println!("  stop: {}", dec.stop);
    // The final cells' neighbouring pairs: peaks, sampled and refined saddles.
    let part = &dec.partition;
    let room_of = |pc: usize| -> String {
        let mut r = BTreeSet::new();
        for (i, s) in samples.iter().enumerate() {
            for c in locate_in_complex(&cx, s).into_iter().flatten() {
                if part.cell_of(c) == Some(pc) {
                    r.insert(i);
                }
            }
        }
        names(&r)
    };
    let peak = |pc: usize| -> f64 {
        part.cells[pc]
            .pieces
            .iter()
            .map(|c| field.value[c.idx()])
            .fold(0.0, f64::max)
    };
    for mp in part.portals(&cx) {
        let (Some(i), Some(j)) = (part.cell_of(mp.cells[0]), part.cell_of(mp.cells[1])) else {
            continue;
        };
        let s0 = mp.portals.iter().map(|&k| field.passage[k]).fold(0.0, f64::max);
        let s1 = mp
            .portals
            .iter()
            .map(|&k| field.refined_passage(&cx, k))
            .fold(0.0, f64::max);
        let (pi, pj) = (peak(i), peak(j));
        println!(
            "  final {i}|{j} peaks {pi:.3}/{pj:.3} saddle {s0:.3} refined {s1:.3} w {:.4} area {:.2} [{}] | [{}]",
            pi.min(pj) / s1,
            mp.area,
            room_of(i),
            room_of(j)
        );
    }
}
