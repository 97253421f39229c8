//! The ground truth of one suite case: rooms' sample boxes and doorways.
//! `cargo run --release --example diag_truth -- FAMILY SEED`
use portalfind::suite::{Family, case};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let fam = Family::from_name(&a[1]).unwrap_or_else(|| panic!("family {}", a[1]));
    let c = case(fam, a[2].parse().unwrap()).expect("case");
    for (i, r) in c.truth.rooms.iter().enumerate() {
        let lo = [0, 1, 2].map(|k| r.samples.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min));
        let hi = [0, 1, 2].map(|k| r.samples.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max));
        println!(
            "room {i} {}: {} samples, box {lo:.2?} .. {hi:.2?}",
            r.name,
            r.samples.len()
        );
    }
    for d in &c.truth.doorways {
        println!("doorway {d:?}");
    }
}
