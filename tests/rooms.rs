//! The clearance-persistence merge (`portalfind::rooms`) on the thesis models.

use portalfind::complex::{CellComplex, Subdivision};
use portalfind::decimate::{Decimation, Partition, StopRule};
use portalfind::rooms::{CellField, DEFAULT_RATIO, merge};

fn locate(cx: &CellComplex, p: &[f64; 3]) -> Option<u32> {
    cx.active_cells()
        .find(|(_, c)| c.poly.contains(p, &cx.tol))
        .map(|(id, _)| id.0)
}

/// Rooms whose samples all lie in one final cell holding no other room's samples.
fn isolated(cx: &CellComplex, part: &Partition, rooms: &[Vec<[f64; 3]>]) -> usize {
    let cells: Vec<Vec<Option<usize>>> = rooms
        .iter()
        .map(|r| {
            r.iter()
                .map(|p| locate(cx, p).and_then(|c| part.cell_of(portalfind::CellId(c))))
                .collect()
        })
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

fn rotate_789(p: [f64; 3]) -> [f64; 3] {
    let (sx, cx) = 7f64.to_radians().sin_cos();
    let (sy, cy) = 8f64.to_radians().sin_cos();
    let (sz, cz) = 9f64.to_radians().sin_cos();
    let [mut x, mut y, mut z] = p;
    (y, z) = (cx * y - sx * z, sx * y + cx * z);
    (x, z) = (cy * x + sy * z, -sy * x + cy * z);
    [cz * x - sz * y, sz * x + cz * y, z]
}

/// (rooms isolated, final cells, final portal pairs) at the default stop.
fn at_default_stop(name: &str, f: impl Fn([f64; 3]) -> [f64; 3]) -> (usize, usize, usize, usize, usize) {
    let tm = portalfind::thesis_models::by_name(name).unwrap();
    let verts: Vec<[f64; 3]> = tm.soup.vertices.iter().map(|&p| f(p)).collect();
    let m = portalfind::model::from_soup(tm.name, verts, tm.soup.polygons.clone()).unwrap();
    let (cx, _, _) = portalfind::experiment::build_cells(&m, Subdivision::Delaunay).unwrap();
    let field = CellField::new(&m, &cx);
    let mg = merge(&cx, &field, StopRule::Threshold(DEFAULT_RATIO));
    let part = Decimation::replay(&cx, &mg.steps).unwrap();
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
/// (The caverns have 6 caves and 7 tunnels; the noisy model 4 rooms.)
#[test]
fn thesis_models_rooms_at_default_stop() {
    let mut failures = Vec::new();
    for name in [
        "four_room_optimized",
        "four_room_tessellated",
        "four_room_distorted",
        "noisy",
        "caverns",
    ] {
        for (variant, moved) in [("as shipped", false), ("rotated 7/8/9 + 1e6", true)] {
            let got = if moved {
                at_default_stop(name, |p| {
                    let q = rotate_789(p);
                    [q[0] + 1e6, q[1] + 1e6, q[2] + 1e6]
                })
            } else {
                at_default_stop(name, |p| p)
            };
            let (iso, rooms, cells, portals, doorways) = got;
            println!(
                "{name:<24} {variant:<22} rooms {iso}/{rooms} cells {cells} portals {portals} (doorways {doorways})"
            );
            if iso != rooms || cells != rooms || portals != doorways {
                failures.push(format!("{name} {variant}: {got:?}"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
#[ignore = "exploration: prints a table"]
fn thesis_models_table() {
    for tm in portalfind::thesis_models::all() {
        let m = portalfind::model::from_soup(tm.name, tm.soup.vertices.clone(), tm.soup.polygons.clone()).unwrap();
        let (cx, _, _) = portalfind::experiment::build_cells(&m, Subdivision::Delaunay).unwrap();
        let field = CellField::new(&m, &cx);
        let full = merge(&cx, &field, StopRule::None);
        let mut top: Vec<f64> = full.steps.iter().map(|s| s.weight).collect();
        top.sort_by(|a, b| b.total_cmp(a));
        let top: Vec<String> = top.iter().take(14).map(|w| format!("{w:.2}")).collect();
        println!("{:<24} top weights {}", tm.name, top.join(" "));
        let mg = merge(&cx, &field, StopRule::Threshold(DEFAULT_RATIO));
        let part = Decimation::replay(&cx, &mg.steps).unwrap();
        let rooms: Vec<Vec<[f64; 3]>> = tm.truth.rooms.iter().map(|r| r.samples.clone()).collect();
        let iso = isolated(&cx, &part, &rooms);
        let ws: Vec<String> = mg
            .steps
            .iter()
            .rev()
            .take(8)
            .map(|s| format!("{:.2}", s.weight))
            .collect();
        println!(
            "{:<24} cells {:>6} final {:>4} rooms {}/{}  stop {}  last weights {}",
            tm.name,
            mg.initial_cells,
            part.len(),
            iso,
            rooms.len(),
            mg.stop,
            ws.join(" ")
        );
    }
}

#[test]
#[ignore = "exploration: prints the surviving peaks of the caverns"]
fn caverns_peaks() {
    let tm = portalfind::thesis_models::by_name("caverns").unwrap();
    let m = portalfind::model::from_soup(tm.name, tm.soup.vertices.clone(), tm.soup.polygons.clone()).unwrap();
    let (cx, _, _) = portalfind::experiment::build_cells(&m, Subdivision::Delaunay).unwrap();
    let field = CellField::new(&m, &cx);
    let mg = merge(&cx, &field, StopRule::Threshold(DEFAULT_RATIO));
    let part = Decimation::replay(&cx, &mg.steps).unwrap();
    for mc in part.cells.iter().take(30) {
        // The peak cell of the component.
        let best = mc
            .pieces
            .iter()
            .max_by(|a, b| field.value[a.idx()].total_cmp(&field.value[b.idx()]))
            .unwrap();
        let c = &cx.cells[best.idx()];
        let thick = 3.0 * c.poly.volume() / c.poly.surface_area();
        let (lo, hi) = c.poly.aabb();
        let ext = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
        let links: Vec<String> = cx
            .portals
            .iter()
            .enumerate()
            .filter(|(_, p)| p.cells.contains(best))
            .map(|(k, p)| {
                let o = if p.cells[0] == *best { p.cells[1] } else { p.cells[0] };
                format!("{:.2}->{:.2}", field.passage[k], field.value[o.idx()])
            })
            .collect();
        println!(
            "comp {:>5} cells {:>4} vol {:>8.3} peak {:.3} thick {:.3} extent {:.2} links {}",
            mc.id.0,
            mc.pieces.len(),
            mc.volume,
            field.value[best.idx()],
            thick,
            ext,
            links.join(" ")
        );
    }
}

#[test]
#[ignore = "exploration: e1m1 at the default ratio"]
fn e1m1_table() {
    let m = portalfind::model::load_model(std::path::Path::new("models/quake/e1m1.obj")).unwrap();
    let t0 = std::time::Instant::now();
    let (cx, _, _) = portalfind::experiment::build_cells(&m, Subdivision::Delaunay).unwrap();
    let t1 = std::time::Instant::now();
    let field = CellField::new(&m, &cx);
    let t2 = std::time::Instant::now();
    let full = merge(&cx, &field, StopRule::None);
    let t3 = std::time::Instant::now();
    let mut ws: Vec<f64> = full.steps.iter().map(|s| s.weight).collect();
    ws.sort_by(|a, b| b.total_cmp(a));
    for r in [1.5, 1.8, 2.0, 2.5, 3.0, 4.0] {
        println!(
            "ratio {r}: {} cells",
            full.initial_cells - ws.iter().filter(|&&w| w < r).count()
        );
    }
    let top: Vec<String> = ws.iter().take(60).map(|w| format!("{w:.2}")).collect();
    println!("top {}", top.join(" "));
    println!(
        "complex {:.2}s field {:.2}s merge {:.2}s cells {}",
        (t1 - t0).as_secs_f64(),
        (t2 - t1).as_secs_f64(),
        (t3 - t2).as_secs_f64(),
        full.initial_cells
    );
}
