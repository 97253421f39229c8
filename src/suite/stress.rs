//! The stress table (issue 16, "A stress suite"; `portalfind bench stress`): models of the
//! suite (the thesis models and generated buildings and caverns, each with true rooms)
//! under rigid motions, offsets, scales, vertex noise, shuffles, centroid splits and
//! duplicated faces. Per variant: validation, leaks, regions, active cells, final portals
//! (`run`'s default decimation: aperture at its own stop) and rooms isolated, compared with the unmoved model.
//!
//! The variants began as the `stress_table` test of `tests/fuzz_finds.rs` (noise,
//! rotation, offset, shuffle); this module owns them now, with the rest of the list.
//! Rigid motions and scalings map the truth's sample points too; the other variants keep
//! them (noise moves vertices by far less than a sample's distance to the walls).

use super::{Family, SuiteCase, case};
use crate::base::rng::SplitMix64;
use crate::base::vec::P3;
use crate::decimate::Decimation;
use crate::experiment::eval::locate_in_complex;
use crate::model::from_soup;
use serde::Serialize;
use std::time::Instant;

/// A transformation of a soup.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum Variant {
    /// The model as generated.
    Base,
    /// Rotation by 7°, 8°, 9° about x, y, z.
    Rotate789,
    /// A random rotation (uniform unit quaternion from the seed).
    RotateRandom(u64),
    /// Every vertex shifted by (o, 0.7 o, -0.4 o).
    Offset(f64),
    /// Every vertex scaled by s about the origin.
    Scale(f64),
    /// Uniform noise of this fraction of the bounding-box diagonal on every coordinate.
    Noise(f64),
    /// Faces shuffled and each face's first vertex rotated (seeded).
    Shuffle(u64),
    /// Vertices renumbered by a random permutation (seeded; faces remapped).
    RenumberVertices(u64),
    /// Every polygon split into a fan around its centroid.
    CentroidSplit,
    /// Every fifth face duplicated.
    Duplicate,
    /// Every fifth face duplicated with reversed orientation (a two-sided wall there).
    FlippedDuplicate,
}

impl std::fmt::Display for Variant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Variant::Base => write!(f, "base"),
            Variant::Rotate789 => write!(f, "rotate 7/8/9"),
            Variant::RotateRandom(s) => write!(f, "rotate random {s}"),
            Variant::Offset(o) => write!(f, "offset {o:.0e}"),
            Variant::Scale(s) => write!(f, "scale {s:.0e}"),
            Variant::Noise(e) => write!(f, "noise {e:.0e}"),
            Variant::Shuffle(s) => write!(f, "shuffle {s}"),
            Variant::RenumberVertices(s) => write!(f, "renumber vertices {s}"),
            Variant::CentroidSplit => write!(f, "centroid split"),
            Variant::Duplicate => write!(f, "duplicate faces"),
            Variant::FlippedDuplicate => write!(f, "flipped duplicates"),
        }
    }
}

/// The variants of the full table (`quick`: a subset of one of each kind).
pub fn variants(quick: bool) -> Vec<Variant> {
    use Variant::*;
    if quick {
        return vec![
            Base,
            Rotate789,
            RotateRandom(1),
            Offset(1e6),
            Scale(1e-4),
            Noise(1e-6),
            Shuffle(1),
            CentroidSplit,
            Duplicate,
        ];
    }
    vec![
        Base,
        Rotate789,
        RotateRandom(1),
        RotateRandom(2),
        RotateRandom(3),
        Offset(1e3),
        Offset(1e6),
        Offset(1e9),
        Scale(1e-4),
        Scale(1e6),
        Noise(1e-7),
        Noise(1e-6),
        Noise(1e-5),
        Noise(1e-4),
        Noise(1e-3),
        Noise(1e-2),
        Shuffle(1),
        Shuffle(2),
        CentroidSplit,
        Duplicate,
        FlippedDuplicate,
    ]
}

/// The models of the table: (family, seed).
pub fn models(quick: bool) -> Vec<(Family, u64)> {
    if quick {
        vec![(Family::Thesis, 0), (Family::Thesis, 2), (Family::Tessellated, 1)]
    } else {
        let mut m: Vec<(Family, u64)> = (0..6).map(|s| (Family::Thesis, s)).collect();
        m.extend([
            (Family::Tessellated, 1),
            (Family::Greedy, 1),
            (Family::MultiStorey, 1),
            (Family::Caverns, 1),
        ]);
        m
    }
}

