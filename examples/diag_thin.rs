//! Diagnostics for regions lost to the sliver rules: `cargo run --release --example
//! diag_thin -- MODEL.obj`. Counts cells that are thin, flat, face an occluder with and
//! without the sliver rule, and the volume of each class; and the occluder pieces.
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let m = portalfind::model::load_model(std::path::Path::new(&a[1])).expect("load");
    let cx = portalfind::pipeline::complex_of_unchecked(&m).expect("complex");
    let tol = cx.tol;
    println!("sliver width {:.3e}", tol.sliver_width());
    let (mut n, mut thin, mut flat, mut faces, mut faces_any, mut ext) = (0, 0, 0, 0, 0, 0);
    let (mut v_all, mut v_ext, mut v_thin) = (0.0, 0.0, 0.0);
    for (i, c) in cx.cells.iter().enumerate() {
        if !c.alive {
            continue;
        }
        n += 1;
        let id = portalfind::ids::CellId(i as u32);
        let v = c.volume();
        v_all += v;
        if cx.is_thin(id) {
            thin += 1;
            v_thin += v;
        }
        if c.flat {
            flat += 1;
        }
        if cx.faces_occluder(id) {
            faces += 1;
        }
        let any = c.tags().iter().any(|&t| {
            let p = &cx.patches[t as usize];
            let side = if p.cells[0] == id { 0 } else { 1 };
            p.occluders.iter().any(|o| o.faces == side)
        });
        if any {
            faces_any += 1;
        }
        if c.exterior {
            ext += 1;
            v_ext += v;
        }
    }
    println!("cells {n} thin {thin} flat {flat} faces-occluder {faces} faces-any-occluder {faces_any} exterior {ext}");
    println!("volume all {v_all:.4} exterior {v_ext:.4} thin {v_thin:.4}");
    let occ: usize = cx.patches.iter().filter(|p| p.alive).map(|p| p.occluders.len()).sum();
    let patches = cx.patches.iter().filter(|p| p.alive).count();
    println!("alive patches {patches} occluder pieces {occ}");
}
