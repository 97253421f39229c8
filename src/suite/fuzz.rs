//! A stable, deterministic, time-bounded fuzzer (issue 16, "Fuzzing"): `cargo-fuzz` needs a
//! nightly toolchain, so this is a plain mutation fuzzer over a small corpus kept in the
//! repository (`tests/fuzz-corpus/<target>/`), run by `portalfind bench fuzz`.
//!
//! Targets ([`Target`]):
//! - `obj`, `mesh`: the readers on mutated bytes (lossy UTF-8, as [`crate::model::load_model`]
//!   reads files). A reader must never panic, and what it accepts must satisfy the model's
//!   invariants (polygons of ≥ 3 distinct existing vertices, finite coordinates). The OBJ
//!   target also checks the parallel reader against its sequential paths on every case
//!   (`model::obj_reader_paths_agree`: the text parsed in pieces of 1–61 bytes, and the
//!   weld in short runs, against the whole parse and the sequential weld).
//! - `pipeline`: small OBJ soups (≤ [`Limits::max_vertices`] vertices, ≤
//!   [`Limits::max_polygons`] polygons; larger inputs are skipped) from the corpus or
//!   generated (random boxes, random triangles), perturbed geometrically (a few ulps, noise
//!   near the weld distance, flipped, duplicated, split, shifted faces). A loaded model must
//!   give, with the Delaunay and the BSP subdivisions, either a typed error or a complex
//!   that passes [`CellComplex::validate`](crate::complex::CellComplex::validate), and the
//!   decimation must not panic.
//!
//! Every case is a pure function of `(seed, case number)` ([`case_input`]), and the check
//! ([`check`]) a pure function of the bytes, so a run reproduces. Failures are grouped in
//! **buckets** (the panic or error message with its numbers replaced by `N`); known
//! failure classes ([`KNOWN`]) are counted separately. The first find of each bucket is
//! shrunk ([`shrink`]: delta debugging over lines, then bytes) and returned for writing
//! out as a regression file (`tests/data/fuzz/<target>/`, checked by
//! `tests/fuzz_regressions.rs`).
//!
//! Panics are caught with [`std::panic::catch_unwind`]; [`run`] silences the panic hook
//! while it runs (and restores it), so a run prints nothing but its report.

use crate::base::rng::SplitMix64;
use crate::model::{self, Model};
use crate::pipeline::{self, CellSettings, Subdivision};
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::Instant;

/// What is fuzzed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Target {
    /// The OBJ reader and cleaning.
    Obj,
    /// The `.mesh` reader and cleaning.
    Mesh,
    /// Load (OBJ), cell complex (Delaunay and BSP), validation, decimation.
    Pipeline,
}

impl Target {
    /// Every target.
    pub const ALL: [Target; 3] = [Target::Obj, Target::Mesh, Target::Pipeline];
    /// The name (`obj`, `mesh`, `pipeline`), also the corpus and finds directory name.
    pub fn name(self) -> &'static str {
        match self {
            Target::Obj => "obj",
            Target::Mesh => "mesh",
            Target::Pipeline => "pipeline",
        }
    }
    /// The file extension of its inputs.
    pub fn ext(self) -> &'static str {
        match self {
            Target::Mesh => "mesh",
            _ => "obj",
        }
    }
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Target {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Target::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| format!("unknown fuzz target {s:?}; use obj, mesh or pipeline"))
    }
}

/// Bounds that keep each case fast.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Limits {
    /// Inputs are truncated to this many bytes.
    pub max_bytes: usize,
    /// Pipeline: models with more vertices are skipped.
    pub max_vertices: usize,
    /// Pipeline: models with more polygons (after cleaning) are skipped.
    pub max_polygons: usize,
    /// A case slower than this is a find (bucket `slow`).
    pub slow_seconds: f64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_bytes: 4096,
            max_vertices: 64,
            max_polygons: 96,
            slow_seconds: 5.0,
        }
    }
}

