//! Diagnostics for a "model polygon crosses the interior of cell" failure:
//! `cargo run --release --example diag_cross -- FAMILY SEED VARIANT [ARG]` or `-- obj PATH`.
//! Prints the crossing cell (its tetrahedron, vertex distances to the polygon's support
//! plane, faces with their patches and occluders) and the polygon.
use portalfind::complex::ComplexError;
use portalfind::suite::stress::{Variant, apply};
use portalfind::suite::{Family, case};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let m = if a[1] == "obj" {
        portalfind::model::load_model(std::path::Path::new(&a[2])).expect("load")
    } else {
        let fam: Family = Family::from_name(&a[1]).unwrap_or_else(|| panic!("family {}", a[1]));
        let seed: u64 = a[2].parse().unwrap();
        let arg = a.get(4).map(|s| s.parse::<f64>().unwrap()).unwrap_or(1.0);
        let v = match a[3].as_str() {
            "base" => Variant::Base,
            "noise" => Variant::Noise(arg),
            "rot789" => Variant::Rotate789,
            v => panic!("variant {v}"),
        };
        let c = case(fam, seed).expect("case");
        let (vs, ps) = apply(v, &c.model.vertices, &c.model.polygons);
        portalfind::model::from_soup(&c.name, vs, ps).expect("load")
    };
    let tol = m.tolerances;
    println!(
        "scale {} weld {:.3e} coplanar {:.3e} area {:.3e} sliver {:.3e}",
        tol.scale,
        tol.weld_abs(),
        tol.coplanar_abs(),
        tol.area_abs(),
        tol.sliver_width()
    );
    let cx = portalfind::pipeline::complex_of_unchecked(&m).expect("complex");
    println!(
        "tets {} split {} refused {} sealed {} unplaced {} neighbour {}",
        cx.stats.tetrahedra,
        cx.stats.cells_split,
        cx.stats.splits_refused,
        cx.stats.cells_sealed,
        cx.stats.unplaced_fragments,
        cx.stats.neighbour_cuts
    );
    // DIAG_POLY=P DIAG_CELLS=a,b: those cells' vertex distances to polygon P's plane and
    // their faces' patches (neighbours, occluder sources).
    if let (Ok(pp), Ok(cs)) = (std::env::var("DIAG_POLY"), std::env::var("DIAG_CELLS")) {
        let pl = cx.polygon_planes[pp.parse::<usize>().unwrap()].normalized();
        for c in cs.split(',').map(|x| x.parse::<usize>().unwrap()) {
            let cell = &cx.cells[c];
            println!(
                "cell {c} alive {} tet {:?} vol {:.3e}",
                cell.alive,
                cell.tet,
                cell.volume()
            );
            for (fi, f) in cell.poly().faces.iter().enumerate() {
                let t = cell.tags()[fi] as usize;
                let pa = &cx.patches[t];
                println!(
                    "  face {fi} patch {t} cells {:?} area {:.3e} occ {:?} d {:?}",
                    pa.cells,
                    f.area(),
                    pa.occluders.iter().map(|o| o.source.0).collect::<Vec<_>>(),
                    f.verts
                        .iter()
                        .map(|v| format!("{:.2e}", pl.eval(v)))
                        .collect::<Vec<_>>()
                );
            }
        }
    }
    let e = cx.validate(&m);
    println!("validate: {:?}", e.as_ref().err().map(|e| e.to_string()));
    let Err(ComplexError::Crossing { polygon, cell, .. }) = e else {
        return;
    };
    let pl = cx.polygon_planes[polygon as usize].normalized();
    let p = &m.polygons[polygon as usize];
    println!("polygon {polygon} plane {:?}", pl);
    for v in &p.verts {
        let x = m.vertices[v.idx()];
        println!("  pv {:?} d {:.3e}", x, pl.eval(&x));
    }
    for (k, q) in m.polygons.iter().enumerate() {
        let same = cx.polygon_planes[k].normalized();
        let dot: f64 = (0..3).map(|i| same.n[i] * pl.n[i]).sum();
        if k != polygon as usize && dot.abs() > 1.0 - 1e-9 && (same.d * dot.signum() - pl.d).abs() < 1e-9 {
            let _ = q;
            print!(" samesupport {k}");
        }
    }
    println!();
    let c = &cx.cells[cell as usize];
    println!(
        "cell {cell} tet {:?} flat {} vol {:.3e} faces {}",
        c.tet,
        c.flat,
        c.volume(),
        c.poly().faces.len()
    );
    for (fi, f) in c.poly().faces.iter().enumerate() {
        let t = c.tags()[fi] as usize;
        let pa = &cx.patches[t];
        println!(
            " face {fi} tag {t} cells {:?} area {:.3e} occ {:?}",
            pa.cells,
            f.area(),
            pa.occluders
                .iter()
                .map(|o| (o.source.0, o.polygon.area()))
                .collect::<Vec<_>>()
        );
        for v in &f.verts {
            println!("    {:?} d {:.3e}", v, pl.eval(v));
        }
    }
    let plane = cx.polygon_planes[polygon as usize];
    let ds: Vec<f64> = c.vertices().iter().map(|v| pl.eval(v)).collect();
    println!(
        " cell vertex distances {:?}",
        ds.iter().map(|d| format!("{d:.2e}")).collect::<Vec<_>>()
    );
    let proj = portalfind::geom::ConvexPolygon::new(
        p.verts
            .iter()
            .map(|v| {
                let x = m.vertices[v.idx()];
                let d = pl.eval(&x);
                [x[0] - d * pl.n[0], x[1] - d * pl.n[1], x[2] - d * pl.n[2]]
            })
            .collect(),
    );
    println!(" clip {:?}", c.poly().clip_polygon(&proj, &tol).map(|q| q.area()));
    for (name, t) in [("tol", tol), ("sealing", tol.sealing())] {
        match c.poly().cut(&plane, &t, 0) {
            portalfind::geom::Cut::Split(s) => println!(
                " cut {name}: split vols {:.3e} {:.3e} section {:.3e} on_dist {:.3e} checks {:?} {:?}",
                s.front.volume(),
                s.back.volume(),
                s.section.area(),
                s.on_dist,
                s.front.check(&tol).err(),
                s.back.check(&tol).err()
            ),
            portalfind::geom::Cut::Front => println!(" cut {name}: Front"),
            portalfind::geom::Cut::Back => println!(" cut {name}: Back"),
        }
    }
    // Other live cells of the same tetrahedron.
    for (ci, o) in cx.cells.iter().enumerate() {
        if o.alive && o.tet == c.tet && ci != cell as usize {
            let ds: Vec<f64> = o.vertices().iter().map(|v| pl.eval(v)).collect();
            let (lo, hi) = ds
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &d| (a.min(d), b.max(d)));
            println!(" sibling {ci} vol {:.3e} d [{lo:.3e}, {hi:.3e}]", o.volume());
        }
    }
}
