//! Diagnostics for one stress variant: `cargo run --release --example diag_stress -- FAMILY SEED VARIANT [ARG]`
//! (e.g. `thesis 0 noise 1e-6`): complex stats, validation, leaks with their paths.
use portalfind::suite::stress::{Variant, apply};
use portalfind::suite::{Family, case};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let fam: Family = match a[1].as_str() {
        "thesis" => Family::Thesis,
        "tessellated" => Family::Tessellated,
        "greedy" => Family::Greedy,
        "multistorey" => Family::MultiStorey,
        "caverns" => Family::Caverns,
        f => panic!("family {f}"),
    };
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
    let cx = portalfind::pipeline::complex_of_unchecked(&m).expect("complex");
    println!("{} {v}: {:#?}", c.name, cx.stats);
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
                c0.poly.volume(),
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
                for &t in &c0.poly.tags {
                    let pa = &cx.patches[t as usize];
                    if pa.cells.contains(&w[1]) {
                        println!(
                            "     patch {t} cells {:?} area {:.4e} verts {:?}",
                            pa.cells,
                            pa.polygon.area(),
                            pa.polygon.verts
                        );
                        for o in &pa.occluders {
                            println!(
                                "       occ src {:?} faces {} area {:.4e} {:?}",
                                o.source,
                                o.faces,
                                o.polygon.area(),
                                o.polygon.verts
                            );
                        }
                    }
                }
            }
        }
    }
}