/// Known failure classes, tracked elsewhere: (substring of the bucket, short name). Their
/// finds are counted under `known: NAME` and do not count as new.
pub const KNOWN: &[(&str, &str)] = &[("crosses the interior of cell", "polygon crosses cell")];

/// The result of one case.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Accepted and every check passed.
    Pass,
    /// Refused with a typed error (a pass).
    Refused,
    /// Outside the [`Limits`] (pipeline only): not run.
    Skipped,
    /// A check failed.
    Fail {
        /// The normalised message (numbers replaced by `N`).
        bucket: String,
        /// The full message.
        detail: String,
    },
}

impl Outcome {
    /// The bucket of a failure.
    pub fn bucket(&self) -> Option<&str> {
        match self {
            Outcome::Fail { bucket, .. } => Some(bucket),
            _ => None,
        }
    }
}

/// The message with every run of digits (and the decimal point, exponent and sign of a
/// number) replaced by `N`, cut at 100 characters: a failure's bucket.
pub fn normalize(msg: &str) -> String {
    let mut out = String::new();
    let cs: Vec<char> = msg.chars().collect();
    let mut i = 0;
    while i < cs.len() {
        if cs[i].is_ascii_digit() {
            while i < cs.len()
                && (cs[i].is_ascii_digit()
                    || cs[i] == '.'
                    || ((cs[i] == 'e' || cs[i] == 'E')
                        && i + 1 < cs.len()
                        && (cs[i + 1].is_ascii_digit() || cs[i + 1] == '-'))
                    || (cs[i] == '-' && i > 0 && (cs[i - 1] == 'e' || cs[i - 1] == 'E')))
            {
                i += 1;
            }
            if out.ends_with('-') {
                out.pop();
            }
            out.push('N');
        } else {
            out.push(cs[i]);
            i += 1;
        }
    }
    out.chars().take(100).collect()
}

/// The known class of a bucket, if any.
pub fn known_class(bucket: &str) -> Option<&'static str> {
    KNOWN.iter().find(|(s, _)| bucket.contains(s)).map(|(_, n)| *n)
}

fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "(non-string panic)".to_string()
    }
}

fn fail(prefix: &str, msg: &str) -> Outcome {
    Outcome::Fail {
        bucket: format!("{prefix}: {}", normalize(msg)),
        detail: format!("{prefix}: {msg}"),
    }
}

/// The model invariants a reader promises for what it accepts.
fn check_model(m: &Model) -> Result<(), String> {
    if let Some(v) = m.vertices.iter().position(|p| p.iter().any(|x| !x.is_finite())) {
        return Err(format!("accepted a non-finite vertex {v}"));
    }
    for (i, p) in m.polygons.iter().enumerate() {
        if p.verts.len() < 3 {
            return Err(format!("accepted polygon {i} with {} vertices", p.verts.len()));
        }
        if p.verts.iter().any(|v| v.idx() >= m.vertices.len()) {
            return Err(format!("accepted polygon {i} naming a missing vertex"));
        }
        let mut vs: Vec<u32> = p.verts.iter().map(|v| v.0).collect();
        vs.sort_unstable();
        vs.dedup();
        if vs.len() != p.verts.len() {
            return Err(format!("accepted polygon {i} repeating a vertex"));
        }
    }
    Ok(())
}

/// Runs one case (a pure function of `bytes`, whose panics are caught).
pub fn check(target: Target, bytes: &[u8], limits: &Limits) -> Outcome {
    let t0 = Instant::now();
    let r = catch_unwind(AssertUnwindSafe(|| check_inner(target, bytes, limits)));
    let out = match r {
        Ok(o) => o,
        Err(p) => fail("panic", &panic_message(p.as_ref())),
    };
    let s = t0.elapsed().as_secs_f64();
    if matches!(out, Outcome::Pass | Outcome::Refused | Outcome::Skipped) && s > limits.slow_seconds {
        return Outcome::Fail {
            bucket: "slow".into(),
            detail: format!("slow: {s:.1} s"),
        };
    }
    out
}