fn random_rotation(seed: u64) -> [[f64; 3]; 3] {
    let mut rng = SplitMix64(seed);
    let (mut q, mut n) = ([0.0; 4], 0.0);
    while !(n > 0.1 && n <= 1.0) {
        q = [
            rng.signed_unit(),
            rng.signed_unit(),
            rng.signed_unit(),
            rng.signed_unit(),
        ];
        n = q.iter().map(|x| x * x).sum::<f64>();
    }
    let n = n.sqrt();
    crate::base::rigid::quaternion_matrix(q.map(|c| c / n))
}

/// The point map of a rigid motion or scaling (`None` for the other variants).
pub fn point_map(v: Variant) -> Option<Box<dyn Fn(P3) -> P3>> {
    match v {
        Variant::Rotate789 => Some(Box::new(crate::base::rigid::rotate_789)),
        Variant::RotateRandom(s) => {
            let r = random_rotation(s);
            Some(Box::new(move |a: P3| {
                [0, 1, 2].map(|i| r[i][0] * a[0] + r[i][1] * a[1] + r[i][2] * a[2])
            }))
        }
        Variant::Offset(o) => Some(Box::new(move |a: P3| [a[0] + o, a[1] + 0.7 * o, a[2] - 0.4 * o])),
        Variant::Scale(s) => Some(Box::new(move |a: P3| a.map(|x| x * s))),
        _ => None,
    }
}

/// The soup of `v` applied to (vertices, polygons).
pub fn apply(v: Variant, vs: &[P3], ps: &[Vec<u32>]) -> (Vec<P3>, Vec<Vec<u32>>) {
    let (mut vs, mut ps) = (vs.to_vec(), ps.to_vec());
    if let Some(f) = point_map(v) {
        for p in &mut vs {
            *p = f(*p);
        }
        return (vs, ps);
    }
    match v {
        Variant::Noise(e) => {
            let (lo, hi) = crate::model::bbox_of(vs.iter());
            let diag = crate::base::vec::norm(&crate::base::vec::sub(&hi, &lo));
            let mut rng = SplitMix64(0x5eed ^ e.to_bits());
            for p in &mut vs {
                for x in p.iter_mut() {
                    *x += e * diag * rng.signed_unit();
                }
            }
        }
        Variant::Shuffle(s) => {
            let mut rng = SplitMix64(s);
            for i in (1..ps.len()).rev() {
                ps.swap(i, rng.below(i + 1));
            }
            for p in &mut ps {
                let r = rng.below(p.len());
                p.rotate_left(r);
            }
        }
        Variant::RenumberVertices(s) => {
            let mut rng = SplitMix64(s);
            let mut perm: Vec<usize> = (0..vs.len()).collect();
            for i in (1..perm.len()).rev() {
                perm.swap(i, rng.below(i + 1));
            }
            // Old vertex i becomes new vertex perm[i].
            let old = vs.clone();
            for (i, &j) in perm.iter().enumerate() {
                vs[j] = old[i];
            }
            for p in &mut ps {
                for x in p.iter_mut() {
                    *x = perm[*x as usize] as u32;
                }
            }
        }
        Variant::CentroidSplit => {
            let mut out = Vec::new();
            for p in &ps {
                let c = crate::base::vec::weighted_mean(p.iter().map(|&i| (1.0, vs[i as usize])));
                let ci = vs.len() as u32;
                vs.push(c);
                for k in 0..p.len() {
                    out.push(vec![p[k], p[(k + 1) % p.len()], ci]);
                }
            }
            ps = out;
        }
        Variant::Duplicate | Variant::FlippedDuplicate => {
            let n = ps.len();
            for i in (0..n).step_by(5) {
                let mut f = ps[i].clone();
                if v == Variant::FlippedDuplicate {
                    f.reverse();
                }
                ps.push(f);
            }
        }
        _ => {}
    }
    (vs, ps)
}

/// Whether a cleaned model is **closed**: every edge shared by exactly two polygons (no
/// open or non-manifold edge) and no T-junction (the cleaning report's counts). Noise on a
/// model with T-junctions moves each T-vertex off the edge it lay on, so the edge and the
/// two edges beside the vertex become open: a real crack, about as wide as the noise.
pub fn is_closed(m: &crate::model::Model) -> bool {
    let r = &m.report;
    r.open_edges == 0 && r.non_manifold_edges == 0 && r.t_junctions == 0
}

