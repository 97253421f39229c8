//! Top views of suite models at the default stop of the default heuristic (`aperture`,
//! `threshold:1.8`): each final cell's pieces filled in one colour, the walls, and the
//! final portals (the `cells.svg` of `portalfind run`, with the cells added).
//!
//! `cargo run --release --example suite_pictures -- OUT_DIR case-name...`

use portalfind::decimate::project::hull2;
use portalfind::decimate::{HeuristicKind, Settings as DecSettings};
use portalfind::output::cells_svg;
use portalfind::suite;
use std::fmt::Write as _;
use std::path::Path;

const WIDTH: f64 = 1200.0;
const MARGIN: f64 = 20.0;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let out = Path::new(&args[1]);
    std::fs::create_dir_all(out).unwrap();
    for name in &args[2..] {
        let case = suite::suite()
            .into_iter()
            .find(|c| &c.name == name)
            .expect("a suite case name");
        let model = case.load().unwrap();
        let h = HeuristicKind::Aperture;
        let settings = portalfind::pipeline::Settings {
            decimation: DecSettings {
                heuristic: h,
                stop: h.default_stop(),
                ..DecSettings::default()
            },
            ..Default::default()
        };
        let run = portalfind::pipeline::run_model(&model, Path::new(name), &settings, Vec::new(), &mut |_| {}).unwrap();
        let a = portalfind::suite::metrics::score(&run.cx, &run.dec.partition, &case.truth, &Default::default());
        let svg = cells_svg(&model, &run.doc);
        // The same transform as cells_svg.
        let (lo, hi) = model.bbox();
        let w = (hi[0] - lo[0]).max(1e-12);
        let s = (WIDTH - 2.0 * MARGIN) / w;
        let tx = |p: &[f64; 3]| (MARGIN + (p[0] - lo[0]) * s, MARGIN + 30.0 + (hi[1] - p[1]) * s);
        let mut layer = String::new();
        for (i, c) in run.dec.partition.cells.iter().enumerate() {
            let hue = (i as f64 * 137.507_764) % 360.0;
            let mut d = String::new();
            for p in &c.pieces {
                let pts: Vec<[f64; 2]> = run.cx.cells[p.idx()]
                    .poly()
                    .vertices()
                    .iter()
                    .map(|v| {
                        let (x, y) = tx(v);
                        [x, y]
                    })
                    .collect();
                for (k, [x, y]) in hull2(pts).iter().enumerate() {
                    let _ = write!(d, "{}{x:.1},{y:.1}", if k == 0 { "M" } else { "L" });
                }
                d.push('Z');
            }
            let _ = writeln!(
                layer,
                r#"<path d="{d}" fill="hsl({hue:.1},70%,75%)" fill-opacity="0.55" stroke="none"><title>cell {}</title></path>"#,
                c.id
            );
        }
        let note = format!(
            r#"<text x="{MARGIN}" y="{}" font-family="sans-serif" font-size="13">truth: {} rooms, {} isolated; P {:.3} R {:.3} (micro); cells filled per cell, walls grey, portals bold</text>"#,
            40, a.rooms, a.rooms_isolated, a.precision_micro, a.recall_micro
        );
        let marker = r#"<rect width="100%" height="100%" fill="white"/>"#;
        let svg = svg.replacen(marker, &format!("{marker}\n{layer}{note}"), 1);
        std::fs::write(out.join(format!("{name}.svg")), svg).unwrap();
        println!(
            "{name}: {} cells, {} portals, {}/{} rooms isolated, P {:.3} R {:.3}",
            run.dec.partition.len(),
            run.doc.portals.len(),
            a.rooms_isolated,
            a.rooms,
            a.precision_micro,
            a.recall_micro
        );
    }
}
