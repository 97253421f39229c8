//! PVS of a qbsp PRT1 portal file (Quake's leaves), with the flow's source clipping off and
//! on, interleaved so the two timings share the machine's load:
//! `cargo run --release --example prt_pvs -- models/quake/e1m1.prt [ROUNDS] [both|old|new] [BUDGET]`
//! (`old`/`new`: one rule only, so `/usr/bin/time` gives its CPU time; BUDGET: flow steps per
//! source, default [`PvsSettings::max_steps_per_source`]).

use portalfind::visibility::{PvsSettings, prt, pvs};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "models/quake/e1m1.prt".into());
    let rounds: usize = std::env::args().nth(2).map_or(Ok(1), |s| s.parse())?;
    let mode = std::env::args().nth(3).unwrap_or_else(|| "both".into());
    let budget: u64 = std::env::args()
        .nth(4)
        .map_or(Ok(PvsSettings::default().max_steps_per_source), |s| s.parse())?;
    let rules: Vec<bool> = match mode.as_str() {
        "old" => vec![false],
        "new" => vec![true],
        _ => vec![false, true],
    };
    let f = prt::read(std::path::Path::new(&path))?;
    let g = f.graph();
    println!("{path}: {} leaves, {} portals", g.cells, g.portals.len());
    let mut last: Option<pvs::Pvs> = None;
    for round in 0..rounds {
        for &clip_source in &rules {
            let settings = PvsSettings {
                clip_source,
                max_steps_per_source: budget,
                ..Default::default()
            };
            let t0 = Instant::now();
            let p = pvs::compute(&g, &settings);
            let t = t0.elapsed().as_secs_f64();
            println!(
                "round {round} clip_source {clip_source}: PVS mean {:.1} max {} leaves; {t:.2} s (base {:.2} s, flow {:.2} s); \
                 {} chains; {} sources truncated (budget {} steps)",
                p.mean_size(),
                p.max_size(),
                p.stats.base_seconds,
                p.stats.flow_seconds,
                p.stats.chains,
                p.stats.sources_truncated,
                settings.max_steps_per_source
            );
            if let Some(q) = &last {
                // The tighter rule's sets lie inside the looser rule's.
                let (a, b) = if clip_source { (&p, q) } else { (q, &p) };
                let outside = (0..g.cells)
                    .map(|c| (0..g.cells).filter(|&d| a.sees(c, d) && !b.sees(c, d)).count())
                    .sum::<usize>();
                println!("  leaf pairs seen with source clipping but not without: {outside}");
            }
            last = Some(p);
        }
        last = None;
    }
    Ok(())
}
