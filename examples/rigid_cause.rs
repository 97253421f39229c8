//! Why active-cell counts move under rigid motions (issue 16, "explain the exact cause"):
//! for each stress-table model and each rigid variant (rotations, offsets, scales), the
//! cell complex of the moved model built twice — on its own Delaunay tetrahedralization
//! (what `run` does) and on the unmoved model's tetrahedralization with its vertices moved
//! ([`Tetrahedralization::moved`]). If the second always matches the unmoved model's
//! counts, the whole difference comes from the tetrahedralization: cospherical ties,
//! broken by a perturbation keyed to the lexicographic order of the coordinates (which a
//! rotation changes), and near-ties that the rounding of moved coordinates decides.
//!
//! Also prints the unmoved tetrahedralization's **tie faces**: interior faces whose two
//! tetrahedra are cospherical (exact `insphere` = 0), i.e. where the Delaunay
//! tetrahedralization is not unique and the perturbation chose.
//!
//! `cargo run --release --example rigid_cause [-- --quick] [-- --csv PATH]`
use portalfind::complex::CellComplex;
use portalfind::delaunay::Tetrahedralization;
use portalfind::model::{Model, from_soup};
use portalfind::suite::stress::{Variant, apply, models, variants};

struct Counts {
    cells_after_split: usize,
    active: usize,
    valid: bool,
}

fn complex_counts(m: &Model, t: &Tetrahedralization) -> Counts {
    let mut cx = CellComplex::build(m, t);
    cx.seal_cracks_auto(m);
    Counts {
        cells_after_split: cx.stats.cells_after_split,
        active: cx.stats.active_cells,
        valid: cx.validate(m).is_ok(),
    }
}

fn tie_faces(t: &Tetrahedralization) -> usize {
    let mut n = 0;
    for (id, vs) in t.tets() {
        for f in 0..4 {
            if let Some((o, of)) = t.neighbor(id, f)
                && id < o
            {
                let opp = t.tet(o)[of];
                let p = vs.map(|v| t.point(v));
                if portalfind::predicates::insphere(p[0], p[1], p[2], p[3], t.point(opp)) == 0 {
                    n += 1;
                }
            }
        }
    }
    n
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let csv_path = args
        .iter()
        .position(|a| a == "--csv")
        .and_then(|i| args.get(i + 1))
        .cloned();
    let rigid: Vec<Variant> = variants(false)
        .into_iter()
        .filter(|v| {
            matches!(v, Variant::Rotate789 | Variant::RotateRandom(_) | Variant::Scale(_))
                || matches!(v, Variant::Offset(o) if *o < 1e8)
        })
        .collect();
    let mut csv = String::from(
        "model,variant,base_active,tie_faces,same_tetrahedralization,own_active,moved_tet_active,own_cells_after_split,moved_tet_cells_after_split,base_cells_after_split,moved_valid\n",
    );
    println!(
        "| model | variant | tie faces (unmoved) | same tetrahedralization | active: unmoved | own Delaunay | unmoved tetrahedralization, moved |"
    );
    println!("|---|---|---:|---|---:|---:|---:|");
    let (mut rows, mut own_eq, mut moved_eq, mut moved_none) = (0, 0, 0, 0);
    for (family, seed) in models(quick) {
        let Some(c) = portalfind::suite::case(family, seed) else {
            continue;
        };
        let m0 = from_soup(&c.name, c.model.vertices.clone(), c.model.polygons.clone()).expect("suite model loads");
        let t0 = Tetrahedralization::build(&m0.vertices).expect("tetrahedralization");
        let base = complex_counts(&m0, &t0);
        let ties = tie_faces(&t0);
        let set0 = t0.sorted_tets();
        for &v in &rigid {
            let (vs, ps) = apply(v, &c.model.vertices, &c.model.polygons);
            let m1 = from_soup(&c.name, vs, ps).expect("rigid variant loads");
            let t1 = Tetrahedralization::build(&m1.vertices).expect("tetrahedralization");
            let own = complex_counts(&m1, &t1);
            let same = t1.sorted_tets() == set0;
            let moved = if m1.vertices.len() == m0.vertices.len() {
                t0.moved(&m1.vertices).map(|t| complex_counts(&m1, &t))
            } else {
                None
            };
            rows += 1;
            own_eq += usize::from(own.active == base.active);
            match &moved {
                Some(mc) => moved_eq += usize::from(mc.active == base.active),
                None => moved_none += 1,
            }
            let mtxt = moved
                .as_ref()
                .map_or("not a triangulation".to_string(), |mc| mc.active.to_string());
            println!(
                "| {} | {v} | {ties} | {} | {} | {} | {mtxt} |",
                c.name,
                if same { "yes" } else { "no" },
                base.active,
                own.active
            );
            csv.push_str(&format!(
                "{},{v},{},{ties},{same},{},{},{},{},{},{}\n",
                c.name,
                base.active,
                own.active,
                moved.as_ref().map_or(String::new(), |m| m.active.to_string()),
                own.cells_after_split,
                moved
                    .as_ref()
                    .map_or(String::new(), |m| m.cells_after_split.to_string()),
                base.cells_after_split,
                moved.as_ref().map_or(String::new(), |m| m.valid.to_string()),
            ));
        }
    }
    println!(
        "\n{rows} rigid rows: active cells equal to the unmoved model's on the own Delaunay in {own_eq}, on the unmoved tetrahedralization moved in {moved_eq} (of {} where it stays a triangulation)",
        rows - moved_none
    );
    if let Some(p) = csv_path {
        std::fs::write(&p, csv).expect("write csv");
    }
}
