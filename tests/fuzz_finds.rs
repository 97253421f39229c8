//! Regression tests for the shrunk fuzz finds in `tests/data/fuzz_finds/` (see its
//! README): each model must either be refused at load with a typed error, or give a cell
//! complex that validates, in bounded time.

use portalfind::complex::CellComplex;
use portalfind::delaunay::Tetrahedralization;
use portalfind::model::load_model;
use std::path::PathBuf;
use std::time::Instant;

fn path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/fuzz_finds")
        .join(name)
}

/// Loads and builds; `Ok(None)` when the loader refused the file.
fn build(name: &str) -> Result<Option<CellComplex>, String> {
    let m = match load_model(&path(name)) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("{name}: refused at load: {e}");
            return Ok(None);
        }
    };
    let t = Tetrahedralization::build(&m.vertices).map_err(|e| e.to_string())?;
    let cx = CellComplex::build(&m, &t);
    cx.check_valid().map_err(|e| format!("{name}: {e}"))?;
    cx.validate(&m).map_err(|e| format!("{name}: {e}"))?;
    Ok(Some(cx))
}

fn check(name: &str) {
    let t0 = Instant::now();
    if let Err(e) = build(name) {
        panic!("{e}");
    }
    eprintln!("{name}: {:.2} s", t0.elapsed().as_secs_f64());
}

#[test]
fn open_edge() {
    check("open_edge.obj");
}

#[test]
fn edge_used_twice() {
    check("edge_used_twice.obj");
}

#[test]
fn face_repeats_vertex() {
    check("face_repeats_vertex.obj");
}

#[test]
fn vertex_in_front_of_face() {
    check("vertex_in_front_of_face.obj");
}

/// An earlier cut through a vertex 1e-8 off its plane leaves a valid cell with a sliver
/// face; the cut by polygon 5 finds that face entirely on its plane. It used to be refused
/// (so the polygon crossed the cell); now the face goes whole to one piece.
#[test]
fn polygon_crosses_cell() {
    check("polygon_crosses_cell.obj");
}

#[test]
fn slow_1000_vertex_face_is_bounded() {
    // A two-room model plus one face of 1000 random vertex indices: it must be refused at
    // load or give a valid complex within seconds (it took 204 s and ~190k cells).
    let t0 = Instant::now();
    if let Err(e) = build("slow_1000_vertex_face.obj") {
        panic!("{e}");
    }
    let s = t0.elapsed().as_secs_f64();
    assert!(s < 20.0, "took {s:.1} s");
}

// ---- Stress: shipped models under noise, rotations, offsets and shuffles ----

use portalfind::model::{Model, from_soup};

/// SplitMix64.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [-1, 1).
    fn f(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

#[derive(Clone, Copy, Debug)]
enum Variant {
    Noise(f64),
    Rotate,
    Offset(f64),
    Shuffle,
    /// Vertices renumbered by a random permutation (faces remapped).
    ShuffleVertices,
}

impl std::fmt::Display for Variant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Variant::Noise(e) => write!(f, "noise {e:.0e}"),
            Variant::Rotate => write!(f, "rotation"),
            Variant::Offset(o) => write!(f, "offset {o:.0e}"),
            Variant::Shuffle => write!(f, "shuffled faces"),
            Variant::ShuffleVertices => write!(f, "shuffled verts"),
        }
    }
}

fn soup(m: &Model) -> (Vec<[f64; 3]>, Vec<Vec<u32>>) {
    (
        m.vertices.clone(),
        m.polygons
            .iter()
            .map(|p| p.verts.iter().map(|v| v.0).collect())
            .collect(),
    )
}