fn check_inner(target: Target, bytes: &[u8], limits: &Limits) -> Outcome {
    let text = String::from_utf8_lossy(bytes);
    if target == Target::Obj {
        // The parallel reader's paths (pieces, weld runs) against its sequential ones; the
        // piece size and run length are a function of the bytes, so a find reproduces.
        let seed = bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
            (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
        });
        if let Err(e) = model::obj_reader_paths_agree(&text, seed) {
            return fail("reader paths", &e);
        }
    }
    let loaded = match target {
        Target::Mesh => model::parse_mesh_str("fuzz.mesh", &text),
        _ => model::parse_obj_str("fuzz.obj", &text),
    };
    let m = match loaded {
        Ok(m) => m,
        Err(e) => {
            // A typed error must still print (Display must not panic).
            let _ = e.to_string();
            return Outcome::Refused;
        }
    };
    if let Err(e) = check_model(&m) {
        return fail("reader", &e);
    }
    if target != Target::Pipeline {
        return Outcome::Pass;
    }
    if m.vertices.len() > limits.max_vertices || m.polygons.len() > limits.max_polygons {
        return Outcome::Skipped;
    }
    for sub in Subdivision::ALL {
        let label = PathBuf::from("fuzz.obj");
        // `run`'s build: the fallback ladder of `build_cells`. A case fails when no level
        // passes the checks (bucketed by level 0's violation, as before the ladder), or
        // when the full validation rejects the complex the checks passed.
        let attempts = match pipeline::build_cells_attempts(&m, &label, &CellSettings::of(sub), &mut |_| {}) {
            Ok(a) => a,
            Err(e) => {
                let _ = e.to_string();
                return Outcome::Refused;
            }
        };
        let cells = attempts.cells;
        if !attempts.valid {
            let e = &cells.rejected[0].error;
            let kind = match e {
                crate::complex::ComplexError::Crossing { .. } => "validate",
                _ => "cells",
            };
            return fail(&format!("{sub} {kind}"), &e.to_string());
        }
        // The ladder's checks passed (`check_valid` among them); the full validation is
        // the fuzzer's own (a fallback level already passed it, level 0 did not run it).
        if let Err(e) = cells.cx.validate(&m) {
            return fail(&format!("{sub} validate"), &e.to_string());
        }
        let dec = crate::decimate::Decimation::run(&cells.cx, &Default::default());
        if dec.stats.steps > dec.stats.initial_cells {
            return fail(&format!("{sub} decimate"), "cell counts disagree");
        }
    }
    Outcome::Pass
}

// ---- Inputs ----

/// The corpus of a target: every file of `dir/<target>/`, sorted by name.
pub fn load_corpus(dir: &Path, target: Target) -> std::io::Result<Vec<(String, Vec<u8>)>> {
    let d = dir.join(target.name());
    let mut out = Vec::new();
    for e in std::fs::read_dir(&d)? {
        let p = e?.path();
        if p.is_file() {
            let name = p
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            out.push((name, std::fs::read(&p)?));
        }
    }
    out.sort();
    Ok(out)
}

const TOKENS: &[&str] = &[
    "v ",
    "f ",
    "vt ",
    "vn ",
    "o ",
    "g ",
    "s off",
    "usemtl x",
    "mtllib a.mtl",
    "#",
    "\n",
    " ",
    "/",
    "//",
    "-",
    "\\\n",
    "\r\n",
    "\t",
    "\u{feff}",
    "é",
    "0",
    "-1",
    "3",
    "4 ",
];
const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "2",
    "3",
    "1e308",
    "-1e308",
    "1e309",
    "1e-310",
    "5e-324",
    "nan",
    "inf",
    "-inf",
    "NaN",
    "4294967295",
    "4294967296",
    "-4294967296",
    "18446744073709551616",
    "999999999999",
    "1.0000000000000002",
    "0.1",
    "1e9",
    "1e-9",
    "0x10",
    "1_000",
    "+1",
    ".5",
    "5.",
    "1e",
    "--1",
];

