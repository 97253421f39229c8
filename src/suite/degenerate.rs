//! Bounded cost on degenerate input (issue 16): `portalfind bench degenerate`.
//!
//! Models that are valid but hostile to a polygon pipeline, each at growing sizes, through
//! `portalfind complex --no-validate` (loading, cleaning, the tetrahedralization and the
//! cell complex) in fresh processes: wall time, peak memory (the child's own, `wait4`),
//! the load and splitting stages as the child printed them, and the growth exponent of
//! each family (log-log least squares of wall time against the size). The families:
//!
//! - `convex-cap prism`: a closed prism whose floor and ceiling are each **one convex
//!   planar n-gon** (a round room of n wall quads). Splitting the cells by one polygon
//!   clips it against every cell it meets, so one n-gon costs O(n²); the loader
//!   ear-clips convex polygons of more than 256 vertices.
//! - `star-cap prism`: the same with **non-convex star n-gons** as caps (every other
//!   vertex pulled in by a fifth): ear clipping, once O(n²) (a 100k-gon: about a minute),
//!   now tests each ear only against the reflex vertices under it (a grid).
//! - `random-index face`: a closed box room plus **one face of n random vertex indices**
//!   into n points inside it (the 204 s, 850 MB at n = 1000): non-planar and
//!   crossing itself, it is refused at load, naming the face, beyond 64 vertices.
//!
//! - `straight-edged floor`: a 20 × 20 × 3 room whose floor is **one polygon with n
//!   vertices along its four straight edges** (every wall strip's foot), walls of n
//!   quads, the ceiling its mirror image (closed). Only the 4 corners are clipped (straight-angle vertices
//!   are not corners, `Model::is_corner`); ear-clipped into slivers it took 57 s at 10k.
//! - `plate stack`: a 10 m cube room with **n two-sided 6 × 6 plates 1e-6 apart** at
//!   mid-height (welding keeps every other one: n/2 plates 2e-6 apart): stacked membranes
//!   that the portal graph walks up through (the walk stopped after 9 until session 29
//!   and split the room in two).
//!
//! Sizes are fixed (no tuning is involved): the table shows what each size costs.

use crate::model::write::write_atomic;
use crate::suite::scale::{loglog_slope, parse_stages, run_child};
use crate::suite::util::Rng;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// One family at one size.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Family name.
    pub family: String,
    /// Its size parameter (vertices of the cap or face).
    pub n: usize,
    /// Input triangles and polygons as written (polygons of the OBJ file).
    pub polygons: usize,
    /// Whether the child exited 0 (a refusal at load exits 1).
    pub ok: bool,
    /// The child's first error line when it did not.
    pub error: String,
    /// Wall seconds of the child.
    pub seconds: f64,
    /// Peak resident memory of the child, MiB.
    pub peak_mib: f64,
    /// The load stage's seconds, as the child printed them ("loaded .. in S s").
    pub load_s: Option<f64>,
    /// The splitting stage's seconds, as the child printed them.
    pub splitting_s: Option<f64>,
}

/// The families and their sizes (the largest first dropped by `max_n`).
pub const FAMILIES: [(&str, &[usize]); 5] = [
    ("convex-cap prism", &[1_000, 10_000, 100_000]),
    // Smaller sizes: its cells (the Delaunay tetrahedra of two star-shaped rings span the
    // room) each meet thousands of wall polygons in the crossing check, which is
    // quadratic here (see the table's exponent).
    ("star-cap prism", &[1_000, 3_000, 10_000, 30_000]),
    ("random-index face", &[64, 1_000, 10_000]),
    ("straight-edged floor", &[1_000, 10_000, 100_000]),
    // Each gap between plates is a membrane, and each membrane walks up the stack above
    // it: quadratic in n.
    ("plate stack", &[100, 1_000, 3_000]),
];

/// A box room `[0, size]` facing inwards, as OBJ lines: vertices 1–8 and six quads.
fn box_room(s: &mut String, size: [f64; 3]) {
    let [x, y, z] = size;
    for h in [0.0, z] {
        for (u, v) in [(0.0, 0.0), (x, 0.0), (x, y), (0.0, y)] {
            let _ = writeln!(s, "v {u:?} {v:?} {h:?}");
        }
    }
    for f in [
        [1, 2, 3, 4],
        [5, 8, 7, 6],
        [1, 5, 6, 2],
        [2, 6, 7, 3],
        [3, 7, 8, 4],
        [4, 8, 5, 1],
    ] {
        let _ = writeln!(s, "f {} {} {} {}", f[0], f[1], f[2], f[3]);
    }
}

