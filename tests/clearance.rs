//! The `clearance` heuristic (a persistence merge on the clearance field) on the thesis
//! models and e1m1.

mod common;
use common::locate;

use portalfind::complex::CellComplex;
use portalfind::decimate::clearance::DEFAULT_RATIO;
use portalfind::decimate::{Decimation, HeuristicKind, Partition, Settings, StopRule};

use portalfind::base::rigid::{rotate_789, rotate_xyz_deg_inverse};

/// The inverse of [`rotate_789`].
fn unrotate_789(p: [f64; 3]) -> [f64; 3] {
    rotate_xyz_deg_inverse(p, [7.0, 8.0, 9.0])
}

fn settings(stop: StopRule) -> Settings {
    Settings {
        heuristic: HeuristicKind::Clearance,
        stop,
        ..Settings::default()
    }
}

/// Rooms whose samples all lie in one final cell holding no other room's samples.
fn isolated(cx: &CellComplex, part: &Partition, rooms: &[Vec<[f64; 3]>]) -> usize {
    let cells: Vec<Vec<Option<usize>>> = rooms
        .iter()
        .map(|r| r.iter().map(|p| locate(cx, part, p)).collect())
        .collect();
    (0..rooms.len())
        .filter(|&i| {
            let c = cells[i][0];
            c.is_some()
                && cells[i].iter().all(|&x| x == c)
                && (0..rooms.len()).all(|j| j == i || cells[j].iter().all(|&x| x != c))
        })
        .count()
}

/// A thesis model moved by `f`, its complex, and `h`'s partition at the default stop.
fn thesis_at_default_stop(
    h: HeuristicKind,
    tm: &portalfind::generate::thesis::ThesisModel,
    f: &impl Fn([f64; 3]) -> [f64; 3],
) -> (CellComplex, Partition) {
    let verts: Vec<[f64; 3]> = tm.soup.vertices.iter().map(|&p| f(p)).collect();
    let m = portalfind::model::from_soup(tm.name, verts, tm.soup.polygons.clone()).unwrap();
    let cx = portalfind::pipeline::complex_of(&m).unwrap();
    let part = Decimation::run(
        &cx,
        &Settings {
            heuristic: h,
            ..settings(StopRule::Threshold(DEFAULT_RATIO))
        },
    )
    .partition;
    (cx, part)
}

/// (rooms isolated, final cells, final portal pairs) at the default stop.
fn at_default_stop(
    h: HeuristicKind,
    name: &str,
    f: impl Fn([f64; 3]) -> [f64; 3],
) -> (usize, usize, usize, usize, usize) {
    let tm = portalfind::generate::thesis::by_name(name).unwrap();
    let (cx, part) = thesis_at_default_stop(h, &tm, &f);
    let rooms: Vec<Vec<[f64; 3]>> = tm
        .truth
        .rooms
        .iter()
        .map(|r| r.samples.iter().map(|&p| f(p)).collect())
        .collect();
    (
        isolated(&cx, &part, &rooms),
        rooms.len(),
        part.len(),
        part.portals(&cx).len(),
        tm.truth.doorways.len(),
    )
}