/// The widest gap between open edges (moved to [`crate::model::gaps`], where `run` and
/// `complex` use it beside leak warnings).
pub use crate::model::gaps::widest_gap;

/// The sealing size the table tries on leaking rows, in widest gaps: a portal through a
/// crack is not in the wall's plane, so its width as [`crate::complex::CellComplex::seal_holes`]
/// measures it (twice the clearance over it) exceeds the crack's width; on the suite's
/// noisy models (noise 1e-5..1e-2 of the diagonal) 2 gaps sealed 10 of 11 leaks, 3 and 4
/// all 11.
pub const SEAL_GAPS: f64 = 4.0;

/// One row of the table.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Suite case name.
    pub model: String,
    /// Variant.
    pub variant: String,
    /// `ok`, or what failed: `refused: ..` (the loader), `invalid cells: ..` (the
    /// pipeline's structural check: no decimation), `invalid: ..` (full validation).
    pub validation: String,
    /// Whether the cleaned input is closed ([`is_closed`]: every edge shared by exactly
    /// two polygons, no T-junction). A leak of an open input may be a real opening.
    pub closed: bool,
    /// The widest gap of the cleaned input ([`widest_gap`]), as a fraction of its
    /// bounding-box diagonal (0 when closed).
    pub widest_gap: f64,
    /// Leaks.
    pub leaks: usize,
    /// Leaks left after sealing openings narrower than [`SEAL_GAPS`] times the widest gap
    /// ([`crate::complex::CellComplex::seal_holes`], `run --seal-holes SIZE`), on a copy of
    /// the complex; `None` when there is no leak or no gap.
    pub leaks_sealed_4gap: Option<usize>,
    /// The fallback tolerance level the complex was built at
    /// ([`crate::Tolerances::fallback`]; 0: the model's own).
    pub tolerance_level: u32,
    /// Interior regions.
    pub regions: usize,
    /// The share of the kept volume that cells thinner than the sliver width lost
    /// ([`crate::complex::ComplexStats::thin_removed_volume`] over the active cells'
    /// volume); `run` warns above 1% ([`crate::complex::CellComplex::thin_loss_warning`]).
    pub thin_lost: f64,
    /// Active cells.
    pub active_cells: usize,
    /// Final portals after `run`'s default decimation (aperture at its own stop).
    pub final_portals: usize,
    /// Rooms isolated.
    pub rooms_isolated: usize,
    /// Rooms of the truth.
    pub rooms: usize,
    /// The same rooms isolated as the unmoved model (base row).
    pub same_rooms: bool,
    /// Seconds for this variant.
    pub seconds: f64,
}

/// The isolated rooms (indices) of a partition: all a room's samples in one final cell
/// that holds no other room's sample.
fn isolated_rooms(cx: &crate::complex::CellComplex, dec: &Decimation, samples: &[Vec<P3>]) -> Vec<usize> {
    let cells: Vec<Vec<Option<usize>>> = samples
        .iter()
        .map(|s| {
            locate_in_complex(cx, s)
                .into_iter()
                .map(|c| c.and_then(|c| dec.partition.cell_of(c)))
                .collect()
        })
        .collect();
    (0..samples.len())
        .filter(|&r| {
            let Some(Some(c)) = cells[r].first().copied() else {
                return false;
            };
            cells[r].iter().all(|&x| x == Some(c))
                && (0..samples.len()).all(|o| o == r || cells[o].iter().all(|&x| x != Some(c)))
        })
        .collect()
}