/// The OBJ text of family `family` at size `n`, and its polygon count.
pub fn model(family: &str, n: usize) -> (String, usize) {
    let mut s = String::new();
    let mut polys = 0;
    match family {
        "convex-cap prism" | "star-cap prism" => {
            let star = family.starts_with("star");
            for z in [0.0, 3.0] {
                for k in 0..n {
                    let t = std::f64::consts::TAU * k as f64 / n as f64;
                    let r = if star && k % 2 == 1 { 4.0 } else { 5.0 };
                    let _ = writeln!(s, "v {:?} {:?} {z:?}", r * t.cos(), r * t.sin());
                }
            }
            // Floor seen from above (the room side), ceiling seen from below, walls inward.
            s.push('f');
            for k in 0..n {
                let _ = write!(s, " {}", k + 1);
            }
            s.push_str("\nf");
            for k in (0..n).rev() {
                let _ = write!(s, " {}", n + k + 1);
            }
            s.push('\n');
            for k in 0..n {
                let (a, b) = (k + 1, (k + 1) % n + 1);
                let _ = writeln!(s, "f {a} {} {} {b}", n + a, n + b);
            }
            polys = n + 2;
        }
        "random-index face" => {
            // A box room 10 x 10 x 3 facing inwards, then n points inside it and one face
            // through them in a fixed pseudo-random order (the suite's seeded generator,
            // seed n: the same file on every machine).
            box_room(&mut s, [10.0, 10.0, 3.0]);
            let mut rng = Rng::new(n as u64);
            for _ in 0..n {
                let p = [rng.range(1.0, 9.0), rng.range(1.0, 9.0), rng.range(0.5, 2.5)];
                let _ = writeln!(s, "v {:?} {:?} {:?}", p[0], p[1], p[2]);
            }
            let mut order: Vec<usize> = (0..n).collect();
            for i in (1..n).rev() {
                order.swap(i, rng.below(i + 1));
            }
            s.push('f');
            for i in order {
                let _ = write!(s, " {}", 9 + i);
            }
            s.push('\n');
            polys = 7;
        }
        "straight-edged floor" => {
            let per = n.div_ceil(4);
            let sq = [[-10.0, -10.0], [10.0, -10.0], [10.0, 10.0], [-10.0, 10.0]];
            let mut rim = Vec::with_capacity(4 * per);
            for e in 0..4 {
                let (a, b) = (sq[e], sq[(e + 1) % 4]);
                for i in 0..per {
                    let t = i as f64 / per as f64;
                    rim.push([a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t]);
                }
            }
            let m = rim.len();
            for z in [0.0, 3.0] {
                for p in &rim {
                    let _ = writeln!(s, "v {:?} {:?} {z:?}", p[0], p[1]);
                }
            }
            // The floor seen from above, the walls inward, the ceiling seen from below.
            s.push('f');
            for k in 0..m {
                let _ = write!(s, " {}", k + 1);
            }
            s.push('\n');
            for k in 0..m {
                let (a, b) = (k + 1, (k + 1) % m + 1);
                let _ = writeln!(s, "f {a} {} {} {b}", m + a, m + b);
            }
            s.push('f');
            for k in (0..m).rev() {
                let _ = write!(s, " {}", m + k + 1);
            }
            s.push('\n');
            polys = m + 2;
        }
        "plate stack" => {
            box_room(&mut s, [10.0, 10.0, 10.0]);
            for i in 0..n {
                let z = 5.0 + i as f64 * 1e-6;
                for (x, y) in [(2.0, 2.0), (8.0, 2.0), (8.0, 8.0), (2.0, 8.0)] {
                    let _ = writeln!(s, "v {x:?} {y:?} {z:?}");
                }
                let b = 9 + 4 * i;
                let _ = writeln!(s, "f {} {} {} {}", b, b + 1, b + 2, b + 3);
                let _ = writeln!(s, "f {} {} {} {}", b + 3, b + 2, b + 1, b);
            }
            polys = 6 + 2 * n;
        }
        _ => {}
    }
    (s, polys)
}

/// Runs every family at every size up to `max_n` through `exe complex --no-validate` in
/// fresh processes (files under `work`); `progress` gets a line per case.
pub fn run(exe: &Path, max_n: usize, work: &Path, progress: &mut dyn FnMut(&str)) -> std::io::Result<Vec<Row>> {
    std::fs::create_dir_all(work)?;
    let mut rows = Vec::new();
    for (family, sizes) in FAMILIES {
        for &n in sizes.iter().filter(|&&n| n <= max_n) {
            let (text, polygons) = model(family, n);
            let file = work.join(format!("{}-{n}.obj", family.replace(' ', "-")));
            write_atomic(&file, text.as_bytes())?;
            let args = ["complex".as_ref(), file.as_os_str(), "--no-validate".as_ref()];
            let c = run_child(exe, &args, None)?;
            let stages = parse_stages(&c.stdout);
            let stage = |name: &str| stages.iter().find(|(s, _)| s == name).map(|&(_, v)| v);
            let load_s = c.stdout.lines().chain(c.stderr.lines()).find_map(|l| {
                let rest = l.strip_prefix("loaded ")?;
                let (_, t) = rest.rsplit_once(" in ")?;
                t.trim_end_matches(" s").parse().ok()
            });
            let error = c
                .stderr
                .lines()
                .find(|l| l.starts_with("error"))
                .unwrap_or("")
                .to_string();
            let row = Row {
                family: family.into(),
                n,
                polygons,
                ok: c.ok,
                error,
                seconds: c.secs,
                peak_mib: c.peak_mib,
                load_s,
                splitting_s: stage("splitting"),
            };
            progress(&format!(
                "{family} n={n}: {} in {:.2} s, {:.0} MiB",
                if row.ok { "ok" } else { "refused" },
                row.seconds,
                row.peak_mib
            ));
            let _ = std::fs::remove_file(&file);
            rows.push(row);
        }
    }
    Ok(rows)
}

