//! The cells on each leak path of a stress variant's complex (`cargo run --release
//! --example diag_leakpath -- FAMILY SEED NOISE`): thin, flat, membrane, and the occluders
//! on each face (normal's |cos| to the largest face's).
use portalfind::base::vec::dot;
use portalfind::ids::CellId;
use portalfind::suite::stress::{Variant, apply};
use portalfind::suite::{Family, case};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let fam = Family::from_name(&a[1]).expect("family");
    let seed: u64 = a[2].parse().unwrap();
    let noise: f64 = a[3].parse().unwrap();
    let c = case(fam, seed).expect("case");
    let (vs, ps) = apply(Variant::Noise(noise), &c.model.vertices, &c.model.polygons);
    let m = portalfind::model::from_soup("v", vs, ps).expect("model");
    let t = portalfind::delaunay::Tetrahedralization::build(&m.vertices).expect("tetra");
    let cx = portalfind::complex::CellComplex::build(&m, &t);
    println!("leaks {}", cx.leaks.len());
    for l in &cx.leaks {
        for &id in &l.path {
            let cell = &cx.cells[id.idx()];
            let faces = cell.faces();
            let big = faces.iter().max_by(|a, b| a.area().total_cmp(&b.area())).unwrap();
            let n = big.plane().normalized().n;
            let mut desc = Vec::new();
            for (f, &t) in faces.iter().zip(cell.tags()) {
                let fnm = f.plane().normalized().n;
                let cos = dot(&n, &fnm).abs();
                let p = &cx.patches[t as usize];
                desc.push(format!("cos {cos:.3} area {:.2e} occ {}", f.area(), p.occluders.len()));
            }
            let pl = big.plane().normalized();
            let maxd = faces
                .iter()
                .flat_map(|f| f.verts.iter())
                .map(|v| pl.eval(v).abs())
                .fold(0.0f64, f64::max);
            println!(
                "  slab: max vertex distance {maxd:.3e} vs sliver width {:.3e}",
                cx.tol.sliver_width()
            );
            println!(
                "cell {} thin {} flat {} membrane {} vol {:.2e}: {}",
                id.0,
                cx.is_thin(id),
                cell.flat,
                cx.is_membrane(CellId(id.0)),
                cell.volume(),
                desc.join(" | ")
            );
        }
    }
}