fn fmt_f(x: f64) -> String {
    format!("{x:?}")
}

/// Byte ranges of the number tokens of `s`.
fn number_spans(s: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < s.len() {
        let c = s[i];
        if c.is_ascii_digit() || ((c == b'-' || c == b'.') && i + 1 < s.len() && s[i + 1].is_ascii_digit()) {
            let st = i;
            i += 1;
            while i < s.len() && (s[i].is_ascii_digit() || matches!(s[i], b'.' | b'e' | b'E' | b'-' | b'+')) {
                i += 1;
            }
            out.push((st, i));
        } else {
            i += 1;
        }
    }
    out
}

fn lines_of(s: &[u8]) -> Vec<Vec<u8>> {
    s.split(|&b| b == b'\n').map(|l| l.to_vec()).collect()
}

fn join_lines(ls: &[Vec<u8>]) -> Vec<u8> {
    ls.join(&b'\n')
}

/// Perturbs a number: a few ulps, a relative nudge near the weld distance, or noise.
fn perturb_number(x: f64, rng: &mut SplitMix64) -> f64 {
    match rng.below(4) {
        0 => {
            let mut y = x;
            for _ in 0..1 + rng.below(4) {
                y = if rng.below(2) == 0 { y.next_up() } else { y.next_down() };
            }
            y
        }
        1 => x + rng.signed_unit() * 10f64.powi(-(5 + rng.below(5) as i32)),
        2 => x * (1.0 + rng.signed_unit() * 1e-9),
        _ => x + rng.signed_unit() * 0.05,
    }
}

/// One text mutation of `s` (`other`: another corpus input for splicing).
fn mutate_bytes(s: &mut Vec<u8>, other: &[u8], rng: &mut SplitMix64) {
    let n = s.len();
    match rng.below(12) {
        0 if n > 0 => {
            let i = rng.below(n);
            s[i] ^= 1 << rng.below(8);
        }
        1 if n > 0 => {
            let i = rng.below(n);
            s[i] = b"0123456789-.e /\n#\t\r\xff"[rng.below(20)];
        }
        2 => {
            let t = TOKENS[rng.below(TOKENS.len())].as_bytes();
            let i = rng.below(n + 1);
            s.splice(i..i, t.iter().copied());
        }
        3 if n > 0 => {
            let i = rng.below(n);
            let j = (i + 1 + rng.below(16)).min(n);
            s.drain(i..j);
        }
        4..=6 => {
            let mut ls = lines_of(s);
            let k = ls.len();
            if k > 0 {
                let i = rng.below(k);
                match rng.below(3) {
                    0 => {
                        let l = ls[i].clone();
                        ls.insert(rng.below(k + 1), l);
                    }
                    1 => {
                        ls.remove(i);
                    }
                    _ => ls.swap(i, rng.below(k)),
                }
                *s = join_lines(&ls);
            }
        }
        7 => {
            let ol = lines_of(other);
            if !ol.is_empty() {
                let mut ls = lines_of(s);
                let l = ol[rng.below(ol.len())].clone();
                ls.insert(rng.below(ls.len() + 1), l);
                *s = join_lines(&ls);
            }
        }
        8 | 9 => {
            let sp = number_spans(s);
            if !sp.is_empty() {
                let (a, b) = sp[rng.below(sp.len())];
                let new = if rng.below(2) == 0 {
                    NUMBERS[rng.below(NUMBERS.len())].to_string()
                } else {
                    let x: f64 = std::str::from_utf8(&s[a..b])
                        .ok()
                        .and_then(|t| t.parse().ok())
                        .unwrap_or(0.0);
                    fmt_f(perturb_number(x, rng))
                };
                s.splice(a..b, new.bytes());
            }
        }
        _ => mutate_geometry(s, rng),
    }
}