/// Runs every variant of one case; `progress(variant)` before each.
pub fn run_case(c: &SuiteCase, variants: &[Variant], progress: &mut dyn FnMut(&str)) -> Vec<Row> {
    let mut rows = Vec::new();
    let mut base: Option<Vec<usize>> = None;
    for &v in variants {
        progress(&format!("{} {v}", c.name));
        let t0 = Instant::now();
        let (vs, ps) = apply(v, &c.model.vertices, &c.model.polygons);
        let map = point_map(v);
        let samples: Vec<Vec<P3>> = c
            .truth
            .rooms
            .iter()
            .map(|r| r.samples.iter().map(|&p| map.as_ref().map_or(p, |f| f(p))).collect())
            .collect();
        let mut row = Row {
            model: c.name.clone(),
            variant: v.to_string(),
            validation: "ok".into(),
            closed: false,
            widest_gap: 0.0,
            leaks: 0,
            leaks_sealed_4gap: None,
            tolerance_level: 0,
            regions: 0,
            thin_lost: 0.0,
            active_cells: 0,
            final_portals: 0,
            rooms_isolated: 0,
            rooms: samples.len(),
            same_rooms: false,
            seconds: 0.0,
        };
        let m = match from_soup(&c.name, vs, ps) {
            Ok(m) => m,
            Err(e) => {
                row.validation = format!("refused: {e}");
                row.seconds = t0.elapsed().as_secs_f64();
                rows.push(row);
                continue;
            }
        };
        // The samples in the model's frame (a model far from the origin is recentred on
        // loading; the identity otherwise).
        let samples: Vec<Vec<P3>> = samples
            .iter()
            .map(|s| s.iter().map(|&p| m.from_user(p)).collect())
            .collect();
        row.closed = is_closed(&m);
        let gap = widest_gap(&m);
        row.widest_gap = gap / m.tolerances.scale;
        match crate::pipeline::complex_of(&m) {
            Err(e) => {
                let mut msg = e.to_string();
                let mut src = std::error::Error::source(&e);
                while let Some(s) = src {
                    msg = format!("{msg}: {s}");
                    src = s.source();
                }
                row.validation = format!("invalid cells: {msg}");
            }
            Ok(cx) => {
                if let Err(e) = cx.validate(&m) {
                    row.validation = format!("invalid: {e}");
                }
                row.leaks = cx.stats.leaks;
                row.tolerance_level = cx.stats.tolerance_level;
                row.regions = cx.stats.interior_regions;
                row.active_cells = cx.stats.active_cells;
                if cx.stats.thin_removed_volume > 0.0 {
                    let kept: f64 = cx.active_cells().map(|(_, c)| c.volume()).sum();
                    row.thin_lost = cx.stats.thin_removed_volume / kept;
                }
                if row.leaks > 0 && gap > 0.0 {
                    let mut sealed = cx.clone();
                    sealed.seal_holes(&m, SEAL_GAPS * gap);
                    row.leaks_sealed_4gap = Some(sealed.stats.leaks);
                }
                // `run`'s defaults: the aperture heuristic at its own stop.
                let mut settings = crate::decimate::Settings {
                    heuristic: crate::decimate::HeuristicKind::Aperture,
                    ..Default::default()
                };
                settings.stop = settings.heuristic.default_stop();
                let dec = Decimation::run(&cx, &settings);
                row.final_portals = dec.partition.portals(&cx).len();
                let iso = isolated_rooms(&cx, &dec, &samples);
                row.rooms_isolated = iso.len();
                if v == Variant::Base {
                    base = Some(iso.clone());
                }
                row.same_rooms = base.as_ref() == Some(&iso);
            }
        }
        row.seconds = t0.elapsed().as_secs_f64();
        rows.push(row);
    }
    rows
}

/// The whole table.
pub fn run(quick: bool, progress: &mut dyn FnMut(&str)) -> Vec<Row> {
    run_models(&models(quick), quick, progress)
}

/// The generated families of the table (buildings: tessellated, greedy, multi-storey;
/// caverns) at each of `seeds`, without the thesis models: `bench stress --seeds` runs
/// them on seeds other than the table's seed 1, models no setting was tuned on.
pub fn generated_models(seeds: &[u64]) -> Vec<(Family, u64)> {
    seeds
        .iter()
        .flat_map(|&s| {
            [
                Family::Tessellated,
                Family::Greedy,
                Family::MultiStorey,
                Family::Caverns,
            ]
            .map(|f| (f, s))
        })
        .collect()
}

/// The table of `models` (family and seed) under the full (or quick) variants.
pub fn run_models(models: &[(Family, u64)], quick: bool, progress: &mut dyn FnMut(&str)) -> Vec<Row> {
    let vs = variants(quick);
    models
        .iter()
        .filter_map(|&(f, s)| case(f, s))
        .flat_map(|c| run_case(&c, &vs, progress))
        .collect()
}

