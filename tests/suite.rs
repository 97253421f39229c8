//! The ground-truth suite (issue 15): deterministic generation, clean models, truth samples
//! in their rooms, the accuracy metrics on hand-made partitions, and (ignored) the baseline
//! of the thesis heuristics on the whole suite.

use portalfind::CellId;
use portalfind::complex::CellComplex;
use portalfind::decimate::{Estimator, HeuristicKind};
use portalfind::generate::scenes::Soup;
use portalfind::suite::bench::{run_case, settings_at_rooms, table, write_all};
use portalfind::suite::metrics::{MetricOptions, partition_from_groups, score};
use portalfind::suite::{
    Aabb, Doorway, Family, Half, Membership, Similarity, SuiteTruth, TruthRoom, case, family_cases, suite,
};

fn complex_of(soup: &Soup) -> CellComplex {
    let m = portalfind::model::from_soup("test", soup.vertices.clone(), soup.polygons.clone()).expect("loads");
    portalfind::pipeline::complex_of(&m).expect("builds")
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn suite_is_deterministic_and_large_enough() {
    let a = suite();
    let b = suite();
    assert!(a.len() >= 60, "{} models", a.len());
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.name, y.name);
        assert_eq!(x.model.polygons, y.model.polygons, "{}", x.name);
        let bits = |s: &Soup| s.vertices.iter().flat_map(|v| v.map(f64::to_bits)).collect::<Vec<_>>();
        assert_eq!(bits(&x.model), bits(&y.model), "{}", x.name);
        assert_eq!(x.truth, y.truth, "{}", x.name);
        assert_eq!(x.half, if x.seed % 2 == 0 { Half::Tune } else { Half::Report });
    }
    // Different seeds give different models.
    let t = family_cases(Family::Tessellated);
    assert_ne!(t[0].model.polygons, t[4].model.polygons);
    for f in Family::ALL {
        let n = a.iter().filter(|c| c.family == f).count();
        let report = a.iter().filter(|c| c.family == f && c.half == Half::Report).count();
        assert!(n >= 6 && report * 2 == n, "{f}: {n} models, {report} report");
    }
}

#[test]
fn models_load_cleanly_and_samples_lie_in_their_rooms() {
    let mut errors = Vec::new();
    let mut lines = Vec::new();
    for f in Family::ALL {
        let mut tris = Vec::new();
        let mut rooms = Vec::new();
        for c in family_cases(f) {
            match c.check() {
                Ok(chk) => {
                    if chk.triangles > 20_000 {
                        errors.push(format!("{}: {} triangles", c.name, chk.triangles));
                    }
                    tris.push(chk.triangles);
                    rooms.push(c.truth.rooms.len());
                    lines.push(format!(
                        "{:32} {:6} tris, {:2} rooms, {:2} doorways, open {:5}, T {:5}",
                        c.name,
                        chk.triangles,
                        c.truth.rooms.len(),
                        c.truth.doorways.len(),
                        chk.report.open_edges,
                        chk.report.t_junctions
                    ));
                }
                Err(e) => errors.push(e),
            }
        }
        tris.sort_unstable();
        if !tris.is_empty() {
            lines.push(format!(
                "== {f}: {} models, triangles min {} median {} max {}, rooms {}..{} (total {})",
                tris.len(),
                tris[0],
                tris[tris.len() / 2],
                tris[tris.len() - 1],
                rooms.iter().min().unwrap(),
                rooms.iter().max().unwrap(),
                rooms.iter().sum::<usize>()
            ));
        }
    }
    println!("{}", lines.join("\n"));
    assert!(errors.is_empty(), "{}", errors.join("\n"));
}

#[test]
fn one_case_per_kind_runs_without_leaks() {
    // A small building and a small cavern through the whole pipeline: no leaks, every truth
    // sample located in an active cell.
    // (Caverns may leak: the complex's weakness on marching-tetrahedra meshes; see the
    // baseline's leak counts.)
    for c in [case(Family::Tessellated, 6).unwrap(), case(Family::Caverns, 2).unwrap()] {
        let s = settings_at_rooms(&c, HeuristicKind::Volume, Estimator::Hull);
        let r = run_case(&c, &s).expect("runs");
        if c.family != Family::Caverns {
            assert_eq!(r.leaks, 0, "{}", c.name);
        }
        assert_eq!(r.accuracy.unlocated_samples, 0, "{}", c.name);
        assert_eq!(r.accuracy.final_cells, c.truth.rooms.len(), "{}", c.name);
        // Most of the active volume lies in rooms, for the building (a leaking cavern keeps
        // the outside active).
        if c.family != Family::Caverns {
            assert!(
                r.accuracy.room_volume_share > 0.5,
                "{}: {}",
                c.name,
                r.accuracy.room_volume_share
            );
        }
    }
}