/// A parsed OBJ-like soup: `v` and `f` lines only (1-based face indices, no slashes).
fn parse_soup(s: &[u8]) -> (Vec<[f64; 3]>, Vec<Vec<i64>>) {
    let (mut vs, mut fs) = (Vec::new(), Vec::new());
    for l in String::from_utf8_lossy(s).lines() {
        let t: Vec<&str> = l.split_whitespace().collect();
        match t.first() {
            Some(&"v") if t.len() >= 4 => {
                let p: Vec<f64> = t[1..4].iter().map(|x| x.parse().unwrap_or(0.0)).collect();
                vs.push([p[0], p[1], p[2]]);
            }
            Some(&"f") => fs.push(
                t[1..]
                    .iter()
                    .map(|x| x.split('/').next().unwrap_or("").parse().unwrap_or(1))
                    .collect(),
            ),
            _ => {}
        }
    }
    (vs, fs)
}

fn soup_text(vs: &[[f64; 3]], fs: &[Vec<i64>]) -> Vec<u8> {
    let mut s = String::new();
    for v in vs {
        s += &format!("v {} {} {}\n", fmt_f(v[0]), fmt_f(v[1]), fmt_f(v[2]));
    }
    for f in fs {
        s += "f";
        for i in f {
            s += &format!(" {i}");
        }
        s += "\n";
    }
    s.into_bytes()
}

/// One geometric mutation of an OBJ soup (rewritten as `v`/`f` lines only).
fn mutate_geometry(s: &mut Vec<u8>, rng: &mut SplitMix64) {
    let (mut vs, mut fs) = parse_soup(s);
    if vs.is_empty() {
        return;
    }
    let (lo, hi) = vs
        .iter()
        .fold(([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]), |(mut lo, mut hi), p| {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
            (lo, hi)
        });
    let diag = ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2))
        .sqrt()
        .max(1e-300);
    let nv = vs.len();
    match rng.below(11) {
        0 => {
            // A few ulps on one coordinate.
            let i = rng.below(nv);
            let k = rng.below(3);
            for _ in 0..1 + rng.below(3) {
                vs[i][k] = if rng.below(2) == 0 {
                    vs[i][k].next_up()
                } else {
                    vs[i][k].next_down()
                };
            }
        }
        1 => {
            // Noise near the weld distance (1e-9..1e-5 of the diagonal), one vertex or all.
            let e = diag * 10f64.powi(-(5 + rng.below(5) as i32));
            let all = rng.below(3) == 0;
            let i = rng.below(nv);
            for (j, p) in vs.iter_mut().enumerate() {
                if all || j == i {
                    for x in p.iter_mut() {
                        *x += e * rng.signed_unit();
                    }
                }
            }
        }
        2 if !fs.is_empty() => {
            let i = rng.below(fs.len());
            fs[i].reverse();
        }
        3 if !fs.is_empty() => {
            let i = rng.below(fs.len());
            let f = fs[i].clone();
            fs.insert(rng.below(fs.len() + 1), f);
        }
        4 if !fs.is_empty() => {
            // Split a face at its centroid.
            let i = rng.below(fs.len());
            let f = fs.remove(i);
            let ids: Vec<usize> = f
                .iter()
                .filter(|&&x| x >= 1 && (x as usize) <= nv)
                .map(|&x| x as usize - 1)
                .collect();
            if ids.len() >= 3 {
                let c = crate::base::vec::weighted_mean(ids.iter().map(|&j| (1.0, vs[j])));
                vs.push(c);
                let ci = vs.len() as i64;
                for k in 0..ids.len() {
                    fs.push(vec![ids[k] as i64 + 1, ids[(k + 1) % ids.len()] as i64 + 1, ci]);
                }
            }
        }
        5 if !fs.is_empty() => {
            // A copy of a face a hair away (nearly coplanar), or a vertex moved onto another.
            let i = rng.below(fs.len());
            let f = fs[i].clone();
            let d = diag * 10f64.powi(-(3 + rng.below(6) as i32));
            let off = [rng.signed_unit() * d, rng.signed_unit() * d, rng.signed_unit() * d];
            let base = vs.len() as i64;
            let mut nf = Vec::new();
            for (k, &x) in f.iter().enumerate() {
                let p = vs.get((x - 1).max(0) as usize).copied().unwrap_or([0.0; 3]);
                vs.push([p[0] + off[0], p[1] + off[1], p[2] + off[2]]);
                nf.push(base + k as i64 + 1);
            }
            fs.push(nf);
        }
        6 => {
            let (a, b) = (rng.below(nv), rng.below(nv));
            let e = diag * 10f64.powi(-(6 + rng.below(8) as i32));
            vs[a] = [vs[b][0] + e * rng.signed_unit(), vs[b][1], vs[b][2]];
        }
        7 => {
            // A random face over existing vertices.
            let k = 3 + rng.below(5);
            fs.push((0..k).map(|_| 1 + rng.below(nv) as i64).collect());
        }
        8 if !fs.is_empty() => {
            let i = rng.below(fs.len());
            fs.remove(i);
        }
        9 if !fs.is_empty() => {
            let i = rng.below(fs.len());
            let r = rng.below(fs[i].len().max(1));
            fs[i].rotate_left(r);
        }
        _ => {
            // A rigid motion or scaling of everything: a small rotation about z, an
            // offset, or a scale.
            match rng.below(3) {
                0 => {
                    let a = rng.signed_unit() * 0.3;
                    let (sn, cs) = a.sin_cos();
                    for p in &mut vs {
                        *p = [cs * p[0] - sn * p[1], sn * p[0] + cs * p[1], p[2]];
                    }
                }
                1 => {
                    let o = 10f64.powi(rng.below(10) as i32) * rng.signed_unit();
                    for p in &mut vs {
                        p[0] += o;
                        p[1] -= 0.7 * o;
                    }
                }
                _ => {
                    let sc = 10f64.powi(rng.below(11) as i32 - 4);
                    for p in &mut vs {
                        *p = p.map(|x| x * sc);
                    }
                }
            }
        }
    }
    *s = soup_text(&vs, &fs);
}

