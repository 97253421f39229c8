//! Benchmark inputs and the `portalfind bench delaunay` table.
//!
//! The four input kinds match the reference measurements in `shared/notes` (CGAL 5.5 and
//! TetGen on this machine kind), so the table can be read against them:
//! - `uniform`: uniform random points in the unit cube;
//! - `grid`: the k³ integer lattice (every cell's corners cospherical, walls coplanar);
//! - `boxes`: corners of room-like axis-aligned boxes with decimal sizes, in columns, rows
//!   and floors (the architectural case: many exact ties);
//! - `urot`: uniform points rotated by (7°, 8°, 9°) about x, y, z and offset by 1e6.
//!
//! Each case runs in a child process so its peak memory (`VmHWM`) is its own.

use crate::base::rng::SplitMix64;
use crate::delaunay::Tetrahedralization;
use crate::predicates::P3;
use std::time::Instant;

/// The input kinds.
pub const KINDS: [&str; 4] = ["uniform", "grid", "boxes", "urot"];

/// The stress rotation and transform, re-exported from their one definition in
/// [`crate::base::rigid`] (the `caverns_rotated` model's description names
/// `bench::rotate_789`).
pub use crate::base::rigid::{rotate_789, rotate_789_offset};

/// The seed of every benchmark input.
pub const SEED: u64 = 12345;

/// Generates about `n` points of the given kind with a fixed seed.
pub fn generate(kind: &str, n: usize, seed: u64) -> Option<Vec<P3>> {
    let mut rng = SplitMix64(seed);
    let mut unit = move || rng.unit();
    Some(match kind {
        "uniform" => (0..n).map(|_| [unit(), unit(), unit()]).collect(),
        "urot" => (0..n).map(|_| rotate_789_offset([unit(), unit(), unit()])).collect(),
        "grid" => {
            let k = (n as f64).cbrt().round().max(2.0) as usize;
            let mut v = Vec::with_capacity(k * k * k);
            for x in 0..k {
                for y in 0..k {
                    for z in 0..k {
                        v.push([x as f64, y as f64, z as f64]);
                    }
                }
            }
            v
        }
        "boxes" => {
            // n/8 boxes on a cols × rows × floors lattice; sizes in decimal steps of 0.1 m.
            let b = (n / 8).max(1);
            let k = (b as f64).cbrt().ceil() as usize;
            let mut v = Vec::with_capacity(b * 8);
            'outer: for f in 0..k {
                for r in 0..k {
                    for c in 0..k {
                        if v.len() >= b * 8 {
                            break 'outer;
                        }
                        let x0 = c as f64 * 10.0 + 0.1 * ((r * 3 + f) % 7) as f64;
                        let y0 = r as f64 * 10.0 + 0.1 * ((c * 5 + f) % 9) as f64;
                        let z0 = f as f64 * 3.5;
                        let w = 6.0 + 0.1 * ((c * 7 + r * 3 + f) % 25) as f64;
                        let d = 5.0 + 0.1 * ((c * 2 + r * 11 + f * 5) % 30) as f64;
                        let h = 2.4 + 0.1 * ((c + r + f) % 6) as f64;
                        for corner in 0..8 {
                            v.push([
                                x0 + if corner & 1 != 0 { w } else { 0.0 },
                                y0 + if corner & 2 != 0 { d } else { 0.0 },
                                z0 + if corner & 4 != 0 { h } else { 0.0 },
                            ]);
                        }
                    }
                }
            }
            v
        }
        _ => return None,
    })
}

/// One benchmark measurement.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Row {
    /// Input kind.
    pub kind: String,
    /// Points generated.
    pub points: usize,
    /// Construction time in seconds (no generation, no validation); with repeats, the
    /// fastest run (the one least disturbed by the rest of the machine).
    pub seconds: f64,
    /// Every run's construction time, in run order (one entry without repeats).
    #[serde(default)]
    pub runs: Vec<f64>,
    /// Peak resident memory of the process after construction, in MB.
    pub peak_mb: f64,
    /// Finite tetrahedra.
    pub tets: usize,
    /// Tetrahedra with exact zero volume (must be 0).
    pub flat: usize,
    /// "ok", or the validation error.
    pub validate: String,
}

/// Peak resident set size of this process in MiB (Linux `VmHWM`), if available.
pub use crate::base::mem::peak_rss_mib as peak_rss_mb;

/// Runs one case in this process.
pub fn run_one(kind: &str, n: usize, validate: bool) -> Option<Row> {
    let pts = generate(kind, n, SEED)?;
    let t0 = Instant::now();
    // Construction only, as CGAL's: without the canonical renumbering (timed by `tetra`).
    let built = Tetrahedralization::build_with_progress(&pts, 0x5eed, false, &mut |_, _| {});
    let seconds = t0.elapsed().as_secs_f64();
    let peak_mb = peak_rss_mb().unwrap_or(f64::NAN);
    Some(match built {
        Err(e) => Row {
            kind: kind.into(),
            points: pts.len(),
            seconds,
            runs: vec![seconds],
            peak_mb,
            tets: 0,
            flat: 0,
            validate: e.to_string(),
        },
        Ok(t) => {
            let flat = t
                .tets()
                .filter(|(_, v)| {
                    let [a, b, c, d] = v.map(|x| t.point(x));
                    crate::predicates::orient3d(a, b, c, d) == 0
                })
                .count();
            let validate = if validate {
                match t.validate() {
                    Ok(_) => "ok".to_string(),
                    Err(e) => e.to_string(),
                }
            } else {
                "skipped".to_string()
            };
            if std::env::var_os("PF_BENCH_STATS").is_some() {
                let st = t.stats();
                eprintln!(
                    "walk steps/pt {:.2}, cavity tets/pt {:.2}, phases [rank, order, insert, compact, canonical] {:?}",
                    st.walk_steps as f64 / pts.len() as f64,
                    st.cavity_tets as f64 / pts.len() as f64,
                    st.seconds
                );
            }
            Row {
                kind: kind.into(),
                points: pts.len(),
                seconds,
                runs: vec![seconds],
                peak_mb,
                tets: t.num_tets(),
                flat,
                validate,
            }
        }
    })
}

/// The median of `v` (the mean of the middle two for an even count), `None` if empty.
pub fn median(v: &[f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let mut w = v.to_vec();
    w.sort_by(f64::total_cmp);
    let m = w.len() / 2;
    Some(if w.len() % 2 == 1 {
        w[m]
    } else {
        0.5 * (w[m - 1] + w[m])
    })
}

/// Formats rows as a Markdown table.
pub fn table(rows: &[Row]) -> String {
    let mut s = String::from(
        "| input | points | time (s), best | median | runs | peak RSS (MB) | tetrahedra | flat | validate |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---|\n",
    );
    for r in rows {
        s += &format!(
            "| {} | {} | {:.3} | {:.3} | {} | {:.0} | {} | {} | {} |\n",
            r.kind,
            r.points,
            r.seconds,
            median(&r.runs).unwrap_or(r.seconds),
            r.runs.len().max(1),
            r.peak_mb,
            r.tets,
            r.flat,
            r.validate
        );
    }
    s
}