/// The model's soup transformed by `v` with seed `seed`.
fn variant(m: &Model, v: Variant, seed: u64) -> (Vec<[f64; 3]>, Vec<Vec<u32>>) {
    let (mut vs, mut ps) = soup(m);
    let mut rng = Rng(seed);
    let diag = m.tolerances.scale;
    match v {
        Variant::Noise(e) => {
            for p in &mut vs {
                for x in p.iter_mut() {
                    *x += e * diag * rng.f();
                }
            }
        }
        Variant::Rotate => {
            // A random unit quaternion.
            let (mut q, mut n) = ([0.0; 4], 0.0);
            while !(n > 0.1 && n <= 1.0) {
                q = [rng.f(), rng.f(), rng.f(), rng.f()];
                n = q.iter().map(|x| x * x).sum::<f64>();
            }
            let n = n.sqrt();
            let [w, x, y, z] = q.map(|c| c / n);
            let r = [
                [
                    1.0 - 2.0 * (y * y + z * z),
                    2.0 * (x * y - w * z),
                    2.0 * (x * z + w * y),
                ],
                [
                    2.0 * (x * y + w * z),
                    1.0 - 2.0 * (x * x + z * z),
                    2.0 * (y * z - w * x),
                ],
                [
                    2.0 * (x * z - w * y),
                    2.0 * (y * z + w * x),
                    1.0 - 2.0 * (x * x + y * y),
                ],
            ];
            for p in &mut vs {
                let a = *p;
                *p = [0, 1, 2].map(|i| r[i][0] * a[0] + r[i][1] * a[1] + r[i][2] * a[2]);
            }
        }
        Variant::Offset(o) => {
            let d = [
                o * (1.0 + 0.1 * rng.f()),
                o * (0.7 + 0.1 * rng.f()),
                -o * (0.4 + 0.1 * rng.f()),
            ];
            for p in &mut vs {
                for k in 0..3 {
                    p[k] += d[k];
                }
            }
        }
        Variant::Shuffle => {
            for i in (1..ps.len()).rev() {
                let j = (rng.next() % (i as u64 + 1)) as usize;
                ps.swap(i, j);
            }
            for p in &mut ps {
                let r = (rng.next() % p.len() as u64) as usize;
                p.rotate_left(r);
            }
        }
        Variant::ShuffleVertices => {
            let mut perm: Vec<usize> = (0..vs.len()).collect();
            for i in (1..perm.len()).rev() {
                let j = (rng.next() % (i as u64 + 1)) as usize;
                perm.swap(i, j);
            }
            // Old vertex i becomes new vertex perm[i].
            let mut nv = vs.clone();
            for (i, &j) in perm.iter().enumerate() {
                nv[j] = vs[i];
            }
            vs = nv;
            for p in &mut ps {
                for x in p.iter_mut() {
                    *x = perm[*x as usize] as u32;
                }
            }
        }
    }
    (vs, ps)
}

/// Outcome of one variant.
enum Outcome {
    /// Refused at load.
    Refused,
    /// Valid; active cells and portal pairs.
    Valid(usize, usize),
    /// A cell is not a valid polyhedron or the topology is broken (`check_valid`).
    BadCells(String),
    /// Cells valid, but `validate` failed (a model polygon left crossing a cell, coverage).
    Invalid(String),
}

fn run_variant(m: &Model, v: Variant, seed: u64) -> Outcome {
    let (vs, ps) = variant(m, v, seed);
    let Ok(m2) = from_soup("stress", vs, ps) else {
        return Outcome::Refused;
    };
    let t = Tetrahedralization::build(&m2.vertices).expect("tetrahedralization");
    let cx = CellComplex::build(&m2, &t);
    if let Err(e) = cx.check_valid() {
        return Outcome::BadCells(e.to_string());
    }
    match cx.validate(&m2) {
        Ok(_) => Outcome::Valid(cx.stats.active_cells, cx.stats.portal_pairs),
        Err(e) => Outcome::Invalid(e.to_string()),
    }
}

fn thesis(name: &str) -> Model {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("models/thesis")
        .join(name);
    load_model(&p).expect("shipped model")
}