/// A fresh small random soup: an (optionally rotated) box room with inward faces, perhaps
/// with a box pillar or a second room, or random triangles in the unit cube.
fn random_soup(rng: &mut SplitMix64) -> Vec<u8> {
    if rng.below(3) == 0 {
        let nv = 4 + rng.below(16);
        let vs: Vec<[f64; 3]> = (0..nv).map(|_| [rng.unit(), rng.unit(), rng.unit()]).collect();
        let fs: Vec<Vec<i64>> = (0..1 + rng.below(12))
            .map(|_| (0..3).map(|_| 1 + rng.below(nv) as i64).collect())
            .collect();
        return soup_text(&vs, &fs);
    }
    let mut soup = crate::generate::scenes::Soup::default();
    let s = [1.0 + 4.0 * rng.unit(), 1.0 + 4.0 * rng.unit(), 1.0 + 3.0 * rng.unit()];
    soup.boxed([0.0; 3], s, true);
    if rng.below(2) == 0 {
        let c = [s[0] * rng.unit(), s[1] * rng.unit(), 0.0];
        let w = 0.1 + 0.4 * rng.unit();
        soup.boxed(c, [c[0] + w, c[1] + w, s[2] * rng.unit()], false);
    }
    let a = rng.signed_unit() * std::f64::consts::PI;
    let (sn, cs) = a.sin_cos();
    let soup = soup.map(|p| [cs * p[0] - sn * p[1], sn * p[0] + cs * p[1], p[2]]);
    let fs: Vec<Vec<i64>> = soup
        .polygons
        .iter()
        .map(|p| p.iter().map(|&i| i as i64 + 1).collect())
        .collect();
    soup_text(&soup.vertices, &fs)
}