// ---------------------------------------------------------------------------------------
// Metrics on hand-made partitions.

/// Three disjoint closed box rooms: A (volume 48), B (36), C (12).
const BOXES: [([f64; 3], [f64; 3]); 3] = [
    ([0.0, 0.0, 0.0], [4.0, 4.0, 3.0]),
    ([6.0, 0.0, 0.0], [9.0, 4.0, 3.0]),
    ([11.0, 0.0, 0.0], [13.0, 2.0, 3.0]),
];
const VOLS: [f64; 3] = [48.0, 36.0, 12.0];

fn three_boxes() -> CellComplex {
    let mut s = Soup::default();
    for (lo, hi) in BOXES {
        s.boxed(lo, hi, true);
    }
    complex_of(&s)
}

fn samples_of(b: &Aabb) -> Vec<[f64; 3]> {
    [[0.5, 0.5, 0.5], [0.25, 0.25, 0.6], [0.75, 0.75, 0.6], [0.25, 0.75, 0.4]]
        .iter()
        .map(|&f| b.at(f))
        .collect()
}

/// Truth with the given rooms as boxes (identity frame).
fn box_truth(rooms: &[Aabb]) -> SuiteTruth {
    SuiteTruth {
        rooms: rooms
            .iter()
            .enumerate()
            .map(|(i, b)| TruthRoom {
                name: format!("room {i}"),
                samples: samples_of(b),
            })
            .collect(),
        doorways: Vec::new(),
        membership: Membership::Boxes {
            frame: Similarity::IDENTITY,
            rooms: rooms.iter().map(|b| vec![*b]).collect(),
            solids: Vec::new(),
        },
    }
}

/// Active cells grouped by the box holding their centroid.
fn cells_by(cx: &CellComplex, key: impl Fn([f64; 3]) -> usize, n: usize) -> Vec<Vec<CellId>> {
    let mut g = vec![Vec::new(); n];
    for (id, c) in cx.active_cells() {
        g[key(c.centroid())].push(id);
    }
    g
}

fn box_index(p: [f64; 3]) -> usize {
    BOXES
        .iter()
        .position(|(lo, hi)| (0..3).all(|k| p[k] >= lo[k] && p[k] <= hi[k]))
        .expect("a cell lies in a box")
}

fn aabbs() -> Vec<Aabb> {
    BOXES.iter().map(|&(lo, hi)| Aabb::new(lo, hi)).collect()
}

#[test]
fn perfect_partition_scores_one() {
    let cx = three_boxes();
    assert!(
        cx.active_cells().count() > 3,
        "the boxes are cut into several cells each"
    );
    let truth = box_truth(&aabbs());
    let p = partition_from_groups(&cx, &cells_by(&cx, box_index, 3));
    assert_eq!(p.len(), 3);
    let a = score(&cx, &p, &truth, &MetricOptions::default());
    assert_eq!(a.rooms_isolated, 3);
    assert_eq!(a.spike_cells, 0);
    for v in [a.precision_micro, a.precision_macro, a.recall_micro, a.recall_macro] {
        assert!(close(v, 1.0, 1e-12), "{a:?}");
    }
    assert!(close(a.cells_per_room, 1.0, 0.0));
    assert!(close(a.room_volume_share, 1.0, 1e-9));
    // The unmerged complex: every cell is precise, rooms are split (recall < 1), nothing
    // isolated.
    let none = partition_from_groups(&cx, &[]);
    let b = score(&cx, &none, &truth, &MetricOptions::default());
    assert!(close(b.precision_micro, 1.0, 1e-12));
    assert!(b.recall_micro < 0.9, "{}", b.recall_micro);
    assert!(b.rooms_isolated < 3);
}

