//! PVS of a qbsp PRT1 portal file (Quake's leaves) under several flow rules, interleaved
//! so their timings share the machine's load:
//! `cargo run --release --example prt_pvs -- models/quake/e1m1.prt [ROUNDS] [RULES] [BUDGET]`
//!
//! RULES is a comma-separated list of `old` (target clipped only, one-way sets), `clip`
//! (source clipped too, one-way sets: the default before the symmetric rule), `new` (the
//! default: source clipped, symmetric sets), or `both` (= `old,new`, the default); a single
//! rule per process lets `/usr/bin/time` give its CPU time. BUDGET: flow steps per source,
//! default [`PvsSettings::max_steps_per_source`]. After each rule the leaf pairs it sees
//! that the previous rule in the list does not are counted (must be 0 when the list goes
//! from looser to tighter), and for `new` after `clip` the leaves whose sets shrank most.

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
    let mut rules: Vec<(&str, bool, bool)> = Vec::new();
    for r in mode.split(',') {
        match r {
            "old" => rules.push(("old", false, false)),
            "clip" => rules.push(("clip", true, false)),
            "new" => rules.push(("new", true, true)),
            "both" => rules.extend([("old", false, false), ("new", true, true)]),
            _ => return Err(format!("unknown rule {r:?} (old, clip, new, both)").into()),
        }
    }
    let f = prt::read(std::path::Path::new(&path))?;
    let g = f.graph();
    println!("{path}: {} leaves, {} portals", g.cells, g.portals.len());
    for round in 0..rounds {
        let mut last: Option<(&str, pvs::Pvs)> = None;
        for &(name, clip_source, symmetric) in &rules {
            let settings = PvsSettings {
                clip_source,
                symmetric,
                max_steps_per_source: budget,
                ..Default::default()
            };
            let t0 = Instant::now();
            let p = pvs::compute(&g, &settings);
            let t = t0.elapsed().as_secs_f64();
            println!(
                "round {round} {name} (clip_source {clip_source}, symmetric {symmetric}): PVS mean {:.1} max {} leaves; \
                 {t:.2} s (base {:.2} s, flow {:.2} s); {} chains; {} sources truncated (budget {} steps); \
                 {} one-way pairs dropped",
                p.mean_size(),
                p.max_size(),
                p.stats.base_seconds,
                p.stats.flow_seconds,
                p.stats.chains,
                p.stats.sources_truncated,
                settings.max_steps_per_source,
                p.stats.asymmetric_dropped
            );
            if let Some((prev, q)) = &last {
                let outside = (0..g.cells)
                    .map(|c| (0..g.cells).filter(|&d| p.sees(c, d) && !q.sees(c, d)).count())
                    .sum::<usize>();
                println!("  leaf pairs seen by {name} but not by {prev}: {outside}");
                let mut shrink: Vec<(usize, usize, usize)> = (0..g.cells)
                    .map(|c| {
                        (
                            q.sets[c].count() - q.sets[c].count().min(p.sets[c].count()),
                            c,
                            q.sets[c].count(),
                        )
                    })
                    .collect();
                shrink.sort_by(|a, b| b.cmp(a));
                let changed = shrink.iter().filter(|s| s.0 > 0).count();
                println!(
                    "  leaves whose set shrank: {changed}; largest drops (leaf: {prev} -> {name}): {}",
                    shrink
                        .iter()
                        .take(8)
                        .map(|&(d, c, n)| format!("{c}: {n} -> {}", n - d))
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            }
            last = Some((name, p));
        }
    }
    Ok(())
}