/// The input of case `i` of a run with `seed`: a corpus entry (or, for the pipeline, one
/// time in four a fresh random soup) with 1–8 mutations (pipeline: 1–4, mostly geometric).
pub fn case_input(target: Target, corpus: &[(String, Vec<u8>)], seed: u64, i: u64, limits: &Limits) -> Vec<u8> {
    let mut rng = SplitMix64(seed ^ i.wrapping_mul(0xA24B_AED4_963E_E407));
    rng.next_u64();
    let pick = |rng: &mut SplitMix64| -> Vec<u8> {
        if corpus.is_empty() {
            Vec::new()
        } else {
            corpus[rng.below(corpus.len())].1.clone()
        }
    };
    let mut s = if target == Target::Pipeline && (corpus.is_empty() || rng.below(4) == 0) {
        random_soup(&mut rng)
    } else {
        pick(&mut rng)
    };
    let other = pick(&mut rng);
    let n = if target == Target::Pipeline {
        1 + rng.below(4)
    } else {
        1 + rng.below(8)
    };
    for _ in 0..n {
        if target == Target::Pipeline && rng.below(4) != 0 {
            mutate_geometry(&mut s, &mut rng);
        } else {
            mutate_bytes(&mut s, &other, &mut rng);
        }
    }
    s.truncate(limits.max_bytes);
    s
}

// ---- Shrinking ----

/// Delta debugging: removes chunks of lines (halving the chunk size), then chunks of bytes
/// (for inputs of at most 2 KB), keeping the failure in `bucket`. At most `budget` checks.
pub fn shrink(target: Target, input: &[u8], bucket: &str, limits: &Limits, budget: usize) -> Vec<u8> {
    let mut checks = 0;
    let still = |c: &[u8], checks: &mut usize| -> bool {
        *checks += 1;
        check(target, c, limits).bucket() == Some(bucket)
    };
    let mut best = input.to_vec();
    // Lines.
    let mut ls = lines_of(&best);
    let mut chunk = ls.len().div_ceil(2).max(1);
    loop {
        let mut i = 0;
        while i < ls.len() && checks < budget {
            let mut cand = ls.clone();
            cand.drain(i..(i + chunk).min(ls.len()));
            if still(&join_lines(&cand), &mut checks) {
                ls = cand;
            } else {
                i += chunk;
            }
        }
        if chunk == 1 || checks >= budget {
            break;
        }
        chunk = chunk.div_ceil(2);
    }
    best = join_lines(&ls);
    // Bytes.
    if best.len() <= 2048 {
        let mut chunk = 8;
        while chunk >= 1 && checks < budget {
            let mut i = 0;
            while i < best.len() && checks < budget {
                let mut cand = best.clone();
                cand.drain(i..(i + chunk).min(best.len()));
                if still(&cand, &mut checks) {
                    best = cand;
                } else {
                    i += chunk;
                }
            }
            chunk /= 2;
        }
    }
    best
}

// ---- The runner ----

/// One bucket's count and its first find.
#[derive(Clone, Debug, Serialize)]
pub struct Bucket {
    /// The bucket (normalised message).
    pub bucket: String,
    /// The known class it belongs to, if any ([`KNOWN`]).
    pub known: Option<&'static str>,
    /// Cases that failed in it.
    pub count: usize,
    /// The first failing case's number.
    pub first_case: u64,
    /// Its full message.
    pub detail: String,
    /// The shrunk input (not serialised; written out by the caller).
    #[serde(skip)]
    pub shrunk: Vec<u8>,
}

/// A fuzz run's figures.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// The target.
    pub target: Target,
    /// The seed.
    pub seed: u64,
    /// Wall time in seconds.
    pub seconds: f64,
    /// Cases run.
    pub cases: u64,
    /// Cases per second.
    pub cases_per_second: f64,
    /// Cases that passed every check.
    pub passed: u64,
    /// Cases refused with a typed error.
    pub refused: u64,
    /// Cases outside the limits (not run).
    pub skipped: u64,
    /// Failed cases outside the known classes.
    pub new_failures: u64,
    /// Failed cases in known classes.
    pub known_failures: u64,
    /// Failures per bucket.
    pub buckets: Vec<Bucket>,
    /// The limits.
    pub limits: Limits,
    /// The corpus files used.
    pub corpus: Vec<String>,
}