/// The growth exponent of each family's wall time against its size (sizes at which the
/// child exited 0; None for fewer than two).
pub fn exponents(rows: &[Row]) -> Vec<(String, Option<f64>)> {
    FAMILIES
        .iter()
        .map(|(f, _)| {
            let pts: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| r.family == *f && r.ok)
                .map(|r| (r.n as f64, r.seconds))
                .collect();
            (f.to_string(), loglog_slope(&pts))
        })
        .collect()
}

/// The Markdown table of `rows` and the exponents.
pub fn table(rows: &[Row]) -> String {
    let f = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.3}"));
    let mut s = String::from(
        "| family | n | polygons | outcome | wall s | peak MiB | load s | splitting s |\n|---|---:|---:|---|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let outcome = if r.ok {
            "ok".to_string()
        } else {
            // The message after the file's name and line (the temporary path says nothing).
            let why = r.error.split_once(".obj:").map_or(r.error.as_str(), |(_, w)| w);
            let why = why.split_once(": ").map_or(why, |(_, w)| w);
            format!("refused: {}", why.chars().take(110).collect::<String>())
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.2} | {:.0} | {} | {} |",
            r.family,
            r.n,
            r.polygons,
            outcome,
            r.seconds,
            r.peak_mib,
            f(r.load_s),
            f(r.splitting_s)
        );
    }
    s.push_str("\nGrowth exponent of the wall time (log-log least squares over the sizes that ran):");
    for (fam, e) in exponents(rows) {
        let _ = write!(s, " {fam} {};", e.map_or("-".into(), |v| format!("{v:.2}")));
    }
    s.pop();
    s.push('\n');
    s
}

/// Writes degenerate.csv, degenerate.json and table.md into `dir`.
pub fn write_all(rows: &[Row], dir: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).map_err(std::io::Error::other)?;
    }
    let bytes = w.into_inner().map_err(std::io::Error::other)?;
    write_atomic(&dir.join("degenerate.csv"), &bytes)?;
    let json = serde_json::to_string_pretty(rows).map_err(std::io::Error::other)?;
    write_atomic(&dir.join("degenerate.json"), json.as_bytes())?;
    write_atomic(&dir.join("table.md"), table(rows).as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every family's smallest model loads as intended: the prisms closed, with their
    /// caps triangulated once they pass the loader's limits, and the random-index face
    /// refused beyond 64 vertices, naming the face.
    #[test]
    fn families_load_as_described() {
        let load = |fam: &str, n: usize| {
            let (text, _) = model(fam, n);
            crate::model::parse_obj_str(fam, &text)
        };
        let m = load("convex-cap prism", 1000).expect("loads");
        assert_eq!(m.report.open_edges, 0);
        assert_eq!(
            m.report.nonplanar_or_nonconvex_triangulated, 2,
            "both caps: {}",
            m.report
        );
        let m = load("convex-cap prism", 200).expect("loads");
        assert_eq!(
            m.report.nonplanar_or_nonconvex_triangulated, 0,
            "small convex caps are kept"
        );
        let m = load("star-cap prism", 1000).expect("loads");
        assert_eq!(m.report.open_edges, 0);
        assert_eq!(m.report.nonplanar_or_nonconvex_triangulated, 2);
        assert_eq!(m.report.triangles_from_triangulation, 2 * 998);
        let e = load("random-index face", 1000).expect_err("refused");
        let msg = e.to_string();
        assert!(msg.contains("face 6") && msg.contains("crosses itself"), "{msg}");
        // The straight-edged floor and ceiling stay polygons of n vertices, closed.
        let m = load("straight-edged floor", 1000).expect("loads");
        assert_eq!(m.polygons.len(), 1000 + 2);
        assert_eq!(m.polygons[0].verts.len(), 1000);
        assert_eq!(m.report.nonplanar_or_nonconvex_triangulated, 0, "{}", m.report);
        assert_eq!(m.report.open_edges, 0, "{}", m.report);
        // The plates: 1e-6 apart is below the weld distance (1e-7 of the 17.3 m diagonal),
        // and welding is not transitive, so every other plate survives: 50 two-sided
        // plates 2e-6 apart, 49 stacked membranes.
        let m = load("plate stack", 100).expect("loads");
        assert_eq!(m.polygons.len(), 6 + 100, "{}", m.report);
        assert_eq!(m.report.two_sided_pairs, 50, "{}", m.report);
    }
}