#[test]
fn merging_two_rooms_scores_what_the_formulas_say() {
    let cx = three_boxes();
    let truth = box_truth(&aabbs());
    let g = cells_by(&cx, box_index, 3);
    let merged = partition_from_groups(&cx, &[[g[0].clone(), g[1].clone()].concat(), g[2].clone()]);
    assert_eq!(merged.len(), 2);
    let a = score(&cx, &merged, &truth, &MetricOptions::default());
    let [v1, v2, v3] = VOLS;
    // Cell {A, B}: precision max(V1, V2) / (V1 + V2); cell {C}: 1.
    let p_ab = v1.max(v2) / (v1 + v2);
    assert!(
        close(a.precision_macro, (p_ab + 1.0) / 2.0, 1e-9),
        "{}",
        a.precision_macro
    );
    assert!(
        close(a.precision_micro, (v1.max(v2) + v3) / (v1 + v2 + v3), 1e-9),
        "{}",
        a.precision_micro
    );
    // Every room lies wholly in one cell.
    assert!(close(a.recall_micro, 1.0, 1e-9) && close(a.recall_macro, 1.0, 1e-9));
    // A and B share a cell: neither is isolated; C is.
    assert_eq!(a.rooms_isolated, 1);
    assert!(a.per_room[2].isolated && !a.per_room[0].isolated);
    assert!(close(a.cells_per_room, 2.0 / 3.0, 1e-12));

    // Splitting room A in two halves (x < 2, x >= 2, by cell centroid): A's recall is its
    // larger half's share.
    let mut halves = [Vec::new(), Vec::new()];
    for &c in &g[0] {
        let x = cx.cells[c.idx()].centroid()[0];
        halves[usize::from(x >= 2.0)].push(c);
    }
    let vol = |cs: &[CellId]| cs.iter().map(|c| cx.cells[c.idx()].volume()).sum::<f64>();
    let best = vol(&halves[0]).max(vol(&halves[1]));
    let split = partition_from_groups(&cx, &[halves[0].clone(), halves[1].clone(), g[1].clone(), g[2].clone()]);
    let s = score(&cx, &split, &truth, &MetricOptions::default());
    assert!(
        close(s.per_room[0].recall, best / v1, 1e-9),
        "{} vs {}",
        s.per_room[0].recall,
        best / v1
    );
    assert!(close(s.recall_macro, (best / v1 + 2.0) / 3.0, 1e-9));
    assert!(close(s.recall_micro, (best + v2 + v3) / (v1 + v2 + v3), 1e-9));
    assert!(close(s.precision_micro, 1.0, 1e-9));
}

#[test]
fn precision_by_sampling_where_rooms_cut_through_cells() {
    // Room A's box as two truth rooms, x < 2.2 and x > 2.2: complex cells straddle the
    // boundary, so the shares come from the volume samples. One cell for the whole box:
    // precision 2.2 / 4 = 0.55 of its volume (within sampling tolerance), recall 1.
    let cx = three_boxes();
    let rooms = [
        Aabb::new([0.0, 0.0, 0.0], [2.2, 4.0, 3.0]),
        Aabb::new([2.2, 0.0, 0.0], [4.0, 4.0, 3.0]),
    ];
    let truth = box_truth(&rooms);
    let g = cells_by(&cx, box_index, 3);
    let p = partition_from_groups(&cx, &[g[0].clone()]);
    let idx = p.cell_of(g[0][0]).unwrap();
    let a = score(&cx, &p, &truth, &MetricOptions::default());
    assert!(close(a.precision_micro, 0.55, 0.01), "{}", a.precision_micro);
    assert!(close(a.recall_micro, 1.0, 1e-9));
    assert_eq!(a.per_room[0].cell, Some(idx));
    assert_eq!(a.rooms_isolated, 0);
    // Room volumes measured by sampling.
    assert!(close(a.per_room[0].volume, 2.2 * 12.0, 0.3), "{}", a.per_room[0].volume);
    assert!(close(a.per_room[1].volume, 1.8 * 12.0, 0.3), "{}", a.per_room[1].volume);
    // Boxes B and C are in no room: their cells hold no sample (spikes), and the room
    // volume share is 48 / 96.
    assert!(close(a.room_volume_share, 0.5, 1e-9));
}

#[test]
fn spike_cell_counts_with_its_volume_share() {
    let cx = three_boxes();
    // Only A and B are rooms; box C is a cell holding no sample.
    let truth = box_truth(&aabbs()[..2]);
    let p = partition_from_groups(&cx, &cells_by(&cx, box_index, 3));
    let a = score(&cx, &p, &truth, &MetricOptions::default());
    assert_eq!(a.spike_cells, 1);
    let total: f64 = VOLS.iter().sum();
    assert!(
        close(a.spike_volume_share, VOLS[2] / total, 1e-9),
        "{}",
        a.spike_volume_share
    );
    assert_eq!(a.rooms_isolated, 2);
    assert!(close(a.precision_micro, 1.0, 1e-12) && close(a.recall_micro, 1.0, 1e-12));
    // Unmerged: many spikes, and they carry most of the volume.
    let none = partition_from_groups(&cx, &[]);
    let b = score(&cx, &none, &truth, &MetricOptions::default());
    assert!(b.spike_cells > 3 && b.spike_volume_share > a.spike_volume_share);
}