/// The thesis models at the default stop, as shipped and after the 7°/8°/9° rotation with
/// an offset of 1e6: every room isolated, one cell per room, one portal pair per doorway.
/// (The caverns have 6 caves and 7 tunnels; the noisy model 4 rooms.) Both `clearance` and
/// `aperture` (the default).
#[test]
fn thesis_models_rooms_at_default_stop() {
    let mut failures = Vec::new();
    for h in [HeuristicKind::Clearance, HeuristicKind::Aperture] {
        for name in [
            "four_room_optimized",
            "four_room_tessellated",
            "four_room_distorted",
            "noisy",
            "caverns",
        ] {
            for (variant, moved) in [("as shipped", false), ("rotated 7/8/9 + 1e6", true)] {
                let got = if moved {
                    at_default_stop(h, name, |p| {
                        let q = rotate_789(p);
                        [q[0] + 1e6, q[1] + 1e6, q[2] + 1e6]
                    })
                } else {
                    at_default_stop(h, name, |p| p)
                };
                let (iso, rooms, cells, portals, doorways) = got;
                println!(
                    "{h} {name:<24} {variant:<22} rooms {iso}/{rooms} cells {cells} portals {portals} (doorways {doorways})"
                );
                if iso != rooms || cells != rooms || portals != doorways {
                    failures.push(format!("{h} {name} {variant}: {got:?}"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The thesis caverns' final portals at the default stop (`aperture`): (area, centroid
/// mapped back by `back`), sorted by centroid.
fn cavern_portals(f: impl Fn([f64; 3]) -> [f64; 3], back: impl Fn([f64; 3]) -> [f64; 3]) -> Vec<(f64, [f64; 3])> {
    let tm = portalfind::generate::thesis::by_name("caverns").unwrap();
    let (cx, part) = thesis_at_default_stop(HeuristicKind::Aperture, &tm, &f);
    let mut out: Vec<(f64, [f64; 3])> = part
        .portals(&cx)
        .iter()
        .map(|mp| {
            let (mut a, mut c) = (0.0, [0.0; 3]);
            for q in &mp.pieces {
                let (qa, qc) = (q.area(), back(q.centroid()));
                a += qa;
                for k in 0..3 {
                    c[k] += qa * qc[k];
                }
            }
            (mp.area, c.map(|v| v / a))
        })
        .collect();
    out.sort_by(|x, y| x.1[0].total_cmp(&y.1[0]).then(x.1[1].total_cmp(&y.1[1])));
    out
}

/// Thesis 4.3.4's rotation check at the default stop: the caverns rotated 7°/8°/9°, and
/// offset by 1e6, have the same 7 final portals as shipped (each tunnel's boundary at the
/// least-area cut between its caves, not where the collapse order put it).
#[test]
fn caverns_portals_are_the_same_rotated_and_offset() {
    let shipped = cavern_portals(|p| p, |p| p);
    assert_eq!(shipped.len(), 7);
    for (name, moved) in [
        ("rotated 7/8/9", cavern_portals(rotate_789, unrotate_789)),
        (
            "offset 1e6",
            cavern_portals(|p| p.map(|v| v + 1e6), |p| p.map(|v| v - 1e6)),
        ),
    ] {
        assert_eq!(moved.len(), 7, "{name}");
        for ((a, c), (b, d)) in shipped.iter().zip(&moved) {
            let dist = (0..3).map(|k| (c[k] - d[k]).powi(2)).sum::<f64>().sqrt();
            println!("{name}: area {a:.4} / {b:.4}, centroids {dist:.2e} apart");
            assert!(
                (a - b).abs() <= 1e-6 * a && dist <= 1e-6,
                "{name}: {a} at {c:?} vs {b} at {d:?}"
            );
        }
    }
}

#[test]
#[ignore = "exploration: e1m1 at the default ratio"]
fn e1m1_table() {
    let m = portalfind::model::load_model(std::path::Path::new("models/quake/e1m1.obj")).unwrap();
    let t0 = std::time::Instant::now();
    let cx = portalfind::pipeline::complex_of(&m).unwrap();
    let t1 = std::time::Instant::now();
    for r in [1.5, 1.8, 2.0, 2.5, 3.0, 4.0] {
        let d = Decimation::run(&cx, &settings(StopRule::Threshold(r)));
        println!(
            "ratio {r}: {} cells, {} portal pairs",
            d.partition.len(),
            d.partition.portals(&cx).len()
        );
    }
    let full = Decimation::run(&cx, &settings(StopRule::None));
    let mut ws: Vec<f64> = full.steps.iter().map(|s| s.weight).collect();
    ws.sort_by(|a, b| b.total_cmp(a));
    let top: Vec<String> = ws.iter().take(40).map(|w| format!("{w:.2}")).collect();
    println!("top weights {}", top.join(" "));
    println!(
        "complex {:.2} s; field and initial weights {:.2} s; merge {:.2} s; active cells {}",
        (t1 - t0).as_secs_f64(),
        full.stats.init_seconds,
        full.stats.collapse_seconds,
        full.stats.initial_cells
    );
}
