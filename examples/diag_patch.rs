//! Diagnostics for a coverage failure ("patch N: area .. but open .."):
//! `cargo run --release --example diag_patch -- PATH PATCH`. Prints the patch's loop, its
//! occluders, its two cells' faces and the open pieces the subtraction leaves.
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let m = portalfind::model::load_model(std::path::Path::new(&a[1])).expect("load");
    let pi: usize = a[2].parse().unwrap();
    let cx = portalfind::pipeline::complex_of_unchecked(&m).expect("complex");
    let p = &cx.patches[pi];
    println!(
        "patch {pi} cells {:?} alive {} area {:.6e}",
        p.cells,
        p.alive,
        p.polygon.area()
    );
    for v in &p.polygon.verts {
        println!("  v {:?}", v);
    }
    for o in p.occluders.iter() {
        println!(" occluder area {:.6e}", o.polygon.area());
        for v in &o.polygon.verts {
            println!("  v {:?}", v);
        }
    }
    for &c in &p.cells {
        if c == portalfind::complex::HULL {
            continue;
        }
        let cell = &cx.cells[c.0 as usize];
        println!(
            "cell {:?} alive {} volume {:.3e} tags {:?}",
            c,
            cell.alive,
            cell.volume(),
            cell.tags()
        );
        for f in cell.faces().iter() {
            println!("  face n {:?} area {:.3e}: {:?}", f.normal(), f.area(), f.verts);
        }
    }
    let (pieces, s, sa) = cx.open_pieces(portalfind::complex::PatchId(pi as u32));
    println!("open {} pieces, slivers {s} {sa:.3e}", pieces.len());
    for q in pieces {
        println!(" piece area {:.6e}", q.area());
        for v in &q.verts {
            println!("  v {:?}", v);
        }
    }
}