#[test]
fn doorways_matched_only_by_a_portal_between_the_rooms() {
    // scenes::two_rooms: A = [0,4]x[0,4]x[0,3], B = [5,9]x..., a corridor between them
    // (x in [4,5], y in [1.5,2.5], z in [0,2]) that belongs to no room.
    let cx = complex_of(&portalfind::generate::scenes::two_rooms());
    let rooms = [
        Aabb::new([0.0, 0.0, 0.0], [4.0, 4.0, 3.0]),
        Aabb::new([5.0, 0.0, 0.0], [9.0, 4.0, 3.0]),
    ];
    let mut truth = box_truth(&rooms);
    truth.doorways.push(Doorway {
        rooms: [0, 1],
        polygon: vec![[4.5, 1.5, 0.0], [4.5, 2.5, 0.0], [4.5, 2.5, 2.0], [4.5, 1.5, 2.0]],
    });
    let by_x = |split: &[f64]| cells_by(&cx, |c| split.iter().filter(|&&s| c[0] >= s).count(), split.len() + 1);
    // Split at the corridor's middle: matched, both isolated, precision and recall ~1.
    let p = partition_from_groups(&cx, &by_x(&[4.5]));
    let a = score(&cx, &p, &truth, &MetricOptions::default());
    assert_eq!((a.doorways, a.doorways_matched, a.rooms_isolated), (1, 1, 2));
    assert!(a.precision_micro > 0.999 && a.recall_micro > 0.999, "{a:?}");
    // The corridor as a cell of its own: the rooms' cells share no portal.
    let p3 = partition_from_groups(&cx, &by_x(&[4.0, 5.0]));
    let b = score(&cx, &p3, &truth, &MetricOptions::default());
    assert_eq!((b.doorways_matched, b.rooms_isolated, b.spike_cells), (0, 2, 1));
    // One cell: nothing matched or isolated; precision is the larger room's share.
    let one = partition_from_groups(&cx, &by_x(&[]));
    let c = score(&cx, &one, &truth, &MetricOptions::default());
    assert_eq!((c.doorways_matched, c.rooms_isolated), (0, 0));
    assert!(close(c.precision_micro, 0.5, 0.01), "{}", c.precision_micro);
    // The conversion to the experiments' ground truth keeps rooms and doorways.
    let gt = truth.to_ground_truth();
    assert_eq!(gt.rooms.len(), 2);
    assert_eq!(gt.doorways, truth.doorways);
}

// ---------------------------------------------------------------------------------------
// The baseline.

/// The thesis heuristics on the whole suite at `cells:K`; prints the table and writes
/// `cases.csv`, `summary.csv`, `accuracy.json`, `table.md` into `$PF_SUITE_OUT`
/// (default `target/suite_baseline`). Run with
/// `cargo test --release --test suite -- --ignored --nocapture baseline`.
#[test]
#[ignore]
fn baseline_thesis_heuristics() {
    let configs = [
        (HeuristicKind::Aspect, Estimator::Hull),
        (HeuristicKind::Refined, Estimator::Hull),
        (HeuristicKind::Volume, Estimator::Hull),
    ];
    let cases = suite();
    let mut results = Vec::new();
    for (h, e) in configs {
        for c in &cases {
            let s = settings_at_rooms(c, h, e);
            match run_case(c, &s) {
                Ok(r) => {
                    eprintln!(
                        "{:10} {:32} {:6} tris {:7} cells  isolated {:2}/{:2}  P {:.3} R {:.3}  spike {:.3}  {:.2}s (+{:.2}s score)",
                        r.config.split(' ').next().unwrap_or(""),
                        r.name,
                        r.triangles,
                        r.complex_cells,
                        r.accuracy.rooms_isolated,
                        r.accuracy.rooms,
                        r.accuracy.precision_micro,
                        r.accuracy.recall_micro,
                        r.accuracy.spike_volume_share,
                        r.seconds_pipeline(),
                        r.seconds_score
                    );
                    results.push(r);
                }
                Err(err) => panic!("{}: {err:#}", c.name),
            }
        }
    }
    let out = std::env::var_os("PF_SUITE_OUT")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/suite_baseline"));
    write_all(&results, &out).expect("writes the results");
    println!("{}", table(&results));
}