/// Runs `target` for `seconds` (at least one case), starting at case 0 with `seed`.
/// `progress(cases, failures)` is called about once a second. The first find of each
/// bucket is shrunk (at most `shrink_budget` checks).
pub fn run(
    target: Target,
    corpus: &[(String, Vec<u8>)],
    seed: u64,
    seconds: f64,
    limits: &Limits,
    shrink_budget: usize,
    progress: &mut dyn FnMut(u64, u64),
) -> Report {
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let t0 = Instant::now();
    let mut buckets: BTreeMap<String, Bucket> = BTreeMap::new();
    let (mut cases, mut passed, mut refused, mut skipped, mut new_f, mut known_f) = (0u64, 0, 0, 0, 0, 0);
    let mut last = 0.0;
    while cases == 0 || t0.elapsed().as_secs_f64() < seconds {
        let input = case_input(target, corpus, seed, cases, limits);
        match check(target, &input, limits) {
            Outcome::Pass => passed += 1,
            Outcome::Refused => refused += 1,
            Outcome::Skipped => skipped += 1,
            Outcome::Fail { bucket, detail } => {
                let known = known_class(&bucket);
                if known.is_some() {
                    known_f += 1;
                } else {
                    new_f += 1;
                }
                if let Some(b) = buckets.get_mut(&bucket) {
                    b.count += 1;
                } else {
                    let shrunk = shrink(target, &input, &bucket, limits, shrink_budget);
                    buckets.insert(
                        bucket.clone(),
                        Bucket {
                            bucket,
                            known,
                            count: 1,
                            first_case: cases,
                            detail,
                            shrunk,
                        },
                    );
                }
            }
        }
        cases += 1;
        let e = t0.elapsed().as_secs_f64();
        if e - last >= 1.0 {
            last = e;
            progress(cases, new_f + known_f);
        }
    }
    std::panic::set_hook(hook);
    let secs = t0.elapsed().as_secs_f64();
    Report {
        target,
        seed,
        seconds: secs,
        cases,
        cases_per_second: cases as f64 / secs.max(1e-9),
        passed,
        refused,
        skipped,
        new_failures: new_f,
        known_failures: known_f,
        buckets: buckets.into_values().collect(),
        limits: *limits,
        corpus: corpus.iter().map(|(n, _)| n.clone()).collect(),
    }
}

/// A file name for a find: the bucket as a slug plus an FNV-1a hash of the input.
pub fn find_name(target: Target, bucket: &str, input: &[u8]) -> String {
    let mut slug: String = bucket
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect();
    while slug.contains("__") {
        slug = slug.replace("__", "_");
    }
    let slug: String = slug.trim_matches('_').chars().take(48).collect();
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in input {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{slug}-{:08x}.{}", h as u32, target.ext())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalize_replaces_numbers() {
        assert_eq!(
            normalize("cell 49 crosses 0.59 at -1e-7 and 3"),
            "cell N crosses N at N and N"
        );
    }

    #[test]
    fn cases_reproduce_and_shrink_keeps_the_bucket() {
        let tet = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";
        let corpus = vec![("a.obj".to_string(), tet.to_vec())];
        let l = Limits::default();
        for i in 0..50 {
            assert_eq!(
                case_input(Target::Pipeline, &corpus, 7, i, &l),
                case_input(Target::Pipeline, &corpus, 7, i, &l)
            );
        }
        // A closed tetrahedron passes every target's check.
        for t in Target::ALL {
            assert_eq!(
                check(t, &corpus[0].1, &l),
                if t == Target::Mesh {
                    Outcome::Refused
                } else {
                    Outcome::Pass
                }
            );
        }
        assert_eq!(check(Target::Obj, b"f 1 2 3\n", &l), Outcome::Refused);
    }
}