/// Runs every (model, variant) over `seeds`, prints a table, and returns the numbers of
/// runs with invalid cells and with any validation failure.
fn stress(models: &[&str], variants: &[Variant], seeds: u64) -> (usize, usize) {
    let (mut bad_total, mut invalid_total) = (0, 0);
    eprintln!(
        "{:<28} {:<16} {:>5} {:>8} {:>10} {:>8}",
        "model", "variant", "runs", "refused", "bad cells", "invalid"
    );
    for name in models {
        let m = thesis(name);
        for &v in variants {
            let (mut refused, mut bad, mut invalid) = (0, 0, 0);
            for seed in 0..seeds {
                match run_variant(&m, v, 1000 + seed) {
                    Outcome::Valid(..) => {}
                    Outcome::Refused => refused += 1,
                    Outcome::BadCells(e) => {
                        bad += 1;
                        invalid += 1;
                        eprintln!("  {name} {v} seed {seed}: {e}");
                    }
                    Outcome::Invalid(e) => {
                        invalid += 1;
                        eprintln!("  {name} {v} seed {seed}: {e}");
                    }
                }
            }
            bad_total += bad;
            invalid_total += invalid;
            eprintln!(
                "{name:<28} {:<16} {seeds:>5} {refused:>8} {bad:>10} {invalid:>8}",
                v.to_string()
            );
        }
    }
    (bad_total, invalid_total)
}

const ALL_VARIANTS: [Variant; 10] = [
    Variant::Noise(1e-7),
    Variant::Noise(1e-6),
    Variant::Noise(1e-5),
    Variant::Noise(1e-4),
    Variant::Noise(1e-3),
    Variant::Rotate,
    Variant::Offset(1e3),
    Variant::Offset(1e6),
    Variant::Offset(1e9),
    Variant::Shuffle,
];

/// The fast subset kept in the default test run: cells are always valid polyhedra with
/// consistent topology (cuts that would break them are refused), and the rigid motions
/// validate fully. (Vertex noise can still leave a polygon crossing a cell where a cut was
/// refused: counted in the table, not asserted yet.)
#[test]
fn stress_small_models_validate() {
    let models = ["four_room_distorted.obj", "four_room_optimized.obj"];
    let (bad, _) = stress(&models, &ALL_VARIANTS[..5], 2);
    assert_eq!(bad, 0, "{bad} runs with invalid cells");
    let (bad, invalid) = stress(&models, &ALL_VARIANTS[5..8], 2);
    assert_eq!((bad, invalid), (0, 0), "rigid motions must validate");
}

/// The full table (run with `--ignored --nocapture`).
#[test]
#[ignore]
fn stress_table() {
    let (bad, invalid) = stress(
        &[
            "four_room_optimized.obj",
            "four_room_distorted.obj",
            "four_room_tessellated.obj",
            "noisy.obj",
            "caverns.obj",
        ],
        &ALL_VARIANTS,
        4,
    );
    eprintln!("total: {bad} with invalid cells, {invalid} failing validation");
}

/// Face order, face starts and vertex order: polygons are placed in a geometric order from
/// a geometric start vertex, so shuffled faces (with rotated starts) and renumbered
/// vertices give the identical complex: the same active cells and portal pairs.
#[test]
fn shuffled_faces_validate() {
    for name in ["four_room_distorted.obj", "noisy.obj", "four_room_tessellated.obj"] {
        let m = thesis(name);
        let Outcome::Valid(base, portals) = run_variant(&m, Variant::Noise(0.0), 0) else {
            panic!("{name} does not validate")
        };
        for (v, seed) in [
            (Variant::Shuffle, 0),
            (Variant::Shuffle, 1),
            (Variant::Shuffle, 2),
            (Variant::ShuffleVertices, 0),
            (Variant::ShuffleVertices, 1),
        ] {
            match run_variant(&m, v, seed) {
                Outcome::Valid(s, p) => {
                    eprintln!("{name}: {base} active cells, {portals} portal pairs; {v} (seed {seed}): {s}, {p}");
                    assert_eq!((s, p), (base, portals), "{name} {v} seed {seed}");
                }
                Outcome::Refused => panic!("refused"),
                Outcome::BadCells(e) | Outcome::Invalid(e) => panic!("{name} {v} {seed}: {e}"),
            }
        }
    }
}