/// The headline: rows, validation failures, leaks in rows whose base had none, rows whose
/// rooms differ from the base.
pub fn headline(rows: &[Row]) -> String {
    let invalid = rows.iter().filter(|r| r.validation != "ok").count();
    let leaky = rows.iter().filter(|r| r.leaks > 0).count();
    let leaky_closed = rows.iter().filter(|r| r.leaks > 0 && r.closed).count();
    let sealed = rows.iter().filter(|r| r.leaks_sealed_4gap == Some(0)).count();
    let moved = rows.iter().filter(|r| !r.same_rooms).count();
    let fallback = rows.iter().filter(|r| r.tolerance_level > 0).count();
    let thin = rows.iter().filter(|r| r.thin_lost > 0.01).count();
    let thin_max = rows.iter().map(|r| r.thin_lost).fold(0.0, f64::max);
    format!(
        "{} variants: {invalid} fail validation ({fallback} valid only at a fallback tolerance level), {leaky} leak ({leaky_closed} with a closed input; {sealed} sealed by --seal-holes 4 x widest gap), {moved} isolate other rooms than the unmoved model, {thin} lose over 1% of the kept volume to sliver cells (most: {:.2e})",
        rows.len(),
        thin_max
    )
}

/// The table as Markdown.
pub fn table(rows: &[Row]) -> String {
    let mut s = String::from(
        "| model | variant | validation | closed | widest gap | leaks | leaks sealed 4 x gap | tolerance level | regions | active cells | final portals | rooms isolated | same rooms | s |\n|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|\n",
    );
    for r in rows {
        let v: String = r.validation.chars().take(70).collect();
        s += &format!(
            "| {} | {} | {} | {} | {:.1e} | {} | {} | {} | {} | {} | {} | {}/{} | {} | {:.2} |\n",
            r.model,
            r.variant,
            v,
            if r.closed { "yes" } else { "no" },
            r.widest_gap,
            r.leaks,
            r.leaks_sealed_4gap.map_or("-".to_string(), |l| l.to_string()),
            r.tolerance_level,
            r.regions,
            r.active_cells,
            r.final_portals,
            r.rooms_isolated,
            r.rooms,
            if r.same_rooms { "yes" } else { "no" },
            r.seconds
        );
    }
    s += &format!("\n{}\n", headline(rows));
    s
}

/// Writes `stress.csv`, `stress.json` and `table.md` into `dir`.
pub fn write_all(rows: &[Row], dir: &std::path::Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let mut w = csv::Writer::from_path(dir.join("stress.csv")).map_err(std::io::Error::other)?;
    for r in rows {
        w.serialize(r).map_err(std::io::Error::other)?;
    }
    w.flush()?;
    let json = serde_json::to_string_pretty(rows).map_err(std::io::Error::other)?;
    crate::model::write::write_atomic(&dir.join("stress.json"), json.as_bytes())?;
    crate::model::write::write_atomic(&dir.join("table.md"), table(rows).as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_inputs_have_no_gap_and_noise_opens_t_junctions() {
        // Thesis 1 (tessellated) is conforming; thesis 0 (optimised) has T-junctions a
        // rounding off their edges, which noise opens into cracks about as wide as it.
        let closed = case(super::super::Family::Thesis, 1).unwrap().load().unwrap();
        assert!(is_closed(&closed));
        assert_eq!(widest_gap(&closed), 0.0);
        let c = case(super::super::Family::Thesis, 0).unwrap();
        let m = c.load().unwrap();
        assert!(!is_closed(&m));
        assert!(widest_gap(&m) < 1e-12 * m.tolerances.scale);
        let (vs, ps) = apply(Variant::Noise(1e-3), &c.model.vertices, &c.model.polygons);
        let n = from_soup(&c.name, vs, ps).unwrap();
        let rel = widest_gap(&n) / n.tolerances.scale;
        assert!(rel > 1e-3 && rel < 2e-3, "{rel}");
    }

    #[test]
    fn variants_keep_polygons_and_map_points() {
        let vs = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let ps = vec![vec![0, 1, 2]];
        let (v2, p2) = apply(Variant::CentroidSplit, &vs, &ps);
        assert_eq!((v2.len(), p2.len()), (4, 3));
        let (v3, _) = apply(Variant::Offset(1e3), &vs, &ps);
        assert_eq!(v3[1], [1001.0, 700.0, -400.0]);
        let (_, p4) = apply(Variant::FlippedDuplicate, &vs, &ps);
        assert_eq!(p4, vec![vec![0, 1, 2], vec![2, 1, 0]]);
        let (v5, p5) = apply(Variant::RenumberVertices(3), &vs, &ps);
        let p5: Vec<P3> = p5[0].iter().map(|&i| v5[i as usize]).collect();
        assert_eq!(p5, vs);
    }
}
