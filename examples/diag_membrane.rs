//! Membranes of a model's complex (`cargo run --release --example diag_membrane --
//! MODEL.obj`): flat cells, and cells thinner than the sliver width whose side faces
//! (normal within |cos| 0.99 of the largest face's, the complex's `THIN_ATTACH_COS`) do or
//! do not carry an occluder, with their volumes and how many of each were removed as
//! exterior.
use portalfind::base::vec::dot;
use portalfind::ids::CellId;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let m = portalfind::model::load_model(std::path::Path::new(&a[1])).expect("load");
    let cx = portalfind::pipeline::complex_of_unchecked(&m).expect("complex");
    let (mut flat, mut sided, mut bare) = ((0, 0.0, 0), (0, 0.0, 0), (0, 0.0, 0));
    for (i, c) in cx.cells.iter().enumerate() {
        let id = CellId(i as u32);
        if !c.alive || !cx.is_membrane(id) {
            continue;
        }
        let v = c.volume();
        let ext = usize::from(c.exterior);
        if c.flat {
            flat = (flat.0 + 1, flat.1 + v, flat.2 + ext);
            continue;
        }
        let faces = c.faces();
        let big = faces.iter().max_by(|a, b| a.area().total_cmp(&b.area())).unwrap();
        let n = big.plane().normalized().n;
        let tags = c.tags();
        let side_occluded = faces.iter().zip(tags).any(|(f, &t)| {
            let fnrm = f.plane().normalized().n;
            let cos = dot(&n, &fnrm).abs();
            cos >= 0.99 && !cx.patches[t as usize].occluders.is_empty()
        });
        if side_occluded {
            sided = (sided.0 + 1, sided.1 + v, sided.2 + ext);
        } else {
            bare = (bare.0 + 1, bare.1 + v, bare.2 + ext);
        }
    }
    println!("flat membranes {} (volume {:.3e}, exterior {})", flat.0, flat.1, flat.2);
    println!(
        "thin, a side face occluded {} (volume {:.3e}, exterior {})",
        sided.0, sided.1, sided.2
    );
    println!(
        "thin, no side face occluded {} (volume {:.3e}, exterior {})",
        bare.0, bare.1, bare.2
    );
}
